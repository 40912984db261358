//! The modified Bessel function of the first kind, order 0: exact (power
//! series and asymptotic expansion, exponentially scaled) and the truncated
//! form Mitsuba 3 uses.

use super::Real;

/// Exponentially scaled Bessel function `i0e(x) = e^{-|x|} I0(x)`.
///
/// Power series `Σ (x²/4)^k / (k!)²` (all terms positive, no cancellation) up
/// to [`Real::I0_SERIES_MAX`], the asymptotic series
/// `e^{-x} I0(x) = (2πx)^{-1/2} Σ_k ((2k-1)!!)² / (k! (8x)^k)` above, summed
/// until its terms stop shrinking or drop below epsilon. Relative error is a
/// few ulps over the whole range (tested against scipy's `ive`). Finite for
/// every finite input; `i0e(±inf) = 0`, `i0e(NaN) = NaN`.
pub fn i0e<T: Real>(x: T) -> T {
    let x = x.abs();
    if x <= T::I0_SERIES_MAX {
        i0_series(x) * (-x).exp()
    } else {
        i0e_asymptotic_sum(x) / (T::TWO_PI * x).sqrt()
    }
}

/// Natural logarithm of I0, accurate to a few ulps (relative) in the result,
/// including near 0 where `log I0(x) ≈ x²/4` (no `ln(1 + tiny)` cancellation).
pub fn log_i0<T: Real>(x: T) -> T {
    let x = x.abs();
    if x <= T::I0_SERIES_MAX {
        i0_series_minus_one(x).ln_1p()
    } else {
        x + i0e_asymptotic_sum(x).ln() - T::HALF * (T::TWO_PI * x).ln()
    }
}

/// `1 / k²` for k = 1..=64: the power series' term ratio without a division.
const INV_K2: [f64; 64] = {
    let mut t = [0.0; 64];
    let mut k = 0;
    while k < 64 {
        let kf = (k + 1) as f64;
        t[k] = 1.0 / (kf * kf);
        k += 1;
    }
    t
};

/// `(2k-1)² / (8k)` for k = 1..=64: the asymptotic series' term ratio times x.
const ASYM_RATIO: [f64; 64] = {
    let mut t = [0.0; 64];
    let mut k = 0;
    while k < 64 {
        let kf = (k + 1) as f64;
        t[k] = (2.0 * kf - 1.0) * (2.0 * kf - 1.0) / (8.0 * kf);
        k += 1;
    }
    t
};

/// `I0(x) - 1` by the power series (terms k ≥ 1), for `|x| ≤ I0_SERIES_MAX`.
#[inline]
fn i0_series_minus_one<T: Real>(x: T) -> T {
    let q = T::from_f64(0.25) * x * x;
    let mut term = q;
    let mut sum = q;
    // At most ~35 terms for f64 at the switch point (x = 18), ~17 for f32 at 9.
    for &inv in &INV_K2[1..] {
        term = term * q * T::from_f64(inv);
        sum += term;
        if term <= sum * T::EPSILON {
            break;
        }
    }
    sum
}

#[inline]
fn i0_series<T: Real>(x: T) -> T {
    T::ONE + i0_series_minus_one(x)
}

/// `Σ_k ((2k-1)!!)² / (k! (8x)^k)`, summed while the terms decrease.
#[inline]
fn i0e_asymptotic_sum<T: Real>(x: T) -> T {
    let r = T::ONE / x;
    let mut term = T::ONE;
    let mut sum = T::ONE;
    for &c in &ASYM_RATIO {
        let next = term * T::from_f64(c) * r;
        if next >= term || next <= sum * T::EPSILON {
            break;
        }
        term = next;
        sum += term;
    }
    sum
}

/// Mitsuba 3's `warp::detail::i0`: the power series truncated after the
/// `x^20` term. Accurate only for small x (5e-4 relative error at x = 10).
#[inline]
pub fn i0_mitsuba<T: Real>(x: T) -> T {
    let x2 = x * x;
    let mut result = T::ONE;
    let mut xi = x2;
    let mut denom = T::from_f64(4.0);
    let mut factor = T::ONE;
    for _ in 1..=10 {
        factor += T::ONE;
        result += xi / denom;
        xi *= x2;
        denom *= T::from_f64(4.0) * factor * factor;
    }
    result
}

/// Mitsuba 3's `warp::detail::log_i0`: `log(i0_mitsuba(x))` up to 12, then
/// `x + ½(log(1/(2πx)) + 1/(8x))` (the `1/(8x)` correction is halved
/// relative to the true expansion, as in pbrt).
#[inline]
pub fn log_i0_mitsuba<T: Real>(x: T) -> T {
    if x > T::from_f64(12.0) {
        x + T::HALF * ((T::ONE / (T::TWO_PI * x)).ln() + T::ONE / (T::from_f64(8.0) * x))
    } else {
        i0_mitsuba(x).ln()
    }
}
