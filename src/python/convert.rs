//! Arrays in and out, errors, and the GIL: everything the bindings share.
//!
//! Every native operation takes flat 1-D numpy arrays of one float type
//! ([`Floats`]: float32 or float64, chosen by the typed Python API) and
//! returns flat arrays of the same type. [`with_floats!`] runs an
//! operation's body once per type, with the model built in that precision.

use crate::batch::Precision;
use crate::fiber::ParamError;
use numpy::{Element, PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// The float types the bindings compute in.
pub trait Float: Precision + Element + Default {}
impl Float for f32 {}
impl Float for f64 {}

/// A flat float array of either precision, as numpy passes it.
#[derive(FromPyObject)]
pub enum Floats<'py> {
    F32(PyReadonlyArray1<'py, f32>),
    F64(PyReadonlyArray1<'py, f64>),
}

/// Runs `$body` with the arrays `$a…` (each a [`Floats`]) bound to slices
/// of their common float type and `$m` to `$obj.m32` or `$obj.m64`
/// accordingly; a `ValueError` when their types differ. The body is
/// written once and compiled for both precisions.
macro_rules! with_floats {
    ($obj:ident . $m:ident, ($($a:ident),+) => $body:expr) => {{
        use $crate::python::convert::{slice, Floats};
        match ($(&$a,)+) {
            ($(Floats::F32($a),)+) => {
                let $m = &$obj.m32;
                $(let $a = slice($a, stringify!($a))?;)+
                $body
            }
            ($(Floats::F64($a),)+) => {
                let $m = &$obj.m64;
                $(let $a = slice($a, stringify!($a))?;)+
                $body
            }
            _ => Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "{}: arrays must all be float32 or all float64",
                [$(stringify!($a)),+].join(", ")
            ))),
        }
    }};
}
pub(crate) use with_floats;

/// A parameter error as the `ValueError` Python sees.
pub fn value_error(e: ParamError) -> PyErr {
    PyValueError::new_err(format!("{}: {}", e.param, e.message))
}

/// Runs `f` with the GIL released.
pub fn without_gil<R: Send>(py: Python<'_>, f: impl FnOnce() -> R + Send) -> R {
    py.detach(f)
}

/// The contiguous data of `a`, or a `ValueError` naming it.
pub fn slice<'a, T: Element>(a: &'a PyReadonlyArray1<'_, T>, name: &str) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: array must be C-contiguous")))
}

/// A new numpy array holding `v`, as a Python object.
pub fn to_numpy<T: Element>(py: Python<'_>, v: Vec<T>) -> Bound<'_, PyAny> {
    PyArray1::from_vec(py, v).into_any()
}

/// Number of pairs, or a `ValueError` naming the shapes.
pub fn pairs(wi: &[impl Sized], wo: &[impl Sized]) -> PyResult<usize> {
    let ok = wi.len() % 3 == 0
        && wo.len() % 3 == 0
        && !wi.is_empty()
        && !wo.is_empty()
        && (wi.len() == wo.len() || wi.len() == 3 || wo.len() == 3);
    if !ok {
        return Err(PyValueError::new_err(format!(
            "wi, wo: shapes ({}, 3) and ({}, 3) do not broadcast",
            wi.len() / 3,
            wo.len() / 3
        )));
    }
    Ok(wi.len().max(wo.len()) / 3)
}

/// `len` must be `unit` (broadcast) or `unit * n`.
pub fn check_len(name: &str, len: usize, unit: usize, n: usize) -> PyResult<()> {
    if len == unit || len == unit * n {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "{name}: expected {unit} or {} values for {n} pairs, got {len}",
            unit * n
        )))
    }
}

/// Number of entries of per-pair arrays (`(values, values per entry,
/// name)`, each of `unit` or `unit · N` values), or a `ValueError`.
pub fn entries<T>(arrays: &[(&[T], usize, &str)]) -> PyResult<usize> {
    let n = arrays
        .iter()
        .map(|(a, u, _)| a.len() / u)
        .max()
        .unwrap_or(0);
    for (a, u, name) in arrays {
        check_len(name, a.len(), *u, n)?;
    }
    if n == 0 {
        let names: Vec<&str> = arrays.iter().map(|a| a.2).collect();
        return Err(PyValueError::new_err(format!(
            "{}: no values given",
            names.join(", ")
        )));
    }
    Ok(n)
}

/// `len` zeros, or a `MemoryError` naming `what` and the bytes asked for.
pub fn zeroed<T: Clone + Default + Send + Sync>(len: usize, what: &str) -> PyResult<Vec<T>> {
    crate::alloc::try_zeroed(len, what).map_err(|e| PyMemoryError::new_err(e.to_string()))
}

/// Runs `work` on a worker thread while this one, with the GIL, calls
/// `poll` every 50 ms and once the work is done. When `poll` fails,
/// `stop()` asks the work to end early; the guard it returns is held
/// until the worker has finished, and the error is returned.
pub fn run_polling<R: Send, G>(
    py: Python<'_>,
    work: impl FnOnce() -> R + Send,
    mut poll: impl FnMut() -> PyResult<()>,
    stop: impl FnOnce() -> G,
) -> PyResult<R> {
    std::thread::scope(|s| {
        // The worker signals its end on a channel, so the wait returns as
        // soon as the work is done.
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let rx = std::sync::Mutex::new(rx);
        let handle = s.spawn(move || {
            let r = work();
            drop(tx);
            r
        });
        loop {
            let finished = without_gil(py, || {
                let rx = rx.lock().unwrap_or_else(|e| e.into_inner());
                matches!(
                    rx.recv_timeout(std::time::Duration::from_millis(50)),
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) | Ok(())
                )
            });
            if let Err(e) = poll() {
                let guard = stop();
                let _ = without_gil(py, || handle.join());
                drop(guard);
                return Err(e);
            }
            if finished {
                break;
            }
        }
        handle
            .join()
            .map_err(|_| PyRuntimeError::new_err("the computation panicked"))
    })
}

/// Values below which a batch runs on the calling thread: a batch this
/// small takes well under the 50 ms a Ctrl-C may wait anyway.
const INTERRUPTIBLE_FROM: usize = 1 << 16;

/// Runs `f` (a batch of `len` values, or of that much work) with the GIL
/// released; for large batches on a worker thread while this one checks for Ctrl-C every
/// 50 ms ([`run_polling`]). On Ctrl-C the batch loops stop at their next
/// chunk ([`crate::batch::StopBatches`]) and the signal's exception
/// (normally `KeyboardInterrupt`) is raised; a batch cut short by a stop
/// another thread asked for raises `KeyboardInterrupt` too, never returns
/// partial output.
pub fn interruptible<R: Send>(
    py: Python<'_>,
    len: usize,
    f: impl FnOnce() -> R + Send,
) -> PyResult<R> {
    let epoch = crate::batch::stop_epoch();
    let r = if len < INTERRUPTIBLE_FROM {
        without_gil(py, f)
    } else {
        run_polling(py, f, || py.check_signals(), crate::batch::StopBatches::new)?
    };
    if !crate::batch::ran_whole(epoch) {
        return Err(PyKeyboardInterrupt::new_err(
            "batch stopped by an interrupt before it finished",
        ));
    }
    Ok(r)
}

/// `len` outputs of `f`, computed with the GIL released and Ctrl-C
/// honoured ([`interruptible`]); `MemoryError` when the output cannot be
/// allocated.
pub fn compute<'py, T: Float>(
    py: Python<'py>,
    len: usize,
    f: impl FnOnce(&mut [T]) + Send,
) -> PyResult<Bound<'py, PyAny>> {
    compute_costing(py, len, len, f)
}

/// [`compute`] for a model whose values cost about `work` cheap ones in
/// all (DEonHair: a value can take a second at 2^20 offsets), so that a
/// small but slow batch polls for Ctrl-C too.
pub fn compute_costing<'py, T: Float>(
    py: Python<'py>,
    len: usize,
    work: usize,
    f: impl FnOnce(&mut [T]) + Send,
) -> PyResult<Bound<'py, PyAny>> {
    let mut out = zeroed::<T>(len, &format!("output array of {len} values"))?;
    let out = interruptible(py, work, move || {
        f(&mut out);
        out
    })?;
    Ok(to_numpy(py, out))
}

/// The value named `name` among `options` (`(name, value)` pairs), or a
/// `ValueError` naming `param` and the allowed names.
pub fn by_name<T: Copy>(param: &str, name: &str, options: &[(&str, T)]) -> PyResult<T> {
    match options.iter().find(|o| o.0 == name) {
        Some(o) => Ok(o.1),
        None => {
            let allowed: Vec<String> = options.iter().map(|o| format!("'{}'", o.0)).collect();
            Err(PyValueError::new_err(format!(
                "{param}: must be {}, got {name:?}",
                allowed.join(" or ")
            )))
        }
    }
}
