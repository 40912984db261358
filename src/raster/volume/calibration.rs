//! The fiber medium's transmittance calibrated against the strands':
//! rays traced through both, and the scale of the medium's
//! cross-section that matches them.

use super::*;

/// Rays of the calibration.
pub const CALIBRATION_RAYS: usize = 16384;

/// The medium's transmittance against the strands': `rays` rays from points
/// on strand segments (drawn by a hash of the ray's index) in directions
/// uniform on the sphere. Per ray, whether it leaves the strands' grid
/// without meeting a capsule (traced as the `traced` shadows are), and the
/// medium's optical depth along it.
pub(super) fn calibration_rays(
    medium: &Medium,
    segments: &[crate::raster::setup::WorldSegment],
    grid: &crate::raster::traced::SegmentGrid,
    rays: usize,
) -> Vec<(f32, f32)> {
    if segments.is_empty() {
        return Vec::new();
    }
    pool().install(|| {
        (0..rays)
            .into_par_iter()
            .map(|i| {
                let mut rng = Rng::new(i as u64 ^ 0xC0FF_EE00);
                let si = ((rng.uniform() as f64 * segments.len() as f64) as usize)
                    .min(segments.len() - 1);
                let s = &segments[si];
                let o = s.a + (s.b - s.a) * rng.uniform();
                let z = 1.0 - 2.0 * rng.uniform();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let a = std::f32::consts::TAU * rng.uniform();
                let d = Vec3::new(r * a.cos(), r * a.sin(), z);
                let fiber = crate::raster::shade::Fiber {
                    radius: 0.5 * (s.ra + s.rb),
                    strand: s.strand,
                    segment: si as u32,
                };
                let clear = if grid.occluded(o, d, f32::INFINITY, &fiber) {
                    0.0
                } else {
                    1.0
                };
                (clear, medium.optical_depth(o, d))
            })
            .collect()
    })
}

/// The calibration of a solve: the mean transmittance through the strands
/// and through the medium before and after scaling its cross-section by
/// `k` (chosen so that the means agree).
#[derive(Debug, Clone, Copy, Default)]
pub struct Calibration {
    pub strands: f64,
    pub medium: f64,
    pub calibrated: f64,
    pub k: f64,
}

/// The factor `k` for which the medium's mean `exp(−k τ)` over `rays`
/// equals the strands' mean transmittance (bisection on [1/4, 4]).
pub(super) fn calibrate(rays: &[(f32, f32)]) -> Calibration {
    if rays.is_empty() {
        return Calibration {
            strands: 1.0,
            medium: 1.0,
            calibrated: 1.0,
            k: 1.0,
        };
    }
    let n = rays.len() as f64;
    let geo = rays.iter().map(|r| r.0 as f64).sum::<f64>() / n;
    let vol = |k: f64| rays.iter().map(|r| (-(k * r.1 as f64)).exp()).sum::<f64>() / n;
    let (mut lo, mut hi) = (0.25f64, 4.0f64);
    for _ in 0..40 {
        let mid = (lo * hi).sqrt();
        // the mean falls as k grows
        if vol(mid) > geo {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let k = (lo * hi).sqrt();
    Calibration {
        strands: geo,
        medium: vol(1.0),
        calibrated: vol(k),
        k,
    }
}
