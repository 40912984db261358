//! Tests of the scalar KarisHair lobes.

use super::*;

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

#[test]
fn t01_lobes_sum_to_eval() {
    let m: KarisHair<f64> = KarisParams {
        scatter: 0.7,
        ..Default::default()
    }
    .build()
    .unwrap();
    let tr = Transmittance {
        shadow: 0.4,
        global_scattering: [0.8, 0.7, 0.6],
        local_scattering: [0.1, 0.05, 0.0],
        opaque_visibility: 0.9,
    };
    let (l, v, t) = (
        unit([0.3, 0.5, 0.8]),
        unit([-0.4, 0.2, 0.9]),
        unit([0.0, 1.0, 0.1]),
    );
    let lobes = m.lobes(&l, &v, &t, &tr);
    let e = m.eval(&l, &v, &t, &tr);
    for c in 0..3 {
        let s = lobes.r[c] + lobes.tt[c] + lobes.trt[c] + lobes.ms[c];
        assert!((s - e[c]).abs() < 1e-15 && s > 0.0);
    }
}

#[test]
fn t02_disabled_lobes_are_zero_and_others_unchanged() {
    let all: KarisHair<f64> = KarisParams::default().build().unwrap();
    let only_tt = all.with_components(Components {
        r: false,
        tt: true,
        trt: false,
        ms: false,
    });
    let tr = Transmittance::default();
    let (l, v, t) = (
        unit([0.3, -0.5, -0.8]),
        unit([-0.4, 0.2, 0.9]),
        unit([0.1, 1.0, 0.0]),
    );
    let a = all.lobes(&l, &v, &t, &tr);
    let b = only_tt.lobes(&l, &v, &t, &tr);
    assert_eq!(a.tt, b.tt);
    assert_eq!(b.r, [0.0; 3]);
    assert_eq!(b.trt, [0.0; 3]);
    assert_eq!(b.ms, [0.0; 3]);
}

#[test]
fn t03_degenerate_geometry_is_finite() {
    let m: KarisHair<f32> = KarisParams {
        scatter: 1.0,
        base_color: [0.0, 0.0, 0.0],
        ..Default::default()
    }
    .build()
    .unwrap();
    let t = [0.0f32, 1.0, 0.0];
    for (l, v) in [
        (t, t),
        ([0.0, -1.0, 0.0], t),
        ([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]),
        ([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
    ] {
        let e = m.eval(
            &l,
            &v,
            &t,
            &Transmittance {
                shadow: 0.3,
                ..Default::default()
            },
        );
        assert!(
            e.iter().all(|x| x.is_finite() && *x >= 0.0),
            "{l:?} {v:?} {e:?}"
        );
    }
}

// 04: the parts put back together are the lobes: for every lobe
// `g(width, x − shift) · rest` equals what `lobes` returns (f64, the same
// operations in another order: 1e-14 relative), and a disabled lobe has a
// zero rest.
#[test]
fn t04_parts_rebuild_the_lobes() {
    use crate::fiber::lobes::gaussian;
    for absorption in [
        Absorption::Legacy,
        Absorption::Chiang,
        Absorption::ChiangCorrected,
    ] {
        let m: KarisHair<f64> = KarisParams {
            roughness: 0.35,
            backlit: 0.6,
            absorption,
            ..Default::default()
        }
        .build()
        .unwrap();
        let t = unit([0.1, 1.0, -0.2]);
        for (l, v) in [
            ([0.3, 0.5, 0.8], [-0.4, 0.2, 0.9]),
            ([0.9, -0.3, 0.1], [-0.8, 0.1, -0.2]),
            ([0.0, 0.7, -0.6], [0.2, 0.6, 0.7]),
        ] {
            let (l, v) = (unit(l), unit(v));
            let lobes = m.lobes(&l, &v, &t, &Transmittance::default());
            let p = m.parts(&l, &v, &t);
            let want = [lobes.r, lobes.tt, lobes.trt];
            for i in 0..3 {
                let g = gaussian(p.width[i], p.x - p.shift[i]);
                for c in 0..3 {
                    let got = g * p.rest[i][c];
                    assert!(
                        (got - want[i][c]).abs() <= 1e-14 * want[i][c].abs().max(1e-300),
                        "{absorption:?} lobe {i}: {got} vs {}",
                        want[i][c]
                    );
                }
            }
        }
        let no_tt = m.with_components(Components {
            tt: false,
            ..Components::ALL
        });
        let p = no_tt.parts(&unit([0.3, 0.5, 0.8]), &unit([-0.4, 0.2, 0.9]), &t);
        assert_eq!(p.rest[1], [0.0; 3]);
        assert!(p.rest[0][0] > 0.0 && p.rest[2][0] > 0.0);
    }
}

// 05: `spreads` is `parts` without the rests: the same x, cos θd, widths
// and shifts, bit for bit.
#[test]
fn t05_spreads_are_the_parts_gaussians() {
    let m: KarisHair<f32> = KarisParams::default().build().unwrap();
    let (l, v, t) = (
        [0.3f32, 0.5, 0.81],
        [-0.4f32, 0.2, 0.89],
        [0.0f32, 1.0, 0.0],
    );
    let (p, s) = (m.parts(&l, &v, &t), m.spreads(&l, &v, &t));
    assert_eq!(
        (p.x, p.cos_theta_d, p.width, p.shift),
        (s.x, s.cos_theta_d, s.width, s.shift)
    );
    assert_eq!(s.rest, [[0.0; 3]; 3]);
}
