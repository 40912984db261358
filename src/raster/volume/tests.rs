use super::smooth::local_linear;
use super::*;

/// 1. Calibration recovers the scale of a medium whose optical depths
///    are those of the strands times a known factor: with the strands'
///    transmittance exp(−0.8 τ) per ray, k = 0.8.
#[test]
fn calibration_recovers_a_known_scale() {
    let rays: Vec<(f32, f32)> = (0..1000)
        .map(|i| {
            let tau = 3.0 * i as f32 / 1000.0;
            ((-0.8 * tau).exp(), tau)
        })
        .collect();
    let c = calibrate(&rays);
    assert!((c.k - 0.8).abs() < 1e-5, "{c:?}");
    assert!((c.calibrated - c.strands).abs() < 1e-9);
    assert!(c.medium < c.strands);
}

/// 3. The local linear fit at a cell on the hair's surface (its
///    neighbours all on one side, their fibers off their centres):
///    a constant is kept exactly (the coefficients sum to 1), and a
///    linear fluence is read at the cell's fibers within a tenth of the
///    weighted mean's error there (the mean is biased by half a cell's
///    slope; the fit only by [`RIDGE`]'s shrinking of the slope).
#[test]
fn local_linear_fit_at_the_surface() {
    let mut pts = Vec::new();
    let mut slot = 0;
    for dz in -1i32..=0 {
        for dy in -1i32..=1 {
            for dx in -1i32..=1 {
                let w = [1.0f32, 0.5, 0.25][(dx.abs() + dy.abs() + dz.abs()).min(2) as usize]
                    * (1.0 + 0.3 * (slot % 3) as f32);
                let off = Vec3::new(
                    0.1 * (slot % 2) as f32,
                    -0.15,
                    0.2 * (slot % 3) as f32 - 0.2,
                );
                pts.push((slot, w, Vec3::new(dx as f32, dy as f32, dz as f32) + off));
                slot += 1;
            }
        }
    }
    let l = local_linear(&pts);
    let sum_l: f32 = l.iter().sum();
    assert!((sum_l - 1.0).abs() < 1e-5, "{sum_l}");
    // a fluence rising by 0.5 a cell towards the surface (+z)
    let field = |x: Vec3| 2.0 + 0.5 * x.z + 0.1 * x.x;
    let fit: f32 = pts.iter().zip(&l).map(|(p, c)| c * field(p.2)).sum();
    let wsum: f32 = pts.iter().map(|p| p.1).sum();
    let mean: f32 = pts.iter().map(|p| p.1 * field(p.2)).sum::<f32>() / wsum;
    let truth = field(Vec3::ZERO);
    assert!(
        (fit - truth).abs() < 0.1 * (mean - truth).abs(),
        "fit {fit}, mean {mean}, truth {truth}"
    );
}

/// 2. One response table per material: the same material reads the
///    table built before, another material builds its own.
#[test]
fn response_table_is_built_once_per_material() {
    let hair = |roughness: f64| {
        HairShading::Karis(
            crate::fiber::karis::KarisParams {
                roughness,
                ..Default::default()
            }
            .build()
            .unwrap(),
        )
    };
    let (a, b, c) = (hair(0.31), hair(0.31), hair(0.57));
    let (ta, tb, tc) = (response_table(&a), response_table(&b), response_table(&c));
    assert!(Arc::ptr_eq(&ta, &tb));
    assert!(!Arc::ptr_eq(&ta, &tc));
}

const MEAN: VolumeDirections = VolumeDirections::Mean;

/// [`fold`] without its normalization.
fn fold_raw(response: &response::ResponseTable, acc: &[[f32; 6]], t: Vec3, v: Vec3) -> Vec3 {
    let sv = t.dot(v).clamp(-1.0, 1.0);
    let v_n = (v - t * sv).normalize_or_zero();
    bin_lights(acc)
        .iter()
        .fold(Vec3::ZERO, |s, b| s + b.scattered(response, t, sv, v_n))
}

/// `nz × np` directions of equal solid angle (midpoints in z and φ),
/// and that solid angle.
fn sphere_directions(nz: usize, np: usize) -> (Vec<Vec3>, f32) {
    let dirs: Vec<Vec3> = (0..nz * np)
        .map(|i| {
            let z = -1.0 + 2.0 * ((i / np) as f32 + 0.5) / nz as f32;
            let p = std::f32::consts::TAU * ((i % np) as f32 + 0.5) / np as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * p.cos(), r * p.sin(), z)
        })
        .collect();
    let dw = 4.0 * std::f32::consts::PI / dirs.len() as f32;
    (dirs, dw)
}

/// The bins' tally of a radiance `radiance(l)` arriving from each of
/// `dirs` (solid angle `dw` each): light arriving from `l` propagates
/// along `−l`.
fn field_tally(
    bins: Bins,
    dirs: &[Vec3],
    dw: f32,
    radiance: impl Fn(Vec3) -> f32,
) -> Vec<[f32; 6]> {
    let mut acc = vec![[0.0f32; 6]; bins.count()];
    for &l in dirs {
        let b = &mut acc[bins.of(-l)];
        let w = radiance(l) * dw;
        for k in 0..3 {
            b[k] += w;
            b[3 + k] -= l[k] * w;
        }
    }
    acc
}

/// ChiangHair of `p`, tabulated as the renderer shades it.
fn chiang(p: crate::fiber::ChiangParams) -> HairShading {
    use crate::fiber::chiang::{ChiangFarTable, TableSize};
    let m: crate::fiber::ChiangHair<f64> = p.build().unwrap();
    HairShading::ChiangFar(Arc::new(ChiangFarTable::new(
        &m,
        TableSize::for_scale(m.logistic_scale()),
    )))
}

/// 4. The fold of a radiance field through the bins against the
///    direct integral `∫ f(t, v, l) L(l) dl` (a 400 × 800 equal-area
///    quadrature of the same response), for a white fiber and a
///    brown one, six fibers and views, at 4, 8 and 16 bins a side:
///    - a radiance of 1 from everywhere gives the albedo within 0.5%
///      (measured 0.2%), where the fold without its normalization is
///      off by more than 5% at some fiber at 8 bins (measured
///      0.936-1.034);
///    - a radiance rising linearly across the sphere (from 0.2 to 1.8)
///      within 7%, 3% and 1.5% at 4, 8 and 16 bins (measured 5.9%,
///      2.2%, 0.8%; without the normalization 32%, 5.5%, 1.4%), and
///      its summed error under 0.6 of the unnormalized fold's
///      (measured 0.30).
#[test]
fn fold_integrates_the_response() {
    let (dirs, dw) = sphere_directions(400, 800);
    let views = [
        (Vec3::new(0.3, 1.0, -0.2), Vec3::new(0.0, 0.2, 1.0)),
        (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)),
        (Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.6, -0.3, 0.7)),
        (Vec3::new(0.5, 0.5, 0.7), Vec3::new(-0.2, 0.7, 0.4)),
        (Vec3::new(0.1, 0.9, 0.1), Vec3::new(0.9, 0.1, 0.3)),
        (Vec3::new(-0.7, 0.2, 0.6), Vec3::new(0.3, 0.3, 0.9)),
    ];
    let a = Vec3::new(0.3, -0.5, 0.8).normalize();
    let linear = |l: Vec3| 1.0 + 0.8 * l.dot(a);
    let mut raw_worst = 0.0f32;
    // summed |error| of the linear field, normalized and raw
    let mut err_lin = [0.0f32; 2];
    for sigma_a in [[0.0, 0.0, 0.0], [0.8, 1.2, 2.0]] {
        let hair = chiang(crate::fiber::ChiangParams {
            sigma_a: Some(sigma_a),
            ..Default::default()
        });
        let table = response::ResponseTable::new(crate::raster::shade::far_response(&hair));
        let f = crate::raster::shade::far_response(&hair);
        for n in [4usize, 8, 16] {
            let bins = Bins { n };
            let uniform = bins.uniform_field();
            let lights = bin_lights(&uniform);
            let lin = field_tally(bins, &dirs, dw, linear);
            for (t, v) in views {
                let (t, v) = (t.normalize(), v.normalize());
                let exact = dirs.iter().fold(Vec3::ZERO, |s, &l| s + f(t, v, l) * dw);
                let exact_lin = dirs
                    .iter()
                    .fold(Vec3::ZERO, |s, &l| s + f(t, v, l) * (linear(l) * dw));
                let got = fold(&table, &uniform, &lights, MEAN, t, v);
                let got_lin = fold(&table, &lin, &lights, MEAN, t, v);
                for c in 0..3 {
                    let r = got[c] / exact[c];
                    assert!(
                        (r - 1.0).abs() < 0.005,
                        "{sigma_a:?} bins {n} t {t} v {v}: {r}"
                    );
                    let r = got_lin[c] / exact_lin[c];
                    let tol = match n {
                        4 => 0.07,
                        8 => 0.03,
                        _ => 0.015,
                    };
                    assert!(
                        (r - 1.0).abs() < tol,
                        "{sigma_a:?} bins {n} t {t} v {v}, linear: {r}"
                    );
                    let raw = fold_raw(&table, &lin, t, v)[c] / exact_lin[c];
                    err_lin[0] += (r - 1.0).abs();
                    err_lin[1] += (raw - 1.0).abs();
                }
                if n == 8 {
                    let raw = fold_raw(&table, &uniform, t, v).x / exact.x;
                    raw_worst = raw_worst.max((raw - 1.0).abs());
                }
            }
        }
    }
    assert!(raw_worst > 0.05, "{raw_worst}");
    assert!(err_lin[0] < 0.6 * err_lin[1], "{err_lin:?}");
}

/// 5. A radiance of 1 from everywhere at fibers and views drawn at
///    random (100 pairs, 8 bins), for three roughnesses: the fold
///    gives the albedo within 0.5% (measured 0.1%), views along the
///    fiber included, where the table's nodes miss the lobes closing
///    in on the pole and the unnormalized fold read 0.84-1.85 of it.
#[test]
fn fold_gives_the_albedo_at_random_fibers() {
    let (dirs, dw) = sphere_directions(200, 400);
    let bins = Bins { n: 8 };
    let u = bins.uniform_field();
    let lights = bin_lights(&u);
    let mut raw_worst = 0.0f32;
    for (beta_m, beta_n) in [(0.3, 0.3), (0.2, 0.3), (0.4, 0.4)] {
        let hair = chiang(crate::fiber::ChiangParams {
            sigma_a: Some([0.0, 0.0, 0.0]),
            longitudinal_roughness: beta_m,
            azimuthal_roughness: beta_n,
            ..Default::default()
        });
        let table = response::ResponseTable::new(crate::raster::shade::far_response(&hair));
        let f = crate::raster::shade::far_response(&hair);
        let mut rng = trace::Rng::new(7);
        let mut unit = || {
            let z = 1.0 - 2.0 * rng.uniform();
            let p = std::f32::consts::TAU * rng.uniform();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * p.cos(), r * p.sin(), z)
        };
        for _ in 0..100 {
            let (t, v) = (unit(), unit());
            let exact = dirs.iter().fold(0.0f32, |a, &l| a + f(t, v, l).x * dw);
            let r = fold(&table, &u, &lights, MEAN, t, v).x / exact;
            assert!(
                (r - 1.0).abs() < 0.005,
                "beta {beta_m} {beta_n} t {t} v {v}: {r}"
            );
            raw_worst = raw_worst.max((fold_raw(&table, &u, t, v).x / exact - 1.0).abs());
        }
    }
    assert!(raw_worst > 0.1, "{raw_worst}");
}

/// 6. Each group's row after [`others`] is the other groups' light times
///    `groups / (groups − 1)`, and the rows' mean is the whole light (what
///    a point of no strand reads): checked against sums written out, on
///    two cells of four groups and three bins with distinct values; one
///    group is left unchanged.
#[test]
fn each_group_reads_the_others_light() {
    let (nb, groups) = (3usize, 4usize);
    let value = |c: usize, g: usize, b: usize, k: usize| (1 + c * 97 + g * 13 + b * 5 + k) as f32;
    // rows of 6 words (RGB and a direction) as the solve lays them out
    let fluence: Vec<f32> = (0..2 * groups * nb * 6)
        .map(|i| {
            let (r, k) = (i / 6, i % 6);
            let (c, g, b) = (r / (groups * nb), (r / nb) % groups, r % nb);
            value(c, g, b, k)
        })
        .collect();
    let mut rows = fluence.clone();
    others(&mut rows, nb * 6, groups);
    for c in 0..2 {
        for b in 0..nb {
            for k in 0..6 {
                let total: f32 = (0..groups).map(|g| value(c, g, b, k)).sum();
                let mut mean = 0.0;
                for g in 0..groups {
                    let got = rows[((c * groups + g) * nb + b) * 6 + k];
                    let want = (total - value(c, g, b, k)) * 4.0 / 3.0;
                    assert!(
                        (got - want).abs() <= 1e-5 * want,
                        "cell {c} group {g} bin {b}: {got} {want}"
                    );
                    mean += got / groups as f32;
                }
                assert!((mean - total).abs() <= 1e-5 * total, "{mean} {total}");
            }
        }
    }
    let mut one = fluence.clone();
    others(&mut one, nb * groups * 6, 1);
    assert_eq!(one, fluence);
}

/// 7. A new light's solve reads the medium an earlier solve of the same
///    geometry built (it depends on neither lights nor material), and
///    gives what a solve that builds its own gives: two solves of one
///    groom under different lights share one medium; a third, without a
///    geometry key (nothing kept), builds another, and its fluence equals
///    the second's bit for bit. Both transports.
#[test]
fn a_new_light_reads_the_kept_medium() {
    let mut scene = Scene::of_strands(medium::random_strands(
        0x51_7cc1_b727_220a,
        400,
        8,
        0.08,
        0.004,
    ));
    let light = |y: f32| Light::Directional {
        direction: Vec3::new(0.3, y, 0.5),
        intensity: Vec3::ONE,
        shadows: true,
    };
    let segments = crate::raster::setup::world_segments(&scene.strands);
    let geometry = crate::raster::shadow::geometry_hash(&scene);
    for transport in [VolumeTransport::Strands, VolumeTransport::Medium] {
        let settings = VolumeSettings {
            resolution: 12,
            photons: 4096,
            bins: 4,
            transport,
            directions: VolumeDirections::Mean,
        };
        let solve = |scene: &Scene, geometry: u64| {
            let input = SolveInput {
                scene,
                geometry,
                segments: &segments,
                traced: None,
                env: None,
            };
            VolumeRadiance::solve(&input, settings, None, None).unwrap()
        };
        scene.lights = vec![light(1.0)];
        let a = solve(&scene, geometry);
        scene.lights = vec![light(-0.4)];
        let b = solve(&scene, geometry);
        let c = solve(&scene, 0);
        assert!(Arc::ptr_eq(&a.medium, &b.medium), "{transport:?}");
        assert!(!Arc::ptr_eq(&b.medium, &c.medium), "{transport:?}");
        assert!(b.fluence.iter().any(|&f| f > 0.0), "{transport:?}");
        assert_eq!(b.fluence, c.fluence, "{transport:?}");
        assert_ne!(a.fluence, b.fluence, "{transport:?}");
    }
}

/// 8. The bins' own directions ([`VolumeDirections::Centre`]):
///    - a radiance of 1 from everywhere reads what the mean directions
///      read (the same lights: the albedo, test 4);
///    - the reading is linear in the tallies: two tallies of 200 and 150
///      photons (random directions and powers, 8 bins) read as their sum
///      within float rounding (1e-5 relative), where the mean
///      directions' reading is not (it differs by more than 1%: measured
///      1.9% at the worst of these fibers);
///    - a radiance rising linearly across the sphere (0.2 to 1.8) within
///      8% of the direct integral at 8 bins (measured 0.4-6.3%: a bin's
///      centre does not see the slope across the bin, which its mean
///      direction does: 2.2% in test 4).
#[test]
fn bin_centres_read_linearly() {
    let hair = chiang(crate::fiber::ChiangParams {
        sigma_a: Some([0.3, 0.5, 0.9]),
        ..Default::default()
    });
    let table = response::ResponseTable::new(crate::raster::shade::far_response(&hair));
    let f = crate::raster::shade::far_response(&hair);
    let bins = Bins { n: 8 };
    let uniform = bins.uniform_field();
    let lights = bin_lights(&uniform);
    let centre = VolumeDirections::Centre;
    let mut rng = trace::Rng::new(11);
    let mut unit = || {
        let z = 1.0 - 2.0 * rng.uniform();
        let p = std::f32::consts::TAU * rng.uniform();
        let r = (1.0 - z * z).max(0.0).sqrt();
        (Vec3::new(r * p.cos(), r * p.sin(), z), rng.uniform())
    };
    // a tally of `n` photons: each bin its RGB fluence and summed direction
    let mut photons = |n: usize| {
        let mut acc = vec![[0.0f32; 6]; bins.count()];
        for _ in 0..n {
            let (d, w) = unit();
            let b = &mut acc[bins.of(d)];
            for k in 0..3 {
                b[k] += w;
                b[3 + k] += d[k] * w;
            }
        }
        acc
    };
    let (a, b) = (photons(200), photons(150));
    let sum: Vec<[f32; 6]> = a
        .iter()
        .zip(&b)
        .map(|(x, y)| std::array::from_fn(|k| x[k] + y[k]))
        .collect();
    let (dirs, dw) = sphere_directions(400, 800);
    let a_lin = Vec3::new(0.3, -0.5, 0.8).normalize();
    let linear = |l: Vec3| 1.0 + 0.8 * l.dot(a_lin);
    let lin = field_tally(bins, &dirs, dw, linear);
    let mut mean_gap = 0.0f32;
    for (t, v) in [
        (Vec3::new(0.3, 1.0, -0.2), Vec3::new(0.0, 0.2, 1.0)),
        (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)),
        (Vec3::new(0.5, 0.5, 0.7), Vec3::new(-0.2, 0.7, 0.4)),
    ] {
        let (t, v) = (t.normalize(), v.normalize());
        let read = |acc: &[[f32; 6]], d| fold(&table, acc, &lights, d, t, v);
        let (u_c, u_m) = (read(&uniform, centre), read(&uniform, MEAN));
        assert!(
            (u_c - u_m).abs().max_element() <= 1e-6 * u_m.max_element(),
            "{u_c} {u_m}"
        );
        let (s, parts) = (read(&sum, centre), read(&a, centre) + read(&b, centre));
        assert!(
            (s - parts).abs().max_element() <= 1e-5 * s.max_element(),
            "{s} {parts}"
        );
        let (s, parts) = (read(&sum, MEAN), read(&a, MEAN) + read(&b, MEAN));
        mean_gap = mean_gap.max(((s - parts).abs() / s).max_element());
        let exact = dirs
            .iter()
            .fold(Vec3::ZERO, |s, &l| s + f(t, v, l) * (linear(l) * dw));
        let got = read(&lin, centre);
        for c in 0..3 {
            let r = got[c] / exact[c];
            assert!((r - 1.0).abs() < 0.08, "t {t} v {v}: {r}");
        }
    }
    assert!(mean_gap > 0.01, "{mean_gap}");
}

/// 9. A solve for the bins' centres tallies the same light as one for the
///    mean directions, without the directions: its RGB fluence equals
///    the other's bit for bit (the same photons, sums and filter), in
///    half the words.
#[test]
fn centre_solve_tallies_the_same_light() {
    let mut scene = Scene::of_strands(medium::random_strands(
        0x3c6e_f372_fe94_f82b,
        400,
        8,
        0.08,
        0.004,
    ));
    scene.lights = vec![Light::Directional {
        direction: Vec3::new(0.3, -1.0, 0.5),
        intensity: Vec3::ONE,
        shadows: true,
    }];
    let segments = crate::raster::setup::world_segments(&scene.strands);
    let solve = |directions| {
        let input = SolveInput {
            scene: &scene,
            geometry: 0,
            segments: &segments,
            traced: None,
            env: None,
        };
        let settings = VolumeSettings {
            resolution: 12,
            photons: 4096,
            bins: 4,
            transport: VolumeTransport::Strands,
            directions,
        };
        VolumeRadiance::solve(&input, settings, None, None).unwrap()
    };
    let (mean, centre) = (
        solve(VolumeDirections::Mean),
        solve(VolumeDirections::Centre),
    );
    let words = |v: &VolumeRadiance| words(v.directions);
    assert_eq!((words(&mean), words(&centre)), (6, 3));
    assert_eq!(mean.fluence.len(), 2 * centre.fluence.len());
    let rows = |v: &VolumeRadiance| {
        v.fluence
            .chunks_exact(words(v))
            .map(|r| r[..3].to_vec())
            .collect::<Vec<_>>()
    };
    assert!(mean
        .fluence
        .chunks_exact(6)
        .any(|f| f[0] > 0.0 && f[3] != 0.0));
    assert_eq!(rows(&mean), rows(&centre));
}
