//! hairshade's own thread pool: every batch evaluation and render runs on it.

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
    static SINGLE: std::sync::OnceLock<rayon::ThreadPool> = std::sync::OnceLock::new();
    let try_build = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .thread_name(|i| format!("hairshade-{i}"))
            .start_handler(|_| clear_upper_simd_state())
            .build()
    };
    // A pool the system cannot start (threads refused: RAYON_NUM_THREADS
    // far beyond the CPUs from a caller that skipped the bindings' check)
    // falls back to one thread per CPU, then to one thread: work runs
    // slower, it does not abort.
    let build = |n: usize| {
        try_build(n)
            .or_else(|_| try_build(std::thread::available_parallelism().map_or(1, |c| c.get())))
            .or_else(|_| try_build(1))
            .expect("cannot start even a one-thread pool")
    };
    if SINGLE_THREADED.load(std::sync::atomic::Ordering::Relaxed) {
        SINGLE.get_or_init(|| build(1))
    } else {
        // 0: RAYON_NUM_THREADS or the CPU count.
        POOL.get_or_init(|| build(0))
    }
}

static SINGLE_THREADED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Runs later batches on one thread (`true`) or on all (`false`); for
/// measuring scaling. Results do not depend on it.
pub fn set_single_threaded(on: bool) {
    SINGLE_THREADED.store(on, std::sync::atomic::Ordering::Relaxed);
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

/// The items of `0..n` concatenated in index order, built in parallel on
/// [`pool`] directly into the result: item `i` contributes exactly
/// `count(i)` values, which `fill(i, push)` passes to `push` in order.
/// (Collecting per-item vectors and flattening them copies the whole
/// result on one thread, and its pages are first touched there.)
///
/// Panics if `fill(i)` pushes other than `count(i)` values.
pub fn concat_ordered<T, C, F>(n: usize, count: C, fill: F) -> Vec<T>
where
    T: Send,
    C: Fn(usize) -> usize + Sync,
    F: Fn(usize, &mut dyn FnMut(T)) + Sync,
{
    use rayon::prelude::*;
    let counts: Vec<usize> = pool().install(|| (0..n).into_par_iter().map(&count).collect());
    let total: usize = counts.iter().sum();
    let mut out: Vec<T> = Vec::with_capacity(total);
    // Disjoint destination slices, one per item, in order.
    let mut parts = Vec::with_capacity(n);
    let mut rest = &mut out.spare_capacity_mut()[..total];
    for &c in &counts {
        let (a, b) = rest.split_at_mut(c);
        parts.push(a);
        rest = b;
    }
    pool().install(|| {
        parts.into_par_iter().enumerate().for_each(|(i, dst)| {
            let mut k = 0;
            fill(i, &mut |v| {
                assert!(k < dst.len(), "item {i} pushed more than its count");
                dst[k].write(v);
                k += 1;
            });
            assert_eq!(k, dst.len(), "item {i} pushed fewer than its count");
        })
    });
    // SAFETY: every slot of `..total` was written exactly once (each
    // item's slice was filled to its length, asserted above; a panic
    // there unwinds before this line, leaving `out` empty).
    unsafe { out.set_len(total) };
    out
}

#[cfg(test)]
mod tests {
    /// 1. Items concatenated in order whatever the thread count; a wrong
    ///    count panics instead of leaving slots unwritten.
    #[test]
    fn t01_concat_ordered() {
        let v = super::concat_ordered(
            1000,
            |i| i % 7,
            |i, push| {
                for k in 0..i % 7 {
                    push((i, k));
                }
            },
        );
        let want: Vec<(usize, usize)> = (0..1000)
            .flat_map(|i| (0..i % 7).map(move |k| (i, k)))
            .collect();
        assert_eq!(v, want);
        let r = std::panic::catch_unwind(|| {
            super::concat_ordered(
                10,
                |_| 2,
                |i, push| {
                    push(i);
                },
            )
        });
        assert!(r.is_err());
    }
}
