//! Batched evaluation over flat `(N, 3)` arrays, in parallel with rayon.
//!
//! Every model's per-pair function sees unit vectors only: inputs are
//! normalized here, and a pair with a non-finite or zero-length direction
//! produces 0 (value, pdf and sample weight; a sampled `wo` of 0) without
//! touching its neighbours.

use crate::fiber::frame::{normalized, Vec3};
use crate::math::Real;
use rayon::prelude::*;

/// The thread pool every batch runs on.
///
/// Its threads clear the upper halves of the AVX registers when they start:
/// a thread inherits its creator's register state, and if the creator last
/// ran AVX code without `vzeroupper` (the JIT-compiled kernels of a renderer
/// loaded in the same process, for example), every SSE instruction of the
/// new thread pays a state-transition penalty, measured here as a 7× slower
/// `eval`. Threads: `RAYON_NUM_THREADS` or the number of CPUs.
pub fn pool() -> &'static rayon::ThreadPool {
    static POOL: std::sync::OnceLock<rayon::ThreadPool> = std::sync::OnceLock::new();
    POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .thread_name(|i| format!("hairshade-{i}"))
            .start_handler(|_| clear_upper_simd_state())
            .build()
            .expect("cannot start the hairshade thread pool")
    })
}

#[inline]
fn clear_upper_simd_state() {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU supports AVX (checked above); vzeroupper only
            // zeroes the upper halves of ymm registers, which hold no live
            // values at thread start.
            unsafe { clear_upper_avx() }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn clear_upper_avx() {
    std::arch::x86_64::_mm256_zeroupper();
}

/// Number of threads batches run on.
pub fn num_threads() -> usize {
    pool().current_num_threads()
}

/// Pairs per parallel task: large enough to amortize scheduling, small
/// enough to balance two to a few dozen threads.
const CHUNK: usize = 4096;

#[inline(always)]
fn load<T: Real>(a: &[T], i: usize) -> Option<Vec3<T>> {
    normalized(&[a[3 * i], a[3 * i + 1], a[3 * i + 2]])
}

/// Direction `i` of `a`, or of a single broadcast direction when `a.len() == 3`.
#[inline(always)]
fn load_bc<T: Real>(a: &[T], i: usize) -> Option<Vec3<T>> {
    if a.len() == 3 {
        load(a, 0)
    } else {
        load(a, i)
    }
}

/// Number of pairs described by two direction arrays (each `3N` or a
/// broadcast `3`). Panics on inconsistent lengths: callers validate shapes.
pub fn pair_count<T>(a: &[T], b: &[T]) -> usize {
    assert!(
        a.len() % 3 == 0 && b.len() % 3 == 0,
        "direction arrays must hold whole vectors"
    );
    let (na, nb) = (a.len() / 3, b.len() / 3);
    assert!(
        na == nb || na == 1 || nb == 1,
        "direction counts {na} and {nb} do not broadcast"
    );
    na.max(nb)
}

/// `out[i] = f(wi[i], wo[i])` (RGB), `out.len() == 3N`.
pub fn map_pairs_rgb<T: Real, F>(wi: &[T], wo: &[T], out: &mut [T], f: F)
where
    F: Fn(&Vec3<T>, &Vec3<T>) -> [T; 3] + Sync,
{
    let n = pair_count(wi, wo);
    assert_eq!(out.len(), 3 * n);
    pool().install(|| {
        out.par_chunks_mut(3 * CHUNK)
            .enumerate()
            .for_each(|(k, chunk)| {
                let base = k * CHUNK;
                for (j, o) in chunk.chunks_exact_mut(3).enumerate() {
                    let i = base + j;
                    let v = match (load_bc(wi, i), load_bc(wo, i)) {
                        (Some(a), Some(b)) => f(&a, &b),
                        _ => [T::ZERO; 3],
                    };
                    o.copy_from_slice(&v);
                }
            })
    });
}

/// `out[i] = f(wi[i], wo[i])` (scalar), `out.len() == N`.
pub fn map_pairs_scalar<T: Real, F>(wi: &[T], wo: &[T], out: &mut [T], f: F)
where
    F: Fn(&Vec3<T>, &Vec3<T>) -> T + Sync,
{
    let n = pair_count(wi, wo);
    assert_eq!(out.len(), n);
    pool().install(|| {
        out.par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(k, chunk)| {
                let base = k * CHUNK;
                for (j, o) in chunk.iter_mut().enumerate() {
                    let i = base + j;
                    *o = match (load_bc(wi, i), load_bc(wo, i)) {
                        (Some(a), Some(b)) => f(&a, &b),
                        _ => T::ZERO,
                    };
                }
            })
    });
}

/// Output buffers of a batched `sample`.
pub struct SampleOut<'a, T> {
    /// Sampled directions, `3N`.
    pub wo: &'a mut [T],
    /// `f / pdf` per channel, `3N`.
    pub weight: &'a mut [T],
    /// Solid-angle density, `N`.
    pub pdf: &'a mut [T],
}

/// Batched sampling: `f(wi[i], u1[i], u2[i]) -> (wo, weight, pdf)`.
/// `wi` is `3N` or a broadcast `3`; `u1` is `N`, `u2` is `2N`. Non-finite
/// random numbers give a failed sample (all zero).
pub fn sample_batch<T: Real, F>(wi: &[T], u1: &[T], u2: &[T], out: SampleOut<'_, T>, f: F)
where
    F: Fn(&Vec3<T>, T, [T; 2]) -> (Vec3<T>, [T; 3], T) + Sync,
{
    let n = u1.len();
    assert!(wi.len() == 3 || wi.len() == 3 * n);
    assert_eq!(u2.len(), 2 * n);
    assert!(out.wo.len() == 3 * n && out.weight.len() == 3 * n && out.pdf.len() == n);
    let SampleOut { wo, weight, pdf } = out;
    pool().install(|| sample_chunks(wi, u1, u2, wo, weight, pdf, &f));
}

fn sample_chunks<T: Real, F>(
    wi: &[T],
    u1: &[T],
    u2: &[T],
    wo: &mut [T],
    weight: &mut [T],
    pdf: &mut [T],
    f: &F,
) where
    F: Fn(&Vec3<T>, T, [T; 2]) -> (Vec3<T>, [T; 3], T) + Sync,
{
    wo.par_chunks_mut(3 * CHUNK)
        .zip(weight.par_chunks_mut(3 * CHUNK))
        .zip(pdf.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(k, ((wo, weight), pdf))| {
            let base = k * CHUNK;
            for j in 0..pdf.len() {
                let i = base + j;
                let (a, b, c) = (u1[i], u2[2 * i], u2[2 * i + 1]);
                let ok = a.is_finite() && b.is_finite() && c.is_finite();
                let (d, w, p) = match load_bc(wi, i) {
                    Some(v) if ok => f(&v, clamp01(a), [clamp01(b), clamp01(c)]),
                    _ => ([T::ZERO; 3], [T::ZERO; 3], T::ZERO),
                };
                wo[3 * j..3 * j + 3].copy_from_slice(&d);
                weight[3 * j..3 * j + 3].copy_from_slice(&w);
                pdf[j] = p;
            }
        });
}

#[inline(always)]
fn clamp01<T: Real>(x: T) -> T {
    x.max(T::ZERO).min(T::ONE)
}
