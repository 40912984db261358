//! A render's memory, estimated before anything is allocated: the large
//! buffers each stage holds at its peak, from the scene's sizes and the
//! options alone. A render whose estimate exceeds the memory available is
//! refused with the estimate instead of failing part-way (or being killed).

use super::scene::{Light, RenderOptions, Scene};
use super::setup::{Segment, WorldSegment};
use super::shadow::{ShadowModel, LAYERS, SLABS};

/// Estimated peak bytes per buffer group, largest items of a render.
#[derive(Debug, Clone)]
pub struct MemoryEstimate {
    pub items: Vec<(&'static str, u64)>,
}

impl MemoryEstimate {
    pub fn total(&self) -> u64 {
        self.items.iter().map(|i| i.1).sum()
    }

    /// The largest item.
    pub fn largest(&self) -> (&'static str, u64) {
        self.items
            .iter()
            .copied()
            .max_by_key(|i| i.1)
            .unwrap_or(("nothing", 0))
    }
}

/// Bytes of the traced shadows' segment grid per segment (measured 97 on
/// the demo head, 106 with the capsules' radius kept; a segment across the
/// cells' diagonals reaches more).
const TRACED_BYTES_PER_SEGMENT: u64 = 128;
/// The same with the near field, whose grid lists each capsule a fiber
/// radius wider (`traced::bundle`: measured 208-209 on the six dense
/// ChiangHair heads, whose fibers are thick against their cells).
const TRACED_BYTES_PER_SEGMENT_SPREAD: u64 = 256;

/// Bytes of one shadow map at `n²` texels while it is built: first-hair
/// and opaque depth (2 floats per texel), up to 8 per-thread depth buffers
/// merged by `min`, and with the opacity model `SLABS` floats and
/// `LAYERS` 16-byte deposits per texel.
pub fn shadow_map_bytes(n: u32, model: ShadowModel) -> u64 {
    let texels = n as u64 * n as u64;
    let parts = crate::threads::num_threads().clamp(1, 8) as u64;
    let mut b = texels * 4 * (2 + parts);
    if model == ShadowModel::Opacity {
        b += texels * (SLABS as u64 * 4 + LAYERS as u64 * 16);
    }
    b
}

/// Voxels of the density grid of `scene` at `resolution` (the arithmetic
/// of [`super::density::DensityGrid::new`]); 0 without hair.
fn density_voxels(hair: Option<(glam::Vec3, glam::Vec3)>, resolution: usize) -> u64 {
    hair.and_then(|b| super::density::grid_frame_in(b, resolution))
        .map_or(0, |(_, _, d)| d.iter().map(|&e| e as u64).product())
}

/// The estimate for rendering `scene` with `opts` and multiple scattering
/// `ms` (dual scattering needs the density grid).
pub fn estimate(scene: &Scene, opts: &RenderOptions) -> MemoryEstimate {
    let m = super::methods::Methods::new(scene, opts);
    let c = &scene.camera;
    let pixels = c.width as u64 * c.height as u64;
    let vertices = scene.strands.points.len() as u64;
    let segments = vertices.saturating_sub(scene.strands.strand_count() as u64);
    let shadowed = scene
        .lights
        .iter()
        .filter(|l| {
            matches!(
                l,
                Light::Directional { shadows: true, .. } | Light::Point { shadows: true, .. }
            )
        })
        .count() as u64;
    // the hair's box, once (it reads every vertex), where a grid needs it
    let boxed = std::cell::OnceCell::new();
    let hair = || *boxed.get_or_init(|| super::density::hair_box_of(scene));
    let mut items = vec![
        // The tiles' results and the assembled image, RGB float each.
        ("image (framebuffer and tiles)", pixels * 12 * 2),
        (
            "strand segments",
            segments
                * (std::mem::size_of::<Segment>() + std::mem::size_of::<WorldSegment>()) as u64
                + vertices * 12 * 2,
        ),
        // Frustum and sphere culling copy the segments they keep into a
        // new vector while the projected ones are alive
        // (`cull::visible_segments`): at most a second copy.
        (
            "culled segments",
            if super::cull::may_copy_segments(scene, opts) {
                segments * std::mem::size_of::<Segment>() as u64
            } else {
                0
            },
        ),
        (
            "shadow maps",
            shadowed * shadow_map_bytes(opts.shadow_map_size.max(16), opts.shadow_model),
        ),
    ];
    // Per voxel and light: [n, clear], and the count away from the light
    // for the two-stream back scattering.
    let per_light = if m.counts_behind { 12 } else { 8 };
    if m.fiber_counts && shadowed > 0 {
        // Moments (7 floats) summed from 8 per-chunk grids, and the counts.
        let voxels = density_voxels(hair(), opts.density_resolution);
        items.push(("density grid", voxels * (28 * 9 + per_light * shadowed)));
    }
    if m.environment_as_lights {
        // The environment as lights: a coarser grid, the counts per voxel
        // for each direction.
        let voxels = density_voxels(
            hair(),
            super::env_light::grid_resolution(opts.density_resolution, m.dual),
        );
        items.push((
            "environment fiber counts",
            voxels * (28 * 9 + per_light * opts.environment_directions as u64),
        ));
    }
    if m.traced {
        // Capsules (48 bytes) and their cell lists (4 bytes a cell a
        // capsule reaches, ~8 at cells a quarter of a segment long, about
        // twice as many listed a fiber radius wider for the near field),
        // and up to 256³ list starts.
        let per = if m.near_field {
            TRACED_BYTES_PER_SEGMENT_SPREAD
        } else {
            TRACED_BYTES_PER_SEGMENT
        };
        items.push(("traced segment grid", segments * per));
    }
    if m.volume {
        // The medium, the light's integer tallies and its fluence, and the
        // segment grid its calibration traces through (the traced shadows'
        // when there is one).
        let s = super::volume::VolumeSettings::of(opts);
        let grid = if m.traced {
            0
        } else {
            segments * TRACED_BYTES_PER_SEGMENT
        };
        items.push((
            "volume scattering",
            hair().map_or(0, |b| super::volume::bytes_estimate(scene, b, &s)) as u64 + grid,
        ));
    }
    MemoryEstimate { items }
}

/// Bytes this process can still allocate, as far as the system says: the
/// smaller of the memory available (`MemAvailable`) and what the
/// address-space limit leaves; None where it cannot be read (not Linux).
pub fn available_bytes() -> Option<u64> {
    let field = |text: &str, key: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(key))?;
        line[key.len()..]
            .split_whitespace()
            .next()?
            .parse::<u64>()
            .ok()
    };
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let mut avail = field(&meminfo, "MemAvailable:")? * 1024;
    if let (Ok(limits), Ok(status)) = (
        std::fs::read_to_string("/proc/self/limits"),
        std::fs::read_to_string("/proc/self/status"),
    ) {
        if let (Some(limit), Some(used)) = (
            field(&limits, "Max address space"),
            field(&status, "VmSize:"),
        ) {
            avail = avail.min(limit.saturating_sub(used * 1024));
        }
    }
    Some(avail)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t01_shadow_map_bytes_grow_with_texels_and_model() {
        let e = shadow_map_bytes(1024, ShadowModel::Exponential);
        let o = shadow_map_bytes(1024, ShadowModel::Opacity);
        assert!(e >= 8 << 20);
        assert_eq!(
            o - e,
            (1024 * 1024) * (SLABS as u64 * 4 + LAYERS as u64 * 16)
        );
        assert_eq!(shadow_map_bytes(2048, ShadowModel::Exponential), 4 * e);
    }

    #[test]
    fn t02_available_bytes_is_positive_on_linux() {
        if cfg!(target_os = "linux") {
            assert!(available_bytes().unwrap() > 0);
        }
    }
}
