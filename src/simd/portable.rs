//! The portable level: lanes as plain arrays, vectorized by the compiler
//! with the target's baseline ISA.

use super::poly::SHIFTER_BITS;
use super::Lanes;
use std::ops::{Add, BitAnd, Div, Mul, Neg, Sub};

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
    fn rsqrt_estimate(self) -> Self {
        self.map(|x| 1.0 / x.sqrt())
    }
    #[inline(always)]
    fn recip_estimate(self) -> Self {
        self.map(|x| 1.0 / x)
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
