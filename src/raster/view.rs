//! The camera as the rasterizer uses it: an orthonormal basis, a pinhole
//! projection to pixel coordinates, and the near plane.

use super::scene::Camera;
use glam::Vec3;

/// The camera's basis and projection.
#[derive(Debug, Clone, Copy)]
pub struct View {
    pub eye: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    /// Focal length in pixels.
    pub focal: f32,
    pub width: u32,
    pub height: u32,
    /// Near-plane depth: 1e-4 of the distance to the far side of the hair
    /// ([`super::setup::near_reference`]). Depths are stored linearly in
    /// f32, so a small near plane costs no depth precision.
    pub near: f32,
}

impl View {
    /// The view of camera `c`; the near plane is 1e-4 of `reference`
    /// ([`super::setup::near_reference`]).
    pub fn new(c: &Camera, reference: f32) -> Self {
        let forward = (c.target - c.position).normalize_or(Vec3::Z);
        let right = forward.cross(c.up).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let focal = 0.5 * c.height as f32 / (0.5 * c.fov_y.to_radians()).tan();
        Self {
            eye: c.position,
            right,
            up,
            forward,
            focal,
            width: c.width,
            height: c.height,
            near: (1e-4 * reference).max(1e-6),
        }
    }

    /// View-space coordinates (x right, y up, z forward depth).
    #[inline]
    pub fn to_view(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// Pixel coordinates of a view-space point with z > 0.
    #[inline]
    pub fn project(&self, v: Vec3) -> (f32, f32) {
        (
            0.5 * self.width as f32 + self.focal * v.x / v.z,
            0.5 * self.height as f32 - self.focal * v.y / v.z,
        )
    }

    /// Pixel coordinates of a view-space point, as an array.
    #[inline]
    pub fn project2(&self, v: Vec3) -> [f32; 2] {
        let (x, y) = self.project(v);
        [x, y]
    }

    /// World-space direction of the ray through pixel position (x, y).
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Vec3 {
        let vx = (x - 0.5 * self.width as f32) / self.focal;
        let vy = (0.5 * self.height as f32 - y) / self.focal;
        (self.forward + vx * self.right + vy * self.up).normalize()
    }
}
