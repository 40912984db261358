//! The environment light for far-field fiber models (ChiangHair, DEonHair)
//! and for KarisHair under dual scattering.
//!
//! The radiance a fiber scatters towards the viewer from a band-2 SH
//! environment `L(ω)` is `∫ f(v, ω) L(ω) V(ω) dω`. It is computed by a fixed
//! spherical quadrature: `K` directions of a Fibonacci lattice (Swinbank &
//! Purser 2006), each with the weight `4π/K`, so that each direction acts as
//! a directional light of irradiance `L(ω_k)·4π/K` (clamped at 0, as the
//! background is). What reaches a fiber from direction `ω_k` is what the
//! fibers on the way let through: the fiber count `n` towards `ω_k` from a
//! density grid coarser than the render's ([`grid_resolution`]), and
//! `clear`, the part of the way free of opaque geometry (the head). Without dual scattering a fiber receives
//! `clear·e^{−n}` of each direction; with it, the dual-scattering terms of
//! [`crate::fiber::dual`] as for a light.
//!
//! The `n` of the unscattered part `clear·e^{−n}` is read half a voxel
//! towards the direction ([`super::density::UNSCATTERED_LOOKAHEAD`]); the
//! scattered part reads `n` at the point (light it carries has crossed the
//! fibers around the point as well).
//!
//! Error: the lattice undersamples the narrowest lobes (R at low roughness);
//! its directions are fixed, so the error is a deterministic pattern, not
//! noise. Measured against path tracing on `tests/data/dense/blond_env`.

use super::density::{DensityGrid, FiberCount, LightPath};
use super::scene::{Environment, HairShading, Light, MultipleScattering, Scene};
use crate::lighting::sh9_eval;
use glam::Vec3;
use rayon::prelude::*;

/// Quadrature directions: the default and the inclusive range of
/// `render.environment_directions`.
pub const DIRECTIONS: usize = 32;
pub const DIRECTIONS_RANGE: (usize, usize) = (8, 1024);

/// Whether an environment is shaded as these lights with fiber counts:
/// for every model but KarisHair, which shades it by its SH fake-normal
/// lobes, except under dual scattering (which needs the count towards each
/// direction).
pub fn as_lights(hair: &HairShading, ms: MultipleScattering) -> bool {
    !matches!(hair, HairShading::Karis(_))
        || matches!(ms, MultipleScattering::Dual | MultipleScattering::Volume)
}

/// The environment as directional lights, with the fiber count towards each.
pub struct EnvLights {
    pub lights: Vec<Light>,
    /// Per light (empty when the scene has no hair to count).
    pub counts: Vec<FiberCount>,
}

/// Voxels along the hair's longest side of the environment's count grid,
/// from the render's `density_resolution`: a quarter of it (at least 16)
/// where the counts also carry the environment's scattered light (`dual`
/// scattering, whose terms are smooth); half of it otherwise (the volume's
/// multiple scattering, or none), where they carry only the unscattered
/// light, whose shadows are sharp. Measured (`accurate`, the default 128:
/// 32 -> 64 voxels; relMSE against path tracing): curly_blond_env
/// 4.29e-3 -> 3.44e-3, blond_env 2.50e-3 -> 2.32e-3, wavy_black_env
/// 2.87e-3 -> 2.73e-3, curly_auburn_point 2.06e-3 -> 1.90e-3; at the full
/// 128 curly_blond_env reaches 3.14e-3 for 8 times the memory again. The
/// coarse grid's `e^{−n̄}` of a cell's mean count is below the cell's mean
/// `e^{−n}` (white fibers under a white environment, max_depth 2: 0.174 of
/// the environment at 32 voxels, 0.178 at 64, 0.183 at 128; Mitsuba
/// 0.1865).
pub fn grid_resolution(density_resolution: usize, dual: bool) -> usize {
    (density_resolution / if dual { 4 } else { 2 }).max(16)
}

/// `k`-th of `n` points of the Fibonacci lattice on the unit sphere.
fn fibonacci(k: usize, n: usize) -> Vec3 {
    let golden = std::f32::consts::PI * (3.0 - 5.0f32.sqrt());
    let y = 1.0 - (2.0 * k as f32 + 1.0) / n as f32;
    let r = (1.0 - y * y).max(0.0).sqrt();
    let phi = golden * k as f32;
    Vec3::new(r * phi.cos(), y, r * phi.sin())
}

impl EnvLights {
    /// The `count`-direction quadrature of `env` for `scene`, its fiber
    /// counts from a grid of `resolution` voxels along the hair's longest
    /// side ([`grid_resolution`]), swept in parallel on the render's pool (with
    /// `behind`, the counts away from each direction too).
    pub fn new(
        scene: &Scene,
        env: &Environment,
        count: usize,
        resolution: usize,
        behind: bool,
    ) -> Self {
        let w = 4.0 * std::f32::consts::PI / count as f32;
        let lights: Vec<Light> = (0..count)
            .filter_map(|k| {
                let d = fibonacci(k, count);
                let e = Vec3::from(sh9_eval(&env.sh, &d.to_array())).max(Vec3::ZERO) * w;
                (e.max_element() > 0.0).then_some(Light::Directional {
                    direction: d,
                    intensity: e,
                    shadows: true,
                })
            })
            .collect();
        let counts = match DensityGrid::new(scene, resolution) {
            Some(grid) => crate::threads::pool().install(|| {
                lights
                    .par_iter()
                    .map(|l| grid.fiber_count_with(l, behind))
                    .collect()
            }),
            None => Vec::new(),
        };
        Self { lights, counts }
    }

    /// The way towards direction `k` from `p` of a fiber of radius `r`,
    /// its own share left out (no hair: [`LightPath::OPEN`]; `behind` when
    /// the counts hold it).
    #[inline]
    pub fn path(&self, k: usize, p: Vec3, r: f32) -> LightPath {
        self.counts
            .get(k)
            .map_or(LightPath::OPEN, |c| c.at_fiber_behind(p, r))
    }

    /// The part of the way towards direction `k` from `p` clear of opaque
    /// geometry ([`FiberCount::at`]; 1 without hair): all the unscattered
    /// light needs besides [`Self::unscattered_count`].
    #[inline]
    pub fn clear(&self, k: usize, p: Vec3) -> f32 {
        self.counts.get(k).map_or(1.0, |c| c.at(p).clear)
    }

    /// The fiber count of the unscattered light of direction `k` (towards
    /// `d`) at `p` of a fiber of radius `r`
    /// ([`FiberCount::unscattered_at`]; 0 without hair).
    #[inline]
    pub fn unscattered_count(&self, k: usize, p: Vec3, r: f32, d: Vec3) -> f32 {
        self.counts
            .get(k)
            .map_or(0.0, |c| c.unscattered_at(p, r, d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. The lattice integrates the SH basis as the sphere does: the
    ///    constant to 4π exactly, and every band-1 and band-2 function to
    ///    0 within 2 % of the constant's integral (32 points; the Fibonacci
    ///    lattice's error for smooth integrands falls as 1/K).
    #[test]
    fn t01_lattice_integrates_low_bands() {
        let n = DIRECTIONS;
        let w = 4.0 * std::f32::consts::PI / n as f32;
        for band in 0..9 {
            let mut sh = [[0.0f32; 3]; 9];
            sh[band] = [1.0; 3];
            let s: f32 = (0..n)
                .map(|k| sh9_eval(&sh, &fibonacci(k, n).to_array())[0] * w)
                .sum();
            let want = if band == 0 {
                (4.0 * std::f32::consts::PI).sqrt()
            } else {
                0.0
            };
            assert!(
                (s - want).abs() < 0.02 * 3.545,
                "band {band}: {s} vs {want}"
            );
        }
    }
}
