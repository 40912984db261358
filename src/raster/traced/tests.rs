use super::*;
use crate::raster::shade::Fiber;

fn rnd(state: &mut u64) -> f32 {
    *state ^= *state >> 12;
    *state ^= *state << 25;
    *state ^= *state >> 27;
    (state.wrapping_mul(0x2545F4914F6CDD1D) >> 40) as f32 / (1u64 << 24) as f32
}

/// `n` segments of radius `r` starting in the unit cube, each
/// `spread` at most along each axis, `per_strand` to a strand.
fn random_segments(
    st: &mut u64,
    n: u32,
    spread: f32,
    r: f32,
    per_strand: u32,
) -> Vec<WorldSegment> {
    (0..n)
        .map(|i| {
            let a = Vec3::new(rnd(st), rnd(st), rnd(st));
            let b = a + (Vec3::new(rnd(st), rnd(st), rnd(st)) - 0.5) * spread;
            WorldSegment {
                a,
                b,
                ra: r,
                rb: r,
                strand: i / per_strand,
                vertex: 0,
            }
        })
        .collect()
}

/// Distance from the point at ray parameter s to the segment (dense
/// sampling of the segment: an independent brute force).
fn ray_segment_gap(o: Vec3, d: Vec3, t_max: f32, s: &Capsule) -> f32 {
    let mut best = f32::INFINITY;
    for i in 0..=400 {
        let q = s.a + s.u * (i as f32 / 400.0);
        let t = (q - o).dot(d).clamp(0.0, t_max);
        best = best.min((o + d * t - q).length());
    }
    best
}

/// 1. The grid traversal finds an occluder exactly when a brute-force
///    test over every capsule does (rays whose closest approach is
///    within 2% of a radius of the surface are skipped: the dense
///    sampling of the reference is that coarse).
#[test]
fn t01_grid_agrees_with_brute_force() {
    let mut st = 0x1234_5678_9abc_def0u64;
    let segs = random_segments(&mut st, 400, 0.2, 0.01, 4);
    let grid = SegmentGrid::new(&segs).unwrap();
    let (mut hits, mut checked) = (0, 0);
    for _ in 0..3000 {
        let o = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) * 1.4 - 0.2;
        let d = (Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - 0.5).normalize();
        let own = Fiber {
            radius: 0.0,
            strand: u32::MAX - 1,
            segment: 0,
        };
        // Capsules holding the origin do not block (brute force: the
        // gap at t = 0).
        let gaps: Vec<f32> = grid
            .segments
            .iter()
            .filter(|c| ray_segment_gap(o, d, 0.0, c) > c.r2.sqrt())
            .map(|c| ray_segment_gap(o, d, f32::INFINITY, c) - c.r2.sqrt())
            .collect();
        if gaps.iter().any(|g| g.abs() < 2e-4)
            || grid
                .segments
                .iter()
                .any(|c| (ray_segment_gap(o, d, 0.0, c) - c.r2.sqrt()).abs() < 2e-4)
        {
            continue;
        }
        let want = gaps.iter().any(|&g| g < 0.0);
        assert_eq!(
            grid.occluded(o, d, f32::INFINITY, &own),
            want,
            "ray {o} {d}"
        );
        hits += want as u32;
        checked += 1;
    }
    assert!(
        checked > 2500 && hits > 300 && hits < checked - 300,
        "{hits} of {checked}"
    );
}

/// 2. A ray from inside a capsule is not blocked by it, and is by a
///    capsule it meets farther on.
#[test]
fn t02_origin_inside_leaves_unblocked() {
    let seg = |z: f32, strand| WorldSegment {
        a: Vec3::new(-1.0, 0.0, z),
        b: Vec3::new(1.0, 0.0, z),
        ra: 0.1,
        rb: 0.1,
        strand,
        vertex: 0,
    };
    let own = Fiber {
        radius: 0.0,
        strand: u32::MAX - 1,
        segment: 0,
    };
    let o = Vec3::new(0.0, 0.05, 0.0);
    let up = Vec3::Y;
    let inside = SegmentGrid::new(&[seg(0.0, 0)]).unwrap();
    assert!(!inside.occluded(o, up, f32::INFINITY, &own));
    assert!(!inside.occluded(o, -up, f32::INFINITY, &own));
    let above = SegmentGrid::new(&[
        seg(0.0, 0),
        WorldSegment {
            a: Vec3::new(-1.0, 0.5, 0.0),
            b: Vec3::new(1.0, 0.5, 0.0),
            ..seg(0.0, 1)
        },
    ])
    .unwrap();
    assert!(above.occluded(o, up, f32::INFINITY, &own));
    assert!(!above.occluded(o, -up, f32::INFINITY, &own));
}

/// 3. A ray that runs inside its own fiber (light from behind, nearly
///    along a strand of short segments) passes the rest of its own
///    strand; another strand on its way, and its own strand turning back
///    across it outside the tube, still shadow it.
#[test]
fn t03_a_ray_inside_its_own_fiber_passes_its_strand() {
    let r = 0.01;
    // strand 0: 40 segments of 0.05 along x; strand 1 crosses at x = 1.5
    let mut segs: Vec<WorldSegment> = (0..40)
        .map(|i| WorldSegment {
            a: Vec3::new(i as f32 * 0.05, 0.0, 0.0),
            b: Vec3::new((i + 1) as f32 * 0.05, 0.0, 0.0),
            ra: r,
            rb: r,
            strand: 0,
            vertex: 0,
        })
        .collect();
    let own = Fiber {
        radius: r,
        strand: 0,
        segment: 10,
    };
    // on segment 10's surface (x = 0.525, y = r), into the fiber, 0.5 degrees off its axis
    let o = Vec3::new(0.525, r, 0.0);
    let d = Vec3::new(1.0, -0.00873, 0.0).normalize();
    // a segment across the x axis at `x`, from -half to half in y
    let across = |x: f32, half: f32, strand: u32| WorldSegment {
        a: Vec3::new(x, -half, 0.0),
        b: Vec3::new(x, half, 0.0),
        ra: r,
        rb: r,
        strand,
        vertex: 0,
    };
    let grid = SegmentGrid::new(&segs).unwrap();
    assert!(
        !grid.occluded(o, d, f32::INFINITY, &own),
        "own strand ahead, inside the tube"
    );
    segs.push(across(1.5, 0.5, 1));
    let crossed = SegmentGrid::new(&segs).unwrap();
    assert!(
        crossed.occluded(o, d, f32::INFINITY, &own),
        "another strand on the way"
    );
    // the own strand turning back across the ray beyond where the ray
    // leaves its tube (at the strand's end, x = 2.01)
    segs.pop();
    segs.push(across(3.0, 0.3, 0));
    let curl = SegmentGrid::new(&segs).unwrap();
    assert!(
        curl.occluded(o, d, f32::INFINITY, &own),
        "own strand outside the tube"
    );
}

/// 4. A ray that starts inside another strand's tube (fibers that
///    interpenetrate) passes that strand until it leaves the tube, as it
///    passes its own; a third strand on the way still shadows it.
#[test]
fn t04_a_ray_starting_inside_another_fiber_passes_it() {
    let r = 0.01;
    let strand = |k: u32, y: f32| {
        (0..40).map(move |i| WorldSegment {
            a: Vec3::new(i as f32 * 0.05, y, 0.0),
            b: Vec3::new((i + 1) as f32 * 0.05, y, 0.0),
            ra: r,
            rb: r,
            strand: k,
            vertex: 0,
        })
    };
    // the receiver on strand 0 at x = 0.525; strand 1 runs 0.5 r beside it
    let mut segs: Vec<WorldSegment> = strand(0, 0.0).chain(strand(1, 0.005)).collect();
    let own = Fiber {
        radius: r,
        strand: 0,
        segment: 10,
    };
    let o = Vec3::new(0.525, r, 0.0); // inside strand 1's tube (0.005 from its axis)
    let d = Vec3::new(1.0, -0.00873, 0.0).normalize();
    let grid = SegmentGrid::new(&segs).unwrap();
    assert!(
        !grid.occluded(o, d, f32::INFINITY, &own),
        "strand 1, started inside"
    );
    segs.extend((0..1).map(|_| WorldSegment {
        a: Vec3::new(1.5, -0.5, 0.0),
        b: Vec3::new(1.5, 0.5, 0.0),
        ra: r,
        rb: r,
        strand: 2,
        vertex: 0,
    }));
    let crossed = SegmentGrid::new(&segs).unwrap();
    assert!(
        crossed.occluded(o, d, f32::INFINITY, &own),
        "strand 2 on the way"
    );
}

/// 5. [`capsule_exit`] from a point inside a capsule is where a fine
///    march along the ray leaves it (an independent brute force: the
///    distance to the axis sampled every 1e-5 of the capsule's length,
///    so the two agree within that step).
#[test]
fn t05_capsule_exit_agrees_with_a_march() {
    let mut st = 0x0dd_ba11u64;
    let mut checked = 0;
    for _ in 0..300 {
        let a = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st));
        let u = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5);
        let r = 0.02 + 0.2 * rnd(&mut st);
        let c = Capsule {
            a,
            r2: r * r,
            u,
            reach: 0.0,
            r,
            strand: 0,
            segment: 0,
        };
        // a point inside: on the axis, pushed out by less than the radius
        let side = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5);
        let o = a + u * (1.2 * rnd(&mut st) - 0.1) + side.normalize() * r * 0.9 * rnd(&mut st);
        if !contains(o, &c) {
            continue;
        }
        let d =
            (Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5)).normalize();
        let step = 1e-5 * (u.length() + 2.0 * r);
        let mut t = 0.0;
        while contains(o + d * (t + step), &c) {
            t += step;
        }
        let e = capsule_exit(o, d, &c);
        assert!(
            (e - t).abs() <= 2.0 * step + 1e-5,
            "exit {e} against the march's {t}"
        );
        checked += 1;
    }
    assert!(checked > 100, "{checked} points inside");
}

/// 6. A strand's shadows are its tube's: the same bent strand cut into
///    4 collinear pieces a segment shadows the same rays from points on
///    its surface (rays towards the fiber and away from it, the strand
///    bending back across them or not). The rays that graze the tube,
///    within 1e-3 of a radius of its surface where one grid and not the
///    other would call them blocked, are left out (rounding of the two
///    geometries' tests); counted, they are a few in a thousand.
#[test]
fn t06_cutting_a_strand_into_pieces_keeps_its_shadows() {
    let r = 0.02;
    // a wave with bends of up to 40 degrees between segments, and a curl
    let points: Vec<Vec3> = (0..=24)
        .map(|i| {
            let x = i as f32 * 0.1;
            Vec3::new(x, 0.15 * (3.0 * x).sin(), 0.12 * (5.0 * x).cos())
        })
        .collect();
    let strand = |pieces: usize| -> Vec<WorldSegment> {
        points
            .windows(2)
            .flat_map(|w| {
                (0..pieces).map(move |k| WorldSegment {
                    a: w[0] + (w[1] - w[0]) * (k as f32 / pieces as f32),
                    b: w[0] + (w[1] - w[0]) * ((k + 1) as f32 / pieces as f32),
                    ra: r,
                    rb: r,
                    strand: 0,
                    vertex: 0,
                })
            })
            .collect()
    };
    let (whole, cut) = (strand(1), strand(4));
    let (g1, g4) = (
        SegmentGrid::new(&whole).unwrap(),
        SegmentGrid::new(&cut).unwrap(),
    );
    // the distance from the strand's axis to the ray beyond where the
    // ray leaves the tube, at its least (a march): near r, the ray grazes
    // the tube
    let graze = |o: Vec3, d: Vec3| {
        let dist = |p: Vec3| {
            whole
                .iter()
                .map(|s| {
                    let u = s.b - s.a;
                    let t = ((p - s.a).dot(u) / u.length_squared()).clamp(0.0, 1.0);
                    (p - s.a - u * t).length()
                })
                .fold(f32::INFINITY, f32::min)
        };
        let mut t = 0.0;
        let mut near = f32::INFINITY;
        let mut outside = false;
        while t < 4.0 {
            let x = dist(o + d * t);
            outside |= x > r * (1.0 + 1e-3);
            if outside {
                near = near.min(x);
            }
            t += 2e-4;
        }
        (near - r).abs() < 1e-3 * r
    };
    let mut st = 0xC0_7_u64;
    let (mut same, mut blocked, mut grazing) = (0, 0, 0);
    for _ in 0..2000 {
        let seg = ((rnd(&mut st) * 24.0) as usize).min(23);
        let f = rnd(&mut st);
        let (a, b) = (points[seg], points[seg + 1]);
        let axis = (b - a).normalize();
        let (e1, e2) = axis.any_orthonormal_pair();
        let phi = std::f32::consts::TAU * rnd(&mut st);
        let o = a + (b - a) * f + (e1 * phi.cos() + e2 * phi.sin()) * r;
        // half the rays nearly along the strand (light from behind it)
        let d = if rnd(&mut st) < 0.5 {
            let off = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5);
            (axis * if rnd(&mut st) < 0.5 { 1.0 } else { -1.0 } + off * 0.4).normalize()
        } else {
            let z = 1.0 - 2.0 * rnd(&mut st);
            let s = (1.0 - z * z).sqrt();
            let p = std::f32::consts::TAU * rnd(&mut st);
            Vec3::new(s * p.cos(), s * p.sin(), z)
        };
        let piece = ((f * 4.0) as usize).min(3);
        let own1 = Fiber {
            radius: r,
            strand: 0,
            segment: seg as u32,
        };
        let own4 = Fiber {
            segment: (seg * 4 + piece) as u32,
            ..own1
        };
        let b1 = g1.occluded(o, d, f32::INFINITY, &own1);
        let b4 = g4.occluded(o, d, f32::INFINITY, &own4);
        if b1 == b4 {
            same += 1;
            blocked += b1 as usize;
        } else {
            assert!(graze(o, d), "o {o} d {d}: whole {b1}, cut {b4}");
            grazing += 1;
        }
    }
    // the strand bends back across some rays: the test sees shadows
    assert!(blocked > 50, "{blocked} of {same} blocked");
    assert!(grazing <= 10, "{grazing} grazing rays differ");
}

/// 7. The first fiber a ray meets is the brute force's: over every
///    capsule, the least closest approach (each capsule's own, read up
///    to t_max), at equal distance the earlier segment. Exactly, not
///    within a tolerance: the grid tests the same capsules with the same
///    arithmetic, so the order its lists hold them in (Morton order of
///    their midpoints, not the strands') must not show.
#[test]
fn t07_first_hit_is_the_nearest_in_any_order() {
    let mut st = 0x0bad_cafe_1234_5678u64;
    let segs = random_segments(&mut st, 600, 0.15, 0.012, 6);
    let grid = SegmentGrid::new(&segs).unwrap();
    let own = Fiber {
        radius: 0.0,
        strand: u32::MAX - 1,
        segment: u32::MAX - 1,
    };
    let (mut met, mut rays) = (0, 0);
    for _ in 0..3000 {
        let o = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) * 1.2 - 0.1;
        let d = (Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - 0.5).normalize();
        let t_max = 0.2 + rnd(&mut st);
        if grid.segments.iter().any(|c| contains(o, c)) {
            continue; // (what a ray starting inside a fiber passes: t03, t04)
        }
        let want = grid
            .segments
            .iter()
            .filter_map(|c| capsule_hit(o, d, t_max, c).map(|t| (t, c.segment)))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let got = grid
            .first_hit(o, d, t_max, &own)
            .map(|h| (h.0, h.2.segment));
        assert_eq!(got, want, "ray {o} {d} to {t_max}");
        met += want.is_some() as u32;
        rays += 1;
    }
    assert!(
        rays > 2500 && met > 300 && met < rays - 300,
        "{met} of {rays}"
    );
}

/// 8. The grid built in parallel is the same on one thread and on all:
///    its capsules in the same order, the same cells and lists, with
///    and without spread (40 000 segments, several build chunks; a
///    NaN segment left out in both).
#[test]
fn t08_grid_independent_of_threads() {
    let mut st = 0x0dd_ba11u64;
    let mut segs = random_segments(&mut st, 40_000, 0.05, 0.002, 16);
    segs[777].a = Vec3::new(f32::NAN, 0.0, 0.0);
    for spread in [0.0, 0.004] {
        let key = |g: &SegmentGrid| {
            let caps: Vec<(u32, u32)> = g.segments.iter().map(|c| (c.segment, c.strand)).collect();
            (
                caps,
                g.start.clone(),
                g.items.clone(),
                g.capsule_of.clone(),
                g.cell.to_bits(),
                g.dims,
            )
        };
        let all = key(&SegmentGrid::with_spread(&segs, spread).unwrap());
        crate::threads::set_single_threaded(true);
        let one = key(&SegmentGrid::with_spread(&segs, spread).unwrap());
        crate::threads::set_single_threaded(false);
        assert!(all.0.len() == segs.len() - 1 && all.2.len() > all.0.len());
        assert!(all == one, "spread {spread}");
    }
}
