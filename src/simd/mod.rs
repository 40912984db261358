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
//! [`Lanes::exp`] is Cephes `expf`'s range reduction with a fitted degree-5
//! polynomial (relative error ≤ 2 ulp on
//! `[-87.3, 88.7]`, measured against f64 in the tests), flushing results below
//! `2^-126` to 0 (the scalar path returns denormals there: an absolute
//! difference below 1.2e-38), `+inf` above 88.72, NaN to NaN.

mod poly;
mod portable;
#[cfg(target_arch = "x86_64")]
mod x86;

pub(crate) use poly::{atan2, atan2_finite, i0_small, i0e_large, wrap_pi, I0_SWITCH};
use poly::{expm_poly, LN2_HI, LN2_LO, SHIFTER};
pub use portable::{F, M};
#[cfg(target_arch = "x86_64")]
pub use x86::{F16, F8};

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
    /// An estimate of `1/√x`: relative error ≤ 2^-14 (AVX-512), 1.5·2^-12
    /// (AVX2), exact (portable lanes).
    fn rsqrt_estimate(self) -> Self;
    /// An estimate of `1/x`, with the error bounds of [`Lanes::rsqrt_estimate`].
    fn recip_estimate(self) -> Self;

    /// `1/√x` for normal positive finite `x`: the estimate and one Newton
    /// step (relative error ≤ 4e-7, measured in the tests). Zero, infinite
    /// and NaN lanes give NaN.
    #[inline(always)]
    fn rsqrt(self) -> Self {
        let y = self.rsqrt_estimate();
        let e = (-(self * y)).mul_add(y, Self::splat(1.0));
        (y * 0.5).mul_add(e, y)
    }

    /// `1/x` for normal finite `x`: the estimate and one Newton step
    /// (relative error ≤ 4e-7, measured in the tests). Zero, infinite and NaN
    /// lanes give NaN.
    #[inline(always)]
    fn recip(self) -> Self {
        let y = self.recip_estimate();
        let e = (-self).mul_add(y, Self::splat(1.0));
        e.mul_add(y, y)
    }

    /// The `N` three-wide records `s[..3N]` de-interleaved: `[x, y, z]`.
    #[inline(always)]
    fn load3(s: &[f32]) -> [Self; 3] {
        let mut buf = [[0.0f32; 16]; 3];
        for (j, r) in s[..3 * Self::N].chunks_exact(3).enumerate() {
            for c in 0..3 {
                buf[c][j] = r[c];
            }
        }
        buf.map(|b| Self::load(&b))
    }

    /// `x`, `y`, `z` interleaved into the `N` records `s[..3N]`.
    #[inline(always)]
    fn store3(x: &[Self; 3], s: &mut [f32]) {
        let mut buf = [[0.0f32; 16]; 3];
        for c in 0..3 {
            x[c].store(&mut buf[c]);
        }
        for (j, r) in s[..3 * Self::N].chunks_exact_mut(3).enumerate() {
            for c in 0..3 {
                r[c] = buf[c][j];
            }
        }
    }

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
    /// [`Lanes::scale_pow2`], where the result is a normal number (as in
    /// [`Lanes::exp_bounded`], whose `e^r ∈ [0.7, 1.42]` is ≥ 1 where n is
    /// -126); elsewhere unspecified (AVX2 and AVX-512 add n to the exponent
    /// field).
    fn scale_pow2_small(self, shifted: Self) -> Self;

    /// `e^x`: `x = n ln2 + r`, `|r| ≤ ½ ln2` (Cephes `expf`'s reduction), a
    /// degree-5 polynomial in r, times `2^n` built in the exponent bits.
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
    if W == 3 && count == V::N {
        // A full vector of 3-wide records: de-interleaved in registers.
        let v = V::load3(&a[3 * base..3 * (base + count)]);
        out[..3].copy_from_slice(&v);
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
    // |w|² in the normal range in every lane (almost always): one square
    // root, and every component is finite; otherwise scale by the largest
    // component first.
    // (No closures here or in the kernels: a closure is compiled without
    // the caller's target features, and its intrinsics become calls.)
    // A lane's result depends on that lane alone (not on which path its
    // neighbours need), so a direction normalizes the same in any batch.
    let normal = d.gt(V::splat(1e-30)) & d.lt(V::splat(1e30));
    let inv = d.rsqrt();
    let fast = [w[0] * inv, w[1] * inv, w[2] * inv];
    if V::all(normal) {
        return (fast, normal);
    }
    let ok = w[0].is_finite() & w[1].is_finite() & w[2].is_finite();
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
    if W == 3 && count == V::N {
        V::store3(&[x[0], x[1], x[2]], o);
        return;
    }
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

/// Asks the CPU to bring the cache lines of `*p` towards the cache ahead of
/// its use (no effect on any value; a no-op off x86-64). For loops whose
/// next items lie at unpredictable addresses, such as a tile's strand
/// segments, listed by depth.
#[inline(always)]
pub fn prefetch<T>(p: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let first = p as *const T as *const i8;
        let size = std::mem::size_of::<T>().max(1);
        // a byte every 64 from the first, and the last: every line `*p`
        // touches, wherever it starts within one
        for offset in (0..size).step_by(64).chain([size - 1]) {
            // SAFETY: a prefetch never faults and changes no value; every
            // address lies within `*p`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(first.wrapping_add(offset)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
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
                at(i0_small(xf * xf * 0.25)) * (-(x as f32 as f64)).exp()
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

    /// Records of three in and out of lanes: `load3`/`store3` (permutes at
    /// AVX2 and AVX-512) against reading the components one by one, and
    /// back; `load`/`store` of a full vector take that path.
    fn check_records<V: Lanes>() {
        let n = V::N;
        let s: Vec<f32> = (0..3 * n).map(|k| k as f32 * 0.5 - 7.0).collect();
        let v = V::load3(&s);
        let mut buf = vec![0.0f32; n];
        for (c, vc) in v.iter().enumerate() {
            vc.store(&mut buf);
            for j in 0..n {
                assert_eq!(buf[j], s[3 * j + c], "lane {j} component {c}");
            }
        }
        let mut back = vec![0.0f32; 3 * n];
        V::store3(&v, &mut back);
        assert_eq!(back, s);
        let w = load::<V, 3>(&s, 0, n);
        let mut back = vec![0.0f32; 3 * n];
        store::<V, 3>(&mut back, &w, n);
        assert_eq!(back, s);
    }

    /// 4. load3/store3 at every level.
    #[test]
    fn t04_records_of_three() {
        at_every_level!(check_records);
    }

    /// `rsqrt` and `recip` (estimate and one Newton step) against f64 over
    /// normal arguments from 1e-37 to 1e37: within the documented 4e-7.
    fn check_reciprocals<V: Lanes>() {
        let mut buf = vec![0.0f32; V::N];
        let (mut worst_rsqrt, mut worst_recip) = (0.0f64, 0.0f64);
        for k in 0..=200_000 {
            let x = 10f64.powf(-37.0 + 74.0 * k as f64 / 200_000.0) as f32;
            V::splat(x).rsqrt().store(&mut buf);
            let want = 1.0 / (x as f64).sqrt();
            worst_rsqrt = worst_rsqrt.max((buf[0] as f64 / want - 1.0).abs());
            for x in [x, -x] {
                V::splat(x).recip().store(&mut buf);
                worst_recip = worst_recip.max((buf[0] as f64 * x as f64 - 1.0).abs());
            }
        }
        assert!(
            worst_rsqrt < 4e-7,
            "rsqrt worst relative error {worst_rsqrt}"
        );
        assert!(
            worst_recip < 4e-7,
            "recip worst relative error {worst_recip}"
        );
    }

    /// 5. rsqrt and recip at every level.
    #[test]
    fn t05_reciprocals_match_f64() {
        at_every_level!(check_reciprocals);
    }
}
