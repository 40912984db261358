//! One 16×16 tile, as a sequence of passes over the primitives binned to
//! it: the opaque pass (background, spheres, mesh triangles: nearest depth
//! and diffuse radiance per pixel), the strand pass and the card pass
//! (hair fragments with their coverage, depth-tested against the opaque
//! depth), the shading of the collected fragments, and the resolve (the
//! transparency layers composited over the opaque surface).

mod opaque;
mod pending;
mod resolve;

use opaque::Surface;
use pending::{Pending, VertexPending};

use super::bin::TILE;
use super::coverage::{coverage_at, stretch_param, triangle_pixels, RowSpan, Tri2};
use super::cull::{BehindHair, BehindOpaque};
use super::oit::Layers;
use super::samples::{surface_lead, unit, Claim, SampleBuffer, SamplePoints, StrandSamples};
use super::scene::{RenderOptions, Scene, Transparency};
use super::setup::{CardTri, Segment, SolidTri};
use super::shade::offset_line;
use super::shade::{Fiber, Shader, ShadowMaps, VertexColors};
use super::view::View;
use crate::lighting::sh9_eval;
use crate::math::{ceil, floor};
use glam::Vec3;

/// How many segments ahead of the one being drawn the strand pass fetches.
const PREFETCH_AHEAD: usize = 4;

/// What every tile of a render reads.
pub struct TileContext<'a> {
    pub scene: &'a Scene,
    pub opts: &'a RenderOptions,
    pub view: &'a View,
    pub shadows: &'a ShadowMaps,
    pub shader: &'a Shader<'a>,
    pub segs: &'a [Segment],
    pub cards: &'a [CardTri],
    pub solids: &'a [SolidTri],
    /// The background's radiance where it is the same along every ray
    /// (no environment, or a constant one); None: per pixel.
    pub uniform_background: Option<Vec3>,
    /// Per-vertex shading on demand (MLAB and sorted transparency): the
    /// vertices' radiance, shaded when a tile first needs it; None where
    /// the segments carry it (`Segment::ca`, `cb`) from before the tiles.
    pub vertex_colors: Option<&'a VertexColors<'a>>,
}

/// The background's radiance when no pixel's ray changes it: the constant
/// background without an environment, or an environment whose SH has only
/// the constant band (its value is then the same in every direction, bit
/// for bit: the other bands add zeros).
pub fn uniform_background(scene: &Scene, opts: &RenderOptions) -> Option<Vec3> {
    match &scene.environment {
        None => Some(opts.background),
        Some(env) if env.sh[1..].iter().all(|c| c.iter().all(|&x| x == 0.0)) => {
            Some(Vec3::from(sh9_eval(&env.sh, &[0.0, 0.0, 1.0])).max(Vec3::ZERO))
        }
        Some(_) => None,
    }
}

/// The primitives binned to one tile (indices, in scene order; strand
/// segments nearest first where the tile draws them so:
/// `RenderOptions::draws_nearest_first`).
pub struct TileBins<'a> {
    pub segs: &'a [u32],
    pub cards: &'a [u32],
    pub solids: &'a [u32],
}

/// A finished tile.
pub struct TileResult {
    /// RGB radiance of the tile's 16×16 pixels, row-major (pixels outside
    /// the image are 0).
    pub pixels: Vec<f32>,
    /// Hair fragments drawn.
    pub fragments: u64,
    /// Pixels whose radiance was not finite (written as 0).
    pub non_finite: u64,
    /// Segment or card-triangle visits skipped by opaque culling.
    pub culled: u64,
    /// Hair fragments and segment visits skipped by hair culling.
    pub hair_culled: u64,
}

impl TileResult {
    /// The result of a tile that was not rendered (cancelled).
    pub fn empty() -> Self {
        Self {
            pixels: Vec::new(),
            fragments: 0,
            non_finite: 0,
            culled: 0,
            hair_culled: 0,
        }
    }
}

/// A tile's buffers, kept by a worker from one tile to the next so that a
/// frame does not allocate (and first-touch) them once per tile; every
/// tile starts from them reset, so results do not depend on which tiles a
/// worker rendered before.
#[derive(Default)]
pub struct TileMemory {
    opaque_depth: Vec<f32>,
    surface: Vec<Option<Surface>>,
    layers: Option<Layers>,
    pending: Pending,
    hair: Option<BehindHair>,
    vertex_pending: VertexPending,
}

/// Renders tile `(tx, ty)` in the buffers of `mem`.
pub fn render_tile(
    ctx: &TileContext<'_>,
    bins: &TileBins<'_>,
    tx: u32,
    ty: u32,
    mem: &mut TileMemory,
) -> TileResult {
    let mut t = Tile::new(ctx, tx, ty, std::mem::take(mem));
    t.opaque_spheres();
    t.opaque_meshes(bins.solids);
    let behind = BehindOpaque::new(
        ctx.opts.opaque_culling,
        t.pixel_indices().map(|k| t.opaque_depth[k]),
    );
    t.start_samples();
    t.start_hair_culling();
    t.set_layer_depth_range(bins);
    t.strands(bins.segs, behind);
    t.add_vertex_shaded();
    t.cards(bins.cards, behind);
    t.shade_pending();
    let (result, memory) = t.resolve();
    *mem = memory;
    result
}

/// A tile in progress.
struct Tile<'a> {
    ctx: &'a TileContext<'a>,
    /// The tile's first pixel and its size (clipped to the image).
    x0: u32,
    y0: u32,
    tw: u32,
    th: u32,
    /// Nearest opaque depth and surface per pixel (None: the background).
    /// A surface is shaded only where the hair in front lets it be seen
    /// ([`Self::base`]).
    opaque_depth: Vec<f32>,
    surface: Vec<Option<Surface>>,
    layers: Layers,
    /// Coverage samples (transparency `coverage`): the points and the
    /// nearest fragment per sample; fragments are then collected in
    /// `pending` (ids are their indices there) and only those owning a
    /// sample are shaded.
    samples: Option<(SamplePoints, SampleBuffer)>,
    /// Per-pixel shading on the vector kernel: the tile's hair fragments are
    /// collected (in the order they are produced), shaded in one batch, then
    /// composited in that same order (MLAB depends on it).
    deferred: bool,
    pending: Pending,
    /// Strand fragments awaiting their vertices' radiance (on-demand
    /// per-vertex shading: `TileContext::vertex_colors`).
    vertex_pending: VertexPending,
    /// Hair culling (MLAB and sorted transparency; see [`BehindHair`]).
    hair: Option<BehindHair>,
    /// The culling state of an earlier tile, to be reset and reused.
    spare_hair: Option<BehindHair>,
    fragments: u64,
    culled: u64,
    /// Fragments and segment visits skipped by hair culling.
    hair_culled: u64,
}

impl<'a> Tile<'a> {
    fn new(ctx: &'a TileContext<'a>, tx: u32, ty: u32, mut mem: TileMemory) -> Self {
        let n = (TILE * TILE) as usize;
        let (x0, y0) = (tx * TILE, ty * TILE);
        mem.opaque_depth.clear();
        mem.opaque_depth.resize(n, f32::INFINITY);
        mem.surface.clear();
        mem.surface.resize(n, None);
        let k = match ctx.opts.transparency {
            Transparency::Mlab(k) => Some(k),
            Transparency::Sorted | Transparency::Coverage(_) => None,
        };
        let layers = match mem.layers.take() {
            Some(mut l) => {
                if !l.reset(n, k, ctx.opts.layer_format) {
                    l = Layers::new(n, k, ctx.opts.layer_format);
                }
                l
            }
            None => Layers::new(n, k, ctx.opts.layer_format),
        };
        mem.pending.clear();
        mem.vertex_pending.clear();
        Self {
            ctx,
            x0,
            y0,
            tw: TILE.min(ctx.view.width - x0),
            th: TILE.min(ctx.view.height - y0),
            opaque_depth: mem.opaque_depth,
            surface: mem.surface,
            layers,
            samples: None,
            deferred: ctx.shader.batches(),
            pending: mem.pending,
            vertex_pending: mem.vertex_pending,
            hair: None,
            spare_hair: mem.hair,
            fragments: 0,
            culled: 0,
            hair_culled: 0,
        }
    }

    /// Hair culling, once the opaque depth is known (on when the cutoff is
    /// positive, except with coverage samples, whose hair is opaque).
    /// Packed MLAB layers store depth within the range of the tile's hair:
    /// its segments' ends widened by their radii, and its card triangles.
    fn set_layer_depth_range(&mut self, bins: &TileBins<'_>) {
        if !matches!(self.layers, Layers::Packed(_)) {
            return;
        }
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for &si in bins.segs {
            let s = &self.ctx.segs[si as usize];
            lo = lo.min(s.za - s.ra).min(s.zb - s.rb);
            hi = hi.max(s.za + s.ra).max(s.zb + s.rb);
        }
        for &ci in bins.cards {
            for &z in &self.ctx.cards[ci as usize].z {
                lo = lo.min(z);
                hi = hi.max(z);
            }
        }
        if lo <= hi {
            self.layers.set_depth_range(lo, hi);
        }
    }

    fn start_hair_culling(&mut self) {
        let cutoff = self.ctx.opts.hair_cull_transmittance;
        if cutoff > 0.0 && self.samples.is_none() {
            let (tw, th) = (self.tw as usize, self.th as usize);
            let mut h = self.spare_hair.take().unwrap_or_default();
            h.reset(cutoff, tw, th, TILE as usize, &self.opaque_depth);
            self.hair = Some(h);
        }
    }

    /// Whether hair culling hides a fragment at pixel `k`, `depth` (counted).
    #[inline]
    fn hidden_by_hair(&mut self, k: usize, depth: f32) -> bool {
        let hidden = self.hair.as_ref().is_some_and(|h| h.hides(k, depth));
        self.hair_culled += hidden as u64;
        hidden
    }

    /// Whether hair culling hides every fragment at pixel `k` no nearer
    /// than `z_lo`, by hair (counted) or by the opaque surface.
    #[inline]
    fn hidden_before_depth(&mut self, k: usize, z_lo: f32) -> bool {
        let Some(h) = &self.hair else {
            return false;
        };
        if !h.hides(k, z_lo) {
            return false;
        }
        self.hair_culled += (h.hidden_depth(k) < self.opaque_depth[k]) as u64;
        true
    }

    /// Tile-local indices of the pixels inside the image.
    fn pixel_indices(&self) -> impl Iterator<Item = usize> {
        let tw = self.tw;
        (0..self.th).flat_map(move |j| (0..tw).map(move |i| (j * TILE + i) as usize))
    }

    /// Centre of tile-local pixel (i, j) in image coordinates.
    #[inline]
    fn center(&self, i: i64, j: i64) -> [f32; 2] {
        [
            (self.x0 as i64 + i) as f32 + 0.5,
            (self.y0 as i64 + j) as f32 + 0.5,
        ]
    }

    /// The sample buffer, once the opaque depth is known (coverage mode).
    fn start_samples(&mut self) {
        if let Transparency::Coverage(n) = self.ctx.opts.transparency {
            let pts = SamplePoints::lazy(n, self.x0, self.y0);
            self.samples = Some((pts, SampleBuffer::new(n, &self.opaque_depth)));
        }
    }

    /// Whether a fragment none of whose samples lies nearer than `depth_lo`
    /// could take one of pixel `k`'s samples (coverage mode; see
    /// [`SampleBuffer::may_take`]).
    #[inline]
    fn may_take(&self, k: usize, depth_lo: f32) -> bool {
        self.samples
            .as_ref()
            .is_some_and(|(_, buf)| buf.may_take(k, depth_lo))
    }

    /// The farthest sample depth of the tile's pixels inside the image
    /// (coverage mode; infinite without samples).
    fn farthest_sample(&self) -> f32 {
        match &self.samples {
            Some((_, buf)) => self
                .pixel_indices()
                .map(|k| buf.farthest(k))
                .fold(f32::NEG_INFINITY, f32::max),
            None => f32::INFINITY,
        }
    }

    /// A hair fragment at tile pixel `k` over its samples (coverage mode;
    /// `depth`, the pixel centre's, is kept for the fragment): `cover`
    /// takes the samples where it lies nearest into the buffer, given the
    /// pixel's points and the fragment's id, and says whether it took any;
    /// the fragment is collected if so.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn sampled_fragment(
        &mut self,
        k: usize,
        depth: f32,
        p: Vec3,
        t: Vec3,
        fiber: Fiber,
        color: Option<Vec3>,
        line: [f32; 4],
        cover: impl FnOnce(&mut SampleBuffer, &[[f32; 2]], u32) -> bool,
    ) {
        let Some((pts, buf)) = &mut self.samples else {
            return;
        };
        let id = self.pending.k.len() as u32;
        if cover(buf, pts.pixel_mut(k), id) {
            self.fragments += 1;
            self.pending.push(k, depth, 1.0, p, t, fiber);
            // NaN: not shaded yet (a card, or per-fragment shading)
            self.pending.color.push(color.unwrap_or(Vec3::NAN));
            self.pending.line.push(line);
        }
    }

    /// A hair fragment at tile pixel `k`: shaded now, or collected for the
    /// batch (`deferred`); `color` is the interpolated per-vertex radiance
    /// when there is one.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn hair_fragment(
        &mut self,
        k: usize,
        depth: f32,
        alpha: f32,
        p: Vec3,
        t: Vec3,
        fiber: Fiber,
        color: Option<Vec3>,
    ) {
        self.fragments += 1;
        if let Some(h) = &mut self.hair {
            h.add(k, depth, alpha);
        }
        // A fragment with its per-vertex radiance goes straight to the
        // layers while none waits for the batch (strands come before
        // cards, so every strand fragment does under per-vertex shading):
        // the layers see the same order.
        if self.deferred && !(color.is_some() && self.pending.k.is_empty()) {
            // shaded in the batch unless it carries its per-vertex radiance
            self.pending.push(k, depth, alpha, p, t, fiber);
            self.pending.color.push(color.unwrap_or(Vec3::NAN));
            return;
        }
        let c = color.unwrap_or_else(|| {
            self.ctx
                .shader
                .shade(p, t, (self.ctx.view.eye - p).normalize_or_zero(), fiber)
        });
        self.layers.add(k, depth, c, alpha);
    }

    /// A strand fragment whose radiance is interpolated between the vertex
    /// radiance of segment `si` at `tw` (on-demand per-vertex shading): its
    /// coverage counts for hair culling now, and it goes to the layers in
    /// [`Self::add_vertex_shaded`], once its vertices are shaded.
    #[inline]
    fn vertex_fragment(&mut self, k: usize, depth: f32, alpha: f32, si: u32, tw: f32) {
        self.fragments += 1;
        if let Some(h) = &mut self.hair {
            h.add(k, depth, alpha);
        }
        self.vertex_pending.push(k, depth, alpha, si, tw);
    }

    /// Strand segments: every pixel of each segment's row spans, with
    /// perspective-correct depth and world position, in scene order (so
    /// every pixel sees its fragments in a fixed order).
    fn strands(&mut self, bin: &[u32], behind: BehindOpaque) {
        let (view, opts) = (self.ctx.view, self.ctx.opts);
        let (x0, y0, tw, th) = (self.x0, self.y0, self.tw, self.th);
        let sampled = self.samples.is_some();
        let near = self.ctx.shader.near_field();
        let on_demand = self.ctx.vertex_colors.is_some();
        debug_assert!(
            !(on_demand && sampled),
            "on-demand vertex colours without samples only"
        );
        // Coverage samples: pixels whose samples all lie nearer than a
        // fragment are skipped before it is set up (exact: it would take
        // none), most of them when the nearest hair comes first.
        let skip = sampled && opts.nearest_first;
        // With hair culling or that skip, front to back (nearest depth,
        // then scene order; the samples' owners do not depend on the order:
        // SampleBuffer): the bins list them so
        // (`RenderOptions::draws_nearest_first`).
        debug_assert_eq!(self.hair.is_some() || skip, opts.draws_nearest_first());
        debug_assert!(
            !opts.draws_nearest_first()
                || bin.windows(2).all(|w| {
                    let z = |si: u32| {
                        let s = &self.ctx.segs[si as usize];
                        s.za.min(s.zb)
                    };
                    z(w[0]).total_cmp(&z(w[1])).then(w[0].cmp(&w[1])).is_lt()
                })
        );
        // With the skip: the farthest sample of the tile's pixels, renewed
        // every few segments, and the widest lead of its segments; a
        // segment nearest no nearer than that, less that lead, takes no
        // sample, nor does any after it (they lie farther).
        let lead_bound = if skip {
            let segs = self.ctx.segs;
            17.0 * bin
                .iter()
                .map(|&si| segs[si as usize].ra.max(segs[si as usize].rb))
                .fold(0.0f32, f32::max)
        } else {
            0.0
        };
        let mut tile_far = f32::INFINITY;
        for (n, &si) in bin.iter().enumerate() {
            // The bin lists segments by depth, at scattered addresses: the
            // one a few ahead is fetched while this one is drawn.
            if let Some(&ahead) = bin.get(n + PREFETCH_AHEAD) {
                crate::simd::prefetch(&self.ctx.segs[ahead as usize]);
            }
            let s = &self.ctx.segs[si as usize];
            if skip {
                if n % 8 == 0 {
                    tile_far = self.farthest_sample();
                }
                if s.za.min(s.zb) - lead_bound >= tile_far {
                    break;
                }
            }
            if behind.hides(s.za.min(s.zb)) {
                self.culled += 1;
                continue;
            }
            if self
                .hair
                .as_ref()
                .is_some_and(|h| h.hides_tile(s.za.min(s.zb)))
            {
                // this one and every later one (they lie farther)
                self.hair_culled += (bin.len() - n) as u64;
                break;
            }
            let pad = s.pad();
            let bx0 = (floor(s.a[0].min(s.b[0]) - pad) as i64 - x0 as i64).max(0) as u32;
            let bx1 = (ceil(s.a[0].max(s.b[0]) + pad) as i64 - x0 as i64).min(tw as i64 - 1);
            let by0 = (floor(s.a[1].min(s.b[1]) - pad) as i64 - y0 as i64).max(0) as u32;
            let by1 = (ceil(s.a[1].max(s.b[1]) + pad) as i64 - y0 as i64).min(th as i64 - 1);
            if bx1 < 0 || by1 < 0 {
                continue;
            }
            let tangent = (s.pb - s.pa).normalize_or_zero();
            let span = RowSpan::new(s, pad - 0.5);
            let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let inv_len2 = if len2 > 0.0 { 1.0 / len2 } else { 0.0 };
            let z_min = s.za.min(s.zb);
            // surface_lead's bound: 1/sin α ≤ 16 and view depth ≤ distance,
            // so the lead is at most 16 radii (17: room for rounding)
            let lead_max = 17.0 * s.ra.max(s.rb);
            // Hair culling: a pixel hidden nearer than the segment's nearest
            // depth (its perspective-correct depth, rounded, lies within a
            // few ulps above it: 1e-6 relative is room for them) is skipped
            // before its depth is computed (exact: the depth test or
            // `hidden_by_hair` below would skip it).
            let z_hidden_lo = z_min * (1.0 - 1e-6);
            for j in by0..=by1 as u32 {
                if self
                    .hair
                    .as_ref()
                    .is_some_and(|h| h.hides_row(j as usize, z_min))
                {
                    continue;
                }
                let py = (y0 + j) as f32 + 0.5;
                let Some((lo, hi)) = span.pixels(py, x0, bx0, bx1 as u32) else {
                    continue;
                };
                for i in lo..=hi {
                    let k = (j * TILE + i) as usize;
                    if self.hidden_before_depth(k, z_hidden_lo) {
                        continue;
                    }
                    let pc = [(x0 + i) as f32 + 0.5, py];
                    // The parameter of the centre line's point nearest the
                    // pixel centre: clamped (coverage samples), or on this
                    // segment's stretch of the strand (analytic coverage).
                    let t = if sampled {
                        let t_raw = ((pc[0] - s.a[0]) * d[0] + (pc[1] - s.a[1]) * d[1]) * inv_len2;
                        t_raw.clamp(0.0, 1.0)
                    } else {
                        match stretch_param(s, pc) {
                            Some(t) => t,
                            None => continue,
                        }
                    };
                    // Perspective-correct depth; depth tests before coverage.
                    let inv = (1.0 - t) / s.za + t / s.zb;
                    let depth = 1.0 / inv;
                    if !(depth > view.near && depth < self.opaque_depth[k]) {
                        continue;
                    }
                    if self.hidden_by_hair(k, depth) {
                        continue;
                    }
                    // Coverage samples: no sample of this pixel lies nearer
                    // than the centre's depth less the change over a pixel
                    // and a half along the segment, less the lead (below;
                    // at most `lead_max`). A pixel whose samples all lie
                    // nearer takes none of them: skipped before the lead.
                    let z_lo = if sampled {
                        (depth - 1.5 * (s.zb - s.za).abs() * inv_len2.sqrt()).max(z_min)
                    } else {
                        f32::NAN
                    };
                    if skip && !self.may_take(k, z_lo - lead_max) {
                        continue;
                    }
                    let cov = if sampled { 0.0 } else { coverage_at(s, pc, t) };
                    if !sampled && !(cov > 0.0) {
                        continue;
                    }
                    let tw_ = (t / s.zb) / inv;
                    let pw = s.pa + (s.pb - s.pa) * tw_;
                    let color =
                        (opts.vertex_shading && !on_demand).then(|| s.ca + (s.cb - s.ca) * tw_);
                    let fiber = Fiber {
                        radius: s.ra + (s.rb - s.ra) * tw_,
                        strand: s.strand,
                        segment: s.i - s.strand,
                    };
                    if sampled {
                        let lead = surface_lead(fiber.radius, tangent, pw, view.eye, depth);
                        let lo = z_lo - lead;
                        if skip && !self.may_take(k, lo) {
                            continue;
                        }
                        let line = if near {
                            offset_line(view, s, t, pw, tangent, fiber.radius)
                        } else {
                            [f32::NAN; 4]
                        };
                        let seg = StrandSamples::new(s, d, inv_len2, lead);
                        self.sampled_fragment(
                            k,
                            depth,
                            pw,
                            tangent,
                            fiber,
                            color,
                            line,
                            |buf, pix, id| {
                                let c = Claim {
                                    id,
                                    key: si,
                                    depth_lo: lo,
                                };
                                buf.cover_strand(k, c, pix, &seg)
                            },
                        );
                    } else if on_demand {
                        self.vertex_fragment(k, depth, cov, si, tw_);
                    } else {
                        self.hair_fragment(k, depth, cov, pw, tangent, fiber, color);
                    }
                }
            }
        }
    }

    /// Card triangles: perspective-correct barycentrics, alpha from the
    /// card's texture (cards are shaded per pixel in every mode).
    fn cards(&mut self, bin: &[u32], behind: BehindOpaque) {
        let (scene, view) = (self.ctx.scene, self.ctx.view);
        for &ti in bin {
            let t = &self.ctx.cards[ti as usize];
            if behind.hides(t.z[0].min(t.z[1]).min(t.z[2])) {
                self.culled += 1;
                continue;
            }
            let Some(tri) = Tri2::new(t.p) else { continue };
            let b = tri.bounds.local(self.x0, self.y0, self.tw, self.th);
            let tex = &scene.cards.textures[t.tex as usize];
            for (k, w, depth) in triangle_pixels(&tri, &t.z, b, self.x0, self.y0) {
                if !(depth > view.near && depth < self.opaque_depth[k]) {
                    continue;
                }
                let u = (w[0] * t.uv[0][0] + w[1] * t.uv[1][0] + w[2] * t.uv[2][0]) * depth;
                let v = (w[0] * t.uv[0][1] + w[1] * t.uv[1][1] + w[2] * t.uv[2][1]) * depth;
                let alpha = tex.sample(u, v);
                if !(alpha > 0.0) || self.hidden_by_hair(k, depth) {
                    continue;
                }
                let pw = (t.world[0] * w[0] + t.world[1] * w[1] + t.world[2] * w[2]) * depth;
                if self.samples.is_some() {
                    // Alpha to coverage: a sample is covered when a hash of
                    // (triangle, pixel, sample) falls below alpha, so
                    // overlapping cards cover independently.
                    let (gx, gy) = (self.x0 + (k as u32 % TILE), self.y0 + (k as u32 / TILE));
                    let seed = ti.wrapping_mul(0x2C1B_3C6D)
                        ^ gx.wrapping_mul(0x297A_2D39)
                        ^ gy.wrapping_mul(0x9E37_79B1);
                    let mut s = 0u32;
                    let no_line = [f32::NAN; 4];
                    self.sampled_fragment(
                        k,
                        depth,
                        pw,
                        t.tangent,
                        Fiber::NONE,
                        None,
                        no_line,
                        |buf, _, id| {
                            // (cards come after every strand, in scene
                            // order: at equal depth the first drawn keeps
                            // a sample)
                            let c = Claim {
                                id,
                                key: u32::MAX,
                                depth_lo: depth,
                            };
                            buf.cover(k, c, |_| {
                                s += 1;
                                (unit(seed.wrapping_add(s.wrapping_mul(0x6A09_E667))) < alpha)
                                    .then_some(depth)
                            })
                        },
                    );
                } else {
                    self.hair_fragment(k, depth, alpha, pw, t.tangent, Fiber::NONE, None);
                }
            }
        }
    }
}
