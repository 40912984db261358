//! The Python extension module `hairshade._native`: the only code that knows
//! about Python. It converts flat numpy arrays to slices, parameter errors to
//! `ValueError`, and runs every computation with the GIL released
//! ([`without_gil`]). Shapes and dtypes are checked by the typed API in
//! `python/hairshade/`; lengths are re-checked here so that a direct caller
//! gets an error, never a panic.

use crate::batch::{map_pairs_rgb, map_pairs_scalar, sample_batch, SampleOut};
use crate::fiber::{ChiangHair, ChiangParams, I0Mode, ParamError};
use crate::math::Real;
use numpy::{Element, PyArray1, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

fn value_error(e: ParamError) -> PyErr {
    PyValueError::new_err(format!("{}: {}", e.param, e.message))
}

/// Runs `f` with the GIL released.
fn without_gil<R: Send>(py: Python<'_>, f: impl FnOnce() -> R + Send) -> R {
    py.detach(f)
}

fn slice<'a, T: Element>(a: &'a PyReadonlyArray1<'_, T>, name: &str) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: array must be C-contiguous")))
}

/// Number of pairs, or a `ValueError` naming the shapes.
fn pairs(wi: &[impl Sized], wo: &[impl Sized]) -> PyResult<usize> {
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

fn rgb_pairs<'py, T: Real + Element>(
    py: Python<'py>,
    wi: PyReadonlyArray1<'py, T>,
    wo: PyReadonlyArray1<'py, T>,
    f: impl Fn(&[T; 3], &[T; 3]) -> [T; 3] + Sync + Send,
) -> PyResult<Bound<'py, PyArray1<T>>> {
    let (a, b) = (slice(&wi, "wi")?, slice(&wo, "wo")?);
    let n = pairs(a, b)?;
    let out = without_gil(py, || {
        let mut out = vec![T::ZERO; 3 * n];
        map_pairs_rgb(a, b, &mut out, f);
        out
    });
    Ok(PyArray1::from_vec(py, out))
}

fn scalar_pairs<'py, T: Real + Element>(
    py: Python<'py>,
    wi: PyReadonlyArray1<'py, T>,
    wo: PyReadonlyArray1<'py, T>,
    f: impl Fn(&[T; 3], &[T; 3]) -> T + Sync + Send,
) -> PyResult<Bound<'py, PyArray1<T>>> {
    let (a, b) = (slice(&wi, "wi")?, slice(&wo, "wo")?);
    let n = pairs(a, b)?;
    let out = without_gil(py, || {
        let mut out = vec![T::ZERO; n];
        map_pairs_scalar(a, b, &mut out, f);
        out
    });
    Ok(PyArray1::from_vec(py, out))
}

type SampleArrays<'py, T> = (
    Bound<'py, PyArray1<T>>,
    Bound<'py, PyArray1<T>>,
    Bound<'py, PyArray1<T>>,
);

fn sample_pairs<'py, T: Real + Element>(
    py: Python<'py>,
    wi: PyReadonlyArray1<'py, T>,
    u1: PyReadonlyArray1<'py, T>,
    u2: PyReadonlyArray1<'py, T>,
    f: impl Fn(&[T; 3], T, [T; 2]) -> ([T; 3], [T; 3], T) + Sync + Send,
) -> PyResult<SampleArrays<'py, T>> {
    let (a, s1, s2) = (slice(&wi, "wi")?, slice(&u1, "u1")?, slice(&u2, "u2")?);
    let n = s1.len();
    if n == 0 || s2.len() != 2 * n || !(a.len() == 3 || a.len() == 3 * n) {
        return Err(PyValueError::new_err(format!(
            "wi, u1, u2: shapes ({}, 3), ({},), ({}, 2) do not match",
            a.len() / 3,
            n,
            s2.len() / 2
        )));
    }
    let (wo, weight, pdf) = without_gil(py, || {
        let (mut wo, mut weight, mut pdf) =
            (vec![T::ZERO; 3 * n], vec![T::ZERO; 3 * n], vec![T::ZERO; n]);
        sample_batch(
            a,
            s1,
            s2,
            SampleOut {
                wo: &mut wo,
                weight: &mut weight,
                pdf: &mut pdf,
            },
            f,
        );
        (wo, weight, pdf)
    });
    Ok((
        PyArray1::from_vec(py, wo),
        PyArray1::from_vec(py, weight),
        PyArray1::from_vec(py, pdf),
    ))
}

/// Chiang 2016 hair BSDF (flat-array interface; see `hairshade.ChiangHair`).
#[pyclass(frozen, module = "hairshade._native", name = "ChiangHair")]
struct PyChiangHair {
    m32: ChiangHair<f32>,
    m64: ChiangHair<f64>,
}

#[pymethods]
impl PyChiangHair {
    #[new]
    #[pyo3(signature = (sigma_a, eumelanin, pheomelanin, longitudinal_roughness, azimuthal_roughness, scale_tilt, eta, i0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        sigma_a: Option<[f64; 3]>,
        eumelanin: Option<f64>,
        pheomelanin: Option<f64>,
        longitudinal_roughness: f64,
        azimuthal_roughness: f64,
        scale_tilt: f64,
        eta: f64,
        i0: &str,
    ) -> PyResult<Self> {
        let i0 = match i0 {
            "exact" => I0Mode::Exact,
            "mitsuba" => I0Mode::Mitsuba,
            other => {
                return Err(PyValueError::new_err(format!(
                    "i0: must be 'exact' or 'mitsuba', got {other:?}"
                )))
            }
        };
        let p = ChiangParams {
            sigma_a,
            eumelanin,
            pheomelanin,
            longitudinal_roughness,
            azimuthal_roughness,
            scale_tilt,
            eta,
            i0,
        };
        Ok(Self {
            m32: p.build().map_err(value_error)?,
            m64: p.build().map_err(value_error)?,
        })
    }

    fn eval_f32<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f32>,
        wo: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        rgb_pairs(py, wi, wo, |a, b| self.m32.eval(a, b))
    }
    fn eval_f64<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f64>,
        wo: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        rgb_pairs(py, wi, wo, |a, b| self.m64.eval(a, b))
    }
    fn eval_far_f32<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f32>,
        wo: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        rgb_pairs(py, wi, wo, |a, b| self.m32.eval_far(a, b))
    }
    fn eval_far_f64<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f64>,
        wo: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        rgb_pairs(py, wi, wo, |a, b| self.m64.eval_far(a, b))
    }
    fn pdf_f32<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f32>,
        wo: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        scalar_pairs(py, wi, wo, |a, b| self.m32.pdf(a, b))
    }
    fn pdf_f64<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f64>,
        wo: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        scalar_pairs(py, wi, wo, |a, b| self.m64.pdf(a, b))
    }
    fn sample_f32<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f32>,
        u1: PyReadonlyArray1<'py, f32>,
        u2: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<SampleArrays<'py, f32>> {
        sample_pairs(py, wi, u1, u2, |a, x, y| self.m32.sample(a, x, y))
    }
    fn sample_f64<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f64>,
        u1: PyReadonlyArray1<'py, f64>,
        u2: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<SampleArrays<'py, f64>> {
        sample_pairs(py, wi, u1, u2, |a, x, y| self.m64.sample(a, x, y))
    }
    /// Longitudinal variances v_p (R, TT, TRT, residual).
    #[getter]
    fn variances(&self) -> [f64; 4] {
        self.m64.variances()
    }
    /// Logistic scale s of the azimuthal term.
    #[getter]
    fn logistic_scale(&self) -> f64 {
        self.m64.logistic_scale()
    }
    /// Number of γ nodes used by `eval_far`.
    #[getter]
    fn far_field_order(&self) -> usize {
        self.m64.far_field_order()
    }
}

/// Exponentially scaled Bessel function e^{-|x|} I0(x), elementwise (f64).
#[pyfunction]
fn i0e<'py>(py: Python<'py>, x: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let xs = slice(&x, "x")?;
    let out = without_gil(py, || {
        xs.iter().map(|&v| crate::math::i0e(v)).collect::<Vec<_>>()
    });
    Ok(PyArray1::from_vec(py, out))
}

/// log I0(x), elementwise (f64); `mitsuba=True` uses Mitsuba 3's approximation.
#[pyfunction]
#[pyo3(signature = (x, mitsuba=false))]
fn log_i0<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    mitsuba: bool,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let xs = slice(&x, "x")?;
    let out = without_gil(py, || {
        xs.iter()
            .map(|&v| {
                if mitsuba {
                    crate::math::log_i0_mitsuba(v)
                } else {
                    crate::math::log_i0(v)
                }
            })
            .collect::<Vec<_>>()
    });
    Ok(PyArray1::from_vec(py, out))
}

/// Number of threads the batch evaluations use.
#[pyfunction]
fn num_threads() -> usize {
    crate::batch::num_threads()
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyChiangHair>()?;
    m.add_function(wrap_pyfunction!(i0e, m)?)?;
    m.add_function(wrap_pyfunction!(log_i0, m)?)?;
    m.add_function(wrap_pyfunction!(num_threads, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
