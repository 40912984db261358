//! Directions in `n × n` octahedral bins (the unit sphere folded onto the
//! octahedron |x| + |y| + |z| = 1, then onto the square).

use glam::Vec3;

/// `n × n` octahedral bins.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bins {
    pub n: usize,
}

impl Bins {
    pub fn count(&self) -> usize {
        self.n * self.n
    }

    /// The bin of unit `d`.
    #[inline]
    pub fn of(&self, d: Vec3) -> usize {
        let [u, v] = encode(d);
        let n = self.n as f32;
        let i = ((u * 0.5 + 0.5) * n).clamp(0.0, n - 1.0) as usize;
        let j = ((v * 0.5 + 0.5) * n).clamp(0.0, n - 1.0) as usize;
        j * self.n + i
    }

    /// The tally of a radiance of 1 from every direction, as the solve
    /// keeps its bins: per bin its solid angle (as RGB fluence) and the sum
    /// of its propagation directions (`∫_b ω dω`), by an equal-area
    /// quadrature of 256 × 512 directions.
    pub fn uniform_field(&self) -> Vec<[f32; 6]> {
        let (nz, np) = (256usize, 512usize);
        let dw = 4.0 * std::f64::consts::PI / (nz * np) as f64;
        let mut acc = vec![[0.0f64; 6]; self.count()];
        for i in 0..nz * np {
            let z = -1.0 + 2.0 * ((i / np) as f64 + 0.5) / nz as f64;
            let phi = std::f64::consts::TAU * ((i % np) as f64 + 0.5) / np as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let d = [r * phi.cos(), r * phi.sin(), z];
            let a = &mut acc[self.of(Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32))];
            for k in 0..3 {
                a[k] += dw;
                a[3 + k] += d[k] * dw;
            }
        }
        acc.iter().map(|a| a.map(|x| x as f32)).collect()
    }

    /// The unit direction at the centre of bin `b`.
    pub fn centre(&self, b: usize) -> Vec3 {
        let n = self.n as f32;
        let (i, j) = (b % self.n, b / self.n);
        let u = (i as f32 + 0.5) / n * 2.0 - 1.0;
        let v = (j as f32 + 0.5) / n * 2.0 - 1.0;
        decode([u, v])
    }
}

/// Octahedral encoding of unit `d` into [-1, 1]².
#[inline]
fn encode(d: Vec3) -> [f32; 2] {
    let s = d.x.abs() + d.y.abs() + d.z.abs();
    let (x, y, z) = (d.x / s, d.y / s, d.z / s);
    if z >= 0.0 {
        [x, y]
    } else {
        let sx = if x >= 0.0 { 1.0 } else { -1.0 };
        let sy = if y >= 0.0 { 1.0 } else { -1.0 };
        [(1.0 - y.abs()) * sx, (1.0 - x.abs()) * sy]
    }
}

/// The unit direction of octahedral coordinates `[u, v]`.
fn decode([u, v]: [f32; 2]) -> Vec3 {
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z >= 0.0 {
        (u, v)
    } else {
        let sx = if u >= 0.0 { 1.0 } else { -1.0 };
        let sy = if v >= 0.0 { 1.0 } else { -1.0 };
        ((1.0 - v.abs()) * sx, (1.0 - u.abs()) * sy)
    };
    Vec3::new(x, y, z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. Every bin's centre falls in that bin.
    #[test]
    fn centres_in_their_bins() {
        for n in [4, 8, 12] {
            let bins = Bins { n };
            for b in 0..bins.count() {
                assert_eq!(bins.of(bins.centre(b)), b, "n {n} bin {b}");
            }
        }
    }

    /// 2. The uniform field's bins tile the sphere: their solid angles sum
    ///    to 4π and their propagation directions to 0 (the quadrature is
    ///    symmetric), and each bin's mean direction lies in the bin.
    #[test]
    fn uniform_field_tiles_the_sphere() {
        for n in [4, 8, 16] {
            let bins = Bins { n };
            let u = bins.uniform_field();
            let total: f32 = u.iter().map(|a| a[0]).sum();
            assert!(
                (total - 4.0 * std::f32::consts::PI).abs() < 1e-3,
                "n {n}: {total}"
            );
            let sum = u
                .iter()
                .fold(Vec3::ZERO, |s, a| s + Vec3::new(a[3], a[4], a[5]));
            assert!(sum.length() < 1e-3, "n {n}: {sum}");
            for (b, a) in u.iter().enumerate() {
                assert_eq!(
                    bins.of(Vec3::new(a[3], a[4], a[5]).normalize()),
                    b,
                    "n {n} bin {b}"
                );
            }
        }
    }
}
