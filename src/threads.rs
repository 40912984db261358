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
    let build = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .thread_name(|i| format!("hairshade-{i}"))
            .start_handler(|_| clear_upper_simd_state())
            .build()
            .expect("cannot start the hairshade thread pool")
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
