//! Setup: the scene's bounds, and its primitives in the forms the later
//! stages use: strand segments projected and clipped to the near plane,
//! card and mesh triangles projected, world-space segments for shadow maps.

use super::scene::{Scene, Strands};
use super::view::View;
use glam::Vec3;

/// A projected strand segment.
#[derive(Debug, Clone, Copy)]
pub struct Segment {
    /// Screen positions of the ends.
    pub a: [f32; 2],
    pub b: [f32; 2],
    /// View depths of the ends.
    pub za: f32,
    pub zb: f32,
    /// Pixel widths at the ends.
    pub wa: f32,
    pub wb: f32,
    /// World ends (after near-plane clipping).
    pub pa: Vec3,
    pub pb: Vec3,
    /// The segment ends at a strand tip (round coverage there), else butt.
    pub last: bool,
    /// Index of the strand vertex the segment starts at, and where its
    /// ends lie between that vertex and the next (0 and 1 unless clipped).
    pub i: u32,
    pub ta: f32,
    pub tb: f32,
    /// Shaded radiance at the ends (per-vertex shading only).
    pub ca: Vec3,
    pub cb: Vec3,
    /// World radii at the ends, and the strand.
    pub ra: f32,
    pub rb: f32,
    pub strand: u32,
}

impl Segment {
    /// How far its coverage reaches beyond the centre line, in pixels: half
    /// the widest width (at least one pixel) plus the half-pixel filter,
    /// plus half a pixel of margin.
    #[inline]
    pub fn pad(&self) -> f32 {
        0.5 * self.wa.max(self.wb).max(1.0) + 1.0
    }

    /// A screen-space segment from `a` to `b` at depth 1, `wa`, `wb` pixels
    /// wide at its ends, on no strand (for the coverage tests).
    #[cfg(test)]
    pub fn on_screen(a: [f32; 2], b: [f32; 2], (wa, wb): (f32, f32), last: bool) -> Self {
        Segment {
            a,
            b,
            za: 1.0,
            zb: 1.0,
            wa,
            wb,
            pa: Vec3::ZERO,
            pb: Vec3::ZERO,
            last,
            i: 0,
            ta: 0.0,
            tb: 1.0,
            ca: Vec3::ZERO,
            cb: Vec3::ZERO,
            ra: 0.0,
            rb: 0.0,
            strand: 0,
        }
    }
}

/// A strand segment in world space, with the radii at its ends.
#[derive(Debug, Clone, Copy)]
pub struct WorldSegment {
    pub a: Vec3,
    pub b: Vec3,
    pub ra: f32,
    pub rb: f32,
    /// The strand it belongs to.
    pub strand: u32,
    /// The index of its first vertex (`a`) in the strands' points.
    pub vertex: u32,
}

/// A sphere bounding the whole scene: (centre, radius).
#[derive(Debug, Clone, Copy)]
pub struct Bounds {
    pub center: Vec3,
    pub radius: f32,
}

/// The bounding sphere of the scene's bounding box (strands with their
/// radii, cards, meshes, spheres); the unit sphere when nothing is finite.
pub fn scene_bounds(scene: &Scene) -> Bounds {
    let (mut lo, mut hi) = hair_box(&[&scene.strands])
        .unwrap_or((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)));
    for c in scene
        .cards
        .corners
        .iter()
        .chain(scene.triangles.iter().flat_map(|t| t.p.iter()))
    {
        lo = lo.min(*c);
        hi = hi.max(*c);
    }
    for s in &scene.spheres {
        lo = lo.min(s.center - Vec3::splat(s.radius));
        hi = hi.max(s.center + Vec3::splat(s.radius));
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Bounds {
            center: Vec3::ZERO,
            radius: 1.0,
        };
    }
    Bounds {
        center: 0.5 * (lo + hi),
        radius: (0.5 * (hi - lo).length()).max(1e-6),
    }
}

/// How far from the hair's centre (the per-axis median of its vertices) a
/// vertex may lie, in units of the 90th percentile of the vertices'
/// distances from it, and still count in the hair's box. On the dense,
/// held-out and demo heads the farthest vertex lies at 1.33-1.51 of that
/// percentile; a stray strand 1e5 or 1e18 away stretched the shadow maps,
/// density grids and the traced grid over it, and every shadow went wrong.
/// Hair of which more than a tenth lies far away keeps all of it.
pub const OUTLIER_DISTANCE: f32 = 16.0;

/// The box of the vertices of `strands`, each grown by its radius, leaving
/// out non-finite vertices and those beyond [`OUTLIER_DISTANCE`] times the
/// 90th-percentile distance from the hair's centre (the renderer still draws them; shadow
/// maps and grids do not reach them, so they cast no shadows there). None
/// without a finite vertex.
pub fn hair_box(strands: &[&Strands]) -> Option<(Vec3, Vec3)> {
    let runs: Vec<(&[Vec3], &[f32])> = strands
        .iter()
        .map(|st| {
            let n = st.points.len().min(st.radii.len());
            (&st.points[..n], &st.radii[..n])
        })
        .collect();
    box_of(&runs)
}

/// [`hair_box`] of points with radii.
pub fn robust_box(points: &[Vec3], radii: &[f32]) -> Option<(Vec3, Vec3)> {
    let n = points.len().min(radii.len());
    box_of(&[(&points[..n], &radii[..n])])
}

/// Vertices a task of [`box_of`]'s passes reads.
const BOX_CHUNK: usize = 8192;

/// [`hair_box`] of the points with radii of `runs` laid end to end, read
/// in place run by run (the statistics from a sample, the box in
/// parallel: a head's 425 000 vertices, copied out first, took 10 ms a
/// frame on one thread; read through an index over the runs, 5 ms).
fn box_of(runs: &[(&[Vec3], &[f32])]) -> Option<(Vec3, Vec3)> {
    use rayon::prelude::*;
    let finite = |p: &Vec3, r: &f32| p.is_finite() && r.is_finite();
    let chunks = || {
        runs.par_iter()
            .flat_map(|(p, r)| p.par_chunks(BOX_CHUNK).zip(r.par_chunks(BOX_CHUNK)))
    };
    let dropped = crate::threads::pool().install(|| {
        chunks()
            .map(|(p, r)| p.iter().zip(r).filter(|(p, r)| !finite(p, r)).count())
            .sum::<usize>()
    });
    if dropped > 0 {
        // the finite ones alone, in order
        let (points, radii): (Vec<Vec3>, Vec<f32>) = runs
            .iter()
            .flat_map(|(p, r)| p.iter().zip(r.iter()))
            .filter(|(p, r)| finite(p, r))
            .map(|(p, r)| (*p, *r))
            .unzip();
        return box_of(&[(&points, &radii)]);
    }
    let n: usize = runs.iter().map(|(p, _)| p.len()).sum();
    if n == 0 {
        return None;
    }
    // vertex i of the runs laid end to end (for the sample)
    let ends: Vec<usize> = runs
        .iter()
        .scan(0, |n, (p, _)| {
            *n += p.len();
            Some(*n)
        })
        .collect();
    let point = |i: usize| {
        let k = ends.partition_point(|&e| e <= i);
        let j = i - if k > 0 { ends[k - 1] } else { 0 };
        (runs[k].0[j], runs[k].1[j])
    };
    // the k-th smallest, and the median (the mean of the two middle values
    // of an even count: the lower one alone put the centre of two strands
    // at one of their ends)
    let nth = |v: &mut Vec<f32>, k: usize| *v.select_nth_unstable_by(k, f32::total_cmp).1;
    let median = |mut v: Vec<f32>| {
        let n = v.len();
        let lo = nth(&mut v, (n - 1) / 2);
        if n % 2 == 1 {
            lo
        } else {
            // (the next value up: the least of those the selection left
            // above the middle)
            let hi = v[n / 2..]
                .iter()
                .copied()
                .min_by(f32::total_cmp)
                .unwrap_or(lo);
            0.5 * (lo + hi)
        }
    };
    // the statistics from at most 65536 evenly spaced vertices (a head's
    // 800 000 took 20 ms a frame), the three axes' medians in parallel
    let step = n.div_ceil(1 << 16);
    let sample = || (0..n).step_by(step).map(&point);
    let axis = |k: usize| median(sample().map(|e| e.0[k]).collect());
    let (x, (y, z)) = crate::threads::pool()
        .install(|| rayon::join(|| axis(0), || rayon::join(|| axis(1), || axis(2))));
    let c = Vec3::new(x, y, z);
    let mut d: Vec<f32> = sample().map(|e| (e.0 - c).length()).collect();
    let m = d.len();
    let spread = nth(&mut d, (m - 1) * 9 / 10);
    let limit = if spread > 0.0 {
        OUTLIER_DISTANCE * spread
    } else {
        f32::INFINITY
    };
    // (min and max are exact: the same box in any order)
    let empty = || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let (lo, hi) = crate::threads::pool().install(|| {
        chunks()
            .map(|(p, r)| {
                p.iter().zip(r).fold(empty(), |(lo, hi), (&p, &r)| {
                    if (p - c).length() <= limit {
                        (lo.min(p - Vec3::splat(r)), hi.max(p + Vec3::splat(r)))
                    } else {
                        (lo, hi)
                    }
                })
            })
            .reduce(empty, |a, b| (a.0.min(b.0), a.1.max(b.1)))
    });
    Some((lo, hi))
}

/// The distance the near plane is a small fraction of ([`View::new`]):
/// the median distance of the hair (strand segments' nearest points and
/// card corners) from the camera, so
/// a large floor or ground sphere does not push the near plane past nearby
/// hair; without hair, the nearer of the camera's target and the far side
/// of the scene (`bounds`). A median, not the far side: a stray strand far
/// away (one at 1e5, or one from x = -1e18 to 1e18 among four vertices)
/// took the near plane past the rest of the hair, which then vanished.
pub fn near_reference(scene: &Scene, bounds: Bounds) -> f32 {
    let eye = scene.camera.position;
    let st = &scene.strands;
    // per segment, the distance of its nearest point (a long segment's
    // ends can both lie far from where it passes the camera)
    let segment = |s: usize| {
        let (a, b) = (st.points[s], st.points[s + 1]);
        let u = b - a;
        let t = if u.length_squared() > 0.0 {
            ((eye - a).dot(u) / u.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (a + u * t - eye).length() + st.radii[s].max(st.radii[s + 1])
    };
    // (in parallel over strands: the median is the same in any order)
    let mut hair: Vec<f32> = {
        use rayon::prelude::*;
        crate::threads::pool().install(|| {
            (0..st.strand_count())
                .into_par_iter()
                .flat_map_iter(|k| {
                    (st.offsets[k] as usize..(st.offsets[k + 1] as usize).saturating_sub(1))
                        .map(segment)
                })
                .chain(scene.cards.corners.par_iter().map(|p| (*p - eye).length()))
                .filter(|d| d.is_finite())
                .collect()
        })
    };
    let far = if hair.is_empty() {
        None
    } else {
        let k = (hair.len() - 1) / 2;
        Some(*hair.select_nth_unstable_by(k, f32::total_cmp).1)
    };
    match far {
        Some(d) if d > 0.0 => d,
        _ => {
            let far = (bounds.center - eye).length() + bounds.radius;
            let target = (scene.camera.target - eye).length();
            if target > 0.0 && target.is_finite() {
                far.min(target)
            } else {
                far
            }
        }
    }
}

/// Every strand segment in world space (for shadow maps: unclipped).
pub fn world_segments(st: &Strands) -> Vec<WorldSegment> {
    let range = |s: usize| st.offsets[s] as usize..(st.offsets[s + 1] as usize).saturating_sub(1);
    crate::threads::concat_ordered(
        st.strand_count(),
        |s| range(s).len(),
        |s, push| {
            for i in range(s) {
                push(WorldSegment {
                    a: st.points[i],
                    b: st.points[i + 1],
                    ra: st.radii[i],
                    rb: st.radii[i + 1],
                    strand: s as u32,
                    vertex: i as u32,
                });
            }
        },
    )
}

/// Projects every strand segment, clipped to the near plane, in parallel
/// over strands and in scene order.
pub fn project_segments(st: &Strands, view: &View) -> Vec<Segment> {
    let range = |s: usize| st.offsets[s] as usize..(st.offsets[s + 1] as usize).saturating_sub(1);
    // Segments wholly behind the near plane are dropped (the same test as
    // in `project`, on the same view-space depths).
    let behind = |i: usize| {
        view.to_view(st.points[i]).z < view.near && view.to_view(st.points[i + 1]).z < view.near
    };
    let count = |s: usize| range(s).filter(|&i| !behind(i)).count();
    let project = |s: usize, push: &mut dyn FnMut(Segment)| {
        let i1 = st.offsets[s + 1] as usize;
        for i in range(s) {
            let (mut pa, mut pb) = (st.points[i], st.points[i + 1]);
            let (mut ra, mut rb) = (st.radii[i], st.radii[i + 1]);
            let (mut ta, mut tb) = (0.0, 1.0);
            let (mut va, mut vb) = (view.to_view(pa), view.to_view(pb));
            // Clip to the near plane.
            if va.z < view.near && vb.z < view.near {
                continue;
            }
            if va.z < view.near || vb.z < view.near {
                let t = (view.near - va.z) / (vb.z - va.z);
                let pc = pa + (pb - pa) * t;
                let rc = ra + (rb - ra) * t;
                if va.z < view.near {
                    (pa, ra, ta) = (pc, rc, t);
                    va = view.to_view(pa);
                } else {
                    (pb, rb, tb) = (pc, rc, t);
                    vb = view.to_view(pb);
                }
            }
            // Clip to a guard band twice the view's width and height (one
            // million times the view's size across, a segment's pixel
            // coordinates lost the line in float32: a strand from x = -1e18
            // to 1e18 drew nothing); a segment wholly outside keeps its ends
            // (it draws nothing either way).
            // (both ends inside the band, with room for float32's rounding:
            // the whole segment is, and nothing is clipped)
            let inside = |v: Vec3| {
                let (gx, gy) = (
                    view.width as f32 / view.focal,
                    view.height as f32 / view.focal,
                );
                v.x.abs() <= 0.5 * gx * v.z && v.y.abs() <= 0.5 * gy * v.z
            };
            let clipped = if inside(va) && inside(vb) {
                None
            } else {
                guard_band(view, pa, pb, ra.max(rb))
            };
            if let Some(([s0, s1], [qa, qb])) = clipped {
                if s0 > 0.0 || s1 < 1.0 {
                    let lerp = |x: f32, y: f32, s: f64| (x as f64 + (y - x) as f64 * s) as f32;
                    (ra, rb) = (lerp(ra, rb, s0), lerp(ra, rb, s1));
                    (ta, tb) = (lerp(ta, tb, s0), lerp(ta, tb, s1));
                    (pa, pb) = (qa, qb);
                    (va, vb) = (view.to_view(pa), view.to_view(pb));
                }
            }
            // widths across the projected axis, perspective's off-centre
            // stretch included (View::fiber_width)
            let tau = (vb - va).normalize_or_zero();
            push(Segment {
                a: view.project2(va),
                b: view.project2(vb),
                za: va.z,
                zb: vb.z,
                wa: view.fiber_width(va, tau, ra),
                wb: view.fiber_width(vb, tau, rb),
                pa,
                pb,
                last: i + 2 == i1,
                i: i as u32,
                ta,
                tb,
                ca: Vec3::ZERO,
                cb: Vec3::ZERO,
                ra,
                rb,
                strand: s as u32,
            });
        }
    };
    crate::threads::concat_ordered(st.strand_count(), count, project)
}

/// The part `[s0, s1]` of the world segment `pa`–`pb` (in front of the
/// near plane) inside the guard band `|x|, |y| ≤ 2 z tan(half angle) +
/// margin` of the view, and its ends, or None when no part is. In float64
/// about the segment's point nearest the eye, so that the ends of a segment
/// 1e18 long land near the band (their error runs along the segment).
fn guard_band(view: &View, pa: Vec3, pb: Vec3, margin: f32) -> Option<([f64; 2], [Vec3; 2])> {
    use glam::DVec3;
    let eye = view.eye.as_dvec3();
    let axes = [view.right.as_dvec3(), view.up.as_dvec3()];
    let fwd = view.forward.as_dvec3();
    let da = pa.as_dvec3() - eye;
    let u = pb.as_dvec3() - pa.as_dvec3();
    let t_c = if u.length_squared() > 0.0 {
        (-da.dot(u) / u.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let c = da + u * t_c;
    let g = [
        view.width as f64 / view.focal as f64,
        view.height as f64 / view.focal as f64,
    ];
    // σ about t_c, within the segment
    let (mut s0, mut s1) = (-t_c, 1.0 - t_c);
    let (mut clip0, mut clip1) = (false, false);
    // each plane: g z + margin ∓ x ≥ 0, linear in σ: f(c) + σ L(u)
    for k in 0..2 {
        for sign in [1.0f64, -1.0] {
            let lin = |d: DVec3| g[k] * d.dot(fwd) - sign * d.dot(axes[k]);
            let (f0, fu) = (lin(c) + margin as f64, lin(u));
            if fu == 0.0 {
                if f0 < 0.0 {
                    return None;
                }
            } else if fu > 0.0 && -f0 / fu > s0 {
                (s0, clip0) = (-f0 / fu, true);
            } else if fu < 0.0 && -f0 / fu < s1 {
                (s1, clip1) = (-f0 / fu, true);
            }
        }
    }
    (s0 < s1).then(|| {
        let end = |s: f64| (eye + c + u * s).as_vec3();
        (
            [
                if clip0 { t_c + s0 } else { 0.0 },
                if clip1 { t_c + s1 } else { 1.0 },
            ],
            [
                if clip0 { end(s0) } else { pa },
                if clip1 { end(s1) } else { pb },
            ],
        )
    })
}

/// Radiance at the segments' ends from the per-vertex radiance (linear
/// between the two vertices where a segment was clipped).
pub fn color_segments(segs: &mut [Segment], colors: &[Vec3]) {
    use rayon::prelude::*;
    crate::threads::pool().install(|| segs.par_iter_mut().for_each(|s| color_segment(s, colors)));
}

/// [`color_segments`] of one segment.
fn color_segment(s: &mut Segment, colors: &[Vec3]) {
    let (c0, c1) = (colors[s.i as usize], colors[s.i as usize + 1]);
    let at = |t: f32| {
        if t == 0.0 {
            c0
        } else if t == 1.0 {
            c1
        } else {
            c0 + (c1 - c0) * t
        }
    };
    (s.ca, s.cb) = (at(s.ta), at(s.tb));
}

/// A projected card triangle.
#[derive(Debug, Clone, Copy)]
pub struct CardTri {
    pub p: [[f32; 2]; 3],
    pub z: [f32; 3],
    pub uv: [[f32; 2]; 3],
    pub world: [Vec3; 3],
    pub tangent: Vec3,
    pub tex: u32,
}

/// A projected opaque triangle.
#[derive(Debug, Clone, Copy)]
pub struct SolidTri {
    pub p: [[f32; 2]; 3],
    pub z: [f32; 3],
    pub world: [Vec3; 3],
    pub normal: Vec3,
    pub albedo: Vec3,
}

/// The part of a triangle (view-space corners `v`) in front of the near
/// plane, as a fan of triangles whose corners are barycentric weights of
/// the original corners (none when it lies wholly behind, or a corner is
/// not finite; the triangle itself when wholly in front).
fn clip_near(v: [Vec3; 3], near: f32) -> Vec<[[f32; 3]; 3]> {
    const CORNER: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if !v.iter().all(|x| x.is_finite()) {
        return Vec::new();
    }
    if v.iter().all(|x| x.z > near) {
        return vec![CORNER];
    }
    // Sutherland–Hodgman against z > near: at most four corners remain.
    let mut poly: Vec<[f32; 3]> = Vec::with_capacity(4);
    for k in 0..3 {
        let (a, b) = (k, (k + 1) % 3);
        let (za, zb) = (v[a].z, v[b].z);
        if za > near {
            poly.push(CORNER[a]);
        }
        if (za > near) != (zb > near) {
            let t = (near - za) / (zb - za);
            let mut w = [0.0; 3];
            w[a] = 1.0 - t;
            w[b] = t;
            poly.push(w);
        }
    }
    (1..poly.len().saturating_sub(1))
        .map(|k| [poly[0], poly[k], poly[k + 1]])
        .collect()
}

/// `Σ w_k x_k` for barycentric weights `w`.
#[inline]
fn blend<T>(w: [f32; 3], x: [T; 3]) -> T
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    x[0] * w[0] + x[1] * w[1] + x[2] * w[2]
}

/// View-space corners of a clipped triangle: its world corners with the
/// interpolated depths `z` (at least the near plane, which rounding in
/// the world-space blend could undercut).
fn clipped_view(view: &View, world: [Vec3; 3], z: [f32; 3]) -> [Vec3; 3] {
    std::array::from_fn(|k| view.to_view(world[k]).with_z(z[k].max(view.near)))
}

/// Opaque mesh triangles, projected and clipped to the near plane,
/// without those back-face culling skips (`cull[mesh]`, see
/// [`super::cull::meshes_to_cull`]). Returns the triangles and the number
/// culled.
pub fn project_solid_tris(scene: &Scene, view: &View, cull: &[bool]) -> (Vec<SolidTri>, usize) {
    let mut culled = 0;
    let mut tris = Vec::new();
    for t in &scene.triangles {
        let v = t.p.map(|x| view.to_view(x));
        let face = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
        let parts = clip_near(v, view.near);
        if parts.is_empty() {
            continue;
        }
        if cull.get(t.mesh as usize) == Some(&true) && face.dot(t.p[0] - view.eye) > 0.0 {
            culled += 1;
            continue;
        }
        let z = v.map(|x| x.z);
        for w in parts {
            let world = w.map(|w| blend(w, t.p));
            let v = clipped_view(view, world, w.map(|w| blend(w, z)));
            tris.push(SolidTri {
                p: v.map(|x| view.project2(x)),
                z: v.map(|x| x.z),
                world,
                normal: face.normalize_or_zero(),
                albedo: t.albedo,
            });
        }
    }
    (tris, culled)
}

/// Card quads as triangles, clipped to the near plane.
pub fn project_card_tris(scene: &Scene, view: &View) -> Vec<CardTri> {
    let c = &scene.cards;
    let mut out = Vec::with_capacity(2 * c.quad_count());
    for q in 0..c.quad_count() {
        for tri in [[0, 1, 2], [0, 2, 3]] {
            let idx = tri.map(|k| 4 * q + k);
            let corners = idx.map(|i| c.corners[i]);
            let v = corners.map(|x| view.to_view(x));
            let uv = idx.map(|i| glam::Vec2::from(c.uvs[i]));
            let z = v.map(|x| x.z);
            for w in clip_near(v, view.near) {
                let world = w.map(|w| blend(w, corners));
                let v = clipped_view(view, world, w.map(|w| blend(w, z)));
                out.push(CardTri {
                    p: v.map(|x| view.project2(x)),
                    z: v.map(|x| x.z),
                    uv: w.map(|w| blend(w, uv).to_array()),
                    world,
                    tangent: c.tangents[q],
                    tex: c.texture[q],
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{hair_box, robust_box, Strands};
    use glam::Vec3;

    /// 1. The hair box, read in place and in parallel: the same on one
    ///    thread and on all; across two strand sets the box of their
    ///    vertices together; a non-finite vertex left out (the box of the
    ///    rest, exactly); a far outlier left out; each vertex grown by
    ///    its radius.
    #[test]
    fn t01_hair_box() {
        // 200 000 vertices on a 2 x 1 x 0.5 block (more than the 65 536
        // the statistics sample), radius 0.01
        let n = 200_000;
        let p = |i: usize| {
            let f = i as f32 / n as f32;
            Vec3::new(2.0 * f, (97.0 * f).fract(), 0.5 * (31.0 * f).fract())
        };
        let points: Vec<Vec3> = (0..n).map(p).collect();
        let set = |pts: &[Vec3]| Strands {
            points: pts.to_vec(),
            radii: vec![0.01; pts.len()],
            offsets: vec![0, pts.len() as u32],
        };
        let (a, b) = (set(&points[..n / 3]), set(&points[n / 3..]));
        let whole = hair_box(&[&set(&points)]).unwrap();
        assert_eq!(hair_box(&[&a, &b]).unwrap(), whole);
        crate::threads::set_single_threaded(true);
        let one = hair_box(&[&a, &b]).unwrap();
        crate::threads::set_single_threaded(false);
        assert_eq!(one, whole);
        let (lo, hi) = points
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &q| {
                (l.min(q), h.max(q))
            });
        assert_eq!(whole, (lo - Vec3::splat(0.01), hi + Vec3::splat(0.01)));
        let with = |extra: Vec3| {
            let mut v = points.clone();
            v.insert(n / 2, extra);
            robust_box(&v, &vec![0.01; v.len()]).unwrap()
        };
        assert_eq!(with(Vec3::new(f32::NAN, 0.0, 0.0)), whole);
        assert_eq!(with(Vec3::splat(1e5)), whole);
    }
}
