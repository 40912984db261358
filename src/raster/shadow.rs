//! Shadow maps for hair: per light, the depth of the first hair and of the
//! first opaque surface seen from the light; opaque occluders block fully,
//! and hair attenuates exponentially, filtered by PCF. Two hair models:
//!
//! - `Opacity`: opacity accumulated along the light (a deep
//!   opacity map): every strand crossing a texel adds its optical depth
//!   `−ln(1 − coverage)` (cards: `−ln(1 − alpha)`) to one of `SLABS` depth
//!   slabs behind the first hair; a receiver sees `exp(−Σ optical depth in
//!   front of it)`. Memory: `SLABS` floats per texel.
//! - `Exponential` (default, Karis 2016): `exp(−density · (z − z_first_hair))`.
//!
//! Directional lights use an orthographic map over the scene's bounding
//! sphere, point lights a perspective map from the light towards it.
//! This file builds a map; `lookup` reads it.

use super::coverage::{ray_sphere, Tri2};
use super::scene::{Light, RenderOptions, Scene};
use super::setup::{Bounds, WorldSegment};
use crate::math::{ceil, floor};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::AtomicBool;

mod cache;
mod lookup;
pub use cache::{clear_cache, geometry_hash, WordHash, CACHE_MAPS};

/// A built shadow map.
#[derive(Debug, Clone)]
pub struct ShadowMap {
    size: u32,
    hair: Vec<f32>,
    opaque: Vec<f32>,
    proj: LightProjection,
    density: f32,
    pcf: i32,
    bias: f32,
    scale: f32,
    model: ShadowModel,
    /// Optical depth per texel and slab (Opacity model), of the deposits
    /// behind the texel's first `LAYERS` fibers.
    slabs: Vec<f32>,
    /// The nearest `LAYERS` deposits per texel, sorted by depth (Opacity
    /// model).
    layers: Vec<Deposit>,
    slab_width: f32,
}

/// Depth slabs of the opacity model.
pub const SLABS: usize = 12;
/// Deposits kept exactly per texel (opacity model).
pub const LAYERS: usize = 4;

/// The strand of a card deposit, and of a receiver that is not on a strand.
pub const NO_STRAND: u32 = u32::MAX;

/// One fiber's optical depth in a texel, at its depth along the light.
#[derive(Debug, Clone, Copy)]
struct Deposit {
    depth: f32,
    tau: f32,
    strand: u32,
    /// The world segment of the strand that is nearest the light here.
    segment: u32,
}

impl Deposit {
    const EMPTY: Deposit = Deposit {
        depth: f32::INFINITY,
        tau: 0.0,
        strand: NO_STRAND,
        segment: 0,
    };
}
const SLAB_GROWTH: f32 = 2.0;

/// How hair attenuates light in shadow maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShadowModel {
    Opacity,
    Exponential,
    /// Opaque geometry only: hair's shadowing comes from the fiber density
    /// grid ([`super::density`]).
    Density,
    /// Opaque geometry only: hair's shadowing is ray traced through the
    /// strands ([`super::traced`]); exact and slow, a reference.
    Traced,
}

impl ShadowModel {
    /// Whether this model's maps hold hair (the others' hold opaque
    /// geometry alone).
    pub fn maps_hair(self) -> bool {
        matches!(self, ShadowModel::Opacity | ShadowModel::Exponential)
    }
}

/// The light's view: an origin (the eye of a point light) and basis, and
/// the projection.
#[derive(Debug, Clone, Copy)]
struct LightProjection {
    origin: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    kind: Projection,
}

#[derive(Debug, Clone, Copy)]
enum Projection {
    /// Orthographic over a square of half extent `half`.
    Ortho { half: f32 },
    /// Perspective with `tan_half` the tangent of the half field of view.
    Persp { tan_half: f32 },
}

impl LightProjection {
    /// (u, v) in [0, 1]² and depth along the light.
    #[inline]
    fn map(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let d = p - self.origin;
        match self.kind {
            Projection::Ortho { half } => Some((
                0.5 + 0.5 * d.dot(self.right) / half,
                0.5 - 0.5 * d.dot(self.up) / half,
                d.dot(self.forward),
            )),
            Projection::Persp { tan_half } => {
                let z = d.dot(self.forward);
                if z <= 0.0 {
                    return None;
                }
                Some((
                    0.5 + 0.5 * d.dot(self.right) / (z * tan_half),
                    0.5 - 0.5 * d.dot(self.up) / (z * tan_half),
                    z,
                ))
            }
        }
    }

    /// The ray (origin, unit direction) through map position (u, v).
    #[inline]
    fn ray(&self, u: f32, v: f32) -> (Vec3, Vec3) {
        match self.kind {
            Projection::Ortho { half } => (
                self.origin
                    + self.right * ((2.0 * u - 1.0) * half)
                    + self.up * ((1.0 - 2.0 * v) * half),
                self.forward,
            ),
            Projection::Persp { tan_half } => (
                self.origin,
                (self.forward
                    + self.right * ((2.0 * u - 1.0) * tan_half)
                    + self.up * ((1.0 - 2.0 * v) * tan_half))
                    .normalize(),
            ),
        }
    }
}

/// A render's cancel flag as the map's drawing polls it.
#[derive(Clone, Copy)]
struct Stop<'a>(Option<&'a AtomicBool>);

impl Stop<'_> {
    #[inline]
    fn now(&self) -> bool {
        self.0
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
    }
}

/// `n` copies of `v`, written in chunks between which `stop` is polled
/// (an 8192² opacity map fills 4 GB of layers: seconds); shorter once
/// stopped (the flag stays set, so the caller sees it and returns).
fn filled<T: Copy>(n: usize, v: T, stop: Stop) -> Vec<T> {
    const CHUNK: usize = 1 << 20;
    let mut out = Vec::with_capacity(n);
    while out.len() < n && !stop.now() {
        let k = (n - out.len()).min(CHUNK);
        out.extend(std::iter::repeat_n(v, k));
    }
    out
}

fn basis(forward: Vec3) -> (Vec3, Vec3) {
    let right = forward.any_orthonormal_vector();
    (right, forward.cross(right))
}

impl ShadowMap {
    /// The map for `light`, or None when it casts no shadows or `cancel`
    /// was set while it was drawn (polled between segments, quads,
    /// triangles and rows of texels).
    pub fn build(
        light: &Light,
        scene: &Scene,
        segments: &[WorldSegment],
        bounds: Bounds,
        opts: &RenderOptions,
        cancel: Option<&AtomicBool>,
    ) -> Option<Self> {
        let stop = Stop(cancel);
        let Bounds { center, radius } = bounds;
        let proj = match *light {
            Light::Directional {
                direction,
                shadows: true,
                ..
            } => {
                let forward = -direction.normalize_or(Vec3::Z);
                let (right, up) = basis(forward);
                LightProjection {
                    origin: center - forward * (2.0 * radius),
                    right,
                    up,
                    forward,
                    kind: Projection::Ortho { half: radius },
                }
            }
            Light::Point {
                position,
                shadows: true,
                ..
            } => {
                let to = center - position;
                let dist = to.length();
                let forward = to.normalize_or(Vec3::Z);
                let (right, up) = basis(forward);
                // Cover the bounding sphere (or everything, from inside it).
                let tan_half = if dist > radius * 1.01 {
                    radius / (dist * dist - radius * radius).sqrt()
                } else {
                    4.0
                };
                LightProjection {
                    origin: position,
                    right,
                    up,
                    forward,
                    kind: Projection::Persp { tan_half },
                }
            }
            _ => return None,
        };
        let n = opts.shadow_map_size.max(16);
        let texel = 2.0 * radius / n as f32;
        let texels = (n * n) as usize;
        let (hair, opaque) = (
            filled(texels, f32::INFINITY, stop),
            filled(texels, f32::INFINITY, stop),
        );
        if stop.now() {
            return None;
        }
        let mut m = ShadowMap {
            size: n,
            hair,
            opaque,
            proj,
            density: opts.shadow_density,
            pcf: opts.pcf_radius.max(0),
            bias: 2.0 * texel,
            scale: radius,
            model: opts.shadow_model,
            slabs: Vec::new(),
            layers: Vec::new(),
            slab_width: 0.5 * texel,
        };
        if !matches!(m.model, ShadowModel::Density | ShadowModel::Traced) {
            m.draw_hair(segments, stop);
            m.draw_cards(scene, false, stop);
        }
        if m.model == ShadowModel::Opacity {
            m.slabs = vec![0.0; texels * SLABS];
            m.layers = filled(texels * LAYERS, Deposit::EMPTY, stop);
            if stop.now() {
                return None;
            }
            m.accumulate_hair(segments, stop);
            m.draw_cards(scene, true, stop);
        }
        m.draw_spheres(scene, stop);
        m.draw_triangles(scene, stop);
        (!stop.now()).then_some(m)
    }

    /// Continuous slab position of a depth `d` ≥ 0 behind the first hair:
    /// slab k spans [w0 (g^k − 1)/(g − 1), w0 (g^{k+1} − 1)/(g − 1)).
    #[inline]
    fn slab_coord(&self, d: f32) -> f32 {
        let (w0, g) = (self.slab_width, SLAB_GROWTH);
        (1.0 + d.max(0.0) * (g - 1.0) / w0).ln() / g.ln()
    }

    /// The scene radius the map was built for (for offsets).
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// First-hair depth of the strands, drawn in parallel
    /// ([`Self::min_depth_in_parallel`]).
    fn draw_hair(&mut self, segments: &[WorldSegment], stop: Stop) {
        self.min_depth_in_parallel(segments.len(), |this, range, buf| {
            this.draw_hair_into(&segments[range], buf, stop)
        });
    }

    /// Draws `count` items into the first-hair depth in parallel: up to 8
    /// chunks of items, each drawn by `draw(self, chunk, buffer)` into its
    /// own buffer, merged by `min` (order-independent, so the map does not
    /// depend on the thread count).
    fn min_depth_in_parallel(
        &mut self,
        count: usize,
        draw: impl Fn(&Self, std::ops::Range<usize>, &mut [f32]) + Sync,
    ) {
        let parts = crate::threads::num_threads().clamp(1, 8);
        let per = count.div_ceil(parts).max(1);
        let texels = self.hair.len();
        let this = &*self;
        let bufs: Vec<Vec<f32>> = crate::threads::pool().install(|| {
            (0..count.div_ceil(per))
                .into_par_iter()
                .map(|k| {
                    let mut buf = vec![f32::INFINITY; texels];
                    draw(this, k * per..((k + 1) * per).min(count), &mut buf);
                    buf
                })
                .collect()
        });
        for buf in bufs {
            for (h, z) in self.hair.iter_mut().zip(buf) {
                if z < *h {
                    *h = z;
                }
            }
        }
    }

    fn draw_hair_into(&self, segments: &[WorldSegment], hair: &mut [f32], stop: Stop) {
        let n = self.size as f32;
        for (i, &WorldSegment { a, b, ra, rb, .. }) in segments.iter().enumerate() {
            if i % 64 == 0 && stop.now() {
                return;
            }
            let (Some(pa), Some(pb)) = (self.proj.map(a), self.proj.map(b)) else {
                continue;
            };
            let (ax, ay) = (pa.0 * n, pa.1 * n);
            let (bx, by) = (pb.0 * n, pb.1 * n);
            let steps = ((bx - ax).abs().max((by - ay).abs()).ceil() as usize)
                .clamp(1, 4 * self.size as usize);
            // Thick lines: every texel within max(half a texel, the radius) of the segment.
            let half_w = match self.proj.kind {
                Projection::Ortho { half } => 0.5 * (ra.max(rb)) / half * n,
                Projection::Persp { tan_half } => {
                    0.5 * ra.max(rb) / (pa.2.min(pb.2).max(1e-6) * tan_half) * n
                }
            }
            .max(0.5);
            let reach = half_w.ceil() as i32;
            for k in 0..=steps {
                let t = k as f32 / steps as f32;
                let (x, y, z) = (
                    ax + (bx - ax) * t,
                    ay + (by - ay) * t,
                    pa.2 + (pb.2 - pa.2) * t,
                );
                for dy in -reach..=reach {
                    for dx in -reach..=reach {
                        let (xi, yi) = (x as i32 + dx, y as i32 + dy);
                        if xi < 0 || yi < 0 || xi >= self.size as i32 || yi >= self.size as i32 {
                            continue;
                        }
                        let cx = xi as f32 + 0.5 - x;
                        let cy = yi as f32 + 0.5 - y;
                        if cx * cx + cy * cy > (half_w + 0.5).powi(2) {
                            continue;
                        }
                        let idx = (yi as u32 * self.size + xi as u32) as usize;
                        if z < hair[idx] {
                            hair[idx] = z;
                        }
                    }
                }
            }
        }
    }

    /// Cards: their texels with alpha above one half set the first-hair
    /// depth (`accumulate` false; in parallel, [`Self::min_depth_in_parallel`]),
    /// or add `−ln(1 − alpha)` to their slab.
    fn draw_cards(&mut self, scene: &Scene, accumulate: bool, stop: Stop) {
        let quads = scene.cards.quad_count();
        if quads == 0 {
            return;
        }
        if accumulate {
            let mut texels = Vec::new();
            self.card_texels(scene, 0..quads, stop, |i, z, alpha| {
                texels.push((i, z, alpha))
            });
            for (i, z, alpha) in texels {
                self.add_optical_depth(i, z, alpha, NO_STRAND, 0);
            }
            return;
        }
        self.min_depth_in_parallel(quads, |this, range, buf| {
            this.card_texels(scene, range, stop, |i, z, alpha| {
                if alpha >= 0.5 && z < buf[i] {
                    buf[i] = z;
                }
            })
        });
    }

    /// Calls `emit(texel, depth, alpha)` for every texel center covered by
    /// the quads `range`.
    fn card_texels(
        &self,
        scene: &Scene,
        range: std::ops::Range<usize>,
        stop: Stop,
        mut emit: impl FnMut(usize, f32, f32),
    ) {
        let c = &scene.cards;
        let n = self.size as f32;
        for q in range {
            if stop.now() {
                return;
            }
            for tri in [[0, 1, 2], [0, 2, 3]] {
                let idx = tri.map(|k| 4 * q + k);
                let m = idx.map(|i| self.proj.map(c.corners[i]));
                let Some(m) = m.iter().copied().collect::<Option<Vec<_>>>() else {
                    continue;
                };
                let Some(tri) = Tri2::new([0, 1, 2].map(|k| [m[k].0 * n, m[k].1 * n])) else {
                    continue;
                };
                let b = tri.bounds.local(0, 0, self.size, self.size);
                let (x0, x1, y0, y1) = (b.x0, b.x1, b.y0, b.y1);
                let tex = &c.textures[c.texture[q] as usize];
                for yi in y0..=y1 {
                    for xi in x0..=x1 {
                        let Some(b) = tri.barycentric([xi as f32 + 0.5, yi as f32 + 0.5]) else {
                            continue;
                        };
                        let uv = |k: usize| {
                            b[0] * c.uvs[idx[0]][k]
                                + b[1] * c.uvs[idx[1]][k]
                                + b[2] * c.uvs[idx[2]][k]
                        };
                        let alpha = tex.sample(uv(0), uv(1));
                        let z = b[0] * m[0].2 + b[1] * m[1].2 + b[2] * m[2].2;
                        emit((yi as u32 * self.size + xi as u32) as usize, z, alpha);
                    }
                }
            }
        }
    }

    #[inline]
    fn add_optical_depth(&mut self, texel: usize, z: f32, alpha: f32, strand: u32, segment: u32) {
        if !(alpha > 0.0) || !self.hair[texel].is_finite() {
            return;
        }
        let mut d = Deposit {
            depth: z,
            tau: -(1.0 - alpha.min(0.95)).ln(),
            strand,
            segment,
        };
        // Insert among the texel's nearest deposits; the deepest of them
        // (or this one) goes to the slabs.
        let layers = &mut self.layers[texel * LAYERS..(texel + 1) * LAYERS];
        for slot in layers.iter_mut() {
            if d.depth < slot.depth {
                std::mem::swap(slot, &mut d);
            }
        }
        if !d.depth.is_finite() {
            return;
        }
        let k = (self.slab_coord(d.depth - self.hair[texel]) as usize).min(SLABS - 1);
        self.slabs[texel * SLABS + k] += d.tau;
    }

    /// Strands' optical depth: each segment visits the texels of its
    /// bounding box once, with the same tent coverage as the screen
    /// rasterizer (strands thinner than a texel scale their coverage). A
    /// strand covers a texel once: where several of its segments reach the
    /// same texel (at joints, or along a strand running towards the light)
    /// the deposit takes the nearest depth and the largest coverage (a ray
    /// through the texel meets the fiber once).
    fn accumulate_hair(&mut self, segments: &[WorldSegment], stop: Stop) {
        let mut merged: std::collections::HashMap<usize, (f32, f32, u32)> = Default::default();
        let mut start = 0;
        while start < segments.len() {
            if stop.now() {
                return;
            }
            let strand = segments[start].strand;
            let end = start
                + segments[start..]
                    .iter()
                    .take_while(|s| s.strand == strand)
                    .count();
            merged.clear();
            for seg in &segments[start..end] {
                // The segment's index among its scene's world segments
                // (what a receiver's `Fiber::segment` holds; under a level
                // of detail the casters' own order differs).
                let index = seg.vertex - seg.strand;
                self.segment_texels(seg, |texel, z, cov| {
                    let e = merged.entry(texel).or_insert((z, cov, index));
                    if z < e.0 {
                        (e.0, e.2) = (z, index);
                    }
                    e.1 = e.1.max(cov);
                });
            }
            let mut texels: Vec<(usize, (f32, f32, u32))> = merged.drain().collect();
            texels.sort_unstable_by_key(|e| e.0);
            for (texel, (z, cov, segment)) in texels {
                self.add_optical_depth(texel, z, cov, strand, segment);
            }
            start = end;
        }
    }

    /// Calls `emit(texel, depth, coverage)` for every texel a segment covers.
    fn segment_texels(&self, seg: &WorldSegment, mut emit: impl FnMut(usize, f32, f32)) {
        let n = self.size as f32;
        let (Some(pa), Some(pb)) = (self.proj.map(seg.a), self.proj.map(seg.b)) else {
            return;
        };
        let (ax, ay, bx, by) = (pa.0 * n, pa.1 * n, pb.0 * n, pb.1 * n);
        let texels_per_unit = |z: f32| match self.proj.kind {
            Projection::Ortho { half } => 0.5 * n / half,
            Projection::Persp { tan_half } => 0.5 * n / (z.max(1e-6) * tan_half),
        };
        let (wa, wb) = (
            2.0 * seg.ra * texels_per_unit(pa.2),
            2.0 * seg.rb * texels_per_unit(pb.2),
        );
        let pad = 0.5 * wa.max(wb).max(1.0) + 1.0;
        let x0 = (floor(ax.min(bx) - pad).max(0.0)) as i64;
        let x1 = (ceil(ax.max(bx) + pad) as i64).min(self.size as i64 - 1);
        let y0 = (floor(ay.min(by) - pad).max(0.0)) as i64;
        let y1 = (ceil(ay.max(by) + pad) as i64).min(self.size as i64 - 1);
        let (dx, dy) = (bx - ax, by - ay);
        let len2 = dx * dx + dy * dy;
        for yi in y0..=y1 {
            for xi in x0..=x1 {
                let (px, py) = (xi as f32 + 0.5, yi as f32 + 0.5);
                let t = if len2 > 0.0 {
                    (((px - ax) * dx + (py - ay) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let dist = ((px - ax - t * dx).powi(2) + (py - ay - t * dy).powi(2)).sqrt();
                let mut w = wa + (wb - wa) * t;
                let mut scale = 1.0;
                if w < 1.0 {
                    scale = w.max(0.0);
                    w = 1.0;
                }
                let cov = (0.5 * w + 0.5 - dist).clamp(0.0, 1.0) * scale;
                if cov > 0.0 {
                    emit(
                        (yi as u32 * self.size + xi as u32) as usize,
                        pa.2 + (pb.2 - pa.2) * t,
                        cov,
                    );
                }
            }
        }
    }

    /// Opaque mesh triangles into the opaque depth.
    fn draw_triangles(&mut self, scene: &Scene, stop: Stop) {
        let n = self.size as f32;
        for t in &scene.triangles {
            if stop.now() {
                return;
            }
            let m = t.p.map(|c| self.proj.map(c));
            let Some(m) = m.iter().copied().collect::<Option<Vec<_>>>() else {
                continue;
            };
            let Some(tri) = Tri2::new([0, 1, 2].map(|k| [m[k].0 * n, m[k].1 * n])) else {
                continue;
            };
            let b = tri.bounds.local(0, 0, self.size, self.size);
            for yi in b.y0..=b.y1 {
                for xi in b.x0..=b.x1 {
                    let Some(b) = tri.barycentric([xi as f32 + 0.5, yi as f32 + 0.5]) else {
                        continue;
                    };
                    let z = b[0] * m[0].2 + b[1] * m[1].2 + b[2] * m[2].2;
                    let i = (yi as u32 * self.size + xi as u32) as usize;
                    if z < self.opaque[i] {
                        self.opaque[i] = z;
                    }
                }
            }
        }
    }

    fn draw_spheres(&mut self, scene: &Scene, stop: Stop) {
        if scene.spheres.is_empty() {
            return;
        }
        let n = self.size;
        for yi in 0..n {
            if stop.now() {
                return;
            }
            for xi in 0..n {
                let (u, v) = ((xi as f32 + 0.5) / n as f32, (yi as f32 + 0.5) / n as f32);
                let (o, d) = self.proj.ray(u, v);
                let mut best = f32::INFINITY;
                for s in &scene.spheres {
                    if let Some(t) = ray_sphere(o, d, s.center, s.radius) {
                        let p = o + d * t;
                        if let Some((_, _, z)) = self.proj.map(p) {
                            best = best.min(z);
                        }
                    }
                }
                self.opaque[(yi * n + xi) as usize] = best;
            }
        }
    }
}
