//! Fiber density: a voxel grid of hair cross-section per unit volume, and
//! per light the expected number of fibers a ray from each voxel crosses on
//! its way to the light (after Capcom's RE4 forward-scattering map, with
//! the fiber orientation kept).
//!
//! Each voxel holds, from the strand segments splatted into it trilinearly
//! (pieces at most half a voxel long),
//!
//! ```text
//! S = Σ 2r ℓ,   M = Σ 2r ℓ t tᵀ          (r radius, ℓ length, t unit tangent)
//! ```
//!
//! A ray along unit `d` meets a fiber of tangent t with the cross-section
//! 2r ℓ |t × d| per fiber length ℓ, so the expected number of fibers crossed
//! per unit length is σ(d) = Σ 2r ℓ |t × d| / V. The grid keeps the second
//! moment of t instead of every tangent and evaluates
//! `σ(d) = √(S² − S·dᵀM d) / V`, exact for fibers of one orientation (the
//! hair of a voxel is mostly aligned) and the root mean square of |t × d|
//! otherwise.
//!
//! Per light, [`FiberCount`] holds `n(x) = ∫ σ(x + s d) ds` over the path
//! to the light at every voxel centre: for a directional light by a sweep
//! along the light's major axis (each voxel takes the value one slice
//! upstream, interpolated bilinearly, plus the trapezoid of σ over the
//! step), for a point light by marching from each voxel centre; and the
//! fraction of that path clear of opaque spheres (0 or 1 at voxel centres,
//! interpolated between them).

use super::scene::{Light, Scene, Strands};
pub use crate::fiber::dual::LightPath;
use crate::threads::pool;
use glam::Vec3;
use rayon::prelude::*;

/// z slices per slab of the parallel splat.
const SLAB_SLICES: usize = 4;

/// How far towards the light, in voxels, the fiber count of its
/// unscattered light is read ([`FiberCount::unscattered_at`]). The splat
/// spreads each fiber's cross-section over the voxels around it, so a count
/// read at a point on the hair's lit side also holds about half a voxel of
/// the hair behind the point, and the outer layer sat in the shadow of the
/// layers under it. Measured (coverage, 64 samples; `docs/dense_hair.md`):
/// the environment of `blond_env` without multiple scattering against
/// Mitsuba at max_depth 2, 0.988/0.989/0.992 of its mean read at the point,
/// 0.999/0.999/0.999 half a voxel ahead (a whole voxel overshoots: 1.01,
/// measured without the own share left out); the `density` shadow model on
/// the card head (KarisHair on both sides, direct light), 0.45 -> 0.58 of
/// Mitsuba's mean.
pub const UNSCATTERED_LOOKAHEAD: f32 = 0.5;

/// The fiber cross-section of a scene's hair on a voxel grid.
#[derive(Debug, Clone)]
pub struct DensityGrid {
    /// Corner of voxel (0, 0, 0) and the voxel edge.
    origin: Vec3,
    voxel: f32,
    dims: [usize; 3],
    /// `[S, Mxx, Myy, Mzz, Mxy, Mxz, Myz]` per voxel, divided by the voxel
    /// volume.
    moments: Vec<[f32; 7]>,
    /// Voxel centres inside an opaque sphere.
    opaque: Vec<bool>,
}

/// The expected number of fibers crossed from each voxel centre to one
/// light, and whether the path is clear of opaque geometry.
#[derive(Debug, Clone)]
pub struct FiberCount {
    origin: Vec3,
    voxel: f32,
    dims: [usize; 3],
    /// `[n, clear]` per voxel.
    n: Vec<[f32; 2]>,
    /// Per voxel, the fibers crossed going the other way, away from the
    /// light, up to the grid's edge or opaque geometry (empty unless asked
    /// for: the two-stream back scattering of [`crate::fiber::dual`]).
    behind: Vec<f32>,
}

/// The density grid's corner, voxel edge and dims for `scene` at
/// `resolution` (voxels along the longest side of the bounding box of the
/// strands and card fibers, padded by two voxels); None without hair.
pub fn grid_frame(scene: &Scene, resolution: usize) -> Option<(Vec3, f32, [usize; 3])> {
    grid_frame_in(hair_box_of(scene)?, resolution)
}

/// The box the density grid of `scene` covers: [`crate::raster::setup::hair_box`]
/// of its strands and card fibers.
pub fn hair_box_of(scene: &Scene) -> Option<(Vec3, Vec3)> {
    crate::raster::setup::hair_box(&[&scene.strands, &scene.cards.fibers])
}

/// [`grid_frame`] of the hair box `(lo, hi)` ([`hair_box_of`]).
pub fn grid_frame_in((lo, hi): (Vec3, Vec3), resolution: usize) -> Option<(Vec3, f32, [usize; 3])> {
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let res = resolution.clamp(4, 1024);
    let voxel = ((hi - lo).max_element() / (res - 4) as f32).max(1e-6);
    let origin = lo - Vec3::splat(2.0 * voxel);
    let dims = ((hi - lo) / voxel)
        .to_array()
        .map(|e| (e.ceil() as usize + 4).max(2));
    Some((origin, voxel, dims))
}

impl DensityGrid {
    /// The grid of `scene`'s strands and the fibers of its baked cards,
    /// `resolution` voxels along the longest side of their bounding box
    /// (padded by two voxels), or None when the scene has neither.
    pub fn new(scene: &Scene, resolution: usize) -> Option<Self> {
        let (origin, voxel, dims) = grid_frame(scene, resolution)?;
        let mut grid = Self {
            origin,
            voxel,
            dims,
            moments: vec![[0.0; 7]; dims[0] * dims[1] * dims[2]],
            opaque: Vec::new(),
        };
        grid.splat_strands(&[&scene.strands, &scene.cards.fibers]);
        grid.mark_opaque(scene);
        Some(grid)
    }

    #[inline]
    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Centre of the voxel of index `v`.
    #[inline]
    fn centre_of(&self, v: usize) -> Vec3 {
        let d = self.dims;
        self.centre(v % d[0], (v / d[0]) % d[1], v / (d[0] * d[1]))
    }

    /// Voxel centre (i, j, k).
    #[inline]
    fn centre(&self, i: usize, j: usize, k: usize) -> Vec3 {
        self.origin + (Vec3::new(i as f32, j as f32, k as f32) + 0.5) * self.voxel
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.moments.len() * 28 + self.opaque.len()
    }

    /// Voxels along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn splat_strands(&mut self, sets: &[&Strands]) {
        // Slabs of z slices in parallel: each worker walks every segment
        // whose z range reaches its slab and adds only into the slab's own
        // voxels, so a voxel's sum is taken in strand order whatever the
        // thread count (and no worker holds a copy of the grid).
        let plane = self.dims[0] * self.dims[1];
        let slab = SLAB_SLICES.min(self.dims[2]);
        let inv_volume = 1.0 / (self.voxel * self.voxel * self.voxel);
        let mut moments = std::mem::take(&mut self.moments);
        let this = &*self;
        pool().install(|| {
            moments
                .par_chunks_mut(plane * slab)
                .enumerate()
                .for_each(|(c, m)| {
                    // Written before it is read: a fresh zeroed page read
                    // first is mapped shared and then copied on the first
                    // write (a second fault, and a TLB flush on every core).
                    m.fill([0.0; 7]);
                    let k0 = c * slab;
                    for st in sets {
                        for s in 0..st.strand_count() {
                            this.splat_strand(st, s, k0, m);
                        }
                    }
                    for v in m.iter_mut() {
                        for x in v.iter_mut() {
                            *x *= inv_volume;
                        }
                    }
                });
        });
        self.moments = moments;
    }

    /// Adds strand `s`'s segments, in pieces at most half a voxel long, to
    /// the slab `m` of z slices from `k0`.
    fn splat_strand(&self, st: &Strands, s: usize, k0: usize, m: &mut [[f32; 7]]) {
        let plane = self.dims[0] * self.dims[1];
        let k1 = k0 + m.len() / plane;
        let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
        for i in i0..i1.saturating_sub(1) {
            let (a, b) = (st.points[i], st.points[i + 1]);
            // z slices the segment's splats can reach: its z range, one
            // voxel either side (trilinear weights)
            let kz = |z: f32| (z - self.origin.z) / self.voxel - 0.5;
            let (za, zb) = (kz(a.z), kz(b.z));
            if za.max(zb) + 1.0 < k0 as f32 || za.min(zb) - 1.0 >= k1 as f32 {
                continue;
            }
            let (ra, rb) = (st.radii[i], st.radii[i + 1]);
            let len = (b - a).length();
            if !(len > 0.0 && len.is_finite() && ra.is_finite() && rb.is_finite()) {
                continue;
            }
            let t = (b - a) / len;
            let tt = [
                t.x * t.x,
                t.y * t.y,
                t.z * t.z,
                t.x * t.y,
                t.x * t.z,
                t.y * t.z,
            ];
            let pieces = ((2.0 * len / self.voxel).ceil() as usize).clamp(1, 1 << 16);
            let piece = len / pieces as f32;
            for q in 0..pieces {
                let f = (q as f32 + 0.5) / pieces as f32;
                let area = (ra + (rb - ra) * f).max(0.0) * 2.0 * piece;
                let mut v = [area; 7];
                for c in 0..6 {
                    v[c + 1] = area * tt[c];
                }
                self.splat(a + (b - a) * f, &v, k0..k1, m);
            }
        }
    }

    /// Adds `v` at point `p` to the 8 voxels around it (trilinear weights),
    /// those in z slices `ks` (the slab `m`).
    #[inline]
    fn splat(&self, p: Vec3, v: &[f32; 7], ks: std::ops::Range<usize>, m: &mut [[f32; 7]]) {
        let g = (p - self.origin) / self.voxel - 0.5;
        let b = crate::math::floor3(g);
        let f = g - b;
        for dz in 0..2 {
            for dy in 0..2 {
                for dx in 0..2 {
                    let (i, j, k) = (b.x as i64 + dx, b.y as i64 + dy, b.z as i64 + dz);
                    if i < 0 || j < 0 || k < ks.start as i64 || k >= ks.end as i64 {
                        continue;
                    }
                    let (i, j, k) = (i as usize, j as usize, k as usize);
                    if i >= self.dims[0] || j >= self.dims[1] {
                        continue;
                    }
                    let w = (if dx == 1 { f.x } else { 1.0 - f.x })
                        * (if dy == 1 { f.y } else { 1.0 - f.y })
                        * (if dz == 1 { f.z } else { 1.0 - f.z });
                    let cell = &mut m[self.index(i, j, k - ks.start)];
                    for c in 0..7 {
                        cell[c] += w * v[c];
                    }
                }
            }
        }
    }

    /// Marks voxel centres inside the scene's spheres.
    fn mark_opaque(&mut self, scene: &Scene) {
        if scene.spheres.is_empty() {
            return;
        }
        let mut opaque = vec![false; self.moments.len()];
        for k in 0..self.dims[2] {
            for j in 0..self.dims[1] {
                for i in 0..self.dims[0] {
                    let c = self.centre(i, j, k);
                    opaque[self.index(i, j, k)] = scene
                        .spheres
                        .iter()
                        .any(|s| (c - s.center).length_squared() < s.radius * s.radius);
                }
            }
        }
        self.opaque = opaque;
    }

    /// σ(d) of voxel `v`: fibers crossed per unit length along unit `d`.
    #[inline]
    fn sigma(&self, v: usize, d: Vec3) -> f32 {
        let m = &self.moments[v];
        let dmd = m[1] * d.x * d.x
            + m[2] * d.y * d.y
            + m[3] * d.z * d.z
            + 2.0 * (m[4] * d.x * d.y + m[5] * d.x * d.z + m[6] * d.y * d.z);
        (m[0] * m[0] - m[0] * dmd).max(0.0).sqrt()
    }

    /// σ along `d` at every voxel.
    fn sigma_field(&self, d: Vec3) -> Vec<f32> {
        (0..self.moments.len()).map(|v| self.sigma(v, d)).collect()
    }

    /// Whether voxel `v`'s centre is inside opaque geometry.
    #[inline]
    fn is_opaque(&self, v: usize) -> bool {
        self.opaque.get(v) == Some(&true)
    }

    /// The fiber count to `light` from every voxel centre.
    pub fn fiber_count(&self, light: &Light) -> FiberCount {
        self.fiber_count_with(light, false)
    }

    /// [`Self::fiber_count`], with `behind` also the count away from the
    /// light from every voxel centre.
    pub fn fiber_count_with(&self, light: &Light, behind: bool) -> FiberCount {
        let (n, behind) = match *light {
            Light::Directional { direction, .. } => {
                let d = direction.normalize_or(Vec3::Y);
                let back = if behind {
                    self.sweep(-d, true).into_iter().map(|v| v[0]).collect()
                } else {
                    Vec::new()
                };
                (self.sweep(d, false), back)
            }
            Light::Point { position, .. } => {
                let back = if behind {
                    self.march_away(position)
                } else {
                    Vec::new()
                };
                (self.march_to(position), back)
            }
        };
        FiberCount {
            origin: self.origin,
            voxel: self.voxel,
            dims: self.dims,
            n,
            behind,
        }
    }

    /// `n` for a directional light towards `d`, slice by slice along its
    /// major axis, starting at the slice nearest the light (each slice's
    /// rows in parallel, into slice-major storage, then gathered into the
    /// grid's order). With `stop`, a path ends at opaque geometry: an
    /// opaque voxel holds `[0, 0]` and the count restarts past it.
    fn sweep(&self, d: Vec3, stop: bool) -> Vec<[f32; 2]> {
        let sigma = self.sigma_field(d);
        let a = d.abs().max_position();
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let da = d[a];
        // One slice upstream: `step` along d moves one voxel along axis a,
        // and (ob, oc) voxels along the other two.
        let step = self.voxel / da.abs();
        let (ob, oc) = (d[b] / da.abs(), d[c] / da.abs());
        let dims = self.dims;
        let idx = |v: [usize; 3]| (v[2] * dims[1] + v[1]) * dims[0] + v[0];
        let at = |ia: usize, ib: usize, ic: usize| {
            let mut v = [0usize; 3];
            v[a] = ia;
            v[b] = ib;
            v[c] = ic;
            idx(v)
        };
        let order: Vec<usize> = if da > 0.0 {
            (0..dims[a]).rev().collect()
        } else {
            (0..dims[a]).collect()
        };
        // `slices[pos]`: the slice `order[pos]`, row ic, column ib.
        let area = dims[b] * dims[c];
        let mut slices = vec![[0.0f32, 1.0]; sigma.len()];
        pool().install(|| {
            for (pos, &ia) in order.iter().enumerate() {
                let (done, rest) = slices.split_at_mut(pos * area);
                let here_slice = &mut rest[..area];
                let upstream = (pos > 0).then(|| (order[pos - 1], &done[(pos - 1) * area..]));
                here_slice
                    .par_chunks_mut(dims[b])
                    .enumerate()
                    .for_each(|(ic, row)| {
                        for (ib, out) in row.iter_mut().enumerate() {
                            let v = at(ia, ib, ic);
                            let here = sigma[v];
                            let clear = if self.is_opaque(v) { 0.0 } else { 1.0 };
                            if stop && clear == 0.0 {
                                *out = [0.0, 0.0];
                                continue;
                            }
                            let Some((ua, up)) = upstream else {
                                *out = [0.5 * step * here, clear];
                                continue;
                            };
                            // Bilinear value of n, clear and σ one slice
                            // upstream (outside the grid: no hair, clear).
                            let (fb, fc) = (ib as f32 + ob, ic as f32 + oc);
                            let (mut nu, mut cu, mut su) = (0.0f32, 0.0f32, 0.0f32);
                            let (b0, c0) = (crate::math::floor(fb), crate::math::floor(fc));
                            let (wb, wc) = (fb - b0, fc - c0);
                            for (db, wdb) in [(0i64, 1.0 - wb), (1, wb)] {
                                for (dc, wdc) in [(0i64, 1.0 - wc), (1, wc)] {
                                    let (jb, jc) = (b0 as i64 + db, c0 as i64 + dc);
                                    let w = wdb * wdc;
                                    if w == 0.0 {
                                        continue;
                                    }
                                    if jb < 0
                                        || jc < 0
                                        || jb >= dims[b] as i64
                                        || jc >= dims[c] as i64
                                    {
                                        cu += w;
                                        continue;
                                    }
                                    let (jb, jc) = (jb as usize, jc as usize);
                                    let [nn, cc] = up[jc * dims[b] + jb];
                                    nu += w * nn;
                                    cu += w * cc;
                                    su += w * sigma[at(ua, jb, jc)];
                                }
                            }
                            *out = [nu + 0.5 * step * (here + su), clear * cu];
                        }
                    });
            }
            // Gather into the grid's order.
            let mut pos_of = vec![0usize; dims[a]];
            for (pos, &ia) in order.iter().enumerate() {
                pos_of[ia] = pos;
            }
            let mut n = vec![[0.0f32, 1.0]; sigma.len()];
            n.par_chunks_mut(dims[0])
                .enumerate()
                .for_each(|(row, out)| {
                    let (j, k) = (row % dims[1], row / dims[1]);
                    for (i, o) in out.iter_mut().enumerate() {
                        let v = [i, j, k];
                        *o = slices[pos_of[v[a]] * area + v[c] * dims[b] + v[b]];
                    }
                });
            n
        })
    }

    /// `n` for a point light at `p`: a march from every voxel centre,
    /// half-voxel steps, nearest-voxel σ.
    fn march_to(&self, p: Vec3) -> Vec<[f32; 2]> {
        let sigma = self.sigma_field_towards(p);
        pool().install(|| {
            (0..sigma.len())
                .into_par_iter()
                .map(|v| {
                    let x = self.centre_of(v);
                    let to = p - x;
                    let dist = to.length();
                    let steps = ((2.0 * dist / self.voxel).ceil() as usize).clamp(1, 4 * 1024);
                    let h = dist / steps as f32;
                    let (mut n, mut clear) = (0.0, 1.0);
                    for s in 0..steps {
                        let q = x + to * ((s as f32 + 0.5) / steps as f32);
                        if let Some(w) = self.voxel_at(q) {
                            n += h * sigma[w];
                            if self.is_opaque(w) {
                                clear = 0.0;
                            }
                        }
                    }
                    [n, clear]
                })
                .collect()
        })
    }

    /// The count away from a point light at `p` from every voxel centre:
    /// a march along the line from `p` through the centre, half-voxel
    /// steps, nearest-voxel σ, up to the grid's edge or opaque geometry.
    fn march_away(&self, p: Vec3) -> Vec<f32> {
        let sigma = self.sigma_field_towards(p);
        let dims = self.dims;
        let max_steps = 2 * (dims[0] + dims[1] + dims[2]);
        let h = 0.5 * self.voxel;
        pool().install(|| {
            (0..sigma.len())
                .into_par_iter()
                .map(|v| {
                    let x = self.centre_of(v);
                    let dir = (x - p).normalize_or(Vec3::Y);
                    let mut n = 0.0;
                    for s in 0..max_steps {
                        let Some(w) = self.voxel_at(x + dir * (h * (s as f32 + 0.5))) else {
                            break;
                        };
                        if self.is_opaque(w) {
                            break;
                        }
                        n += h * sigma[w];
                    }
                    n
                })
                .collect()
        })
    }

    /// σ towards a point `p` at every voxel.
    fn sigma_field_towards(&self, p: Vec3) -> Vec<f32> {
        (0..self.moments.len())
            .map(|v| self.sigma(v, (p - self.centre_of(v)).normalize_or(Vec3::Y)))
            .collect()
    }

    /// The voxel containing `p`, if inside the grid.
    #[inline]
    fn voxel_at(&self, p: Vec3) -> Option<usize> {
        let g = (p - self.origin) / self.voxel;
        if !(g.x >= 0.0 && g.y >= 0.0 && g.z >= 0.0) {
            return None;
        }
        let (i, j, k) = (g.x as usize, g.y as usize, g.z as usize);
        (i < self.dims[0] && j < self.dims[1] && k < self.dims[2]).then(|| self.index(i, j, k))
    }
}

impl FiberCount {
    /// The grid's voxel edge.
    pub fn voxel(&self) -> f32 {
        self.voxel
    }

    /// [`Self::at`] at a point of a fiber of radius `r`, with the fiber's
    /// own share left out: the grid holds every fiber's cross-section, this
    /// one's too. A ray leaving the fiber's axis along `d` crosses
    /// `2r|t × d| / voxel²` of it per unit length over about
    /// `voxel / (2|t × d|)` (the splat is a voxel wide), so about
    /// `r / voxel` whatever the angle (density test 5: 0.50-1.25 of it).
    /// Without this a lone fiber of radius 0.5 voxel received 0.40 of a
    /// constant environment.
    #[inline]
    pub fn at_fiber(&self, p: Vec3, r: f32) -> LightPath {
        let path = self.at(p);
        LightPath {
            n: (path.n - self.own_share(r)).max(0.0),
            ..path
        }
    }

    /// The fiber's own share of the count: its radius over the voxel
    /// (see [`Self::at_fiber`]).
    #[inline]
    fn own_share(&self, r: f32) -> f32 {
        r / self.voxel
    }

    /// [`Self::at_fiber`]'s fiber count for the light's unscattered part:
    /// read [`UNSCATTERED_LOOKAHEAD`] voxels towards the light `d`.
    #[inline]
    pub fn unscattered_at(&self, p: Vec3, r: f32, d: Vec3) -> f32 {
        self.at_fiber(p + d * (UNSCATTERED_LOOKAHEAD * self.voxel), r)
            .n
    }

    /// Bytes held by the counts.
    pub fn bytes(&self) -> usize {
        self.n.len() * 8 + self.behind.len() * 4
    }

    /// Whether the counts hold the fibers behind each point
    /// ([`LightPath::behind`]: two-stream back scattering).
    pub fn has_behind(&self) -> bool {
        !self.behind.is_empty()
    }

    /// [`Self::at_fiber`] with the count away from the light there (its
    /// own share left out too) when this count holds it, in one pass.
    #[inline]
    pub fn at_fiber_behind(&self, p: Vec3, r: f32) -> LightPath {
        let has = !self.behind.is_empty();
        let (mut n, mut clear, mut m) = (0.0, 0.0, 0.0);
        let inside = self.trilinear(p, |v, w| {
            n += w * self.n[v][0];
            clear += w * self.n[v][1];
            if has {
                m += w * self.behind[v];
            }
        });
        let own = self.own_share(r);
        LightPath {
            n: (n - own).max(0.0),
            clear: clear + (1.0 - inside),
            behind: has.then(|| (m - own).max(0.0)),
        }
    }

    /// Calls `f(voxel, weight)` for the trilinear weights of `p` between
    /// voxel centres inside the grid; returns the weights' sum.
    #[inline]
    fn trilinear(&self, p: Vec3, mut f: impl FnMut(usize, f32)) -> f32 {
        let g = (p - self.origin) / self.voxel - 0.5;
        let b = crate::math::floor3(g);
        let fr = g - b;
        let mut inside = 0.0;
        for dz in 0..2 {
            for dy in 0..2 {
                for dx in 0..2 {
                    let (i, j, k) = (b.x as i64 + dx, b.y as i64 + dy, b.z as i64 + dz);
                    if i < 0
                        || j < 0
                        || k < 0
                        || i >= self.dims[0] as i64
                        || j >= self.dims[1] as i64
                        || k >= self.dims[2] as i64
                    {
                        continue;
                    }
                    let w = (if dx == 1 { fr.x } else { 1.0 - fr.x })
                        * (if dy == 1 { fr.y } else { 1.0 - fr.y })
                        * (if dz == 1 { fr.z } else { 1.0 - fr.z });
                    if w > 0.0 {
                        f(
                            ((k as usize * self.dims[1]) + j as usize) * self.dims[0] + i as usize,
                            w,
                        );
                        inside += w;
                    }
                }
            }
        }
        inside
    }

    /// At `p`: the expected fibers crossed on the way to the light and the
    /// fraction of the path clear of opaque geometry (trilinear between
    /// voxel centres; outside the grid [`LightPath::OPEN`]); `behind` is
    /// not read here.
    #[inline]
    pub fn at(&self, p: Vec3) -> LightPath {
        let (mut n, mut clear) = (0.0, 0.0);
        let inside = self.trilinear(p, |v, w| {
            n += w * self.n[v][0];
            clear += w * self.n[v][1];
        });
        LightPath {
            n,
            clear: clear + (1.0 - inside),
            behind: None,
        }
    }
}

#[cfg(test)]
mod tests;
