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
}
