//! What a render builds from the geometry and the lights, whatever the
//! camera: the fiber counts towards each light, the environment as
//! directional lights with theirs, the strands' grid for traced
//! shadows, and the fiber counts towards each opaque sphere's centre
//! (the light it reflects into the hair, [`super::bounce`]). A camera
//! move re-renders with those of the previous frame (with
//! `reuse_shadow_maps`, as the shadow maps are): identical either way,
//! since building them is deterministic.

use super::density::{DensityGrid, FiberCount};
use super::env_light::EnvLights;
use super::methods::Methods;
use super::scene::{Light, RenderOptions, Scene};
use super::setup::WorldSegment;
use super::shadow::WordHash;
use super::traced::SegmentGrid;
use glam::Vec3;
use std::sync::{Arc, Mutex, OnceLock};

/// Bytes the cache may hold: one entry (the last lighting), if it fits.
pub const CACHE_BYTES: usize = 512 << 20;

/// The per-lighting structures of a render.
pub struct Lighting {
    /// Per light, the fiber count towards it (shadow model `density`, and
    /// dual scattering; None for a light without shadows).
    pub counts: Vec<Option<FiberCount>>,
    /// The strands for ray-traced shadows (shadow model `traced`).
    pub traced: Option<SegmentGrid>,
    /// The environment as directional lights (ChiangHair, DEonHair, and
    /// KarisHair under dual or volume scattering).
    pub env_lights: Option<EnvLights>,
    /// Per scene sphere, the fiber count towards its centre (dual
    /// scattering's sphere bounce; None for a sphere of no size; empty
    /// without the bounce or without hair).
    pub sphere_counts: Vec<Option<FiberCount>>,
}

impl Lighting {
    /// Nothing: no counts, no grid, no environment lights (for `lights`
    /// scene lights).
    pub fn none(lights: usize) -> Self {
        Self {
            counts: (0..lights).map(|_| None).collect(),
            traced: None,
            env_lights: None,
            sphere_counts: Vec::new(),
        }
    }

    /// Builds what `methods` need for `scene` (whose world segments are
    /// `segments`).
    pub fn build(
        scene: &Scene,
        opts: &RenderOptions,
        methods: &Methods,
        segments: &[WorldSegment],
    ) -> Self {
        // The near field's probes start within a fiber radius of the axis
        // (shade::near): the grid lists capsules that much farther out so
        // that they can be walked together.
        let spread = if methods.near_field {
            let r = segments
                .iter()
                .map(|s| s.ra.max(s.rb))
                .filter(|r| r.is_finite())
                .fold(0.0f32, f32::max);
            r * 1.001 + 1e-5
        } else {
            0.0
        };
        let traced = methods
            .traced
            .then(|| SegmentGrid::with_spread(segments, spread))
            .flatten();
        let env_lights = match &scene.environment {
            Some(env) if methods.environment_as_lights => Some(EnvLights::new(
                scene,
                env,
                opts.environment_directions,
                super::env_light::grid_resolution(opts.density_resolution, methods.dual),
                methods.counts_behind,
            )),
            _ => None,
        };
        Self {
            counts: fiber_counts(scene, opts, methods),
            traced,
            env_lights,
            sphere_counts: sphere_counts(scene, opts, methods),
        }
    }

    /// [`Self::build`], or the lighting the previous render built for the
    /// same geometry (`geometry`: [`super::shadow::geometry_hash`]),
    /// lights, environment and settings (with `opts.reuse_shadow_maps`);
    /// the flag says whether it was reused. A render that needs none of it
    /// builds nothing and leaves the cache as it is.
    pub fn cached(
        scene: &Scene,
        opts: &RenderOptions,
        methods: &Methods,
        segments: &[WorldSegment],
        geometry: u64,
    ) -> (Arc<Self>, bool) {
        let needed = methods.fiber_counts
            || methods.traced
            || methods.environment_as_lights
            || bounces(scene, opts, methods);
        if !opts.reuse_shadow_maps || !needed {
            return (Arc::new(Self::build(scene, opts, methods, segments)), false);
        }
        let k = key(scene, geometry, opts, methods);
        {
            let c = cache().lock().unwrap_or_else(|e| e.into_inner());
            if let Some((_, l)) = c.as_ref().filter(|(key, _)| *key == k) {
                return (l.clone(), true);
            }
        }
        let built = Arc::new(Self::build(scene, opts, methods, segments));
        let mut c = cache().lock().unwrap_or_else(|e| e.into_inner());
        *c = (built.bytes() <= CACHE_BYTES).then(|| (k, built.clone()));
        (built, false)
    }

    /// Bytes held by the counts and the grid.
    pub fn bytes(&self) -> usize {
        let counts: usize = self.counts.iter().flatten().map(FiberCount::bytes).sum();
        let env: usize = self
            .env_lights
            .iter()
            .flat_map(|e| &e.counts)
            .map(FiberCount::bytes)
            .sum();
        let spheres: usize = self
            .sphere_counts
            .iter()
            .flatten()
            .map(FiberCount::bytes)
            .sum();
        counts + env + spheres + self.traced.as_ref().map_or(0, SegmentGrid::bytes)
    }
}

/// Whether the spheres reflect light into the hair (dual scattering's
/// sphere bounce, a scene with spheres).
fn bounces(scene: &Scene, opts: &RenderOptions, methods: &Methods) -> bool {
    opts.sphere_bounce && methods.dual && !scene.spheres.is_empty()
}

/// Per sphere, the fiber count towards its centre where the spheres
/// reflect light into the hair ([`bounces`]; one density grid at a
/// quarter of the resolution for all of them: the light from the head
/// varies slowly), else nothing.
fn sphere_counts(
    scene: &Scene,
    opts: &RenderOptions,
    methods: &Methods,
) -> Vec<Option<FiberCount>> {
    if !bounces(scene, opts, methods) {
        return Vec::new();
    }
    let Some(grid) = DensityGrid::new(scene, (opts.density_resolution / 4).max(16)) else {
        return Vec::new();
    };
    scene
        .spheres
        .iter()
        .map(|s| {
            (s.radius > 0.0).then(|| {
                grid.fiber_count(&Light::Point {
                    position: s.center,
                    intensity: Vec3::ZERO,
                    shadows: true,
                })
            })
        })
        .collect()
}

/// Per light, its fiber count when the methods need it and the light casts
/// shadows (one density grid for all of them).
fn fiber_counts(scene: &Scene, opts: &RenderOptions, methods: &Methods) -> Vec<Option<FiberCount>> {
    let wanted = |l: &Light| {
        methods.fiber_counts
            && matches!(
                l,
                Light::Directional { shadows: true, .. } | Light::Point { shadows: true, .. }
            )
    };
    if !scene.lights.iter().any(wanted) {
        return vec![None; scene.lights.len()];
    }
    let Some(grid) = DensityGrid::new(scene, opts.density_resolution) else {
        return vec![None; scene.lights.len()];
    };
    scene
        .lights
        .iter()
        .map(|l| wanted(l).then(|| grid.fiber_count_with(l, methods.counts_behind)))
        .collect()
}

/// The key of a lighting: the geometry, where each light is and whether it
/// casts shadows, the environment, and the settings the build reads.
fn key(scene: &Scene, geometry: u64, opts: &RenderOptions, m: &Methods) -> u64 {
    let mut h = WordHash::default();
    h.word(geometry);
    for l in &scene.lights {
        match *l {
            Light::Directional {
                direction, shadows, ..
            } => h.floats([
                0.0,
                direction.x,
                direction.y,
                direction.z,
                shadows as u8 as f32,
            ]),
            Light::Point {
                position, shadows, ..
            } => h.floats([
                1.0,
                position.x,
                position.y,
                position.z,
                shadows as u8 as f32,
            ]),
        }
    }
    h.floats(scene.environment.iter().flat_map(|e| e.sh).flatten());
    h.word(opts.density_resolution as u64);
    h.word(opts.environment_directions as u64);
    for flag in [
        m.fiber_counts,
        m.counts_behind,
        m.traced,
        m.environment_as_lights,
        m.dual,
        bounces(scene, opts, m),
    ] {
        h.word(flag as u64);
    }
    h.finish()
}

type Entry = (u64, Arc<Lighting>);

fn cache() -> &'static Mutex<Option<Entry>> {
    static CACHE: OnceLock<Mutex<Option<Entry>>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(None))
}
