//! What a solve keeps for the next render: the fiber's response table per
//! material, the medium per groom, and the solve per (geometry, lights,
//! environment, material, settings).

use super::*;

/// The key of a solve: the geometry, the lights, the environment's
/// directions, the material and the settings.
fn key(scene: &Scene, geometry: u64, env: Option<&EnvLights>, s: &VolumeSettings) -> u64 {
    use crate::raster::shadow::WordHash;
    let mut h = WordHash::default();
    h.word(geometry);
    for l in scene
        .lights
        .iter()
        .chain(env.into_iter().flat_map(|e| e.lights.iter()))
    {
        match *l {
            Light::Directional {
                direction,
                intensity,
                ..
            } => h.floats([
                0.0,
                direction.x,
                direction.y,
                direction.z,
                intensity.x,
                intensity.y,
                intensity.z,
            ]),
            Light::Point {
                position,
                intensity,
                ..
            } => h.floats([
                1.0,
                position.x,
                position.y,
                position.z,
                intensity.x,
                intensity.y,
                intensity.z,
            ]),
        }
    }
    h.floats(scene.spheres.iter().flat_map(|s| s.albedo.to_array()));
    for b in material_key(&scene.hair).bytes() {
        h.word(b as u64);
    }
    h.word(s.resolution as u64);
    h.word(s.photons as u64);
    h.word(s.bins as u64);
    h.word(s.transport as u64);
    h.word(s.directions as u64);
    h.finish()
}

/// The material's parameters, as the keys of the caches.
fn material_key(hair: &HairShading) -> String {
    match hair {
        HairShading::ChiangFar(c) => format!("{:?}", c.model()),
        HairShading::Karis(k) => format!("{k:?}"),
        HairShading::DEon(_) => String::new(),
    }
}

/// Response tables kept at once (least recently used dropped first).
pub const CACHE_TABLES: usize = 2;

/// The far-field response table of `hair`, built once per material: it
/// depends on nothing else, so a new light or view of the same hair reads
/// the table the last solve built (about 0.1 s of a solve's 0.5 s a light
/// on 2 cores).
pub(super) fn response_table(hair: &HairShading) -> Arc<response::ResponseTable> {
    type Tables = std::sync::Mutex<Vec<(String, Arc<response::ResponseTable>)>>;
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    let tables = TABLES.get_or_init(|| std::sync::Mutex::new(Vec::new()));
    let k = material_key(hair);
    if let Some(t) = kept(tables, &k) {
        return t;
    }
    // built outside the lock: the build runs on the pool
    let t = Arc::new(response::ResponseTable::new(
        crate::raster::shade::far_response(hair),
    ));
    keep(tables, k, t.clone(), CACHE_TABLES);
    t
}

/// A medium and, under the medium transport, its calibration against the
/// strands (applied to it).
pub(super) type BuiltMedium = (Medium, Option<Calibration>);

/// The medium of `input`'s geometry at `resolution` cells (its voxels
/// [`medium::FINE`] times as many), built, or kept from an earlier solve
/// of the same geometry: it depends on neither the lights nor the
/// material, so a new light's solve reads it again. `grid`: the strands'
/// (the calibration traces through it); `strands`: photons fly between
/// the strands (no calibration). None without hair.
pub(super) fn medium_of(
    input: &SolveInput,
    resolution: usize,
    grid: Option<&crate::raster::traced::SegmentGrid>,
    strands: bool,
) -> Option<Arc<BuiltMedium>> {
    type Media = std::sync::Mutex<Vec<(u64, Arc<BuiltMedium>)>>;
    static MEDIA: std::sync::OnceLock<Media> = std::sync::OnceLock::new();
    let media = MEDIA.get_or_init(|| std::sync::Mutex::new(Vec::new()));
    let key = {
        let mut h = crate::raster::shadow::WordHash::default();
        h.word(input.geometry);
        h.word(resolution as u64);
        h.word(strands as u64);
        h.finish()
    };
    // (geometry 0: no key was computed, nothing is kept)
    if input.geometry != 0 {
        if let Some(m) = kept(media, &key) {
            return Some(m);
        }
    }
    let mut medium = Medium::new(input.scene, resolution * medium::FINE)?;
    // the medium's transmittance calibrated against the strands'
    let calibration = match (grid, strands) {
        (_, true) => None,
        (Some(grid), false) => Some(calibrate(&calibration_rays(
            &medium,
            input.segments,
            grid,
            CALIBRATION_RAYS,
        ))),
        (None, false) => Some(calibrate(&[])),
    };
    if let Some(c) = calibration {
        medium.scale(c.k as f32);
    }
    let built = Arc::new((medium, calibration));
    if input.geometry != 0 {
        keep(media, key, built.clone(), CACHE_MEDIA);
    }
    Some(built)
}

/// Media kept at once.
const CACHE_MEDIA: usize = 1;

type Entry = (u64, Arc<VolumeRadiance>);

fn cache() -> &'static std::sync::Mutex<Vec<Entry>> {
    static CACHE: std::sync::OnceLock<std::sync::Mutex<Vec<Entry>>> = std::sync::OnceLock::new();
    CACHE.get_or_init(|| std::sync::Mutex::new(Vec::new()))
}

/// Solves kept at once (least recently used dropped first).
pub const CACHE_SOLVES: usize = 2;

/// [`VolumeRadiance::solve`], or the solve of an earlier render with the
/// same key (identical either way: the solve is deterministic); the flag
/// says whether it was reused.
pub fn cached(
    input: &SolveInput,
    settings: VolumeSettings,
    cancel: Option<&AtomicBool>,
    progress: Option<&AtomicUsize>,
) -> Option<(Arc<VolumeRadiance>, bool)> {
    let k = key(input.scene, input.geometry, input.env, &settings);
    if let Some(r) = kept(cache(), &k) {
        if let Some(p) = progress {
            p.fetch_add(PROGRESS_STEPS, Ordering::Relaxed);
        }
        return Some((r, true));
    }
    // a solve that traces nothing (no light, no photons) counts its steps at once
    let before = progress.map(|p| p.load(Ordering::Relaxed));
    let solved = VolumeRadiance::solve(input, settings, cancel, progress);
    if let (Some(p), Some(b)) = (progress, before) {
        let counted = p.load(Ordering::Relaxed) - b;
        p.fetch_add(PROGRESS_STEPS.saturating_sub(counted), Ordering::Relaxed);
    }
    let solved = Arc::new(solved?);
    keep(cache(), k, solved.clone(), CACHE_SOLVES);
    Some((solved, false))
}
