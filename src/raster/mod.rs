//! CPU software rasterizer for hair strand and card scenes.
//!
//! Pipeline (after Capcom's RE ENGINE strand renderer and Karis 2016), one
//! module per stage, run in this order by [`render_with_progress`]:
//!
//! 0. [`lod`]: the fraction of the strands drawn, widened to keep their
//!    area (all of them by default);
//! 1. [`setup`]: the scene's bounding sphere and [`view`]; world-space
//!    segments for the shadow maps;
//! 2. [`shadow`]: one map per shadowed light (first hair and opaque depth
//!    seen from the light; hair attenuates exponentially behind the first
//!    hair, or by accumulated opacity; PCF), reused across renders while
//!    nothing it depends on changes, skipped for lights [`cull`] shows to
//!    be invisible;
//! 3. [`setup`]: strands cut into segments, clipped to the near plane and
//!    projected; [`cull`]: frustum culling; [`shade`]: per-vertex shading
//!    when it is on, at every strand or at the [`guides`];
//! 4. [`bin`]: segments, card triangles and mesh triangles (after
//!    back-face culling) binned to 16×16 tiles, in scene order;
//! 5. [`tile`], in parallel: opaque pass (background or environment,
//!    spheres, meshes), strand and card passes (analytic coverage from
//!    [`coverage`], depth-tested; opaque culling per tile), shading of the
//!    tile's hair fragments in one batch ([`shade`]), resolve of the
//!    transparency layers ([`oit`]: Multi-Layer Alpha Blending or an exact
//!    sorted composite) over the opaque surface; or, with coverage samples
//!    ([`samples`]), the nearest fragment per sample, only those owning a
//!    sample shaded, each pixel the mean over its samples;
//! 6. tiles copied into the image.
//!
//! Rendering is deterministic: every tile processes its primitives in
//! scene order, whatever the thread count. Non-finite values never reach
//! the image (they are replaced by 0 and counted).

pub mod bin;
pub mod bounce;
pub mod coverage;
pub mod cull;
pub mod density;
pub mod env_light;
pub mod guides;
pub mod lighting;
pub mod lod;
pub mod memory;
pub mod methods;
pub mod oit;
pub mod pack;
pub mod samples;
pub mod scene;
pub mod setup;
pub mod shade;
pub mod shadow;
pub mod tile;
pub mod traced;
pub mod view;
pub mod volume;

use crate::threads::pool;
use bin::{bin_in_order, bin_to_tiles, segment_tiles, triangle_tiles, TileGrid, TILE};
use rayon::prelude::*;
use scene::{RenderOptions, Scene, Transparency};
use shade::Shader;
use shadow::ShadowMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use tile::{render_tile, TileBins, TileContext, TileMemory, TileResult};
use view::View;

/// Statistics of one render.
#[derive(Debug, Clone, Default)]
pub struct RenderStats {
    pub segments: usize,
    pub segments_visible: usize,
    /// Strand vertices shaded (per-vertex shading; frustum culling leaves
    /// out those of segments that reach no pixel, and shading on demand
    /// those of segments that draw no fragment).
    pub vertices_shaded: usize,
    /// Mesh triangles skipped by back-face culling.
    pub backfaces_culled: usize,
    pub fragments: u64,
    pub non_finite_pixels: u64,
    /// Segments dropped behind an opaque sphere before binning
    /// ([`cull::visible_segments`]), and segment or card-triangle visits
    /// skipped because the tile's opaque surface is in front of them
    /// everywhere.
    pub culled_behind_opaque: u64,
    /// Hair fragments and segment visits skipped by hair culling (behind
    /// hair that is nearly opaque; see `cull::BehindHair`).
    pub culled_behind_hair: u64,
    /// Light evaluations skipped by light culling, and the largest bound of
    /// a skipped contribution (radiance; a pixel changes by at most this
    /// times the number of lights).
    pub lights_culled: u64,
    pub light_cull_max_skipped: f32,
    /// Shadow maps taken from an earlier render (see `reuse_shadow_maps`).
    pub shadow_maps_reused: usize,
    /// Whether the fiber counts, the environment's directions and the
    /// traced shadows' grid were those of an earlier render ([`lighting`]).
    pub lighting_reused: bool,
    /// Shadowed lights whose map was not built: light culling skips them at
    /// every hair point (see `lights_without_visible_effect`).
    pub shadow_maps_skipped: usize,
    /// Multiple scattering through the volume ([`volume`]): the solve's
    /// wall time in milliseconds (0 when reused), whether it was reused,
    /// and its voxels holding hair.
    pub volume_ms: f64,
    pub volume_reused: bool,
    pub volume_voxels: usize,
    /// The mean transmittance of rays from the hair in all directions
    /// through the strands, through the medium, and through the medium
    /// calibrated ([`volume::Calibration`]); None without a solve, or under
    /// the strands transport, which does not calibrate the medium.
    pub volume_transmittance: Option<(f64, f64, f64)>,
    /// The fraction of the strands drawn ([`lod`]) and their number.
    pub lod_fraction: f32,
    pub strands_drawn: usize,
    /// The strands' overlap on screen that `lod: auto` read
    /// ([`lod::overlap`]); None under a fixed fraction.
    pub lod_overlap: Option<f32>,
    /// Guide-strand lighting ([`guides`]): the guide strands (0 when off),
    /// and the wall time of choosing them and the taps (about 0 when the
    /// last render's are reused), in milliseconds.
    pub guide_strands: usize,
    pub guides_ms: f64,
    /// Wall time of per-vertex shading before the tiles (`vertex` shading;
    /// at the guides and gathered, with guide-strand lighting), in
    /// milliseconds. Shaded on demand, the vertices are shaded in the
    /// tiles (`tiles_ms`), and this is the near-clipped ends alone.
    pub vertex_ms: f64,
    /// Wall time of the phases, in milliseconds: shadow maps, setup
    /// (per-vertex shading when on, projection, binning), tiles
    /// (rasterization, shading, resolve), and the whole render.
    pub shadow_ms: f64,
    pub setup_ms: f64,
    pub tiles_ms: f64,
    pub total_ms: f64,
    /// The tiles' own times summed, in milliseconds: against `tiles_ms`
    /// times the threads, how busy the threads were in the tile pass
    /// (idle time is imbalance; busy time that grows with the threads is
    /// memory bandwidth or contention).
    pub tiles_busy_ms: f64,
}

/// The rendered image: linear radiance, row-major, RGB.
#[derive(Debug, Clone)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

/// Renders `scene`; returns the image and statistics.
pub fn render(scene: &Scene, opts: &RenderOptions) -> (Image, RenderStats) {
    let (done, cancel) = (AtomicUsize::new(0), AtomicBool::new(false));
    render_with_progress(scene, opts, &done, &cancel).expect("not cancelled")
}

/// Number of tiles a render of `scene` processes.
pub fn tile_count(scene: &Scene) -> usize {
    TileGrid::new(scene.camera.width, scene.camera.height).count()
}

/// The progress total of a render of `scene` with `opts`: its tiles, and
/// [`volume::PROGRESS_STEPS`] for the volume's solve when it has one (a
/// reused solve counts them at once).
pub fn progress_total(scene: &Scene, opts: &RenderOptions) -> usize {
    tile_count(scene)
        + if methods::Methods::new(scene, opts).volume {
            volume::PROGRESS_STEPS
        } else {
            0
        }
}

/// [`render`], counting its progress in `done` (finished tiles, and the
/// volume's solve: [`progress_total`]) and stopping early (None) once
/// `cancel` is set.
pub fn render_with_progress(
    scene: &Scene,
    opts: &RenderOptions,
    done: &AtomicUsize,
    cancel: &AtomicBool,
) -> Option<(Image, RenderStats)> {
    let t0 = std::time::Instant::now();
    let ms = |t: std::time::Instant| t.elapsed().as_secs_f64() * 1e3;
    let mut stats = RenderStats::default();

    // 0. Strand level of detail.
    (stats.lod_fraction, stats.lod_overlap) = lod::choose(opts.lod, &scene.strands, &scene.camera);
    // the scene with every strand, before the level of detail
    let whole = scene;
    let (reduced, guide_settings, kept, widen) =
        match lod::reduce(&scene.strands, stats.lod_fraction) {
            Some(lod::Reduced {
                strands,
                kept,
                widen,
            }) => (
                Some(Scene {
                    camera: scene.camera.clone(),
                    lights: scene.lights.clone(),
                    environment: scene.environment.clone(),
                    strands,
                    cards: scene.cards.clone(),
                    spheres: scene.spheres.clone(),
                    triangles: scene.triangles.clone(),
                    hair: scene.hair.clone(),
                }),
                // given guides, numbered among the strands drawn
                opts.guides.for_subset(&kept),
                kept,
                widen,
            ),
            None => (None, opts.guides.clone(), Vec::new(), 1.0),
        };
    let scene = reduced.as_ref().unwrap_or(scene);
    stats.strands_drawn = scene.strands.strand_count();

    // 1. Bounds, view, world-space segments.
    let bounds = setup::scene_bounds(scene);
    let view = View::new(&scene.camera, setup::near_reference(scene, bounds));
    let world = setup::world_segments(&scene.strands);

    // 2. Shadow maps.
    // The key of the caches a frame reads (maps, lighting, volume), once.
    let methods = methods::Methods::new(scene, opts);
    // Under a level of detail, maps that hold hair are drawn from every
    // strand (`lod` module docs), and the key is then every strand's with
    // the fraction (the strands drawn follow from the two).
    let every_strand = reduced.is_some() && opts.shadow_model.maps_hair();
    let geometry = if !(opts.reuse_shadow_maps || methods.volume) {
        0
    } else if every_strand {
        let mut h = shadow::WordHash::default();
        h.word(shadow::geometry_hash(whole));
        h.word(stats.lod_fraction.to_bits() as u64);
        h.finish()
    } else {
        shadow::geometry_hash(scene)
    };
    let (casters, map_bounds) = if every_strand {
        (
            lod::Casters::every(&whole.strands, &scene.strands, &kept),
            setup::scene_bounds(whole),
        )
    } else {
        (lod::Casters::Drawn(&world), bounds)
    };
    let shadows = shadow_maps(
        scene,
        opts,
        &casters,
        map_bounds,
        geometry,
        &mut stats,
        Some(cancel),
    );
    if cancel.load(Ordering::Relaxed) {
        return None;
    }
    stats.shadow_ms = ms(t0);

    // 3. Segments, frustum culling, per-vertex shading.
    let t1 = std::time::Instant::now();
    let (lit, lighting_reused) =
        lighting::Lighting::cached(scene, opts, &methods, &world, geometry);
    stats.lighting_reused = lighting_reused;
    let volume = if methods.volume {
        let tv = std::time::Instant::now();
        let input = volume::SolveInput {
            scene,
            geometry,
            segments: &world,
            traced: lit.traced.as_ref(),
            env: lit.env_lights.as_ref(),
        };
        let solved = volume::cached(
            &input,
            volume::VolumeSettings::of(opts),
            Some(cancel),
            Some(done),
        );
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        if let Some((v, reused)) = &solved {
            stats.volume_reused = *reused;
            stats.volume_voxels = v.voxels();
            stats.volume_ms = if *reused { 0.0 } else { ms(tv) };
            stats.volume_transmittance = v.calibration.map(|c| (c.strands, c.medium, c.calibrated));
        }
        solved.map(|s| s.0)
    } else {
        None
    };
    let tg = std::time::Instant::now();
    let guide_map = guide_map(scene, opts, &guide_settings, geometry);
    stats.guide_strands = guide_map.as_ref().map_or(0, |g| g.guides.len());
    stats.guides_ms = ms(tg);
    let shader = Shader::new(scene, &shadows, lit, Some(cancel), opts)
        .with_lod_widen(widen)
        .with_sphere_bounce(opts)
        .with_vertex_terms(volume, &world, view.eye, guide_map.clone());
    let grid = TileGrid::new(view.width, view.height);
    let mut segs = setup::project_segments(&scene.strands, &view);
    stats.segments = segs.len();
    let dropped;
    (segs, dropped) = cull::visible_segments(
        segs,
        opts.frustum_culling.then_some(grid),
        cull::culling_spheres(scene, opts),
        &view,
    );
    stats.culled_behind_opaque += dropped;
    let all_from_guides = guide_map
        .as_ref()
        .filter(|_| opts.guides.terms == guides::GuideTerms::All);
    // Per-vertex shading on demand: each vertex shaded when a tile first
    // draws a fragment next to it (`shade::VertexColors`), where the
    // tiles add strand fragments to layers (not coverage samples) and
    // every vertex is shaded on its own (not gathered from guides).
    let on_demand = (opts.vertex_shading
        && opts.vertices_on_demand
        && all_from_guides.is_none()
        && !matches!(opts.transparency, Transparency::Coverage(_)))
    .then(|| shade::VertexColors::new(&scene.strands, &shader, view.eye));
    if on_demand.is_some() {
        let tv = std::time::Instant::now();
        // (a clipped end is shaded where it lies; the vertices in the tiles)
        shade_clipped_ends(&mut segs, &shader, view.eye);
        stats.vertex_ms = ms(tv);
    } else if opts.vertex_shading {
        let tv = std::time::Instant::now();
        let used = opts
            .frustum_culling
            .then(|| vertices_used(&segs, scene.strands.points.len()));
        let colors = match all_from_guides {
            Some(g) => {
                let needed = g.needed(used.as_deref());
                stats.vertices_shaded = needed.iter().filter(|&&x| x).count();
                let at_guides = shade::shade_vertices(scene, &shader, view.eye, Some(&needed));
                gather_from_guides(g, &at_guides, used.as_deref())
            }
            None => {
                stats.vertices_shaded = used.as_ref().map_or(scene.strands.points.len(), |u| {
                    u.iter().filter(|&&x| x).count()
                });
                shade::shade_vertices(scene, &shader, view.eye, used.as_deref())
            }
        };
        setup::color_segments(&mut segs, &colors);
        shade_clipped_ends(&mut segs, &shader, view.eye);
        stats.vertex_ms = ms(tv);
    }

    // 4. Cards and meshes; binning.
    let cards = setup::project_card_tris(scene, &view);
    let cull = if opts.backface_culling {
        cull::meshes_to_cull(scene, &view)
    } else {
        Vec::new()
    };
    let (solids, backfaces_culled) = setup::project_solid_tris(scene, &view, &cull);
    stats.backfaces_culled = backfaces_culled;
    let seg_ranges: Vec<_> =
        pool().install(|| segs.par_iter().map(|s| segment_tiles(s, grid)).collect());
    // Tiles that draw their hair nearest first take it so from their bins:
    // the segments sorted once for all tiles (nearest depth, then scene
    // order: what each tile's own sort gave).
    let seg_bins = if opts.draws_nearest_first() {
        // (a view depth is positive and finite: its bits order as it does)
        let ids: Vec<u32> = pool().install(|| {
            let mut order: Vec<u64> = segs
                .par_iter()
                .enumerate()
                .map(|(i, s)| (s.za.min(s.zb).to_bits() as u64) << 32 | i as u64)
                .collect();
            order.par_sort_unstable();
            order.par_iter().map(|&k| k as u32).collect()
        });
        bin_in_order(&seg_ranges, &ids, grid)
    } else {
        bin_to_tiles(&seg_ranges, grid)
    };
    stats.segments_visible = seg_bins.binned;
    let card_ranges: Vec<_> = cards.iter().map(|t| triangle_tiles(&t.p, grid)).collect();
    let card_bins = bin_to_tiles(&card_ranges, grid);
    let solid_ranges: Vec<_> = solids.iter().map(|t| triangle_tiles(&t.p, grid)).collect();
    let solid_bins = bin_to_tiles(&solid_ranges, grid);
    stats.setup_ms = ms(t1);

    // 5. Tiles.
    let t2 = std::time::Instant::now();
    let ctx = TileContext {
        scene,
        opts,
        view: &view,
        shadows: &shadows,
        shader: &shader,
        segs: &segs,
        cards: &cards,
        solids: &solids,
        uniform_background: tile::uniform_background(scene, opts),
        vertex_colors: on_demand.as_ref(),
    };
    let busy_ns = std::sync::atomic::AtomicU64::new(0);
    let results: Vec<TileResult> = pool().install(|| {
        (0..grid.count())
            .into_par_iter()
            .map_init(TileMemory::default, |mem, ti| {
                if cancel.load(Ordering::Relaxed) {
                    return TileResult::empty();
                }
                let bins = TileBins {
                    segs: seg_bins.tile(ti),
                    cards: card_bins.tile(ti),
                    solids: solid_bins.tile(ti),
                };
                let (tx, ty) = grid.coords(ti);
                let t = std::time::Instant::now();
                let r = render_tile(&ctx, &bins, tx, ty, mem);
                busy_ns.fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
                done.fetch_add(1, Ordering::Relaxed);
                r
            })
            .collect()
    });
    if cancel.load(Ordering::Relaxed) {
        return None;
    }
    stats.tiles_ms = ms(t2);
    if let Some(c) = &on_demand {
        stats.vertices_shaded = c.shaded_count();
    }
    stats.tiles_busy_ms = busy_ns.load(Ordering::Relaxed) as f64 * 1e-6;

    // 6. The image.
    let image = assemble(&results, grid, view.width, view.height, &mut stats);
    (stats.lights_culled, stats.light_cull_max_skipped) = shader.light_cull_stats();
    stats.total_ms = ms(t0);
    Some((image, stats))
}

/// One map per light (None for lights without shadows and for those
/// [`cull::lights_without_visible_effect`] skips), built in parallel or
/// taken from the cache of earlier renders (`reuse_shadow_maps`; `geometry`:
/// [`shadow::geometry_hash`] of the scene).
fn shadow_maps(
    scene: &Scene,
    opts: &RenderOptions,
    casters: &lod::Casters<'_>,
    bounds: setup::Bounds,
    geometry: u64,
    stats: &mut RenderStats,
    cancel: Option<&AtomicBool>,
) -> Vec<Option<Arc<ShadowMap>>> {
    let unneeded = cull::lights_without_visible_effect(scene, opts, bounds);
    let built: Vec<(Option<Arc<ShadowMap>>, bool)> = pool().install(|| {
        scene
            .lights
            .par_iter()
            .zip(&unneeded)
            .map(|(l, &skip)| {
                if skip {
                    (None, false)
                } else if opts.reuse_shadow_maps {
                    ShadowMap::build_cached(l, scene, casters, bounds, opts, geometry, cancel)
                } else {
                    (
                        ShadowMap::build(l, scene, casters.get(), bounds, opts, cancel)
                            .map(Arc::new),
                        false,
                    )
                }
            })
            .collect()
    });
    stats.shadow_maps_reused = built.iter().filter(|b| b.1).count();
    stats.shadow_maps_skipped = unneeded.iter().filter(|&&u| u).count();
    built.into_iter().map(|b| b.0).collect()
}

/// Per-vertex shading of segments clipped at the near plane: a clipped end
/// is shaded where it lies, not interpolated towards the vertex beyond it
/// (behind the camera, so seen from the wrong side).
fn shade_clipped_ends(segs: &mut [setup::Segment], shader: &Shader<'_>, eye: glam::Vec3) {
    // (in parallel: each segment's ends on their own)
    pool().install(|| {
        segs.par_iter_mut()
            .filter(|s| s.ta > 0.0 || s.tb < 1.0)
            .for_each(|s| shade_clipped(s, shader, eye))
    });
}

/// [`shade_clipped_ends`] of one segment.
fn shade_clipped(s: &mut setup::Segment, shader: &Shader<'_>, eye: glam::Vec3) {
    let t = (s.pb - s.pa).normalize_or_zero();
    // World segment index: strand vertices minus one per earlier strand.
    let segment = s.i - s.strand;
    let shade_at = |p: glam::Vec3, radius: f32| {
        let fiber = shade::Fiber {
            radius,
            strand: s.strand,
            segment,
        };
        shader.shade(p, t, (eye - p).normalize_or_zero(), fiber)
    };
    let (ca, cb) = (
        (s.ta > 0.0).then(|| shade_at(s.pa, s.ra)),
        (s.tb < 1.0).then(|| shade_at(s.pb, s.rb)),
    );
    s.ca = ca.unwrap_or(s.ca);
    s.cb = cb.unwrap_or(s.cb);
}

/// The guide map of guide-strand lighting (`g`: the settings, given guides
/// numbered among the strands drawn), when it is on and something is
/// shaded at vertices (`vertex` or `split` shading): cached per geometry
/// while shadow maps are (`geometry`: [`shadow::geometry_hash`], or 0 when
/// the render does not reuse).
fn guide_map(
    scene: &Scene,
    opts: &RenderOptions,
    g: &guides::Guides,
    geometry: u64,
) -> Option<Arc<guides::GuideMap>> {
    if !g.on() || !(opts.vertex_shading || opts.split_shading) {
        return None;
    }
    Some(if opts.reuse_shadow_maps {
        let geometry = if geometry != 0 {
            geometry
        } else {
            shadow::geometry_hash(scene)
        };
        guides::GuideMap::cached(&scene.strands, g, geometry)
    } else {
        Arc::new(guides::GuideMap::new(&scene.strands, g))
    })
}

/// Per vertex where `used` is set (all when `None`), the radiance gathered
/// from the guides' vertices (`at_guides`); 0 elsewhere.
fn gather_from_guides(
    g: &guides::GuideMap,
    at_guides: &[glam::Vec3],
    used: Option<&[bool]>,
) -> Vec<glam::Vec3> {
    pool().install(|| {
        (0..at_guides.len())
            .into_par_iter()
            .map(|i| {
                if used.is_some_and(|u| !u[i]) {
                    glam::Vec3::ZERO
                } else {
                    g.gather(i, |j| at_guides[j])
                }
            })
            .collect()
    })
}

/// Which strand vertices the segments use (for per-vertex shading).
fn vertices_used(segs: &[setup::Segment], vertex_count: usize) -> Vec<bool> {
    use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
    // (in parallel: every store writes `true`, so the result is the same in
    // any order)
    pool().install(|| {
        let used: Vec<AtomicBool> = (0..vertex_count)
            .into_par_iter()
            .map(|_| AtomicBool::new(false))
            .collect();
        segs.par_iter().for_each(|s| {
            used[s.i as usize].store(true, Relaxed);
            used[s.i as usize + 1].store(true, Relaxed);
        });
        used.into_par_iter().map(AtomicBool::into_inner).collect()
    })
}

/// The tiles copied into a `width × height` image; their counters added to
/// `stats`.
fn assemble(
    results: &[TileResult],
    grid: TileGrid,
    w: u32,
    h: u32,
    stats: &mut RenderStats,
) -> Image {
    for tile in results {
        stats.fragments += tile.fragments;
        stats.non_finite_pixels += tile.non_finite;
        stats.culled_behind_opaque += tile.culled;
        stats.culled_behind_hair += tile.hair_culled;
    }
    // One row of tiles per task.
    let mut data = vec![0.0f32; (w * h * 3) as usize];
    let row = (w * TILE * 3) as usize;
    pool().install(|| {
        data.par_chunks_mut(row).enumerate().for_each(|(ty, out)| {
            let rows = out.len() / (w as usize * 3);
            for tx in 0..grid.x {
                let tile = &results[(ty as u32 * grid.x + tx) as usize];
                if tile.pixels.is_empty() {
                    continue;
                }
                for j in 0..rows {
                    for i in 0..TILE.min(w - tx * TILE) {
                        let src = ((j as u32 * TILE + i) * 3) as usize;
                        let dst = (j * w as usize + (tx * TILE + i) as usize) * 3;
                        out[dst..dst + 3].copy_from_slice(&tile.pixels[src..src + 3]);
                    }
                }
            }
        })
    });
    Image {
        width: w,
        height: h,
        data,
    }
}
