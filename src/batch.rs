//! Batched evaluation over flat `(N, 3)` arrays, in parallel on
//! [`crate::threads::pool`].
//!
//! Every model's per-pair function sees unit vectors only: inputs are
//! normalized here, and a pair with a non-finite or zero-length direction
//! produces 0 (value, pdf and sample weight; a sampled `wo` of 0) without
//! touching its neighbours.

use crate::fiber::chiang::{ChiangFarTable, ChiangHair, I0Mode};
use crate::fiber::deon::DEonHair;
use crate::fiber::frame::{normalized, Vec3};
use crate::fiber::karis::{KarisHair, KarisInputs, KarisLobes, LobeVisitor, Transmittance};
use crate::math::Real;
use crate::threads::pool;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Cooperative stop of running batches (Ctrl-C): [`StopBatches`] raises
/// [`STOP`] while the interrupted caller waits for its batch; every chunk
/// loop checks it before starting a chunk. [`STOP_EPOCH`] is odd while a
/// stop is under way and grows by two per stop, so a batch that started at
/// an even epoch and ends at the same epoch never skipped a chunk
/// ([`ran_whole`]); any other batch returns an incomplete result, which the
/// bindings turn into `KeyboardInterrupt`.
static STOP: AtomicBool = AtomicBool::new(false);
static STOP_EPOCH: AtomicU64 = AtomicU64::new(0);

/// Pairs between two looks at [`STOP`] inside a chunk.
const STOP_CHECK: usize = 64;

/// Whether running batches are asked to stop.
#[inline]
pub fn stopped() -> bool {
    STOP.load(Ordering::Relaxed)
}

/// The stop epoch, to pass to [`ran_whole`] after a batch.
pub fn stop_epoch() -> u64 {
    STOP_EPOCH.load(Ordering::SeqCst)
}

/// Whether no stop happened since `epoch` (taken before the batch began).
pub fn ran_whole(epoch: u64) -> bool {
    epoch % 2 == 0 && STOP_EPOCH.load(Ordering::SeqCst) == epoch
}

/// A stop of every running batch, from creation until drop (hold it while
/// waiting for the interrupted batch; batches run again after it).
pub struct StopBatches(());

impl StopBatches {
    pub fn new() -> Self {
        STOP_EPOCH.fetch_add(1, Ordering::SeqCst);
        STOP.store(true, Ordering::SeqCst);
        Self(())
    }
}

impl Default for StopBatches {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for StopBatches {
    fn drop(&mut self) {
        STOP.store(false, Ordering::SeqCst);
        STOP_EPOCH.fetch_add(1, Ordering::SeqCst);
    }
}

/// Pairs per parallel task: large enough to amortize scheduling, small
/// enough to balance two to a few dozen threads.
const CHUNK: usize = 4096;

/// Pairs per task for a batch of `n`: at most [`CHUNK`], and small enough
/// that every thread gets about four tasks (expensive models, such as
/// far fields, come in small batches).
fn chunk_for(n: usize) -> usize {
    (n / (4 * pool().current_num_threads().max(1))).clamp(16, CHUNK)
}

/// Runs a vector kernel over `out` (records of `w` values) in parallel on
/// [`pool`]: `kernel(first, part)` fills the records `first..` of `part`,
/// chunks being whole multiples of 16 records (every lane count); chunks
/// not yet started when Ctrl-C is seen are skipped.
fn par_kernel_chunks(out: &mut [f32], w: usize, kernel: impl Fn(usize, &mut [f32]) + Sync) {
    assert!(out.len() % w == 0);
    pool().install(|| {
        let chunk = chunk_for(out.len() / w).next_multiple_of(16);
        out.par_chunks_mut(w * chunk)
            .enumerate()
            .for_each(|(k, part)| {
                if !stopped() {
                    kernel(k * chunk, part)
                }
            })
    });
}

#[inline(always)]
fn load<T: Real>(a: &[T], i: usize) -> Option<Vec3<T>> {
    normalized(&[a[3 * i], a[3 * i + 1], a[3 * i + 2]])
}

/// Unit direction `i` of a flat `(N, 3)` array, or of its only direction
/// when it holds one (broadcast); `None` if zero-length or non-finite.
#[inline(always)]
pub fn dir_at<T: Real>(a: &[T], i: usize) -> Option<Vec3<T>> {
    if a.len() == 3 {
        load(a, 0)
    } else {
        load(a, i)
    }
}

/// Value `i` of a per-pair scalar array of length N, or its only value.
#[inline(always)]
pub fn scalar_at<T: Copy>(a: &[T], i: usize) -> T {
    if a.len() == 1 {
        a[0]
    } else {
        a[i]
    }
}

/// RGB value `i` of a flat `(N, 3)` array, or its only triple.
#[inline(always)]
pub fn rgb_at<T: Copy>(a: &[T], i: usize) -> [T; 3] {
    let j = if a.len() == 3 { 0 } else { 3 * i };
    [a[j], a[j + 1], a[j + 2]]
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

/// `out[W i .. W i + W] = f(i)` for i in 0..N, in parallel on [`pool`].
pub fn par_map<T: Real, const W: usize, F>(out: &mut [T], f: F)
where
    F: Fn(usize) -> [T; W] + Sync,
{
    assert!(out.len() % W == 0);
    pool().install(|| {
        let chunk = chunk_for(out.len() / W);
        out.par_chunks_mut(W * chunk)
            .enumerate()
            .for_each(|(k, part)| {
                if stopped() {
                    return;
                }
                // Slow models (DEonHair converged: ~1 ms a pair) also
                // look between groups of STOP_CHECK pairs of a chunk.
                for (g, group) in part.chunks_mut(W * STOP_CHECK).enumerate() {
                    if g > 0 && stopped() {
                        return;
                    }
                    let base = k * chunk + g * STOP_CHECK;
                    for (j, o) in group.chunks_exact_mut(W).enumerate() {
                        o.copy_from_slice(&f(base + j));
                    }
                }
            })
    });
}

/// `out[i] = f(wi[i], wo[i])` (RGB), `out.len() == 3N`; degenerate pairs give 0.
pub fn map_pairs_rgb<T: Real, F>(wi: &[T], wo: &[T], out: &mut [T], f: F)
where
    F: Fn(&Vec3<T>, &Vec3<T>) -> [T; 3] + Sync,
{
    let n = pair_count(wi, wo);
    assert_eq!(out.len(), 3 * n);
    par_map(out, |i| match (dir_at(wi, i), dir_at(wo, i)) {
        (Some(a), Some(b)) => f(&a, &b),
        _ => [T::ZERO; 3],
    });
}

/// `out[i] = f(wi[i], wo[i])` (scalar), `out.len() == N`; degenerate pairs give 0.
pub fn map_pairs_scalar<T: Real, F>(wi: &[T], wo: &[T], out: &mut [T], f: F)
where
    F: Fn(&Vec3<T>, &Vec3<T>) -> T + Sync,
{
    let n = pair_count(wi, wo);
    assert_eq!(out.len(), n);
    par_map(out, |i| match (dir_at(wi, i), dir_at(wo, i)) {
        (Some(a), Some(b)) => [f(&a, &b)],
        _ => [T::ZERO],
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
    let chunk = chunk_for(pdf.len());
    wo.par_chunks_mut(3 * chunk)
        .zip(weight.par_chunks_mut(3 * chunk))
        .zip(pdf.par_chunks_mut(chunk))
        .enumerate()
        .for_each(|(k, ((wo, weight), pdf))| {
            if stopped() {
                return;
            }
            let base = k * chunk;
            for j in 0..pdf.len() {
                if j % STOP_CHECK == 0 && j > 0 && stopped() {
                    return;
                }
                let i = base + j;
                let (a, b, c) = (u1[i], u2[2 * i], u2[2 * i + 1]);
                let ok = a.is_finite() && b.is_finite() && c.is_finite();
                let (d, w, p) = match dir_at(wi, i) {
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

/// Unit L, V, T and the transmittance of one pair.
type KarisPair<T> = (Vec3<T>, Vec3<T>, Vec3<T>, Transmittance<T>);

/// Pair `i` of a batch, or None when a direction is degenerate or an input
/// is not finite.
#[inline(always)]
fn karis_at<T: Real>(inp: &KarisInputs<'_, T>, i: usize) -> Option<KarisPair<T>> {
    let (l, v, t) = (dir_at(inp.l, i)?, dir_at(inp.v, i)?, dir_at(inp.t, i)?);
    let tr = Transmittance {
        shadow: scalar_at(inp.shadow, i),
        global_scattering: rgb_at(inp.global_scattering, i),
        local_scattering: rgb_at(inp.local_scattering, i),
        opaque_visibility: scalar_at(inp.opaque_visibility, i),
    };
    let finite = tr.shadow.is_finite()
        && tr.opaque_visibility.is_finite()
        && tr
            .global_scattering
            .iter()
            .chain(&tr.local_scattering)
            .all(|x| x.is_finite());
    finite.then_some((l, v, t, tr))
}

fn flatten_lobes<T: Real>(k: &KarisLobes<T>) -> [T; 12] {
    let mut o = [T::ZERO; 12];
    o[0..3].copy_from_slice(&k.r);
    o[3..6].copy_from_slice(&k.tt);
    o[6..9].copy_from_slice(&k.trt);
    o[9..12].copy_from_slice(&k.ms);
    o
}

/// The precisions batches run in, each with its kernels: `f32` on the
/// vector kernels where the model has one ([`crate::simd`]), `f64` on the
/// scalar ones.
pub trait Precision: Real {
    /// [`karis_eval`] in this precision.
    fn karis_eval<const LOBES: bool>(
        m: &KarisHair<Self>,
        inp: &KarisInputs<'_, Self>,
        out: &mut [Self],
    );
    /// [`chiang_eval`] in this precision.
    fn chiang_eval(m: &ChiangHair<Self>, wi: &[Self], wo: &[Self], out: &mut [Self]);
    /// [`ChiangFarTable::eval`] of every pair (out `3N`) in this precision
    /// (the table is `f32`: `f64` directions are rounded to it).
    fn chiang_far_table_eval(t: &ChiangFarTable, wi: &[Self], wo: &[Self], out: &mut [Self]);
}

impl Precision for f32 {
    /// The vector kernel, except for models with UE's `fast_asin`.
    fn karis_eval<const LOBES: bool>(
        m: &KarisHair<f32>,
        inp: &KarisInputs<'_, f32>,
        out: &mut [f32],
    ) {
        if m.fast_asin() {
            karis_eval_scalar::<f32, LOBES>(m, inp, out)
        } else {
            karis_eval_simd::<LOBES>(m, inp, out, crate::simd::Level::detect())
        }
    }

    /// The vector kernel with the exact I0; Mitsuba's I0 on the scalar one.
    fn chiang_eval(m: &ChiangHair<f32>, wi: &[f32], wo: &[f32], out: &mut [f32]) {
        if m.i0_mode() == I0Mode::Exact {
            chiang_eval_simd(m, wi, wo, out, crate::simd::Level::detect())
        } else {
            map_pairs_rgb(wi, wo, out, |a, b| m.eval(a, b))
        }
    }

    /// The vector kernel.
    fn chiang_far_table_eval(t: &ChiangFarTable, wi: &[f32], wo: &[f32], out: &mut [f32]) {
        chiang_far_table_simd(t, wi, wo, out, crate::simd::Level::detect())
    }
}

impl Precision for f64 {
    fn karis_eval<const LOBES: bool>(
        m: &KarisHair<f64>,
        inp: &KarisInputs<'_, f64>,
        out: &mut [f64],
    ) {
        karis_eval_scalar::<f64, LOBES>(m, inp, out)
    }

    fn chiang_eval(m: &ChiangHair<f64>, wi: &[f64], wo: &[f64], out: &mut [f64]) {
        map_pairs_rgb(wi, wo, out, |a, b| m.eval(a, b))
    }

    /// The scalar look-up, directions rounded to `f32` once normalized.
    fn chiang_far_table_eval(t: &ChiangFarTable, wi: &[f64], wo: &[f64], out: &mut [f64]) {
        map_pairs_rgb(wi, wo, out, |a, b| {
            t.eval(&a.map(|x| x as f32), &b.map(|x| x as f32))
                .map(f64::from)
        })
    }
}

/// Batched [`KarisHair::eval`] (`LOBES = false`, out `3N`) or its lobes
/// (`LOBES = true`, out `12N`: R, TT, TRT, MS). Pairs with a degenerate
/// direction or a non-finite input give 0.
pub fn karis_eval<T: Precision, const LOBES: bool>(
    m: &KarisHair<T>,
    inp: &KarisInputs<'_, T>,
    out: &mut [T],
) {
    T::karis_eval::<LOBES>(m, inp, out)
}

/// [`karis_eval`] on the scalar kernel.
pub fn karis_eval_scalar<T: Real, const LOBES: bool>(
    m: &KarisHair<T>,
    inp: &KarisInputs<'_, T>,
    out: &mut [T],
) {
    struct V<'a, 'b, T: Real, const LOBES: bool>(&'a KarisInputs<'b, T>, &'a mut [T]);
    impl<T: Real, const LOBES: bool> LobeVisitor<T> for V<'_, '_, T, LOBES> {
        type Out = ();
        fn visit<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
            self,
            m: &KarisHair<T>,
        ) {
            let inp = self.0;
            if LOBES {
                par_map::<T, 12, _>(self.1, |i| match karis_at(inp, i) {
                    Some((l, v, t, tr)) => {
                        flatten_lobes(&m.lobes_static::<R, TT, TRT, MS>(&l, &v, &t, &tr))
                    }
                    None => [T::ZERO; 12],
                });
            } else {
                par_map::<T, 3, _>(self.1, |i| match karis_at(inp, i) {
                    Some((l, v, t, tr)) => {
                        m.lobes_static::<R, TT, TRT, MS>(&l, &v, &t, &tr).total()
                    }
                    None => [T::ZERO; 3],
                });
            }
        }
    }
    m.dispatch(V::<T, LOBES>(inp, out));
}

/// [`karis_eval`] for `f32` on the vector kernel ([`crate::simd`]) at
/// `level` (at most [`Level::detect`](crate::simd::Level::detect)'s; lower
/// levels serve measurements), in parallel on [`pool`]. Models with
/// `fast_asin` are evaluated as if it were off.
pub fn karis_eval_simd<const LOBES: bool>(
    m: &KarisHair<f32>,
    inp: &KarisInputs<'_, f32>,
    out: &mut [f32],
    level: crate::simd::Level,
) {
    let level = level.min_with(crate::simd::Level::detect());
    par_kernel_chunks(out, if LOBES { 12 } else { 3 }, |first, part| {
        crate::fiber::karis::simd::eval_range::<LOBES>(m, inp, first, part, level)
    });
}

/// Batched [`ChiangHair::eval`] (out `3N`); degenerate pairs give 0. `f32`
/// models with [`I0Mode::Exact`] run on the vector kernel
/// ([`chiang_eval_simd`]), the others on the scalar one.
pub fn chiang_eval<T: Precision>(m: &ChiangHair<T>, wi: &[T], wo: &[T], out: &mut [T]) {
    T::chiang_eval(m, wi, wo, out)
}

/// [`ChiangHair::eval`] for `f32` on the vector kernel at `level` (at most
/// [`Level::detect`](crate::simd::Level::detect)'s), in parallel on
/// [`pool`]. The model's I0 mode is taken as [`I0Mode::Exact`].
pub fn chiang_eval_simd(
    m: &ChiangHair<f32>,
    wi: &[f32],
    wo: &[f32],
    out: &mut [f32],
    level: crate::simd::Level,
) {
    assert_eq!(out.len(), 3 * pair_count(wi, wo));
    let level = level.min_with(crate::simd::Level::detect());
    par_kernel_chunks(out, 3, |first, part| {
        crate::fiber::chiang::simd::eval_range(m, wi, wo, first, part, level)
    });
}

/// [`ChiangFarTable::eval`] for `f32` on the vector kernel at `level` (at
/// most [`Level::detect`](crate::simd::Level::detect)'s), in parallel on
/// [`pool`]; degenerate pairs give 0.
pub fn chiang_far_table_simd(
    t: &ChiangFarTable,
    wi: &[f32],
    wo: &[f32],
    out: &mut [f32],
    level: crate::simd::Level,
) {
    assert_eq!(out.len(), 3 * pair_count(wi, wo));
    let level = level.min_with(crate::simd::Level::detect());
    let pairs = crate::fiber::chiang::Pairs::Local(wi, wo);
    par_kernel_chunks(out, 3, |first, part| {
        crate::fiber::chiang::table_eval_range(t, pairs, first, part, level)
    });
}

/// Batched environment lighting of `m.environment_variant()` (out `3N`).
pub fn karis_eval_env<T: Real>(
    m: &KarisHair<T>,
    v: &[T],
    t: &[T],
    sh: &[[T; 3]; 9],
    out: &mut [T],
) {
    struct Env<'a, T: Real>(&'a [T], &'a [T], &'a [[T; 3]; 9], &'a mut [T]);
    impl<T: Real> LobeVisitor<T> for Env<'_, T> {
        type Out = ();
        fn visit<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
            self,
            m: &KarisHair<T>,
        ) {
            let (v, t, sh) = (self.0, self.1, self.2);
            par_map::<T, 3, _>(self.3, |i| match (dir_at(v, i), dir_at(t, i)) {
                (Some(v), Some(t)) => m.env_lobes_static::<R, TT, TRT, MS>(&v, &t, sh),
                _ => [T::ZERO; 3],
            });
        }
    }
    let env = m.environment_variant();
    env.dispatch(Env(v, t, sh, out));
}

/// Batched [`DEonHair::lobes`] (out `9N`: R, TT, TRT) or sum (out `3N`).
pub fn deon_eval<T: Real>(m: &DEonHair<T>, l: &[T], v: &[T], t: &[T], lobes: bool, out: &mut [T]) {
    let at = |i: usize| Some((dir_at(l, i)?, dir_at(v, i)?, dir_at(t, i)?));
    if lobes {
        par_map::<T, 9, _>(out, |i| match at(i) {
            Some((l, v, t)) => {
                let s = m.lobes(&l, &v, &t);
                let mut o = [T::ZERO; 9];
                for p in 0..3 {
                    o[3 * p..3 * p + 3].copy_from_slice(&s[p]);
                }
                o
            }
            None => [T::ZERO; 9],
        });
    } else {
        par_map::<T, 3, _>(out, |i| match at(i) {
            Some((l, v, t)) => m.eval(&l, &v, &t),
            None => [T::ZERO; 3],
        });
    }
}
