//! Arrays in and out, errors, and the GIL: everything the bindings share.
//!
//! Every native operation takes flat 1-D numpy arrays of one float type
//! ([`Floats`]: float32 or float64, chosen by the typed Python API) and
//! returns flat arrays of the same type. [`with_floats!`] runs an
//! operation's body once per type, with the model built in that precision.

use crate::batch::Precision;
use crate::fiber::ParamError;
use numpy::{Element, PyArray1, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The float types the bindings compute in.
pub trait Float: Precision + Element {}
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

/// `width · n` outputs of `f`, computed with the GIL released.
pub fn compute<'py, T: Float>(
    py: Python<'py>,
    len: usize,
    f: impl FnOnce(&mut [T]) + Send,
) -> Bound<'py, PyAny> {
    let out = without_gil(py, || {
        let mut out = vec![T::ZERO; len];
        f(&mut out);
        out
    });
    to_numpy(py, out)
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
