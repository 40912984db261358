//! What of a light reaches a point: hair points through the shadow maps,
//! traced shadow rays and fiber counts; opaque points through the hair
//! (the unscattered and, under dual scattering, the forward-scattered part).

use super::{Fiber, Shader};
use crate::raster::shadow::ShadowMap;
use glam::Vec3;
use std::sync::Arc;

impl Shader<'_> {
    /// Visibility of light `li` (shadow map `sm`) at hair point `p` on
    /// `fiber` with tangent `t`, seen from `v`: the shadow map's at the
    /// fiber's surface point facing the viewer (not its own strand's
    /// shadow), times e^-n for the fibers crossed on the way when the light
    /// has a fiber count (read as for unscattered light).
    #[inline]
    pub(super) fn hair_visibility(
        &self,
        li: usize,
        sm: &Option<Arc<ShadowMap>>,
        p: Vec3,
        t: Vec3,
        v: Vec3,
        fiber: Fiber,
    ) -> f32 {
        let facing = (v - t * t.dot(v)).normalize_or_zero();
        let q = p + facing * fiber.radius;
        let vis = sm
            .as_ref()
            .map_or(1.0, |m| m.visibility_fiber(p, q, &fiber));
        if vis > 0.0 && self.traced_occluded(li, q, &fiber) {
            return 0.0;
        }
        match self.counts.get(li).and_then(Option::as_ref) {
            Some(c) if vis > 0.0 && self.count_shadows => {
                let l = self.scene.lights[li].incident(p).0;
                vis * (-c.unscattered_at(p, fiber.radius, t, l)).exp()
            }
            _ => vis,
        }
    }

    /// Whether a strand blocks light `li` from `o` (shadow model `traced`,
    /// a light that casts shadows), `fiber`'s own stretch left out.
    pub(super) fn traced_occluded(&self, li: usize, o: Vec3, fiber: &Fiber) -> bool {
        let (Some(grid), Some(Some(_))) = (&self.traced, self.shadows.get(li)) else {
            return false;
        };
        let light = &self.scene.lights[li];
        grid.occluded(o, light.incident(o).0, light.distance(o), fiber)
    }

    /// The fraction of light `li` that reaches an opaque surface point `p`
    /// through the hair (RGB), where the shadow map does not hold hair:
    /// with the `traced` shadow model 0 or 1 by a ray, plus under dual
    /// scattering what the fibers on the way scatter forward
    /// (`c·(e^{-n(1 - a_f)} − e^{-n})`, from the fiber count); with the
    /// `density` model from the fiber count, under dual scattering all the
    /// light the fibers pass on, scattered or not (`c·e^{-n(1 - a_f)}`),
    /// otherwise the unscattered part `c·e^{-n}` (a_f at normal incidence:
    /// a diffuse surface does not see the spread; c: the fraction of the
    /// way clear of opaque geometry). Other models: 1 (the map holds hair).
    pub fn hair_transmittance(&self, li: usize, p: Vec3) -> Vec3 {
        let count = self.counts.get(li).and_then(Option::as_ref);
        if self.traced.is_some() {
            let blocked = self.traced_occluded(li, p, &Fiber::NONE);
            let unscattered = if blocked { Vec3::ZERO } else { Vec3::ONE };
            return match (&self.dual, count) {
                (Some((dual, _)), Some(count)) => {
                    let (n, clear) = count.at(p);
                    let a_f = Vec3::from(dual.terms(0.0).a_f);
                    let scattered =
                        ((-(Vec3::ONE - a_f) * n).exp() - Vec3::splat((-n).exp())).max(Vec3::ZERO);
                    unscattered + scattered * clear
                }
                _ => unscattered,
            };
        }
        let Some(count) = count else {
            return Vec3::ONE;
        };
        if !self.count_shadows {
            return Vec3::ONE;
        }
        let (n, _) = count.at(p);
        match &self.dual {
            Some((dual, _)) => {
                let a_f = Vec3::from(dual.terms(0.0).a_f);
                (-(Vec3::ONE - a_f) * n).exp()
            }
            None => Vec3::splat((-n).exp()),
        }
    }
}
