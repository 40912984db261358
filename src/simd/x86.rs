//! AVX2 and AVX-512 lanes. SAFETY (every `unsafe` block here): the
//! intrinsics need AVX2+FMA / AVX-512F, and these types are only used
//! inside functions compiled with those features, which run only after
//! [`super::Level::detect`] found them on the CPU.
use super::poly::SHIFTER_BITS;
use super::Lanes;
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
    fn load3(s: &[f32]) -> [Self; 3] {
        assert!(s.len() >= 24);
        // a = x0 y0 z0 x1 y1 z1 x2 y2, b = z2 x3 .. x5, c = y5 z5 .. z7:
        // blend each component's lanes together, then put them in order.
        unsafe {
            let p = s.as_ptr();
            let (a, b, c) = (
                _mm256_loadu_ps(p),
                _mm256_loadu_ps(p.add(8)),
                _mm256_loadu_ps(p.add(16)),
            );
            let x = _mm256_blend_ps::<0b0010_0100>(_mm256_blend_ps::<0b1001_0010>(a, b), c);
            let y = _mm256_blend_ps::<0b0100_1001>(_mm256_blend_ps::<0b0010_0100>(a, b), c);
            let z = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0100_1001>(a, b), c);
            [
                F8(_mm256_permutevar8x32_ps(
                    x,
                    _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5),
                )),
                F8(_mm256_permutevar8x32_ps(
                    y,
                    _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6),
                )),
                F8(_mm256_permutevar8x32_ps(
                    z,
                    _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7),
                )),
            ]
        }
    }
    #[inline(always)]
    fn store3(v: &[Self; 3], s: &mut [f32]) {
        assert!(s.len() >= 24);
        // load3 backwards: each component in blend order, then blended.
        unsafe {
            let x = _mm256_permutevar8x32_ps(v[0].0, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
            let y = _mm256_permutevar8x32_ps(v[1].0, _mm256_setr_epi32(5, 0, 3, 6, 1, 4, 7, 2));
            let z = _mm256_permutevar8x32_ps(v[2].0, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
            let a = _mm256_blend_ps::<0b0010_0100>(_mm256_blend_ps::<0b1001_0010>(x, y), z);
            let b = _mm256_blend_ps::<0b0100_1001>(_mm256_blend_ps::<0b0010_0100>(x, y), z);
            let c = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0100_1001>(x, y), z);
            let p = s.as_mut_ptr();
            _mm256_storeu_ps(p, a);
            _mm256_storeu_ps(p.add(8), b);
            _mm256_storeu_ps(p.add(16), c);
        }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        unsafe { F8(_mm256_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        unsafe { F8(_mm256_rsqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn recip_estimate(self) -> Self {
        unsafe { F8(_mm256_rcp_ps(self.0)) }
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
        // n added to the exponent field: bits(shifted) << 23 is n << 23
        // (SHIFTER_BITS << 23 wraps to 0); exact where the result is normal
        unsafe {
            F8(_mm256_castsi256_ps(_mm256_add_epi32(
                _mm256_castps_si256(self.0),
                _mm256_slli_epi32::<23>(_mm256_castps_si256(shifted.0)),
            )))
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
    fn load3(s: &[f32]) -> [Self; 3] {
        assert!(s.len() >= 48);
        unsafe {
            let p = s.as_ptr();
            let (a, b, c) = (
                _mm512_loadu_ps(p),
                _mm512_loadu_ps(p.add(16)),
                _mm512_loadu_ps(p.add(32)),
            );
            let mut out = [F16(a); 3];
            for (j, o) in out.iter_mut().enumerate() {
                let (i1, i2) = (&LOAD3_IDX[j][0], &LOAD3_IDX[j][1]);
                let t = _mm512_permutex2var_ps(a, _mm512_loadu_si512(i1.as_ptr().cast()), b);
                *o = F16(_mm512_permutex2var_ps(
                    t,
                    _mm512_loadu_si512(i2.as_ptr().cast()),
                    c,
                ));
            }
            out
        }
    }
    #[inline(always)]
    fn store3(v: &[Self; 3], s: &mut [f32]) {
        assert!(s.len() >= 48);
        unsafe {
            let p = s.as_mut_ptr();
            for (q, idx) in STORE3_IDX.iter().enumerate() {
                let (i1, i2) = (&idx[0], &idx[1]);
                let t =
                    _mm512_permutex2var_ps(v[0].0, _mm512_loadu_si512(i1.as_ptr().cast()), v[1].0);
                let o = _mm512_permutex2var_ps(t, _mm512_loadu_si512(i2.as_ptr().cast()), v[2].0);
                _mm512_storeu_ps(p.add(16 * q), o);
            }
        }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        unsafe { F16(_mm512_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        unsafe { F16(_mm512_rsqrt14_ps(self.0)) }
    }
    #[inline(always)]
    fn recip_estimate(self) -> Self {
        unsafe { F16(_mm512_rcp14_ps(self.0)) }
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
        // as F8's
        unsafe {
            F16(_mm512_castsi512_ps(_mm512_add_epi32(
                _mm512_castps_si512(self.0),
                _mm512_slli_epi32::<23>(_mm512_castps_si512(shifted.0)),
            )))
        }
    }
}

/// [`F16::load3`]'s two-step permutations per component `j`: record `k`'s
/// component sits at flat position `p = 3k + j` of the 48 loaded; the first
/// step gathers those in the first two vectors (`p < 32`), the second keeps
/// them and takes the rest from the third.
const LOAD3_IDX: [[[i32; 16]; 2]; 3] = {
    let mut t = [[[0; 16]; 2]; 3];
    let mut j = 0;
    while j < 3 {
        let mut k = 0;
        while k < 16 {
            let p = (3 * k + j) as i32;
            if p < 32 {
                t[j][0][k] = p;
                t[j][1][k] = k as i32;
            } else {
                t[j][1][k] = 16 + p - 32;
            }
            k += 1;
        }
        j += 1;
    }
    t
};

/// [`F16::store3`]'s permutations per output vector `q`: flat position
/// `f = 16q + i` holds component `f mod 3` of record `f / 3`; the first step
/// takes x and y, the second keeps them and takes z.
const STORE3_IDX: [[[i32; 16]; 2]; 3] = {
    let mut t = [[[0; 16]; 2]; 3];
    let mut q = 0;
    while q < 3 {
        let mut i = 0;
        while i < 16 {
            let f = 16 * q + i;
            let k = (f / 3) as i32;
            match f % 3 {
                0 => t[q][0][i] = k,
                1 => t[q][0][i] = 16 + k,
                _ => t[q][1][i] = 16 + k,
            }
            if f % 3 != 2 {
                t[q][1][i] = i as i32;
            }
            i += 1;
        }
        q += 1;
    }
    t
};

macro_rules! ops {
    ($ty:ident, $add:ident, $sub:ident, $mul:ident, $div:ident, $neg:ident) => {
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
                unsafe { $ty($neg(self.0)) }
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
    neg8
);
ops!(
    F16,
    _mm512_add_ps,
    _mm512_sub_ps,
    _mm512_mul_ps,
    _mm512_div_ps,
    neg16
);

/// `−x`: the sign bit flipped.
#[inline(always)]
unsafe fn neg8(x: __m256) -> __m256 {
    _mm256_xor_ps(x, _mm256_set1_ps(-0.0))
}

/// `−x` as `x · (−1)`, which is exact (signed zeros and NaN included) and
/// which the compiler turns into a sign flip and folds into fused
/// multiply-adds (`_mm512_xor_ps` is AVX-512DQ, which the kernels are not
/// compiled for: it would be a call).
#[inline(always)]
unsafe fn neg16(x: __m512) -> __m512 {
    _mm512_mul_ps(x, _mm512_set1_ps(-1.0))
}
