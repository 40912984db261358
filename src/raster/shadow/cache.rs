//! The shadow-map cache: maps of recent renders reused while nothing they
//! depend on changed.

use super::ShadowMap;
use crate::raster::scene::{Light, RenderOptions, Scene};
use crate::raster::setup::Bounds;

/// Shadow maps of recent renders, reused while nothing they depend on
/// changed (the geometry, the light, the shadow settings): a camera move
/// re-renders with the maps of the previous frame. Holds at most
/// [`CACHE_MAPS`] maps and [`CACHE_BYTES`] bytes (least recently used
/// dropped first); each map costs `2 · size²` floats (plus `SLABS · size²`
/// floats and `LAYERS · size²` 16-byte deposits with the opacity model):
/// 8 MiB at the default 1024² (112 MiB with the opacity model), so four
/// maps fit at the default size with either model, while a map too large
/// for the budget (an 8192² opacity map is 7 GiB) is used once and freed.
pub const CACHE_MAPS: usize = 4;

/// Bytes the cache may hold (see [`CACHE_MAPS`]).
pub const CACHE_BYTES: usize = 512 << 20;

/// Bytes held by a shadow map's buffers.
pub fn map_bytes(m: &ShadowMap) -> usize {
    (m.hair.len() + m.opaque.len() + m.slabs.len()) * std::mem::size_of::<f32>()
        + m.layers.len() * std::mem::size_of::<super::Deposit>()
}

type CacheEntry = (u64, std::sync::Arc<ShadowMap>);

fn cache() -> &'static std::sync::Mutex<Vec<CacheEntry>> {
    static CACHE: std::sync::OnceLock<std::sync::Mutex<Vec<CacheEntry>>> =
        std::sync::OnceLock::new();
    CACHE.get_or_init(|| std::sync::Mutex::new(Vec::new()))
}

/// 64-bit hash of a stream of words (a multiply-xorshift mix; collisions
/// between different scenes have probability ~2^-64).
#[derive(Default)]
pub struct WordHash(u64);

impl WordHash {
    #[inline]
    pub fn word(&mut self, w: u64) {
        self.0 = (self.0 ^ w)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .rotate_left(29);
    }
    pub fn floats(&mut self, xs: impl IntoIterator<Item = f32>) {
        let mut n = 0u64;
        for x in xs {
            self.word(x.to_bits() as u64);
            n += 1;
        }
        self.word(n);
    }
    /// The `n` items `item(i)` (each a few floats): fixed runs of them
    /// hashed in parallel, the runs' hashes then in order (the same value
    /// at every thread count; a head's 425 000 vertices took 3 ms a frame
    /// on one thread).
    pub fn items<const K: usize>(&mut self, n: usize, item: impl Fn(usize) -> [f32; K] + Sync) {
        use rayon::prelude::*;
        const RUN: usize = 1 << 14;
        let run = |r: usize| {
            let mut h = WordHash::default();
            for i in r * RUN..((r + 1) * RUN).min(n) {
                for x in item(i) {
                    h.word(x.to_bits() as u64);
                }
            }
            h.0
        };
        let runs: Vec<u64> = if n > RUN {
            crate::threads::pool()
                .install(|| (0..n.div_ceil(RUN)).into_par_iter().map(run).collect())
        } else {
            (0..n.div_ceil(RUN)).map(run).collect()
        };
        for r in runs {
            self.word(r);
        }
        self.word(n as u64);
    }
    pub fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 31)
    }
}

/// Hash of everything a shadow map draws (strands, cards with their alpha
/// textures, spheres, meshes) and of the fibers the cards stand for.
pub fn geometry_hash(scene: &Scene) -> u64 {
    let mut h = WordHash::default();
    for st in [&scene.strands, &scene.cards.fibers] {
        h.items(st.points.len(), |i| st.points[i].to_array());
        h.items(st.radii.len(), |i| [st.radii[i]]);
        h.items(st.offsets.len(), |i| [f32::from_bits(st.offsets[i])]);
    }
    let c = &scene.cards;
    h.floats(c.corners.iter().flat_map(|p| p.to_array()));
    h.floats(c.uvs.iter().flatten().copied());
    h.floats(c.texture.iter().map(|&t| f32::from_bits(t)));
    for t in &c.textures {
        h.word(((t.width as u64) << 32) | t.height as u64);
        h.floats(t.alpha.iter().copied());
    }
    h.floats(
        scene
            .spheres
            .iter()
            .flat_map(|s| [s.center.x, s.center.y, s.center.z, s.radius]),
    );
    h.floats(
        scene
            .triangles
            .iter()
            .flat_map(|t| t.p)
            .flat_map(|p| p.to_array()),
    );
    h.finish()
}

impl ShadowMap {
    /// [`ShadowMap::build`], or the map an earlier render built for the same
    /// geometry (`geometry` = [`geometry_hash`]), light and settings; the
    /// flag says whether it was reused. Identical either way: building is
    /// deterministic.
    pub fn build_cached(
        light: &Light,
        scene: &Scene,
        casters: &crate::raster::lod::Casters<'_>,
        bounds: Bounds,
        opts: &RenderOptions,
        geometry: u64,
        cancel: Option<&std::sync::atomic::AtomicBool>,
    ) -> (Option<std::sync::Arc<ShadowMap>>, bool) {
        let (pos_or_dir, shadows) = match *light {
            Light::Directional {
                direction, shadows, ..
            } => (direction, shadows),
            Light::Point {
                position, shadows, ..
            } => (position, shadows),
        };
        if !shadows {
            return (None, false);
        }
        let mut h = WordHash::default();
        h.word(geometry);
        h.word(matches!(light, Light::Point { .. }) as u64);
        h.floats(pos_or_dir.to_array());
        h.floats(bounds.center.to_array());
        h.floats([bounds.radius, opts.shadow_density]);
        h.word(opts.shadow_map_size as u64);
        h.word(opts.pcf_radius as u64);
        h.word(opts.shadow_model as u64);
        let key = h.finish();
        if let Some(map) = crate::lru::kept(cache(), &key) {
            return (Some(map), true);
        }
        let Some(m) = Self::build(light, scene, casters.get(), bounds, opts, cancel) else {
            return (None, false);
        };
        let m = std::sync::Arc::new(m);
        let bytes = map_bytes(&m);
        if bytes <= CACHE_BYTES {
            let mut c = cache().lock().unwrap_or_else(|e| e.into_inner());
            let held = |c: &Vec<CacheEntry>| c.iter().map(|e| map_bytes(&e.1)).sum::<usize>();
            while !c.is_empty() && (c.len() >= CACHE_MAPS || held(&c) + bytes > CACHE_BYTES) {
                c.remove(0);
            }
            c.push((key, m.clone()));
        }
        (Some(m), false)
    }
}

/// Drops every cached shadow map (see [`ShadowMap::build_cached`]).
pub fn clear_cache() {
    cache().lock().unwrap_or_else(|e| e.into_inner()).clear();
}

#[cfg(test)]
mod tests {
    use super::WordHash;

    /// 1. `items` hashes runs of items in parallel: the value is the same
    ///    on one thread and on all, changes with any one float (the last
    ///    run's too), and with the count.
    #[test]
    fn t01_items_independent_of_threads() {
        let n = 3 * (1 << 14) + 17;
        let x: Vec<[f32; 3]> = (0..n)
            .map(|i| [i as f32, (i as f32).sqrt(), -(i as f32) * 0.5])
            .collect();
        let hash = |x: &[[f32; 3]]| {
            let mut h = WordHash::default();
            h.items(x.len(), |i| x[i]);
            h.finish()
        };
        let many = hash(&x);
        // (other tests running meanwhile just run on one thread too)
        crate::threads::set_single_threaded(true);
        let one = hash(&x);
        crate::threads::set_single_threaded(false);
        assert_eq!(one, many);
        let mut y = x.clone();
        y[n - 1][2] = 1.0;
        assert_ne!(hash(&y), many);
        assert_ne!(hash(&x[..n - 1]), many);
    }
}
