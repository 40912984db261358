//! The fiber frame of Mitsuba 3's `hair` plugin, shared by every fiber model.
//!
//! Local coordinates: **y is the fiber tangent**, z the shading normal, x
//! completes the right-handed frame. For a direction `w`:
//!
//! | quantity | definition |
//! | --- | --- |
//! | longitudinal angle θ | `sin θ = w.y` (angle to the normal plane, not a polar angle) |
//! | azimuth φ | `atan2(w.z, w.x)` |
//! | γ (for `wi`) | signed angle between the normal and `w` projected into the normal plane: `±acos(w.z / |w.xz|)`, positive when `w.x < 0` |
//! | offset h | `sin γ = -w.x / |w.xz|` |
//!
//! h is not an input of the near-field model: it is fixed by where `wi` hits
//! the fiber, i.e. by the normal. Sweeping h means rotating the normal (both
//! directions) about y.

use crate::math::{circ, safe_acos, Real};

/// A direction in the fiber frame.
pub type Vec3<T> = [T; 3];

/// `(sin θ, cos θ)` of the longitudinal angle.
#[inline(always)]
pub fn sin_cos_theta<T: Real>(w: &Vec3<T>) -> (T, T) {
    (w[1], circ(w[1]))
}

/// Azimuth φ in the normal plane, measured from local x towards z.
#[inline(always)]
pub fn azimuth<T: Real>(w: &Vec3<T>) -> T {
    w[2].atan2(w[0])
}

/// γ of a direction: the signed angle between the normal (z) and the
/// direction's projection onto the normal plane (xz). In [-π, π]; 0 when the
/// direction is parallel to the tangent.
#[inline(always)]
pub fn gamma<T: Real>(w: &Vec3<T>) -> T {
    let proj = (w[0] * w[0] + w[2] * w[2]).sqrt();
    let g = if proj == T::ZERO {
        T::ZERO
    } else {
        safe_acos(w[2] / proj)
    };
    if w[0] < T::ZERO {
        g
    } else {
        -g
    }
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
    fn t02_h_is_minus_x_over_projection() {
        // h = sin γ = -x / |xz|, for directions in front of and behind the normal.
        for &w in &[[0.3_f64, 0.5, 0.8], [-0.6, -0.2, 0.1], [0.2, 0.1, -0.9], [-1.0, 0.0, 0.0]] {
            let w = normalized(&w).unwrap();
            let h = gamma(&w).sin();
            let expect = -w[0] / (w[0] * w[0] + w[2] * w[2]).sqrt();
            assert!((h - expect).abs() < 1e-15, "{w:?}: {h} vs {expect}");
        }
        // Parallel to the tangent: γ = 0 by convention.
        assert_eq!(gamma(&[0.0_f64, 1.0, 0.0]), 0.0);
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
