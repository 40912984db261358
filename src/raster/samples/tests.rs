use super::*;

fn segment(a: [f32; 2], b: [f32; 2], w: f32) -> Segment {
    Segment::on_screen(a, b, (w, w), false)
}

/// 1. Each pixel's points are uniform over the pixel: over a 64×64-pixel
///    block with 16 samples, the mean of x and y within the pixel is
///    1/2 ± 0.01 and every point lies in its pixel. (65 536 points; the
///    standard error of a uniform mean is 0.29/256 = 1.1e-3.)
#[test]
fn t01_points_fill_their_pixels() {
    let (mut sx, mut sy, mut m) = (0.0f64, 0.0f64, 0usize);
    for ty in 0..4 {
        for tx in 0..4 {
            let pts = SamplePoints::new(16, tx * TILE, ty * TILE, TILE, TILE);
            for j in 0..TILE {
                for i in 0..TILE {
                    let k = (j * TILE + i) as usize;
                    for p in pts.pixel(k) {
                        let (fx, fy) =
                            (p[0] - (tx * TILE + i) as f32, p[1] - (ty * TILE + j) as f32);
                        assert!((0.0..1.0).contains(&fx) && (0.0..1.0).contains(&fy));
                        sx += fx as f64;
                        sy += fy as f64;
                        m += 1;
                    }
                }
            }
        }
    }
    assert!((sx / m as f64 - 0.5).abs() < 0.01 && (sy / m as f64 - 0.5).abs() < 0.01);
}

/// 1b. Points computed on first use are the points computed all at
///     once, bit for bit: a tile's pixels asked for in a scrambled
///     order, some twice, on a tile off the image origin and clipped
///     at the image's edge (11 × 5 pixels inside).
#[test]
fn t01b_lazy_points_equal_eager_points() {
    let (x0, y0, tw, th) = (3 * TILE, 7 * TILE, 11, 5);
    let eager = SamplePoints::new(16, x0, y0, tw, th);
    let mut lazy = SamplePoints::lazy(16, x0, y0);
    let inside: Vec<usize> = (0..th)
        .flat_map(|j| (0..tw).map(move |i| (j * TILE + i) as usize))
        .collect();
    for step in 0..2 * inside.len() {
        let k = inside[(step * 37 + 5) % inside.len()];
        let bits = |p: &[[f32; 2]]| p.iter().map(|q| q.map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(lazy.pixel_mut(k)), bits(eager.pixel(k)), "pixel {k}");
    }
}

/// 2. A sub-pixel strand covers a fraction of a long row of pixels equal
///    to its area: a horizontal strand 0.2 pixel wide across 256 pixels
///    at a non-aligned height covers 0.2 of the samples ± 3 %. (Per
///    pixel a count out of 32; the per-pixel shifts make the pixels
///    independent: the standard error of the mean fraction is about
///    √(0.2·0.8/32/256) = 4.4e-3, 2.2 % of 0.2.)
#[test]
fn t02_subpixel_strand_covers_its_area() {
    let n = 32;
    let mut covered = 0usize;
    let mut total = 0usize;
    for tx in 0..16 {
        let pts = SamplePoints::new(n, tx * TILE, 0, TILE, TILE);
        let s = segment([-10.0, 7.37], [300.0, 7.37], 0.2);
        let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
        let inv = 1.0 / (d[0] * d[0] + d[1] * d[1]);
        for i in 0..TILE {
            let k = (7 * TILE + i) as usize;
            covered += pts
                .pixel(k)
                .iter()
                .filter(|&&p| strand_covers(&s, d, inv, p))
                .count();
            total += n;
        }
    }
    let f = covered as f64 / total as f64;
    assert!((f / 0.2 - 1.0).abs() < 0.03, "{f}");
}

/// 3. The nearest fragment owns a sample whatever the drawing order,
///    and nothing behind the opaque depth takes a sample.
#[test]
fn t03_nearest_owns() {
    let mut b = SampleBuffer::new(4, &[5.0]);
    let claim = |id: u32, depth_lo: f32| Claim {
        id,
        key: id + 1,
        depth_lo,
    };
    assert!(b.cover(0, claim(0, 3.0), |s| (s < 2).then_some(3.0)));
    assert!(b.cover(0, claim(1, 2.0), |s| (s == 1).then_some(2.0)));
    assert!(!b.cover(0, claim(2, 4.0), |_| Some(4.0)) || b.owners(0).any(|o| o == Some(2)));
    assert!(!b.cover(0, claim(3, 6.0), |_| Some(6.0)));
    // hair at the opaque surface's own depth does not take it
    assert!(!b.cover(0, claim(4, 5.0), |_| Some(5.0)));
    let owners: Vec<_> = b.owners(0).collect();
    assert_eq!(owners, vec![Some(0), Some(1), Some(2), Some(2)]);
    let mut c = vec![0u32; 4];
    b.counts(&mut c);
    assert_eq!(c, vec![1, 1, 2, 0]);
}

/// 4. A sample's depth is where the ray through it meets the fiber's
///    surface: against the analytic ray-cylinder hit (the ray through
///    the sample point, the cylinder of radius r around the segment),
///    for fibers 12°, 30° and 80° off the view ray, at offsets across
///    the fiber from edge to edge. Within 0.25 r: the offset on screen
///    is taken for the ray's distance from the axis, which it is only
///    approximately in perspective (measured: 0.18 r at 12° and
///    |h| = 0.95, 0.03 r at 30°, 0.01 r at 80°, under 0.01 r at the
///    centre). The axis's depth is off by up to r / sin α = 4.8 r at 12°,
///    which the test checks it would see.
#[test]
fn t04_sample_depth_is_the_surface_hit() {
    use crate::raster::scene::Camera;
    use crate::raster::view::View;
    let cam = Camera {
        position: Vec3::new(0.0, 0.0, 1.2),
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov_y: 10.0,
        width: 320,
        height: 180,
    };
    let view = View::new(&cam, 1.0);
    let r = 0.01f32;
    let mut worst_axis = 0.0f32;
    for alpha in [12.0f32, 30.0, 80.0] {
        let a = alpha.to_radians();
        let dir = Vec3::new(0.2 * a.sin(), a.sin(), -a.cos()).normalize();
        let (pa, pb) = (-0.2 * dir, 0.2 * dir);
        let (va, vb) = (view.to_view(pa), view.to_view(pb));
        // widths as `setup::project_segments` draws them
        let tau = (vb - va).normalize();
        let w = |v: Vec3| view.fiber_width(v, tau, r);
        let mut s = Segment::on_screen(view.project2(va), view.project2(vb), (w(va), w(vb)), false);
        (s.za, s.zb) = (va.z, vb.z);
        let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
        let inv_len2 = 1.0 / (d[0] * d[0] + d[1] * d[1]);
        let len = inv_len2.sqrt();
        let perp = [-d[1] * len, d[0] * len];
        let (mid, t) = (view.project2(view.to_view(Vec3::ZERO)), dir);
        let half = 0.5 * w(view.to_view(Vec3::ZERO));
        let lead = surface_lead(r, t, Vec3::ZERO, view.eye, view.to_view(Vec3::ZERO).z);
        for h in [-0.95f32, -0.6, -0.2, 0.0, 0.3, 0.7, 0.95] {
            let p = [mid[0] + perp[0] * half * h, mid[1] + perp[1] * half * h];
            // the exact hit of the ray through p
            let ray = view.ray(p[0], p[1]);
            let w0 = view.eye - pa;
            let (dp, wp) = (ray - t * ray.dot(t), w0 - t * w0.dot(t));
            let (qa, qb, qc) = (dp.dot(dp), 2.0 * wp.dot(dp), wp.dot(wp) - r * r);
            let disc = qb * qb - 4.0 * qa * qc;
            assert!(disc > 0.0, "{alpha} {h}: the ray misses");
            let th = (-qb - disc.sqrt()) / (2.0 * qa);
            let exact = (ray * th).dot(view.forward);
            let got = strand_depth(&s, d, inv_len2, lead, p).expect("covered");
            let axis = strand_depth(&s, d, inv_len2, 0.0, p).unwrap();
            assert!(
                (got - exact).abs() < 0.25 * r,
                "{alpha}° h {h}: {got} vs {exact}"
            );
            worst_axis = worst_axis.max((axis - exact).abs() / r);
        }
    }
    assert!(
        worst_axis > 4.0,
        "the axis's depth is off by {worst_axis} r"
    );
}

/// Numbers in [0, 1) from a linear congruential sequence.
fn uniforms(mut seed: u32) -> impl FnMut() -> f32 {
    move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        unit(seed)
    }
}

/// 5. The strand pass's branch-free `cover_strand` takes the same
///    samples at the same depths as `cover` with `strand_depth`, bit
///    for bit: 4000 random segments (tips and not, zero length, zero
///    width, end depths 0.5 to 4, leads 0 to 0.3) over random pixels,
///    each into a buffer already holding earlier fragments, with
///    `depth_lo` below, between and above the stored depths.
#[test]
fn t05_branch_free_strand_cover_equals_per_sample_cover() {
    let mut r = uniforms(7u32);
    let pts = SamplePoints::new(16, 0, 0, TILE, TILE);
    let opaque = vec![3.0f32; (TILE * TILE) as usize];
    let (mut a, mut b) = (
        SampleBuffer::new(16, &opaque),
        SampleBuffer::new(16, &opaque),
    );
    let mut taken = 0;
    for id in 0..4000u32 {
        let k = (r() * (TILE * TILE) as f32) as usize % (TILE * TILE) as usize;
        let (px, py) = ((k as u32 % TILE) as f32, (k as u32 / TILE) as f32);
        let p0 = [px + 2.0 * r() - 0.5, py + 2.0 * r() - 0.5];
        let p1 = if id % 17 == 0 {
            p0
        } else {
            [px + 3.0 * r() - 1.0, py + 3.0 * r() - 1.0]
        };
        let w = if id % 23 == 0 { 0.0 } else { 1.5 * r() };
        let mut seg = Segment::on_screen(p0, p1, (w, 1.5 * r()), id % 3 == 0);
        (seg.za, seg.zb) = (0.5 + 3.5 * r(), 0.5 + 3.5 * r());
        let d = [seg.b[0] - seg.a[0], seg.b[1] - seg.a[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let inv_len2 = if len2 > 0.0 { 1.0 / len2 } else { 0.0 };
        let lead = 0.3 * r();
        let lo = 0.5 + 3.0 * r();
        let pix = pts.pixel(k);
        let c = Claim {
            id,
            key: id % 97,
            depth_lo: lo,
        };
        let ta = a.cover(k, c, |s| strand_depth(&seg, d, inv_len2, lead, pix[s]));
        let tb = b.cover_strand(k, c, pix, &StrandSamples::new(&seg, d, inv_len2, lead));
        assert_eq!(ta, tb, "fragment {id}");
        taken += ta as u32;
    }
    assert!(taken > 400, "{taken} fragments took samples");
    let bits = |x: &SampleBuffer| x.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.owner, b.owner);
    assert_eq!(a.key, b.key);
}

/// 6. The owners do not depend on the order fragments arrive in: 600
///    random segments over one tile, a sixth of them exact copies of an
///    earlier one (equal depths at every sample), drawn in scene order,
///    nearest first, and farthest first, each pixel skipped where
///    [`SampleBuffer::may_take`] says so: every sample ends with the
///    same depth and the same owner (the smaller key among equals).
///    Fails with ties broken by arrival (copies change owners).
#[test]
fn t06_owners_do_not_depend_on_order() {
    let mut r = uniforms(11u32);
    let pts = SamplePoints::new(16, 0, 0, TILE, TILE);
    let opaque: Vec<f32> = (0..TILE * TILE)
        .map(|k| if k % 5 == 0 { 2.0 } else { 9.0 })
        .collect();
    let mut segs: Vec<(Segment, f32)> = Vec::new();
    for i in 0..600usize {
        if i % 6 == 5 {
            let j = (r() * i as f32) as usize % i;
            segs.push(segs[j].clone());
            continue;
        }
        let p0 = [r() * TILE as f32, r() * TILE as f32];
        let p1 = [p0[0] + 6.0 * r() - 3.0, p0[1] + 6.0 * r() - 3.0];
        let mut seg = Segment::on_screen(p0, p1, (0.3 + 1.2 * r(), 0.3 + 1.2 * r()), i % 4 == 0);
        (seg.za, seg.zb) = (1.0 + 3.0 * r(), 1.0 + 3.0 * r());
        segs.push((seg, 0.05 * r()));
    }
    let draw = |order: &[usize]| {
        let mut buf = SampleBuffer::new(16, &opaque);
        for &i in order {
            let (seg, lead) = &segs[i];
            let d = [seg.b[0] - seg.a[0], seg.b[1] - seg.a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let inv_len2 = if len2 > 0.0 { 1.0 / len2 } else { 0.0 };
            let c = Claim {
                id: i as u32,
                key: i as u32,
                depth_lo: seg.za.min(seg.zb) - lead,
            };
            let ss = StrandSamples::new(seg, d, inv_len2, *lead);
            for k in 0..(TILE * TILE) as usize {
                if buf.may_take(k, c.depth_lo) {
                    buf.cover_strand(k, c, pts.pixel(k), &ss);
                }
            }
        }
        buf
    };
    let scene: Vec<usize> = (0..segs.len()).collect();
    let mut nearest = scene.clone();
    let z = |i: usize| segs[i].0.za.min(segs[i].0.zb);
    nearest.sort_by(|&a, &b| z(a).total_cmp(&z(b)).then(a.cmp(&b)));
    let farthest: Vec<usize> = nearest.iter().rev().copied().collect();
    let a = draw(&scene);
    let copies_own = a
        .owner
        .iter()
        .filter(|&&o| o != NONE && (o as usize) % 6 == 5)
        .count();
    for other in [draw(&nearest), draw(&farthest)] {
        let bits = |x: &SampleBuffer| x.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a), bits(&other));
        assert_eq!(a.owner, other.owner);
    }
    // the copies tie with their originals: the originals (smaller
    // keys) keep every sample a copy covers
    assert_eq!(copies_own, 0);
    assert!(a.owner.iter().filter(|&&o| o != NONE).count() > 2000);
}
