//! What of a light reaches a point: hair points through the shadow maps,
//! traced shadow rays and fiber counts; opaque points through the hair
//! (the unscattered and, under dual scattering, the forward-scattered part).

use super::{Fiber, Shader};
use crate::raster::density::LightPath;
use crate::raster::shadow::ShadowMap;
use glam::Vec3;
use std::sync::Arc;

/// A source of light at hair points: a scene light, or one direction of
/// an environment shaded as lights ([`crate::raster::env_light`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Source {
    Light(usize),
    Environment(usize),
}

/// What [`Shader::incident`] computes of a source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Need {
    /// Everything: the unscattered fraction and the way to the light.
    All,
    /// The unscattered fraction alone (`path` reads [`LightPath::OPEN`],
    /// with `behind` where the counts hold it, so the dual-scattering
    /// terms take the same form).
    Unscattered,
    /// The way to the light alone (`unscattered` reads 0: no shadow ray).
    Path,
}

/// What of one source reaches a hair point: the one producer that every
/// shading path (per point, in batches, per coverage sample) sums over.
#[derive(Debug, Clone, Copy)]
pub(super) struct Incident {
    /// Unit direction towards the light.
    pub dir: Vec3,
    /// Irradiance on a surface facing the light, before anything blocks it.
    pub irradiance: Vec3,
    /// The fraction that arrives unscattered (shadow maps, traced rays,
    /// fiber counts).
    pub unscattered: f32,
    /// The way to the light in fibers, under dual scattering
    /// ([`LightPath::OPEN`] otherwise).
    pub path: LightPath,
}

impl Incident {
    /// Whether nothing of it arrives: no unscattered light, and the whole
    /// way blocked by opaque geometry (a head), which leaves dual
    /// scattering's scattered light, weighted by `path.clear`, at 0 as
    /// well. Every response to it is then exactly 0, and a caller may skip
    /// computing it (the sum is the same, bit for bit).
    #[inline]
    pub fn blocked(&self) -> bool {
        self.unscattered == 0.0 && self.path.clear == 0.0
    }
}

impl Shader<'_> {
    /// The sources in the order they are summed: the scene's lights, then
    /// the environment's directions (unless `lights_only`).
    pub(super) fn sources(&self, lights_only: bool) -> impl Iterator<Item = Source> {
        let lights = self.scene.lights.len();
        let env = match (&self.lit.env_lights, lights_only) {
            (Some(e), false) => e.lights.len(),
            _ => 0,
        };
        (0..lights)
            .map(Source::Light)
            .chain((0..env).map(Source::Environment))
    }

    /// What of `source` reaches hair point `p` on `fiber` with tangent `t`,
    /// seen from `v` (as much as `need` asks; without a lights' traced
    /// shadow ray unless `trace`: the near field traces its own);
    /// `None` where light culling skips the light (counted in `tally`).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn incident(
        &self,
        source: Source,
        p: Vec3,
        t: Vec3,
        v: Vec3,
        fiber: Fiber,
        need: Need,
        trace: bool,
        tally: &mut super::CullTally,
    ) -> Option<Incident> {
        let dual = self.dual.is_some();
        match source {
            Source::Light(li) => {
                let light = &self.scene.lights[li];
                let (dir, irradiance) = light.incident(p);
                if self.culls(irradiance, tally) {
                    return None;
                }
                const NO_MAP: &Option<Arc<ShadowMap>> = &None;
                let sm = self.shadows.get(li).unwrap_or(NO_MAP);
                let unscattered = match need {
                    Need::Path => 0.0,
                    _ => self.hair_visibility(li, sm, p, t, v, fiber, trace),
                };
                let path = match (dual, &self.lit.counts[li], need) {
                    (true, Some(c), Need::Unscattered) => LightPath {
                        behind: c.has_behind().then_some(0.0),
                        ..LightPath::OPEN
                    },
                    (true, Some(c), _) => c.at_fiber_behind(p, self.lookup_radius(&fiber)),
                    _ => LightPath::OPEN,
                };
                Some(Incident {
                    dir,
                    irradiance,
                    unscattered,
                    path,
                })
            }
            Source::Environment(k) => {
                let env = self.lit.env_lights.as_ref()?;
                let (dir, irradiance) = env.lights[k].incident(p);
                // (the way's `clear` is the one `env.clear` reads, in one pass)
                let (path, clear) = if dual {
                    let path = env.path(k, p, self.lookup_radius(&fiber));
                    (path, path.clear)
                } else {
                    (LightPath::OPEN, env.clear(k, p))
                };
                let unscattered =
                    clear * (-env.unscattered_count(k, p, self.lookup_radius(&fiber), dir)).exp();
                Some(Incident {
                    dir,
                    irradiance,
                    unscattered,
                    path,
                })
            }
        }
    }

    /// Visibility of light `li` (shadow map `sm`) at hair point `p` on
    /// `fiber` with tangent `t`, seen from `v`: the shadow map's at the
    /// fiber's surface point facing the viewer (not its own strand's
    /// shadow), times e^-n for the fibers crossed on the way when the light
    /// has a fiber count (read as for unscattered light); and unless
    /// `trace` is false, 0 where a traced shadow ray from there is blocked.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn hair_visibility(
        &self,
        li: usize,
        sm: &Option<Arc<ShadowMap>>,
        p: Vec3,
        t: Vec3,
        v: Vec3,
        fiber: Fiber,
        trace: bool,
    ) -> f32 {
        let q = self.facing_point(p, t, v, &fiber);
        let vis = sm
            .as_ref()
            .map_or(1.0, |m| m.visibility_fiber(p, q, &fiber));
        if trace && vis > 0.0 && self.traced_occluded_fragment(li, q, &fiber) {
            return 0.0;
        }
        match self.lit.counts.get(li).and_then(Option::as_ref) {
            Some(c) if vis > 0.0 && self.count_shadows => {
                let l = self.scene.lights[li].incident(p).0;
                vis * (-c.unscattered_at(p, self.lookup_radius(&fiber), l)).exp()
            }
            _ => vis,
        }
    }

    /// The surface point of the fiber at axis point `p` (tangent `t`)
    /// facing the viewer (direction `v`), where its lookups are read.
    #[inline]
    fn facing_point(&self, p: Vec3, t: Vec3, v: Vec3, fiber: &Fiber) -> Vec3 {
        let facing = (v - t * t.dot(v)).normalize_or_zero();
        p + facing * self.lookup_radius(fiber)
    }

    /// [`Self::traced_occluded`] for a fragment of `fiber` whose ray leaves
    /// from `q`: its segment's two vertices' answer where they agree
    /// (`render.shadows.traced.vertices`), else its own ray.
    fn traced_occluded_fragment(&self, li: usize, q: Vec3, fiber: &Fiber) -> bool {
        if let Some(vs) = &self.vertex_shadows {
            let origin = |p, t, v, f: &Fiber| self.facing_point(p, t, v, f);
            let blocked = |o, f: &Fiber| self.traced_occluded(li, o, f);
            if let Some(b) = vs.agreed(li, fiber, origin, blocked) {
                return b;
            }
        }
        self.traced_occluded(li, q, fiber)
    }

    /// Whether a strand blocks light `li` from `o` (shadow model `traced`,
    /// a light that casts shadows), `fiber`'s own stretch left out.
    pub(super) fn traced_occluded(&self, li: usize, o: Vec3, fiber: &Fiber) -> bool {
        let Some(grid) = self.traced_grid(li) else {
            return false;
        };
        let light = &self.scene.lights[li];
        grid.occluded_with(
            o,
            light.incident(o).0,
            light.distance(o),
            fiber,
            self.own_strand_passes,
        )
    }

    /// The strands' grid where light `li`'s shadows are traced (shadow
    /// model `traced`, a light that casts shadows).
    pub(super) fn traced_grid(&self, li: usize) -> Option<&crate::raster::traced::SegmentGrid> {
        match (&self.lit.traced, self.shadows.get(li)) {
            (Some(grid), Some(Some(_))) => Some(grid),
            _ => None,
        }
    }

    /// [`Self::traced_occluded`] for several origins on one fiber around
    /// axis point `p`, where light `li` is directional and the grid can
    /// walk them together (`traced::bundle`): bit `k` set where origin `k`
    /// is blocked; None otherwise (each traced alone then).
    pub(super) fn traced_occluded_bundle(
        &self,
        li: usize,
        p: Vec3,
        origins: &[Vec3],
        fiber: &Fiber,
    ) -> Option<u32> {
        let Some(grid) = self.traced_grid(li) else {
            return Some(0);
        };
        let light = &self.scene.lights[li];
        if !matches!(light, crate::raster::scene::Light::Directional { .. }) {
            return None;
        }
        grid.occluded_bundle(
            p,
            origins,
            light.incident(p).0,
            light.distance(p),
            fiber,
            self.own_strand_passes,
        )
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
        let count = self.lit.counts.get(li).and_then(Option::as_ref);
        if self.lit.traced.is_some() {
            let blocked = self.traced_occluded(li, p, &Fiber::NONE);
            let unscattered = if blocked { Vec3::ZERO } else { Vec3::ONE };
            return match (&self.dual, count) {
                (Some((dual, _)), Some(count)) => {
                    let LightPath { n, clear, .. } = count.at(p);
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
        let n = count.at(p).n;
        match &self.dual {
            Some((dual, _)) => {
                let a_f = Vec3::from(dual.terms(0.0).a_f);
                (-(Vec3::ONE - a_f) * n).exp()
            }
            None => Vec3::splat((-n).exp()),
        }
    }
}
