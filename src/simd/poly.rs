//! Polynomial and range-reduction constants of the lane functions: `exp`'s
//! polynomial, `atan2`, `wrap_pi`, and I0 (small- and large-argument
//! polynomials); fitted coefficients from `scripts/fit_simd_polys.py`.

use super::Lanes;

/// Round-to-nearest shifter `1.5·2^23` (exact for |x| < 2^22): the integer
/// lands in the mantissa's low bits.
pub(super) const SHIFTER: f32 = 12_582_912.0;
/// Bits of [`SHIFTER`].
pub(super) const SHIFTER_BITS: i32 = 0x4B40_0000;
/// ln 2 split so that n·LN2_HI is exact (LN2_HI has 10 significant bits;
/// it is not an approximation of ln 2 but its leading part).
#[allow(clippy::approx_constant)]
pub(super) const LN2_HI: f32 = 0.693_359_4;
pub(super) const LN2_LO: f32 = -2.121_944_4e-4;

/// `(e^r − 1 − r)/r²` as a polynomial in r on `|r| ≤ ½ ln 2`, fitted in the
/// relative error of `e^r` (1.2e-7 in f64 with these f32 coefficients).
const EXPM: [f32; 4] = [0.499_991_4, 0.166_668_86, 0.041_898_578, 0.008_333_838];

/// `e^r` for `|r| ≤ ½ ln 2`: `1 + r + r² P(r)`.
#[inline(always)]
pub(super) fn expm_poly<V: Lanes>(r: V) -> V {
    let c = V::splat;
    let mut p = c(EXPM[3]);
    p = p.mul_add(r, c(EXPM[2]));
    p = p.mul_add(r, c(EXPM[1]));
    p = p.mul_add(r, c(EXPM[0]));
    p.mul_add(r * r, r + 1.0)
}

// ---------------------------------------------------------------------------
// Special functions of the vector kernels
// ---------------------------------------------------------------------------
//
// Polynomial coefficients: `scripts/fit_simd_polys.py` (least squares on
// Chebyshev nodes against numpy/scipy in f64); the tests below measure the
// f32 evaluation against f64.

/// `atan(a)/a` as a polynomial in `a²` on [0, 1] (absolute error of
/// `a·P(a²)` ≤ 1.2e-8 in f64).
const ATAN: [f32; 9] = [
    1.0,
    -0.333_330_66,
    0.199_924_84,
    -0.142_025_71,
    0.106_367_54,
    -0.074_954_46,
    0.042_587_608,
    -0.016_005_03,
    0.002_834_064_2,
];

/// `atan2(y, x)` in [-π, π] (absolute error ≤ 3e-7, measured in the tests);
/// `atan2(0, 0) = 0`; NaN in, NaN out.
#[inline(always)]
pub(crate) fn atan2<V: Lanes>(y: V, x: V) -> V {
    let r = atan2_finite(y, x);
    // NaN lanes: min/max in atan2_finite dropped them; give them back.
    V::select(x.is_nan(), x, V::select(y.is_nan(), y, r))
}

/// [`atan2`] for finite `y` and `x` (NaN in gives an unspecified value):
/// for kernels that mask their non-finite inputs off.
#[inline(always)]
pub(crate) fn atan2_finite<V: Lanes>(y: V, x: V) -> V {
    let c = V::splat;
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // a = lo/hi in [0, 1]; hi = 0 only when both are 0.
    let a = V::select(hi.gt(c(0.0)), lo / hi, c(0.0));
    let s = a * a;
    let mut p = c(ATAN[8]);
    for &k in ATAN[..8].iter().rev() {
        p = p.mul_add(s, c(k));
    }
    let r = a * p;
    let r = V::select(ay.gt(ax), c(std::f32::consts::FRAC_PI_2) - r, r);
    let r = V::select(x.lt(c(0.0)), c(std::f32::consts::PI) - r, r);
    V::select(y.lt(c(0.0)), -r, r)
}

/// `x − 2πk` in [-π, π] for the nearest integer k (|x| < 2^20).
#[inline(always)]
pub(crate) fn wrap_pi<V: Lanes>(x: V) -> V {
    let c = V::splat;
    let k = x.mul_add(c(0.5 * std::f32::consts::FRAC_1_PI), c(SHIFTER)) - SHIFTER;
    // 2π split so that k·TWO_PI_HI is exact for |k| < 2^11.
    k.mul_add(c(-TWO_PI_HI), x) - k * TWO_PI_LO
}

/// Leading part of 2π (12 significant bits) and the rest.
const TWO_PI_HI: f32 = 6.283_203;
const TWO_PI_LO: f32 = (std::f64::consts::TAU - TWO_PI_HI as f64) as f32;

/// Below this argument [`i0_small`] evaluates I0, above it [`i0e_large`].
pub(crate) const I0_SWITCH: f32 = 6.0;

/// `I0(x)` for `x ≤ I0_SWITCH` as a polynomial in `q = x²/4` (relative error
/// 1.2e-8 in f64; the power series `Σ q^k/(k!)²` would need 12 terms).
const I0_SMALL: [f32; 9] = [
    1.0,
    0.999_999_9,
    0.250_000_42,
    0.027_777_128,
    0.001_736_594_6,
    6.925_241e-5,
    1.971_910_5e-6,
    3.401_397_2e-8,
    9.553_16e-10,
];

/// I0(x) for `x ≤ I0_SWITCH`, from `q = x²/4`.
#[inline(always)]
pub(crate) fn i0_small<V: Lanes>(q: V) -> V {
    let mut p = V::splat(I0_SMALL[8]);
    for &k in I0_SMALL[..8].iter().rev() {
        p = p.mul_add(q, V::splat(k));
    }
    p
}

/// `√x · e^{-x} I0(x)` as a polynomial in `u = I0_SWITCH/x` on (0, 1]
/// (relative error 2e-8 in f64).
const I0E_LARGE: [f32; 7] = [
    0.398_942_3,
    0.008_311_518,
    0.000_776_582_8,
    0.000_144_878_77,
    2.508_355_3e-5,
    5.454_654e-7,
    2.479_454e-5,
];

/// `e^{-x} I0(x)` for `x > I0_SWITCH`.
#[inline(always)]
pub(crate) fn i0e_large<V: Lanes>(x: V) -> V {
    let r = x.rsqrt();
    let u = r * r * I0_SWITCH;
    let mut p = V::splat(I0E_LARGE[6]);
    for &k in I0E_LARGE[..6].iter().rev() {
        p = p.mul_add(u, V::splat(k));
    }
    p * r
}
