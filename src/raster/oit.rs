//! Order-independent transparency: Multi-Layer Alpha Blending (Salvi &
//! Vaidyanathan 2014, as in Capcom's RE4 strand renderer), in f32 layers
//! or packed into 64 bits ([`super::pack`]), and the exact per-pixel sorted
//! composite it approximates.

use super::pack::{
    from_r11g11b10, from_rgb9e5, from_unorm16, r11g11b10, rgb9e5, unorm16, LayerFormat,
};
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

/// No layer: nothing seen, everything behind passes.
const EMPTY: Fragment = Fragment {
    depth: 0.0,
    color: Vec3::ZERO,
    transmittance: 1.0,
};

/// MLAB with `k` layers per pixel kept sorted by depth, for all pixels of
/// a tile in one allocation (pixel `px` owns slots `px·(k+1) ..`); a
/// fragment that would make k + 1 merges the two farthest (color over
/// color, transmittances multiplied).
#[derive(Debug, Clone)]
pub struct Mlab {
    k: usize,
    layers: Vec<Fragment>,
    len: Vec<u8>,
}

impl Mlab {
    /// Empty layers for `pixels` pixels; `k` in 1..=64.
    pub fn new(pixels: usize, k: usize) -> Self {
        let k = k.clamp(1, 64);
        Self {
            k,
            layers: vec![EMPTY; pixels * (k + 1)],
            len: vec![0; pixels],
        }
    }

    /// The layers of pixel `px`, nearest first.
    pub fn layers(&self, px: usize) -> &[Fragment] {
        let base = px * (self.k + 1);
        &self.layers[base..base + self.len[px] as usize]
    }

    #[inline]
    pub fn insert(&mut self, px: usize, f: Fragment) {
        let base = px * (self.k + 1);
        let n = self.len[px] as usize;
        let slots = &mut self.layers[base..base + n + 1];
        // After the layers at the same or a smaller depth (insertion order
        // on ties): an insertion-sort step, k is small.
        let mut pos = n;
        while pos > 0 && slots[pos - 1].depth > f.depth {
            slots[pos] = slots[pos - 1];
            pos -= 1;
        }
        slots[pos] = f;
        if n + 1 > self.k {
            let b = slots[n];
            let a = &mut slots[n - 1];
            a.color += b.color * a.transmittance;
            a.transmittance *= b.transmittance;
        } else {
            self.len[px] = (n + 1) as u8;
        }
    }

    /// Front-to-back composite of pixel `px` over `background`.
    pub fn resolve(&self, px: usize, background: Vec3) -> Vec3 {
        let (c, t) = composite(self.layers(px).iter());
        c + background * t
    }
}

/// Front-to-back composite: the radiance and the transmittance left for
/// what lies behind.
fn composite<'a>(frags: impl Iterator<Item = &'a Fragment>) -> (Vec3, f32) {
    let mut c = Vec3::ZERO;
    let mut t = 1.0;
    for f in frags {
        c += f.color * t;
        t *= f.transmittance;
    }
    (c, t)
}

/// MLAB with `k` layers per pixel stored in 64 bits each: a pixel's layers
/// are unpacked, the fragment inserted and merged as by [`Mlab`], and the
/// layers packed again (the round trip a GPU makes through its packed
/// buffer). Depths are stored relative to the tile's hair depth range
/// ([`Self::set_depth_range`]); fragments outside it are clamped to its
/// ends.
#[derive(Debug, Clone)]
pub struct PackedMlab {
    k: usize,
    format: LayerFormat,
    layers: Vec<u64>,
    len: Vec<u8>,
    z0: f32,
    z_span: f32,
}

impl PackedMlab {
    pub fn new(pixels: usize, k: usize, format: LayerFormat) -> Self {
        let k = k.clamp(1, 64);
        Self {
            k,
            format,
            layers: vec![0; pixels * k],
            len: vec![0; pixels],
            z0: 0.0,
            z_span: 1.0,
        }
    }

    /// The depths the tile's fragments lie between.
    pub fn set_depth_range(&mut self, near: f32, far: f32) {
        self.z0 = near;
        self.z_span = (far - near).max(f32::MIN_POSITIVE);
    }

    fn pack(&self, f: &Fragment) -> u64 {
        let z = unorm16((f.depth - self.z0) / self.z_span) as u64;
        let t = unorm16(f.transmittance) as u64;
        let c = match self.format {
            LayerFormat::Rgb9e5 => rgb9e5(f.color),
            _ => r11g11b10(f.color),
        } as u64;
        z << 48 | t << 32 | c
    }

    fn unpack(&self, b: u64) -> Fragment {
        let c = b as u32;
        Fragment {
            depth: self.z0 + from_unorm16((b >> 48) as u16) * self.z_span,
            transmittance: from_unorm16((b >> 32) as u16),
            color: match self.format {
                LayerFormat::Rgb9e5 => from_rgb9e5(c),
                _ => from_r11g11b10(c),
            },
        }
    }

    /// The layers of pixel `px`, nearest first, unpacked into `out`.
    fn layers(&self, px: usize, out: &mut [Fragment; 65]) -> usize {
        let n = self.len[px] as usize;
        let base = px * self.k;
        for (o, b) in out.iter_mut().zip(&self.layers[base..base + n]) {
            *o = self.unpack(*b);
        }
        n
    }

    #[inline]
    pub fn insert(&mut self, px: usize, f: Fragment) {
        let mut slots = [EMPTY; 65];
        let n = self.layers(px, &mut slots);
        // the fragment as stored: its depth quantized like the layers'
        let f = self.unpack(self.pack(&f));
        let mut pos = n;
        while pos > 0 && slots[pos - 1].depth > f.depth {
            slots[pos] = slots[pos - 1];
            pos -= 1;
        }
        slots[pos] = f;
        let kept = if n + 1 > self.k {
            let b = slots[n];
            let a = &mut slots[n - 1];
            a.color += b.color * a.transmittance;
            a.transmittance *= b.transmittance;
            n
        } else {
            n + 1
        };
        let base = px * self.k;
        for (i, s) in slots[..kept].iter().enumerate() {
            self.layers[base + i] = self.pack(s);
        }
        self.len[px] = kept as u8;
    }

    fn composite(&self, px: usize) -> (Vec3, f32) {
        let mut slots = [EMPTY; 65];
        let n = self.layers(px, &mut slots);
        composite(slots[..n].iter())
    }
}

/// A tile's per-pixel composite in the chosen transparency mode.
pub enum Layers {
    /// MLAB with a fixed number of f32 layers per pixel.
    Mlab(Mlab),
    /// MLAB with layers packed into 64 bits.
    Packed(PackedMlab),
    /// Every fragment kept, sorted at resolve time.
    Sorted(Vec<Vec<Fragment>>),
}

impl Layers {
    /// Empty layers for `pixels` pixels: MLAB with `k` layers in `format`,
    /// or sorted lists when `k` is `None`.
    pub fn new(pixels: usize, k: Option<usize>, format: LayerFormat) -> Self {
        match (k, format) {
            (Some(k), LayerFormat::F32) => Layers::Mlab(Mlab::new(pixels, k)),
            (Some(k), f) => Layers::Packed(PackedMlab::new(pixels, k, f)),
            (None, _) => Layers::Sorted(vec![Vec::new(); pixels]),
        }
    }

    /// Empties the layers for reuse by a tile of `pixels` pixels in mode
    /// `k` and `format` (as [`Self::new`]); false when they were made for
    /// another mode or size, and are to be made anew.
    pub fn reset(&mut self, pixels: usize, k: Option<usize>, format: LayerFormat) -> bool {
        match (self, k) {
            (Layers::Mlab(m), Some(k))
                if format == LayerFormat::F32 && m.k == k.clamp(1, 64) && m.len.len() == pixels =>
            {
                // Only the first len[px] slots of a pixel are ever read.
                m.len.fill(0);
                true
            }
            (Layers::Packed(m), Some(k))
                if m.format == format && m.k == k.clamp(1, 64) && m.len.len() == pixels =>
            {
                m.len.fill(0);
                true
            }
            (Layers::Sorted(lists), None) if lists.len() == pixels => {
                lists.iter_mut().for_each(Vec::clear);
                true
            }
            _ => false,
        }
    }

    /// Adds to pixel `px` a fragment of radiance `color` with coverage
    /// `alpha` at `depth`.
    #[inline]
    pub fn add(&mut self, px: usize, depth: f32, color: Vec3, alpha: f32) {
        let f = Fragment {
            depth,
            color: color * alpha,
            transmittance: 1.0 - alpha,
        };
        match self {
            Layers::Mlab(m) => m.insert(px, f),
            Layers::Packed(m) => m.insert(px, f),
            Layers::Sorted(lists) => lists[px].push(f),
        }
    }

    /// The depths the tile's fragments lie between (packed layers store
    /// depth relative to them; the other modes ignore it).
    pub fn set_depth_range(&mut self, near: f32, far: f32) {
        if let Layers::Packed(m) = self {
            m.set_depth_range(near, far);
        }
    }

    /// Pixel `px` composited: its radiance and the transmittance left for
    /// what lies behind its hair.
    pub fn composite(&mut self, px: usize) -> (Vec3, f32) {
        match self {
            Layers::Mlab(m) => composite(m.layers(px).iter()),
            Layers::Packed(m) => m.composite(px),
            Layers::Sorted(lists) => {
                let frags = &mut lists[px];
                frags.sort_by(|a, b| a.depth.total_cmp(&b.depth));
                composite(frags.iter())
            }
        }
    }
}

/// Exact composite: all fragments sorted by depth (ties keep insertion order).
pub fn resolve_sorted(frags: &mut [Fragment], background: Vec3) -> Vec3 {
    frags.sort_by(|a, b| a.depth.total_cmp(&b.depth));
    let (c, t) = composite(frags.iter());
    c + background * t
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
        let mut m = Mlab::new(3, 4);
        for f in fs {
            m.insert(1, f);
        }
        let mut v = fs.to_vec();
        let exact = resolve_sorted(&mut v, Vec3::splat(0.1));
        assert!((m.resolve(1, Vec3::splat(0.1)) - exact).abs().max_element() < 1e-7);
        // The neighbouring pixels are untouched.
        assert!(m.layers(0).is_empty() && m.layers(2).is_empty());
    }

    #[test]
    fn t02_mlab_merge_keeps_total_transmittance() {
        let mut m = Mlab::new(1, 2);
        let fs: Vec<Fragment> = (0..10).map(|i| frag(10.0 - i as f32, 0.3, 0.2)).collect();
        for f in &fs {
            m.insert(0, *f);
        }
        // With a black background and equal colors, the opacity is order independent.
        let mut v = fs.clone();
        let exact = resolve_sorted(&mut v, Vec3::ONE);
        let approx = m.resolve(0, Vec3::ONE);
        let t_exact: f32 = fs.iter().map(|f| f.transmittance).product();
        assert!(
            (m.layers(0).iter().map(|f| f.transmittance).product::<f32>() - t_exact).abs() < 1e-6
        );
        assert!((approx - exact).abs().max_element() < 0.05);
    }
}
