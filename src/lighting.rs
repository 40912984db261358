//! Light representations shared by the models and the renderer.

use crate::fiber::frame::Vec3;
use crate::math::Real;

/// The constant SH basis function Y00 = 1/(2√π): a constant radiance L
/// has the single coefficient L / Y00.
pub const Y00: f64 = 0.282_094_791_773_878_1;

/// Real spherical-harmonic basis up to band 2 (9 functions) at a unit
/// direction, in the usual order: Y00; Y1-1 (y), Y10 (z), Y11 (x);
/// Y2-2 (xy), Y2-1 (yz), Y20 (3z²−1), Y21 (xz), Y22 (x²−y²).
#[inline(always)]
pub fn sh9_basis<T: Real>(d: &Vec3<T>) -> [T; 9] {
    let (x, y, z) = (d[0], d[1], d[2]);
    let c = |v: f64| T::from_f64(v);
    [
        c(Y00),
        c(0.488_602_511_902_919_9) * y,
        c(0.488_602_511_902_919_9) * z,
        c(0.488_602_511_902_919_9) * x,
        c(1.092_548_430_592_079_2) * x * y,
        c(1.092_548_430_592_079_2) * y * z,
        c(0.315_391_565_252_520_0) * (c(3.0) * z * z - T::ONE),
        c(1.092_548_430_592_079_2) * x * z,
        c(0.546_274_215_296_039_6) * (x * x - y * y),
    ]
}

/// Radiance of a band-2 SH environment (9 RGB coefficients) in direction `d`.
#[inline(always)]
pub fn sh9_eval<T: Real>(coeffs: &[[T; 3]; 9], d: &Vec3<T>) -> [T; 3] {
    let y = sh9_basis(d);
    let mut out = [T::ZERO; 3];
    for k in 0..9 {
        for c in 0..3 {
            out[c] += coeffs[k][c] * y[k];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The basis is orthonormal over the sphere (checked by a product rule).
    #[test]
    fn t01_sh9_orthonormal() {
        let (x, w) = crate::math::gauss_legendre(24);
        let n_phi = 48;
        let mut gram = [[0.0f64; 9]; 9];
        for (zi, wz) in x.iter().zip(&w) {
            let r = (1.0 - zi * zi).sqrt();
            for k in 0..n_phi {
                let phi = std::f64::consts::TAU * k as f64 / n_phi as f64;
                let y = sh9_basis(&[r * phi.cos(), r * phi.sin(), *zi]);
                let dw = wz * std::f64::consts::TAU / n_phi as f64;
                for a in 0..9 {
                    for b in 0..9 {
                        gram[a][b] += y[a] * y[b] * dw;
                    }
                }
            }
        }
        for a in 0..9 {
            for b in 0..9 {
                let e = if a == b { 1.0 } else { 0.0 };
                assert!((gram[a][b] - e).abs() < 1e-12, "{a} {b} {}", gram[a][b]);
            }
        }
    }
}
