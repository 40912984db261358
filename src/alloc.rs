//! Fallible allocation of buffers whose size comes from input: a request
//! the system cannot serve is an error naming the buffer, not an abort.

/// A failed allocation: what it was for and how many bytes it asked for.
#[derive(Debug, Clone)]
pub struct AllocError {
    pub what: String,
    pub bytes: usize,
    /// The bytes the system said were available, when that was the reason.
    pub available: Option<u64>,
}

impl std::fmt::Display for AllocError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: cannot allocate {} bytes ({:.2} GiB)",
            self.what,
            self.bytes,
            self.bytes as f64 / (1u64 << 30) as f64
        )?;
        if let Some(a) = self.available {
            write!(
                f,
                ", more than the {:.2} GiB available",
                a as f64 / (1u64 << 30) as f64
            )?;
        }
        Ok(())
    }
}

impl std::error::Error for AllocError {}

/// `len` copies of `T::default()`, or an [`AllocError`] naming `what`.
pub fn try_zeroed<T: Clone + Default + Send + Sync>(
    len: usize,
    what: &str,
) -> Result<Vec<T>, AllocError> {
    try_filled(len, T::default(), what)
}

/// Requests from this size on are checked against the memory the system
/// says is available before they are made: the system may grant a
/// reservation it cannot back, and filling it then gets the process killed
/// instead of an error.
const CHECK_FROM: usize = 64 << 20;

/// Buffers from this many elements on are filled on every thread of
/// [`crate::threads::pool`] (a batch's output: one thread writing 12 MB
/// took a tenth of a 2^20-pair ChiangHair evaluation).
const PARALLEL_FILL_FROM: usize = 1 << 18;

/// `len` copies of `value`, or an [`AllocError`] naming `what` (also when
/// it is more than the memory available, [`crate::raster::memory::available_bytes`]).
pub fn try_filled<T: Clone + Send + Sync>(
    len: usize,
    value: T,
    what: &str,
) -> Result<Vec<T>, AllocError> {
    let bytes = len.saturating_mul(std::mem::size_of::<T>());
    if bytes >= CHECK_FROM {
        if let Some(a) = crate::raster::memory::available_bytes() {
            if bytes as u64 > a {
                return Err(AllocError {
                    what: what.to_string(),
                    bytes,
                    available: Some(a),
                });
            }
        }
    }
    let mut v = Vec::new();
    v.try_reserve_exact(len).map_err(|_| AllocError {
        what: what.to_string(),
        bytes,
        available: None,
    })?;
    if len < PARALLEL_FILL_FROM {
        v.resize(len, value);
        return Ok(v);
    }
    use rayon::prelude::*;
    crate::threads::pool().install(|| {
        v.spare_capacity_mut()[..len]
            .par_chunks_mut(1 << 16)
            .for_each(|c| {
                for x in c {
                    x.write(value.clone());
                }
            })
    });
    // SAFETY: the capacity is at least `len` (reserved above) and each of
    // the first `len` elements was written just above.
    unsafe { v.set_len(len) };
    Ok(v)
}

#[cfg(test)]
mod tests {
    #[test]
    fn t01_impossible_request_is_an_error() {
        let e = super::try_zeroed::<f64>(usize::MAX / 4, "test buffer").unwrap_err();
        assert_eq!(e.what, "test buffer");
        assert!(e.to_string().starts_with("test buffer: cannot allocate"));
        assert_eq!(super::try_zeroed::<f32>(5, "x").unwrap(), vec![0.0; 5]);
        // Large buffers are filled in parallel: every element.
        let n = 3 * super::PARALLEL_FILL_FROM + 7;
        let v = super::try_filled(n, 2.5f32, "x").unwrap();
        assert_eq!(v.len(), n);
        assert!(v.iter().all(|&x| x == 2.5));
    }
}
