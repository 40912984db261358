//! Order-independent transparency: Multi-Layer Alpha Blending (Salvi &
//! Vaidyanathan 2014, as in Capcom's RE4 strand renderer) and the exact
//! per-pixel sorted composite it approximates.

use glam::Vec3;

/// A shaded, premultiplied fragment.
#[derive(Debug, Clone, Copy)]
pub struct Fragment {
    pub depth: f32,
    /// Premultiplied radiance (color × coverage).
    pub color: Vec3,
    /// 1 − coverage.
    pub transmittance: f32,
}

/// MLAB with `k` layers kept sorted by depth; a fragment that would make
/// k + 1 merges the two farthest (color over color, transmittances multiplied).
#[derive(Debug, Clone)]
pub struct Mlab {
    layers: Vec<Fragment>,
    k: usize,
}

impl Mlab {
    pub fn new(k: usize) -> Self {
        Self {
            layers: Vec::with_capacity(k + 1),
            k: k.max(1),
        }
    }

    pub fn insert(&mut self, f: Fragment) {
        let pos = self.layers.partition_point(|l| l.depth <= f.depth);
        self.layers.insert(pos, f);
        if self.layers.len() > self.k {
            let b = self.layers.pop().expect("k + 1 layers");
            let a = self.layers.last_mut().expect("k >= 1 layers");
            a.color += b.color * a.transmittance;
            a.transmittance *= b.transmittance;
        }
    }

    /// Front-to-back composite over `background`.
    pub fn resolve(&self, background: Vec3) -> Vec3 {
        composite(self.layers.iter(), background)
    }
}

fn composite<'a>(frags: impl Iterator<Item = &'a Fragment>, background: Vec3) -> Vec3 {
    let mut c = Vec3::ZERO;
    let mut t = 1.0;
    for f in frags {
        c += f.color * t;
        t *= f.transmittance;
    }
    c + background * t
}

/// Exact composite: all fragments sorted by depth (ties keep insertion order).
pub fn resolve_sorted(frags: &mut [Fragment], background: Vec3) -> Vec3 {
    frags.sort_by(|a, b| a.depth.total_cmp(&b.depth));
    composite(frags.iter(), background)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frag(d: f32, c: f32, a: f32) -> Fragment {
        Fragment {
            depth: d,
            color: Vec3::splat(c * a),
            transmittance: 1.0 - a,
        }
    }

    #[test]
    fn t01_mlab_exact_when_layers_suffice() {
        let fs = [
            frag(3.0, 0.2, 0.5),
            frag(1.0, 0.9, 0.3),
            frag(2.0, 0.5, 0.7),
        ];
        let mut m = Mlab::new(4);
        for f in fs {
            m.insert(f);
        }
        let mut v = fs.to_vec();
        let exact = resolve_sorted(&mut v, Vec3::splat(0.1));
        assert!((m.resolve(Vec3::splat(0.1)) - exact).abs().max_element() < 1e-7);
    }

    #[test]
    fn t02_mlab_merge_keeps_total_transmittance() {
        let mut m = Mlab::new(2);
        let fs: Vec<Fragment> = (0..10).map(|i| frag(10.0 - i as f32, 0.3, 0.2)).collect();
        for f in &fs {
            m.insert(*f);
        }
        // With a black background and equal colors, the opacity is order independent.
        let mut v = fs.clone();
        let exact = resolve_sorted(&mut v, Vec3::ONE);
        let approx = m.resolve(Vec3::ONE);
        let t_exact: f32 = fs.iter().map(|f| f.transmittance).product();
        assert!((m.layers.iter().map(|f| f.transmittance).product::<f32>() - t_exact).abs() < 1e-6);
        assert!((approx - exact).abs().max_element() < 0.05);
    }
}
