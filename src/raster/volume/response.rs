//! A fiber's far-field response as a table over its three angles: what a
//! fragment of the volume's gather reads once per direction bin instead of
//! evaluating the model.
//!
//! A far-field fiber model depends on the view and the light only through
//! `sin θv = t·v`, `sin θl = t·l` and the azimuth φ between their
//! projections on the normal plane (in [0, π]). The table holds
//! `f(sin θv, sin θl, φ)` (RGB, the response to unit irradiance) at
//! [`NODES`] nodes per axis, uniform in each, read trilinearly.

use glam::Vec3;

/// Nodes per axis.
pub const NODES: usize = 49;

/// arccos of `x` in [-1, 1] to 7e-5 rad (Abramowitz & Stegun 4.4.45; the
/// table's nodes are π/48 = 0.065 rad apart).
#[inline]
pub fn acos(x: f32) -> f32 {
    let a = x.abs().min(1.0);
    let r = (1.0 - a).sqrt()
        * (1.570_728_8 + a * (-0.212_114_4 + a * (0.074_261_0 + a * -0.018_729_3)));
    if x < 0.0 {
        std::f32::consts::PI - r
    } else {
        r
    }
}

pub struct ResponseTable {
    data: Vec<[f32; 3]>,
}

impl ResponseTable {
    /// The table of `f(t, v, l)` (unit tangent, view and light), sampled
    /// with the tangent along y, the view in the y-z plane.
    pub fn new(f: impl Fn(Vec3, Vec3, Vec3) -> Vec3 + Sync) -> Self {
        use rayon::prelude::*;
        let n = NODES;
        let node = |i: usize| -1.0 + 2.0 * i as f32 / (n - 1) as f32;
        let t = Vec3::Y;
        let data = crate::threads::pool().install(|| {
            (0..n * n * n)
                .into_par_iter()
                .map(|idx| {
                    let (iv, il, ip) = (idx / (n * n), (idx / n) % n, idx % n);
                    let (sv, sl) = (node(iv), node(il));
                    let phi = std::f32::consts::PI * ip as f32 / (n - 1) as f32;
                    let cv = (1.0 - sv * sv).max(0.0).sqrt();
                    let cl = (1.0 - sl * sl).max(0.0).sqrt();
                    let v = Vec3::new(0.0, sv, cv);
                    let l = Vec3::new(cl * phi.sin(), sl, cl * phi.cos());
                    let r = f(t, v, l);
                    if r.is_finite() {
                        r.max(Vec3::ZERO).to_array()
                    } else {
                        [0.0; 3]
                    }
                })
                .collect()
        });
        Self { data }
    }

    /// `f` at `sin θv`, `sin θl` and φ ∈ [0, π], trilinear.
    #[inline]
    pub fn eval(&self, sv: f32, sl: f32, phi: f32) -> Vec3 {
        let n = NODES;
        let scale = (n - 1) as f32;
        let pos = |x: f32, lo: f32, span: f32| {
            let u = ((x - lo) / span * scale).clamp(0.0, scale);
            let i = (u as usize).min(n - 2);
            (i, u - i as f32)
        };
        let (iv, fv) = pos(sv, -1.0, 2.0);
        let (il, fl) = pos(sl, -1.0, 2.0);
        let (ip, fp) = pos(phi, 0.0, std::f32::consts::PI);
        let at = |a: usize, b: usize, c: usize| Vec3::from(self.data[(a * n + b) * n + c]);
        let lerp = |a: Vec3, b: Vec3, f: f32| a + (b - a) * f;
        let c00 = lerp(at(iv, il, ip), at(iv, il, ip + 1), fp);
        let c01 = lerp(at(iv, il + 1, ip), at(iv, il + 1, ip + 1), fp);
        let c10 = lerp(at(iv + 1, il, ip), at(iv + 1, il, ip + 1), fp);
        let c11 = lerp(at(iv + 1, il + 1, ip), at(iv + 1, il + 1, ip + 1), fp);
        lerp(lerp(c00, c01, fl), lerp(c10, c11, fl), fv)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.data.len() * 12
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. The fast arccos is within 7e-5 rad of the exact one.
    #[test]
    fn acos_within_its_bound() {
        for i in 0..=20000 {
            let x = -1.0 + 2.0 * i as f32 / 20000.0;
            assert!((acos(x) - x.acos()).abs() < 7e-5, "{x}");
        }
    }
}
