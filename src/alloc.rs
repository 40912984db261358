//! Fallible allocation of buffers whose size comes from input: a request
//! the system cannot serve is an error naming the buffer, not an abort.

/// A failed allocation: what it was for and how many bytes it asked for.
#[derive(Debug, Clone)]
pub struct AllocError {
    pub what: String,
    pub bytes: usize,
}

impl std::fmt::Display for AllocError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: cannot allocate {} bytes ({:.2} GiB)",
            self.what,
            self.bytes,
            self.bytes as f64 / (1u64 << 30) as f64
        )
    }
}

impl std::error::Error for AllocError {}

/// `len` copies of `T::default()`, or an [`AllocError`] naming `what`.
pub fn try_zeroed<T: Clone + Default>(len: usize, what: &str) -> Result<Vec<T>, AllocError> {
    try_filled(len, T::default(), what)
}

/// `len` copies of `value`, or an [`AllocError`] naming `what`.
pub fn try_filled<T: Clone>(len: usize, value: T, what: &str) -> Result<Vec<T>, AllocError> {
    let mut v = Vec::new();
    v.try_reserve_exact(len).map_err(|_| AllocError {
        what: what.to_string(),
        bytes: len.saturating_mul(std::mem::size_of::<T>()),
    })?;
    v.resize(len, value);
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
    }
}
