//! Vector kernel of [`ChiangFarTable::eval`]: the tabulated far field of
//! ChiangHair, one [`Lanes`] vector of direction pairs at a time
//! ([`crate::simd`]).
//!
//! The vector part computes what is arithmetic: the directions' longitudinal
//! angles, `|φo − φi|` (one `atan2` of the cross and dot products of the two
//! projections on the normal plane), the four `M_p` (the near-field
//! kernel's, exact I0). The bilinear look-ups of `N̄_p` (9 values at 4
//! nodes) and `Ā_3` are gathers, done lane by lane by the table's own
//! [`ChiangFarTable::azimuthal`], so a lane's value depends on that lane
//! alone.
//!
//! Differences from the scalar path, all at the level of f32 rounding: `M_p`
//! through [`super::simd::m_p`] (its I0 polynomials), and `|φo − φi|` from
//! one `atan2` instead of the difference of two. A direction along the
//! tangent has no azimuth: the kernel takes `φ = 0` for such a pair (the
//! cross and dot products are 0), the scalar path `|φ|` of the other
//! direction (it takes `atan2(0, 0) = 0` as the undefined azimuth).

use super::simd::{m_p, Consts};
use super::ChiangFarTable;
use crate::simd::{atan2, dot, load_dir, Lanes, Level, F};
#[cfg(target_arch = "x86_64")]
use crate::simd::{F16, F8};

/// RGB of `count ≤ V::N` pairs from `base` into `out[..3 count]`, for
/// `wi`, `wo` in the fiber frame.
#[inline(always)]
fn eval_lanes<V: Lanes>(
    k: &Consts,
    t: &ChiangFarTable,
    wi: &[f32],
    wo: &[f32],
    base: usize,
    count: usize,
    out: &mut [f32],
) {
    let c = V::splat;
    let (i, ok_i) = load_dir::<V>(wi, base, count);
    let (o, ok_o) = load_dir::<V>(wo, base, count);
    // Longitudinal angles (y = tangent).
    let (sin_i, cos_i) = (i[1], i[0].mul_add(i[0], i[2] * i[2]).sqrt().min(c(1.0)));
    let (sin_o, cos_o) = (o[1], o[0].mul_add(o[0], o[2] * o[2]).sqrt().min(c(1.0)));
    // |φo − φi| ∈ [0, π] from the projections (x, z) of wi and wo.
    let cross = i[2].mul_add(o[0], -(i[0] * o[2]));
    let dot = i[0].mul_add(o[0], i[2] * o[2]);
    let phi = atan2(cross.abs(), dot);
    let angles = Angles {
        sin_i,
        cos_i,
        sin_o,
        cos_o,
        phi,
    };
    look_up(k, t, &angles, ok_i & ok_o, count, out)
}

/// As [`eval_lanes`] for world-space `v` (towards the viewer: wi), `l`
/// (towards the light: wo) and the fiber tangent `tan`, each a flat
/// `(N, 3)` array of unit vectors, or one broadcast vector.
#[inline(always)]
fn eval_world_lanes<V: Lanes>(
    k: &Consts,
    t: &ChiangFarTable,
    (v, l, tan): (&[f32], &[f32], &[f32]),
    base: usize,
    count: usize,
    out: &mut [f32],
) {
    let c = V::splat;
    let (v, ok_v) = load_dir::<V>(v, base, count);
    let (l, ok_l) = load_dir::<V>(l, base, count);
    let (tn, ok_t) = load_dir::<V>(tan, base, count);
    let sin_i = dot(&tn, &v).clamp(-1.0, 1.0);
    let sin_o = dot(&tn, &l).clamp(-1.0, 1.0);
    let cos_i = sin_i.mul_add(-sin_i, c(1.0)).max(c(0.0)).sqrt();
    let cos_o = sin_o.mul_add(-sin_o, c(1.0)).max(c(0.0)).sqrt();
    // Projections on the normal plane, and the angle between them (no
    // closures in a kernel: see `crate::simd::load_dir`).
    let vp = [
        tn[0].mul_add(-sin_i, v[0]),
        tn[1].mul_add(-sin_i, v[1]),
        tn[2].mul_add(-sin_i, v[2]),
    ];
    let lp = [
        tn[0].mul_add(-sin_o, l[0]),
        tn[1].mul_add(-sin_o, l[1]),
        tn[2].mul_add(-sin_o, l[2]),
    ];
    let cx = vp[1].mul_add(lp[2], -(vp[2] * lp[1]));
    let cy = vp[2].mul_add(lp[0], -(vp[0] * lp[2]));
    let cz = vp[0].mul_add(lp[1], -(vp[1] * lp[0]));
    let cross = cx.mul_add(cx, cy.mul_add(cy, cz * cz)).sqrt();
    let phi = atan2(cross, dot(&vp, &lp));
    let angles = Angles {
        sin_i,
        cos_i,
        sin_o,
        cos_o,
        phi,
    };
    look_up(k, t, &angles, ok_v & ok_l & ok_t, count, out)
}

/// The angles the far field depends on, per lane.
#[derive(Clone, Copy)]
struct Angles<V> {
    sin_i: V,
    cos_i: V,
    sin_o: V,
    cos_o: V,
    /// |φo − φi| ∈ [0, π].
    phi: V,
}

/// `Σ_p M_p N̄_p + M_3 Ā_3` (RGB) of the lanes `..count` into `out`; lanes
/// outside `ok` give 0.
#[inline(always)]
fn look_up<V: Lanes>(
    k: &Consts,
    t: &ChiangFarTable,
    a: &Angles<V>,
    ok: V::Mask,
    count: usize,
    out: &mut [f32],
) {
    let c = V::splat;
    let Angles {
        sin_i,
        cos_i,
        sin_o,
        cos_o,
        phi,
    } = *a;
    let m = [
        m_p(k, 0, sin_i, cos_i, sin_o, cos_o),
        m_p(k, 1, sin_i, cos_i, sin_o, cos_o),
        m_p(k, 2, sin_i, cos_i, sin_o, cos_o),
        m_p(k, 3, sin_i, cos_i, sin_o, cos_o),
    ];
    let ok = V::select(ok, c(1.0), c(0.0));

    // The table's look-ups lane by lane (gathers), as the scalar path does.
    let mut lanes = [[0.0f32; 16]; 7];
    for (dst, v) in lanes
        .iter_mut()
        .zip([m[0], m[1], m[2], m[3], cos_i, phi, ok])
    {
        v.store(dst);
    }
    let [m0, m1, m2, m3, cos_i, phi, ok] = &lanes;
    for j in 0..count {
        let o = &mut out[3 * j..3 * j + 3];
        if ok[j] == 0.0 {
            o.fill(0.0);
            continue;
        }
        let (n, a3) = t.azimuthal(cos_i[j], phi[j]);
        let mp = [m0[j], m1[j], m2[j]];
        for (ch, o) in o.iter_mut().enumerate() {
            let mut sum = 0.0f32;
            for (p, &mpj) in mp.iter().enumerate() {
                sum += finite_or_zero(mpj * n[p][ch]);
            }
            *o = sum + finite_or_zero(m3[j] * a3[ch]);
        }
    }
}

#[inline(always)]
fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

/// The directions of a batch.
#[derive(Clone, Copy)]
pub enum Pairs<'a> {
    /// `wi`, `wo` in the fiber frame (y = tangent).
    Local(&'a [f32], &'a [f32]),
    /// World-space view `v` (wi), light `l` (wo) and tangent `t`, unit
    /// vectors.
    World(&'a [f32], &'a [f32], &'a [f32]),
}

/// Pairs `base..base + out.len()/3` into `out`.
#[inline(always)]
fn run<V: Lanes>(k: &Consts, t: &ChiangFarTable, pairs: Pairs<'_>, base: usize, out: &mut [f32]) {
    let n = out.len() / 3;
    let mut j = 0;
    while j < n {
        let count = (n - j).min(V::N);
        let o = &mut out[3 * j..3 * (j + count)];
        match pairs {
            Pairs::Local(wi, wo) => eval_lanes::<V>(k, t, wi, wo, base + j, count, o),
            Pairs::World(v, l, tan) => eval_world_lanes::<V>(k, t, (v, l, tan), base + j, count, o),
        }
        j += count;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn run_avx512(
    k: &Consts,
    t: &ChiangFarTable,
    pairs: Pairs<'_>,
    base: usize,
    out: &mut [f32],
) {
    run::<F16>(k, t, pairs, base, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2(k: &Consts, t: &ChiangFarTable, pairs: Pairs<'_>, base: usize, out: &mut [f32]) {
    run::<F8>(k, t, pairs, base, out)
}

/// [`ChiangFarTable::eval`] of pairs `first..first + out.len()/3` of
/// `pairs` (flat `(N, 3)` arrays, or broadcast vectors) at `level` (at most
/// [`Level::detect`]'s), on this thread; degenerate directions give 0, as
/// do non-finite lobes.
pub fn eval_range(
    t: &ChiangFarTable,
    pairs: Pairs<'_>,
    first: usize,
    out: &mut [f32],
    level: Level,
) {
    let k = Consts::new(t.model());
    match level {
        // SAFETY: `Level::detect` returns these levels only when the CPU
        // has the features the functions are compiled for (callers pass
        // at most that level).
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { run_avx512(&k, t, pairs, first, out) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { run_avx2(&k, t, pairs, first, out) },
        _ => run::<F<4>>(&k, t, pairs, first, out),
    }
}

#[cfg(test)]
mod tests {
    use crate::fiber::chiang::{ChiangFarTable, ChiangHair, ChiangParams, TableSize};
    use crate::simd::testing::{directions, levels};
    use crate::simd::Level;

    fn table(p: &ChiangParams) -> ChiangFarTable {
        let m: ChiangHair<f64> = p.build().unwrap();
        ChiangFarTable::new(&m, TableSize::for_scale(m.logistic_scale()))
    }

    fn unit32(a: &[f32], i: usize) -> Option<[f32; 3]> {
        let v = [a[3 * i] as f64, a[3 * i + 1] as f64, a[3 * i + 2] as f64];
        crate::fiber::frame::normalized(&v).map(|u| u.map(|x| x as f32))
    }

    /// 1. The vector kernel at every level this CPU has against the scalar
    ///    table look-up, over smooth to rough fibers, tilt and absorption.
    ///    Bound per value: `1e-4·w + 1e-6·peak` (measured worst relative
    ///    difference 1.1e-5). The look-ups are the same
    ///    arithmetic; what differs is `M_p` (the vector kernel's I0
    ///    polynomials and exponentials agree with libm to ~2e-6 relative,
    ///    amplified by at most ~κ·|Δ(cos θ)| for the narrowest lobes) and
    ///    `φ` from one `atan2` (a few ulp, moving a value by its slope in
    ///    φ: ≤ 1e-6 of the peak at these scales).
    #[test]
    fn t01_vector_kernel_matches_scalar_lookup() {
        let n = 3001;
        let (wi, wo) = (directions(n, 3), directions(n, 5));
        let mut worst = 0.0f64;
        for (bm, bn) in [(0.3, 0.3), (0.1, 0.1), (0.8, 0.9)] {
            for (tilt, sigma_a) in [
                (2.0, None),
                (-5.0, Some([0.0; 3])),
                (0.0, Some([4.0, 1.0, 0.05])),
            ] {
                let p = ChiangParams {
                    longitudinal_roughness: bm,
                    azimuthal_roughness: bn,
                    scale_tilt: tilt,
                    sigma_a,
                    ..Default::default()
                };
                let t = table(&p);
                let want: Vec<[f32; 3]> = (0..n)
                    .map(|i| match (unit32(&wi, i), unit32(&wo, i)) {
                        (Some(a), Some(b)) => t.eval(&a, &b),
                        _ => [0.0; 3],
                    })
                    .collect();
                let peak = want.iter().flatten().fold(0.0f32, |a, &b| a.max(b)) as f64;
                for &level in &levels() {
                    let mut out = vec![-1.0f32; 3 * n];
                    super::eval_range(
                        &t,
                        super::Pairs::Local(&wi, &wo),
                        0,
                        &mut out,
                        level.min_with(Level::detect()),
                    );
                    for i in 0..n {
                        for c in 0..3 {
                            let (g, w) = (out[3 * i + c] as f64, want[i][c] as f64);
                            if w > 1e-3 * peak {
                                worst = worst.max((g - w).abs() / w);
                            }
                            assert!(
                                (g - w).abs() <= 1e-4 * w + 1e-6 * peak,
                                "{level:?} {p:?} pair {i} channel {c}: {g} vs {w}"
                            );
                        }
                    }
                }
            }
        }
        eprintln!("worst relative difference {worst:e}");
    }

    /// 2. Degenerate directions (zero, NaN, infinite) give 0 at every
    ///    level; directions along the tangent and V = ±L give finite,
    ///    non-negative values.
    #[test]
    fn t02_degenerate_directions() {
        let t = table(&ChiangParams::default());
        let wi: Vec<f32> = vec![
            0.0,
            0.0,
            0.0,
            f32::NAN,
            0.0,
            1.0,
            f32::INFINITY,
            0.0,
            0.0,
            0.0,
            1.0,
            0.0,
            0.3,
            -0.4,
            0.5,
            0.3,
            -0.4,
            0.5,
        ];
        let wo: Vec<f32> = vec![
            0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.2, 0.3, 0.1, 0.3, -0.4, 0.5, -0.3, 0.4,
            -0.5,
        ];
        for level in levels() {
            let mut out = vec![-1.0f32; wi.len()];
            super::eval_range(
                &t,
                super::Pairs::Local(&wi, &wo),
                0,
                &mut out,
                level.min_with(Level::detect()),
            );
            assert!(out[..9].iter().all(|&x| x == 0.0), "{level:?} {out:?}");
            assert!(
                out.iter().all(|x| x.is_finite() && *x >= 0.0),
                "{level:?} {out:?}"
            );
            assert!(out[9..].iter().any(|&x| x > 0.0), "{level:?} {out:?}");
        }
    }

    /// 3. World-space directions (view, light, tangent: the renderer's
    ///    batches) against the scalar look-up from the angles the renderer
    ///    computes per point (`fiber::frame::FiberAngles`): the same bound
    ///    as test 1.
    #[test]
    fn t03_world_space_matches_angles() {
        let n = 2001;
        let (v, l, tan) = (directions(n, 13), directions(n, 17), directions(n, 19));
        let unit = |a: &[f32]| -> Vec<f32> {
            (0..n)
                .flat_map(|i| unit32(a, i).unwrap_or([0.0; 3]))
                .collect()
        };
        let (v, l, tan) = (unit(&v), unit(&l), unit(&tan));
        let t = table(&ChiangParams::default());
        let g = |a: &[f32], i: usize| glam::Vec3::from_slice(&a[3 * i..]);
        let want: Vec<[f32; 3]> = (0..n)
            .map(|i| {
                let a = crate::fiber::frame::FiberAngles::new(g(&tan, i), g(&v, i), g(&l, i));
                let lobes = t.lobes_from_angles(a.view, a.light, a.phi);
                std::array::from_fn(|c| lobes.iter().map(|x| x[c]).sum())
            })
            .collect();
        let peak = want.iter().flatten().fold(0.0f32, |a, &b| a.max(b));
        for level in levels() {
            let mut out = vec![-1.0f32; 3 * n];
            let pairs = super::Pairs::World(&v, &l, &tan);
            super::eval_range(&t, pairs, 0, &mut out, level.min_with(Level::detect()));
            for i in 0..n {
                for c in 0..3 {
                    let (g, w) = (out[3 * i + c], want[i][c]);
                    assert!(
                        (g - w).abs() <= 1e-4 * w + 1e-6 * peak,
                        "{level:?} pair {i} channel {c}: {g} vs {w}"
                    );
                }
            }
        }
    }
}
