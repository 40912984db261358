//! The fiber frame of Mitsuba 3's `hair` plugin, shared by every fiber model.
//!
//! Local coordinates: **y is the fiber tangent**, z the shading normal, x
//! completes the right-handed frame. For a direction `w`:
//!
//! | quantity | definition |
//! | --- | --- |
//! | longitudinal angle θ | `sin θ = w.y`, `cos θ = |w.xz|` (angle to the normal plane, not a polar angle) |
//! | azimuth φ | `atan2(w.z, w.x)` |
//! | γ (for `wi`) | signed angle between the normal and `w` projected into the normal plane: `atan2(-w.x, w.z)` (Mitsuba: `±acos(w.z / |w.xz|)`, positive when `w.x < 0`) |
//! | offset h | `sin γ = -w.x / |w.xz|`; `cos γ = w.z / |w.xz|` |
//!
//! Every quantity is computed from the components directly (`cos θ` as
//! `|w.xz|`, not `sqrt(1 - y²)`; γ by `atan2`, not `acos`): the
//! mathematically equal forms Mitsuba uses lose up to half the digits near
//! the poles and near h = 0 and |h| = 1, which matters in f32.
//!
//! h is not an input of the near-field model: it is fixed by where `wi` hits
//! the fiber, i.e. by the normal. Sweeping h means rotating the normal (both
//! directions) about y.

use crate::math::Real;

/// A direction in the fiber frame.
pub type Vec3<T> = [T; 3];

/// `(sin θ, cos θ)` of the longitudinal angle of a unit vector.
#[inline(always)]
pub fn sin_cos_theta<T: Real>(w: &Vec3<T>) -> (T, T) {
    (w[1], (w[0] * w[0] + w[2] * w[2]).sqrt().min(T::ONE))
}

/// Azimuth φ in the normal plane, measured from local x towards z.
#[inline(always)]
pub fn azimuth<T: Real>(w: &Vec3<T>) -> T {
    w[2].atan2(w[0])
}

/// Where a direction enters the fiber: `(γ, h = sin γ, cos γ)`, with γ the
/// signed angle in the normal plane from the normal (z) to the direction's
/// projection, in (-π, π]. A direction along the tangent gives `(0, 0, 1)`.
#[inline(always)]
pub fn offset<T: Real>(w: &Vec3<T>) -> (T, T, T) {
    let proj = (w[0] * w[0] + w[2] * w[2]).sqrt();
    if proj == T::ZERO {
        return (T::ZERO, T::ZERO, T::ONE);
    }
    ((-w[0]).atan2(w[2]), -w[0] / proj, w[2] / proj)
}

/// The unit vector along `w`, or `None` if `w` has a non-finite component or
/// zero length (such directions evaluate to zero in every model).
#[inline(always)]
pub fn normalized<T: Real>(w: &Vec3<T>) -> Option<Vec3<T>> {
    if !(w[0].is_finite() && w[1].is_finite() && w[2].is_finite()) {
        return None;
    }
    // Scale first so that huge and denormal inputs neither overflow nor
    // underflow when squared.
    let m = w[0].abs().max(w[1].abs()).max(w[2].abs());
    if m == T::ZERO {
        return None;
    }
    let s = [w[0] / m, w[1] / m, w[2] / m];
    let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    Some([s[0] / len, s[1] / len, s[2] / len])
}

/// The direction with longitudinal angle `(sin θ, cos θ)` and azimuth φ.
#[inline(always)]
pub fn from_angles<T: Real>(sin_theta: T, cos_theta: T, phi: T) -> Vec3<T> {
    let (sin_phi, cos_phi) = phi.sin_cos();
    [cos_theta * cos_phi, sin_theta, cos_theta * sin_phi]
}

/// The angles a far-field fiber model depends on, for tangent `t`, view
/// `v` and light `l` (unit vectors): (sin θ, cos θ) of the view and of the
/// light (θ from the normal plane, cos θ ≥ 0), and the azimuth between
/// their projections on the normal plane, in [0, π].
#[derive(Debug, Clone, Copy)]
pub struct FiberAngles {
    pub view: (f32, f32),
    pub light: (f32, f32),
    pub phi: f32,
}

impl FiberAngles {
    #[inline]
    pub fn new(t: glam::Vec3, v: glam::Vec3, l: glam::Vec3) -> Self {
        let (sv, sl) = (t.dot(v).clamp(-1.0, 1.0), t.dot(l).clamp(-1.0, 1.0));
        let (vp, lp) = (v - t * sv, l - t * sl);
        Self {
            view: (sv, (1.0 - sv * sv).max(0.0).sqrt()),
            light: (sl, (1.0 - sl * sl).max(0.0).sqrt()),
            phi: vp.cross(lp).length().atan2(vp.dot(lp)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t01_angles_round_trip() {
        for &(st, phi) in &[(0.3_f64, 0.7_f64), (-0.9, -2.5), (0.0, 3.0), (0.99, -0.1)] {
            let ct = (1.0 - st * st).sqrt();
            let w = from_angles(st, ct, phi);
            let (s2, c2) = sin_cos_theta(&w);
            assert!((s2 - st).abs() < 1e-15 && (c2 - ct).abs() < 1e-15);
            assert!((azimuth(&w) - phi).abs() < 1e-14);
        }
    }

    #[test]
    fn t02_offset_matches_mitsuba_gamma() {
        // Mitsuba: γ = ±acos(z/|xz|), positive when x < 0; h = sin γ.
        for &w in &[
            [0.3_f64, 0.5, 0.8],
            [-0.6, -0.2, 0.1],
            [0.2, 0.1, -0.9],
            [-1.0, 0.0, 0.0],
        ] {
            let w = normalized(&w).unwrap();
            let p = (w[0] * w[0] + w[2] * w[2]).sqrt();
            let g_mi = if w[0] < 0.0 {
                (w[2] / p).acos()
            } else {
                -(w[2] / p).acos()
            };
            let (g, h, cg) = offset(&w);
            assert!((g - g_mi).abs() < 1e-14, "{w:?}: {g} vs {g_mi}");
            assert!((h - g_mi.sin()).abs() < 1e-15 && (cg - g_mi.cos()).abs() < 1e-15);
        }
        // Parallel to the tangent: γ = 0 by convention.
        assert_eq!(offset(&[0.0_f64, 1.0, 0.0]), (0.0, 0.0, 1.0));
    }

    #[test]
    fn t03_normalized_rejects_degenerate() {
        assert!(normalized(&[0.0_f32, 0.0, 0.0]).is_none());
        assert!(normalized(&[f32::NAN, 0.0, 1.0]).is_none());
        assert!(normalized(&[f64::INFINITY, 0.0, 1.0]).is_none());
        let big = normalized(&[1e300_f64, 1e300, 0.0]).unwrap();
        assert!((big[0] - 0.5_f64.sqrt()).abs() < 1e-15);
        let tiny = normalized(&[1e-40_f32, 0.0, 0.0]).unwrap();
        assert_eq!(tiny, [1.0, 0.0, 0.0]);
    }
}
