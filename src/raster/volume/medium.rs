//! The hair as an anisotropic medium of oriented fibers (Jakob et al. 2010):
//! per voxel the fiber cross-section and a few of the fibers' tangents.
//!
//! From the strand segments (and the fibers baked cards stand for), cut
//! into pieces at most half a voxel long and each given to the voxel of its
//! midpoint:
//!
//! ```text
//! S = Σ 2r ℓ / V,   M = Σ 2r ℓ t tᵀ / V          (r radius, ℓ length, t unit tangent)
//! σt(ω) = √(S² − S ωᵀ M ω)                       (= Σ 2r ℓ |t × ω| / V for one orientation)
//! ```
//!
//! σt is the expected number of fibers a ray along ω crosses per unit
//! length: a ray along the fibers crosses almost none, one across them the
//! most. A collision picks the fiber it meets among [`TANGENTS`] tangents
//! kept per voxel (drawn in proportion to 2rℓ by a hash of the piece, so
//! the same in every render), each weighted by `|t × ω|`: curly hair and
//! crown whorls keep their spread of orientations.

use super::super::scene::{Scene, Strands};
use glam::Vec3;

/// Tangents kept per voxel.
pub const TANGENTS: usize = 6;

/// Where a slot's `moments` hold the weight of its tallied light: after
/// the seven moments, which the scalings of the cross-section touch alone.
const WEIGHT: usize = 7;

/// The medium on a voxel grid; only voxels holding hair carry data.
pub struct Medium {
    pub origin: Vec3,
    pub voxel: f32,
    pub dims: [usize; 3],
    /// Per slot: `[S, Mxx, Myy, Mzz, Mxy, Mxz, Myz]` per unit volume, then
    /// the weight of the light tallied in the voxel ([`Medium::weight`]),
    /// beside them so that a photon's step reads both from one cache line.
    pub moments: Vec<[f32; 8]>,
    /// Per slot: up to [`TANGENTS`] fiber tangents (zero: unused).
    pub tangents: Vec<[Vec3; TANGENTS]>,
    /// Per slot: the dense voxel index.
    pub voxel_of: Vec<u32>,
    /// The grid light is tallied on.
    pub cells: Cells,
    /// Dense voxel index -> its slot (a voxel with hair) and the slot of
    /// the cell holding it (`u32::MAX`: none), side by side for the
    /// photons' walk.
    pub slots: Vec<[u32; 2]>,
    /// Dense voxel index -> the distance (L∞, in voxels, at most
    /// [`EMPTY_REACH`]) to the nearest voxel holding hair: the voxels
    /// less than this away hold none, and a photon crosses them without
    /// reading them.
    pub empty: Vec<u8>,
}

/// The farthest [`Medium::empty`] looks (a photon leaving the hair crosses
/// empty voxels in runs of up to 2·EMPTY_REACH − 1 without reading them;
/// on blond_back, 89% of the voxels photons crossed were empty).
pub const EMPTY_REACH: u8 = 6;

/// Per voxel of a grid of `dims`, the L∞ distance in voxels to the nearest
/// voxel where `hair` holds (capped at [`EMPTY_REACH`]): the distance to a
/// set is separable in L∞, min over u of max_k |v_k − u_k|, so three
/// passes along the axes, each g(i) = min_j max(|i − j|, f(j)), give it.
fn empty_distance(hair: impl Fn(usize) -> bool, dims: [usize; 3]) -> Vec<u8> {
    let n = dims[0] * dims[1] * dims[2];
    let mut f: Vec<u8> = (0..n)
        .map(|v| if hair(v) { 0 } else { EMPTY_REACH })
        .collect();
    let strides = [1, dims[0], dims[0] * dims[1]];
    for (axis, &stride) in strides.iter().enumerate() {
        let len = dims[axis];
        let mut g = f.clone();
        for v in 0..n {
            if g[v] == 0 {
                continue;
            }
            let i = (v / stride) % len;
            let mut best = g[v];
            for off in 1..EMPTY_REACH as usize {
                if off >= best as usize {
                    break;
                }
                let lo = (i >= off).then(|| f[v - off * stride]);
                let hi = (i + off < len).then(|| f[v + off * stride]);
                for x in [lo, hi].into_iter().flatten() {
                    best = best.min(x.max(off as u8));
                }
            }
            g[v] = best;
        }
        f = g;
    }
    f
}

/// The Morton code of dense cell index `n` on a grid of `dims` cells.
fn morton_of_cell(n: u32, dims: [usize; 3]) -> u64 {
    crate::raster::traced::morton_code(grid_coords(dims, n as usize).map(|a| a as u32))
}

/// The grid the light is tallied on: [`FINE`] medium voxels a side per
/// cell, a cell for every cell holding hair.
pub struct Cells {
    pub origin: Vec3,
    pub size: f32,
    pub dims: [usize; 3],
    /// Dense cell index -> slot (`u32::MAX`: none).
    pub slot: Vec<u32>,
    /// Per slot: the dense cell index. Slots follow the cells' Morton
    /// order.
    pub cell_of: Vec<u32>,
    /// Per slot: the cell's fibers, as the fraction of its volume that its
    /// voxels holding hair have outside opaque spheres, each voxel weighted
    /// by its fiber density ([`Medium::weight`]). Light is tallied in
    /// those voxels only, by the same weights, and per unit of this: the
    /// fluence the cell's fibers bathe in, their mean over the fibers. Not
    /// its mean over a cell that the hair's surface cuts, which holds the
    /// light just outside, where nothing scatters it sideways or inwards;
    /// nor its mean over the cell's volume, where sparse voxels at the
    /// hair's edge, which light crosses unscattered, count as much as dense
    /// ones.
    pub weight: Vec<f32>,
    /// Per slot: the mean position of the cell's fibers (weighted as
    /// `weight`), from the cell's centre, in cells.
    pub centroid: Vec<Vec3>,
}

/// Medium voxels per cell side: the medium is resolved finer than the
/// light (measured on blond_back, the light's multiple-scattering part
/// against the truth's fell with the medium's voxel, 1.32 / 1.20 / 1.15
/// of the truth's at 32 / 48 / 64 voxels a side, while the tallies'
/// noise grows as their cells shrink).
pub const FINE: usize = 2;

/// The fraction of the cube at `corner` with edge `size` outside `scene`'s
/// opaque spheres (4³ points; at least 1/64, so that a cube the hair
/// reaches keeps a volume).
fn free_fraction(scene: &Scene, corner: Vec3, size: f32) -> f32 {
    let mut free = 0;
    for s in 0..64 {
        let p = corner
            + Vec3::new(
                (s % 4) as f32 + 0.5,
                ((s / 4) % 4) as f32 + 0.5,
                (s / 16) as f32 + 0.5,
            ) * (0.25 * size);
        if !scene
            .spheres
            .iter()
            .any(|sp| (p - sp.center).length_squared() < sp.radius * sp.radius)
        {
            free += 1;
        }
    }
    free.max(1) as f32 / 64.0
}

/// The dense index of cell or voxel `ijk` (inside) of a grid of `dims`:
/// `i` runs fastest.
#[inline]
fn dense(dims: [usize; 3], [i, j, k]: [usize; 3]) -> usize {
    (k * dims[1] + j) * dims[0] + i
}

/// The dense index of cell or voxel `(i, j, k)` of a grid of `dims`, or
/// None outside it.
#[inline]
pub fn dense_index(dims: [usize; 3], i: i64, j: i64, k: i64) -> Option<usize> {
    let inside = |x: i64, n: usize| x >= 0 && x < n as i64;
    (inside(i, dims[0]) && inside(j, dims[1]) && inside(k, dims[2]))
        .then(|| dense(dims, [i as usize, j as usize, k as usize]))
}

/// `(i, j, k)` of dense index `n` of a grid of `dims` (the inverse of
/// [`dense_index`]).
#[inline]
pub fn grid_coords(dims: [usize; 3], n: usize) -> [usize; 3] {
    [
        n % dims[0],
        (n / dims[0]) % dims[1],
        n / (dims[0] * dims[1]),
    ]
}

/// The voxel `(i, j, k)` holding `p` of a grid of `dims` voxels of side
/// `voxel` from `origin` (None: outside, or not finite).
#[inline]
fn voxel_coords(origin: Vec3, voxel: f32, dims: [usize; 3], p: Vec3) -> Option<[usize; 3]> {
    let q = (p - origin) / voxel;
    if !(q.is_finite() && q.min_element() >= 0.0) {
        return None;
    }
    let ijk = [q.x as usize, q.y as usize, q.z as usize];
    (ijk[0] < dims[0] && ijk[1] < dims[1] && ijk[2] < dims[2]).then_some(ijk)
}

/// The dense index of the cell holding voxel `ijk`, on a grid of `cells`
/// cells of [`FINE`]³ voxels.
#[inline]
fn cell_holding(cells: [usize; 3], ijk: [usize; 3]) -> usize {
    dense(cells, ijk.map(|x| x / FINE))
}

/// A 64-bit mix (splitmix64's finalizer).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Calls `f(p, t, w)` for each piece of `st`'s segments, cut as the
/// medium cuts them: at most half of `voxel` long, `p` its midpoint, `t`
/// its unit tangent, `w = 2rℓ` its cross-section weight. Degenerate and
/// non-finite segments give none.
fn for_each_piece(st: &Strands, voxel: f32, mut f: impl FnMut(Vec3, Vec3, f32)) {
    for s in 0..st.strand_count() {
        let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
        for i in i0..i1.saturating_sub(1) {
            let (a, b) = (st.points[i], st.points[i + 1]);
            let r = 0.5 * (st.radii[i] + st.radii[i + 1]);
            let d = b - a;
            let len = d.length();
            if !(len > 0.0 && len.is_finite() && r.is_finite() && r > 0.0) {
                continue;
            }
            let t = d / len;
            let n = (len / (0.5 * voxel)).ceil().clamp(1.0, 4096.0) as usize;
            let l = len / n as f32;
            for k in 0..n {
                f(a + d * ((k as f32 + 0.5) / n as f32), t, 2.0 * r * l);
            }
        }
    }
}

/// What a medium of `scene` at `resolution` holds, counted before it is
/// built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Occupancy {
    /// Voxels of the grid (dense arrays).
    pub voxels: usize,
    /// Voxels holding hair (a slot each).
    pub hair_voxels: usize,
    /// Cells of the light's grid (dense arrays).
    pub cells: usize,
    /// Cells holding hair (tallies each).
    pub hair_cells: usize,
}

impl Occupancy {
    /// The exact count: the strands cut into pieces as [`Medium::new`]
    /// cuts them, each piece's voxel and cell marked on a bitset (an
    /// eighth of a byte a voxel). The tallies hold only the cells with
    /// hair, a shell around the head: on blond_back, 14% of the cells at
    /// 48 cells a side, 10% at 96.
    pub fn of(scene: &Scene, hair: (Vec3, Vec3), resolution: usize) -> Option<Self> {
        let (origin, voxel, dims) = crate::raster::density::grid_frame_in(hair, resolution)?;
        let cd = dims.map(|d| d.div_ceil(FINE));
        let voxels = dims[0] * dims[1] * dims[2];
        let cells = cd[0] * cd[1] * cd[2];
        let mut voxel_bits = vec![0u64; voxels.div_ceil(64)];
        let mut cell_bits = vec![0u64; cells.div_ceil(64)];
        let (mut hair_voxels, mut hair_cells) = (0, 0);
        let mark = |bits: &mut [u64], n: usize| {
            let (w, b) = (n / 64, 1u64 << (n % 64));
            let new = bits[w] & b == 0;
            bits[w] |= b;
            new
        };
        for st in [&scene.strands, &scene.cards.fibers] {
            for_each_piece(st, voxel, |p, _, _| {
                let Some(ijk) = voxel_coords(origin, voxel, dims, p) else {
                    return;
                };
                if mark(&mut voxel_bits, dense(dims, ijk)) {
                    hair_voxels += 1;
                    hair_cells += usize::from(mark(&mut cell_bits, cell_holding(cd, ijk)));
                }
            });
        }
        Some(Self {
            voxels,
            hair_voxels,
            cells,
            hair_cells,
        })
    }

    /// Bytes the medium holds: per voxel the slot index (8 bytes), the
    /// empty distance and its pass buffer (1 each); per voxel with hair its
    /// moments, tangents and index; per cell with hair its slot, weight
    /// and centroid; the dense cell index.
    pub fn medium_bytes(&self) -> usize {
        self.voxels * 10
            + self.hair_voxels * (32 + TANGENTS * 12 + 4)
            + self.cells * 4
            + self.hair_cells * 20
    }
}

impl Medium {
    /// The medium of `scene`'s strands and card fibers, `resolution` voxels
    /// along the longest side of their bounds (padded by two voxels); None
    /// without hair.
    pub fn new(scene: &Scene, resolution: usize) -> Option<Self> {
        let (origin, voxel, dims) = crate::raster::density::grid_frame(scene, resolution)?;
        let mut m = Self {
            origin,
            voxel,
            dims,
            slots: vec![[u32::MAX; 2]; dims[0] * dims[1] * dims[2]],
            empty: Vec::new(),
            moments: Vec::new(),
            tangents: Vec::new(),
            voxel_of: Vec::new(),
            cells: Cells {
                origin,
                size: voxel * FINE as f32,
                dims: dims.map(|d| d.div_ceil(FINE)),
                slot: Vec::new(),
                cell_of: Vec::new(),
                weight: Vec::new(),
                centroid: Vec::new(),
            },
        };
        // per slot: the reservoir's total weight
        let mut total: Vec<[f32; TANGENTS]> = Vec::new();
        let mut piece = 0u64;
        for st in [&scene.strands, &scene.cards.fibers] {
            m.add_strands(st, &mut total, &mut piece);
        }
        let inv_v = 1.0 / (voxel * voxel * voxel);
        for v in &mut m.moments {
            for x in v[..WEIGHT].iter_mut() {
                *x *= inv_v;
            }
        }
        let free: Vec<f32> = m
            .voxel_of
            .iter()
            .map(|&v| m.free_fraction(scene, v as usize))
            .collect();
        for (mo, &f) in m.moments.iter_mut().zip(&free) {
            for x in mo[..WEIGHT].iter_mut() {
                *x /= f;
            }
        }
        m.build_cells(&free);
        m.empty = empty_distance(|v| m.slots[v][0] != u32::MAX, m.dims);
        Some(m)
    }

    /// The cells: one for every cell holding a voxel with hair, its
    /// weight the free volume of those voxels (`free`: per slot, the
    /// voxel's fraction outside opaque spheres) times their fiber density
    /// over the mean. Measured in the white furnace (`docs/volume.md`,
    /// where the truth is 1), the hair read 0.857 on average tallied over
    /// whole cells and their neighbours (its multiple scattering 0.84 of
    /// Mitsuba's), 0.894 over the voxels holding hair (0.885; both read at
    /// each bin's mean direction), 0.929 with the blurred reading and
    /// each voxel weighted by its fibers, here, in the filter and in the
    /// reading ([`super::VolumeRadiance::radiance`]); through the strands'
    /// own transport 0.945 by volume, 0.984 by fibers (multiple scattering
    /// 0.947 and 0.996 of Mitsuba's).
    fn build_cells(&mut self, free: &[f32]) {
        let mean_s = self.moments.iter().map(|m| m[0] as f64).sum::<f64>()
            / self.moments.len().max(1) as f64;
        for m in &mut self.moments {
            m[WEIGHT] = (m[0] as f64 / mean_s) as f32;
        }
        let c = &mut self.cells;
        let cd = c.dims;
        c.slot = vec![u32::MAX; cd[0] * cd[1] * cd[2]];
        c.cell_of.clear();
        c.weight.clear();
        c.centroid.clear();
        let d = self.dims;
        let per_cell = 1.0 / (FINE * FINE * FINE) as f32;
        let cell_of_voxel = |v: u32| cell_holding(cd, grid_coords(d, v as usize));
        // the cells holding hair, numbered along the Morton curve: cells
        // near one another in space lie near one another in the tallies
        // (the filter reads each cell's 26 neighbours, a photon's flight
        // adds to the cells along it)
        for &v in &self.voxel_of {
            let n = cell_of_voxel(v);
            if c.slot[n] == u32::MAX {
                c.slot[n] = 0;
                c.cell_of.push(n as u32);
            }
        }
        c.cell_of.sort_unstable_by_key(|&n| morton_of_cell(n, cd));
        for (s, &n) in c.cell_of.iter().enumerate() {
            c.slot[n as usize] = s as u32;
        }
        c.weight = vec![0.0; c.cell_of.len()];
        c.centroid = vec![Vec3::ZERO; c.cell_of.len()];
        for ((&v, &f), m) in self.voxel_of.iter().zip(free).zip(&self.moments) {
            let w = m[WEIGHT];
            let n = cell_of_voxel(v);
            let [i, j, k] = grid_coords(d, v as usize);
            let s = c.slot[n] as usize;
            c.weight[s] += f * w * per_cell;
            // the voxel's centre within its cell, in cells from the cell's centre
            let within = Vec3::new(
                (i % FINE) as f32 + 0.5,
                (j % FINE) as f32 + 0.5,
                (k % FINE) as f32 + 0.5,
            ) / FINE as f32
                - Vec3::splat(0.5);
            c.centroid[s] += within * (f * w * per_cell);
        }
        for (g, &w) in c.centroid.iter_mut().zip(&c.weight) {
            *g = if w > 0.0 { *g / w } else { Vec3::ZERO };
        }
        for (v, s) in self.slots.iter_mut().enumerate() {
            // light is tallied in the voxels that hold hair
            s[1] = if s[0] == u32::MAX {
                u32::MAX
            } else {
                c.slot[cell_of_voxel(v as u32)]
            };
        }
    }

    /// The fraction of voxel `v` outside `scene`'s opaque spheres.
    fn free_fraction(&self, scene: &Scene, v: usize) -> f32 {
        let corner =
            self.origin + Vec3::from(grid_coords(self.dims, v).map(|x| x as f32)) * self.voxel;
        free_fraction(scene, corner, self.voxel)
    }

    fn add_strands(&mut self, st: &Strands, total: &mut Vec<[f32; TANGENTS]>, piece: &mut u64) {
        for_each_piece(st, self.voxel, |p, t, w| {
            *piece += 1;
            self.add_piece(p, t, w, total, *piece);
        });
    }

    fn add_piece(&mut self, p: Vec3, t: Vec3, w: f32, total: &mut Vec<[f32; TANGENTS]>, id: u64) {
        let Some(v) = self.voxel_at(p) else {
            return;
        };
        let mut s = self.slots[v][0];
        if s == u32::MAX {
            s = self.moments.len() as u32;
            self.slots[v][0] = s;
            self.moments.push([0.0; 8]);
            self.tangents.push([Vec3::ZERO; TANGENTS]);
            total.push([0.0; TANGENTS]);
            self.voxel_of.push(v as u32);
        }
        let s = s as usize;
        let m = &mut self.moments[s];
        m[0] += w;
        m[1] += w * t.x * t.x;
        m[2] += w * t.y * t.y;
        m[3] += w * t.z * t.z;
        m[4] += w * t.x * t.y;
        m[5] += w * t.x * t.z;
        m[6] += w * t.y * t.z;
        // Each of the TANGENTS reservoirs keeps one piece, drawn in
        // proportion to its weight (weighted reservoir sampling).
        let h = mix64(id);
        for (j, (tw, tt)) in total[s].iter_mut().zip(&mut self.tangents[s]).enumerate() {
            *tw += w;
            let u = ((mix64(h ^ (j as u64 + 1)) >> 40) as f32 + 0.5) * (1.0 / (1u64 << 24) as f32);
            if u * *tw < w {
                *tt = t;
            }
        }
    }

    /// Dense index of the voxel holding `p`.
    #[inline]
    pub fn voxel_at(&self, p: Vec3) -> Option<usize> {
        voxel_coords(self.origin, self.voxel, self.dims, p).map(|ijk| dense(self.dims, ijk))
    }

    /// The weight of the light tallied in slot `s`'s voxel: its fiber
    /// density over the mean of the voxels holding hair (taken before the
    /// calibration scales the cross-section).
    #[inline]
    pub fn weight(&self, s: usize) -> f32 {
        self.moments[s][WEIGHT]
    }

    /// Fibers crossed per unit length along unit `d` in slot `s`.
    #[inline]
    pub fn sigma(&self, s: usize, d: Vec3) -> f32 {
        let m = &self.moments[s];
        let q = d.x * d.x * m[1]
            + d.y * d.y * m[2]
            + d.z * d.z * m[3]
            + 2.0 * (d.x * d.y * m[4] + d.x * d.z * m[5] + d.y * d.z * m[6]);
        (m[0] * m[0] - m[0] * q).max(0.0).sqrt()
    }

    /// The tangent of the fiber a ray along `d` meets in slot `s`, chosen
    /// by `u` among the kept tangents in proportion to `|t × d|`.
    #[inline]
    pub fn fiber_met(&self, s: usize, d: Vec3, u: f32) -> Vec3 {
        let ts = &self.tangents[s];
        let w: [f32; TANGENTS] = std::array::from_fn(|j| ts[j].cross(d).length());
        let sum: f32 = w.iter().sum();
        if sum <= 0.0 {
            return ts[0];
        }
        let mut x = u * sum;
        for j in 0..TANGENTS {
            if x < w[j] {
                return ts[j];
            }
            x -= w[j];
        }
        ts[TANGENTS - 1]
    }

    /// Scales the fiber cross-section everywhere by `k` (calibration).
    pub fn scale(&mut self, k: f32) {
        for m in &mut self.moments {
            for x in m[..WEIGHT].iter_mut() {
                *x *= k;
            }
        }
    }

    /// The expected fibers crossed from `o` along unit `d` to the grid's
    /// edge (marched in quarter voxels).
    pub fn optical_depth(&self, o: Vec3, d: Vec3) -> f32 {
        let step = 0.25 * self.voxel;
        let mut tau = 0.0;
        let mut p = o + d * (0.5 * step);
        let limit = 4 * (self.dims[0] + self.dims[1] + self.dims[2]);
        for _ in 0..limit {
            let Some(v) = self.voxel_at(p) else { break };
            let s = self.slots[v][0];
            if s != u32::MAX {
                tau += self.sigma(s as usize, d) * step;
            }
            p += d * step;
        }
        tau
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.slots.len() * 8
            + self.empty.len()
            + self.moments.len() * (32 + TANGENTS * 12 + 4)
            + self.cells.slot.len() * 4
            + self.cells.cell_of.len() * 20
    }
}

/// `count` random walks of `points` points each in the unit box (their
/// steps up to `step / 2` along each axis, clamped to the box), of radius
/// `radius`, from the seed `seed` (for tests).
#[cfg(test)]
pub(super) fn random_strands(
    seed: u64,
    count: usize,
    points: usize,
    step: f32,
    radius: f32,
) -> Strands {
    let mut st = seed;
    let mut u = || {
        st = mix64(st);
        (st >> 40) as f32 / (1u64 << 24) as f32
    };
    let (mut pts, mut offsets) = (Vec::new(), vec![0u32]);
    for _ in 0..count {
        let mut p = Vec3::new(u(), u(), u());
        for _ in 0..points {
            pts.push(p);
            p = (p + step * (Vec3::new(u(), u(), u()) - 0.5)).clamp(Vec3::ZERO, Vec3::ONE);
        }
        offsets.push(pts.len() as u32);
    }
    Strands {
        radii: vec![radius; pts.len()],
        points: pts,
        offsets,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. The empty distance is the brute force's: per voxel, the least L∞
    ///    distance to a voxel holding hair, capped at [`EMPTY_REACH`].
    #[test]
    fn empty_distance_is_the_brute_force() {
        let dims = [13, 9, 11];
        let n = dims[0] * dims[1] * dims[2];
        let mut st = 0x9e37_79b9_7f4a_7c15u64;
        let hair: Vec<bool> = (0..n)
            .map(|_| {
                st = mix64(st);
                st % 97 == 0
            })
            .collect();
        let at = |v: usize| {
            [
                v % dims[0],
                (v / dims[0]) % dims[1],
                v / (dims[0] * dims[1]),
            ]
        };
        let got = empty_distance(|v| hair[v], dims);
        let mut seen = [0usize; EMPTY_REACH as usize + 1];
        for v in 0..n {
            let p = at(v);
            let want = (0..n)
                .filter(|&u| hair[u])
                .map(|u| {
                    let q = at(u);
                    (0..3).map(|k| p[k].abs_diff(q[k])).max().unwrap()
                })
                .min()
                .map_or(EMPTY_REACH, |x| x.min(EMPTY_REACH as usize) as u8);
            assert_eq!(got[v], want, "voxel {p:?}");
            seen[want as usize] += 1;
        }
        // the grid has hair, voxels at every distance, and capped ones
        assert!(seen.iter().all(|&c| c > 0), "{seen:?}");
    }

    /// 2. The cells are numbered along the Morton curve, and each is the
    ///    cell of its voxels: slot and dense index map to each other one to
    ///    one, the Morton codes rise with the slot, every voxel holding hair
    ///    names the cell it lies in, and each cell's weight is the sum of
    ///    its voxels' (written out, in the voxels' order; 300 random
    ///    strands in a unit box, 24 voxels a side).
    #[test]
    fn cells_follow_the_morton_curve() {
        let scene = Scene::of_strands(random_strands(0x2545_f491_4f6c_dd1d, 300, 6, 0.1, 0.002));
        let m = Medium::new(&scene, 24).unwrap();
        let c = &m.cells;
        let key = |n: u32| morton_of_cell(n, c.dims);
        assert!(c.cell_of.len() > 100, "{} cells", c.cell_of.len());
        for (s, &n) in c.cell_of.iter().enumerate() {
            assert_eq!(c.slot[n as usize], s as u32);
            if s > 0 {
                assert!(key(c.cell_of[s - 1]) < key(n), "slot {s}");
            }
        }
        assert_eq!(
            c.slot.iter().filter(|&&s| s != u32::MAX).count(),
            c.cell_of.len()
        );
        let d = m.dims;
        let mut weight = vec![0.0f32; c.cell_of.len()];
        for (&v, mo) in m.voxel_of.iter().zip(&m.moments) {
            let v = v as usize;
            let (i, j, k) = (v % d[0], (v / d[0]) % d[1], v / (d[0] * d[1]));
            let n = ((k / FINE) * c.dims[1] + j / FINE) * c.dims[0] + i / FINE;
            let s = m.slots[v][1];
            assert_eq!(s, c.slot[n], "voxel {v}");
            // (no spheres: every voxel is free)
            weight[s as usize] += mo[WEIGHT] / (FINE * FINE * FINE) as f32;
        }
        assert_eq!(weight, c.weight);
    }

    /// 3. The memory estimate's count is the medium's: [`Occupancy::of`]
    ///    finds as many voxels and cells holding hair as [`Medium::new`]
    ///    gives slots, and the dense grids' sizes (random strands, one
    ///    segment of zero length, a short strand added; 24 and 37 voxels
    ///    a side).
    #[test]
    fn occupancy_counts_the_slots_the_medium_builds() {
        let mut st = random_strands(0x9e37_79b9_7f4a_7c15, 200, 8, 0.2, 0.003);
        let p = st.points[3];
        st.points[4] = p;
        st.radii.extend([0.003, 0.003]);
        st.points
            .extend([Vec3::splat(0.5), Vec3::new(0.5, 0.5, 0.51)]);
        st.offsets.push(st.points.len() as u32);
        let scene = Scene::of_strands(st);
        let hair = crate::raster::density::hair_box_of(&scene).unwrap();
        for resolution in [24, 37] {
            let m = Medium::new(&scene, resolution).unwrap();
            let o = Occupancy::of(&scene, hair, resolution).unwrap();
            assert_eq!(o.hair_voxels, m.moments.len(), "at {resolution}");
            assert_eq!(o.hair_cells, m.cells.cell_of.len(), "at {resolution}");
            assert_eq!(o.voxels, m.slots.len());
            assert_eq!(o.cells, m.cells.slot.len());
            assert!(o.hair_cells < o.cells && o.hair_voxels < o.voxels);
        }
    }
}
