//! Property-based tests (proptest) of every fiber model over the full
//! parameter and direction ranges, extremes included: roughness 0, 1/255
//! and 1, θ → ±90°, φ = 0 and π exactly, h = ±1, σa = 0 and 1e3, η from
//! 1.01 to 3, V = ±L, L or V along the tangent, denormal and huge direction
//! components; f32 and f64. Every output is finite and ≥ 0, nothing
//! panics, and f32 agrees with f64 (bounds below, each with its reason).
//! The Python suite (tests/test_stress.py) runs the same properties through
//! the bindings with hypothesis.

use hairshade::batch::{chiang_eval_simd, karis_eval_simd};
use hairshade::fiber::deon::DEonParams;
use hairshade::fiber::karis::KarisInputs;
use hairshade::fiber::karis::{Absorption, Components, KarisParams, Transmittance};
use hairshade::fiber::{ChiangHair, ChiangParams};
use hairshade::simd::Level;
use proptest::prelude::*;

/// Directions: random, axis-aligned (along the tangent y, so θ = ±90°),
/// in the normal plane (θ = 0, φ = 0 / π exactly against ±x), and with
/// denormal or huge components. Not necessarily unit length.
fn direction() -> impl Strategy<Value = [f64; 3]> {
    let finite = prop_oneof![
        -1.0f64..1.0,
        Just(0.0),
        Just(-0.0),
        Just(1e-310),
        Just(-1e-310),
        Just(1e300),
        Just(1.0),
        Just(-1.0)
    ];
    prop_oneof![
        [finite.clone(), finite.clone(), finite]
            .prop_filter("non-zero", |w| w.iter().any(|x| *x != 0.0)),
        Just([0.0, 1.0, 0.0]),
        Just([0.0, -1.0, 0.0]),
        Just([1.0, 0.0, 0.0]),
        Just([-1.0, 0.0, 0.0]),
        Just([0.0, 0.0, 1.0]),
        Just([1.0, 1e-7, 0.0]),
    ]
}

fn roughness() -> impl Strategy<Value = f64> {
    prop_oneof![0.0f64..=1.0, Just(0.0), Just(1.0 / 255.0), Just(1.0)]
}

fn unit(w: [f64; 3]) -> Option<[f64; 3]> {
    hairshade::fiber::frame::normalized(&w)
}

fn ok(x: &[f64]) -> bool {
    x.iter().all(|v| v.is_finite() && *v >= 0.0)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// 1. ChiangHair eval / pdf / sample: finite and ≥ 0 in f32 and f64,
    ///    and the f32 vector kernel at every level this CPU has (given the
    ///    raw, unnormalized directions) too; where the pair is well
    ///    conditioned (roughness ≥ 0.02, wi and wo more than 2.6° from the
    ///    tangent) the vector kernel agrees with the f64 kernel to 1e-3 of
    ///    the larger value plus 1e-6 absolute (the tight bound on random
    ///    pairs is src/fiber/chiang/simd.rs test 1).
    #[test]
    fn p01_chiang_finite_nonnegative(
        wi in direction(), wo in direction(),
        beta_m in roughness(), beta_n in roughness(),
        sigma in prop_oneof![0.0f64..10.0, Just(0.0), Just(1e3)],
        eta in prop_oneof![1.01f64..3.0, Just(1.01), Just(3.0)],
        u in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0),
    ) {
        let (raw_i, raw_o) = (wi.map(|x| x as f32), wo.map(|x| x as f32));
        let (Some(wi), Some(wo)) = (unit(wi), unit(wo)) else { return Ok(()); };
        let p = ChiangParams {
            sigma_a: Some([sigma, sigma * 0.5, 0.0]),
            longitudinal_roughness: beta_m,
            azimuthal_roughness: beta_n,
            eta,
            ..Default::default()
        };
        let m64: ChiangHair<f64> = p.build().unwrap();
        let m32: ChiangHair<f32> = p.build().unwrap();
        prop_assert!(ok(&m64.eval(&wi, &wo)));
        prop_assert!(m64.pdf(&wi, &wo).is_finite() && m64.pdf(&wi, &wo) >= 0.0);
        let (d, w, pdf) = m64.sample(&wi, u.0, [u.1, u.2]);
        prop_assert!(ok(&w) && pdf.is_finite() && pdf >= 0.0 && d.iter().all(|x| x.is_finite()));
        let (wi32, wo32) = (wi.map(|x| x as f32), wo.map(|x| x as f32));
        let e32 = m32.eval(&wi32, &wo32);
        prop_assert!(e32.iter().all(|v| v.is_finite() && *v >= 0.0));
        // The kernel sees the f32-rounded directions (1e-310 rounds to 0:
        // a degenerate direction, value 0).
        let (ri, ro) = (unit(raw_i.map(|x| x as f64)), unit(raw_o.map(|x| x as f64)));
        let (e64, conditioned) = match (ri, ro) {
            (Some(a), Some(b)) => (
                m64.eval(&a, &b),
                beta_m >= 0.02 && beta_n >= 0.02 && a[1].abs() < 0.999 && b[1].abs() < 0.999,
            ),
            _ => ([0.0; 3], true),
        };
        for level in [Level::Portable, Level::Avx2, Level::Avx512] {
            let mut out = [0.0f32; 3];
            chiang_eval_simd(&m32, &raw_i, &raw_o, &mut out, level);
            prop_assert!(out.iter().all(|v| v.is_finite() && *v >= 0.0), "{level:?} {out:?}");
            if conditioned {
                for c in 0..3 {
                    let (g, w) = (out[c] as f64, e64[c]);
                    prop_assert!((g - w).abs() <= 1e-3 * g.max(w) + 1e-6, "{level:?} {g} vs {w}");
                }
            }
        }
    }

    /// 2. KarisHair, scalar kernel (f32, f64) and vector kernel (every level
    ///    this CPU has): finite and ≥ 0 for any parameters, directions and
    ///    transmittance; where the pair is well conditioned (roughness ≥
    ///    0.02, L and V more than 2.6° from the tangent: closer, f32 cannot
    ///    resolve θd, and a 1/255 roughness is a near-delta lobe) the vector
    ///    kernel agrees with the scalar f64 kernel to 1e-3 of the larger
    ///    value plus 1e-6 absolute (the tight bound on random pairs is
    ///    src/fiber/karis/simd.rs test 1).
    #[test]
    fn p02_karis_finite_nonnegative(
        l in direction(), v in direction(), t in direction(),
        r in roughness(), scatter in 0.0f64..=1.0, shift in -0.25f64..=0.25,
        color in [0.0f64..=1.0, 0.0f64..=1.0, 0.0f64..=1.0],
        comps in 1u32..16, absorption in 0usize..3, separable in any::<bool>(),
        shadow in 0.0f64..=1.0,
    ) {
        let p = KarisParams {
            base_color: color,
            roughness: r,
            scatter,
            shift,
            components: Components { r: comps & 1 != 0, tt: comps & 2 != 0, trt: comps & 4 != 0, ms: comps & 8 != 0 },
            absorption: [Absorption::Legacy, Absorption::Chiang, Absorption::ChiangCorrected][absorption],
            separable_r: separable,
            ..Default::default()
        };
        let m64 = p.build::<f64>().unwrap();
        let m32 = p.build::<f32>().unwrap();
        let tr = Transmittance { shadow, ..Default::default() };
        let mut conditioned = r >= 0.02;
        let want = match (unit(l), unit(v), unit(t)) {
            (Some(l), Some(v), Some(t)) => {
                let d = |a: &[f64; 3]| (a[0] * t[0] + a[1] * t[1] + a[2] * t[2]).abs();
                conditioned &= d(&l) < 0.999 && d(&v) < 0.999;
                m64.eval(&l, &v, &t, &tr)
            }
            _ => [0.0; 3],
        };
        prop_assert!(ok(&want));
        let f = |w: [f64; 3]| w.map(|x| x as f32);
        let (l32, v32, t32) = (f(l), f(v), f(t));
        let inp = KarisInputs {
            l: &l32, v: &v32, t: &t32,
            shadow: &[shadow as f32],
            global_scattering: &[1.0; 3],
            local_scattering: &[0.0; 3],
            opaque_visibility: &[1.0],
        };
        for level in [Level::Portable, Level::Avx2, Level::Avx512] {
            let mut out = [0.0f32; 3];
            karis_eval_simd::<false>(&m32, &inp, &mut out, level);
            for c in 0..3 {
                let (g, w) = (out[c] as f64, want[c]);
                prop_assert!(g.is_finite() && g >= 0.0);
                // Directions that are huge or denormal in f64 may not be
                // representable in f32 (→ 0 or inf: a degenerate pair).
                let representable = [l, v, t].iter().all(|d| d.iter().all(|x| x.abs() < 1e38 && (x.abs() > 1e-37 || *x == 0.0)));
                if representable && conditioned {
                    prop_assert!((g - w).abs() <= 1e-3 * g.max(w) + 1e-6, "{level:?}: {g} vs {w}");
                }
            }
        }
    }

    /// 3. DEonHair (UE's 16-sample reference estimate, and the converged
    ///    quadrature at a coarser case count below): finite and ≥ 0.
    #[test]
    fn p03_deon_finite_nonnegative(
        l in direction(), v in direction(), t in direction(),
        r in roughness(), shift in -0.25f64..=0.25,
        color in [0.0f64..=1.0, 0.0f64..=1.0, 0.0f64..=1.0],
        eta in prop_oneof![1.01f64..3.0, Just(1.01), Just(3.0)],
    ) {
        let (Some(l), Some(v), Some(t)) = (unit(l), unit(v), unit(t)) else { return Ok(()); };
        let p = DEonParams { base_color: color, roughness: r, shift, eta, h_samples: Some(16), ..Default::default() };
        prop_assert!(ok(&p.build::<f64>().unwrap().eval(&l, &v, &t)));
        let e32 = p.build::<f32>().unwrap().eval(&l.map(|x| x as f32), &v.map(|x| x as f32), &t.map(|x| x as f32));
        prop_assert!(e32.iter().all(|x| x.is_finite() && *x >= 0.0));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// 5. KarisHair::upper_bound (light culling's bound) is above every
    ///    value the model takes, at shadow in [0, 1].
    #[test]
    fn p05_karis_upper_bound_holds(
        l in direction(), v in direction(), t in direction(),
        r in roughness(), scatter in 0.0f64..=1.0, shift in -0.25f64..=0.25,
        color in [0.0f64..=1.0, 0.0f64..=1.0, 0.0f64..=1.0],
        backlit in 0.0f64..=1.0, specular in 0.0f64..=1.0, area in 0.0f64..=1.0,
        comps in 1u32..16, separable in any::<bool>(), shadow in 0.0f64..=1.0,
    ) {
        let (Some(l), Some(v), Some(t)) = (unit(l), unit(v), unit(t)) else { return Ok(()); };
        let p = KarisParams {
            base_color: color, roughness: r, scatter, shift, backlit, specular, area,
            components: Components { r: comps & 1 != 0, tt: comps & 2 != 0, trt: comps & 4 != 0, ms: comps & 8 != 0 },
            separable_r: separable,
            ..Default::default()
        };
        let m = p.build::<f32>().unwrap();
        let f = |w: [f64; 3]| w.map(|x| x as f32);
        let e = m.eval(&f(l), &f(v), &f(t), &Transmittance { shadow: shadow as f32, ..Default::default() });
        let bound = m.upper_bound();
        prop_assert!(e.iter().all(|x| *x <= bound), "{e:?} > {bound}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// 4. DEonHair converged (adaptive quadrature, ~1000x the cost): finite
    ///    and ≥ 0 at the same extremes.
    #[test]
    fn p04_deon_converged_finite_nonnegative(
        l in direction(), v in direction(),
        r in roughness(), eta in prop_oneof![1.01f64..3.0, Just(3.0)],
    ) {
        let (Some(l), Some(v)) = (unit(l), unit(v)) else { return Ok(()); };
        let p = DEonParams { roughness: r, eta, h_samples: None, ..Default::default() };
        prop_assert!(ok(&p.build::<f64>().unwrap().eval(&l, &v, &[0.0, 1.0, 0.0])));
    }
}
