//! Particle tracing through the fiber medium: photons leave the lights,
//! fly by the medium's direction-dependent extinction (regular tracking
//! voxel by voxel), scatter off the fiber they meet by the material's own
//! scattering, reflect off opaque spheres by their albedo, and after their
//! first scattering deposit their track length per voxel and direction bin.

use super::bins::Bins;
use super::medium::{mix64, Medium};
use crate::fiber::chiang::ChiangHair;
use crate::fiber::karis::{KarisHair, Transmittance};
use crate::raster::scene::{Light, Sphere};
use glam::Vec3;

/// Scattering events a photon may take: a path of Mitsuba's `max_depth` 64
/// has at most 63 scattering vertices, the last one the camera's.
pub const MAX_EVENTS: u32 = 62;

/// Events before Russian roulette starts.
const ROULETTE_AFTER: u32 = 4;

/// A random stream per photon (splitmix64), the same in every thread.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(mix64(seed))
    }
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        ((mix64(self.0) >> 40) as f32 + 0.5) * (1.0 / (1u64 << 24) as f32)
    }
}

/// How a fiber scatters a photon.
pub enum Phase<'a> {
    /// ChiangHair's importance sampling (the near field at a uniformly
    /// random offset h across the fiber, as a ray meets it).
    Chiang(&'a ChiangHair<f32>),
    /// KarisHair: a uniformly random direction weighted by the model.
    Karis(&'a KarisHair<f32>),
}

impl Phase<'_> {
    /// A photon moving along `d` meets a fiber of tangent `t`: its new
    /// direction and the factor its power takes (None: absorbed).
    pub fn scatter(&self, d: Vec3, t: Vec3, rng: &mut Rng) -> Option<(Vec3, Vec3)> {
        let wi = -d;
        match self {
            Phase::Chiang(m) => {
                // the normal plane's direction of wi, and the normal that
                // puts wi at offset h = sin γ
                let along = wi - t * t.dot(wi);
                let p = along
                    .try_normalize()
                    .unwrap_or_else(|| t.any_orthonormal_vector());
                let q = t.cross(p);
                let h = 2.0 * rng.uniform() - 1.0;
                let (sin_g, cos_g) = (h, (1.0 - h * h).max(0.0).sqrt());
                let z = p * cos_g + q * sin_g;
                let x = t.cross(z);
                let local = [wi.dot(x), wi.dot(t), wi.dot(z)];
                let (u1, u2, u3) = (rng.uniform(), rng.uniform(), rng.uniform());
                let (wo, weight, pdf) = m.sample(&local, u1, [u2, u3]);
                if !(pdf > 0.0) {
                    return None;
                }
                let o = x * wo[0] + t * wo[1] + z * wo[2];
                let w = Vec3::from(weight);
                (w.is_finite() && o.is_finite()).then_some((o.normalize_or_zero(), w))
            }
            Phase::Karis(k) => {
                // a uniform direction; the model read with the roles of
                // light and view swapped, so that its cosine is the
                // outgoing direction's (the photon's scattering density)
                let z = 1.0 - 2.0 * rng.uniform();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let a = std::f32::consts::TAU * rng.uniform();
                let o = Vec3::new(r * a.cos(), r * a.sin(), z);
                let f = k.eval(
                    &o.to_array(),
                    &wi.to_array(),
                    &t.to_array(),
                    &Transmittance::default(),
                );
                let w = Vec3::from(f) * (4.0 * std::f32::consts::PI);
                w.is_finite().then_some((o, w.max(Vec3::ZERO)))
            }
        }
    }
}

/// A light as photons leave it: its power towards the hair's bounding
/// sphere and how a photon starts.
pub struct Emitter {
    /// Mean over RGB of the power, and the RGB power over that mean.
    pub power: f32,
    pub tint: Vec3,
    start: Start,
}

/// Where a light's photons start, fixed per light.
enum Start {
    /// The disk of radius `r` facing a directional light, behind the
    /// bounding sphere (centre `c`): photons along `d`, `a` and `b` across.
    Disk {
        c: Vec3,
        r: f32,
        d: Vec3,
        a: Vec3,
        b: Vec3,
    },
    /// The cone from a point light towards the bounding sphere (the whole
    /// sphere of directions when the light is inside): `cos_a` its
    /// half-angle's cosine about `axis`, `a` and `b` across.
    Cone {
        position: Vec3,
        axis: Vec3,
        a: Vec3,
        b: Vec3,
        cos_a: f32,
    },
}

impl Emitter {
    /// `light` towards the bounding sphere of centre `c` and radius `r`.
    pub fn new(light: &Light, c: Vec3, r: f32) -> Self {
        let (p, start) = match *light {
            Light::Directional {
                direction,
                intensity,
                ..
            } => {
                let d = -direction.normalize();
                let (a, b) = d.any_orthonormal_pair();
                (
                    intensity * std::f32::consts::PI * r * r,
                    Start::Disk { c, r, d, a, b },
                )
            }
            Light::Point {
                position,
                intensity,
                ..
            } => {
                let to = c - position;
                let dist = to.length();
                let cos_a = if dist > r {
                    (1.0 - (r / dist).powi(2)).max(0.0).sqrt()
                } else {
                    -1.0
                };
                let axis = if dist > 0.0 { to / dist } else { Vec3::Z };
                let (a, b) = axis.any_orthonormal_pair();
                let start = Start::Cone {
                    position,
                    axis,
                    a,
                    b,
                    cos_a,
                };
                (intensity * std::f32::consts::TAU * (1.0 - cos_a), start)
            }
        };
        let power = (p.x + p.y + p.z) / 3.0;
        let tint = if power > 0.0 { p / power } else { Vec3::ZERO };
        Self {
            power: if power.is_finite() {
                power.max(0.0)
            } else {
                0.0
            },
            tint,
            start,
        }
    }

    /// A photon's start and direction from the unit square point `u` (the
    /// disk facing a directional light, or the cone of a point light
    /// towards the bounding sphere).
    pub fn start(&self, u: [f32; 2]) -> (Vec3, Vec3) {
        let phi = std::f32::consts::TAU * u[1];
        match self.start {
            Start::Disk { c, r, d, a, b } => {
                let rad = r * u[0].sqrt();
                (
                    c - d * (r * 1.01) + (a * phi.cos() + b * phi.sin()) * rad,
                    d,
                )
            }
            Start::Cone {
                position,
                axis,
                a,
                b,
                cos_a,
            } => {
                let z = 1.0 - u[0] * (1.0 - cos_a);
                let s = (1.0 - z * z).max(0.0).sqrt();
                (
                    position,
                    (axis * z + (a * phi.cos() + b * phi.sin()) * s).normalize(),
                )
            }
        }
    }
}

/// Where deposits go: per occupied voxel and direction bin, the RGB sums
/// and the sum of the directions weighted by their mean (the bin's mean
/// direction), in fixed point (2^-32 units of a photon's power times a
/// voxel's length), added atomically: integer sums (two's complement, wrapping)
/// do not depend on the order, so the result is the same at every thread
/// count.
pub struct Tally<'a> {
    pub sums: &'a [std::sync::atomic::AtomicU64],
    pub bins: Bins,
    /// Strand groups tallied apart ([`GROUPS`] under the strands
    /// transport, else 1).
    pub groups: usize,
    /// Words per bin: [`WORDS`] with the mean directions (what
    /// [`crate::raster::scene::VolumeDirections::Mean`] reads), else 3
    /// (RGB alone).
    pub words: usize,
}

/// Groups the strands transport tallies apart: light a strand scattered
/// is kept in its strand's group, so that a fiber reads only the light
/// that other strands scattered (`super::VolumeRadiance::radiance`).
///
/// Four, not two: a fiber then reads three quarters of the light, not a
/// half (measured in scratch builds at 2^16 / 2^18 photons a light,
/// `accurate`, two filter passes, relMSE against the truth, two groups
/// -> four: curly_blond_env 4.57e-3 -> 4.05e-3 / 3.08e-3 -> 2.86e-3,
/// wavy_blond_rim 4.69e-3 -> 4.41e-3 / 3.57e-3 -> 3.43e-3, blond_back
/// 7.86e-3 -> 7.62e-3 / 5.24e-3 -> 5.26e-3), at twice the tallies'
/// memory.
pub const GROUPS: usize = 4;

/// The group of `strand` (a hash, so that neighbouring strands of a clump
/// fall in any group): the hash's top log2([`GROUPS`]) bits.
#[inline]
pub fn group_of(strand: u32) -> usize {
    const { assert!(GROUPS.is_power_of_two() && GROUPS > 1) };
    (mix64(strand as u64 ^ 0x9E37_79B9) >> (64 - GROUPS.ilog2())) as usize
}

/// Words per voxel and bin: RGB, then the weighted direction.
pub const WORDS: usize = 6;

pub const FIXED: f64 = 4_294_967_296.0;

impl Tally<'_> {
    #[inline]
    fn add(&self, slot: usize, group: usize, bin: usize, w: Vec3, d: Vec3) {
        use std::sync::atomic::Ordering::Relaxed;
        let base = ((slot * self.groups + group) * self.bins.count() + bin) * self.words;
        for (c, x) in w.to_array().into_iter().enumerate() {
            let q = (x as f64 * FIXED) as u64;
            if q > 0 {
                self.sums[base + c].fetch_add(q, Relaxed);
            }
        }
        if self.words < WORDS {
            return;
        }
        let mean = (w.x + w.y + w.z) as f64 / 3.0;
        for (c, x) in d.to_array().into_iter().enumerate() {
            let q = (x as f64 * mean * FIXED) as i64;
            if q != 0 {
                self.sums[base + 3 + c].fetch_add(q as u64, Relaxed);
            }
        }
    }
}

/// A group drawn uniformly (light that no strand scattered).
#[inline]
fn random_group(groups: usize, rng: &mut Rng) -> usize {
    if groups > 1 {
        ((rng.uniform() * groups as f32) as usize).min(groups - 1)
    } else {
        0
    }
}

/// The box of the medium: `[lo, hi]`.
fn box_hit(m: &Medium, o: Vec3, d: Vec3) -> Option<(f32, f32)> {
    let lo = m.origin;
    let hi = m.origin + Vec3::new(m.dims[0] as f32, m.dims[1] as f32, m.dims[2] as f32) * m.voxel;
    let inv = d.recip();
    let (a, b) = ((lo - o) * inv, (hi - o) * inv);
    let t0 = a.min(b).max_element().max(0.0);
    let t1 = a.max(b).min_element();
    (t0 < t1 && t1.is_finite()).then_some((t0, t1))
}

/// The nearest sphere `o + t d` enters after `eps`, with its index.
fn sphere_hit(spheres: &[Sphere], o: Vec3, d: Vec3) -> Option<(f32, usize)> {
    let mut best: Option<(f32, usize)> = None;
    for (i, s) in spheres.iter().enumerate() {
        let oc = o - s.center;
        let b = oc.dot(d);
        let c = oc.length_squared() - s.radius * s.radius;
        let disc = b * b - c;
        if disc < 0.0 {
            continue;
        }
        let sq = disc.sqrt();
        let t = if -b - sq > 1e-6 { -b - sq } else { -b + sq };
        if t > 1e-6 && best.is_none_or(|(bt, _)| t < bt) && c > 0.0 {
            best = Some((t, i));
        }
    }
    best
}

/// A photon leaving its light: where from, which way, and its RGB power
/// in units of the mean photon's.
pub struct Photon {
    pub o: Vec3,
    pub d: Vec3,
    pub w: Vec3,
}

/// The medium and boundaries a photon flies through, and where its light
/// is tallied.
pub struct Transport<'a> {
    pub medium: &'a Medium,
    pub phase: &'a Phase<'a>,
    pub spheres: &'a [Sphere],
    pub tally: &'a Tally<'a>,
    /// The strands themselves: when set, photons fly between the fibers
    /// they really meet (traced through the strands' grid), and the medium
    /// only holds the tallies.
    pub strands: Option<&'a crate::raster::traced::SegmentGrid>,
}

/// The axis whose next voxel boundary the ray meets first (the least of
/// `t_next`; ties to the lower axis).
#[inline]
fn next_axis(t_next: &[f32; 3]) -> usize {
    if t_next[0] <= t_next[1] && t_next[0] <= t_next[2] {
        0
    } else if t_next[1] <= t_next[2] {
        1
    } else {
        2
    }
}

/// Traces one photon.
pub fn trace(tr: &Transport, photon: Photon, rng: &mut Rng) {
    let (m, phase, spheres, tally) = (tr.medium, tr.phase, tr.spheres, tr.tally);
    let Photon {
        mut o,
        mut d,
        mut w,
    } = photon;
    let mut events = 0u32;
    // the fiber the photon leaves (strand transport)
    let mut fiber = crate::raster::shade::Fiber::NONE;
    // the tally group of the light since the last event: its strand's, or
    // (off a sphere, or in the medium) either, at random
    let mut group = 0usize;
    let inv_voxel = 1.0 / m.voxel;
    let inv_cell = 1.0 / m.cells.size;
    loop {
        let sphere = sphere_hit(spheres, o, d);
        let t_sphere = sphere.map_or(f32::INFINITY, |s| s.0);
        // the flight: through the strands, the first fiber met; through
        // the medium, the optical depth to the next collision
        let hit = tr.strands.and_then(|g| g.first_hit(o, d, t_sphere, &fiber));
        let mut tau = if tr.strands.is_some() {
            f32::INFINITY
        } else {
            -(1.0 - rng.uniform()).ln()
        };
        let t_hit = hit.map_or(f32::INFINITY, |h| h.0);
        let mut collided = None;
        // the walk through the medium: for its collisions (medium
        // transport) and its tallies (after the first event; between the
        // strands, a light's own flight to its first fiber has neither)
        let walks = tr.strands.is_none() || events > 0;
        if let Some((t_in, t_out)) = box_hit(m, o, d).filter(|_| walks) {
            let t_end = t_out.min(t_sphere).min(t_hit);
            // regular tracking, voxel by voxel (Amanatides & Woo)
            let p = (o + d * t_in - m.origin) * inv_voxel;
            let dims = [m.dims[0] as i32, m.dims[1] as i32, m.dims[2] as i32];
            let mut ijk = [0i32; 3];
            let mut step = [0i32; 3];
            let mut t_next = [f32::INFINITY; 3];
            let mut t_delta = [f32::INFINITY; 3];
            for a in 0..3 {
                ijk[a] = (crate::math::floor(p[a]) as i32).clamp(0, dims[a] - 1);
                if d[a] > 0.0 {
                    step[a] = 1;
                    t_delta[a] = m.voxel / d[a];
                    t_next[a] = t_in + ((ijk[a] + 1) as f32 - p[a]) * m.voxel / d[a];
                } else if d[a] < 0.0 {
                    step[a] = -1;
                    t_delta[a] = -m.voxel / d[a];
                    t_next[a] = t_in + (ijk[a] as f32 - p[a]) * m.voxel / d[a];
                }
            }
            let bin = tally.bins.of(d);
            // the track length in the current cell, added once the flight
            // leaves it (a cell spans FINE³ voxels)
            let (mut run_cell, mut run) = (u32::MAX, 0.0f32);
            let flush = |cell: u32, len: f32| {
                if events > 0 && cell != u32::MAX && len > 0.0 {
                    tally.add(cell as usize, group, bin, w * (len * inv_cell), d);
                }
            };
            let mut t = t_in;
            'walk: while t < t_end {
                let a = next_axis(&t_next);
                let t1 = t_next[a].min(t_end);
                let v =
                    (ijk[2] as usize * m.dims[1] + ijk[1] as usize) * m.dims[0] + ijk[0] as usize;
                let len = (t1 - t).max(0.0);
                let [slot, cell] = m.slots[v];
                if cell != run_cell {
                    flush(run_cell, run);
                    (run_cell, run) = (cell, 0.0);
                }
                let reach = m.empty[v] as i32 - 1;
                if reach > 0 {
                    // no hair within `reach` voxels: on through them
                    // without reading them (the same steps as below, where
                    // they would add nothing)
                    let (lo, hi) = (ijk.map(|x| x - reach), ijk.map(|x| x + reach));
                    loop {
                        let a = next_axis(&t_next);
                        t = t_next[a].min(t_end);
                        ijk[a] += step[a];
                        t_next[a] += t_delta[a];
                        if ijk[a] < 0 || ijk[a] >= dims[a] {
                            break 'walk;
                        }
                        if !(t < t_end) || ijk[a] < lo[a] || ijk[a] > hi[a] {
                            break;
                        }
                    }
                    continue;
                }
                // the track length weighted by the voxel's fibers (none
                // outside the voxels holding hair: their cell is MAX)
                let mut weight = 0.0;
                if slot != u32::MAX {
                    let s = slot as usize;
                    weight = m.weight(s);
                    // the medium's collisions (between the strands, tau
                    // stays infinite and the cross-section is not read)
                    if tau < f32::INFINITY {
                        let sigma = m.sigma(s, d);
                        if sigma * len >= tau {
                            let tc = t + tau / sigma;
                            run += (tc - t) * weight;
                            collided = Some((tc, s));
                            break;
                        }
                        tau -= sigma * len;
                    }
                }
                run += len * weight;
                t = t1;
                ijk[a] += step[a];
                t_next[a] += t_delta[a];
                if ijk[a] < 0 || ijk[a] >= dims[a] {
                    break;
                }
            }
            flush(run_cell, run);
        }
        if events >= MAX_EVENTS {
            return;
        }
        if let Some((tc, t_fiber, met)) = hit {
            // a strand's fiber
            o += d * tc;
            fiber = met;
            group = if tally.groups > 1 {
                group_of(met.strand)
            } else {
                0
            };
            let Some((dn, f)) = phase.scatter(d, t_fiber, rng) else {
                return;
            };
            d = dn;
            w *= f;
        } else if let Some((tc, s)) = collided {
            // a fiber of the medium
            o += d * tc;
            let t = m.fiber_met(s, d, rng.uniform());
            group = random_group(tally.groups, rng);
            let Some((dn, f)) = phase.scatter(d, t, rng) else {
                return;
            };
            d = dn;
            w *= f;
        } else if let Some((ts, i)) = sphere {
            // an opaque sphere: diffuse reflection by its albedo
            let sp = &spheres[i];
            o += d * ts;
            let n = (o - sp.center).normalize();
            o = sp.center + n * (sp.radius * (1.0 + 1e-5));
            fiber = crate::raster::shade::Fiber::NONE;
            group = random_group(tally.groups, rng);
            let (a, b) = n.any_orthonormal_pair();
            let (u1, u2) = (rng.uniform(), rng.uniform());
            let r = u1.sqrt();
            let phi = std::f32::consts::TAU * u2;
            d = (a * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt())
                .normalize();
            w *= sp.albedo;
        } else {
            return;
        }
        events += 1;
        if events > ROULETTE_AFTER {
            let q = w.max_element().min(0.95);
            if !(q > 0.0) || rng.uniform() >= q {
                return;
            }
            w /= q;
        }
    }
}
