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

use super::coverage::{ray_sphere, Tri2};
use super::scene::{Light, RenderOptions, Scene};
use super::setup::{Bounds, WorldSegment};
use glam::Vec3;
use rayon::prelude::*;

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
    /// Optical depth per texel and slab (Opacity model).
    slabs: Vec<f32>,
    slab_width: f32,
}

/// Depth slabs of the opacity model.
pub const SLABS: usize = 8;

/// How hair attenuates light in shadow maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShadowModel {
    Opacity,
    Exponential,
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

fn basis(forward: Vec3) -> (Vec3, Vec3) {
    let right = forward.any_orthonormal_vector();
    (right, forward.cross(right))
}

impl ShadowMap {
    /// The map for `light`, or None when it casts no shadows.
    pub fn build(
        light: &Light,
        scene: &Scene,
        segments: &[WorldSegment],
        bounds: Bounds,
        opts: &RenderOptions,
    ) -> Option<Self> {
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
        let mut m = ShadowMap {
            size: n,
            hair: vec![f32::INFINITY; (n * n) as usize],
            opaque: vec![f32::INFINITY; (n * n) as usize],
            proj,
            density: opts.shadow_density,
            pcf: opts.pcf_radius.max(0),
            bias: 2.0 * texel,
            scale: radius,
            model: opts.shadow_model,
            slabs: Vec::new(),
            slab_width: 2.0 * radius / SLABS as f32,
        };
        m.draw_hair(segments);
        m.draw_cards(scene, false);
        if m.model == ShadowModel::Opacity {
            m.slabs = vec![0.0; (n * n) as usize * SLABS];
            m.accumulate_hair(segments);
            m.draw_cards(scene, true);
        }
        m.draw_spheres(scene);
        m.draw_triangles(scene);
        Some(m)
    }

    /// The scene radius the map was built for (for offsets).
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// First-hair depth of the strands, drawn in parallel
    /// ([`Self::min_depth_in_parallel`]).
    fn draw_hair(&mut self, segments: &[WorldSegment]) {
        self.min_depth_in_parallel(segments.len(), |this, range, buf| {
            this.draw_hair_into(&segments[range], buf)
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

    fn draw_hair_into(&self, segments: &[WorldSegment], hair: &mut [f32]) {
        let n = self.size as f32;
        for &WorldSegment { a, b, ra, rb } in segments {
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
    fn draw_cards(&mut self, scene: &Scene, accumulate: bool) {
        let quads = scene.cards.quad_count();
        if quads == 0 {
            return;
        }
        if accumulate {
            let mut texels = Vec::new();
            self.card_texels(scene, 0..quads, |i, z, alpha| texels.push((i, z, alpha)));
            for (i, z, alpha) in texels {
                self.add_optical_depth(i, z, alpha);
            }
            return;
        }
        self.min_depth_in_parallel(quads, |this, range, buf| {
            this.card_texels(scene, range, |i, z, alpha| {
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
        mut emit: impl FnMut(usize, f32, f32),
    ) {
        let c = &scene.cards;
        let n = self.size as f32;
        for q in range {
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
    fn add_optical_depth(&mut self, texel: usize, z: f32, alpha: f32) {
        if !(alpha > 0.0) || !self.hair[texel].is_finite() {
            return;
        }
        let k = (((z - self.hair[texel]) / self.slab_width).max(0.0) as usize).min(SLABS - 1);
        self.slabs[texel * SLABS + k] += -(1.0 - alpha.min(0.95)).ln();
    }

    /// Strands' optical depth: each segment visits the texels of its
    /// bounding box once, with the same tent coverage as the screen
    /// rasterizer (strands thinner than a texel scale their coverage).
    fn accumulate_hair(&mut self, segments: &[WorldSegment]) {
        let n = self.size as f32;
        for &WorldSegment { a, b, ra, rb } in segments {
            let (Some(pa), Some(pb)) = (self.proj.map(a), self.proj.map(b)) else {
                continue;
            };
            let (ax, ay, bx, by) = (pa.0 * n, pa.1 * n, pb.0 * n, pb.1 * n);
            let texels_per_unit = |z: f32| match self.proj.kind {
                Projection::Ortho { half } => 0.5 * n / half,
                Projection::Persp { tan_half } => 0.5 * n / (z.max(1e-6) * tan_half),
            };
            let (wa, wb) = (
                2.0 * ra * texels_per_unit(pa.2),
                2.0 * rb * texels_per_unit(pb.2),
            );
            let pad = 0.5 * wa.max(wb).max(1.0) + 1.0;
            let x0 = ((ax.min(bx) - pad).floor().max(0.0)) as i64;
            let x1 = ((ax.max(bx) + pad).ceil() as i64).min(self.size as i64 - 1);
            let y0 = ((ay.min(by) - pad).floor().max(0.0)) as i64;
            let y1 = ((ay.max(by) + pad).ceil() as i64).min(self.size as i64 - 1);
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
                        let z = pa.2 + (pb.2 - pa.2) * t;
                        self.add_optical_depth(
                            (yi as u32 * self.size + xi as u32) as usize,
                            z,
                            cov,
                        );
                    }
                }
            }
        }
    }

    /// Opaque mesh triangles into the opaque depth.
    fn draw_triangles(&mut self, scene: &Scene) {
        let n = self.size as f32;
        for t in &scene.triangles {
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

    fn draw_spheres(&mut self, scene: &Scene) {
        if scene.spheres.is_empty() {
            return;
        }
        let n = self.size;
        for yi in 0..n {
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

    /// Light visibility at `p` in [0, 1].
    pub fn visibility(&self, p: Vec3) -> f32 {
        let Some((u, v, z)) = self.proj.map(p) else {
            return 1.0;
        };
        let n = self.size as i32;
        let (x, y) = ((u * n as f32) as i32, (v * n as f32) as i32);
        let mut sum = 0.0;
        let mut count = 0.0;
        for dy in -self.pcf..=self.pcf {
            for dx in -self.pcf..=self.pcf {
                let (xi, yi) = (x + dx, y + dy);
                count += 1.0;
                if xi < 0 || yi < 0 || xi >= n || yi >= n {
                    sum += 1.0;
                    continue;
                }
                let idx = (yi * n + xi) as usize;
                if z > self.opaque[idx] + self.bias {
                    continue;
                }
                let behind = z - self.hair[idx] - self.bias;
                sum += if !(behind > 0.0) {
                    1.0
                } else if self.model == ShadowModel::Exponential {
                    (-self.density * behind).exp()
                } else {
                    let s = behind / self.slab_width;
                    let k = s as usize;
                    let slabs = &self.slabs[idx * SLABS..idx * SLABS + SLABS];
                    let mut tau: f32 = slabs[..k.min(SLABS)].iter().sum();
                    if k < SLABS {
                        tau += (s - k as f32) * slabs[k];
                    }
                    (-tau).exp()
                };
            }
        }
        sum / count
    }
}

/// Shadow maps of recent renders, reused while nothing they depend on
/// changed (the geometry, the light, the shadow settings): a camera move
/// re-renders with the maps of the previous frame. Holds at most
/// [`CACHE_MAPS`] maps (least recently used dropped first); each costs
/// `2 · size²` floats (plus `SLABS · size²` with the opacity model): 8 MiB
/// at the default 1024², so the cache holds at most 32 MiB by default.
pub const CACHE_MAPS: usize = 4;

type CacheEntry = (u64, std::sync::Arc<ShadowMap>);

fn cache() -> &'static std::sync::Mutex<Vec<CacheEntry>> {
    static CACHE: std::sync::OnceLock<std::sync::Mutex<Vec<CacheEntry>>> =
        std::sync::OnceLock::new();
    CACHE.get_or_init(|| std::sync::Mutex::new(Vec::new()))
}

/// 64-bit hash of a stream of words (a multiply-xorshift mix; collisions
/// between different scenes have probability ~2^-64).
#[derive(Default)]
pub struct WordHash(u64);

impl WordHash {
    #[inline]
    pub fn word(&mut self, w: u64) {
        self.0 = (self.0 ^ w)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .rotate_left(29);
    }
    pub fn floats(&mut self, xs: impl IntoIterator<Item = f32>) {
        let mut n = 0u64;
        for x in xs {
            self.word(x.to_bits() as u64);
            n += 1;
        }
        self.word(n);
    }
    pub fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 31)
    }
}

/// Hash of everything a shadow map draws (strands, cards with their alpha
/// textures, spheres, meshes).
pub fn geometry_hash(scene: &Scene) -> u64 {
    let mut h = WordHash::default();
    let st = &scene.strands;
    h.floats(st.points.iter().flat_map(|p| p.to_array()));
    h.floats(st.radii.iter().copied());
    h.floats(st.offsets.iter().map(|&o| f32::from_bits(o)));
    let c = &scene.cards;
    h.floats(c.corners.iter().flat_map(|p| p.to_array()));
    h.floats(c.uvs.iter().flatten().copied());
    h.floats(c.texture.iter().map(|&t| f32::from_bits(t)));
    for t in &c.textures {
        h.word(((t.width as u64) << 32) | t.height as u64);
        h.floats(t.alpha.iter().copied());
    }
    h.floats(
        scene
            .spheres
            .iter()
            .flat_map(|s| [s.center.x, s.center.y, s.center.z, s.radius]),
    );
    h.floats(
        scene
            .triangles
            .iter()
            .flat_map(|t| t.p)
            .flat_map(|p| p.to_array()),
    );
    h.finish()
}

impl ShadowMap {
    /// [`ShadowMap::build`], or the map an earlier render built for the same
    /// geometry (`geometry` = [`geometry_hash`]), light and settings; the
    /// flag says whether it was reused. Identical either way: building is
    /// deterministic.
    pub fn build_cached(
        light: &Light,
        scene: &Scene,
        segments: &[WorldSegment],
        bounds: Bounds,
        opts: &RenderOptions,
        geometry: u64,
    ) -> (Option<std::sync::Arc<ShadowMap>>, bool) {
        let (pos_or_dir, shadows) = match *light {
            Light::Directional {
                direction, shadows, ..
            } => (direction, shadows),
            Light::Point {
                position, shadows, ..
            } => (position, shadows),
        };
        if !shadows {
            return (None, false);
        }
        let mut h = WordHash::default();
        h.word(geometry);
        h.word(matches!(light, Light::Point { .. }) as u64);
        h.floats(pos_or_dir.to_array());
        h.floats(bounds.center.to_array());
        h.floats([bounds.radius, opts.shadow_density]);
        h.word(opts.shadow_map_size as u64);
        h.word(opts.pcf_radius as u64);
        h.word(opts.shadow_model as u64);
        let key = h.finish();
        {
            let mut c = cache().lock().unwrap_or_else(|e| e.into_inner());
            if let Some(i) = c.iter().position(|(k, _)| *k == key) {
                let e = c.remove(i);
                let map = e.1.clone();
                c.push(e);
                return (Some(map), true);
            }
        }
        let Some(m) = Self::build(light, scene, segments, bounds, opts) else {
            return (None, false);
        };
        let m = std::sync::Arc::new(m);
        let mut c = cache().lock().unwrap_or_else(|e| e.into_inner());
        if c.len() >= CACHE_MAPS {
            c.remove(0);
        }
        c.push((key, m.clone()));
        (Some(m), false)
    }
}

/// Drops every cached shadow map (see [`ShadowMap::build_cached`]).
pub fn clear_cache() {
    cache().lock().unwrap_or_else(|e| e.into_inner()).clear();
}
