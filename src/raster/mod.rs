//! CPU software rasterizer for hair strand scenes.
//!
//! Pipeline (after Capcom's RE ENGINE strand renderer and Karis 2016):
//!
//! 1. strands are cut into segments, clipped to the near plane, projected,
//!    and binned to 16×16 screen tiles;
//! 2. shadow maps are built for the lights that cast shadows (depth of the
//!    first hair and of opaque geometry; hair attenuates exponentially with
//!    the depth behind the first hair, PCF-filtered, as Karis describes);
//! 3. tiles are processed in parallel (rayon): opaque spheres are ray-cast
//!    per pixel, every segment covering a pixel becomes a fragment with
//!    analytic anti-aliased coverage (strands thinner than a pixel are drawn
//!    one pixel wide with their alpha scaled by the width, as UE and RE4
//!    do), shaded per pixel, and inserted into Multi-Layer Alpha Blending
//!    (k layers) or an exact per-pixel sorted list;
//! 4. layers are composited front to back over the opaque surface.
//!
//! Rendering is deterministic: every tile processes its segments in scene
//! order, whatever the thread count. Non-finite values never reach the
//! image (they are replaced by 0 and counted).

pub mod oit;
pub mod scene;
pub mod shadow;

use crate::batch::pool;
use crate::fiber::karis::Transmittance;
use crate::lighting::sh9_eval;
use glam::Vec3;
use oit::Layers;
use rayon::prelude::*;
use scene::{HairShading, RenderOptions, Scene, Transparency};
use shadow::ShadowMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

const TILE: u32 = 16;

/// The camera's basis and projection.
#[derive(Debug, Clone, Copy)]
pub struct View {
    pub eye: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub focal: f32,
    pub width: u32,
    pub height: u32,
    pub near: f32,
}

impl View {
    pub fn new(c: &scene::Camera, scene_radius: f32) -> Self {
        let forward = (c.target - c.position).normalize_or(Vec3::Z);
        let right = forward.cross(c.up).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let focal = 0.5 * c.height as f32 / (0.5 * c.fov_y.to_radians()).tan();
        Self {
            eye: c.position,
            right,
            up,
            forward,
            focal,
            width: c.width,
            height: c.height,
            near: (1e-4 * scene_radius).max(1e-6),
        }
    }

    /// View-space coordinates (x right, y up, z forward depth).
    #[inline]
    pub fn to_view(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// Pixel coordinates of a view-space point with z > 0.
    #[inline]
    pub fn project(&self, v: Vec3) -> (f32, f32) {
        (
            0.5 * self.width as f32 + self.focal * v.x / v.z,
            0.5 * self.height as f32 - self.focal * v.y / v.z,
        )
    }

    /// World-space direction of the ray through pixel position (x, y).
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Vec3 {
        let vx = (x - 0.5 * self.width as f32) / self.focal;
        let vy = (0.5 * self.height as f32 - y) / self.focal;
        (self.forward + vx * self.right + vy * self.up).normalize()
    }
}

/// A projected strand segment.
#[derive(Debug, Clone, Copy)]
struct Segment {
    /// Screen positions of the ends.
    a: [f32; 2],
    b: [f32; 2],
    /// View depths of the ends.
    za: f32,
    zb: f32,
    /// Pixel widths at the ends.
    wa: f32,
    wb: f32,
    /// World ends (after near-plane clipping).
    pa: Vec3,
    pb: Vec3,
    /// The segment ends at a strand tip (round coverage there), else butt.
    last: bool,
    /// Index of the strand vertex the segment starts at, and where its
    /// ends lie between that vertex and the next (0 and 1 unless clipped).
    i: u32,
    ta: f32,
    tb: f32,
    /// Shaded radiance at the ends (per-vertex shading only).
    ca: Vec3,
    cb: Vec3,
}

impl Segment {
    /// How far its coverage reaches beyond the centre line, in pixels: half
    /// the widest width (at least one pixel) plus the half-pixel filter,
    /// plus half a pixel of margin.
    #[inline]
    fn pad(&self) -> f32 {
        0.5 * self.wa.max(self.wb).max(1.0) + 1.0
    }
}

/// Statistics of one render.
#[derive(Debug, Clone, Default)]
pub struct RenderStats {
    pub segments: usize,
    pub segments_visible: usize,
    /// Strand vertices shaded (per-vertex shading; frustum culling leaves
    /// out those of segments that reach no pixel).
    pub vertices_shaded: usize,
    /// Mesh triangles skipped by back-face culling.
    pub backfaces_culled: usize,
    pub fragments: u64,
    pub non_finite_pixels: u64,
    /// Segment or card-triangle visits skipped because the tile's opaque
    /// surface is in front of them everywhere.
    pub culled_behind_opaque: u64,
    /// Light evaluations skipped by light culling, and the largest bound of
    /// a skipped contribution (radiance; a pixel changes by at most this
    /// times the number of lights).
    pub lights_culled: u64,
    pub light_cull_max_skipped: f32,
    /// Shadow maps taken from an earlier render (see `reuse_shadow_maps`).
    pub shadow_maps_reused: usize,
    /// Shadowed lights whose map was not built: light culling skips them at
    /// every hair point (see `lights_without_visible_effect`).
    pub shadow_maps_skipped: usize,
    /// Wall time of the phases, in milliseconds: shadow maps, setup
    /// (per-vertex shading when on, projection, binning), tiles
    /// (rasterization, shading, resolve), and the whole render.
    pub shadow_ms: f64,
    pub setup_ms: f64,
    pub tiles_ms: f64,
    pub total_ms: f64,
}

/// The rendered image: linear radiance, row-major, RGB.
#[derive(Debug, Clone)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

fn scene_bounds(scene: &Scene) -> (Vec3, f32) {
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
        return (Vec3::ZERO, 1.0);
    }
    let c = 0.5 * (lo + hi);
    (c, (0.5 * (hi - lo).length()).max(1e-6))
}

/// Radiance shaded at the strand vertices where `needed` is set (all when
/// `None`; 0 elsewhere), for per-vertex shading. Tangent: the central
/// difference.
fn shade_vertices(
    scene: &Scene,
    shader: &Shader<'_>,
    eye: Vec3,
    needed: Option<&[bool]>,
) -> Vec<Vec3> {
    let st = &scene.strands;
    let mut owner = vec![0usize; st.points.len()];
    for s in 0..st.strand_count() {
        for o in &mut owner[st.offsets[s] as usize..st.offsets[s + 1] as usize] {
            *o = s;
        }
    }
    let tangent = |i: usize| {
        let s = owner[i];
        let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
        let (a, b) = (st.points[i.max(i0 + 1) - 1], st.points[(i + 1).min(i1 - 1)]);
        (b - a).normalize_or_zero()
    };
    // The vertices to shade, as indices into the strands' points.
    let index: Vec<usize> = match needed {
        Some(m) => (0..st.points.len()).filter(|&i| m[i]).collect(),
        None => (0..st.points.len()).collect(),
    };
    let points: Vec<Vec3> = index.iter().map(|&i| st.points[i]).collect();
    let shaded = shader
        .shade_batch(&points, &|j| tangent(index[j]), eye)
        .unwrap_or_else(|| {
            pool().install(|| {
                index
                    .par_iter()
                    .map(|&i| {
                        let p = st.points[i];
                        shader.shade(p, tangent(i), (eye - p).normalize_or_zero())
                    })
                    .collect()
            })
        });
    if needed.is_none() {
        return shaded;
    }
    let mut out = vec![Vec3::ZERO; st.points.len()];
    for (&i, c) in index.iter().zip(shaded) {
        out[i] = c;
    }
    out
}

/// Projects every strand segment, clipped to the near plane, in parallel
/// over strands and in scene order, with the number of segments before
/// culling. With `frustum_culling`, segments that reach no tile (the
/// binning test [`tile_range`]) are dropped here, before any shading.
fn build_segments(
    scene: &Scene,
    view: &View,
    tiles: (u32, u32),
    frustum_culling: bool,
) -> (Vec<Segment>, usize) {
    let st = &scene.strands;
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
            let (a, b) = (view.project(va), view.project(vb));
            out.push(Segment {
                a: [a.0, a.1],
                b: [b.0, b.1],
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
    let total = per_strand.iter().map(Vec::len).sum();
    let segs = per_strand
        .into_iter()
        .flatten()
        .filter(|s| !frustum_culling || tile_range(s, tiles.0, tiles.1).is_some())
        .collect();
    (segs, total)
}

/// Which strand vertices the segments use (for per-vertex shading).
fn vertices_used(segs: &[Segment], vertex_count: usize) -> Vec<bool> {
    let mut used = vec![false; vertex_count];
    for s in segs {
        used[s.i as usize] = true;
        used[s.i as usize + 1] = true;
    }
    used
}

/// Radiance at the segments' ends from the per-vertex radiance (linear
/// between the two vertices where a segment was clipped).
fn color_segments(segs: &mut [Segment], colors: &[Vec3]) {
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

/// A 2D triangle's signed doubled area and pixel bounding box, for
/// barycentric rasterization; None when degenerate or non-finite.
pub(crate) struct Tri2 {
    p: [[f32; 2]; 3],
    area: f32,
    /// Inclusive pixel bounds (x0, x1, y0, y1), unclamped.
    pub bounds: (i64, i64, i64, i64),
}

impl Tri2 {
    pub(crate) fn new(p: [[f32; 2]; 3]) -> Option<Self> {
        let area =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
        if area.abs() < 1e-12 || !area.is_finite() {
            return None;
        }
        let (xs, ys) = (p.map(|q| q[0]), p.map(|q| q[1]));
        let bounds = (
            xs[0].min(xs[1]).min(xs[2]).floor() as i64,
            xs[0].max(xs[1]).max(xs[2]).ceil() as i64,
            ys[0].min(ys[1]).min(ys[2]).floor() as i64,
            ys[0].max(ys[1]).max(ys[2]).ceil() as i64,
        );
        Some(Self { p, area, bounds })
    }

    /// Barycentric coordinates of `s`, or None outside the triangle.
    #[inline]
    pub(crate) fn barycentric(&self, s: [f32; 2]) -> Option<[f32; 3]> {
        let edge = |a: [f32; 2], b: [f32; 2]| {
            (b[0] - a[0]) * (s[1] - a[1]) - (s[0] - a[0]) * (b[1] - a[1])
        };
        let p = &self.p;
        let b = [
            edge(p[1], p[2]) / self.area,
            edge(p[2], p[0]) / self.area,
            edge(p[0], p[1]) / self.area,
        ];
        (b[0] >= 0.0 && b[1] >= 0.0 && b[2] >= 0.0).then_some(b)
    }
}

/// A projected card triangle.
#[derive(Debug, Clone, Copy)]
struct CardTri {
    p: [[f32; 2]; 3],
    z: [f32; 3],
    uv: [[f32; 2]; 3],
    world: [Vec3; 3],
    tangent: Vec3,
    tex: u32,
}

/// A projected opaque triangle.
#[derive(Debug, Clone, Copy)]
struct SolidTri {
    p: [[f32; 2]; 3],
    z: [f32; 3],
    world: [Vec3; 3],
    normal: Vec3,
    albedo: Vec3,
}

/// Opaque mesh triangles, projected; a triangle with a corner behind the
/// near plane is dropped (meshes are not clipped).
fn build_solid_tris(scene: &Scene, view: &View, cull: &[bool]) -> (Vec<SolidTri>, usize) {
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
            let n = face.normalize_or_zero();
            Some(SolidTri {
                p: v.map(|x| {
                    let (a, b) = view.project(x);
                    [a, b]
                }),
                z: v.map(|x| x.z),
                world: t.p,
                normal: n,
                albedo: t.albedo,
            })
        })
        .collect();
    (tris, culled)
}

/// Per mesh, whether its back faces can be skipped: it is closed and
/// consistently oriented (every directed edge is matched by exactly one
/// opposite edge, vertices compared bit for bit), oriented outwards
/// (positive signed volume), the eye is outside it (winding number 0, from
/// the sum of the triangles' solid angles) and no triangle of it is dropped
/// at the near plane. Then every ray from the eye enters the mesh through a
/// front face before it can meet a back face, so back faces are hidden.
fn meshes_to_cull(scene: &Scene, view: &View) -> Vec<bool> {
    let meshes = scene
        .triangles
        .iter()
        .map(|t| t.mesh as usize + 1)
        .max()
        .unwrap_or(0);
    let mut by_mesh: Vec<Vec<&scene::OpaqueTri>> = vec![Vec::new(); meshes];
    for t in &scene.triangles {
        by_mesh[t.mesh as usize].push(t);
    }
    let key = |p: Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    by_mesh
        .iter()
        .map(|tris| {
            if tris.is_empty() {
                return false;
            }
            let mut edges = std::collections::HashMap::with_capacity(3 * tris.len());
            for t in tris {
                for k in 0..3 {
                    *edges
                        .entry((key(t.p[k]), key(t.p[(k + 1) % 3])))
                        .or_insert(0u32) += 1;
                }
            }
            let closed = edges
                .iter()
                .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1));
            if !closed {
                return false;
            }
            let (mut volume, mut solid_angle) = (0.0f64, 0.0f64);
            for t in tris {
                let p = t.p.map(|x| x.as_dvec3());
                volume += p[0].dot(p[1].cross(p[2]));
                let [a, b, c] = p.map(|x| x - view.eye.as_dvec3());
                let (la, lb, lc) = (a.length(), b.length(), c.length());
                let num = a.dot(b.cross(c));
                let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
                solid_angle += 2.0 * num.atan2(den);
            }
            let winding = solid_angle / (4.0 * std::f64::consts::PI);
            let in_front = tris
                .iter()
                .all(|t| t.p.iter().all(|&x| view.to_view(x).z > view.near));
            volume > 0.0 && winding.abs() < 0.5 && in_front
        })
        .collect()
}

/// Card quads as triangles; a triangle with a corner behind the near plane
/// is dropped (cards are not clipped).
fn build_card_tris(scene: &Scene, view: &View) -> Vec<CardTri> {
    let c = &scene.cards;
    let mut out = Vec::with_capacity(2 * c.quad_count());
    for q in 0..c.quad_count() {
        for tri in [[0, 1, 2], [0, 2, 3]] {
            let idx = tri.map(|k| 4 * q + k);
            let v = idx.map(|i| view.to_view(c.corners[i]));
            if v.iter().any(|x| !(x.z > view.near)) {
                continue;
            }
            let p = v.map(|x| {
                let (a, b) = view.project(x);
                [a, b]
            });
            out.push(CardTri {
                p,
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

/// Tiles covered by a screen triangle's bounding box, or None when off screen.
fn tri_tile_range(p: &[[f32; 2]; 3], tiles_x: u32, tiles_y: u32) -> Option<(u32, u32, u32, u32)> {
    let (xs, ys) = (p.map(|q| q[0]), p.map(|q| q[1]));
    let x0 = xs[0].min(xs[1]).min(xs[2]);
    let x1 = xs[0].max(xs[1]).max(xs[2]);
    let y0 = ys[0].min(ys[1]).min(ys[2]);
    let y1 = ys[0].max(ys[1]).max(ys[2]);
    bbox_tiles(x0, x1, y0, y1, tiles_x, tiles_y)
}

/// Screen-space bounding box in tiles, or None when off screen.
fn tile_range(s: &Segment, tiles_x: u32, tiles_y: u32) -> Option<(u32, u32, u32, u32)> {
    let pad = s.pad();
    bbox_tiles(
        s.a[0].min(s.b[0]) - pad,
        s.a[0].max(s.b[0]) + pad,
        s.a[1].min(s.b[1]) - pad,
        s.a[1].max(s.b[1]) + pad,
        tiles_x,
        tiles_y,
    )
}

/// Tiles `(x0, y0, x1, y1)` (inclusive) overlapped by a pixel bounding box,
/// or None when it is off screen or not finite.
fn bbox_tiles(
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    tiles_x: u32,
    tiles_y: u32,
) -> Option<(u32, u32, u32, u32)> {
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return None;
    }
    let (w, h) = ((tiles_x * TILE) as f32, (tiles_y * TILE) as f32);
    if x1 < 0.0 || y1 < 0.0 || x0 >= w || y0 >= h {
        return None;
    }
    let tx0 = (x0.max(0.0) as u32) / TILE;
    let ty0 = (y0.max(0.0) as u32) / TILE;
    let tx1 = (x1.min(w - 1.0) as u32) / TILE;
    let ty1 = (y1.min(h - 1.0) as u32) / TILE;
    Some((tx0, ty0, tx1.min(tiles_x - 1), ty1.min(tiles_y - 1)))
}

/// Per tile, the indices of the primitives whose tile range covers it (in
/// primitive order, so every tile sees its primitives in scene order).
fn bin_to_tiles(
    ranges: impl Iterator<Item = Option<(u32, u32, u32, u32)>>,
    tiles_x: u32,
    tiles_y: u32,
) -> (Vec<Vec<u32>>, usize) {
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); (tiles_x * tiles_y) as usize];
    let mut binned = 0;
    for (i, r) in ranges.enumerate() {
        if let Some((x0, y0, x1, y1)) = r {
            binned += 1;
            for ty in y0..=y1 {
                for tx in x0..=x1 {
                    bins[(ty * tiles_x + tx) as usize].push(i as u32);
                }
            }
        }
    }
    (bins, binned)
}

/// The pixels of a row that a segment can cover: those whose centers lie
/// within `r` (the widest half-width plus the half-pixel filter) of the
/// segment's line, widened by 0.01 pixel against rounding. Conservative:
/// [`coverage`] still decides every pixel, so the image is the same as
/// visiting the whole bounding box.
struct RowSpan {
    a: [f32; 2],
    d: [f32; 2],
    /// `r·|d|`
    r_len: f32,
}

impl RowSpan {
    fn new(s: &Segment, r: f32) -> Self {
        let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
        Self {
            a: s.a,
            d,
            r_len: r * (d[0] * d[0] + d[1] * d[1]).sqrt(),
        }
    }

    /// Tile-local pixel range `[lo, hi]` within `[bx0, bx1]` of the row
    /// whose centers have y = `py`, in the tile starting at `x0`; None if empty.
    #[inline]
    fn pixels(&self, py: f32, x0: u32, bx0: u32, bx1: u32) -> Option<(u32, u32)> {
        // |(x − ax) dy − (py − ay) dx| ≤ r|d| bounds x when dy ≠ 0.
        if self.d[1].abs() < 1e-6 || !self.r_len.is_finite() {
            return Some((bx0, bx1));
        }
        let c = self.a[0] + (py - self.a[1]) * self.d[0] / self.d[1];
        let half = self.r_len / self.d[1].abs();
        // Pixel centers x0 + i + 0.5 within [c − half, c + half], widened by
        // 0.01 pixel against rounding (f32 coordinates below 2^14 pixels
        // carry errors below 1e-3 pixel): i from ⌈c − half − x0 − 0.51⌉ to
        // ⌊c + half − x0 − 0.49⌋. Truncation stands in for both (⌊⌋ on the
        // clamped, non-negative values: at most one extra pixel; the
        // baseline ISA has no rounding instruction, floor/ceil are calls).
        let lo = c - half - x0 as f32 - 0.51;
        let hi = c + half - x0 as f32 - 0.49;
        if !(lo.is_finite() && hi.is_finite()) {
            return Some((bx0, bx1));
        }
        if hi < 0.0 {
            return None;
        }
        let lo = (lo.clamp(0.0, 1e6) as u32).max(bx0);
        let hi = (hi.min(1e6) as i64).min(bx1 as i64);
        (hi >= lo as i64).then_some((lo, hi as u32))
    }
}

/// Coverage of pixel center `p` by segment `s`, and the screen parameter t.
#[inline]
fn coverage(s: &Segment, p: [f32; 2]) -> Option<(f32, f32)> {
    let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t_raw = if len2 > 0.0 {
        ((p[0] - s.a[0]) * d[0] + (p[1] - s.a[1]) * d[1]) / len2
    } else {
        0.0
    };
    // Butt joints: each pixel belongs to one segment of a polyline (no
    // double coverage at vertices); the strand's tip gets a rounded end.
    let inside = if s.last {
        t_raw >= 0.0
    } else {
        (0.0..1.0).contains(&t_raw)
    };
    if !inside && len2 > 0.0 {
        return None;
    }
    let t = t_raw.clamp(0.0, 1.0);
    let c = [s.a[0] + t * d[0], s.a[1] + t * d[1]];
    let dist = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt();
    let mut w = s.wa + (s.wb - s.wa) * t;
    let mut scale = 1.0;
    if w < 1.0 {
        // Sub-pixel strand: one pixel wide, alpha scaled by its width.
        scale = w.max(0.0);
        w = 1.0;
    }
    let cov = (0.5 * w + 0.5 - dist).clamp(0.0, 1.0) * scale;
    (cov > 0.0).then_some((cov, t))
}

/// Light-culling statistics gathered locally and added to the render's
/// counters once per batch ([`Shader::flush`]).
#[derive(Default, Clone, Copy)]
struct CullTally {
    count: u64,
    max: f32,
}

/// Everything hair shading needs, prepared once per render.
struct Shader<'a> {
    scene: &'a Scene,
    /// The scene's model, with what it cannot use disabled (see [`Shader::new`]).
    hair: HairShading,
    /// The environment variant of a KarisHair model (when there is an environment).
    env_model: Option<crate::fiber::karis::KarisHair<f32>>,
    shadows: &'a [Option<std::sync::Arc<ShadowMap>>],
    /// Upper bound of the hair BSDF's value over all directions (KarisHair;
    /// `None`: no light culling).
    f_max: Option<f32>,
    /// Radiance below which a light's bounded contribution is skipped.
    cull_threshold: f32,
    /// Light evaluations skipped, and the largest skipped bound (f32 bits).
    culled: std::sync::atomic::AtomicU64,
    culled_max_bits: std::sync::atomic::AtomicU32,
}

impl<'a> Shader<'a> {
    /// With KarisHair and Scatter = 0, the MS block adds exactly 0 under the
    /// renderer's default transmittance (global 1, local 0, visibility 1: it
    /// rescales the single scattering by 1 and adds a Kajiya-Kay term scaled
    /// by Scatter), so it is compiled out (`skip_unused`).
    ///
    /// Light culling (`cull_threshold` > 0, KarisHair): a light whose
    /// irradiance times the BSDF's upper bound is below the threshold at a
    /// shading point is not evaluated there (nor its shadow map read). Each
    /// skipped term is at most the threshold, so a pixel changes by at most
    /// `threshold × lights` (its fragments' weights sum to ≤ 1); the largest
    /// skipped bound is reported in the statistics.
    fn new(
        scene: &'a Scene,
        shadows: &'a [Option<std::sync::Arc<ShadowMap>>],
        skip_unused: bool,
        cull_threshold: f32,
    ) -> Self {
        let hair = match &scene.hair {
            HairShading::Karis(k) if skip_unused && k.scatter_is_zero() && k.components().ms => {
                let mut c = k.components();
                c.ms = false;
                HairShading::Karis(k.with_components(c))
            }
            other => other.clone(),
        };
        let env_model = match (&scene.environment, &hair) {
            (Some(_), HairShading::Karis(k)) => Some(k.environment_variant()),
            _ => None,
        };
        let f_max = match &hair {
            HairShading::Karis(k) if cull_threshold > 0.0 => Some(k.upper_bound()),
            _ => None,
        };
        Self {
            scene,
            hair,
            env_model,
            shadows,
            f_max,
            cull_threshold,
            culled: Default::default(),
            culled_max_bits: Default::default(),
        }
    }

    /// Whether [`Self::shade_batch`] and [`Self::shade_serial`] serve this
    /// model (KarisHair on the vector kernel).
    fn batches(&self) -> bool {
        matches!(&self.hair, HairShading::Karis(k) if !k.fast_asin())
    }

    /// [`Self::shade`] for many points at once, in parallel chunks of
    /// [`Self::shade_serial`] (`None` unless [`Self::batches`]).
    fn shade_batch(
        &self,
        points: &[Vec3],
        tangent: &(dyn Fn(usize) -> Vec3 + Sync),
        eye: Vec3,
    ) -> Option<Vec<Vec3>> {
        if !self.batches() {
            return None;
        }
        const CHUNK: usize = 4096;
        let mut out = vec![Vec3::ZERO; points.len()];
        pool().install(|| {
            out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, o)| {
                let range = c * CHUNK..c * CHUNK + o.len();
                let t: Vec<Vec3> = range.clone().map(tangent).collect();
                self.shade_serial(&points[range], &t, eye, o);
            })
        });
        Some(out)
    }

    /// [`Self::shade`] for `points` with `tangents`, on this thread, for
    /// KarisHair (requires [`Self::batches`]): per light, the directions,
    /// irradiance and shadow-map visibility per point, then one call of the
    /// vector kernel over all points; the environment likewise. Equal to
    /// `shade` up to the vector kernel's rounding.
    fn shade_serial(&self, points: &[Vec3], tangents: &[Vec3], eye: Vec3, out: &mut [Vec3]) {
        use crate::batch::KarisInputs;
        use crate::fiber::karis::simd::eval_range;
        let HairShading::Karis(k) = &self.hair else {
            unreachable!("shade_serial without a KarisHair model");
        };
        let n = points.len();
        let level = crate::simd::Level::detect();
        let t: Vec<f32> = tangents.iter().flat_map(|x| x.to_array()).collect();
        let v: Vec<f32> = points
            .iter()
            .flat_map(|p| (eye - *p).normalize_or_zero().to_array())
            .collect();
        out.fill(Vec3::ZERO);
        let mut tally = CullTally::default();
        let mut f = vec![0.0f32; 3 * n];
        let mut l = vec![0.0f32; 3 * n];
        let mut shadow = vec![0.0f32; n];
        let mut irradiance = vec![Vec3::ZERO; n];
        for (light, sm) in self.scene.lights.iter().zip(self.shadows) {
            // per point: direction, irradiance, visibility (0 where culled)
            for (i, p) in points.iter().enumerate() {
                let (li, e) = light.incident(*p);
                l[3 * i..3 * i + 3].copy_from_slice(&li.to_array());
                (irradiance[i], shadow[i]) = if self.culls(e, &mut tally) {
                    (Vec3::ZERO, 0.0)
                } else {
                    (e, sm.as_ref().map_or(1.0, |m| m.visibility(*p)))
                };
            }
            // The kernel runs on the points the light reaches (culled and
            // fully shadowed ones add nothing); lanes are independent, so
            // the values do not depend on which points share a batch.
            let active: Vec<usize> = (0..n).filter(|&i| shadow[i] > 0.0).collect();
            if active.is_empty() {
                continue;
            }
            let (la, va, ta, sa);
            let inp = if active.len() == n {
                KarisInputs {
                    shadow: &shadow,
                    ..KarisInputs::directions(&l, &v, &t)
                }
            } else {
                let pick3 = |a: &[f32]| -> Vec<f32> {
                    active
                        .iter()
                        .flat_map(|&i| [a[3 * i], a[3 * i + 1], a[3 * i + 2]])
                        .collect()
                };
                (la, va, ta) = (pick3(&l), pick3(&v), pick3(&t));
                sa = active.iter().map(|&i| shadow[i]).collect::<Vec<f32>>();
                KarisInputs {
                    shadow: &sa,
                    ..KarisInputs::directions(&la, &va, &ta)
                }
            };
            let fa = &mut f[..3 * active.len()];
            eval_range::<false>(k, &inp, 0, fa, level);
            for (j, &i) in active.iter().enumerate() {
                out[i] += Vec3::from_slice(&fa[3 * j..]) * irradiance[i] * shadow[i];
            }
        }
        self.flush(tally);
        if let (Some(env), Some(m)) = (&self.scene.environment, &self.env_model) {
            // L = the fake normal n = normalize(V − T(T·V)); π · SH(n)⁺ · f
            for i in 0..n {
                let (vi, ti) = (Vec3::from_slice(&v[3 * i..]), tangents[i]);
                let nn = (vi - ti * ti.dot(vi)).normalize_or_zero();
                l[3 * i..3 * i + 3].copy_from_slice(&nn.to_array());
                irradiance[i] = Vec3::from(sh9_eval(&env.sh, &nn.to_array())).max(Vec3::ZERO);
            }
            eval_range::<false>(m, &KarisInputs::directions(&l, &v, &t), 0, &mut f, level);
            for (i, o) in out.iter_mut().enumerate() {
                *o += Vec3::from_slice(&f[3 * i..]) * irradiance[i] * std::f32::consts::PI;
            }
        }
    }

    /// The light-culling threshold for opaque diffuse surfaces: the hair's
    /// when hair is culled (KarisHair), else 0 (off).
    fn diffuse_cull(&self) -> f32 {
        if self.f_max.is_some() {
            self.cull_threshold
        } else {
            0.0
        }
    }

    /// Whether light culling skips a light of irradiance `e` at a hair point
    /// (its bounded contribution is below the threshold); counts the skip
    /// and keeps the largest skipped bound in `tally` (see [`CullTally`]).
    #[inline]
    fn culls(&self, e: Vec3, tally: &mut CullTally) -> bool {
        let Some(f_max) = self.f_max else {
            return false;
        };
        let bound = f_max * e.max_element();
        if bound >= self.cull_threshold {
            return false;
        }
        tally.count += 1;
        tally.max = tally.max.max(bound.max(0.0));
        true
    }

    /// Adds a tally to the render's statistics (one atomic update per
    /// batch: per point, two threads contending for the counters made
    /// light culling slower than no culling).
    fn flush(&self, tally: CullTally) {
        use std::sync::atomic::Ordering::Relaxed;
        if tally.count > 0 {
            self.culled.fetch_add(tally.count, Relaxed);
            // non-negative floats order as their bits
            self.culled_max_bits.fetch_max(tally.max.to_bits(), Relaxed);
        }
    }

    /// Radiance scattered by hair at `p` with tangent `t` towards the eye `v`.
    fn shade(&self, p: Vec3, t: Vec3, v: Vec3) -> Vec3 {
        let mut out = Vec3::ZERO;
        let mut tally = CullTally::default();
        for (light, sm) in self.scene.lights.iter().zip(self.shadows) {
            let (l, e) = light.incident(p);
            if self.culls(e, &mut tally) {
                continue;
            }
            let vis = sm.as_ref().map_or(1.0, |m| m.visibility(p));
            if vis <= 0.0 {
                continue;
            }
            let f = match &self.hair {
                HairShading::Karis(k) => {
                    let tr = Transmittance {
                        shadow: vis,
                        ..Default::default()
                    };
                    Vec3::from(k.eval(&l.to_array(), &v.to_array(), &t.to_array(), &tr))
                }
                HairShading::ChiangFar(c) => {
                    // Mitsuba's convention: wi towards the viewer (its offset h is
                    // the one averaged across the fiber's visible width), wo towards
                    // the light.
                    let (wi, wo) = fiber_frame(t, v, l);
                    Vec3::from(c.eval_far(&wi, &wo))
                }
                HairShading::DEon(d) => {
                    Vec3::from(d.eval(&l.to_array(), &v.to_array(), &t.to_array()))
                }
            };
            out += f * e * vis;
        }
        self.flush(tally);
        if let (Some(env), Some(m)) = (&self.scene.environment, &self.env_model) {
            out += Vec3::from(m.dispatch(EnvOne { v, t, sh: &env.sh }));
        }
        out
    }
}

struct EnvOne<'a> {
    v: Vec3,
    t: Vec3,
    sh: &'a [[f32; 3]; 9],
}

impl crate::fiber::karis::LobeVisitor<f32> for EnvOne<'_> {
    type Out = [f32; 3];
    fn visit<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
        self,
        m: &crate::fiber::karis::KarisHair<f32>,
    ) -> [f32; 3] {
        m.env_lobes_static::<R, TT, TRT, MS>(&self.v.to_array(), &self.t.to_array(), self.sh)
    }
}

/// `(a, b)` in a fiber frame with y = tangent (far field: the normal's
/// rotation about y does not matter).
#[inline]
fn fiber_frame(t: Vec3, a: Vec3, b: Vec3) -> ([f32; 3], [f32; 3]) {
    let n = t.any_orthonormal_vector();
    let x = t.cross(n);
    let to = |w: Vec3| [w.dot(x), w.dot(t), w.dot(n)];
    (to(a), to(b))
}

/// Diffuse radiance of an opaque surface point. Light culling (`cull` > 0):
/// a light with `irradiance/π` below `cull` is skipped (albedo ≤ 1, so its
/// contribution is below `cull`).
fn shade_diffuse(
    scene: &Scene,
    shadows: &[Option<std::sync::Arc<ShadowMap>>],
    p: Vec3,
    n: Vec3,
    albedo: Vec3,
    cull: f32,
) -> Vec3 {
    let mut e_total = Vec3::ZERO;
    for (light, sm) in scene.lights.iter().zip(shadows) {
        let (l, e) = light.incident(p);
        let c = n.dot(l);
        if c <= 0.0 || e.max_element() * std::f32::consts::FRAC_1_PI < cull {
            continue;
        }
        let vis = sm
            .as_ref()
            .map_or(1.0, |m| m.visibility(p + n * 1e-4 * m.scale()));
        e_total += e * c * vis;
    }
    if let Some(env) = &scene.environment {
        // Irradiance of band-limited SH radiance: convolution with the
        // clamped cosine (Ramamoorthi & Hanrahan 2001): π, 2π/3, π/4.
        let a = [
            std::f32::consts::PI,
            2.0 * std::f32::consts::PI / 3.0,
            std::f32::consts::PI / 4.0,
        ];
        let band = [0, 1, 1, 1, 2, 2, 2, 2, 2];
        let sh: [[f32; 3]; 9] = std::array::from_fn(|k| env.sh[k].map(|c| c * a[band[k]]));
        e_total += Vec3::from(sh9_eval(&sh, &n.to_array())).max(Vec3::ZERO);
    }
    albedo * std::f32::consts::FRAC_1_PI * e_total
}

/// Per light: whether its shadow map can be skipped (`skip_unused`) because
/// light culling skips the light at every point of the scene's bounding
/// sphere, hair and opaque surfaces alike, so the map would never be read:
/// KarisHair, culling on, and the larger of the BSDF bound and 1/π (opaque
/// surfaces) times the largest irradiance inside the sphere below 0.99 × the
/// threshold (the margin covers f32 rounding of the per-point bounds).
fn lights_without_visible_effect(
    scene: &Scene,
    opts: &RenderOptions,
    center: Vec3,
    radius: f32,
) -> Vec<bool> {
    let f_max = match &scene.hair {
        HairShading::Karis(k) if opts.skip_unused && opts.light_cull_threshold > 0.0 => {
            k.upper_bound()
        }
        _ => return vec![false; scene.lights.len()],
    };
    let f_max = if scene.spheres.is_empty() && scene.triangles.is_empty() {
        f_max
    } else {
        f_max.max(std::f32::consts::FRAC_1_PI)
    };
    scene
        .lights
        .iter()
        .map(|l| {
            let e_max = match *l {
                scene::Light::Directional { intensity, .. } => intensity.max_element(),
                scene::Light::Point {
                    position,
                    intensity,
                    ..
                } => {
                    let gap = (position - center).length() - radius;
                    if gap > 0.0 {
                        intensity.max_element() / (gap * gap)
                    } else {
                        f32::INFINITY
                    }
                }
            };
            f_max * e_max < 0.99 * opts.light_cull_threshold
        })
        .collect()
}

/// Renders `scene`; returns the image and statistics.
pub fn render(scene: &Scene, opts: &RenderOptions) -> (Image, RenderStats) {
    let (done, cancel) = (AtomicUsize::new(0), AtomicBool::new(false));
    render_with_progress(scene, opts, &done, &cancel).expect("not cancelled")
}

/// Number of tiles a render of `scene` processes (the progress total).
pub fn tile_count(scene: &Scene) -> usize {
    (scene.camera.width.div_ceil(TILE) * scene.camera.height.div_ceil(TILE)) as usize
}

/// [`render`], counting finished tiles in `done` and stopping early (None)
/// once `cancel` is set.
pub fn render_with_progress(
    scene: &Scene,
    opts: &RenderOptions,
    done: &AtomicUsize,
    cancel: &AtomicBool,
) -> Option<(Image, RenderStats)> {
    let t0 = std::time::Instant::now();
    let ms = |t: std::time::Instant| t.elapsed().as_secs_f64() * 1e3;
    let (center, radius) = scene_bounds(scene);
    let view = View::new(
        &scene.camera,
        (center - scene.camera.position).length() + radius,
    );
    let (w, h) = (view.width, view.height);
    let world = segs_world(scene);
    let geometry = if opts.reuse_shadow_maps {
        shadow::geometry_hash(scene)
    } else {
        0
    };
    let unneeded = lights_without_visible_effect(scene, opts, center, radius);
    let built: Vec<(Option<std::sync::Arc<ShadowMap>>, bool)> = pool().install(|| {
        scene
            .lights
            .par_iter()
            .zip(&unneeded)
            .map(|(l, &skip)| {
                if skip {
                    (None, false)
                } else if opts.reuse_shadow_maps {
                    ShadowMap::build_cached(l, scene, &world, center, radius, opts, geometry)
                } else {
                    (
                        ShadowMap::build(l, scene, &world, center, radius, opts)
                            .map(std::sync::Arc::new),
                        false,
                    )
                }
            })
            .collect()
    });
    let shadow_maps_reused = built.iter().filter(|b| b.1).count();
    let shadow_maps_skipped = unneeded.iter().filter(|&&u| u).count();
    let shadows: Vec<Option<std::sync::Arc<ShadowMap>>> = built.into_iter().map(|b| b.0).collect();
    let shadow_ms = ms(t0);
    let t1 = std::time::Instant::now();
    let shader = Shader::new(scene, &shadows, opts.skip_unused, opts.light_cull_threshold);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let (mut segs, segment_count) =
        build_segments(scene, &view, (tiles_x, tiles_y), opts.frustum_culling);
    let mut vertices_shaded = 0;
    if opts.vertex_shading {
        let used = opts
            .frustum_culling
            .then(|| vertices_used(&segs, scene.strands.points.len()));
        vertices_shaded = used.as_ref().map_or(scene.strands.points.len(), |u| {
            u.iter().filter(|&&x| x).count()
        });
        let colors = shade_vertices(scene, &shader, view.eye, used.as_deref());
        color_segments(&mut segs, &colors);
    }
    let (bins, visible) = bin_to_tiles(
        segs.iter().map(|s| tile_range(s, tiles_x, tiles_y)),
        tiles_x,
        tiles_y,
    );
    let tris = build_card_tris(scene, &view);
    let (tri_bins, _) = bin_to_tiles(
        tris.iter().map(|t| tri_tile_range(&t.p, tiles_x, tiles_y)),
        tiles_x,
        tiles_y,
    );
    let cull = if opts.backface_culling {
        meshes_to_cull(scene, &view)
    } else {
        Vec::new()
    };
    let (solids, backfaces_culled) = build_solid_tris(scene, &view, &cull);
    let (solid_bins, _) = bin_to_tiles(
        solids
            .iter()
            .map(|t| tri_tile_range(&t.p, tiles_x, tiles_y)),
        tiles_x,
        tiles_y,
    );

    let setup_ms = ms(t1);
    let t2 = std::time::Instant::now();
    let results: Vec<(Vec<f32>, u64, u64, u64)> = pool().install(|| {
        bins.par_iter()
            .zip(tri_bins.par_iter())
            .enumerate()
            .map(|(ti, (bin, tri_bin))| {
                if cancel.load(Ordering::Relaxed) {
                    return (Vec::new(), 0, 0, 0);
                }
                let ctx = TileContext {
                    scene,
                    opts,
                    view: &view,
                    shadows: &shadows,
                    shader: &shader,
                    segs: &segs,
                    tris: &tris,
                    solids: &solids,
                    solid_bin: &solid_bins[ti],
                };
                let r = render_tile(&ctx, bin, tri_bin, ti as u32 % tiles_x, ti as u32 / tiles_x);
                done.fetch_add(1, Ordering::Relaxed);
                r
            })
            .collect()
    });
    if cancel.load(Ordering::Relaxed) {
        return None;
    }

    let mut data = vec![0.0f32; (w * h * 3) as usize];
    let mut stats = RenderStats {
        segments: segment_count,
        segments_visible: visible,
        vertices_shaded,
        backfaces_culled,
        shadow_ms,
        shadow_maps_reused,
        shadow_maps_skipped,
        setup_ms,
        tiles_ms: ms(t2),
        ..Default::default()
    };
    for (ti, (tile, frags, bad, culled)) in results.into_iter().enumerate() {
        stats.fragments += frags;
        stats.non_finite_pixels += bad;
        stats.culled_behind_opaque += culled;
        let (tx, ty) = (ti as u32 % tiles_x, ti as u32 / tiles_x);
        for j in 0..TILE {
            let y = ty * TILE + j;
            if y >= h {
                break;
            }
            for i in 0..TILE {
                let x = tx * TILE + i;
                if x >= w {
                    break;
                }
                let src = ((j * TILE + i) * 3) as usize;
                let dst = ((y * w + x) * 3) as usize;
                data[dst..dst + 3].copy_from_slice(&tile[src..src + 3]);
            }
        }
    }
    stats.lights_culled = shader.culled.load(Ordering::Relaxed);
    stats.light_cull_max_skipped = f32::from_bits(shader.culled_max_bits.load(Ordering::Relaxed));
    stats.total_ms = ms(t0);
    Some((
        Image {
            width: w,
            height: h,
            data,
        },
        stats,
    ))
}

/// World-space segments for shadow maps (all strands, unclipped).
fn segs_world(scene: &Scene) -> Vec<(Vec3, Vec3, f32, f32)> {
    let st = &scene.strands;
    let mut out = Vec::new();
    for s in 0..st.strand_count() {
        let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
        for i in i0..i1.saturating_sub(1) {
            out.push((st.points[i], st.points[i + 1], st.radii[i], st.radii[i + 1]));
        }
    }
    out
}

struct TileContext<'a> {
    scene: &'a Scene,
    opts: &'a RenderOptions,
    view: &'a View,
    shadows: &'a [Option<std::sync::Arc<ShadowMap>>],
    shader: &'a Shader<'a>,
    segs: &'a [Segment],
    tris: &'a [CardTri],
    solids: &'a [SolidTri],
    solid_bin: &'a [u32],
}

fn render_tile(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tri_bin: &[u32],
    tx: u32,
    ty: u32,
) -> (Vec<f32>, u64, u64, u64) {
    let (scene, opts, view, shadows, segs) = (ctx.scene, ctx.opts, ctx.view, ctx.shadows, ctx.segs);
    let n = (TILE * TILE) as usize;
    let (x0, y0) = (tx * TILE, ty * TILE);
    let (tw, th) = (TILE.min(view.width - x0), TILE.min(view.height - y0));

    // Opaque surface (nearest sphere) or background, per pixel.
    let mut opaque_depth = vec![f32::INFINITY; n];
    let mut base = vec![Vec3::ZERO; n];
    for j in 0..th {
        for i in 0..tw {
            let k = (j * TILE + i) as usize;
            let p = [(x0 + i) as f32 + 0.5, (y0 + j) as f32 + 0.5];
            let ray = view.ray(p[0], p[1]);
            // Background: the environment seen along the ray (clamped SH), else the constant.
            base[k] = match &scene.environment {
                Some(env) => Vec3::from(sh9_eval(&env.sh, &ray.to_array())).max(Vec3::ZERO),
                None => opts.background,
            };
            for s in &scene.spheres {
                if let Some(t) = ray_sphere(view.eye, ray, s.center, s.radius) {
                    let depth = t * ray.dot(view.forward);
                    if depth < opaque_depth[k] && depth > view.near {
                        opaque_depth[k] = depth;
                        let hit = view.eye + ray * t;
                        base[k] = shade_diffuse(
                            scene,
                            shadows,
                            hit,
                            (hit - s.center) / s.radius,
                            s.albedo,
                            ctx.shader.diffuse_cull(),
                        );
                    }
                }
            }
        }
    }

    // Fragments: each segment visits only the pixels of its bounding box, in
    // scene order (so every pixel sees its fragments in a fixed order).
    let mut layers = Layers::new(
        n,
        match opts.transparency {
            Transparency::Mlab(k) => Some(k),
            Transparency::Sorted => None,
        },
    );
    let mut frags = 0u64;
    // Per-pixel shading on the vector kernel: the tile's hair fragments are
    // collected (in the order they are produced), shaded in one batch, then
    // composited in that same order (MLAB depends on it).
    let deferred = !opts.vertex_shading && ctx.shader.batches();
    let mut pending = Pending::default();
    // Opaque mesh triangles: nearest depth and diffuse shading per pixel.
    for &si in ctx.solid_bin {
        let t = &ctx.solids[si as usize];
        let Some(tri) = Tri2::new(t.p) else { continue };
        let (bx0, bx1, by0, by1) = tri.bounds;
        let (bx0, bx1) = (
            (bx0 - x0 as i64).max(0),
            (bx1 - x0 as i64).min(tw as i64 - 1),
        );
        let (by0, by1) = (
            (by0 - y0 as i64).max(0),
            (by1 - y0 as i64).min(th as i64 - 1),
        );
        for j in by0..=by1 {
            for i in bx0..=bx1 {
                let k = (j as u32 * TILE + i as u32) as usize;
                let p = [(x0 as i64 + i) as f32 + 0.5, (y0 as i64 + j) as f32 + 0.5];
                let Some(b) = tri.barycentric(p) else {
                    continue;
                };
                let w = [b[0] / t.z[0], b[1] / t.z[1], b[2] / t.z[2]];
                let depth = 1.0 / (w[0] + w[1] + w[2]);
                if !(depth > view.near && depth < opaque_depth[k]) {
                    continue;
                }
                opaque_depth[k] = depth;
                let pw = (t.world[0] * w[0] + t.world[1] * w[1] + t.world[2] * w[2]) * depth;
                // Two-sided: the normal faces the camera.
                let n = if t.normal.dot(view.eye - pw) < 0.0 {
                    -t.normal
                } else {
                    t.normal
                };
                base[k] = shade_diffuse(scene, shadows, pw, n, t.albedo, ctx.shader.diffuse_cull());
            }
        }
    }

    // Opaque early-out: hair entirely behind the farthest opaque surface of a
    // fully covered tile cannot be seen (the sphere hides what is behind it).
    let tile_far_opaque = (0..th)
        .flat_map(|j| (0..tw).map(move |i| (j * TILE + i) as usize))
        .map(|k| opaque_depth[k])
        .fold(0.0f32, f32::max);
    let mut culled = 0u64;
    for &si in bin {
        let s = &segs[si as usize];
        if opts.opaque_culling && s.za.min(s.zb) >= tile_far_opaque {
            culled += 1;
            continue;
        }
        let pad = s.pad();
        let bx0 = ((s.a[0].min(s.b[0]) - pad).floor() as i64 - x0 as i64).max(0) as u32;
        let bx1 = ((s.a[0].max(s.b[0]) + pad).ceil() as i64 - x0 as i64).min(tw as i64 - 1);
        let by0 = ((s.a[1].min(s.b[1]) - pad).floor() as i64 - y0 as i64).max(0) as u32;
        let by1 = ((s.a[1].max(s.b[1]) + pad).ceil() as i64 - y0 as i64).min(th as i64 - 1);
        if bx1 < 0 || by1 < 0 {
            continue;
        }
        let tangent = (s.pb - s.pa).normalize_or_zero();
        let span = RowSpan::new(s, pad - 0.5);
        for j in by0..=by1 as u32 {
            let py = (y0 + j) as f32 + 0.5;
            let Some((lo, hi)) = span.pixels(py, x0, bx0, bx1 as u32) else {
                continue;
            };
            for i in lo..=hi {
                let k = (j * TILE + i) as usize;
                let p = [(x0 + i) as f32 + 0.5, py];
                let Some((cov, t)) = coverage(s, p) else {
                    continue;
                };
                // Perspective-correct depth and world position.
                let inv = (1.0 - t) / s.za + t / s.zb;
                let depth = 1.0 / inv;
                if !(depth > view.near && depth < opaque_depth[k]) {
                    continue;
                }
                let tw_ = (t / s.zb) / inv;
                let pw = s.pa + (s.pb - s.pa) * tw_;
                frags += 1;
                if deferred {
                    pending.push(k, depth, cov, pw, tangent);
                    continue;
                }
                let c = if opts.vertex_shading {
                    s.ca + (s.cb - s.ca) * tw_
                } else {
                    ctx.shader
                        .shade(pw, tangent, (view.eye - pw).normalize_or_zero())
                };
                layers.add(k, depth, c, cov);
            }
        }
    }

    // Card triangles: perspective-correct barycentrics, alpha from the texture.
    for &ti in tri_bin {
        let t = &ctx.tris[ti as usize];
        if opts.opaque_culling && t.z[0].min(t.z[1]).min(t.z[2]) >= tile_far_opaque {
            culled += 1;
            continue;
        }
        let Some(tri) = Tri2::new(t.p) else { continue };
        let (bx0, bx1, by0, by1) = tri.bounds;
        let (bx0, bx1) = (
            (bx0 - x0 as i64).max(0),
            (bx1 - x0 as i64).min(tw as i64 - 1),
        );
        let (by0, by1) = (
            (by0 - y0 as i64).max(0),
            (by1 - y0 as i64).min(th as i64 - 1),
        );
        let tex = &scene.cards.textures[t.tex as usize];
        for j in by0..=by1 {
            for i in bx0..=bx1 {
                let k = (j as u32 * TILE + i as u32) as usize;
                let p = [(x0 as i64 + i) as f32 + 0.5, (y0 as i64 + j) as f32 + 0.5];
                let Some(b) = tri.barycentric(p) else {
                    continue;
                };
                let w = [b[0] / t.z[0], b[1] / t.z[1], b[2] / t.z[2]];
                let inv = w[0] + w[1] + w[2];
                let depth = 1.0 / inv;
                if !(depth > view.near && depth < opaque_depth[k]) {
                    continue;
                }
                let u = (w[0] * t.uv[0][0] + w[1] * t.uv[1][0] + w[2] * t.uv[2][0]) * depth;
                let v = (w[0] * t.uv[0][1] + w[1] * t.uv[1][1] + w[2] * t.uv[2][1]) * depth;
                let alpha = tex.sample(u, v);
                if !(alpha > 0.0) {
                    continue;
                }
                let pw = (t.world[0] * w[0] + t.world[1] * w[1] + t.world[2] * w[2]) * depth;
                frags += 1;
                if deferred {
                    pending.push(k, depth, alpha, pw, t.tangent);
                    continue;
                }
                let view_dir = (view.eye - pw).normalize_or_zero();
                let c = ctx.shader.shade(pw, t.tangent, view_dir);
                layers.add(k, depth, c, alpha);
            }
        }
    }

    if deferred {
        let mut colors = vec![Vec3::ZERO; pending.k.len()];
        ctx.shader
            .shade_serial(&pending.p, &pending.t, view.eye, &mut colors);
        for (i, c) in colors.into_iter().enumerate() {
            layers.add(pending.k[i] as usize, pending.depth[i], c, pending.alpha[i]);
        }
    }

    let mut out = vec![0.0f32; n * 3];
    let mut bad = 0u64;
    for j in 0..th {
        for i in 0..tw {
            let k = (j * TILE + i) as usize;
            let col = layers.resolve(k, base[k]);
            if col.is_finite() {
                out[3 * k..3 * k + 3].copy_from_slice(&col.to_array());
            } else {
                bad += 1;
            }
        }
    }
    (out, frags, bad, culled)
}

/// Hair fragments of a tile awaiting shading: pixel, depth, coverage
/// (alpha), world position, tangent.
#[derive(Default)]
struct Pending {
    k: Vec<u32>,
    depth: Vec<f32>,
    alpha: Vec<f32>,
    p: Vec<Vec3>,
    t: Vec<Vec3>,
}

impl Pending {
    #[inline]
    fn push(&mut self, k: usize, depth: f32, alpha: f32, p: Vec3, t: Vec3) {
        self.k.push(k as u32);
        self.depth.push(depth);
        self.alpha.push(alpha);
        self.p.push(p);
        self.t.push(t);
    }
}

/// Nearest positive ray parameter of a ray-sphere hit.
#[inline]
pub fn ray_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<f32> {
    let oc = o - c;
    let b = oc.dot(d);
    let cc = oc.length_squared() - r * r;
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t0 = -b - s;
    let t1 = -b + s;
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 {
        None // camera inside the sphere: its inside is not drawn
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::scene::{Camera, Cards, Environment, Light, Strands};
    use super::*;
    use crate::fiber::karis::KarisParams;

    /// 1. Per-vertex shading on the vector kernel (one batch per light and
    ///    one for the environment) against the per-point scalar path, with
    ///    a shadowed directional light, a point light, an SH environment and
    ///    the MS block on: equal to 1e-4 relative + 1e-7 absolute (the
    ///    vector kernel's rounding; `fiber::karis::simd` test 1 bounds it
    ///    against f64). Shading a subset of the vertices (frustum culling)
    ///    gives the same bits for them.
    #[test]
    fn t01_batched_vertex_shading_matches_per_point_shading() {
        let mut points = Vec::new();
        let mut offsets = vec![0u32];
        for s in 0..40 {
            let a = s as f32 * 0.37;
            for k in 0..12 {
                let y = k as f32 * 0.08;
                points.push(Vec3::new(
                    a.cos() * (0.3 + 0.02 * k as f32),
                    y,
                    a.sin() * 0.3 + 0.01 * y * y,
                ));
            }
            offsets.push(points.len() as u32);
        }
        let mut sh = [[0.0f32; 3]; 9];
        sh[0] = [0.8, 0.8, 0.9];
        sh[2] = [0.3, 0.2, 0.1];
        sh[5] = [-0.2, 0.1, 0.0];
        let scene = Scene {
            camera: Camera {
                position: Vec3::new(0.0, 0.5, 3.0),
                target: Vec3::new(0.0, 0.5, 0.0),
                up: Vec3::Y,
                fov_y: 40.0,
                width: 64,
                height: 64,
            },
            lights: vec![
                Light::Directional {
                    direction: Vec3::new(0.5, 0.7, 0.5).normalize(),
                    intensity: Vec3::splat(3.0),
                    shadows: true,
                },
                Light::Point {
                    position: Vec3::new(-1.0, 1.0, 1.0),
                    intensity: Vec3::new(2.0, 1.5, 1.0),
                    shadows: false,
                },
            ],
            environment: Some(Environment { sh }),
            strands: Strands {
                radii: vec![0.004; points.len()],
                points,
                offsets,
            },
            cards: Cards::default(),
            spheres: Vec::new(),
            triangles: Vec::new(),
            hair: HairShading::Karis(
                KarisParams {
                    scatter: 0.4,
                    ..Default::default()
                }
                .build()
                .unwrap(),
            ),
        };
        let opts = RenderOptions::default();
        let (center, radius) = scene_bounds(&scene);
        let world = segs_world(&scene);
        let shadows: Vec<_> = scene
            .lights
            .iter()
            .map(|l| {
                ShadowMap::build(l, &scene, &world, center, radius, &opts).map(std::sync::Arc::new)
            })
            .collect();
        let shader = Shader::new(&scene, &shadows, true, 0.0);
        let eye = scene.camera.position;
        let batched = shade_vertices(&scene, &shader, eye, None);
        let st = &scene.strands;
        // A subset of the vertices shades to the same bits (each SIMD lane
        // depends on its own inputs only), and the rest to 0.
        let needed: Vec<bool> = (0..st.points.len()).map(|i| i % 3 != 1).collect();
        let subset = shade_vertices(&scene, &shader, eye, Some(&needed));
        for i in 0..st.points.len() {
            let want = if needed[i] { batched[i] } else { Vec3::ZERO };
            assert_eq!(subset[i], want, "vertex {i}");
        }
        let mut shadowed = 0;
        for s in 0..st.strand_count() {
            let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
            for i in i0..i1 {
                let (a, b) = (st.points[i.max(i0 + 1) - 1], st.points[(i + 1).min(i1 - 1)]);
                let p = st.points[i];
                let want = shader.shade(
                    p,
                    (b - a).normalize_or_zero(),
                    (eye - p).normalize_or_zero(),
                );
                let got = batched[i];
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() <= 1e-4 * want[c].abs() + 1e-7,
                        "vertex {i} channel {c}: {got} vs {want}"
                    );
                }
                shadowed += (shadows[0].as_ref().unwrap().visibility(p) < 1.0) as usize;
            }
        }
        assert!(shadowed > 0, "the test should exercise shadowed vertices");
    }

    /// 2. The row span of a segment holds every pixel its coverage reaches:
    ///    over 20 000 random segments (lengths 0 to 40 pixels, all
    ///    directions including axis-aligned, widths from sub-pixel to 8
    ///    pixels, strand tips and not, positions up to 4000 pixels), every
    ///    pixel of the padded bounding box with non-zero coverage lies in
    ///    its row's span.
    #[test]
    fn t02_row_span_holds_every_covered_pixel() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut rnd = move || {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545F4914F6CDD1D) >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut covered, mut visited) = (0u64, 0u64);
        for n in 0..20_000 {
            let origin = if n % 2 == 0 { 0.0 } else { 4000.0 * rnd() };
            let a = [origin + 64.0 * rnd(), origin + 64.0 * rnd()];
            let (len, ang) = (40.0 * rnd(), std::f32::consts::TAU * rnd());
            let ang = match n % 5 {
                0 => 0.0,
                1 => std::f32::consts::FRAC_PI_2,
                _ => ang,
            };
            let b = [a[0] + len * ang.cos(), a[1] + len * ang.sin()];
            let w = |u: f32| if u < 0.5 { 2.0 * u } else { 16.0 * (u - 0.5) };
            let s = Segment {
                a,
                b,
                za: 1.0,
                zb: 1.0,
                wa: w(rnd()),
                wb: w(rnd()),
                pa: Vec3::ZERO,
                pb: Vec3::ZERO,
                last: n % 3 == 0,
                i: 0,
                ta: 0.0,
                tb: 1.0,
                ca: Vec3::ZERO,
                cb: Vec3::ZERO,
            };
            let pad = s.pad();
            let span = RowSpan::new(&s, pad - 0.5);
            let x0 = ((a[0].min(b[0]) - pad).max(0.0) as u32 / TILE) * TILE;
            let y0 = (a[1].min(b[1]) - pad).max(0.0) as u32;
            let x1 = (a[0].max(b[0]) + pad) as u32;
            let y1 = (a[1].max(b[1]) + pad) as u32;
            for y in y0..=y1 {
                let py = y as f32 + 0.5;
                // The whole padded box as one wide "tile" starting at x0.
                let bx1 = x1 - x0;
                let r = span.pixels(py, x0, 0, bx1);
                for i in 0..=bx1 {
                    let p = [(x0 + i) as f32 + 0.5, py];
                    visited += 1;
                    if coverage(&s, p).is_some() {
                        covered += 1;
                        let (lo, hi) = r.unwrap_or_else(|| {
                            panic!("segment {n}: row {y} empty, pixel {i} covered")
                        });
                        assert!(
                            lo <= i && i <= hi,
                            "segment {n} {s:?}: row {y} span {lo}..={hi}, pixel {i} covered"
                        );
                    }
                }
            }
        }
        assert!(
            covered > 100_000 && visited > 2 * covered,
            "{covered} of {visited}"
        );
    }
}
