//! Multiple scattering carried through the hair volume
//! (`multiple_scattering: "volume"`), after Moon, Walter & Marschner 2008.
//!
//! 1. **The medium** ([`medium`]): the strands as oriented fibers on a voxel
//!    grid; a ray along ω crosses σt(ω) = √(S² − S ωᵀMω) fibers per unit
//!    length (Jakob et al. 2010), so light runs far along combed hair.
//! 2. **The transport** ([`trace`]): photons from every light and every
//!    environment direction (the quadrature of [`super::env_light`]) fly
//!    through the medium, scatter off the fiber they meet by the material's
//!    own scattering (ChiangHair's sampling at a random offset, so that each
//!    event has the fiber's albedo and keeps light on its cone; KarisHair's
//!    lobes), reflect off opaque spheres, with Russian roulette and at most
//!    [`trace::MAX_EVENTS`] events.
//! 3. **The radiance**: after its first scattering, a photon's track length
//!    is tallied per cell (in the voxels holding hair, each weighted by its
//!    fibers) and direction bin (octahedral, [`bins`]): the fluence
//!    `Φ_b(x) = ∫_b L(x, ω) dω` of light scattered at least once, averaged
//!    over the cell's fibers, with its mean direction where the fragments
//!    read it ([`VolumeDirections::Mean`]). Under the strands
//!    transport, light is tallied per group of the strand that last
//!    scattered it ([`trace::GROUPS`]). The tallies are filtered by a local
//!    linear fit over each cell's neighbours ([`smooth`]; twice below
//!    2^20 photons a light, [`smoothing_passes`]).
//! 4. **A fragment** at `x` with tangent `t` seen from `v` reads it
//!    (trilinear over the cells that hold hair, weighted by their fibers)
//!    and scatters it once more
//!    by the far field: `L_ms = Σ_b f_σb(t, v, −ω_b) Φ_b(x)`, where `f × E`
//!    is what a directional light of irradiance `E` gives, `ω_b` the bin's
//!    mean direction and `f_σb` the response blurred by the spread of the
//!    bin's light about it ([`response`]; or, with
//!    [`VolumeDirections::Centre`], the bin's centre and the spread of a
//!    uniform light over the bin: linear in the tallies, less noise from
//!    few photons), normalized so that a radiance of
//!    1 from everywhere gives the fiber's albedo exactly ([`fold`]: the
//!    few bins integrate a response peaked on the fiber's cone unevenly,
//!    0.94-1.03 of it at 8 × 8 bins). With groups, a fiber reads only
//!    the light of the other groups' strands, scaled up by their share: a
//!    fiber is never lit by what it has just scattered itself, and a cell
//!    holding few fibers would otherwise count it (measured on blond_back:
//!    the multiple scattering 1.03/1.05/1.09 of the truth's at 128 cells a
//!    side, 0.97/0.99/1.02 read this way; 0.98/0.99/0.99 at 48 either way).
//!
//! The direct light stays the renderer's single scattering (traced or
//! mapped shadows); the volume holds only light that scattered, so nothing
//! is counted twice. Computed once per (geometry, lights, environment,
//! material, settings) and kept ([`cached`]): a new view reads it again.
//! The sums are integers added atomically, so the result is the same at
//! every thread count.

pub mod bins;
mod cache;
mod calibration;
pub mod medium;
pub mod response;
mod smooth;
pub mod trace;

pub use cache::{cached, CACHE_SOLVES, CACHE_TABLES};
use cache::{medium_of, response_table, BuiltMedium};
use calibration::{calibrate, calibration_rays};
pub use calibration::{Calibration, CALIBRATION_RAYS};

use crate::lru::{keep, kept};
use crate::raster::env_light::EnvLights;
use crate::raster::scene::{
    HairShading, Light, RenderOptions, Scene, VolumeDirections, VolumeTransport,
};
use crate::threads::pool;
use bins::Bins;
use glam::Vec3;
use medium::Medium;
use rayon::prelude::*;
use smooth::smooth;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use trace::{Emitter, Phase, Rng, Tally};

/// Photons per parallel chunk (the cancel flag is polled between chunks).
const CHUNK: usize = 2048;

/// Progress steps a solve counts in a render's progress ([`crate::raster::progress_total`]).
pub const PROGRESS_STEPS: usize = 100;

/// Inclusive ranges of the settings.
pub const RESOLUTION: (usize, usize) = (8, 256);
pub const PHOTONS: (usize, usize) = (1, 1 << 26);
pub const BINS: (usize, usize) = (1, 16);

/// The settings of the solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct VolumeSettings {
    /// Cells (of the light's tallies) along the longest side of the hair's
    /// bounds; the medium has [`medium::FINE`] times as many voxels.
    pub resolution: usize,
    /// Photons per light, the environment counted as one (traced all
    /// together, shared among the lights and the environment's directions
    /// by power).
    pub photons: usize,
    /// Octahedral direction bins per side (`bins²` per voxel).
    pub bins: usize,
    /// How the photons fly.
    pub transport: VolumeTransport,
    /// Which direction each bin's light is read from ([`fold`]).
    pub directions: VolumeDirections,
}

impl VolumeSettings {
    pub fn of(opts: &RenderOptions) -> Self {
        Self {
            resolution: opts.volume_resolution,
            photons: opts.volume_photons,
            bins: opts.volume_bins,
            transport: opts.volume_transport,
            directions: opts.volume_directions,
        }
    }
}

/// The multiple-scattered radiance of one lighting of one groom.
pub struct VolumeRadiance {
    /// The medium and its calibration, shared by the solves of one
    /// geometry ([`medium_of`]).
    medium: Arc<BuiltMedium>,
    bins: Bins,
    /// Strand groups tallied apart ([`trace::GROUPS`] under the strands
    /// transport, else 1).
    groups: usize,
    /// Per occupied voxel, group and bin, [`words`] floats: the RGB
    /// fluence of scattered light and, under [`VolumeDirections::Mean`],
    /// its mean propagation direction times its mean over RGB.
    fluence: Vec<f32>,
    /// The bins' tally of a radiance of 1 from every direction
    /// ([`Bins::uniform_field`]) as [`fold`] reads it, which it normalizes
    /// by.
    uniform: Vec<BinLight>,
    /// The fiber's far-field response ([`response`]), shared by the solves
    /// of one material ([`response_table`]).
    response: Arc<response::ResponseTable>,
    /// Which direction each bin's light is read from ([`fold`]).
    directions: VolumeDirections,
    /// Seconds the solve took.
    pub solve_seconds: f64,
    /// The medium's calibration against the strands (None under the
    /// strands transport, whose photons never read the medium's
    /// cross-section: they fly between the strands themselves).
    pub calibration: Option<Calibration>,
}

/// Bytes the solve of `scene` (whose hair box is `hair`:
/// [`crate::raster::density::hair_box_of`]) with `s` needs at most (the
/// medium, the integer tallies and the fluence, the response table),
/// before anything is allocated.
pub fn bytes_estimate(scene: &Scene, hair: (glam::Vec3, glam::Vec3), s: &VolumeSettings) -> usize {
    let Some(o) = occupancy(scene, hair, s.resolution * medium::FINE) else {
        return 0;
    };
    let groups = match s.transport {
        VolumeTransport::Strands => trace::GROUPS,
        VolumeTransport::Medium => 1,
    };
    o.medium_bytes()
        + o.hair_cells * groups * s.bins * s.bins * words(s.directions) * (8 + 4)
        + response::ResponseTable::BYTES
}

/// [`medium::Occupancy::of`], kept for the last few (geometry,
/// resolution): counting walks every strand piece (41 ms for 25k random
/// strands of 16 segments at 96 voxels a side), while a frame that reuses
/// its solve hashes only the geometry.
fn occupancy(scene: &Scene, hair: (Vec3, Vec3), resolution: usize) -> Option<medium::Occupancy> {
    type Counts = std::sync::Mutex<Vec<(u64, Arc<Option<medium::Occupancy>>)>>;
    static COUNTS: std::sync::OnceLock<Counts> = std::sync::OnceLock::new();
    let counts = COUNTS.get_or_init(|| std::sync::Mutex::new(Vec::new()));
    let key = {
        let mut h = crate::raster::shadow::WordHash::default();
        h.word(crate::raster::shadow::geometry_hash(scene));
        h.word(resolution as u64);
        h.finish()
    };
    if let Some(o) = kept(counts, &key) {
        return *o;
    }
    let o = medium::Occupancy::of(scene, hair, resolution);
    keep(counts, key, Arc::new(o), CACHE_SOLVES);
    o
}

/// What a solve reads: the scene, its strands' world segments and, when
/// the render traces shadows, their grid (the calibration traces through it,
/// or through one it builds), and the environment's directions.
pub struct SolveInput<'a> {
    pub scene: &'a Scene,
    /// [`crate::raster::shadow::geometry_hash`] of the scene (the cache's key).
    pub geometry: u64,
    pub segments: &'a [crate::raster::setup::WorldSegment],
    pub traced: Option<&'a crate::raster::traced::SegmentGrid>,
    pub env: Option<&'a EnvLights>,
}

impl VolumeRadiance {
    /// Solves the transport of the scene's lights and the environment's
    /// directions (None: cancelled, or no hair).
    pub fn solve(
        input: &SolveInput,
        settings: VolumeSettings,
        cancel: Option<&AtomicBool>,
        progress: Option<&AtomicUsize>,
    ) -> Option<Self> {
        let (scene, env) = (input.scene, input.env);
        let t0 = std::time::Instant::now();
        let built;
        let grid = match input.traced {
            Some(g) => Some(g),
            None => {
                built = crate::raster::traced::SegmentGrid::new(input.segments);
                built.as_ref()
            }
        };
        // the strands photons fly between (None: through the medium), and
        // the groups their tallies keep apart
        let strands = grid.filter(|_| settings.transport == VolumeTransport::Strands);
        let groups = if strands.is_some() { trace::GROUPS } else { 1 };
        let built_medium = medium_of(input, settings.resolution, grid, strands.is_some())?;
        let (medium, calibration) = (&built_medium.0, built_medium.1);
        let bins = Bins {
            n: settings.bins.clamp(BINS.0, BINS.1),
        };
        let size = Vec3::new(
            medium.dims[0] as f32,
            medium.dims[1] as f32,
            medium.dims[2] as f32,
        ) * medium.voxel;
        let (c, r) = (medium.origin + 0.5 * size, 0.5 * size.length());
        let lights: Vec<&Light> = scene
            .lights
            .iter()
            .chain(env.into_iter().flat_map(|e| e.lights.iter()))
            .collect();
        let emitters: Vec<Emitter> = lights.iter().map(|l| Emitter::new(l, c, r)).collect();
        let total: f64 = emitters.iter().map(|e| e.power as f64).sum();
        let slots = medium.cells.cell_of.len();
        let words = words(settings.directions);
        let sums = zeroed_atomics(slots * groups * bins.count() * words);
        // photons per light, the environment counted as one light
        let sources = scene.lights.len() + usize::from(env.is_some_and(|e| !e.lights.is_empty()));
        let n = settings.photons.saturating_mul(sources.max(1));
        if total > 0.0 && n > 0 {
            let cdf: Vec<f64> = emitters
                .iter()
                .scan(0.0, |a, e| {
                    *a += e.power as f64 / total;
                    Some(*a)
                })
                .collect();
            // KarisHair's single scattering (its own multiple-scattering
            // term is what the volume replaces)
            let karis = match &scene.hair {
                HairShading::Karis(k) => Some(k.single_scattering()),
                _ => None,
            };
            let phase = match (&scene.hair, &karis) {
                (HairShading::ChiangFar(c), _) => Phase::Chiang(c.model()),
                (HairShading::Karis(_), Some(k)) => Phase::Karis(k),
                _ => return None,
            };
            let tally = Tally {
                sums: &sums,
                bins,
                groups,
                words,
            };
            let transport = trace::Transport {
                medium,
                phase: &phase,
                spheres: &scene.spheres,
                tally: &tally,
                strands,
            };
            let chunks = n.div_ceil(CHUNK);
            pool().install(|| {
                (0..chunks).into_par_iter().for_each(|ci| {
                    if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                        return;
                    }
                    if let Some(p) = progress {
                        // chunk ci's share of the steps (they sum to all of them)
                        let share = |c: usize| c * PROGRESS_STEPS / chunks;
                        p.fetch_add(share(ci + 1) - share(ci), Ordering::Relaxed);
                    }
                    for i in ci * CHUNK..((ci + 1) * CHUNK).min(n) {
                        let mut rng = Rng::new(i as u64 ^ 0x5851_F42D_4C95_7F2D);
                        // emitter by power, start by the R2 sequence
                        let x = rng.uniform() as f64;
                        let e = cdf.partition_point(|&a| a <= x).min(emitters.len() - 1);
                        let em = &emitters[e];
                        let g = 1.324_718;
                        let u = [
                            (0.5 + i as f64 / g).fract() as f32,
                            (0.5 + i as f64 / (g * g)).fract() as f32,
                        ];
                        let (o, d) = em.start(u);
                        // power / (pmf · n) = tint · total / n: the tint in
                        // units of the mean photon
                        trace::trace(&transport, trace::Photon { o, d, w: em.tint }, &mut rng);
                    }
                });
            });
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return None;
            }
        }
        // fluence = (power per photon) Σ w ℓ / V, tallied as Σ w ℓ/voxel
        let per_photon = if n > 0 { total / n as f64 } else { 0.0 };
        let scale = (per_photon / trace::FIXED / (medium.cells.size as f64).powi(2)) as f32;
        // per unit of the cell's fibers (its voxels' free volume weighted
        // by their fibers, as the track lengths were)
        let nb = bins.count() * groups;
        // cell by cell, in parallel: its rows converted, then each group's
        // replaced by the other groups' light
        let mut fluence = vec![0.0f32; sums.len()];
        pool().install(|| {
            fluence
                .par_chunks_mut(nb.max(1) * words)
                .zip(sums.par_chunks(nb.max(1) * words))
                .zip(&medium.cells.weight)
                .for_each(|((rows, tallies), &weight)| {
                    let s = scale / weight;
                    for (i, (x, c)) in rows.iter_mut().zip(tallies).enumerate() {
                        let c = c.load(Ordering::Relaxed);
                        // RGB sums, then signed direction sums
                        *x = if i % words < 3 {
                            c as f32
                        } else {
                            c as i64 as f32
                        } * s;
                    }
                    others(rows, bins.count() * words, groups);
                })
        });
        drop(sums);
        // the tallies' noise filtered in space (measured on blond_back and
        // blond_env at 2^20 photons: relMSE 2.15e-2 -> 2.06e-2 and
        // 3.34e-3 -> 3.04e-3 by one pass), twice below 2^20 photons
        // (two buffers passed back and forth: the second's pages are first
        // touched by the parallel writes of the first pass)
        let passes = smoothing_passes(settings.photons);
        let mut spare = vec![0.0f32; if passes > 0 { fluence.len() } else { 0 }];
        for _ in 0..passes {
            smooth(
                &medium.cells,
                &fluence,
                &mut spare,
                bins.count() * groups,
                words,
            );
            std::mem::swap(&mut fluence, &mut spare);
        }
        drop(spare);
        let response = response_table(&scene.hair);
        Some(Self {
            medium: built_medium.clone(),
            bins,
            groups,
            fluence,
            uniform: bin_lights(&bins.uniform_field()),
            response,
            directions: settings.directions,
            calibration,
            solve_seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.medium.0.bytes() + self.fluence.len() * 4 + self.response.bytes()
    }

    /// Occupied voxels.
    pub fn voxels(&self) -> usize {
        self.medium.0.cells.cell_of.len()
    }

    /// The scattered light at `p` scattered once more towards the eye `v`
    /// by a fiber of tangent `t`: `Σ_b f(t, v, l_b) Φ_b(p)`, with `f` the
    /// fiber's response to a directional light of unit irradiance from
    /// `l` (read from [`response`]).
    ///
    /// With strand groups, a fiber of `strand` reads the light the other
    /// groups' strands scattered, times the groups over the others (its
    /// group's row, [`others`]): light that a strand scatters never meets
    /// that strand again at once, and the cell's whole tally would count
    /// it there (measured: the multiple scattering 3-9% too bright at 128
    /// cells a side). A point of no strand reads the mean of the rows
    /// (every group's light).
    pub fn radiance(&self, p: Vec3, t: Vec3, v: Vec3, strand: u32) -> Vec3 {
        let m = &self.medium.0.cells;
        let nb = self.bins.count();
        let (row_of, gain) = if self.groups > 1 && strand != crate::raster::shadow::NO_STRAND {
            (Some(trace::group_of(strand)), 1.0)
        } else {
            (None, 1.0 / self.groups as f32)
        };
        let q = (p - m.origin) / m.size - Vec3::splat(0.5);
        let base = crate::math::floor3(q);
        let fr = q - base;
        // every bin count the settings allow (BINS.1² at most) fits
        let mut acc = [[0.0f32; 6]; BINS.1 * BINS.1];
        let acc = &mut acc[..nb];
        let mut wsum = 0.0;
        for corner in 0..8 {
            let (dx, dy, dz) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let (i, j, k) = (base.x as i64 + dx, base.y as i64 + dy, base.z as i64 + dz);
            let Some(v) = medium::dense_index(m.dims, i, j, k) else {
                continue;
            };
            let s = m.slot[v];
            if s == u32::MAX {
                continue;
            }
            // trilinear, times the cell's fibers
            let w = m.weight[s as usize]
                * (if dx == 1 { fr.x } else { 1.0 - fr.x })
                * (if dy == 1 { fr.y } else { 1.0 - fr.y })
                * (if dz == 1 { fr.z } else { 1.0 - fr.z });
            if w <= 0.0 {
                continue;
            }
            wsum += w;
            let s = s as usize;
            let words = words(self.directions);
            let span = nb * self.groups * words;
            let cell = &self.fluence[s * span..(s + 1) * span];
            for (g, row) in cell.chunks_exact(nb * words).enumerate() {
                if row_of.is_some_and(|own| own != g) {
                    continue;
                }
                for (a, r) in acc.iter_mut().zip(row.chunks_exact(words)) {
                    for k in 0..words {
                        a[k] += w * gain * r[k];
                    }
                }
            }
        }
        if wsum <= 0.0 {
            return Vec3::ZERO;
        }
        fold(&self.response, acc, &self.uniform, self.directions, t, v) / wsum
    }
}

/// Filter passes over the tallies ([`smooth`]'s 3×3×3 local linear fit;
/// applied twice, a wider kernel that still keeps a linear fluence):
/// fewer photons, more noise, a wider filter. Measured against the truth
/// (`accurate`, 320x180, four groups, relMSE, one pass -> two; scratch
/// builds): at 2^16 photons a light blond_back 8.95e-3 -> 7.62e-3,
/// curly_blond_env 5.33e-3 -> 4.05e-3 (the white furnace's noise per
/// pixel 0.24 -> 0.19); at 2^20,
/// blond_back 4.07e-3 -> 4.38e-3, wavy_blond_rim 2.90e-3 -> 2.96e-3,
/// curly_blond_env 2.78e-3 -> 2.61e-3, clumped_blond_key 2.68e-3 ->
/// 2.65e-3: there the filter's bias has caught up with the noise it
/// removes, and one pass is kept. A 5×5×5 fit did as well as two passes
/// at over twice the cost; a weighted mean (no slope) darkened the
/// rim-lit head by 2%.
fn smoothing_passes(photons: usize) -> usize {
    if photons >= 1 << 20 {
        1
    } else {
        2
    }
}

/// Tallied words per bin: RGB, and the summed propagation direction
/// where the fold reads it ([`VolumeDirections::Mean`]).
fn words(directions: VolumeDirections) -> usize {
    match directions {
        VolumeDirections::Mean => trace::WORDS,
        VolumeDirections::Centre => 3,
    }
}

/// `n` atomic words, zero: allocated zeroed (large blocks come from the
/// system's zero pages, touched lazily by whichever thread tallies there
/// first, rather than written once on one thread).
fn zeroed_atomics(n: usize) -> Vec<AtomicU64> {
    let layout =
        std::alloc::Layout::array::<AtomicU64>(n).expect("tallies larger than the address space");
    if layout.size() == 0 {
        return Vec::new();
    }
    // SAFETY: the layout is non-empty and is AtomicU64's own; all-zero
    // bytes are a valid AtomicU64 (zero); the vector owns the block with
    // length and capacity n, and frees it with the same layout.
    unsafe {
        let p = std::alloc::alloc_zeroed(layout) as *mut AtomicU64;
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Vec::from_raw_parts(p, n, n)
    }
}

/// Per cell, each group's row of `fluence` (`nb` floats, `groups` rows a
/// cell) replaced by the light of the other groups, times
/// `groups / (groups − 1)`: what a fiber of that group reads
/// ([`VolumeRadiance::radiance`]), one row for any number of groups. The
/// mean of the rows is the cell's whole light. One group: unchanged.
fn others(fluence: &mut [f32], nb: usize, groups: usize) {
    if groups < 2 || nb == 0 {
        return;
    }
    let gain = groups as f32 / (groups - 1) as f32;
    for cell in fluence.chunks_exact_mut(nb * groups) {
        for b in 0..nb {
            let total: f32 = (0..groups).map(|g| cell[g * nb + b]).sum();
            for g in 0..groups {
                let x = &mut cell[g * nb + b];
                *x = (total - *x) * gain;
            }
        }
    }
}

/// A bin's light as [`fold`] reads it: the direction it comes from
/// (against its mean propagation), its spread about it (from its mean
/// resultant length), and its RGB fluence.
#[derive(Debug, Clone, Copy)]
struct BinLight {
    l: Vec3,
    sigma: f32,
    rgb: Vec3,
}

impl BinLight {
    /// The light of a bin's tally (RGB fluence, then its summed
    /// propagation direction); None for a bin without light.
    #[inline]
    fn of(a: &[f32; 6]) -> Option<Self> {
        let sum = a[0] + a[1] + a[2];
        if !(sum > 0.0) {
            return None;
        }
        let mean = Vec3::new(a[3], a[4], a[5]);
        let r_bar = mean.length() * 3.0 / sum;
        Some(Self {
            l: -mean.normalize_or_zero(),
            sigma: response::spread_of(r_bar),
            rgb: Vec3::new(a[0], a[1], a[2]),
        })
    }

    /// `f_σ(t, v, l) Φ`: this light scattered towards the view of
    /// `sin θv = sv` (`v_n`: the view's unit projection on the normal
    /// plane) by a fiber of tangent `t`.
    #[inline]
    fn scattered(&self, response: &response::ResponseTable, t: Vec3, sv: f32, v_n: Vec3) -> Vec3 {
        let sl = t.dot(self.l).clamp(-1.0, 1.0);
        let l_n = self.l - t * sl;
        let len = l_n.length();
        let cos_phi = if len > 0.0 {
            (v_n.dot(l_n) / len).clamp(-1.0, 1.0)
        } else {
            1.0
        };
        response.eval_spread(sv, sl, response::acos(cos_phi), self.sigma) * self.rgb
    }
}

/// The lights of tallies `acc` (bins without light left out).
fn bin_lights(acc: &[[f32; 6]]) -> Vec<BinLight> {
    acc.iter().filter_map(BinLight::of).collect()
}

/// `Σ_b f_σb(t, v, l_b) Φ_b`: each bin's fluence `Φ_b` (RGB, then its
/// summed propagation direction) scattered towards `v` by a fiber of
/// tangent `t`, read from the light's mean direction `l_b` (against its
/// propagation) and spread `σ_b` (from its mean resultant length), or,
/// with [`VolumeDirections::Centre`], from the bin's own direction and
/// spread under a uniform radiance (`uniform`'s: linear in the tallies);
/// normalized so that the bins of a uniform radiance give the fiber's
/// albedo towards `v` exactly.
///
/// Why the bins' own directions: a bin that a few photons crossed has a
/// noisy mean direction, and the response, peaked on the fiber's cone,
/// turns that noise into error. Measured on blond_back (`balanced` at
/// 2^16 photons, 6 × 6 bins, unfiltered, 320×180): relMSE against the
/// truth 1.12e-2 read at the mean directions, 7.8e-3 at the bins'; at
/// 8 × 8 bins, 2^17 photons and 64 samples, 5.8e-3 and 4.8e-3. With many
/// photons the mean direction is the sharper reading: `accurate`'s rim-lit
/// wavy blond head reads 0.957 of its truth's red at the mean directions,
/// 0.947 at the bins'.
///
/// A few dozen bins integrate a response that peaks on the fiber's cone
/// unevenly: a radiance of 1 from every direction read at 8 × 8 bins gives
/// 0.94-1.03 of the albedo depending on how the fiber lies among the bins
/// (0.67-1.13 at 4 × 4; volume test 4), and white fibers under a white
/// environment came out 5.5% dark. The factor `a(θv) / fold(uniform)`, per
/// channel, is the quadrature's own error at that fiber and view (the
/// renormalization of a discretized phase function in discrete-ordinates
/// transport).
fn fold(
    response: &response::ResponseTable,
    acc: &[[f32; 6]],
    uniform: &[BinLight],
    directions: VolumeDirections,
    t: Vec3,
    v: Vec3,
) -> Vec3 {
    let sv = t.dot(v).clamp(-1.0, 1.0);
    let v_n = (v - t * sv).normalize_or_zero();
    let raw = match directions {
        VolumeDirections::Mean => acc
            .iter()
            .filter_map(BinLight::of)
            .fold(Vec3::ZERO, |s, b| s + b.scattered(response, t, sv, v_n)),
        // (every bin holds light under a uniform radiance: `uniform` has
        // one light per bin, in the bins' order)
        VolumeDirections::Centre => acc.iter().zip(uniform).fold(Vec3::ZERO, |s, (a, u)| {
            if a[0] + a[1] + a[2] > 0.0 {
                let b = BinLight {
                    rgb: Vec3::new(a[0], a[1], a[2]),
                    ..*u
                };
                s + b.scattered(response, t, sv, v_n)
            } else {
                s
            }
        }),
    };
    let u = uniform
        .iter()
        .fold(Vec3::ZERO, |s, b| s + b.scattered(response, t, sv, v_n));
    let a = response.albedo(sv);
    let norm = |c: usize| if u[c] > 0.0 { a[c] / u[c] } else { 1.0 };
    Vec3::new(raw.x * norm(0), raw.y * norm(1), raw.z * norm(2))
}

#[cfg(test)]
mod tests;
