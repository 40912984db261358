//! Setup: the scene's bounds, and its primitives in the forms the later
//! stages use: strand segments projected and clipped to the near plane,
//! card and mesh triangles projected, world-space segments for shadow maps.

use super::scene::{Scene, Strands};
use super::view::View;
use crate::threads::pool;
use glam::Vec3;
use rayon::prelude::*;

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
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for (p, r) in scene.strands.points.iter().zip(&scene.strands.radii) {
        lo = lo.min(*p - Vec3::splat(*r));
        hi = hi.max(*p + Vec3::splat(*r));
    }
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

/// Every strand segment in world space (for shadow maps: unclipped).
pub fn world_segments(st: &Strands) -> Vec<WorldSegment> {
    let mut out = Vec::new();
    for s in 0..st.strand_count() {
        let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
        for i in i0..i1.saturating_sub(1) {
            out.push(WorldSegment {
                a: st.points[i],
                b: st.points[i + 1],
                ra: st.radii[i],
                rb: st.radii[i + 1],
                strand: s as u32,
            });
        }
    }
    out
}

/// Projects every strand segment, clipped to the near plane, in parallel
/// over strands and in scene order.
pub fn project_segments(st: &Strands, view: &View) -> Vec<Segment> {
    let project = |s: usize| -> Vec<Segment> {
        let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
        let mut out = Vec::with_capacity(i1.saturating_sub(i0 + 1));
        for i in i0..i1.saturating_sub(1) {
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
            out.push(Segment {
                a: view.project2(va),
                b: view.project2(vb),
                za: va.z,
                zb: vb.z,
                wa: 2.0 * ra * view.focal / va.z,
                wb: 2.0 * rb * view.focal / vb.z,
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
        out
    };
    let per_strand: Vec<Vec<Segment>> = pool().install(|| {
        (0..st.strand_count())
            .into_par_iter()
            .map(project)
            .collect()
    });
    per_strand.into_iter().flatten().collect()
}

/// Radiance at the segments' ends from the per-vertex radiance (linear
/// between the two vertices where a segment was clipped).
pub fn color_segments(segs: &mut [Segment], colors: &[Vec3]) {
    for s in segs {
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

/// Opaque mesh triangles, projected, without those back-face culling
/// skips (`cull[mesh]`, see [`super::cull::meshes_to_cull`]); a triangle
/// with a corner behind the near plane is dropped (meshes are not
/// clipped). Returns the triangles and the number culled.
pub fn project_solid_tris(scene: &Scene, view: &View, cull: &[bool]) -> (Vec<SolidTri>, usize) {
    let mut culled = 0;
    let tris = scene
        .triangles
        .iter()
        .filter_map(|t| {
            let v = t.p.map(|x| view.to_view(x));
            if v.iter().any(|x| !(x.z > view.near)) {
                return None;
            }
            let face = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
            if cull.get(t.mesh as usize) == Some(&true) && face.dot(t.p[0] - view.eye) > 0.0 {
                culled += 1;
                return None;
            }
            Some(SolidTri {
                p: v.map(|x| view.project2(x)),
                z: v.map(|x| x.z),
                world: t.p,
                normal: face.normalize_or_zero(),
                albedo: t.albedo,
            })
        })
        .collect();
    (tris, culled)
}

/// Card quads as triangles; a triangle with a corner behind the near plane
/// is dropped (cards are not clipped).
pub fn project_card_tris(scene: &Scene, view: &View) -> Vec<CardTri> {
    let c = &scene.cards;
    let mut out = Vec::with_capacity(2 * c.quad_count());
    for q in 0..c.quad_count() {
        for tri in [[0, 1, 2], [0, 2, 3]] {
            let idx = tri.map(|k| 4 * q + k);
            let v = idx.map(|i| view.to_view(c.corners[i]));
            if v.iter().any(|x| !(x.z > view.near)) {
                continue;
            }
            out.push(CardTri {
                p: v.map(|x| view.project2(x)),
                z: v.map(|x| x.z),
                uv: idx.map(|i| c.uvs[i]),
                world: idx.map(|i| c.corners[i]),
                tangent: c.tangents[q],
                tex: c.texture[q],
            });
        }
    }
    out
}
