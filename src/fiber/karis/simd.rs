//! Vector kernel of [`KarisHair`] in `f32`: the same terms as the scalar
//! code in `karis.rs`, one [`Lanes`] vector of pairs at a time
//! ([`crate::simd`]).
//!
//! Differences from the scalar path, all below f32 rounding of the result:
//! - `cos θd = cos(½(θV − θL))` is computed without `asin`/`cos`, from the
//!   half-angle identities `cos(θ/2) = √((1 + cos θ)/2)`,
//!   `sin(θ/2) = sin θ / √(2(1 + cos θ))` (θ ∈ [−π/2, π/2], so both are
//!   well conditioned);
//! - `C^e = e^{e ln C}` with `ln C` computed once per material in f64;
//! - `exp` is [`Lanes::exp_bounded`] (≤ 2 ulp; the lobes' exponents are
//!   ≤ 0.22: an underflowing lobe is ≤ 1.2e-38 instead of 0), and each of TT and TRT takes one
//!   exponential per channel (the exponents of M_p, N_p and the absorption
//!   are added).
//!
//! Models with `fast_asin` (UE's `asinFast`) use the scalar path.

use super::{Absorption, KarisHair, KarisInputs, LobeVisitor};
use crate::simd::{dot, load, load_dir, store, Lanes, Level, F};
#[cfg(target_arch = "x86_64")]
use crate::simd::{F16, F8};

/// A material's constants, splatted once per kernel call. The model's
/// fields are copied in, not borrowed: reading them through a reference in
/// the kernel costs 5% more instructions per pair (callgrind, AVX2).
#[derive(Clone, Copy)]
struct Consts {
    color_ln: [f32; 3],
    color_zero: [bool; 3],
    sqrt_color: [f32; 3],
    col_over_luma_ln: [f32; 3],
    col_over_luma_zero: [bool; 3],
    neg_sigma_a: [f32; 3],
    specular2: f32,
    scatter: f32,
    backlit: f32,
    alpha: [f32; 3],
    sin_alpha_r: f32,
    cos_alpha_r: f32,
    b: [f32; 3],
    f0: f32,
    /// `1/(2B²)` and `1/(√(2π) B)` per lobe (the Gaussian M_p).
    half_inv_b2: [f32; 3],
    norm: [f32; 3],
    separable_r: bool,
    absorption: Absorption,
}

const B_MIN: f32 = crate::fiber::lobes::B_MIN as f32;
const INV_SQRT_2PI: f32 = 0.398_942_3;

impl Consts {
    fn new(m: &KarisHair<f32>) -> Self {
        let ln = |c: f32| if c > 0.0 { (c as f64).ln() as f32 } else { 0.0 };
        Self {
            color_ln: m.color.map(ln),
            color_zero: m.color.map(|c| c <= 0.0),
            sqrt_color: m.sqrt_color,
            col_over_luma_ln: m.color_over_luma.map(ln),
            col_over_luma_zero: m.color_over_luma.map(|c| c <= 0.0),
            neg_sigma_a: m.sigma_a.map(|x| -x),
            specular2: m.specular2,
            scatter: m.scatter,
            backlit: m.backlit,
            alpha: m.alpha,
            sin_alpha_r: m.sin_alpha_r,
            cos_alpha_r: m.cos_alpha_r,
            b: m.b,
            f0: m.f0,
            half_inv_b2: m.b.map(|b| {
                let b = (b as f64).max(crate::fiber::lobes::B_MIN);
                (0.5 / (b * b)) as f32
            }),
            norm: m.b.map(|b| {
                let b = (b as f64).max(crate::fiber::lobes::B_MIN);
                (1.0 / ((2.0 * std::f64::consts::PI).sqrt() * b)) as f32
            }),
            separable_r: m.separable_r,
            absorption: m.absorption,
        }
    }
}

/// `c^e` for a per-material `c` (`ln c` given; `0^0 = 1`, `0^e = 0`).
#[inline(always)]
fn pow_c<V: Lanes>(ln_c: f32, zero: bool, e: V) -> V {
    if zero {
        V::select(e.le(V::splat(0.0)), V::splat(1.0), V::splat(0.0))
    } else {
        (e * ln_c).exp()
    }
}

#[inline(always)]
fn saturate<V: Lanes>(x: V) -> V {
    x.clamp(0.0, 1.0)
}

#[inline(always)]
fn one_minus<V: Lanes>(x: V) -> V {
    V::splat(1.0) - x
}

#[inline(always)]
fn schlick<V: Lanes>(k: &Consts, x: V) -> V {
    saturate(one_minus(x))
        .pow5()
        .mul_add(V::splat(1.0 - k.f0), V::splat(k.f0))
}

/// Lobe `p`, channel `c` of the output: stored (`LOBES`) or added to the
/// running sum in `out[0]`.
#[inline(always)]
fn put<V: Lanes, const LOBES: bool>(out: &mut [[V; 3]; 4], p: usize, c: usize, x: V) {
    if LOBES {
        out[p][c] = x;
    } else {
        out[0][c] = out[0][c] + x;
    }
}

/// R, TT, TRT, MS of `V::N` pairs (each RGB; with `LOBES = false` only
/// `[0]` is written: the running sum of the enabled lobes), and the lanes
/// that are valid.
#[inline(always)]
fn lobes<
    V: Lanes,
    const R: bool,
    const TT: bool,
    const TRT: bool,
    const MS: bool,
    const LOBES: bool,
>(
    k: &Consts,
    inp: &KarisInputs<'_, f32>,
    base: usize,
    count: usize,
) -> ([[V; 3]; 4], V::Mask) {
    let zero = V::splat(0.0);
    let (l, ok_l) = load_dir::<V>(inp.l, base, count);
    let (v, ok_v) = load_dir::<V>(inp.v, base, count);
    let (t, ok_t) = load_dir::<V>(inp.t, base, count);
    let mut ok = ok_l & ok_v & ok_t;
    let mut out = [[zero; 3]; 4];

    // Geometry shared by the lobes.
    let vol = dot(&v, &l);
    let sin_l = dot(&t, &l).clamp(-1.0, 1.0);
    let sin_v = dot(&t, &v).clamp(-1.0, 1.0);
    let cos_l = one_minus(sin_l * sin_l).max(zero).sqrt();
    let cos_v = one_minus(sin_v * sin_v).max(zero).sqrt();
    // cos θd = cos(θV/2)cos(θL/2) + sin(θV/2)sin(θL/2) with
    // cos(θ/2) = √((1+cos θ)/2), sin(θ/2) = sin θ/√(2(1+cos θ)):
    // cos θd = P/4 + sin θV sin θL / P,  P = 2√((1+cos θV)(1+cos θL)).
    let p = ((cos_v + 1.0) * (cos_l + 1.0)).sqrt() * 2.0;
    let cos_theta_d = p * 0.25 + sin_v * sin_l / p;
    let inv_cos_theta_d = V::splat(1.0) / cos_theta_d;
    // (Arrays built without closures: see `simd::load_dir`.)
    let lp = [
        l[0] - sin_l * t[0],
        l[1] - sin_l * t[1],
        l[2] - sin_l * t[2],
    ];
    let vp = [
        v[0] - sin_v * t[0],
        v[1] - sin_v * t[1],
        v[2] - sin_v * t[2],
    ];
    // cos φ = lp·vp / √D, D = |lp|²|vp|² + 1e-4 (UE's guard). Near φ = π,
    // 1 + cos φ cancels; there it is (√D + lp·vp)/√D with the numerator
    // rewritten by Lagrange's identity, D − (lp·vp)² = |lp × vp|² + 1e-4:
    // 1 + cos φ = (|lp × vp|² + 1e-4) / (√D (√D − lp·vp)).
    let lv = dot(&lp, &vp);
    let sqrt_d = (dot(&lp, &lp) * dot(&vp, &vp) + 1e-4).sqrt();
    let cos_phi = lv / sqrt_d;
    let cross = [
        lp[1] * vp[2] - lp[2] * vp[1],
        lp[2] * vp[0] - lp[0] * vp[2],
        lp[0] * vp[1] - lp[1] * vp[0],
    ];
    let one_plus_cos_phi = V::select(
        lv.lt(zero),
        (dot(&cross, &cross) + 1e-4) / (sqrt_d * (sqrt_d - lv)),
        cos_phi + 1.0,
    );
    let cos_half_phi = saturate(one_plus_cos_phi * 0.5).sqrt();
    let sin_sum = sin_l + sin_v;

    if R {
        let (sa, ca) = (k.sin_alpha_r, k.cos_alpha_r);
        let x = sin_sum - (cos_half_phi * cos_v * ca + sin_v * sa) * (2.0 * sa);
        // M_p: Gaussian of width B_R (√2 cos(φ/2) B_R when separable).
        let inv_b = if k.separable_r {
            V::splat(1.0)
                / (cos_half_phi * (k.b[0] * std::f32::consts::SQRT_2)).max(V::splat(B_MIN))
        } else {
            V::splat(1.0 / k.b[0].max(B_MIN))
        };
        let xb = x * inv_b;
        let m_p = (xb * xb * -0.5).exp_bounded() * inv_b * INV_SQRT_2PI;
        let n_p = cos_half_phi * 0.25;
        let f_p = schlick(k, saturate(vol * 0.5 + 0.5).sqrt());
        let back = saturate(-vol) * (k.backlit - 1.0) + 1.0;
        let r = m_p * n_p * f_p * back * k.specular2;
        for c in 0..3 {
            put::<V, LOBES>(&mut out, 0, c, r);
        }
    }
    if TT {
        // a = 1/η' = cos θd / (1.19 + 0.36 cos² θd)
        let a = cos_theta_d / (cos_theta_d * cos_theta_d * 0.36 + 1.19);
        let h = cos_half_phi * (a * (cos_phi * -0.8 + 0.6) + 1.0);
        let f = schlick(k, cos_theta_d * saturate(one_minus(h * h)).sqrt());
        let f_p = one_minus(f) * one_minus(f);
        let ha2 = (h * a) * (h * a);
        // log of M_p·N_p without the Gaussian's normalization
        let x = sin_sum - k.alpha[1];
        let g = x * x * (-k.half_inv_b2[1]) + cos_phi * -3.65 - 3.98;
        let kk = f_p * (k.norm[1] * k.backlit);
        // Absorption exponent: len · coef[c] (legacy: e ln C, else −σa ℓ).
        let (len, coef, zero_color) = match k.absorption {
            Absorption::Legacy => (
                one_minus(ha2).max(zero).sqrt() * inv_cos_theta_d * 0.5,
                k.color_ln,
                k.color_zero,
            ),
            Absorption::Chiang => (
                one_minus(ha2 * inv_cos_theta_d).abs() * 2.0,
                k.neg_sigma_a,
                [false; 3],
            ),
            Absorption::ChiangCorrected => (
                one_minus(ha2).max(zero).sqrt() * inv_cos_theta_d * 2.0,
                k.neg_sigma_a,
                [false; 3],
            ),
        };
        for c in 0..3 {
            let t_p = if zero_color[c] {
                // 0^e: 1 where e ≤ 0, else 0
                V::select(len.le(zero), g.exp_bounded(), zero)
            } else {
                len.mul_add(V::splat(coef[c]), g).exp_bounded()
            };
            put::<V, LOBES>(&mut out, 1, c, kk * t_p);
        }
    }
    if TRT {
        let f = schlick(k, cos_theta_d * 0.5);
        let f_p = one_minus(f) * one_minus(f) * f;
        let x = sin_sum - k.alpha[2];
        let g = x * x * (-k.half_inv_b2[2]) + cos_phi * 17.0 - 16.78;
        let e = inv_cos_theta_d * 0.8;
        let kk = f_p * k.norm[2];
        for c in 0..3 {
            let t_p = if k.color_zero[c] {
                V::select(e.le(zero), g.exp_bounded(), zero)
            } else {
                e.mul_add(V::splat(k.color_ln[c]), g).exp_bounded()
            };
            put::<V, LOBES>(&mut out, 2, c, kk * t_p);
        }
    }
    if MS {
        let shadow = load::<V, 1>(inp.shadow, base, count)[0];
        let gs = load::<V, 3>(inp.global_scattering, base, count);
        let ls = load::<V, 3>(inp.local_scattering, base, count);
        let ov = load::<V, 1>(inp.opaque_visibility, base, count)[0];
        ok = ok & shadow.is_finite() & ov.is_finite();
        for c in 0..3 {
            ok = ok & gs[c].is_finite() & ls[c].is_finite();
        }
        // Kajiya-Kay term with the fake normal n = normalize(V − T(T·V)).
        let kajiya = one_minus(dot(&t, &l).abs());
        let vt = dot(&v, &t);
        let fake = [v[0] - t[0] * vt, v[1] - t[1] * vt, v[2] - t[2] * vt];
        let len = dot(&fake, &fake).sqrt();
        let n_dot_l = V::select(len.gt(zero), dot(&fake, &l) / len, zero);
        let nol = saturate((n_dot_l + 1.0) * 0.25);
        let diffuse = (nol + (kajiya - nol) * 0.33) * (std::f32::consts::FRAC_1_PI * k.scatter);
        let e = one_minus(shadow);
        for c in 0..3 {
            let kk = diffuse
                * pow_c(k.col_over_luma_ln[c], k.col_over_luma_zero[c], e)
                * k.sqrt_color[c];
            let single = if LOBES {
                out[0][c] + out[1][c] + out[2][c]
            } else {
                out[0][c]
            };
            let scaled = gs[c] * (single + ls[c]) * ov;
            let ms = scaled - single + kk;
            if LOBES {
                out[3][c] = ms;
            } else {
                out[0][c] = out[0][c] + ms;
            }
        }
    }
    (out, ok)
}

/// Pairs `base..base + out.len()/W` into `out` (`W` = 3: the clamped sum;
/// `W` = 12: the four lobes).
#[inline(always)]
fn run<
    V: Lanes,
    const R: bool,
    const TT: bool,
    const TRT: bool,
    const MS: bool,
    const LOBES: bool,
>(
    k: &Consts,
    inp: &KarisInputs<'_, f32>,
    base: usize,
    out: &mut [f32],
) {
    let w = if LOBES { 12 } else { 3 };
    let n = out.len() / w;
    let zero = V::splat(0.0);
    let mut j = 0;
    while j < n {
        let count = (n - j).min(V::N);
        let (lobes, ok) = lobes::<V, R, TT, TRT, MS, LOBES>(k, inp, base + j, count);
        let o = &mut out[w * j..w * (j + count)];
        if LOBES {
            let mut x = [zero; 12];
            for (p, lobe) in lobes.iter().enumerate() {
                for (c, v) in lobe.iter().enumerate() {
                    x[3 * p + c] = V::select(ok, *v, zero);
                }
            }
            store::<V, 12>(o, &x, count);
        } else {
            let mut x = [zero; 3];
            for (xc, s) in x.iter_mut().zip(lobes[0]) {
                *xc = V::select(ok & s.is_finite(), s.max(zero), zero);
            }
            store::<V, 3>(o, &x, count);
        }
        j += count;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn run_avx512<
    const R: bool,
    const TT: bool,
    const TRT: bool,
    const MS: bool,
    const LOBES: bool,
>(
    k: &Consts,
    inp: &KarisInputs<'_, f32>,
    base: usize,
    out: &mut [f32],
) {
    run::<F16, R, TT, TRT, MS, LOBES>(k, inp, base, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<
    const R: bool,
    const TT: bool,
    const TRT: bool,
    const MS: bool,
    const LOBES: bool,
>(
    k: &Consts,
    inp: &KarisInputs<'_, f32>,
    base: usize,
    out: &mut [f32],
) {
    run::<F8, R, TT, TRT, MS, LOBES>(k, inp, base, out)
}

fn run_level<const R: bool, const TT: bool, const TRT: bool, const MS: bool, const LOBES: bool>(
    level: Level,
    k: &Consts,
    inp: &KarisInputs<'_, f32>,
    base: usize,
    out: &mut [f32],
) {
    match level {
        // SAFETY: `Level::detect` returns these levels only when the CPU
        // has the features the functions are compiled for.
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { run_avx512::<R, TT, TRT, MS, LOBES>(k, inp, base, out) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { run_avx2::<R, TT, TRT, MS, LOBES>(k, inp, base, out) },
        _ => run::<F<4>, R, TT, TRT, MS, LOBES>(k, inp, base, out),
    }
}

/// Batched `f32` evaluation on the vector kernel, on this thread: pairs
/// `first..` of `inp` into `out` (3 values per pair, the clamped sum; 12
/// with `LOBES`, the four lobes); degenerate pairs give 0. `level` must be
/// at most [`Level::detect`]'s. Models with `fast_asin` are evaluated as
/// if it were off.
pub fn eval_range<const LOBES: bool>(
    m: &KarisHair<f32>,
    inp: &KarisInputs<'_, f32>,
    first: usize,
    out: &mut [f32],
    level: Level,
) {
    struct Run<'a, 'b, const LOBES: bool> {
        level: Level,
        k: Consts,
        inp: &'a KarisInputs<'b, f32>,
        first: usize,
        out: &'a mut [f32],
    }
    impl<const LOBES: bool> LobeVisitor<f32> for Run<'_, '_, LOBES> {
        type Out = ();
        fn visit<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
            self,
            _: &KarisHair<f32>,
        ) {
            run_level::<R, TT, TRT, MS, LOBES>(self.level, &self.k, self.inp, self.first, self.out)
        }
    }
    m.dispatch(Run::<LOBES> {
        level,
        k: Consts::new(m),
        inp,
        first,
        out,
    })
}

#[cfg(test)]
mod tests {
    use super::super::{Absorption, Components, KarisParams};
    use crate::fiber::karis::{KarisHair, KarisInputs, Transmittance};
    use crate::simd::testing::{directions, levels, unit64};
    use crate::simd::Level;

    /// The kernel over the whole batch on this thread, at `level` or the
    /// best this CPU has below it.
    fn eval_all<const LOBES: bool>(
        m: &KarisHair<f32>,
        inp: &KarisInputs<'_, f32>,
        out: &mut [f32],
        level: Level,
    ) {
        super::eval_range::<LOBES>(m, inp, 0, out, level.min_with(Level::detect()))
    }

    /// 1. The vector kernel at every level this CPU has, against the scalar
    ///    kernel in f64, for every absorption, component set, separable R
    ///    on/off, a zero color channel and the MS block with per-pair
    ///    transmittance. Bound per value: `2e-5·w + 10·κ` where `w` is the
    ///    f64 value and `κ` its largest change when L or V moves by one f32
    ///    ulp (2^-23) along an axis: the lobes are steep in places
    ///    (cos(φ/2) near φ = π, narrow Gaussians), and f32 rounding of the
    ///    ~10 operations of the geometry is equivalent to a few-ulp
    ///    perturbation of the inputs (the scalar f32 kernel differs from
    ///    f64 by up to 1.7e-4 relative over 2^20 random pairs, 6e-6 at the
    ///    99.9th percentile). Values below 1e-4 of the batch's peak:
    ///    `1e-6·peak` absolute.
    #[test]
    fn t01_vector_kernel_matches_scalar_f64() {
        let n = 3001; // not a multiple of any lane count: tails are exercised
        let (l, v) = (directions(n, 7), directions(n, 11));
        let t = directions(n, 13);
        let shadow: Vec<f32> = (0..n).map(|i| (i % 7) as f32 / 6.0).collect();
        let gs: Vec<f32> = (0..3 * n).map(|i| 0.5 + (i % 5) as f32 / 10.0).collect();
        let ls: Vec<f32> = (0..3 * n).map(|i| (i % 3) as f32 / 20.0).collect();
        let ov: Vec<f32> = (0..n).map(|i| 0.5 + (i % 2) as f32 / 2.0).collect();
        let inp = KarisInputs {
            l: &l,
            v: &v,
            t: &t,
            shadow: &shadow,
            global_scattering: &gs,
            local_scattering: &ls,
            opaque_visibility: &ov,
        };
        let mut cases = Vec::new();
        for absorption in [
            Absorption::Legacy,
            Absorption::Chiang,
            Absorption::ChiangCorrected,
        ] {
            for (separable_r, base_color, scatter) in [
                (true, [0.3, 0.15, 0.08], 0.0),
                (false, [0.6, 0.0, 0.2], 0.7),
            ] {
                for bits in 1..16u32 {
                    cases.push(KarisParams {
                        absorption,
                        separable_r,
                        base_color,
                        scatter,
                        components: Components {
                            r: bits & 1 != 0,
                            tt: bits & 2 != 0,
                            trt: bits & 4 != 0,
                            ms: bits & 8 != 0,
                        },
                        ..Default::default()
                    });
                }
            }
        }
        let levels = levels();
        for p in &cases {
            let m32: KarisHair<f32> = p.build().unwrap();
            let m64: KarisHair<f64> = p.build().unwrap();
            let want: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let tr = Transmittance {
                        shadow: shadow[i] as f64,
                        global_scattering: [0, 1, 2].map(|c| gs[3 * i + c] as f64),
                        local_scattering: [0, 1, 2].map(|c| ls[3 * i + c] as f64),
                        opaque_visibility: ov[i] as f64,
                    };
                    let (l, v, t) = (unit64(&l, i), unit64(&v, i), unit64(&t, i));
                    let pole =
                        |w: &[f64; 3]| (w[0] * t[0] + w[1] * t[1] + w[2] * t[2]).abs() > 0.99999;
                    if pole(&l) || pole(&v) {
                        [f64::NAN; 3]
                    } else {
                        m64.eval(&l, &v, &t, &tr)
                    }
                })
                .collect();
            let peak = want
                .iter()
                .flatten()
                .filter(|x| x.is_finite())
                .fold(0.0f64, |a, &b| a.max(b));
            let kappa: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let tr = Transmittance {
                        shadow: shadow[i] as f64,
                        global_scattering: [0, 1, 2].map(|c| gs[3 * i + c] as f64),
                        local_scattering: [0, 1, 2].map(|c| ls[3 * i + c] as f64),
                        opaque_visibility: ov[i] as f64,
                    };
                    let (l, v, t) = (unit64(&l, i), unit64(&v, i), unit64(&t, i));
                    let mut k = [0.0f64; 3];
                    for axis in 0..6 {
                        let (mut l2, mut v2) = (l, v);
                        let w = if axis < 3 { &mut l2 } else { &mut v2 };
                        w[axis % 3] += 1.0 / (1u64 << 23) as f64;
                        let f = m64.eval(&l2, &v2, &t, &tr);
                        for c in 0..3 {
                            k[c] = k[c].max((f[c] - want[i][c]).abs());
                        }
                    }
                    k
                })
                .collect();
            for &level in &levels {
                let mut out = vec![0.0f32; 3 * n];
                eval_all::<false>(&m32, &inp, &mut out, level);
                for i in 0..n {
                    for c in 0..3 {
                        let (g, w) = (out[3 * i + c] as f64, want[i][c]);
                        if !w.is_finite() {
                            continue;
                        }
                        let ok = if w > 1e-4 * peak {
                            (g - w).abs() <= 2e-5 * w + 10.0 * kappa[i][c]
                        } else {
                            (g - w).abs() <= 1e-6 * peak
                        };
                        assert!(ok, "{level:?} {p:?} pair {i} channel {c}: {g} vs {w} kappa {} l {:?} v {:?} t {:?}", kappa[i][c], &l[3*i..3*i+3], &v[3*i..3*i+3], &t[3*i..3*i+3]);
                    }
                }
            }
        }
    }

    /// 2. Lobes output (12 per pair) sums to the eval output, and degenerate
    ///    or non-finite inputs give 0 at every level.
    #[test]
    fn t02_lobes_and_degenerate_inputs() {
        let m: KarisHair<f32> = KarisParams {
            scatter: 0.5,
            ..Default::default()
        }
        .build()
        .unwrap();
        let mut l = directions(40, 3);
        l[0..3].copy_from_slice(&[0.0, 0.0, 0.0]);
        l[3] = f32::NAN;
        l[6] = f32::INFINITY;
        l[9..12].copy_from_slice(&[1e-30, 0.0, 1e-30]); // tiny but valid
        l[12..15].copy_from_slice(&[1e30, 2e30, 0.0]); // huge but valid
        let v = directions(40, 5);
        let t = [0.0f32, 1.0, 0.0];
        let inp = KarisInputs {
            l: &l,
            v: &v,
            t: &t,
            shadow: &[0.5],
            global_scattering: &[0.9, 0.8, 0.7],
            local_scattering: &[0.0; 3],
            opaque_visibility: &[1.0],
        };
        for level in [Level::Portable, Level::Avx2, Level::Avx512] {
            let mut sum = vec![0.0f32; 3 * 40];
            let mut lobes = vec![0.0f32; 12 * 40];
            eval_all::<false>(&m, &inp, &mut sum, level);
            eval_all::<true>(&m, &inp, &mut lobes, level);
            assert!(
                sum[..9].iter().all(|&x| x == 0.0),
                "{level:?} {:?}",
                &sum[..9]
            );
            assert!(
                sum[9..15].iter().all(|&x| x > 0.0),
                "{level:?} {:?}",
                &sum[9..15]
            );
            for i in 0..40 {
                for c in 0..3 {
                    let s: f32 = (0..4).map(|p| lobes[12 * i + 3 * p + c]).sum();
                    assert!((s.max(0.0) - sum[3 * i + c]).abs() <= 1e-6 * (1.0 + s.abs()));
                }
            }
        }
    }
}
