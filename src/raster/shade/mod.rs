//! Shading: the radiance a hair fragment or vertex scatters towards the
//! eye from every light (with its shadow-map visibility) and the
//! environment, and the diffuse shading of opaque surfaces. KarisHair and
//! ChiangHair's tabulated far field run on their vector kernels in batches
//! ([`Shader::shade_serial`]); dual scattering and DEonHair per point
//! ([`Shader::shade`]). What of each light reaches a point is in
//! `visibility.rs`.

mod at_vertices;
mod batch;
mod near;
mod vertex_colors;
mod vertex_shadows;
mod vertices;
mod visibility;
pub use near::{offset_line, NearLight};
pub use vertex_colors::{FetchScratch, VertexColors};
pub use vertices::shade_vertices;

use super::lighting::Lighting;
use super::scene::{HairShading, MultipleScattering, RenderOptions, Scene};
use super::shadow::{ShadowMap, NO_STRAND};
use crate::fiber::dual::{DualTable, FarField};
pub use crate::fiber::frame::FiberAngles;
use crate::fiber::karis::Transmittance;
use crate::lighting::sh9_eval;
use glam::Vec3;
use std::sync::Arc;
use visibility::{Incident, Need, Source};

/// One shadow map per light (None: the light casts no shadow, or its map
/// was skipped).
pub type ShadowMaps = [Option<Arc<ShadowMap>>];

/// The fiber a shading point lies on: its radius there (the point's
/// distance to the fiber's surface) and its strand (whose own shadow the
/// point does not see).
#[derive(Debug, Clone, Copy)]
pub struct Fiber {
    pub radius: f32,
    pub strand: u32,
    /// The world segment the point lies on (or, at a vertex, one of the two).
    pub segment: u32,
}

impl Fiber {
    /// A point on no strand (cards).
    pub const NONE: Fiber = Fiber {
        radius: 0.0,
        strand: NO_STRAND,
        segment: 0,
    };

    /// Whether segment `segment` of strand `strand` is the fiber's own
    /// stretch: its segment or a neighbour on the same strand (a shadow ray
    /// leaves it; farther parts of the strand still cast shadows).
    #[inline]
    pub fn is_local(&self, strand: u32, segment: u32) -> bool {
        self.strand != NO_STRAND && strand == self.strand && segment.abs_diff(self.segment) <= 1
    }
}

/// Light-culling statistics gathered locally and added to the render's
/// counters once per batch ([`Shader::flush`]).
#[derive(Default, Clone, Copy)]
struct CullTally {
    count: u64,
    max: f32,
}

/// Everything hair shading needs, prepared once per render.
pub struct Shader<'a> {
    scene: &'a Scene,
    /// The scene's model, with what it cannot use disabled (see [`Shader::new`]).
    hair: HairShading,
    /// The environment variant of a KarisHair model (when there is an environment).
    env_model: Option<crate::fiber::karis::KarisHair<f32>>,
    shadows: &'a ShadowMaps,
    /// The fiber counts, the environment's directions and the strands'
    /// grid for traced shadows ([`super::lighting`]).
    lit: Arc<Lighting>,
    /// Dual scattering: the material's tables and d_f (ChiangHair, KarisHair).
    dual: Option<(Arc<DualTable>, f32)>,
    /// Whether hair's own shadow comes from the fiber count (shadow model
    /// `density`).
    count_shadows: bool,
    /// Light the opaque spheres reflect into the hair (dual scattering).
    bounce: Option<super::bounce::SphereBounce>,
    /// Multiple scattering carried through the volume (`volume`).
    volume: Option<Arc<super::volume::VolumeRadiance>>,
    /// `shading = "split"`: the environment and the lights' scattered
    /// light (dual scattering) are read at strand vertices, with the
    /// volume's ([`at_vertices`]); only each light's unscattered light is
    /// shaded per fragment.
    split: bool,
    /// The terms read at strand vertices (with a volume, or `split`).
    at_vertices: Option<at_vertices::AtVertices<'a>>,
    /// Traced shadows decided at strand vertices where a segment's ends
    /// agree (`render.shadows.traced.vertices`).
    traced_vertices: bool,
    vertex_shadows: Option<vertex_shadows::VertexShadows<'a>>,
    /// Coverage samples shade the lights' single scattering by the near
    /// field at each sample's offset across its fiber (see [`near`]).
    near: bool,
    /// Traced shadow rays pass their whole own strand (Cycles' rule,
    /// `render.shadows.traced.own_strand` "passes").
    own_strand_passes: bool,
    /// The render's cancel flag: once set, shading returns 0 at once (the
    /// render is discarded), so that a slow model (converged DEonHair,
    /// about 1 ms a fragment) stops within a fragment, not a tile.
    cancel: Option<&'a std::sync::atomic::AtomicBool>,
    /// The factor a drawn strand's radius was widened by: 1, or about
    /// `1/f` under a level of detail ([`Self::with_lod_widen`]).
    widen: f32,
    /// Upper bound of the hair BSDF's value over all directions (KarisHair;
    /// `None`: no light culling).
    f_max: Option<f32>,
    /// Radiance below which a light's bounded contribution is skipped.
    cull_threshold: f32,
    /// Light evaluations skipped, and the largest skipped bound (f32 bits).
    culled: std::sync::atomic::AtomicU64,
    culled_max_bits: std::sync::atomic::AtomicU32,
}

impl<'a> Shader<'a> {
    /// With KarisHair and Scatter = 0, the MS block adds exactly 0 under the
    /// renderer's default transmittance (global 1, local 0, visibility 1: it
    /// rescales the single scattering by 1 and adds a Kajiya-Kay term scaled
    /// by Scatter), so it is compiled out (`skip_unused`).
    ///
    /// Light culling (`cull_threshold` > 0, KarisHair): a light whose
    /// irradiance times the BSDF's upper bound is below the threshold at a
    /// shading point is not evaluated there (nor its shadow map read). Each
    /// skipped term is at most the threshold, so a pixel changes by at most
    /// `threshold × lights` (its fragments' weights sum to ≤ 1); the largest
    /// skipped bound is reported in the statistics.
    pub fn new(
        scene: &'a Scene,
        shadows: &'a ShadowMaps,
        lit: Arc<Lighting>,
        cancel: Option<&'a std::sync::atomic::AtomicBool>,
        opts: &RenderOptions,
    ) -> Self {
        let (skip_unused, cull_threshold) = (opts.skip_unused, opts.light_cull_threshold);
        let m = super::methods::Methods::new(scene, opts);
        let ms = m.multiple_scattering;
        let hair = match &scene.hair {
            HairShading::Karis(k)
                if k.components().ms
                    && (ms != MultipleScattering::Karis || skip_unused && k.scatter_is_zero()) =>
            {
                HairShading::Karis(k.single_scattering())
            }
            other => other.clone(),
        };
        let dual_ms = m.dual;
        let env_model = match (&scene.environment, &hair) {
            (Some(_), HairShading::Karis(k)) if !m.environment_as_lights => {
                Some(k.environment_variant())
            }
            _ => None,
        };
        // (the bound holds the single scattering only, not dual's terms)
        let f_max = match &hair {
            HairShading::Karis(k) if cull_threshold > 0.0 && !dual_ms => Some(k.upper_bound()),
            _ => None,
        };
        let d_b = opts.dual_back_density;
        let dual = match (&hair, dual_ms) {
            (HairShading::ChiangFar(c), true) => Some(c.dual(d_b)),
            (HairShading::Karis(k), true) => Some(DualTable::for_karis_cached(k, d_b)),
            _ => None,
        }
        .map(|t| (t, opts.dual_forward_density));
        Self {
            scene,
            hair,
            env_model,
            shadows,
            lit,
            dual,
            count_shadows: m.count_shadows,
            near: m.near_field,
            own_strand_passes: opts.traced_own_strand_passes,
            bounce: None,
            volume: None,
            // (vertex shading with guides that give the scattered terms:
            // the lights' unscattered light per vertex, the rest gathered)
            split: if opts.vertex_shading {
                opts.guides.on() && opts.guides.terms == super::guides::GuideTerms::Scattered
            } else {
                opts.split_shading
            },
            at_vertices: None,
            traced_vertices: opts.traced_vertices,
            vertex_shadows: None,
            cancel,
            widen: 1.0,
            f_max,
            cull_threshold,
            culled: Default::default(),
            culled_max_bits: Default::default(),
        }
    }

    /// For strands widened by `widen` under a level of detail: a drawn
    /// strand stands for about `widen` strands of its original radius, and
    /// what shading reads at a fiber's surface (shadow maps, traced rays,
    /// fiber counts, the sphere's bounce) is read at the surface of one of
    /// those. At the widened surface, `widen` radii from the centre line,
    /// the shadow maps' lookups of light from behind sat in front of the
    /// strands' deposits: the backlit dense head `blond_back` rendered
    /// twice as bright at 1/8 of the strands as with every strand.
    pub fn with_lod_widen(mut self, widen: f32) -> Self {
        self.widen = if widen > 0.0 { widen } else { 1.0 };
        self
    }

    /// The radius at which shading reads lookups around `fiber`
    /// ([`Self::with_lod_widen`]).
    #[inline]
    pub(super) fn lookup_radius(&self, fiber: &Fiber) -> f32 {
        fiber.radius / self.widen
    }

    /// With the light opaque spheres reflect into the hair, under dual
    /// scattering when `opts.sphere_bounce` is on (see [`super::bounce`]).
    pub fn with_sphere_bounce(mut self, opts: &RenderOptions) -> Self {
        if let (true, Some((dual, _))) = (opts.sphere_bounce, &self.dual) {
            self.bounce = super::bounce::SphereBounce::new(
                self.scene,
                &self.lit.counts,
                self.lit.env_lights.as_ref(),
                &self.lit.sphere_counts,
                dual,
            );
        }
        self
    }

    /// With the multiple scattering of a volume solve added at every hair
    /// point, and the terms read at strand vertices (the volume's, and
    /// under `split` the environment's and the scattered light's): on
    /// strands at their vertices as seen from `eye`, once per render, and
    /// interpolated along each segment (`segments`, the world segments of
    /// the scene's strands, which the fibers index); on cards at the point.
    /// Under `split`, with `guides`, the strands' vertex terms are computed
    /// at the guide strands alone and gathered from them.
    pub fn with_vertex_terms(
        mut self,
        volume: Option<Arc<super::volume::VolumeRadiance>>,
        segments: &'a [super::setup::WorldSegment],
        eye: Vec3,
        guides: Option<Arc<super::guides::GuideMap>>,
    ) -> Self {
        self.volume = volume;
        if self.volume.is_some() || self.split {
            self.at_vertices = Some(at_vertices::AtVertices::new(
                segments,
                &self.scene.strands,
                eye,
                guides.filter(|_| self.split),
            ));
        }
        if self.traced_vertices {
            let traced: Vec<bool> = (0..self.scene.lights.len())
                .map(|li| self.traced_grid(li).is_some())
                .collect();
            if traced.iter().any(|&t| t) {
                self.vertex_shadows = Some(vertex_shadows::VertexShadows::new(
                    segments,
                    &self.scene.strands,
                    eye,
                    traced.into_iter(),
                ));
            }
        }
        self
    }

    /// Whether the render was cancelled.
    #[inline]
    pub fn cancelled(&self) -> bool {
        self.cancel
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
    }

    /// The light-culling threshold for opaque diffuse surfaces: the hair's
    /// when hair is culled (KarisHair), else 0 (off).
    pub fn diffuse_cull(&self) -> f32 {
        if self.f_max.is_some() {
            self.cull_threshold
        } else {
            0.0
        }
    }

    /// Whether light culling skips a light of irradiance `e` at a hair point
    /// (its bounded contribution is below the threshold); counts the skip
    /// and keeps the largest skipped bound in `tally` (see [`CullTally`]).
    #[inline]
    fn culls(&self, e: Vec3, tally: &mut CullTally) -> bool {
        let Some(f_max) = self.f_max else {
            return false;
        };
        let bound = f_max * e.max_element();
        if bound >= self.cull_threshold {
            return false;
        }
        tally.count += 1;
        tally.max = tally.max.max(bound.max(0.0));
        true
    }

    /// Adds a tally to the render's statistics (one atomic update per
    /// batch: per point, two threads contending for the counters made
    /// light culling slower than no culling).
    fn flush(&self, tally: CullTally) {
        use std::sync::atomic::Ordering::Relaxed;
        if tally.count > 0 {
            self.culled.fetch_add(tally.count, Relaxed);
            // non-negative floats order as their bits
            self.culled_max_bits.fetch_max(tally.max.to_bits(), Relaxed);
        }
    }

    /// Light evaluations skipped so far, and the largest skipped bound.
    pub fn light_cull_stats(&self) -> (u64, f32) {
        use std::sync::atomic::Ordering::Relaxed;
        (
            self.culled.load(Relaxed),
            f32::from_bits(self.culled_max_bits.load(Relaxed)),
        )
    }

    /// What a fiber with tangent `t` scatters towards `v` of the light
    /// `inc`: the model's far field times the irradiance and the
    /// unscattered fraction, or under dual scattering its effective far
    /// field for the way to the light.
    fn fiber_response(&self, v: Vec3, t: Vec3, inc: &Incident) -> Vec3 {
        if let (Some((dual, d_f)), Some(far)) = (&self.dual, self.far_field()) {
            let g = FiberAngles::new(t, v, inc.dir);
            return Vec3::from(dual.shade(far, &g, inc.unscattered, inc.path, *d_f))
                * inc.irradiance;
        }
        self.unscattered_response(v, t, inc)
    }

    /// The part of [`Self::fiber_response`] carried by the light that
    /// arrives unscattered (under dual scattering, its direct part).
    fn unscattered_response(&self, v: Vec3, t: Vec3, inc: &Incident) -> Vec3 {
        let (l, e, vis) = (inc.dir, inc.irradiance, inc.unscattered);
        if vis <= 0.0 {
            return Vec3::ZERO;
        }
        if let (Some((dual, d_f)), Some(far)) = (&self.dual, self.far_field()) {
            let g = FiberAngles::new(t, v, l);
            let (direct, _) = dual.shade_parts(far, &g, vis, inc.path, *d_f, false);
            return Vec3::from(direct) * e;
        }
        let f = match &self.hair {
            HairShading::Karis(k) => {
                let tr = Transmittance {
                    shadow: vis,
                    ..Default::default()
                };
                Vec3::from(k.eval(&l.to_array(), &v.to_array(), &t.to_array(), &tr))
            }
            HairShading::ChiangFar(c) => chiang_far(c, t, v, l),
            HairShading::DEon(d) => Vec3::from(d.eval(&l.to_array(), &v.to_array(), &t.to_array())),
        };
        f * e * vis
    }

    /// The part of [`Self::fiber_response`] carried by the light the fibers
    /// on the way scattered (dual scattering; 0 otherwise).
    fn scattered_response(&self, v: Vec3, t: Vec3, inc: &Incident) -> Vec3 {
        let (Some((dual, d_f)), Some(far)) = (&self.dual, self.far_field()) else {
            return Vec3::ZERO;
        };
        let g = FiberAngles::new(t, v, inc.dir);
        let (_, scattered) = dual.shade_parts(far, &g, 0.0, inc.path, *d_f, true);
        Vec3::from(scattered) * inc.irradiance
    }

    /// The far field dual scattering shades with (None: DEonHair).
    fn far_field(&self) -> Option<FarField<'_>> {
        match &self.hair {
            HairShading::ChiangFar(c) => Some(FarField::Chiang(c)),
            HairShading::Karis(k) => Some(FarField::Karis(k)),
            HairShading::DEon(_) => None,
        }
    }

    /// Radiance scattered by hair at `p` with tangent `t` towards the eye `v`.
    pub fn shade(&self, p: Vec3, t: Vec3, v: Vec3, fiber: Fiber) -> Vec3 {
        self.shade_impl(p, t, v, fiber, None)
    }

    /// [`Self::shade`]; with `unscattered`, the lights' unscattered single
    /// scattering (the far field times irradiance and visibility) is left
    /// out and each light that reaches the point is pushed there as
    /// (direction, irradiance × visibility), for the near field.
    fn shade_impl(
        &self,
        p: Vec3,
        t: Vec3,
        v: Vec3,
        fiber: Fiber,
        mut unscattered: Option<&mut Vec<NearLight>>,
    ) -> Vec3 {
        let mut out = Vec3::ZERO;
        if self.cancelled() {
            return out;
        }
        let mut tally = CullTally::default();
        // (split: the lights' unscattered light here, the rest at the vertices)
        let need = if self.split {
            Need::Unscattered
        } else {
            Need::All
        };
        // (the near field traces the lights' shadows per bin of offsets)
        let near = unscattered.is_some() && matches!(self.hair, HairShading::ChiangFar(_));
        let response = |inc: &Incident| {
            if self.split {
                self.unscattered_response(v, t, inc)
            } else {
                self.fiber_response(v, t, inc)
            }
        };
        for source in self.sources(self.split) {
            let Some(inc) = self.incident(source, p, t, v, fiber, need, !near, &mut tally) else {
                continue;
            };
            if matches!(source, Source::Environment(_)) && inc.blocked() {
                continue;
            }
            let (Some(list), HairShading::ChiangFar(c), Source::Light(li)) =
                (unscattered.as_deref_mut(), &self.hair, source)
            else {
                out += response(&inc);
                continue;
            };
            // The near field shades the unscattered far field per coverage
            // sample: without dual scattering that is all of the response;
            // with it, what dual scattering adds stays here.
            if self.dual.is_some() {
                out += response(&inc);
            }
            if inc.unscattered > 0.0 {
                if self.dual.is_some() {
                    out -= chiang_far(c, t, v, inc.dir) * inc.irradiance * inc.unscattered;
                }
                let visible = self.offset_visibility(li, p, t, v, &fiber);
                if visible != 0 {
                    list.push(NearLight {
                        dir: inc.dir,
                        irradiance: inc.irradiance * inc.unscattered,
                        visible,
                    });
                }
            }
        }
        self.flush(tally);
        if !self.split {
            out += self.smooth_terms(p, t, v, fiber);
        }
        out + self.vertex_terms(p, t, v, fiber)
    }

    /// The environment shaded by KarisHair's SH lobes and the light the
    /// opaque spheres reflect into the hair, at `p`.
    fn smooth_terms(&self, p: Vec3, t: Vec3, v: Vec3, fiber: Fiber) -> Vec3 {
        let mut out = Vec3::ZERO;
        if let (Some(env), Some(m)) = (&self.scene.environment, &self.env_model) {
            out += Vec3::from(m.dispatch(EnvOne { v, t, sh: &env.sh }));
        }
        if let (Some(bounce), Some((dual, _)), Some(far)) =
            (&self.bounce, &self.dual, self.far_field())
        {
            out += bounce.radiance(far, dual, p, self.lookup_radius(&fiber), t, v);
        }
        out
    }

    /// Under `split`, everything but the lights' unscattered light: their
    /// scattered light, the environment's directions, and
    /// [`Self::smooth_terms`], at `p`.
    fn split_terms(&self, p: Vec3, t: Vec3, v: Vec3, fiber: Fiber) -> Vec3 {
        let mut out = Vec3::ZERO;
        let mut tally = CullTally::default();
        for source in self.sources(false) {
            let light = matches!(source, Source::Light(_));
            if light && self.dual.is_none() {
                continue;
            }
            let need = if light { Need::Path } else { Need::All };
            let Some(inc) = self.incident(source, p, t, v, fiber, need, true, &mut tally) else {
                continue;
            };
            if !light && inc.blocked() {
                continue;
            }
            out += if light {
                self.scattered_response(v, t, &inc)
            } else {
                self.fiber_response(v, t, &inc)
            };
        }
        self.flush(tally);
        out + self.smooth_terms(p, t, v, fiber)
    }

    /// The terms read at strand vertices ([`at_vertices`]): the volume's
    /// multiple scattering, and under `split` [`Self::split_terms`]; at
    /// the point itself on cards.
    fn vertex_terms(&self, p: Vec3, t: Vec3, v: Vec3, fiber: Fiber) -> Vec3 {
        let Some(cache) = &self.at_vertices else {
            return Vec3::ZERO;
        };
        let terms = |q: Vec3, t: Vec3, v: Vec3, f: Fiber| {
            let mut x = Vec3::ZERO;
            if self.split {
                x += self.split_terms(q, t, v, f);
            }
            if let Some(vol) = &self.volume {
                x += vol.radiance(q, t, v, f.strand);
            }
            x
        };
        cache
            .read(p, fiber, terms)
            .unwrap_or_else(|| terms(p, t, v, fiber))
    }
}

/// The far-field response of a fiber of `hair` with tangent `t`, seen
/// from `v`, to a directional light of unit irradiance from `l` (no shadow;
/// KarisHair without its own multiple-scattering term; DEonHair: 0).
pub fn far_response(hair: &HairShading) -> impl Fn(Vec3, Vec3, Vec3) -> Vec3 + Sync + '_ {
    let karis = match hair {
        HairShading::Karis(k) => Some(k.single_scattering()),
        _ => None,
    };
    move |t: Vec3, v: Vec3, l: Vec3| match (hair, &karis) {
        (HairShading::Karis(_), Some(k)) => Vec3::from(k.eval(
            &l.to_array(),
            &v.to_array(),
            &t.to_array(),
            &Transmittance::default(),
        )),
        (HairShading::ChiangFar(c), _) => chiang_far(c, t, v, l),
        _ => Vec3::ZERO,
    }
}

/// ChiangHair's far field (tabulated) for tangent `t`, view `v` and light
/// `l`, in Mitsuba's convention: wi towards the viewer (its offset h is the
/// one averaged across the fiber's visible width), wo towards the light.
#[inline]
fn chiang_far(c: &crate::fiber::chiang::ChiangFarTable, t: Vec3, v: Vec3, l: Vec3) -> Vec3 {
    let g = FiberAngles::new(t, v, l);
    let lobes = c.lobes_from_angles(g.view, g.light, g.phi);
    Vec3::from(lobes[0]) + Vec3::from(lobes[1]) + Vec3::from(lobes[2]) + Vec3::from(lobes[3])
}

struct EnvOne<'a> {
    v: Vec3,
    t: Vec3,
    sh: &'a [[f32; 3]; 9],
}

impl crate::fiber::karis::LobeVisitor<f32> for EnvOne<'_> {
    type Out = [f32; 3];
    fn visit<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
        self,
        m: &crate::fiber::karis::KarisHair<f32>,
    ) -> [f32; 3] {
        m.env_lobes_static::<R, TT, TRT, MS>(&self.v.to_array(), &self.t.to_array(), self.sh)
    }
}

/// Diffuse radiance of an opaque surface point. Light culling (`cull` > 0):
/// a light with `irradiance/π` below `cull` is skipped (albedo ≤ 1, so its
/// contribution is below `cull`).
pub fn shade_diffuse(shader: &Shader, p: Vec3, n: Vec3, albedo: Vec3) -> Vec3 {
    let (scene, shadows, cull) = (shader.scene, shader.shadows, shader.diffuse_cull());
    let mut e_total = Vec3::ZERO;
    for (li, (light, sm)) in scene.lights.iter().zip(shadows).enumerate() {
        let (l, e) = light.incident(p);
        let c = n.dot(l);
        if c <= 0.0 || e.max_element() * std::f32::consts::FRAC_1_PI < cull {
            continue;
        }
        let vis = sm
            .as_ref()
            .map_or(1.0, |m| m.visibility_surface(p + n * 1e-4 * m.scale(), n));
        e_total += e * c * vis * shader.hair_transmittance(li, p);
    }
    if let Some(env) = &scene.environment {
        // Irradiance of band-limited SH radiance: convolution with the
        // clamped cosine (Ramamoorthi & Hanrahan 2001): π, 2π/3, π/4.
        let a = [
            std::f32::consts::PI,
            2.0 * std::f32::consts::PI / 3.0,
            std::f32::consts::PI / 4.0,
        ];
        let band = [0, 1, 1, 1, 2, 2, 2, 2, 2];
        let sh: [[f32; 3]; 9] = std::array::from_fn(|k| env.sh[k].map(|c| c * a[band[k]]));
        e_total += Vec3::from(sh9_eval(&sh, &n.to_array())).max(Vec3::ZERO);
    }
    albedo * std::f32::consts::FRAC_1_PI * e_total
}
