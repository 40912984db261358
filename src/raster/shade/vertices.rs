//! Per-vertex shading: the radiance at strand vertices, for segments that
//! interpolate it (`render.shading = "vertex"`).

use super::{Fiber, Shader};
use crate::raster::scene::{Scene, Strands};
use crate::threads::pool;
use glam::Vec3;
use rayon::prelude::*;

/// Radiance shaded at the strand vertices where `needed` is set (all when
/// `None`; 0 elsewhere), for per-vertex shading. Tangent: the central
/// difference.
pub fn shade_vertices(
    scene: &Scene,
    shader: &Shader<'_>,
    eye: Vec3,
    needed: Option<&[bool]>,
) -> Vec<Vec3> {
    let st = &scene.strands;
    // (each step below in parallel: on one thread they were 3% of a `fast`
    // frame, and at 16 threads half of its per-vertex phase)
    // the strand of each vertex
    let owner: Vec<usize> = crate::threads::concat_ordered(
        st.strand_count(),
        |s| (st.offsets[s + 1] - st.offsets[s]) as usize,
        |s, push| {
            for _ in st.offsets[s]..st.offsets[s + 1] {
                push(s)
            }
        },
    );
    let tangent = |i: usize| vertex_tangent(st, owner[i], i);
    let fiber = |i: usize| vertex_fiber(st, owner[i], i);
    // The vertices to shade, as indices into the strands' points, in
    // world-space locality order (below).
    let mut index: Vec<usize> = pool().install(|| match needed {
        Some(m) => (0..st.points.len())
            .into_par_iter()
            .filter(|&i| m[i])
            .collect(),
        None => (0..st.points.len()).into_par_iter().collect(),
    });
    locality_order(&mut index, &st.points);
    let points: Vec<Vec3> = pool().install(|| index.par_iter().map(|&i| st.points[i]).collect());
    let shaded = shader
        .shade_batch(&points, &|j| tangent(index[j]), &|j| fiber(index[j]), eye)
        .unwrap_or_else(|| {
            pool().install(|| {
                index
                    .par_iter()
                    .map(|&i| {
                        let p = st.points[i];
                        shader.shade(p, tangent(i), (eye - p).normalize_or_zero(), fiber(i))
                    })
                    .collect()
            })
        });
    scatter(st.points.len(), &index, &shaded)
}

/// The tangent at vertex `i` of strand `s`: the central difference (one
/// sided at the ends).
#[inline]
pub(super) fn vertex_tangent(st: &Strands, s: usize, i: usize) -> Vec3 {
    let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
    let (a, b) = (st.points[i.max(i0 + 1) - 1], st.points[(i + 1).min(i1 - 1)]);
    (b - a).normalize_or_zero()
}

/// The fiber at vertex `i` of strand `s`: its radius there, on the segment
/// starting at the vertex (at the tip, the strand's last one).
#[inline]
pub(super) fn vertex_fiber(st: &Strands, s: usize, i: usize) -> Fiber {
    let last = (st.offsets[s + 1] as usize).max(st.offsets[s] as usize + 2) - 2;
    Fiber {
        radius: st.radii[i],
        strand: s as u32,
        segment: (i.min(last) - s) as u32,
    }
}

/// `out[index[j]] = values[j]` for every `j`, 0 elsewhere, over `n`
/// slots, in parallel (each slot's three floats stored as atomic words:
/// `index` lists each slot at most once, so no store races another, and
/// the result is the same in any order).
fn scatter(n: usize, index: &[usize], values: &[Vec3]) -> Vec<Vec3> {
    use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
    pool().install(|| {
        let out: Vec<[AtomicU32; 3]> = (0..n)
            .into_par_iter()
            .map(|_| std::array::from_fn(|_| AtomicU32::new(0)))
            .collect();
        index.par_iter().zip(values).for_each(|(&i, c)| {
            for (slot, v) in out[i].iter().zip(c.to_array()) {
                slot.store(v.to_bits(), Relaxed);
            }
        });
        out.into_par_iter()
            .map(|c| Vec3::from_array(c.map(|w| f32::from_bits(w.into_inner()))))
            .collect()
    })
}

/// Sorts vertex indices `index` by the Morton code of their points on a
/// 1024³ grid over the points' bounds, so that a batch's lookups (shadow
/// map texels, fiber-count and volume cells) lie near one another in
/// memory. Each vertex is shaded on its own (the vector kernels' lanes are
/// independent), so the order changes no value, only the cache misses: a
/// generated head lists its strands in random scalp order, and its
/// vertices' opacity-map lookups missed the cache at nearly every tap.
fn locality_order(index: &mut [usize], points: &[Vec3]) {
    let empty = || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    // (min and max are exact: the same bounds in any order)
    let (lo, hi) = pool().install(|| {
        index
            .par_iter()
            .fold(empty, |(lo, hi), &i| (lo.min(points[i]), hi.max(points[i])))
            .reduce(empty, |a, b| (a.0.min(b.0), a.1.max(b.1)))
    });
    let extent = hi - lo;
    if !extent.is_finite() {
        return;
    }
    let scale = 1023.0 / extent.max_element().max(f32::MIN_POSITIVE);
    pool().install(|| {
        let mut keyed: Vec<(u32, usize)> = index
            .par_iter()
            .map(|&i| (morton_key(points[i], lo, scale), i))
            .collect();
        keyed.par_sort_unstable();
        index
            .par_iter_mut()
            .zip(keyed)
            .for_each(|(slot, (_, i))| *slot = i);
    });
}

/// The Morton code of `p` on the grid of cells `1 / scale` wide from `lo`
/// (1024 a side).
fn morton_key(p: Vec3, lo: Vec3, scale: f32) -> u32 {
    let q = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(1023.0));
    morton3(q.x as u32) | morton3(q.y as u32) << 1 | morton3(q.z as u32) << 2
}

/// The 10 low bits of `x` spread to every third bit.
fn morton3(x: u32) -> u32 {
    let mut x = x & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    (x | x << 2) & 0x0924_9249
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fiber::karis::KarisParams;
    use crate::raster::scene::{
        Camera, Cards, Environment, HairShading, Light, RenderOptions, Strands,
    };
    use crate::raster::setup::{scene_bounds, world_segments};
    use crate::raster::shadow::ShadowMap;
    use std::sync::Arc;

    /// 1. Per-vertex shading on the vector kernel (one batch per light and
    ///    one for the environment) against the per-point scalar path, with
    ///    a shadowed directional light, a point light, an SH environment and
    ///    the MS block on: equal to 1e-4 relative + 1e-7 absolute (the
    ///    vector kernel's rounding; `fiber::karis::simd` test 1 bounds it
    ///    against f64). Shading a subset of the vertices (frustum culling)
    ///    gives the same bits for them. The same for ChiangHair's tabulated
    ///    far field (`fiber::chiang::table_simd` test 1: 1.1e-5 relative
    ///    against the scalar look-up). Shaded on demand
    ///    (`VertexColors`), in small scrambled batches, the same bits.
    #[test]
    fn t01_batched_vertex_shading_matches_per_point_shading() {
        let karis = HairShading::Karis(
            KarisParams {
                scatter: 0.4,
                ..Default::default()
            }
            .build()
            .unwrap(),
        );
        let m: crate::fiber::ChiangHair<f64> =
            crate::fiber::ChiangParams::default().build().unwrap();
        let size = crate::fiber::chiang::TableSize::for_scale(m.logistic_scale());
        let chiang = HairShading::ChiangFar(Arc::new(crate::fiber::chiang::ChiangFarTable::new(
            &m, size,
        )));
        for hair in [karis, chiang] {
            batched_matches_per_point(hair.clone(), false);
            batched_matches_per_point(hair, true);
        }
    }

    /// `dual_split`: under dual scattering with split shading (the lights'
    /// unscattered light in the batch, dual's local back scattering added
    /// to the kernel's far field; the scattered light and the environment
    /// read at the vertices), the batch against the per-point path, which
    /// evaluates the far field in dual's canonical frame
    /// (`fiber::dual::FarField::single`): the same 1e-4 relative.
    fn batched_matches_per_point(hair: HairShading, dual_split: bool) {
        let mut points = Vec::new();
        let mut offsets = vec![0u32];
        for s in 0..40 {
            let a = s as f32 * 0.37;
            for k in 0..12 {
                let y = k as f32 * 0.08;
                points.push(Vec3::new(
                    a.cos() * (0.3 + 0.02 * k as f32),
                    y,
                    a.sin() * 0.3 + 0.01 * y * y,
                ));
            }
            offsets.push(points.len() as u32);
        }
        let mut sh = [[0.0f32; 3]; 9];
        sh[0] = [0.8, 0.8, 0.9];
        sh[2] = [0.3, 0.2, 0.1];
        sh[5] = [-0.2, 0.1, 0.0];
        let scene = Scene {
            camera: Camera {
                position: Vec3::new(0.0, 0.5, 3.0),
                target: Vec3::new(0.0, 0.5, 0.0),
                up: Vec3::Y,
                fov_y: 40.0,
                width: 64,
                height: 64,
            },
            lights: vec![
                Light::Directional {
                    direction: Vec3::new(0.5, 0.7, 0.5).normalize(),
                    intensity: Vec3::splat(3.0),
                    shadows: true,
                },
                Light::Point {
                    position: Vec3::new(-1.0, 1.0, 1.0),
                    intensity: Vec3::new(2.0, 1.5, 1.0),
                    shadows: false,
                },
            ],
            environment: Some(Environment { sh }),
            strands: Strands {
                radii: vec![0.004; points.len()],
                points,
                offsets,
            },
            cards: Cards::default(),
            spheres: Vec::new(),
            triangles: Vec::new(),
            hair,
        };
        let opts = RenderOptions::default();
        let bounds = scene_bounds(&scene);
        let world = world_segments(&scene.strands);
        let shadows: Vec<_> = scene
            .lights
            .iter()
            .map(|l| ShadowMap::build(l, &scene, &world, bounds, &opts, None).map(Arc::new))
            .collect();
        let opts = RenderOptions {
            light_cull_threshold: 0.0,
            split_shading: dual_split,
            multiple_scattering: dual_split
                .then_some(crate::raster::scene::MultipleScattering::Dual),
            ..Default::default()
        };
        let shader = Shader::new(
            &scene,
            &shadows,
            Arc::new(crate::raster::lighting::Lighting::none(2)),
            None,
            &opts,
        )
        .with_vertex_terms(None, &world, scene.camera.position, None);
        assert!(shader.batches());
        assert_eq!(shader.dual.is_some(), dual_split);
        let eye = scene.camera.position;
        let batched = shade_vertices(&scene, &shader, eye, None);
        let st = &scene.strands;
        // A subset of the vertices shades to the same bits (each SIMD lane
        // depends on its own inputs only), and the rest to 0.
        let needed: Vec<bool> = (0..st.points.len()).map(|i| i % 3 != 1).collect();
        let subset = shade_vertices(&scene, &shader, eye, Some(&needed));
        for i in 0..st.points.len() {
            let want = if needed[i] { batched[i] } else { Vec3::ZERO };
            assert_eq!(subset[i], want, "vertex {i}");
        }
        // On demand (`VertexColors`): in small batches of scrambled
        // vertices, listed more than once, the same bits.
        let colors = super::super::VertexColors::new(st, &shader, eye);
        let mut scratch = super::super::FetchScratch::default();
        let n = st.points.len();
        let owner = |i: usize| st.offsets.partition_point(|&o| o as usize <= i) - 1;
        let order: Vec<usize> = (0..2 * n).map(|j| (j * 7919) % n).collect();
        for batch in order.chunks(7) {
            let mut need: Vec<(u32, u32)> =
                batch.iter().map(|&i| (i as u32, owner(i) as u32)).collect();
            colors.fetch(&mut need, &mut scratch);
            for &i in batch {
                assert_eq!(colors.color(i as u32), batched[i], "vertex {i} on demand");
            }
        }
        assert_eq!(colors.shaded_count(), n);
        let mut shadowed = 0;
        for s in 0..st.strand_count() {
            let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
            for i in i0..i1 {
                let (a, b) = (st.points[i.max(i0 + 1) - 1], st.points[(i + 1).min(i1 - 1)]);
                let p = st.points[i];
                let fiber = Fiber {
                    radius: st.radii[i],
                    strand: s as u32,
                    segment: (i - s) as u32,
                };
                let want = shader.shade(
                    p,
                    (b - a).normalize_or_zero(),
                    (eye - p).normalize_or_zero(),
                    fiber,
                );
                let got = batched[i];
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() <= 1e-4 * want[c].abs() + 1e-7,
                        "vertex {i} channel {c}: {got} vs {want}"
                    );
                }
                shadowed += (shadows[0].as_ref().unwrap().visibility(p) < 1.0) as usize;
            }
        }
        assert!(shadowed > 0, "the test should exercise shadowed vertices");
    }

    /// 2. The locality order is a permutation of the vertices it is given,
    ///    its Morton keys non-decreasing; `morton3` spreads each of 10 bits
    ///    to bit 3k, and the three axes interleave into distinct codes.
    #[test]
    fn t02_locality_order_is_a_permutation_along_the_morton_curve() {
        for k in 0..10 {
            assert_eq!(morton3(1 << k), 1 << (3 * k));
        }
        assert_eq!(
            morton3(0x3ff) | morton3(0x3ff) << 1 | morton3(0x3ff) << 2,
            (1 << 30) - 1
        );
        let points: Vec<Vec3> = (0..5000)
            .map(|i| {
                let f = i as f32;
                Vec3::new(
                    (f * 0.618).fract(),
                    (f * 0.414).fract() * 2.0,
                    (f * 0.732).fract() - 3.0,
                )
            })
            .collect();
        let mut index: Vec<usize> = (0..points.len()).filter(|i| i % 3 != 1).collect();
        let want = index.clone();
        locality_order(&mut index, &points);
        let mut sorted = index.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, want);
        let (lo, hi) = want.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &i| (lo.min(points[i]), hi.max(points[i])),
        );
        let scale = 1023.0 / (hi - lo).max_element();
        let key = |i: usize| morton_key(points[i], lo, scale);
        assert!(index.windows(2).all(|w| key(w[0]) <= key(w[1])));
    }

    /// 3. The parallel scatter puts each value at its slot, bit for bit,
    ///    and 0 at the slots not listed; the same on one thread and on all.
    #[test]
    fn t03_scatter() {
        let n = 100_003;
        // every third slot, in a scrambled order
        let mut index: Vec<usize> = (0..n).step_by(3).collect();
        let k = index.len();
        for j in 0..k {
            index.swap(j, (j * 7919) % k);
        }
        let values: Vec<Vec3> = index
            .iter()
            .map(|&i| Vec3::new(i as f32, -(i as f32) * 0.5, 1.0 / (i as f32 + 1.0)))
            .collect();
        let mut want = vec![Vec3::ZERO; n];
        for (&i, &v) in index.iter().zip(&values) {
            want[i] = v;
        }
        let bits = |v: &[Vec3]| -> Vec<[u32; 3]> {
            v.iter().map(|c| c.to_array().map(f32::to_bits)).collect()
        };
        assert_eq!(bits(&scatter(n, &index, &values)), bits(&want));
        crate::threads::set_single_threaded(true);
        let one = scatter(n, &index, &values);
        crate::threads::set_single_threaded(false);
        assert_eq!(bits(&one), bits(&want));
    }
}
