//! Culling: work the image cannot show, skipped before it is done. Each
//! test is exact (the image is the same with it off) and switchable in
//! [`RenderOptions`]:
//!
//! - frustum culling: segments that reach no tile;
//! - back-face culling: back faces of closed, outward meshes seen from
//!   outside;
//! - opaque culling: hair behind a tile's farthest opaque surface;
//! - no shadow map for a light that light culling skips everywhere.
//!
//! Light culling itself (a bounded contribution below a threshold) is
//! decided per shading point in [`super::shade`].

use super::bin::{segment_tiles, TileGrid};
use super::scene::{Light, OpaqueTri, RenderOptions, Scene};
use super::setup::{Bounds, Segment};
use super::view::View;
use crate::raster::scene::HairShading;
use glam::Vec3;

/// The segments that reach at least one tile (the binning test), in order.
pub fn frustum(segs: Vec<Segment>, grid: TileGrid) -> Vec<Segment> {
    segs.into_iter()
        .filter(|s| segment_tiles(s, grid).is_some())
        .collect()
}

/// Opaque culling in one tile: hair entirely behind the farthest opaque
/// surface of a tile cannot be seen (every pixel's depth test would fail).
#[derive(Debug, Clone, Copy)]
pub struct BehindOpaque {
    /// The farthest opaque depth over the tile's pixels (infinite where a
    /// pixel sees no opaque surface); `None` when culling is off.
    far: Option<f32>,
}

impl BehindOpaque {
    pub fn new(on: bool, opaque_depths: impl Iterator<Item = f32>) -> Self {
        Self {
            far: on.then(|| opaque_depths.fold(0.0f32, f32::max)),
        }
    }

    /// Whether a primitive whose nearest depth is `z_min` is hidden.
    #[inline]
    pub fn hides(&self, z_min: f32) -> bool {
        self.far.is_some_and(|far| z_min >= far)
    }
}

/// Per mesh, whether its back faces can be skipped: it is closed and
/// consistently oriented (every directed edge is matched by exactly one
/// opposite edge, vertices compared bit for bit), oriented outwards
/// (positive signed volume), the eye is outside it (winding number 0, from
/// the sum of the triangles' solid angles) and no triangle of it is dropped
/// at the near plane. Then every ray from the eye enters the mesh through a
/// front face before it can meet a back face, so back faces are hidden.
pub fn meshes_to_cull(scene: &Scene, view: &View) -> Vec<bool> {
    let meshes = scene
        .triangles
        .iter()
        .map(|t| t.mesh as usize + 1)
        .max()
        .unwrap_or(0);
    let mut by_mesh: Vec<Vec<&OpaqueTri>> = vec![Vec::new(); meshes];
    for t in &scene.triangles {
        by_mesh[t.mesh as usize].push(t);
    }
    by_mesh
        .iter()
        .map(|tris| !tris.is_empty() && closed(tris) && outward_and_outside(tris, view))
        .collect()
}

/// Every directed edge matched by exactly one opposite edge.
fn closed(tris: &[&OpaqueTri]) -> bool {
    let key = |p: Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let mut edges = std::collections::HashMap::with_capacity(3 * tris.len());
    for t in tris {
        for k in 0..3 {
            *edges
                .entry((key(t.p[k]), key(t.p[(k + 1) % 3])))
                .or_insert(0u32) += 1;
        }
    }
    edges
        .iter()
        .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
}

/// Positive signed volume, the eye outside (winding number 0) and every
/// corner in front of the near plane.
fn outward_and_outside(tris: &[&OpaqueTri], view: &View) -> bool {
    let (mut volume, mut solid_angle) = (0.0f64, 0.0f64);
    for t in tris {
        let p = t.p.map(|x| x.as_dvec3());
        volume += p[0].dot(p[1].cross(p[2]));
        let [a, b, c] = p.map(|x| x - view.eye.as_dvec3());
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        solid_angle += 2.0 * num.atan2(den);
    }
    let winding = solid_angle / (4.0 * std::f64::consts::PI);
    let in_front = tris
        .iter()
        .all(|t| t.p.iter().all(|&x| view.to_view(x).z > view.near));
    volume > 0.0 && winding.abs() < 0.5 && in_front
}

/// Per light: whether its shadow map can be skipped (`skip_unused`) because
/// light culling skips the light at every point of the scene's bounding
/// sphere, hair and opaque surfaces alike, so the map would never be read:
/// KarisHair, culling on, and the larger of the BSDF bound and 1/π (opaque
/// surfaces) times the largest irradiance inside the sphere below 0.99 × the
/// threshold (the margin covers f32 rounding of the per-point bounds).
pub fn lights_without_visible_effect(
    scene: &Scene,
    opts: &RenderOptions,
    bounds: Bounds,
) -> Vec<bool> {
    let f_max = match &scene.hair {
        HairShading::Karis(k) if opts.skip_unused && opts.light_cull_threshold > 0.0 => {
            k.upper_bound()
        }
        _ => return vec![false; scene.lights.len()],
    };
    let f_max = if scene.spheres.is_empty() && scene.triangles.is_empty() {
        f_max
    } else {
        f_max.max(std::f32::consts::FRAC_1_PI)
    };
    scene
        .lights
        .iter()
        .map(|l| {
            let e_max = match *l {
                Light::Directional { intensity, .. } => intensity.max_element(),
                Light::Point {
                    position,
                    intensity,
                    ..
                } => {
                    let gap = (position - bounds.center).length() - bounds.radius;
                    if gap > 0.0 {
                        intensity.max_element() / (gap * gap)
                    } else {
                        f32::INFINITY
                    }
                }
            };
            f_max * e_max < 0.99 * opts.light_cull_threshold
        })
        .collect()
}
