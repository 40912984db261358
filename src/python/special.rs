//! Special functions and lobe pieces, elementwise on f64 arrays (for
//! `hairshade.lobes` and the tests against scipy), and the thread settings.

use super::convert::{slice, to_numpy, without_gil};
use crate::fiber::lobes;
use numpy::PyReadonlyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A lobe piece: its name, arity and the function of its arguments.
type LobeFn = (&'static str, usize, fn(&[f64]) -> f64);

/// Every lobe piece `lobe()` evaluates.
const LOBE_FNS: &[LobeFn] = &[
    ("deon_mp", 3, |x| {
        let (si, so) = (x[0], x[1]);
        let cos = |s: f64| (1.0 - s * s).max(0.0).sqrt();
        lobes::deon_mp(si, cos(si), so, cos(so), x[2])
    }),
    ("gaussian", 2, |x| lobes::gaussian(x[0], x[1])),
    ("gaussian_detector", 2, |x| {
        lobes::gaussian_detector(x[0], x[1])
    }),
    ("eta_prime", 2, |x| lobes::eta_prime(x[0], x[1])),
    ("eta_prime_fit", 1, |x| lobes::eta_prime_fit(x[0])),
    ("h_tt", 2, |x| lobes::h_tt(x[0], x[1])),
    ("h_tt_fit", 2, |x| lobes::h_tt_fit(x[0], x[1])),
    ("d_tt_fit", 1, |x| lobes::d_tt_fit(x[0])),
    ("d_trt_fit", 1, |x| lobes::d_trt_fit(x[0])),
    ("d_tt", 1, |x| {
        lobes::logistic_d(x[0], 0.35, std::f64::consts::PI)
    }),
    ("d_trt", 1, |x| 0.75 * lobes::logistic_d(x[0], 0.15, 0.0)),
    ("logistic", 3, |x| lobes::logistic_d(x[0], x[1], x[2])),
    ("schlick", 2, |x| lobes::schlick_fresnel(x[0], x[1])),
    ("asin_fast", 1, |x| lobes::asin_fast(x[0])),
    ("color_to_absorption", 2, |x| {
        lobes::color_to_absorption(x[0], x[1])
    }),
];

/// Elementwise lobe pieces (f64) for `hairshade.lobes`: `name` selects the
/// function, `args` are equally long arrays (the Python side broadcasts).
#[pyfunction]
pub fn lobe<'py>(
    py: Python<'py>,
    name: &str,
    args: Vec<PyReadonlyArray1<'py, f64>>,
) -> PyResult<Bound<'py, PyAny>> {
    let Some(&(_, arity, f)) = LOBE_FNS.iter().find(|e| e.0 == name) else {
        return Err(PyValueError::new_err(format!(
            "name: unknown lobe function {name:?}"
        )));
    };
    let a: Vec<&[f64]> = args
        .iter()
        .enumerate()
        .map(|(k, x)| slice(x, &format!("argument {k}")))
        .collect::<PyResult<_>>()?;
    if a.len() != arity || a.iter().any(|x| x.len() != a[0].len()) {
        return Err(PyValueError::new_err(format!(
            "{name}: expected {arity} arrays of equal length"
        )));
    }
    let n = a[0].len();
    let out = without_gil(py, || {
        let mut x = vec![0.0; arity];
        (0..n)
            .map(|i| {
                for (xk, ak) in x.iter_mut().zip(&a) {
                    *xk = ak[i];
                }
                f(&x)
            })
            .collect::<Vec<f64>>()
    });
    Ok(to_numpy(py, out))
}

/// `f` elementwise over a f64 array, with the GIL released.
fn map_f64<'py>(
    py: Python<'py>,
    x: &PyReadonlyArray1<'py, f64>,
    f: impl Fn(f64) -> f64 + Send + Sync,
) -> PyResult<Bound<'py, PyAny>> {
    let xs = slice(x, "x")?;
    Ok(to_numpy(
        py,
        without_gil(py, || xs.iter().map(|&v| f(v)).collect::<Vec<_>>()),
    ))
}

/// Exponentially scaled Bessel function e^{-|x|} I0(x), elementwise (f64).
#[pyfunction]
pub fn i0e<'py>(py: Python<'py>, x: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyAny>> {
    map_f64(py, &x, crate::math::i0e)
}

/// log I0(x), elementwise (f64); `mitsuba=True` uses Mitsuba 3's approximation.
#[pyfunction]
#[pyo3(signature = (x, mitsuba=false))]
pub fn log_i0<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    mitsuba: bool,
) -> PyResult<Bound<'py, PyAny>> {
    if mitsuba {
        map_f64(py, &x, crate::math::log_i0_mitsuba)
    } else {
        map_f64(py, &x, crate::math::log_i0)
    }
}

/// Number of threads the batch evaluations use.
#[pyfunction]
pub fn num_threads() -> usize {
    crate::threads::num_threads()
}

/// Runs later evaluations and renders on one thread (True) or all (False).
#[pyfunction]
pub fn set_single_threaded(on: bool) {
    crate::threads::set_single_threaded(on)
}

/// The vector level the f32 kernels run at: "avx512", "avx2" or "portable".
#[pyfunction]
pub fn simd_level() -> &'static str {
    crate::simd::Level::detect().name()
}
