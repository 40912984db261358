//! Scalar math shared by every model: the floating-point abstraction the
//! models are generic over, the modified Bessel function I0 (exact, and the
//! truncated form Mitsuba 3 uses), Fresnel reflectance, the trimmed logistic
//! distribution and Gauss–Legendre quadrature.
//!
//! Special functions live here and nowhere else, so that a model file reads
//! like its paper.

mod bessel;

pub use bessel::{i0_mitsuba, i0e, log_i0, log_i0_mitsuba};

use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// The floating-point types the models are generic over (`f32` and `f64`).
///
/// Only what the models need; every method maps to the inherent `std` method
/// of the same name.
pub trait Real:
    Copy
    + Send
    + Sync
    + PartialOrd
    + std::fmt::Debug
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + 'static
{
    const ZERO: Self;
    const ONE: Self;
    const HALF: Self;
    const TWO: Self;
    const PI: Self;
    const TWO_PI: Self;
    const FRAC_PI_2: Self;
    const INV_TWO_PI: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Largest finite value.
    const MAX: Self;
    /// Smallest positive normal value.
    const MIN_POSITIVE: Self;
    /// Above this argument [`i0e`] switches from the power series to the
    /// asymptotic series: both are then accurate to a few ulps.
    const I0_SERIES_MAX: Self;

    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    fn exp(self) -> Self;
    fn exp_m1(self) -> Self;
    fn ln(self) -> Self;
    fn ln_1p(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn sin_cos(self) -> (Self, Self);
    fn asin(self) -> Self;
    fn acos(self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn sinh(self) -> Self;
    fn abs(self) -> Self;
    fn powi(self, n: i32) -> Self;
    fn max(self, other: Self) -> Self;
    fn min(self, other: Self) -> Self;
    fn rem_euclid(self, rhs: Self) -> Self;
    fn is_finite(self) -> bool;
    fn is_nan(self) -> bool;
}

macro_rules! impl_real {
    ($t:ident, $i0_series_max:expr) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            const TWO: Self = 2.0;
            const PI: Self = std::$t::consts::PI;
            const TWO_PI: Self = std::$t::consts::TAU;
            const FRAC_PI_2: Self = std::$t::consts::FRAC_PI_2;
            const INV_TWO_PI: Self = 1.0 / std::$t::consts::TAU;
            const EPSILON: Self = $t::EPSILON;
            const MAX: Self = $t::MAX;
            const MIN_POSITIVE: Self = $t::MIN_POSITIVE;
            const I0_SERIES_MAX: Self = $i0_series_max;

            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                $t::sqrt(self)
            }
            #[inline(always)]
            fn exp(self) -> Self {
                $t::exp(self)
            }
            #[inline(always)]
            fn exp_m1(self) -> Self {
                $t::exp_m1(self)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                $t::ln(self)
            }
            #[inline(always)]
            fn ln_1p(self) -> Self {
                $t::ln_1p(self)
            }
            #[inline(always)]
            fn sin(self) -> Self {
                $t::sin(self)
            }
            #[inline(always)]
            fn cos(self) -> Self {
                $t::cos(self)
            }
            #[inline(always)]
            fn sin_cos(self) -> (Self, Self) {
                $t::sin_cos(self)
            }
            #[inline(always)]
            fn asin(self) -> Self {
                $t::asin(self)
            }
            #[inline(always)]
            fn acos(self) -> Self {
                $t::acos(self)
            }
            #[inline(always)]
            fn atan2(self, x: Self) -> Self {
                $t::atan2(self, x)
            }
            #[inline(always)]
            fn sinh(self) -> Self {
                $t::sinh(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                $t::abs(self)
            }
            #[inline(always)]
            fn powi(self, n: i32) -> Self {
                $t::powi(self, n)
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                $t::max(self, other)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                $t::min(self, other)
            }
            #[inline(always)]
            fn rem_euclid(self, rhs: Self) -> Self {
                $t::rem_euclid(self, rhs)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                $t::is_finite(self)
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                $t::is_nan(self)
            }
        }
    };
}

// Series/asymptotic switch points: the smallest asymptotic term at x is about
// e^{-2x}, and the power series needs ~2x terms; 18 (f64) and 9 (f32) put
// both below the type's epsilon.
impl_real!(f64, 18.0);
impl_real!(f32, 9.0);

/// `sqrt(max(x, 0))`.
#[inline(always)]
pub fn safe_sqrt<T: Real>(x: T) -> T {
    x.max(T::ZERO).sqrt()
}

/// `asin(clamp(x, -1, 1))`.
#[inline(always)]
pub fn safe_asin<T: Real>(x: T) -> T {
    x.max(-T::ONE).min(T::ONE).asin()
}

/// `acos(clamp(x, -1, 1))`.
#[inline(always)]
pub fn safe_acos<T: Real>(x: T) -> T {
    x.max(-T::ONE).min(T::ONE).acos()
}

/// `sqrt(1 - x²)`, clamped at 0: the cosine belonging to a sine and vice versa.
#[inline(always)]
pub fn circ<T: Real>(x: T) -> T {
    safe_sqrt(T::ONE - x * x)
}

// ---------------------------------------------------------------------------
// Fresnel
// ---------------------------------------------------------------------------

/// Unpolarized Fresnel reflectance of a dielectric interface with relative
/// index `eta` (inside / outside), for `cos_theta_i` measured on the side the
/// light comes from (negative: from inside). Same algebra as Mitsuba 3's
/// `fresnel()`: total internal reflection gives 1, `eta == 1` gives 0, and a
/// grazing `cos_theta_i == 0` gives 1.
#[inline]
pub fn fresnel_dielectric<T: Real>(cos_theta_i: T, eta: T) -> T {
    if eta == T::ONE {
        return T::ZERO;
    }
    let (eta_it, eta_ti) = if cos_theta_i >= T::ZERO {
        (eta, T::ONE / eta)
    } else {
        (T::ONE / eta, eta)
    };
    let cos_theta_t_sqr = T::ONE - (T::ONE - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let cos_i = cos_theta_i.abs();
    if cos_i == T::ZERO {
        return T::ONE;
    }
    let cos_t = safe_sqrt(cos_theta_t_sqr);
    // Amplitudes of the s- and p-polarized reflected waves.
    let a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
    let a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
    T::HALF * (a_s * a_s + a_p * a_p)
}

// ---------------------------------------------------------------------------
// Trimmed logistic distribution on [-π, π]
// ---------------------------------------------------------------------------

/// Logistic density with scale `s`: `e^{-|x|/s} / (s (1 + e^{-|x|/s})²)`.
#[inline(always)]
pub fn logistic<T: Real>(x: T, s: T) -> T {
    let e = (-x.abs() / s).exp();
    let d = T::ONE + e;
    e / (s * d * d)
}

/// Logistic CDF with scale `s`.
#[inline(always)]
pub fn logistic_cdf<T: Real>(x: T, s: T) -> T {
    T::ONE / (T::ONE + (-x / s).exp())
}

/// Logistic density restricted to [-π, π] and renormalized; the caller passes
/// the precomputed normalization `1 / (cdf(π) - cdf(-π))`.
#[inline(always)]
pub fn trimmed_logistic<T: Real>(x: T, s: T, inv_norm: T) -> T {
    logistic(x, s) * inv_norm
}

/// `1 / (cdf(π) - cdf(-π))` for the trimmed logistic of scale `s`.
#[inline]
pub fn trimmed_logistic_inv_norm<T: Real>(s: T) -> T {
    T::ONE / (logistic_cdf(T::PI, s) - logistic_cdf(-T::PI, s))
}

/// Inverts the trimmed logistic CDF: `u ∈ [0, 1]` to `x ∈ [-π, π]`.
#[inline]
pub fn trimmed_logistic_sample<T: Real>(u: T, s: T) -> T {
    let lo = logistic_cdf(-T::PI, s);
    let k = logistic_cdf(T::PI, s) - lo;
    let x = -s * (T::ONE / (u * k + lo) - T::ONE).ln();
    x.max(-T::PI).min(T::PI)
}

/// Cell index and fraction of `x` ∈ [0, 1] (clamped) on a uniform grid of
/// `n ≥ 2` nodes: linear interpolation between nodes `k` and `k + 1`.
#[inline(always)]
pub fn grid_cell(x: f32, n: usize) -> (usize, f32) {
    let t = x.clamp(0.0, 1.0) * (n - 1) as f32;
    let k = (t as usize).min(n - 2);
    (k, t - k as f32)
}

// ---------------------------------------------------------------------------
// Rounding without a library call
// ---------------------------------------------------------------------------
//
// The crate is built for the baseline x86-64 target (SSE2), which has no
// rounding instruction: `f32::floor`, `f32::ceil` and `f64::fract` are calls
// to software routines there, 3 % of a `balanced` frame in the tile loop,
// the shadow-ray walk and the count lookups. These are the same functions,
// equal to the `std` ones for every input (±0, NaN, infinities, values past
// 2^23 or 2^52, which are already integers), inlined: a conversion to an
// integer, which truncates, and a correction.

/// `x.floor()`, equal for every `f32`, inlined.
#[inline(always)]
pub fn floor(x: f32) -> f32 {
    // below 2^23 a float may have a fraction, and fits an i32
    if x.abs() < 8_388_608.0 {
        let i = (x as i32) as f32;
        // (copysign: -0.0 stays -0.0)
        (if i > x { i - 1.0 } else { i }).copysign(x)
    } else {
        x
    }
}

/// `v.floor()` per component, equal for every `Vec3`, inlined.
#[inline(always)]
pub fn floor3(v: glam::Vec3) -> glam::Vec3 {
    glam::Vec3::new(floor(v.x), floor(v.y), floor(v.z))
}

/// `x.ceil()`, equal for every `f32`, inlined.
#[inline(always)]
pub fn ceil(x: f32) -> f32 {
    -floor(-x)
}

/// `x.fract()` (`x − trunc(x)`), equal for every `f64`, inlined.
#[inline(always)]
pub fn fract(x: f64) -> f64 {
    // below 2^52 a double may have a fraction, and fits an i64
    let trunc = if x.abs() < 4_503_599_627_370_496.0 {
        ((x as i64) as f64).copysign(x)
    } else {
        x
    };
    x - trunc
}

/// Wraps an angle into [-π, π].
#[inline(always)]
pub fn wrap_pi<T: Real>(x: T) -> T {
    (x + T::PI).rem_euclid(T::TWO_PI) - T::PI
}

// ---------------------------------------------------------------------------
// Gauss–Legendre quadrature
// ---------------------------------------------------------------------------

/// Nodes and weights of the n-point Gauss–Legendre rule on [-1, 1], by
/// Newton iteration on the Legendre recurrence (nodes to full f64 precision).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1, "Gauss-Legendre needs at least one node");
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let m = n.div_ceil(2);
    for i in 0..m {
        // Tricomi's initial guess for the i-th root.
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (p, d) = legendre_with_derivative(n, z);
            dp = d;
            let dz = p / d;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_with_derivative(n, z);
        dp = if d != 0.0 { d } else { dp };
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    (x, w)
}

/// `(P_n(z), P_n'(z))` by the three-term recurrence.
fn legendre_with_derivative(n: usize, z: f64) -> (f64, f64) {
    let mut p0 = 1.0;
    let mut p1 = z;
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (z * p1 - p0) / (z * z - 1.0);
    (p1, d)
}

// ---------------------------------------------------------------------------
// Adaptive Gauss–Kronrod quadrature
// ---------------------------------------------------------------------------

/// Kronrod 15-point abscissae on [0, 1] (the negatives mirror them); the odd
/// indices are the 7-point Gauss abscissae.
const XGK15: [f64; 8] = [
    0.991_455_371_120_812_639_206_854_697_526_329,
    0.949_107_912_342_758_524_526_189_684_047_851,
    0.864_864_423_359_769_072_789_712_788_640_926,
    0.741_531_185_599_394_439_863_864_773_280_788,
    0.586_087_235_467_691_130_294_144_845_693_013,
    0.405_845_151_377_397_166_906_606_412_076_961,
    0.207_784_955_007_898_467_600_689_403_773_245,
    0.0,
];
const WGK15: [f64; 8] = [
    0.022_935_322_010_529_224_963_732_008_058_970,
    0.063_092_092_629_978_553_290_700_663_189_204,
    0.104_790_010_322_250_183_839_876_322_541_518,
    0.140_653_259_715_525_918_745_189_590_510_238,
    0.169_004_726_639_267_902_826_583_426_598_550,
    0.190_350_578_064_785_409_913_256_402_421_014,
    0.204_432_940_075_298_892_414_161_999_234_649,
    0.209_482_141_084_727_828_012_999_174_891_714,
];
/// 7-point Gauss weights at XGK15[1], [3], [5], [7].
const WG7: [f64; 4] = [
    0.129_484_966_168_869_693_270_611_432_679_082,
    0.279_705_391_489_276_667_901_467_771_423_780,
    0.381_830_050_505_118_944_950_369_775_488_975,
    0.417_959_183_673_469_387_755_102_040_816_327,
];

/// `(Kronrod estimate, |Kronrod − Gauss|)` of ∫_a^b f, componentwise.
#[inline]
pub fn gauss_kronrod15<T: Real, const N: usize>(
    f: &mut impl FnMut(T) -> [T; N],
    a: T,
    b: T,
) -> ([T; N], [T; N]) {
    let c = T::HALF * (a + b);
    let h = T::HALF * (b - a);
    let fc = f(c);
    let mut k = fc.map(|x| x * T::from_f64(WGK15[7]));
    let mut g = fc.map(|x| x * T::from_f64(WG7[3]));
    for j in 0..7 {
        let dx = h * T::from_f64(XGK15[j]);
        let (l, r) = (f(c - dx), f(c + dx));
        for n in 0..N {
            let s = l[n] + r[n];
            k[n] += s * T::from_f64(WGK15[j]);
            if j % 2 == 1 {
                g[n] += s * T::from_f64(WG7[j / 2]);
            }
        }
    }
    (
        k.map(|x| x * h),
        std::array::from_fn(|n| ((k[n] - g[n]) * h).abs()),
    )
}

/// ∫ f (N components) over the union of the intervals between consecutive
/// `breaks` (sorted), refined adaptively: the interval with the largest error
/// estimate is halved until every component's summed error is below
/// `max(abs_tol, rel_tol·|I|)` or `max_intervals` is reached.
/// Returns `(I, error estimate)`.
pub fn integrate_adaptive<T: Real, const N: usize>(
    mut f: impl FnMut(T) -> [T; N],
    breaks: &[T],
    rel_tol: T,
    abs_tol: T,
    max_intervals: usize,
) -> ([T; N], [T; N]) {
    struct Part<T, const N: usize> {
        a: T,
        b: T,
        i: [T; N],
        e: [T; N],
    }
    let mut parts: Vec<Part<T, N>> = Vec::with_capacity(breaks.len() + 32);
    for w in breaks.windows(2) {
        if w[1] > w[0] {
            let (i, e) = gauss_kronrod15(&mut f, w[0], w[1]);
            parts.push(Part {
                a: w[0],
                b: w[1],
                i,
                e,
            });
        }
    }
    loop {
        let mut total = [T::ZERO; N];
        let mut err = [T::ZERO; N];
        for p in &parts {
            for n in 0..N {
                total[n] += p.i[n];
                err[n] += p.e[n];
            }
        }
        // The component furthest beyond its tolerance decides what to refine.
        let mut worst_n = 0;
        let mut worst_ratio = T::ZERO;
        for n in 0..N {
            let tol = abs_tol.max(rel_tol * total[n].abs());
            let ratio = if tol > T::ZERO {
                err[n] / tol
            } else if err[n] > T::ZERO {
                T::MAX
            } else {
                T::ZERO
            };
            if ratio > worst_ratio {
                worst_ratio = ratio;
                worst_n = n;
            }
        }
        if parts.is_empty() || worst_ratio <= T::ONE || parts.len() >= max_intervals {
            return (total, err);
        }
        let mut worst = 0;
        for (k, p) in parts.iter().enumerate() {
            if p.e[worst_n] > parts[worst].e[worst_n] {
                worst = k;
            }
        }
        let (a, b) = (parts[worst].a, parts[worst].b);
        let m = T::HALF * (a + b);
        if !(m > a && m < b) {
            return (total, err); // cannot split further at this precision
        }
        let (i1, e1) = gauss_kronrod15(&mut f, a, m);
        let (i2, e2) = gauss_kronrod15(&mut f, m, b);
        parts[worst] = Part {
            a,
            b: m,
            i: i1,
            e: e1,
        };
        parts.push(Part {
            a: m,
            b,
            i: i2,
            e: e2,
        });
    }
}

#[cfg(test)]
mod tests;
