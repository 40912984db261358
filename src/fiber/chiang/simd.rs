//! Vector kernel of [`ChiangHair::eval`] in `f32` (`I0Mode::Exact`): the
//! terms of `chiang.rs`, one [`Lanes`] vector of direction pairs at a time
//! ([`crate::simd`]).
//!
//! Differences from the scalar path, all at the level of f32 rounding:
//! - the azimuths enter only through `φo + φi`: `Δφ − Φ_p = φo − φi −
//!   (2p γt − 2γi + pπ)` and `γi = φi − π/2 (mod 2π)` give
//!   `φo + φi − 2p γt − (p+1)π`, so one `atan2` of the product
//!   `(xi + i zi)(xo + i zo)` replaces three (a `wi` along the tangent takes
//!   `φi = π/2`, consistent with its `γi = 0`; the scalar path uses
//!   `atan2(0, 0)`: the azimuth of such a direction is undefined);
//! - `γt = atan2(sin γt, cos γt)` instead of `asin`;
//! - `M_p = κ/(1 − e^{−2κ}) · e^{−κ/2 |d|²} · i0e(c)` with i0e from
//!   [`crate::simd::i0_small`] (the `e^{−c}` folded into the one exponential)
//!   or [`crate::simd::i0e_large`]; a vector whose lanes all sit on one side
//!   of the switch computes one polynomial, a mixed one both and one
//!   exponential;
//! - divisions merged: `1/cos θt` serves sin γt and the path length, and
//!   the three N_p and the three channels' A_3 each share one reciprocal
//!   ([`Lanes::recip`], [`Lanes::rsqrt`]: an estimate and a Newton step);
//!   the two Fresnel ratios keep their divisions (see there).
//!
//! Cost (`scripts/bsdf_vs_mitsuba.py`): 111 instructions per pair at AVX2.

use super::ChiangHair;
use crate::simd::{
    atan2_finite, i0_small, i0e_large, load_dir, store, wrap_pi, Lanes, Level, F, I0_SWITCH,
};
#[cfg(target_arch = "x86_64")]
use crate::simd::{F16, F8};

/// A model's constants, copied for the kernel.
#[derive(Clone, Copy)]
pub(super) struct Consts {
    eta: f32,
    inv_eta: f32,
    neg_sigma_a: [f32; 3],
    /// sin, cos of the cuticle tilt of θi per lobe (−2α, α, 4α, 0).
    sin_tilt: [f32; 4],
    cos_tilt: [f32; 4],
    kappa: [f32; 4],
    half_kappa: [f32; 4],
    /// κ/(1 − e^{−2κ}) per lobe, the residual's times 1/2π.
    norm: [f32; 4],
    inv_s: f32,
    /// Trimmed-logistic normalization over s.
    n_scale: f32,
}

impl Consts {
    pub(super) fn new(m: &ChiangHair<f32>) -> Self {
        let v_min = crate::fiber::lobes::V_MIN;
        let kappa: [f64; 4] = m.v.map(|v| 1.0 / (v as f64).max(v_min));
        let norm = std::array::from_fn(|p| {
            let n = kappa[p] / -(-2.0 * kappa[p]).exp_m1();
            (if p == 3 { n / std::f64::consts::TAU } else { n }) as f32
        });
        let (s, c) = (m.sin_2k_alpha, m.cos_2k_alpha);
        Self {
            eta: m.eta,
            inv_eta: (1.0 / m.eta as f64) as f32,
            neg_sigma_a: m.sigma_a.map(|x| -x),
            sin_tilt: [-s[1], s[0], s[2], 0.0],
            cos_tilt: [c[1], c[0], c[2], 1.0],
            kappa: kappa.map(|k| k as f32),
            half_kappa: kappa.map(|k| (0.5 * k) as f32),
            norm,
            inv_s: (1.0 / m.s as f64) as f32,
            n_scale: (m.inv_norm as f64 / m.s as f64) as f32,
        }
    }
}

/// `e^{−κ/2 |d|²} i0e(c)` times the lobe's normalization: d'Eon's M_p.
#[inline(always)]
pub(super) fn m_p<V: Lanes>(k: &Consts, p: usize, sin_i: V, cos_i: V, sin_o: V, cos_o: V) -> V {
    // θi tilted by the cuticle scales: sin(θi + t), |cos(θi + t)|.
    let (st, ct) = (k.sin_tilt[p], k.cos_tilt[p]);
    let (sin_ip, cos_ip) = if p == 3 {
        (sin_i, cos_i)
    } else {
        (
            sin_i.mul_add(V::splat(ct), cos_i * st),
            cos_i.mul_add(V::splat(ct), -(sin_i * st)).abs(),
        )
    };
    let dc = cos_ip - cos_o;
    let ds = sin_ip + sin_o;
    let d2 = dc.mul_add(dc, ds * ds);
    let c = cos_ip * cos_o * k.kappa[p];
    let e = d2 * -k.half_kappa[p];
    let small = c.le(V::splat(I0_SWITCH));
    // e^{e} i0e(c): the series carries e^{−c} in the exponential, the
    // large-argument polynomial includes it.
    let m = if V::all(small) {
        (e - c).exp_bounded() * i0_small(c * c * 0.25)
    } else if V::all(c.gt(V::splat(I0_SWITCH))) {
        e.exp_bounded() * i0e_large(c)
    } else {
        // Each polynomial sees arguments inside its range; one exponential.
        let cs = c.min(V::splat(I0_SWITCH));
        let cl = c.max(V::splat(I0_SWITCH));
        V::select(small, e - c, e).exp_bounded()
            * V::select(small, i0_small(cs * cs * 0.25), i0e_large(cl))
    };
    m * k.norm[p]
}

/// The trimmed logistic N_p at the wrapped azimuth `x` as a fraction
/// `(e · scale, (1 + e)²)`, `e = e^{−|x|/s}`: the three lobes share one
/// division.
#[inline(always)]
fn n_p_parts<V: Lanes>(k: &Consts, x: V) -> (V, V) {
    let e = (wrap_pi(x).abs() * -k.inv_s).exp_bounded();
    let d = e + 1.0;
    (e * k.n_scale, d * d)
}

/// RGB `eval` of `V::N` pairs and the lanes that are valid.
#[inline(always)]
fn eval_lanes<V: Lanes>(
    k: &Consts,
    wi: &[f32],
    wo: &[f32],
    base: usize,
    count: usize,
) -> ([V; 3], V::Mask) {
    let c = V::splat;
    let (i, ok_i) = load_dir::<V>(wi, base, count);
    let (o, ok_o) = load_dir::<V>(wo, base, count);
    // Longitudinal angles (y = tangent).
    let ri2 = i[0].mul_add(i[0], i[2] * i[2]);
    // Offset h = sin γi and cos γi of wi; (0, 1) along the tangent (or
    // within 1e-19 of it, where 1/ri would not be a normal number).
    let along = ri2.lt(c(f32::MIN_POSITIVE));
    let inv_ri = V::select(along, c(1.0), ri2).rsqrt();
    let (sin_i, cos_i) = (i[1], (ri2 * inv_ri).min(c(1.0)));
    let (sin_o, cos_o) = (o[1], o[0].mul_add(o[0], o[2] * o[2]).sqrt().min(c(1.0)));
    let xi = V::select(along, c(0.0), i[0] * inv_ri);
    let zi = V::select(along, c(1.0), i[2] * inv_ri);
    let (h, cos_gamma_i) = (-xi, zi);
    // φo + φi from the product of the azimuthal phasors.
    let phi_sum = atan2_finite(xi.mul_add(o[2], zi * o[0]), xi.mul_add(o[0], -(zi * o[2])));

    // Transmission: θt (Bravais), γt with the modified index
    // η' = √(η² − sin²θi)/cos θi = η cos θt / cos θi, so sin γt = h cos θi /
    // (η cos θt) and the path 2 cos γt / cos θt share 1/cos θt. No
    // refracted ray (η < 1 past the critical angle): NaN, so the pair gives 0.
    let sin_t = sin_i * k.inv_eta;
    let cos_t2 = (-sin_t).mul_add(sin_t, c(1.0));
    let inv_cos_t = V::select(
        cos_t2.gt(c(0.0)),
        cos_t2.max(c(f32::MIN_POSITIVE)).rsqrt(),
        c(f32::NAN),
    );
    let sin_gamma_t = (h * cos_i * inv_cos_t * k.inv_eta).clamp(-1.0, 1.0);
    let cos_gamma_t = (-sin_gamma_t)
        .mul_add(sin_gamma_t, c(1.0))
        .max(c(0.0))
        .sqrt();
    let gamma_t = atan2_finite(sin_gamma_t, cos_gamma_t);
    let length = (cos_gamma_t + cos_gamma_t) * inv_cos_t;
    let mut t = [c(0.0); 3];
    for (tc, s) in t.iter_mut().zip(k.neg_sigma_a) {
        *tc = (length * s).exp_bounded();
    }

    // Fresnel at cos θi cos γi (from outside, so cos ≥ 0). Two divisions:
    // under total internal reflection (η < 1) each ratio is then ±1 exactly
    // and f = 1, which A_3 = (1 − f) f² T³ + O((1 − f)²) needs (an f one ulp
    // below 1 would add 1.2e-7 · M_3).
    let cf = cos_i * cos_gamma_i.abs();
    let ct = (c(1.0) - (c(1.0) - cf * cf) * (k.inv_eta * k.inv_eta))
        .max(c(0.0))
        .sqrt();
    let a_s = (cf - ct * k.eta) / ct.mul_add(c(k.eta), cf);
    let a_p = (ct - cf * k.eta) / cf.mul_add(c(k.eta), ct);
    let f = V::select(cf.le(c(0.0)), c(1.0), (a_s * a_s + a_p * a_p) * 0.5);

    // M_p N_p per explicit lobe (the N_p share one division); the
    // residual's M/2π.
    let pi = std::f32::consts::PI;
    let (n0, q0) = n_p_parts(k, phi_sum - pi);
    let (n1, q1) = n_p_parts(k, gamma_t.mul_add(c(-2.0), phi_sum));
    let (n2, q2) = n_p_parts(k, gamma_t.mul_add(c(-4.0), phi_sum) - pi);
    // (1 + e)² ∈ [1, 4]: the product is a normal number.
    let inv_q = (q0 * q1 * q2).recip();
    let d0 = m_p(k, 0, sin_i, cos_i, sin_o, cos_o) * (n0 * q1 * q2 * inv_q);
    let d1 = m_p(k, 1, sin_i, cos_i, sin_o, cos_o) * (n1 * q0 * q2 * inv_q);
    let d2 = m_p(k, 2, sin_i, cos_i, sin_o, cos_o) * (n2 * q0 * q1 * inv_q);
    let d3 = m_p(k, 3, sin_i, cos_i, sin_o, cos_o);

    // A_p per channel: f, (1−f)² T, A_1 T f, A_2 f T / (1 − T f); the
    // channels share one division. 1 − T f is 0 or at least 6e-8 in f32,
    // so the clamped product of three is a normal number.
    let g = c(1.0) - f;
    let a1_scale = g * g;
    let tf = t.map(|t| t * f);
    let den = tf.map(|x| c(1.0) - x);
    let den_c = den.map(|x| x.max(c(1e-12)));
    let inv_den = (den_c[0] * den_c[1] * den_c[2]).recip();
    let other = [
        den_c[1] * den_c[2],
        den_c[0] * den_c[2],
        den_c[0] * den_c[1],
    ];
    let mut rgb = [c(0.0); 3];
    for ch in 0..3 {
        let a1 = a1_scale * t[ch];
        let a2 = a1 * tf[ch];
        let a3 = V::select(
            den[ch].gt(c(0.0)),
            a2 * tf[ch] * other[ch] * inv_den,
            c(0.0),
        );
        rgb[ch] = a3.mul_add(d3, a2.mul_add(d2, a1.mul_add(d1, f * d0)));
    }
    // Every term is ≥ 0, so the sum is finite exactly when each is.
    let finite = (rgb[0] + rgb[1] + rgb[2]).is_finite();
    (rgb, ok_i & ok_o & finite)
}

/// Pairs `base..base + out.len()/3` into `out`.
#[inline(always)]
fn run<V: Lanes>(k: &Consts, wi: &[f32], wo: &[f32], base: usize, out: &mut [f32]) {
    let n = out.len() / 3;
    let zero = V::splat(0.0);
    let mut j = 0;
    while j < n {
        let count = (n - j).min(V::N);
        let (rgb, ok) = eval_lanes::<V>(k, wi, wo, base + j, count);
        let x = [
            V::select(ok, rgb[0], zero),
            V::select(ok, rgb[1], zero),
            V::select(ok, rgb[2], zero),
        ];
        store::<V, 3>(&mut out[3 * j..3 * (j + count)], &x, count);
        j += count;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn run_avx512(k: &Consts, wi: &[f32], wo: &[f32], base: usize, out: &mut [f32]) {
    run::<F16>(k, wi, wo, base, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2(k: &Consts, wi: &[f32], wo: &[f32], base: usize, out: &mut [f32]) {
    run::<F8>(k, wi, wo, base, out)
}

/// `eval` of pairs `first..first + out.len()/3` of the flat `(N, 3)` (or
/// broadcast) arrays `wi`, `wo` at `level` (at most [`Level::detect`]'s),
/// on this thread; degenerate pairs give 0, as do non-finite results. The
/// model's I0 mode is taken as exact.
pub fn eval_range(
    m: &ChiangHair<f32>,
    wi: &[f32],
    wo: &[f32],
    first: usize,
    out: &mut [f32],
    level: Level,
) {
    let k = Consts::new(m);
    match level {
        // SAFETY: `Level::detect` returns these levels only when the CPU
        // has the features the functions are compiled for (callers pass
        // at most that level).
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { run_avx512(&k, wi, wo, first, out) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { run_avx2(&k, wi, wo, first, out) },
        _ => run::<F<4>>(&k, wi, wo, first, out),
    }
}

#[cfg(test)]
mod tests {
    use crate::fiber::chiang::{ChiangHair, ChiangParams};
    use crate::simd::testing::{directions, levels, unit64};
    use crate::simd::Level;

    /// The kernel over the whole batch on this thread, at `level` or the
    /// best this CPU has below it.
    fn eval_all(m: &ChiangHair<f32>, wi: &[f32], wo: &[f32], out: &mut [f32], level: Level) {
        super::eval_range(m, wi, wo, 0, out, level.min_with(Level::detect()))
    }

    /// 1. The vector kernel at every level this CPU has, against the scalar
    ///    kernel in f64, over roughness 1e-3..1, tilt ±10°, η from 1.01 to
    ///    3 and below 1, no and strong absorption. Bound per value:
    ///    `2e-5·w + 10·κ`, with `w` the f64 value and `κ` its largest change
    ///    when wi or wo moves by one f32 ulp (2^-23) along an axis: f32
    ///    rounding of the geometry is a few-ulp perturbation of the inputs,
    ///    and the narrow lobes of smooth fibers amplify it. Values below
    ///    1e-4 of the batch's peak: `1e-6·peak` absolute.
    #[test]
    fn t01_vector_kernel_matches_scalar_f64() {
        let n = 3001; // not a multiple of any lane count: tails are exercised
        let (wi, wo) = (directions(n, 7), directions(n, 11));
        let mut cases = Vec::new();
        for (bm, bn) in [(0.3, 0.3), (0.0, 0.0), (0.05, 0.1), (1.0, 1.0), (0.2, 0.7)] {
            for (eta, tilt, sigma_a) in [
                (1.55, 2.0, None),
                (1.01, -10.0, Some([0.0; 3])),
                (3.0, 10.0, Some([5.0, 1.0, 0.01])),
                (0.8, 3.0, Some([0.2, 0.3, 0.4])),
            ] {
                cases.push(ChiangParams {
                    longitudinal_roughness: bm,
                    azimuthal_roughness: bn,
                    eta,
                    scale_tilt: tilt,
                    sigma_a,
                    ..Default::default()
                });
            }
        }
        let mut worst_rel = 0.0f64;
        for p in &cases {
            let m32: ChiangHair<f32> = p.build().unwrap();
            let m64: ChiangHair<f64> = p.build().unwrap();
            let want: Vec<[f64; 3]> = (0..n)
                .map(|i| m64.eval(&unit64(&wi, i), &unit64(&wo, i)))
                .collect();
            let peak = want.iter().flatten().fold(0.0f64, |a, &b| a.max(b));
            let kappa: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let (a, b) = (unit64(&wi, i), unit64(&wo, i));
                    let mut k = [0.0f64; 3];
                    for axis in 0..6 {
                        let (mut a2, mut b2) = (a, b);
                        let w = if axis < 3 { &mut a2 } else { &mut b2 };
                        w[axis % 3] += 1.0 / (1u64 << 23) as f64;
                        let f = m64.eval(&a2, &b2);
                        for c in 0..3 {
                            k[c] = k[c].max((f[c] - want[i][c]).abs());
                        }
                    }
                    k
                })
                .collect();
            for &level in &levels() {
                let mut out = vec![0.0f32; 3 * n];
                eval_all(&m32, &wi, &wo, &mut out, level);
                for i in 0..n {
                    for c in 0..3 {
                        let (g, w) = (out[3 * i + c] as f64, want[i][c]);
                        let ok = if w > 1e-4 * peak {
                            worst_rel = worst_rel.max((g - w).abs() / w);
                            (g - w).abs() <= 2e-5 * w + 10.0 * kappa[i][c]
                        } else {
                            (g - w).abs() <= 1e-6 * peak
                        };
                        assert!(
                            ok,
                            "{level:?} {p:?} pair {i} channel {c}: {g} vs {w} kappa {} wi {:?} wo {:?}",
                            kappa[i][c],
                            &wi[3 * i..3 * i + 3],
                            &wo[3 * i..3 * i + 3]
                        );
                    }
                }
            }
        }
        eprintln!("worst relative difference {worst_rel:e}");
    }

    /// 2. Degenerate and edge directions at every level: zero, NaN and
    ///    infinite components give 0; wi or wo along the tangent (±y), h =
    ///    ±1 (wi = ∓x) and V = ±L give finite, non-negative values, equal
    ///    to the f64 kernel's where both azimuths are defined (not along
    ///    the tangent).
    #[test]
    fn t02_degenerate_and_edge_directions() {
        let m32: ChiangHair<f32> = ChiangParams::default().build().unwrap();
        let m64: ChiangHair<f64> = ChiangParams::default().build().unwrap();
        let wi: Vec<f32> = vec![
            0.0,
            0.0,
            0.0, //
            f32::NAN,
            0.0,
            1.0, //
            f32::INFINITY,
            0.0,
            0.0, //
            0.0,
            1.0,
            0.0, // along the tangent
            1.0,
            0.0,
            0.0, // h = -1
            -1.0,
            0.0,
            0.0, // h = 1
            0.3,
            -0.4,
            0.5, // V = L
            0.3,
            -0.4,
            0.5, // V = -L
            1e-30,
            0.0,
            1e-30, // tiny but valid
        ];
        let wo: Vec<f32> = vec![
            0.0, 0.0, 1.0, //
            0.0, 0.0, 1.0, //
            0.0, 0.0, 1.0, //
            0.2, 0.3, 0.1, //
            0.0, 0.0, 1.0, //
            0.0, -1.0, 0.0, // wo along the tangent
            0.3, -0.4, 0.5, //
            -0.3, 0.4, -0.5, //
            0.1, 0.2, 0.3, //
        ];
        let n = wi.len() / 3;
        for level in levels() {
            let mut out = vec![-1.0f32; 3 * n];
            eval_all(&m32, &wi, &wo, &mut out, level);
            assert!(
                out[..9].iter().all(|&x| x == 0.0),
                "{level:?} {:?}",
                &out[..9]
            );
            assert!(
                out.iter().all(|x| x.is_finite() && *x >= 0.0),
                "{level:?} {out:?}"
            );
            for i in (4..n).filter(|&i| i != 5) {
                let a = crate::fiber::frame::normalized(&[0, 1, 2].map(|c| wi[3 * i + c] as f64))
                    .unwrap();
                let b = crate::fiber::frame::normalized(&[0, 1, 2].map(|c| wo[3 * i + c] as f64))
                    .unwrap();
                let want = m64.eval(&a, &b);
                for c in 0..3 {
                    let g = out[3 * i + c] as f64;
                    assert!(
                        (g - want[c]).abs() <= 1e-5 * want[c] + 1e-7,
                        "{level:?} pair {i}: {g} vs {}",
                        want[c]
                    );
                }
            }
        }
    }
}
