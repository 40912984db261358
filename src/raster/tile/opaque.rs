//! The opaque pass of a tile: the nearest sphere or mesh triangle per pixel,
//! and its diffuse radiance where the hair lets it be seen (per pixel, or
//! per coverage sample under traced shadows).

use super::super::bin::TILE;
use super::super::coverage::{ray_sphere, triangle_pixels, RayCone, Tri2};
use super::super::scene::Sphere;
use super::super::shade::shade_diffuse;
use super::Tile;
use crate::lighting::sh9_eval;
use glam::Vec3;

/// An opaque surface point: position, normal towards the camera, albedo.
#[derive(Debug, Clone, Copy)]
pub(super) struct Surface {
    pub(super) p: Vec3,
    pub(super) n: Vec3,
    pub(super) albedo: Vec3,
}

impl Tile<'_> {
    /// The nearest sphere per pixel.
    pub(super) fn opaque_spheres(&mut self) {
        let (scene, view) = (self.ctx.scene, self.ctx.view);
        if scene.spheres.is_empty() {
            return;
        }
        let cone = RayCone::through_pixels(view, self.x0, self.y0, self.tw, self.th);
        let seen: Vec<&Sphere> = scene
            .spheres
            .iter()
            .filter(|s| cone.may_hit(view.eye, s.center, s.radius))
            .collect();
        if seen.is_empty() {
            return;
        }
        for j in 0..self.th {
            for i in 0..self.tw {
                let k = (j * TILE + i) as usize;
                let p = self.center(i as i64, j as i64);
                let ray = view.ray(p[0], p[1]);
                for s in &seen {
                    if let Some(t) = ray_sphere(view.eye, ray, s.center, s.radius) {
                        let depth = t * ray.dot(view.forward);
                        if depth < self.opaque_depth[k] && depth > view.near {
                            self.opaque_depth[k] = depth;
                            let hit = view.eye + ray * t;
                            self.surface[k] = Some(Surface {
                                p: hit,
                                n: (hit - s.center) / s.radius,
                                albedo: s.albedo,
                            });
                        }
                    }
                }
            }
        }
    }

    /// The radiance behind the hair at pixel `k`: its opaque surface,
    /// shaded, or the background (the environment seen along the ray,
    /// clamped SH, else the constant).
    pub(super) fn base(&self, k: usize) -> Vec3 {
        match &self.surface[k] {
            Some(s) => shade_diffuse(self.ctx.shader, s.p, s.n, s.albedo),
            None => match (self.ctx.uniform_background, &self.ctx.scene.environment) {
                (Some(c), _) => c,
                (None, Some(env)) => {
                    let (i, j) = ((k as u32 % TILE) as i64, (k as u32 / TILE) as i64);
                    let p = self.center(i, j);
                    let ray = self.ctx.view.ray(p[0], p[1]);
                    Vec3::from(sh9_eval(&env.sh, &ray.to_array())).max(Vec3::ZERO)
                }
                (None, None) => self.ctx.opts.background,
            },
        }
    }

    /// The opaque surface of pixel `k` shaded where the ray through image
    /// point `xy` of that pixel meets its tangent plane (within a pixel's
    /// footprint of the surface point found at the centre).
    pub(super) fn surface_at(&self, k: usize, xy: [f32; 2]) -> Vec3 {
        let Some(s) = &self.surface[k] else {
            return Vec3::ZERO;
        };
        let view = self.ctx.view;
        let ray = view.ray(xy[0], xy[1]);
        let facing = ray.dot(s.n);
        let p = if facing < -1e-3 {
            view.eye + ray * ((s.p - view.eye).dot(s.n) / facing)
        } else {
            s.p
        };
        shade_diffuse(self.ctx.shader, p, s.n, s.albedo)
    }

    /// Opaque mesh triangles: nearest depth and diffuse shading per pixel
    /// (two-sided: the normal faces the camera).
    pub(super) fn opaque_meshes(&mut self, bin: &[u32]) {
        let view = self.ctx.view;
        for &si in bin {
            let t = &self.ctx.solids[si as usize];
            let Some(tri) = Tri2::new(t.p) else { continue };
            let b = tri.bounds.local(self.x0, self.y0, self.tw, self.th);
            for (k, w, depth) in triangle_pixels(&tri, &t.z, b, self.x0, self.y0) {
                if !(depth > view.near && depth < self.opaque_depth[k]) {
                    continue;
                }
                self.opaque_depth[k] = depth;
                let pw = (t.world[0] * w[0] + t.world[1] * w[1] + t.world[2] * w[2]) * depth;
                let n = if t.normal.dot(view.eye - pw) < 0.0 {
                    -t.normal
                } else {
                    t.normal
                };
                self.surface[k] = Some(Surface {
                    p: pw,
                    n,
                    albedo: t.albedo,
                });
            }
        }
    }
}
