//! Lobe pieces shared by the fiber models, in the papers' notation: the
//! longitudinal terms M_p (d'Eon's and the Gaussian), the modified index η',
//! the TT offset h_TT, the azimuthal distributions D_p (logistic, Gaussian
//! detector, and the Karis fits), Fresnel approximations and the color to
//! absorption map. Each exact form sits beside its fit so the fit's error can
//! be measured (`hairshade.lobes`).

use crate::math::{i0_mitsuba, i0e, log_i0_mitsuba, Real};

/// Smallest longitudinal variance used by [`deon_mp`]; smaller values
/// (including 0, which is a Dirac delta) are raised to it.
pub const V_MIN: f64 = 1e-12;

/// d'Eon et al. 2011 longitudinal scattering, normalized over sin θo:
/// `M_p = csch(1/v)/(2v) · e^{-sin θi sin θo / v} · I0(cos θi cos θo / v)`.
///
/// Evaluated as `κ/(1 - e^{-2κ}) · e^{-κ|d|²/2} · i0e(c)` with `κ = 1/v`,
/// `c = κ cos θi cos θo` and `|d|² = (cos θi - cos θo)² + (sin θi + sin θo)²`
/// (`= 2 - 2cos(θi + θo)`): no overflow of I0 and no cancellation for any v,
/// in f32 or f64. The caller passes matching sines and cosines.
#[inline(always)]
pub fn deon_mp<T: Real>(sin_theta_i: T, cos_theta_i: T, sin_theta_o: T, cos_theta_o: T, v: T) -> T {
    let kappa = T::ONE / v.max(T::from_f64(V_MIN));
    let dc = cos_theta_i - cos_theta_o;
    let ds = sin_theta_i + sin_theta_o;
    let c = cos_theta_i * cos_theta_o * kappa;
    kappa / -(-T::TWO * kappa).exp_m1() * (-T::HALF * kappa * (dc * dc + ds * ds)).exp() * i0e(c)
}

/// d'Eon's M_p as Mitsuba 3 (and pbrt) evaluate it: truncated I0 series,
/// asymptotic log I0 above 12, and a separate branch for `1/v > 10`.
#[inline(always)]
// 0.6931 below is Mitsuba's own truncated ln 2, kept to reproduce it exactly.
#[allow(clippy::approx_constant)]
pub fn deon_mp_mitsuba<T: Real>(
    sin_theta_i: T,
    cos_theta_i: T,
    sin_theta_o: T,
    cos_theta_o: T,
    v: T,
) -> T {
    let kappa = T::ONE / v;
    let c = cos_theta_i * cos_theta_o * kappa;
    let s = sin_theta_i * sin_theta_o * kappa;
    if kappa > T::from_f64(10.0) {
        (-s + log_i0_mitsuba(c) - kappa + T::from_f64(0.6931) + (T::HALF * kappa).ln()).exp()
    } else {
        (-s).exp() * i0_mitsuba(c) * kappa / (T::TWO * kappa.sinh())
    }
}

/// Smallest Gaussian width used by [`gaussian`] (a zero width is a delta).
pub const B_MIN: f64 = 1e-7;

/// Normalized Gaussian `exp(-x²/(2B²)) / (√(2π) B)` (UE's `Hair_g`), the
/// Karis longitudinal term with `x = sin θi + sin θo - α_p`.
#[inline(always)]
pub fn gaussian<T: Real>(b: T, x: T) -> T {
    let b = b.max(T::from_f64(B_MIN));
    (-T::HALF * x * x / (b * b)).exp() / (T::from_f64((2.0 * std::f64::consts::PI).sqrt()) * b)
}

/// Gaussian detector: the Gaussian of width `b` wrapped around the circle
/// (sum over k = -4..=4 of `gaussian(b, φ - 2πk)`), as UE's reference.
#[inline(always)]
pub fn gaussian_detector<T: Real>(b: T, phi: T) -> T {
    let mut d = T::ZERO;
    for k in -4..=4 {
        d += gaussian(b, phi - T::TWO_PI * T::from_f64(k as f64));
    }
    d
}

/// Logistic distribution `D(φ, s, μ) = e^{(φ-μ)/s} / (s (1 + e^{(φ-μ)/s})²)`
/// (Pekelis et al. 2015), evaluated symmetric and overflow-free.
#[inline(always)]
pub fn logistic_d<T: Real>(phi: T, s: T, mu: T) -> T {
    let e = (-(phi - mu).abs() / s).exp();
    e / (s * (T::ONE + e) * (T::ONE + e))
}

/// Schlick's Fresnel `F0 + (1 - F0)(1 - x)^5` with `F0 = ((1-η)/(1+η))²`.
#[inline(always)]
pub fn schlick_fresnel<T: Real>(eta: T, x: T) -> T {
    let f0 = ((T::ONE - eta) / (T::ONE + eta)).powi(2);
    let m = (T::ONE - x).max(T::ZERO).min(T::ONE);
    f0 + (T::ONE - f0) * m.powi(5)
}

/// Modified index of refraction (Bravais) `η' = √(η² - sin²θd) / cos θd`.
#[inline(always)]
pub fn eta_prime<T: Real>(eta: T, cos_theta_d: T) -> T {
    (eta * eta - T::ONE + cos_theta_d * cos_theta_d)
        .max(T::ZERO)
        .sqrt()
        / cos_theta_d
}

/// Karis's fit for η = 1.55: `η' ≈ 1.19 / cos θd + 0.36 cos θd`.
#[inline(always)]
pub fn eta_prime_fit<T: Real>(cos_theta_d: T) -> T {
    T::from_f64(1.19) / cos_theta_d + T::from_f64(0.36) * cos_theta_d
}

/// Exact TT offset for the azimuth φ ∈ [0, π], `a = 1/η'`:
/// `h_TT = cos(φ/2) / √(1 + a² - 2a sin(φ/2))`.
#[inline(always)]
pub fn h_tt<T: Real>(cos_phi: T, a: T) -> T {
    let cos_half = (T::HALF + T::HALF * cos_phi).max(T::ZERO).sqrt();
    let sin_half = (T::HALF - T::HALF * cos_phi).max(T::ZERO).sqrt();
    cos_half
        / (T::ONE + a * a - T::TWO * a * sin_half)
            .max(T::MIN_POSITIVE)
            .sqrt()
}

/// Karis's fit: `h_TT ≈ (1 + a (0.6 - 0.8 cos φ)) cos(φ/2)`.
#[inline(always)]
pub fn h_tt_fit<T: Real>(cos_phi: T, a: T) -> T {
    let cos_half = (T::HALF + T::HALF * cos_phi).max(T::ZERO).sqrt();
    cos_half * (T::ONE + a * (T::from_f64(0.6) - T::from_f64(0.8) * cos_phi))
}

/// Karis's fit of the TT distribution `D(φ, 0.35, π)`: `exp(-3.65 cos φ - 3.98)`.
#[inline(always)]
pub fn d_tt_fit<T: Real>(cos_phi: T) -> T {
    (T::from_f64(-3.65) * cos_phi - T::from_f64(3.98)).exp()
}

/// Karis's fit of the TRT distribution `¾ D(φ, 0.15, 0)`: `exp(17 cos φ - 16.78)`.
#[inline(always)]
pub fn d_trt_fit<T: Real>(cos_phi: T) -> T {
    (T::from_f64(17.0) * cos_phi - T::from_f64(16.78)).exp()
}

/// UE's `asinFast`: `π/2 - acosFast(x)` with Eberly's degree-1 `acosFast`
/// (absolute error up to 9e-3 rad).
#[inline(always)]
pub fn asin_fast<T: Real>(x: T) -> T {
    let ax = x.abs().min(T::ONE);
    let acos_abs = (T::from_f64(-0.156583) * ax + T::FRAC_PI_2) * (T::ONE - ax).sqrt();
    let acos = if x >= T::ZERO {
        acos_abs
    } else {
        T::PI - acos_abs
    };
    T::FRAC_PI_2 - acos
}

/// Chiang et al. 2016 color → absorption map (eq. 9): the σa (per unit
/// radius) that gives a multiple-scattering color `c` for azimuthal
/// roughness `beta_n`: `σa = (ln c / (5.969 - 0.215β + 2.532β² - 10.73β³ + 5.574β⁴ + 0.245β⁵))²`.
/// `c` is clamped to [1e-6, 1] (0 would be an infinite absorption).
#[inline(always)]
pub fn color_to_absorption<T: Real>(c: T, beta_n: T) -> T {
    let b = beta_n;
    let d = T::from_f64(5.969) - T::from_f64(0.215) * b + T::from_f64(2.532) * b * b
        - T::from_f64(10.73) * b.powi(3)
        + T::from_f64(5.574) * b.powi(4)
        + T::from_f64(0.245) * b.powi(5);
    let l = c.max(T::from_f64(1e-6)).min(T::ONE).ln() / d;
    l * l
}

/// UE's `Luminance` weights for hair tint: `dot(c, (0.3, 0.59, 0.11))`.
pub const HAIR_LUMA: [f64; 3] = [0.3, 0.59, 0.11];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::gauss_legendre;

    #[test]
    fn t01_deon_mp_matches_mitsuba_form_where_that_is_accurate() {
        // κ = 2: Mitsuba's direct branch with I0 arguments ≤ 2 is exact to rounding.
        for &(si, so) in &[(0.1_f64, -0.2), (0.7, 0.3), (-0.9, 0.9)] {
            let (ci, co) = ((1.0 - si * si).sqrt(), (1.0 - so * so).sqrt());
            let a = deon_mp(si, ci, so, co, 0.5);
            let b = deon_mp_mitsuba(si, ci, so, co, 0.5);
            assert!(((a - b) / a).abs() < 1e-12);
        }
    }

    #[test]
    fn t02_gaussian_and_detector_normalized() {
        let (x, w) = gauss_legendre(64);
        for b in [0.05_f64, 0.3, 1.0] {
            // ∫ over [-π, π] of the wrapped Gaussian is 1 (wrapping keeps the
            // mass that the plain Gaussian has outside the interval).
            let mut s = 0.0;
            for k in 0..32 {
                let a = -std::f64::consts::PI + k as f64 * std::f64::consts::TAU / 32.0;
                let half = std::f64::consts::PI / 32.0;
                for (xi, wi) in x.iter().zip(&w) {
                    s += wi * half * gaussian_detector(b, a + half * (xi + 1.0));
                }
            }
            assert!((s - 1.0).abs() < 1e-12, "b={b} s={s}");
        }
        assert!(gaussian(0.0_f64, 0.1) == 0.0 && gaussian(0.0_f32, 0.0).is_finite());
    }

    #[test]
    fn t03_eta_prime_fit_close_at_1_55() {
        let mut worst = 0.0_f64;
        for k in 0..=1000 {
            let c = 0.2 + 0.8 * k as f64 / 1000.0;
            worst = worst.max((eta_prime_fit(c) / eta_prime(1.55, c) - 1.0).abs());
        }
        assert!(worst < 0.01, "{worst}");
    }

    #[test]
    fn t04_h_tt_limits() {
        // φ = π (straight through): h = 0; φ = 0: h = 1/(1 - a)... clipped by callers.
        assert!(h_tt(-1.0_f64, 0.6).abs() < 1e-15);
        assert!((h_tt_fit(-1.0_f64, 0.6)).abs() < 1e-15);
    }

    #[test]
    fn t05_asin_fast_error_bound() {
        let mut worst = 0.0_f64;
        for k in -1000..=1000 {
            let x = k as f64 / 1000.0;
            worst = worst.max((asin_fast(x) - x.asin()).abs());
        }
        assert!(worst < 9.1e-3 && worst > 1e-3, "{worst}");
    }
}
