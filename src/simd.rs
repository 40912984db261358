//! Lane-parallel `f32` arithmetic for the vector kernels, with runtime CPU
//! dispatch.
//!
//! A kernel is written once, generic over [`Lanes`], and compiled three
//! times: with [`F16`] (AVX-512F, 16 lanes), [`F8`] (AVX2 + FMA, 8 lanes),
//! each inside a `#[target_feature]` function so the intrinsics inline to
//! single instructions, and with the portable [`F<4>`] (plain arrays the
//! compiler vectorizes with the baseline ISA: SSE2 on x86-64, NEON on
//! aarch64). [`Level::detect`] picks at run time which copy runs, so a wheel
//! built for generic x86-64 uses AVX-512 where the CPU has it.
//!
//! There are no branches per lane: both sides are computed and
//! [`Lanes::select`] blends them.
//!
//! [`Lanes::exp`] is the Cephes `expf` polynomial (relative error ≤ 2 ulp on
//! `[-87.3, 88.7]`, measured against f64 in the tests), flushing results below
//! `2^-126` to 0 (the scalar path returns denormals there: an absolute
//! difference below 1.2e-38), `+inf` above 88.72, NaN to NaN.

use std::ops::{Add, BitAnd, Div, Mul, Neg, Sub};

/// The instruction set a vector kernel runs with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// 16 lanes, AVX-512F (+ AVX2, FMA).
    Avx512,
    /// 8 lanes, AVX2 + FMA.
    Avx2,
    /// 4 lanes in the target's baseline ISA.
    Portable,
}

impl Level {
    /// The best level this CPU supports, once per process; the environment
    /// variable `HAIRSHADE_SIMD` (`avx512`, `avx2`, `portable`) lowers it
    /// (for measurements and tests), never above what the CPU has.
    pub fn detect() -> Level {
        static LEVEL: std::sync::OnceLock<Level> = std::sync::OnceLock::new();
        *LEVEL.get_or_init(|| {
            let best = Self::cpu_best();
            match std::env::var("HAIRSHADE_SIMD").ok().as_deref() {
                Some("portable") => Level::Portable,
                Some("avx2") => Level::Avx2.min_with(best),
                _ => best,
            }
        })
    }

    fn cpu_best() -> Level {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma");
            if avx2 && std::arch::is_x86_feature_detected!("avx512f") {
                return Level::Avx512;
            }
            if avx2 {
                return Level::Avx2;
            }
        }
        Level::Portable
    }

    /// The lower of two levels.
    pub fn min_with(self, other: Level) -> Level {
        let rank = |l: Level| match l {
            Level::Portable => 0,
            Level::Avx2 => 1,
            Level::Avx512 => 2,
        };
        if rank(self) <= rank(other) {
            self
        } else {
            other
        }
    }

    /// Name for reports (`avx512`, `avx2`, `portable`).
    pub fn name(self) -> &'static str {
        match self {
            Level::Avx512 => "avx512",
            Level::Avx2 => "avx2",
            Level::Portable => "portable",
        }
    }
}

/// `N` lanes of `f32`. Only ever used inside functions compiled for the
/// matching [`Level`] (the implementations call that level's intrinsics).
pub trait Lanes:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f32, Output = Self>
    + Sub<f32, Output = Self>
    + Mul<f32, Output = Self>
{
    const N: usize;
    type Mask: Copy + BitAnd<Output = Self::Mask>;

    fn splat(x: f32) -> Self;
    /// Lanes from `s[..N]`.
    fn load(s: &[f32]) -> Self;
    /// Lanes into `s[..N]`.
    fn store(self, s: &mut [f32]);
    fn sqrt(self) -> Self;
    /// `self · a + b` (fused where the level has FMA).
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// `if a > b { a } else { b }` per lane (`b` where `a` is NaN).
    fn max(self, b: Self) -> Self;
    /// `if a < b { a } else { b }` per lane (`b` where `a` is NaN).
    fn min(self, b: Self) -> Self;
    fn lt(self, b: Self) -> Self::Mask;
    fn gt(self, b: Self) -> Self::Mask;
    fn le(self, b: Self) -> Self::Mask;
    /// Lanes that are NaN.
    fn is_nan(self) -> Self::Mask;
    /// Lane-wise `if m { a } else { b }`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Whether every lane of `m` is set.
    fn all(m: Self::Mask) -> bool;
    /// `self · 2^n` where `n = bits(shifted) − bits(1.5·2^23)`, `n ∈ [-126, 128]`
    /// (the integer [`Lanes::exp`] rounds to, read from the float's bits).
    fn scale_pow2(self, shifted: Self) -> Self;

    #[inline(always)]
    fn abs(self) -> Self {
        self.max(-self)
    }

    /// `min(max(self, lo), hi)`; NaN lanes become `hi`.
    #[inline(always)]
    fn clamp(self, lo: f32, hi: f32) -> Self {
        self.max(Self::splat(lo)).min(Self::splat(hi))
    }

    /// Lanes that are neither infinite nor NaN.
    #[inline(always)]
    fn is_finite(self) -> Self::Mask {
        self.abs().le(Self::splat(f32::MAX))
    }

    /// `x^5`.
    #[inline(always)]
    fn pow5(self) -> Self {
        let x2 = self * self;
        x2 * x2 * self
    }

    /// `e^x` for `x ≤ 88` (the exponents of normalized lobes): as
    /// [`Lanes::exp`] with NaN passed through by the clamps' operand order,
    /// but no special cases: `x < -87.3` gives a value ≤ 2^-126 (absolute
    /// error < 1.2e-38) instead of 0, and `x > 88` is not allowed.
    #[inline(always)]
    fn exp_bounded(self) -> Self {
        let c = Self::splat;
        // min/max return `self` where it is NaN (see their contract).
        let xc = c(88.0).min(self);
        let xc = c(-87.33).max(xc);
        let shifted = xc.mul_add(c(std::f32::consts::LOG2_E), c(SHIFTER));
        let n = shifted - SHIFTER;
        let r = n.mul_add(c(-LN2_HI), xc);
        let r = n.mul_add(c(-LN2_LO), r);
        expm_poly(r).scale_pow2_small(shifted)
    }

    /// `self · 2^n`, `n ∈ [-126, 127]`, `n` read from `shifted` as in
    /// [`Lanes::scale_pow2`].
    fn scale_pow2_small(self, shifted: Self) -> Self;

    /// `e^x` (Cephes `expf`): `x = n ln2 + r`, `|r| ≤ ½ ln2`, a degree-7
    /// polynomial in r, times `2^n` built in the exponent bits.
    #[inline(always)]
    fn exp(self) -> Self {
        let c = Self::splat;
        // NaN lanes clamp to the lower bound here and are restored below.
        let xc = self.min(c(88.72)).max(c(-87.34));
        let shifted = xc.mul_add(c(std::f32::consts::LOG2_E), c(SHIFTER));
        let n = shifted - SHIFTER;
        let r = n.mul_add(c(-LN2_HI), xc);
        let r = n.mul_add(c(-LN2_LO), r);
        let e = expm_poly(r);
        let v = e.scale_pow2(shifted);
        let v = Self::select(self.lt(Self::splat(-87.33)), Self::splat(0.0), v);
        let v = Self::select(self.gt(Self::splat(88.72)), Self::splat(f32::INFINITY), v);
        Self::select(self.is_nan(), self, v)
    }
}

/// Round-to-nearest shifter `1.5·2^23` (exact for |x| < 2^22): the integer
/// lands in the mantissa's low bits.
const SHIFTER: f32 = 12_582_912.0;
/// Bits of [`SHIFTER`].
const SHIFTER_BITS: i32 = 0x4B40_0000;
/// ln 2 split so that n·LN2_HI is exact (LN2_HI has 10 significant bits;
/// it is not an approximation of ln 2 but its leading part).
#[allow(clippy::approx_constant)]
const LN2_HI: f32 = 0.693_359_4;
const LN2_LO: f32 = -2.121_944_4e-4;

/// `e^r` for `|r| ≤ ½ ln 2`: Cephes `expf`'s polynomial.
#[inline(always)]
fn expm_poly<V: Lanes>(r: V) -> V {
    let c = V::splat;
    let mut p = c(1.987_569_1e-4);
    p = p.mul_add(r, c(1.398_199_9e-3));
    p = p.mul_add(r, c(8.333_452e-3));
    p = p.mul_add(r, c(4.166_579_6e-2));
    p = p.mul_add(r, c(0.166_666_65));
    p = p.mul_add(r, c(0.5));
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
    let r = V::select(y.lt(c(0.0)), -r, r);
    // NaN lanes: min/max above dropped them; give them back.
    V::select(x.is_nan(), x, V::select(y.is_nan(), y, r))
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

/// Below this argument [`i0_series`] evaluates I0, above it [`i0e_large`].
pub(crate) const I0_SWITCH: f32 = 6.0;

/// `1/(k!)²`, k = 0..=11: the power series of I0 in `q = x²/4` (relative
/// truncation error below 2e-8 for x ≤ [`I0_SWITCH`]).
const I0_SERIES: [f32; 12] = {
    let mut t = [0.0f32; 12];
    let mut f = 1.0f64;
    let mut k = 0;
    while k < 12 {
        if k > 0 {
            f *= k as f64;
        }
        t[k] = (1.0 / (f * f)) as f32;
        k += 1;
    }
    t
};

/// I0(x) for `x ≤ I0_SWITCH`, from `q = x²/4` (all terms positive: a few
/// ulps).
#[inline(always)]
pub(crate) fn i0_series<V: Lanes>(q: V) -> V {
    let mut p = V::splat(I0_SERIES[11]);
    for &k in I0_SERIES[..11].iter().rev() {
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
    let u = V::splat(I0_SWITCH) / x;
    let mut p = V::splat(I0E_LARGE[6]);
    for &k in I0E_LARGE[..6].iter().rev() {
        p = p.mul_add(u, V::splat(k));
    }
    p / x.sqrt()
}

/// Helpers shared by the vector kernels' tests.
#[cfg(test)]
pub(crate) mod testing {
    use super::Level;

    /// `3n` components uniform in [-1, 1) (xorshift64*): directions, not
    /// normalized.
    pub(crate) fn directions(n: usize, seed: u64) -> Vec<f32> {
        let mut s = seed;
        let mut next = move || {
            s ^= s >> 12;
            s ^= s << 25;
            s ^= s >> 27;
            (s.wrapping_mul(0x2545F4914F6CDD1D) >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        (0..3 * n).map(|_| next()).collect()
    }

    /// Direction `i` of a flat f32 array, normalized in f64.
    pub(crate) fn unit64(a: &[f32], i: usize) -> [f64; 3] {
        let w = [a[3 * i] as f64, a[3 * i + 1] as f64, a[3 * i + 2] as f64];
        let len = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        w.map(|x| x / len)
    }

    /// The levels this CPU can run, lowest first.
    pub(crate) fn levels() -> Vec<Level> {
        let mut l = vec![Level::Portable];
        if Level::detect() != Level::Portable {
            l.push(Level::Avx2);
        }
        if Level::detect() == Level::Avx512 {
            l.push(Level::Avx512);
        }
        l
    }
}

// ---------------------------------------------------------------------------
// Records in and out of lanes
// ---------------------------------------------------------------------------

/// Dot product of two lane-vectors of 3D points.
#[inline(always)]
pub(crate) fn dot<V: Lanes>(a: &[V; 3], b: &[V; 3]) -> V {
    a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]))
}

/// Lanes `base..base+count` (`count ≤ N`) of a flat array of `W`-wide
/// records (or of its one broadcast record), de-interleaved; lanes past
/// `count` are 0.
#[inline(always)]
pub(crate) fn load<V: Lanes, const W: usize>(a: &[f32], base: usize, count: usize) -> [V; W] {
    let mut out = [V::splat(0.0); W];
    if a.len() == W {
        for c in 0..W {
            out[c] = V::splat(a[c]);
        }
        return out;
    }
    let mut buf = [[0.0f32; 16]; W];
    let s = &a[W * base..W * (base + count)];
    for j in 0..count.min(16) {
        for c in 0..W {
            buf[c][j] = s[W * j + c];
        }
    }
    for c in 0..W {
        out[c] = V::load(&buf[c]);
    }
    out
}

/// Directions as [`load`], normalized as `frame::normalized`; lanes past
/// `count` and degenerate directions are masked off.
#[inline(always)]
pub(crate) fn load_dir<V: Lanes>(a: &[f32], base: usize, count: usize) -> ([V; 3], V::Mask) {
    let w = load::<V, 3>(a, base, count);
    let d = dot(&w, &w);
    let ok = w[0].is_finite() & w[1].is_finite() & w[2].is_finite();
    // |w|² in the normal range in every lane (almost always): one square
    // root; otherwise scale by the largest component first.
    // (No closures here or in the kernels: a closure is compiled without
    // the caller's target features, and its intrinsics become calls.)
    // A lane's result depends on that lane alone (not on which path its
    // neighbours need), so a direction normalizes the same in any batch.
    let normal = d.gt(V::splat(1e-30)) & d.lt(V::splat(1e30));
    let inv = V::splat(1.0) / d.sqrt();
    let fast = [w[0] * inv, w[1] * inv, w[2] * inv];
    if V::all(normal) {
        return (fast, ok);
    }
    let m = w[0].abs().max(w[1].abs()).max(w[2].abs());
    let ok = ok & m.gt(V::splat(0.0));
    let inv_m = V::splat(1.0) / m;
    let s = [w[0] * inv_m, w[1] * inv_m, w[2] * inv_m];
    let inv = V::splat(1.0) / dot(&s, &s).sqrt();
    (
        [
            V::select(normal, fast[0], s[0] * inv),
            V::select(normal, fast[1], s[1] * inv),
            V::select(normal, fast[2], s[2] * inv),
        ],
        ok,
    )
}

/// Writes lanes `..count` of `W`-wide records into `o` (`o.len() == W·count`).
#[inline(always)]
pub(crate) fn store<V: Lanes, const W: usize>(o: &mut [f32], x: &[V; W], count: usize) {
    let mut buf = [[0.0f32; 16]; W];
    for c in 0..W {
        x[c].store(&mut buf[c]);
    }
    let o = &mut o[..W * count];
    for j in 0..count.min(16) {
        for c in 0..W {
            o[W * j + c] = buf[c][j];
        }
    }
}

/// `N` lanes as a plain array (the portable level).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F<const N: usize>(pub [f32; N]);

/// Masks of [`F`]: `-1` (true) or `0` (false).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct M<const N: usize>(pub [i32; N]);

impl<const N: usize> F<N> {
    #[inline(always)]
    fn map(self, f: impl Fn(f32) -> f32) -> Self {
        let mut o = self.0;
        for x in o.iter_mut() {
            *x = f(*x);
        }
        Self(o)
    }

    #[inline(always)]
    fn zip(self, b: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        let mut o = self.0;
        for i in 0..N {
            o[i] = f(self.0[i], b.0[i]);
        }
        Self(o)
    }

    #[inline(always)]
    fn cmp(self, b: Self, f: impl Fn(f32, f32) -> bool) -> M<N> {
        let mut o = [0i32; N];
        for i in 0..N {
            o[i] = -(f(self.0[i], b.0[i]) as i32);
        }
        M(o)
    }
}

impl<const N: usize> BitAnd for M<N> {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, b: Self) -> Self {
        let mut o = self.0;
        for i in 0..N {
            o[i] &= b.0[i];
        }
        M(o)
    }
}

impl<const N: usize> Lanes for F<N> {
    const N: usize = N;
    type Mask = M<N>;

    #[inline(always)]
    fn splat(x: f32) -> Self {
        Self([x; N])
    }
    #[inline(always)]
    fn load(s: &[f32]) -> Self {
        let mut o = [0.0; N];
        o.copy_from_slice(&s[..N]);
        Self(o)
    }
    #[inline(always)]
    fn store(self, s: &mut [f32]) {
        s[..N].copy_from_slice(&self.0);
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f32::sqrt)
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        self * a + b
    }
    #[inline(always)]
    fn abs(self) -> Self {
        self.map(|x| f32::from_bits(x.to_bits() & 0x7fff_ffff))
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        self.zip(b, |a, b| if a > b { a } else { b })
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        self.zip(b, |a, b| if a < b { a } else { b })
    }
    #[inline(always)]
    fn lt(self, b: Self) -> M<N> {
        self.cmp(b, |a, b| a < b)
    }
    #[inline(always)]
    fn gt(self, b: Self) -> M<N> {
        self.cmp(b, |a, b| a > b)
    }
    #[inline(always)]
    fn le(self, b: Self) -> M<N> {
        self.cmp(b, |a, b| a <= b)
    }
    #[inline(always)]
    fn is_nan(self) -> M<N> {
        self.cmp(self, |a, b| a != b)
    }
    #[inline(always)]
    fn select(m: M<N>, a: Self, b: Self) -> Self {
        let mut o = b.0;
        for i in 0..N {
            if m.0[i] != 0 {
                o[i] = a.0[i];
            }
        }
        F(o)
    }
    #[inline(always)]
    fn all(m: M<N>) -> bool {
        m.0.iter().all(|&x| x != 0)
    }
    #[inline(always)]
    fn scale_pow2(self, shifted: Self) -> Self {
        let mut o = self.0;
        for i in 0..N {
            let n = (shifted.0[i].to_bits() as i32).wrapping_sub(SHIFTER_BITS);
            // two factors so that n = 128 stays representable
            let half = n >> 1;
            let s1 = f32::from_bits(((half + 127) << 23) as u32);
            let s2 = f32::from_bits(((n - half + 127) << 23) as u32);
            o[i] = o[i] * s1 * s2;
        }
        Self(o)
    }
    #[inline(always)]
    fn scale_pow2_small(self, shifted: Self) -> Self {
        let mut o = self.0;
        for i in 0..N {
            let n = (shifted.0[i].to_bits() as i32).wrapping_sub(SHIFTER_BITS);
            o[i] *= f32::from_bits(((n + 127) << 23) as u32);
        }
        Self(o)
    }
}

macro_rules! f_binop {
    ($ty:ty, [$($gen:tt)*], $tr:ident, $f:ident, $op:tt, $vec:expr, $sc:expr) => {
        impl<$($gen)*> $tr for $ty {
            type Output = Self;
            #[inline(always)]
            fn $f(self, b: Self) -> Self {
                $vec(self, b)
            }
        }
        impl<$($gen)*> $tr<f32> for $ty {
            type Output = Self;
            #[inline(always)]
            fn $f(self, b: f32) -> Self {
                $vec(self, <$ty as Lanes>::splat(b))
            }
        }
    };
}

f_binop!(F<N>, [const N: usize], Add, add, +, |a: F<N>, b: F<N>| a.zip(b, |x, y| x + y), ());
f_binop!(F<N>, [const N: usize], Sub, sub, -, |a: F<N>, b: F<N>| a.zip(b, |x, y| x - y), ());
f_binop!(F<N>, [const N: usize], Mul, mul, *, |a: F<N>, b: F<N>| a.zip(b, |x, y| x * y), ());
f_binop!(F<N>, [const N: usize], Div, div, /, |a: F<N>, b: F<N>| a.zip(b, |x, y| x / y), ());

impl<const N: usize> Neg for F<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|x| -x)
    }
}

#[cfg(target_arch = "x86_64")]
pub use x86::{F16, F8};

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! AVX2 and AVX-512 lanes. SAFETY (every `unsafe` block here): the
    //! intrinsics need AVX2+FMA / AVX-512F, and these types are only used
    //! inside functions compiled with those features, which run only after
    //! [`super::Level::detect`] found them on the CPU.
    use super::{Lanes, SHIFTER_BITS};
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, Div, Mul, Neg, Sub};

    /// 8 lanes in a `__m256` (AVX2 + FMA).
    #[derive(Clone, Copy)]
    pub struct F8(__m256);
    /// Mask of [`F8`]: all-ones / all-zeros lanes.
    #[derive(Clone, Copy)]
    pub struct M8(__m256);

    impl BitAnd for M8 {
        type Output = Self;
        #[inline(always)]
        fn bitand(self, b: Self) -> Self {
            unsafe { M8(_mm256_and_ps(self.0, b.0)) }
        }
    }

    impl Lanes for F8 {
        const N: usize = 8;
        type Mask = M8;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            unsafe { F8(_mm256_set1_ps(x)) }
        }
        #[inline(always)]
        fn load(s: &[f32]) -> Self {
            assert!(s.len() >= 8);
            unsafe { F8(_mm256_loadu_ps(s.as_ptr())) }
        }
        #[inline(always)]
        fn store(self, s: &mut [f32]) {
            assert!(s.len() >= 8);
            unsafe { _mm256_storeu_ps(s.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            unsafe { F8(_mm256_sqrt_ps(self.0)) }
        }
        #[inline(always)]
        fn mul_add(self, a: Self, b: Self) -> Self {
            unsafe { F8(_mm256_fmadd_ps(self.0, a.0, b.0)) }
        }
        #[inline(always)]
        fn abs(self) -> Self {
            unsafe { F8(_mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0)) }
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            // maxps(a, b) = a > b ? a : b, so a NaN `a` gives `b`
            unsafe { F8(_mm256_max_ps(self.0, b.0)) }
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            unsafe { F8(_mm256_min_ps(self.0, b.0)) }
        }
        #[inline(always)]
        fn lt(self, b: Self) -> M8 {
            unsafe { M8(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, b.0)) }
        }
        #[inline(always)]
        fn gt(self, b: Self) -> M8 {
            unsafe { M8(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, b.0)) }
        }
        #[inline(always)]
        fn le(self, b: Self) -> M8 {
            unsafe { M8(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, b.0)) }
        }
        #[inline(always)]
        fn is_nan(self) -> M8 {
            unsafe { M8(_mm256_cmp_ps::<_CMP_UNORD_Q>(self.0, self.0)) }
        }
        #[inline(always)]
        fn select(m: M8, a: Self, b: Self) -> Self {
            unsafe { F8(_mm256_blendv_ps(b.0, a.0, m.0)) }
        }
        #[inline(always)]
        fn all(m: M8) -> bool {
            unsafe { _mm256_movemask_ps(m.0) == 0xff }
        }
        #[inline(always)]
        fn scale_pow2(self, shifted: Self) -> Self {
            unsafe {
                let n = _mm256_sub_epi32(
                    _mm256_castps_si256(shifted.0),
                    _mm256_set1_epi32(SHIFTER_BITS),
                );
                let half = _mm256_srai_epi32::<1>(n);
                let bias = _mm256_set1_epi32(127);
                let s1 = _mm256_slli_epi32::<23>(_mm256_add_epi32(half, bias));
                let s2 = _mm256_slli_epi32::<23>(_mm256_add_epi32(_mm256_sub_epi32(n, half), bias));
                F8(_mm256_mul_ps(
                    _mm256_mul_ps(self.0, _mm256_castsi256_ps(s1)),
                    _mm256_castsi256_ps(s2),
                ))
            }
        }
        #[inline(always)]
        fn scale_pow2_small(self, shifted: Self) -> Self {
            unsafe {
                // (bits(shifted) − SHIFTER_BITS + 127) << 23
                let e = _mm256_add_epi32(
                    _mm256_castps_si256(shifted.0),
                    _mm256_set1_epi32(127 - SHIFTER_BITS),
                );
                F8(_mm256_mul_ps(
                    self.0,
                    _mm256_castsi256_ps(_mm256_slli_epi32::<23>(e)),
                ))
            }
        }
    }

    /// 16 lanes in a `__m512` (AVX-512F).
    #[derive(Clone, Copy)]
    pub struct F16(__m512);
    /// Mask of [`F16`]: one bit per lane.
    #[derive(Clone, Copy)]
    pub struct M16(__mmask16);

    impl BitAnd for M16 {
        type Output = Self;
        #[inline(always)]
        fn bitand(self, b: Self) -> Self {
            M16(self.0 & b.0)
        }
    }

    impl Lanes for F16 {
        const N: usize = 16;
        type Mask = M16;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            unsafe { F16(_mm512_set1_ps(x)) }
        }
        #[inline(always)]
        fn load(s: &[f32]) -> Self {
            assert!(s.len() >= 16);
            unsafe { F16(_mm512_loadu_ps(s.as_ptr())) }
        }
        #[inline(always)]
        fn store(self, s: &mut [f32]) {
            assert!(s.len() >= 16);
            unsafe { _mm512_storeu_ps(s.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            unsafe { F16(_mm512_sqrt_ps(self.0)) }
        }
        #[inline(always)]
        fn mul_add(self, a: Self, b: Self) -> Self {
            unsafe { F16(_mm512_fmadd_ps(self.0, a.0, b.0)) }
        }
        #[inline(always)]
        fn abs(self) -> Self {
            unsafe { F16(_mm512_abs_ps(self.0)) }
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            unsafe { F16(_mm512_max_ps(self.0, b.0)) }
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            unsafe { F16(_mm512_min_ps(self.0, b.0)) }
        }
        #[inline(always)]
        fn lt(self, b: Self) -> M16 {
            unsafe { M16(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, b.0)) }
        }
        #[inline(always)]
        fn gt(self, b: Self) -> M16 {
            unsafe { M16(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, b.0)) }
        }
        #[inline(always)]
        fn le(self, b: Self) -> M16 {
            unsafe { M16(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, b.0)) }
        }
        #[inline(always)]
        fn is_nan(self) -> M16 {
            unsafe { M16(_mm512_cmp_ps_mask::<_CMP_UNORD_Q>(self.0, self.0)) }
        }
        #[inline(always)]
        fn select(m: M16, a: Self, b: Self) -> Self {
            unsafe { F16(_mm512_mask_blend_ps(m.0, b.0, a.0)) }
        }
        #[inline(always)]
        fn all(m: M16) -> bool {
            m.0 == 0xffff
        }
        #[inline(always)]
        fn scale_pow2(self, shifted: Self) -> Self {
            unsafe {
                let n = _mm512_sub_epi32(
                    _mm512_castps_si512(shifted.0),
                    _mm512_set1_epi32(SHIFTER_BITS),
                );
                let half = _mm512_srai_epi32::<1>(n);
                let bias = _mm512_set1_epi32(127);
                let s1 = _mm512_slli_epi32::<23>(_mm512_add_epi32(half, bias));
                let s2 = _mm512_slli_epi32::<23>(_mm512_add_epi32(_mm512_sub_epi32(n, half), bias));
                F16(_mm512_mul_ps(
                    _mm512_mul_ps(self.0, _mm512_castsi512_ps(s1)),
                    _mm512_castsi512_ps(s2),
                ))
            }
        }
        #[inline(always)]
        fn scale_pow2_small(self, shifted: Self) -> Self {
            unsafe {
                // (bits(shifted) − SHIFTER_BITS + 127) << 23
                let e = _mm512_add_epi32(
                    _mm512_castps_si512(shifted.0),
                    _mm512_set1_epi32(127 - SHIFTER_BITS),
                );
                F16(_mm512_mul_ps(
                    self.0,
                    _mm512_castsi512_ps(_mm512_slli_epi32::<23>(e)),
                ))
            }
        }
    }

    macro_rules! ops {
        ($ty:ident, $add:ident, $sub:ident, $mul:ident, $div:ident, $xor:ident, $set1:ident) => {
            impl Add for $ty {
                type Output = Self;
                #[inline(always)]
                fn add(self, b: Self) -> Self {
                    unsafe { $ty($add(self.0, b.0)) }
                }
            }
            impl Sub for $ty {
                type Output = Self;
                #[inline(always)]
                fn sub(self, b: Self) -> Self {
                    unsafe { $ty($sub(self.0, b.0)) }
                }
            }
            impl Mul for $ty {
                type Output = Self;
                #[inline(always)]
                fn mul(self, b: Self) -> Self {
                    unsafe { $ty($mul(self.0, b.0)) }
                }
            }
            impl Div for $ty {
                type Output = Self;
                #[inline(always)]
                fn div(self, b: Self) -> Self {
                    unsafe { $ty($div(self.0, b.0)) }
                }
            }
            impl Add<f32> for $ty {
                type Output = Self;
                #[inline(always)]
                fn add(self, b: f32) -> Self {
                    self + <$ty as Lanes>::splat(b)
                }
            }
            impl Sub<f32> for $ty {
                type Output = Self;
                #[inline(always)]
                fn sub(self, b: f32) -> Self {
                    self - <$ty as Lanes>::splat(b)
                }
            }
            impl Mul<f32> for $ty {
                type Output = Self;
                #[inline(always)]
                fn mul(self, b: f32) -> Self {
                    self * <$ty as Lanes>::splat(b)
                }
            }
            impl Neg for $ty {
                type Output = Self;
                #[inline(always)]
                fn neg(self) -> Self {
                    unsafe { $ty($xor(self.0, $set1(-0.0))) }
                }
            }
        };
    }
    ops!(
        F8,
        _mm256_add_ps,
        _mm256_sub_ps,
        _mm256_mul_ps,
        _mm256_div_ps,
        _mm256_xor_ps,
        _mm256_set1_ps
    );
    ops!(
        F16,
        _mm512_add_ps,
        _mm512_sub_ps,
        _mm512_mul_ps,
        _mm512_div_ps,
        _mm512_xor_ps,
        _mm512_set1_ps
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs the generic `$check::<V>()` at every level this CPU has, each
    /// inside a function compiled for that level.
    macro_rules! at_every_level {
        ($check:ident) => {{
            $check::<F<4>>();
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma")]
                unsafe fn avx2() {
                    $check::<F8>()
                }
                #[target_feature(enable = "avx512f,avx2,fma")]
                unsafe fn avx512() {
                    $check::<F16>()
                }
                if Level::detect() != Level::Portable {
                    // SAFETY: AVX2+FMA present (checked).
                    unsafe { avx2() }
                }
                if Level::detect() == Level::Avx512 {
                    // SAFETY: AVX-512F present (checked).
                    unsafe { avx512() }
                }
            }
        }};
    }

    /// Worst relative error of `V::exp` against f64 over [-87, 88.5], and
    /// the documented edges.
    fn check_exp<V: Lanes>() {
        let mut worst = 0.0f64;
        let n = 200_000;
        let mut buf = vec![0.0f32; V::N];
        for k in 0..n {
            let x = -87.0 + 175.5 * k as f32 / n as f32;
            V::splat(x).exp().store(&mut buf);
            let want = (x as f64).exp();
            worst = worst.max(((buf[0] as f64 - want) / want).abs());
        }
        assert!(worst < 2.4e-7, "worst relative error {worst}");
        for (x, want) in [(-100.0f32, 0.0f32), (100.0, f32::INFINITY), (0.0, 1.0)] {
            V::splat(x).exp().store(&mut buf);
            assert_eq!(buf[0], want, "exp({x})");
        }
        V::splat(f32::NAN).exp().store(&mut buf);
        assert!(buf[0].is_nan());
        // exp_bounded: same accuracy up to 88, NaN through, tiny for x < -87.3
        let mut worst = 0.0f64;
        for k in 0..n {
            let x = -87.0 + 175.0 * k as f32 / n as f32;
            V::splat(x).exp_bounded().store(&mut buf);
            let want = (x as f64).exp();
            worst = worst.max(((buf[0] as f64 - want) / want).abs());
        }
        assert!(worst < 2.4e-7, "exp_bounded: worst relative error {worst}");
        V::splat(f32::NAN).exp_bounded().store(&mut buf);
        assert!(buf[0].is_nan());
        V::splat(-1e4).exp_bounded().store(&mut buf);
        assert!((0.0..1.2e-38).contains(&buf[0]));
    }

    /// Masks and selects, NaN behaviour of max/min/is_finite.
    fn check_masks<V: Lanes>() {
        let mut buf = vec![0.0f32; V::N];
        let a = [1.0, f32::NAN, f32::INFINITY, -2.0];
        let mut src = vec![0.0f32; V::N];
        src[..4].copy_from_slice(&a);
        let x = V::load(&src);
        let zero = V::splat(0.0);
        V::select(x.gt(zero), V::splat(1.0), V::splat(2.0)).store(&mut buf);
        assert_eq!(&buf[..4], &[1.0, 2.0, 1.0, 2.0]);
        V::select(x.is_finite(), V::splat(1.0), V::splat(2.0)).store(&mut buf);
        assert_eq!(&buf[..4], &[1.0, 2.0, 2.0, 1.0]);
        x.max(zero).store(&mut buf);
        assert_eq!(&buf[..4], &[1.0, 0.0, f32::INFINITY, 0.0]);
        x.abs().store(&mut buf);
        assert_eq!(buf[3], 2.0);
        assert!(V::all(V::splat(1.0).gt(zero)) && !V::all(x.gt(zero)));
    }

    /// 1. exp: ≤ 2 ulp against f64, edges, NaN (every level this CPU has).
    #[test]
    fn t01_exp_matches_f64() {
        at_every_level!(check_exp);
    }

    /// 2. Masks, selects and NaN rules agree at every level.
    #[test]
    fn t02_masks_and_selects() {
        at_every_level!(check_masks);
    }

    /// Worst errors of the special functions against f64: atan2 (absolute),
    /// wrap_pi (absolute), I0 by series and e^{-x} I0 by the large-argument
    /// polynomial (relative, against `math::i0e`, itself a few ulps from
    /// scipy's `ive`).
    fn check_special<V: Lanes>() {
        let mut buf = vec![0.0f32; V::N];
        let mut at = |v: V| {
            v.store(&mut buf);
            buf[0] as f64
        };
        // atan2 on a ring of directions and on the axes (signed zeros too).
        let mut worst = 0.0f64;
        for k in 0..20_000 {
            let a = -std::f64::consts::PI + std::f64::consts::TAU * (k as f64 + 0.5) / 20_000.0;
            for r in [1e-30, 1e-3, 1.0, 1e30] {
                let (y, x) = ((r * a.sin()) as f32, (r * a.cos()) as f32);
                let got = at(atan2(V::splat(y), V::splat(x)));
                worst = worst.max((got - (y as f64).atan2(x as f64)).abs());
            }
        }
        assert!(worst < 3e-7, "atan2 worst absolute error {worst}");
        for (y, x, want) in [
            (0.0f32, 1.0f32, 0.0f64),
            (1.0, 0.0, std::f64::consts::FRAC_PI_2),
            (0.0, -1.0, std::f64::consts::PI),
            (-1.0, 0.0, -std::f64::consts::FRAC_PI_2),
            (0.0, 0.0, 0.0),
        ] {
            assert!((at(atan2(V::splat(y), V::splat(x))) - want).abs() < 3e-7);
        }
        assert!(at(atan2(V::splat(f32::NAN), V::splat(1.0))).is_nan());
        assert!(at(atan2(V::splat(1.0), V::splat(f32::NAN))).is_nan());
        // wrap_pi over the range the kernels use (|x| ≤ 5π).
        let mut worst = 0.0f64;
        for k in 0..20_001 {
            let x = (-5.0 * std::f64::consts::PI
                + 10.0 * std::f64::consts::PI * k as f64 / 20_000.0) as f32;
            let got = at(wrap_pi(V::splat(x)));
            let want = (x as f64 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            // The same angle, up to the wrap at ±π.
            let d = (got - want).abs();
            let d = d.min((d - std::f64::consts::TAU).abs());
            worst = worst.max(d);
            assert!(got.abs() <= std::f64::consts::PI + 1e-6, "{x} -> {got}");
        }
        assert!(worst < 1e-6, "wrap_pi worst absolute error {worst}");
        // I0: series below the switch, large-argument polynomial above.
        let mut worst = 0.0f64;
        for k in 0..=30_000 {
            let x = 60.0 * k as f64 / 30_000.0;
            let x = if k == 30_000 { 1e6 } else { x };
            let xf = V::splat(x as f32);
            let got = if (x as f32) <= I0_SWITCH {
                at(i0_series(xf * xf * 0.25)) * (-(x as f32 as f64)).exp()
            } else {
                at(i0e_large(xf))
            };
            let want = crate::math::i0e(x as f32 as f64);
            worst = worst.max((got / want - 1.0).abs());
        }
        assert!(worst < 1e-6, "i0 worst relative error {worst}");
    }

    /// 3. Vector atan2, wrap_pi and I0 against f64 at every level.
    #[test]
    fn t03_special_functions_match_f64() {
        at_every_level!(check_special);
    }
}
