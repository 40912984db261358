use super::*;
use crate::fiber::frame::normalized;
use crate::math::gauss_legendre;

fn model(i0: I0Mode) -> ChiangHair<f64> {
    ChiangParams {
        i0,
        ..Default::default()
    }
    .build()
    .unwrap()
}

fn dir(a: f64, b: f64, c: f64) -> Vec3<f64> {
    normalized(&[a, b, c]).unwrap()
}

/// ∫ M_p d(sin θo) = 1 (d'Eon's normalization), by Gauss–Legendre in θo.
#[test]
fn t01_mp_exact_normalized() {
    let (x, w) = gauss_legendre(400);
    for beta in [0.05, 0.1, 0.3, 0.6, 1.0] {
        let m: ChiangHair<f64> = ChiangParams {
            longitudinal_roughness: beta,
            ..Default::default()
        }
        .build()
        .unwrap();
        for &sin_i in &[-0.8, -0.2, 0.0, 0.5, 0.95] {
            for p in 0..=P_MAX {
                // ∫_{-π/2}^{π/2} M_p(θo) cos θo dθo, split into 8 panels.
                let mut total = 0.0;
                for k in 0..8 {
                    let a = -std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::PI / 8.0;
                    let half = std::f64::consts::PI / 16.0;
                    for (xi, wi) in x.iter().zip(&w) {
                        let t = a + half * (xi + 1.0);
                        total += wi
                            * half
                            * t.cos()
                            * m.m_p(sin_i, circ(sin_i), t.sin(), t.cos(), m.v[p]);
                    }
                }
                assert!(
                    (total - 1.0).abs() < 1e-10,
                    "beta={beta} sin_i={sin_i} p={p} total={total}"
                );
            }
        }
    }
}

/// Exact and Mitsuba modes agree where Mitsuba's series is accurate (small κ·cos²).
#[test]
fn t02_mp_modes_agree_for_rough_fibers() {
    let e = model(I0Mode::Exact);
    let mi = model(I0Mode::Mitsuba);
    let v = 0.5; // κ = 2 < 10: Mitsuba's direct branch, I0 argument ≤ 2
    for &(si, so) in &[(0.1, -0.2), (0.7, 0.3), (-0.9, 0.9)] {
        let a = e.m_p(si, circ(si), so, circ(so), v);
        let b = mi.m_p(si, circ(si), so, circ(so), v);
        assert!(((a - b) / a).abs() < 1e-12, "{a} {b}");
    }
}

/// M_p in f32 stays finite and non-negative at the smallest roughness.
#[test]
fn t03_mp_f32_stable_at_min_roughness() {
    let m: ChiangHair<f32> = ChiangParams {
        longitudinal_roughness: 0.0,
        ..Default::default()
    }
    .build()
    .unwrap();
    for &si in &[-1.0_f32, -0.5, 0.0, 0.3, 1.0] {
        for &so in &[-1.0_f32, -0.3, 0.0, 0.299, 1.0] {
            for p in 0..=P_MAX {
                let v = m.m_p(si, circ(si), so, circ(so), m.v[p]);
                assert!(v.is_finite() && v >= 0.0, "si={si} so={so} p={p} v={v}");
            }
        }
    }
}

#[test]
fn t04_invalid_parameters_name_the_parameter() {
    let cases: Vec<(ChiangParams, &str)> = vec![
        (
            ChiangParams {
                longitudinal_roughness: 1.5,
                ..Default::default()
            },
            "longitudinal_roughness",
        ),
        (
            ChiangParams {
                azimuthal_roughness: -0.1,
                ..Default::default()
            },
            "azimuthal_roughness",
        ),
        (
            ChiangParams {
                eta: 1.0,
                ..Default::default()
            },
            "eta",
        ),
        (
            ChiangParams {
                eta: -2.0,
                ..Default::default()
            },
            "eta",
        ),
        (
            ChiangParams {
                eumelanin: Some(-1.0),
                ..Default::default()
            },
            "eumelanin",
        ),
        (
            ChiangParams {
                sigma_a: Some([0.1, -0.1, 0.0]),
                ..Default::default()
            },
            "sigma_a",
        ),
        (
            ChiangParams {
                sigma_a: Some([0.1; 3]),
                eumelanin: Some(1.0),
                ..Default::default()
            },
            "sigma_a",
        ),
        (
            ChiangParams {
                scale_tilt: f64::NAN,
                ..Default::default()
            },
            "scale_tilt",
        ),
    ];
    for (p, name) in cases {
        let err = p.build::<f64>().unwrap_err();
        assert_eq!(err.param, name, "{err}");
    }
}

/// eval_far is unchanged when both directions rotate about the tangent.
#[test]
fn t05_far_field_rotation_invariant() {
    let m = model(I0Mode::Exact);
    let wi = dir(0.3, 0.4, 0.8);
    let wo = dir(-0.5, -0.1, 0.2);
    let base = m.eval_far(&wi, &wo);
    for &ang in &[0.3_f64, 1.7, -2.9] {
        let rot = |w: &Vec3<f64>| {
            let (s, c) = ang.sin_cos();
            [c * w[0] - s * w[2], w[1], s * w[0] + c * w[2]]
        };
        let r = m.eval_far(&rot(&wi), &rot(&wo));
        for c in 0..3 {
            assert!(((r[c] - base[c]) / base[c]).abs() < 1e-12, "{r:?} {base:?}");
        }
    }
}

/// eval at h = ±1 and with wi along the tangent is finite.
#[test]
fn t06_edge_directions_finite() {
    let m = model(I0Mode::Exact);
    for wi in [
        dir(-1.0, 0.0, 0.0),
        dir(1.0, 0.0, 0.0),
        dir(0.0, 1.0, 0.0),
        dir(0.0, -1.0, 0.0),
    ] {
        for wo in [
            dir(0.0, 0.0, 1.0),
            dir(1.0, 0.0, 0.0),
            dir(0.0, 1.0, 0.0),
            dir(0.2, -0.7, 0.1),
        ] {
            let f = m.eval(&wi, &wo);
            assert!(
                f.iter().all(|x| x.is_finite() && *x >= 0.0),
                "{wi:?} {wo:?} {f:?}"
            );
            assert!(m.pdf(&wi, &wo).is_finite());
        }
        for u in [0.0, 0.3, 0.999999] {
            let (wo, w, pdf) = m.sample(&wi, u, [u, 1.0 - u]);
            assert!(
                wo.iter().all(|x| x.is_finite())
                    && w.iter().all(|x| x.is_finite())
                    && pdf.is_finite()
            );
        }
    }
}
