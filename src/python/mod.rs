//! The Python extension module `hairshade._native`: the only code that knows
//! about Python. It converts flat numpy arrays to slices, parameter errors to
//! `ValueError`, and runs every computation with the GIL released
//! ([`without_gil`]). Shapes and dtypes are checked by the typed API in
//! `python/hairshade/`; lengths are re-checked here so that a direct caller
//! gets an error, never a panic.

use crate::batch::{
    deon_eval, karis_eval, karis_eval_env, map_pairs_rgb, map_pairs_scalar, sample_batch,
    KarisInputs, SampleOut,
};
use crate::fiber::deon::{DEonHair, DEonParams};
use crate::fiber::karis::{Absorption, Components, KarisHair, KarisParams};
use crate::fiber::lobes;
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
    rgb_batch(py, wi, wo, |a, b, out| map_pairs_rgb(a, b, out, &f))
}

/// `(N, 3)` RGB output of a whole-batch function of two direction arrays.
fn rgb_batch<'py, T: Real + Element>(
    py: Python<'py>,
    wi: PyReadonlyArray1<'py, T>,
    wo: PyReadonlyArray1<'py, T>,
    f: impl Fn(&[T], &[T], &mut [T]) + Sync + Send,
) -> PyResult<Bound<'py, PyArray1<T>>> {
    let (a, b) = (slice(&wi, "wi")?, slice(&wo, "wo")?);
    let n = pairs(a, b)?;
    let out = without_gil(py, || {
        let mut out = vec![T::ZERO; 3 * n];
        f(a, b, &mut out);
        out
    });
    Ok(PyArray1::from_vec(py, out))
}

fn lobes_pairs<'py, T: Real + Element>(
    py: Python<'py>,
    wi: PyReadonlyArray1<'py, T>,
    wo: PyReadonlyArray1<'py, T>,
    f: impl Fn(&[T; 3], &[T; 3]) -> [[T; 3]; 4] + Sync + Send,
) -> PyResult<Bound<'py, PyArray1<T>>> {
    let (a, b) = (slice(&wi, "wi")?, slice(&wo, "wo")?);
    let n = pairs(a, b)?;
    let out = without_gil(py, || {
        let mut out = vec![T::ZERO; 12 * n];
        crate::batch::par_map::<T, 12, _>(&mut out, |i| {
            match (crate::batch::dir_at(a, i), crate::batch::dir_at(b, i)) {
                (Some(x), Some(y)) => {
                    let l = f(&x, &y);
                    std::array::from_fn(|k| l[k / 3][k % 3])
                }
                _ => [T::ZERO; 12],
            }
        });
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
        rgb_batch(py, wi, wo, |a, b, o| {
            crate::batch::chiang_eval(&self.m32, a, b, o)
        })
    }
    fn eval_f64<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f64>,
        wo: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        rgb_batch(py, wi, wo, |a, b, o| {
            crate::batch::chiang_eval(&self.m64, a, b, o)
        })
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
    fn eval_far_lobes_f32<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f32>,
        wo: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        lobes_pairs(py, wi, wo, |a, b| self.m32.eval_far_lobes(a, b))
    }
    fn eval_far_lobes_f64<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray1<'py, f64>,
        wo: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        lobes_pairs(py, wi, wo, |a, b| self.m64.eval_far_lobes(a, b))
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

fn components(names: &[String]) -> PyResult<Components> {
    let mut c = Components {
        r: false,
        tt: false,
        trt: false,
        ms: false,
    };
    for n in names {
        match n.as_str() {
            "R" => c.r = true,
            "TT" => c.tt = true,
            "TRT" => c.trt = true,
            "MS" => c.ms = true,
            other => {
                return Err(PyValueError::new_err(format!(
                    "components: unknown component {other:?}; allowed: 'R', 'TT', 'TRT', 'MS'"
                )))
            }
        }
    }
    Ok(c)
}

/// `len` must be `unit` (broadcast) or `unit * n`.
fn check_len(name: &str, len: usize, unit: usize, n: usize) -> PyResult<()> {
    if len == unit || len == unit * n {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "{name}: expected {unit} or {} values for {n} pairs, got {len}",
            unit * n
        )))
    }
}

/// Karis 2016 / UE4 hair shading (flat-array interface; see `hairshade.KarisHair`).
#[pyclass(frozen, module = "hairshade._native", name = "KarisHair")]
struct PyKarisHair {
    m32: KarisHair<f32>,
    m64: KarisHair<f64>,
}

type Arr<'py, T> = PyReadonlyArray1<'py, T>;
type Out<'py, T> = PyResult<Bound<'py, PyArray1<T>>>;

impl PyKarisHair {
    fn env<'py, T: Real + Element>(
        &self,
        py: Python<'py>,
        m: &KarisHair<T>,
        v: Arr<'py, T>,
        t: Arr<'py, T>,
        sh: Arr<'py, T>,
    ) -> Out<'py, T> {
        let (v, t, sh) = (slice(&v, "V")?, slice(&t, "T")?, slice(&sh, "sh")?);
        let n = (v.len().max(t.len())) / 3;
        check_len("V", v.len(), 3, n)?;
        check_len("T", t.len(), 3, n)?;
        if n == 0 {
            return Err(PyValueError::new_err("V, T: no directions given"));
        }
        if sh.len() != 27 {
            return Err(PyValueError::new_err(format!(
                "sh: expected 9 RGB coefficients (27 values), got {}",
                sh.len()
            )));
        }
        let coeffs: [[T; 3]; 9] =
            std::array::from_fn(|k| [sh[3 * k], sh[3 * k + 1], sh[3 * k + 2]]);
        let out = without_gil(py, || {
            let mut out = vec![T::ZERO; 3 * n];
            karis_eval_env(m, v, t, &coeffs, &mut out);
            out
        });
        Ok(PyArray1::from_vec(py, out))
    }

    fn run<'py, T: Real + Element, const LOBES: bool>(
        &self,
        py: Python<'py>,
        m: &KarisHair<T>,
        a: [&PyReadonlyArray1<'py, T>; 7],
    ) -> PyResult<Bound<'py, PyArray1<T>>> {
        let names = [
            "L",
            "V",
            "T",
            "shadow",
            "global_scattering",
            "local_scattering",
            "opaque_visibility",
        ];
        let units = [3, 3, 3, 1, 3, 3, 1];
        let mut s: Vec<&[T]> = Vec::with_capacity(7);
        for k in 0..7 {
            s.push(slice(a[k], names[k])?);
        }
        let n = (0..7).map(|k| s[k].len() / units[k]).max().unwrap_or(0);
        for k in 0..7 {
            check_len(names[k], s[k].len(), units[k], n)?;
        }
        if n == 0 {
            return Err(PyValueError::new_err("L, V, T: no directions given"));
        }
        let inp = KarisInputs {
            l: s[0],
            v: s[1],
            t: s[2],
            shadow: s[3],
            global_scattering: s[4],
            local_scattering: s[5],
            opaque_visibility: s[6],
        };
        let width = if LOBES { 12 } else { 3 };
        let out = without_gil(py, || {
            let mut out = vec![T::ZERO; width * n];
            karis_eval::<T, LOBES>(m, &inp, &mut out);
            out
        });
        Ok(PyArray1::from_vec(py, out))
    }
}

#[pymethods]
impl PyKarisHair {
    #[new]
    #[pyo3(signature = (base_color, specular, roughness, scatter, shift, backlit, area, components, separable_r, absorption, fast_asin))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        base_color: [f64; 3],
        specular: f64,
        roughness: f64,
        scatter: f64,
        shift: f64,
        backlit: f64,
        area: f64,
        components: Vec<String>,
        separable_r: bool,
        absorption: &str,
        fast_asin: bool,
    ) -> PyResult<Self> {
        let absorption = match absorption {
            "legacy" => Absorption::Legacy,
            "chiang" => Absorption::Chiang,
            "chiang_corrected" => Absorption::ChiangCorrected,
            other => {
                return Err(PyValueError::new_err(format!(
                    "absorption: must be 'legacy', 'chiang' or 'chiang_corrected', got {other:?}"
                )))
            }
        };
        let p = KarisParams {
            base_color,
            specular,
            roughness,
            scatter,
            shift,
            backlit,
            area,
            components: self::components(&components)?,
            separable_r,
            absorption,
            fast_asin,
        };
        Ok(Self {
            m32: p.build().map_err(value_error)?,
            m64: p.build().map_err(value_error)?,
        })
    }
    #[allow(clippy::too_many_arguments)]
    fn eval_f32<'py>(
        &self,
        py: Python<'py>,
        l: Arr<'py, f32>,
        v: Arr<'py, f32>,
        t: Arr<'py, f32>,
        shadow: Arr<'py, f32>,
        global_scattering: Arr<'py, f32>,
        local_scattering: Arr<'py, f32>,
        opaque_visibility: Arr<'py, f32>,
    ) -> Out<'py, f32> {
        self.run::<f32, false>(
            py,
            &self.m32,
            [
                &l,
                &v,
                &t,
                &shadow,
                &global_scattering,
                &local_scattering,
                &opaque_visibility,
            ],
        )
    }
    #[allow(clippy::too_many_arguments)]
    fn eval_f64<'py>(
        &self,
        py: Python<'py>,
        l: Arr<'py, f64>,
        v: Arr<'py, f64>,
        t: Arr<'py, f64>,
        shadow: Arr<'py, f64>,
        global_scattering: Arr<'py, f64>,
        local_scattering: Arr<'py, f64>,
        opaque_visibility: Arr<'py, f64>,
    ) -> Out<'py, f64> {
        self.run::<f64, false>(
            py,
            &self.m64,
            [
                &l,
                &v,
                &t,
                &shadow,
                &global_scattering,
                &local_scattering,
                &opaque_visibility,
            ],
        )
    }
    #[allow(clippy::too_many_arguments)]
    fn eval_lobes_f32<'py>(
        &self,
        py: Python<'py>,
        l: Arr<'py, f32>,
        v: Arr<'py, f32>,
        t: Arr<'py, f32>,
        shadow: Arr<'py, f32>,
        global_scattering: Arr<'py, f32>,
        local_scattering: Arr<'py, f32>,
        opaque_visibility: Arr<'py, f32>,
    ) -> Out<'py, f32> {
        self.run::<f32, true>(
            py,
            &self.m32,
            [
                &l,
                &v,
                &t,
                &shadow,
                &global_scattering,
                &local_scattering,
                &opaque_visibility,
            ],
        )
    }
    #[allow(clippy::too_many_arguments)]
    fn eval_lobes_f64<'py>(
        &self,
        py: Python<'py>,
        l: Arr<'py, f64>,
        v: Arr<'py, f64>,
        t: Arr<'py, f64>,
        shadow: Arr<'py, f64>,
        global_scattering: Arr<'py, f64>,
        local_scattering: Arr<'py, f64>,
        opaque_visibility: Arr<'py, f64>,
    ) -> Out<'py, f64> {
        self.run::<f64, true>(
            py,
            &self.m64,
            [
                &l,
                &v,
                &t,
                &shadow,
                &global_scattering,
                &local_scattering,
                &opaque_visibility,
            ],
        )
    }
    fn eval_env_f32<'py>(
        &self,
        py: Python<'py>,
        v: Arr<'py, f32>,
        t: Arr<'py, f32>,
        sh: Arr<'py, f32>,
    ) -> Out<'py, f32> {
        self.env(py, &self.m32, v, t, sh)
    }
    fn eval_env_f64<'py>(
        &self,
        py: Python<'py>,
        v: Arr<'py, f64>,
        t: Arr<'py, f64>,
        sh: Arr<'py, f64>,
    ) -> Out<'py, f64> {
        self.env(py, &self.m64, v, t, sh)
    }
}

/// UE4 HairShadingRef (flat-array interface; see `hairshade.DEonHair`).
#[pyclass(frozen, module = "hairshade._native", name = "DEonHair")]
struct PyDEonHair {
    m32: DEonHair<f32>,
    m64: DEonHair<f64>,
}

impl PyDEonHair {
    fn run<'py, T: Real + Element>(
        &self,
        py: Python<'py>,
        m: &DEonHair<T>,
        l: PyReadonlyArray1<'py, T>,
        v: PyReadonlyArray1<'py, T>,
        t: PyReadonlyArray1<'py, T>,
        lobes: bool,
    ) -> PyResult<Bound<'py, PyArray1<T>>> {
        let (l, v, t) = (slice(&l, "L")?, slice(&v, "V")?, slice(&t, "T")?);
        let n = l.len().max(v.len()).max(t.len()) / 3;
        check_len("L", l.len(), 3, n)?;
        check_len("V", v.len(), 3, n)?;
        check_len("T", t.len(), 3, n)?;
        if n == 0 {
            return Err(PyValueError::new_err("L, V, T: no directions given"));
        }
        let out = without_gil(py, || {
            let mut out = vec![T::ZERO; if lobes { 9 } else { 3 } * n];
            deon_eval(m, l, v, t, lobes, &mut out);
            out
        });
        Ok(PyArray1::from_vec(py, out))
    }
}

#[pymethods]
impl PyDEonHair {
    #[new]
    #[pyo3(signature = (base_color, roughness, shift, eta, h_samples, h_offset, components))]
    fn new(
        base_color: [f64; 3],
        roughness: f64,
        shift: f64,
        eta: f64,
        h_samples: Option<u32>,
        h_offset: f64,
        components: Vec<String>,
    ) -> PyResult<Self> {
        let p = DEonParams {
            base_color,
            roughness,
            shift,
            eta,
            h_samples,
            h_offset,
            components: self::components(&components)?,
        };
        Ok(Self {
            m32: p.build().map_err(value_error)?,
            m64: p.build().map_err(value_error)?,
        })
    }
    fn eval_f32<'py>(
        &self,
        py: Python<'py>,
        l: PyReadonlyArray1<'py, f32>,
        v: PyReadonlyArray1<'py, f32>,
        t: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        self.run(py, &self.m32, l, v, t, false)
    }
    fn eval_f64<'py>(
        &self,
        py: Python<'py>,
        l: PyReadonlyArray1<'py, f64>,
        v: PyReadonlyArray1<'py, f64>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.run(py, &self.m64, l, v, t, false)
    }
    fn eval_lobes_f32<'py>(
        &self,
        py: Python<'py>,
        l: PyReadonlyArray1<'py, f32>,
        v: PyReadonlyArray1<'py, f32>,
        t: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        self.run(py, &self.m32, l, v, t, true)
    }
    fn eval_lobes_f64<'py>(
        &self,
        py: Python<'py>,
        l: PyReadonlyArray1<'py, f64>,
        v: PyReadonlyArray1<'py, f64>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.run(py, &self.m64, l, v, t, true)
    }
}

/// Elementwise lobe pieces (f64) for `hairshade.lobes`: `name` selects the
/// function, `args` are equally long arrays (the Python side broadcasts).
#[pyfunction]
fn lobe<'py>(
    py: Python<'py>,
    name: &str,
    args: Vec<PyReadonlyArray1<'py, f64>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let a: Vec<&[f64]> = args
        .iter()
        .enumerate()
        .map(|(k, x)| slice(x, &format!("argument {k}")))
        .collect::<PyResult<_>>()?;
    let arity = match name {
        "deon_mp" => 3,
        "gaussian"
        | "eta_prime"
        | "h_tt"
        | "h_tt_fit"
        | "schlick"
        | "gaussian_detector"
        | "color_to_absorption" => 2,
        "eta_prime_fit" | "d_tt_fit" | "d_trt_fit" | "asin_fast" | "d_tt" | "d_trt" => 1,
        "logistic" => 3,
        other => {
            return Err(PyValueError::new_err(format!(
                "name: unknown lobe function {other:?}"
            )))
        }
    };
    if a.len() != arity || a.iter().any(|x| x.len() != a[0].len()) {
        return Err(PyValueError::new_err(format!(
            "{name}: expected {arity} arrays of equal length"
        )));
    }
    let n = a[0].len();
    let name = name.to_owned();
    let out = without_gil(py, || {
        (0..n)
            .map(|i| {
                let x = |k: usize| a[k][i];
                match name.as_str() {
                    "deon_mp" => {
                        let (si, so) = (x(0), x(1));
                        lobes::deon_mp(
                            si,
                            (1.0 - si * si).max(0.0).sqrt(),
                            so,
                            (1.0 - so * so).max(0.0).sqrt(),
                            x(2),
                        )
                    }
                    "gaussian" => lobes::gaussian(x(0), x(1)),
                    "gaussian_detector" => lobes::gaussian_detector(x(0), x(1)),
                    "eta_prime" => lobes::eta_prime(x(0), x(1)),
                    "eta_prime_fit" => lobes::eta_prime_fit(x(0)),
                    "h_tt" => lobes::h_tt(x(0), x(1)),
                    "h_tt_fit" => lobes::h_tt_fit(x(0), x(1)),
                    "d_tt_fit" => lobes::d_tt_fit(x(0)),
                    "d_trt_fit" => lobes::d_trt_fit(x(0)),
                    "d_tt" => lobes::logistic_d(x(0), 0.35, std::f64::consts::PI),
                    "d_trt" => 0.75 * lobes::logistic_d(x(0), 0.15, 0.0),
                    "logistic" => lobes::logistic_d(x(0), x(1), x(2)),
                    "schlick" => lobes::schlick_fresnel(x(0), x(1)),
                    "asin_fast" => lobes::asin_fast(x(0)),
                    "color_to_absorption" => lobes::color_to_absorption(x(0), x(1)),
                    _ => f64::NAN,
                }
            })
            .collect::<Vec<f64>>()
    });
    Ok(PyArray1::from_vec(py, out))
}

type CameraArgs = ([f32; 3], [f32; 3], [f32; 3], f32, u32, u32);
type LightArgs = (String, [f32; 3], [f32; 3], bool);
type SphereArgs = ([f32; 3], f32, [f32; 3]);
/// (corners Q*4*3, uvs Q*4*2, tangents Q*3, texture index per quad, textures (w, h, alpha)).
type CardArgs<'py> = (
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, u32>,
    Vec<(u32, u32, Vec<f32>)>,
);

fn build_cards(cards: Option<CardArgs<'_>>) -> PyResult<crate::raster::scene::Cards> {
    use crate::raster::scene::{AlphaTexture, Cards};
    use glam::Vec3;
    let Some((corners, uvs, tangents, texture, textures)) = cards else {
        return Ok(Cards::default());
    };
    let (c, u, t, ti) = (
        slice(&corners, "cards")?,
        slice(&uvs, "cards")?,
        slice(&tangents, "cards")?,
        slice(&texture, "cards")?,
    );
    let q = ti.len();
    if c.len() != 12 * q || u.len() != 8 * q || t.len() != 3 * q {
        return Err(PyValueError::new_err(format!(
            "cards: inconsistent array lengths for {q} quads"
        )));
    }
    let mut tex = Vec::with_capacity(textures.len());
    for (k, (w, h, a)) in textures.into_iter().enumerate() {
        if w == 0 || h == 0 || a.len() != (w * h) as usize || a.iter().any(|x| !x.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "cards: texture {k} must hold {w}x{h} finite values"
            )));
        }
        tex.push(AlphaTexture {
            width: w,
            height: h,
            alpha: a,
        });
    }
    if ti.iter().any(|&i| i as usize >= tex.len()) {
        return Err(PyValueError::new_err("cards: texture index out of range"));
    }
    Ok(Cards {
        corners: c
            .chunks_exact(3)
            .map(|x| Vec3::new(x[0], x[1], x[2]))
            .collect(),
        uvs: u.chunks_exact(2).map(|x| [x[0], x[1]]).collect(),
        tangents: t
            .chunks_exact(3)
            .map(|x| Vec3::new(x[0], x[1], x[2]))
            .collect(),
        texture: ti.to_vec(),
        textures: tex,
    })
}

/// Renders a strand scene (flat-array interface; see `hairshade.render`).
/// Returns (image as a flat float32 array, stats dict). `progress`, when
/// given, is called with (tiles done, tiles total) about 10 times a second;
/// Ctrl-C stops the render and raises KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (camera, lights, environment, points, radii, offsets, spheres, hair, transparency, layers, shadow_map_size, shadow_density, pcf_radius, background, progress=None, cards=None, shadow_model="exponential", vertex_shading=false, opaque_culling=true, triangles=None, skip_unused=true, reuse_shadow_maps=true, light_cull_threshold=1e-4, frustum_culling=true, backface_culling=true))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    camera: CameraArgs,
    lights: Vec<LightArgs>,
    environment: Option<Vec<f32>>,
    points: PyReadonlyArray1<'py, f32>,
    radii: PyReadonlyArray1<'py, f32>,
    offsets: PyReadonlyArray1<'py, u32>,
    spheres: Vec<SphereArgs>,
    hair: &Bound<'py, PyAny>,
    transparency: &str,
    layers: usize,
    shadow_map_size: u32,
    shadow_density: f32,
    pcf_radius: i32,
    background: [f32; 3],
    progress: Option<Bound<'py, PyAny>>,
    cards: Option<CardArgs<'py>>,
    shadow_model: &str,
    vertex_shading: bool,
    opaque_culling: bool,
    triangles: Option<(
        PyReadonlyArray1<'py, f32>,
        PyReadonlyArray1<'py, f32>,
        PyReadonlyArray1<'py, u32>,
    )>,
    skip_unused: bool,
    reuse_shadow_maps: bool,
    light_cull_threshold: f32,
    frustum_culling: bool,
    backface_culling: bool,
) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, pyo3::types::PyDict>)> {
    use crate::raster::scene::*;
    use glam::Vec3;
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

    let (pts, rad, off) = (
        slice(&points, "points")?,
        slice(&radii, "radii")?,
        slice(&offsets, "offsets")?,
    );
    if pts.len() != 3 * rad.len() {
        return Err(PyValueError::new_err(format!(
            "points, radii: {} points but {} radii",
            pts.len() / 3,
            rad.len()
        )));
    }
    if off.is_empty()
        || off[0] != 0
        || off.windows(2).any(|w| w[1] < w[0])
        || *off.last().unwrap() as usize != rad.len()
    {
        return Err(PyValueError::new_err(
            "offsets: must start at 0, not decrease, and end at the number of points",
        ));
    }
    if camera.4 == 0 || camera.5 == 0 || camera.4 > 16384 || camera.5 > 16384 {
        return Err(PyValueError::new_err(format!(
            "resolution: must be in [1, 16384], got {}x{}",
            camera.4, camera.5
        )));
    }
    let shading = if let Ok(k) = hair.cast::<PyKarisHair>() {
        HairShading::Karis(k.get().m32.clone())
    } else if let Ok(c) = hair.cast::<PyChiangHair>() {
        HairShading::ChiangFar(Box::new(c.get().m32.clone()))
    } else if let Ok(d) = hair.cast::<PyDEonHair>() {
        HairShading::DEon(Box::new(d.get().m32.clone()))
    } else {
        return Err(PyValueError::new_err(
            "hair: expected a KarisHair, ChiangHair or DEonHair model",
        ));
    };
    let mut ls = Vec::with_capacity(lights.len());
    for (kind, v, i, shadows) in lights {
        ls.push(match kind.as_str() {
            "directional" => Light::Directional {
                direction: Vec3::from(v).normalize_or(Vec3::Z),
                intensity: Vec3::from(i),
                shadows,
            },
            "point" => Light::Point {
                position: Vec3::from(v),
                intensity: Vec3::from(i),
                shadows,
            },
            other => {
                return Err(PyValueError::new_err(format!(
                    "lights: unknown light type {other:?}"
                )))
            }
        });
    }
    let environment = match environment {
        None => None,
        Some(c) if c.len() == 27 => Some(Environment {
            sh: std::array::from_fn(|k| [c[3 * k], c[3 * k + 1], c[3 * k + 2]]),
        }),
        Some(c) => {
            return Err(PyValueError::new_err(format!(
                "environment: expected 27 SH values, got {}",
                c.len()
            )))
        }
    };
    let transparency = match transparency {
        "mlab" => Transparency::Mlab(layers.clamp(1, 64)),
        "sorted" => Transparency::Sorted,
        other => {
            return Err(PyValueError::new_err(format!(
                "transparency: must be 'mlab' or 'sorted', got {other:?}"
            )))
        }
    };
    let scene = Scene {
        camera: Camera {
            position: camera.0.into(),
            target: camera.1.into(),
            up: camera.2.into(),
            fov_y: camera.3,
            width: camera.4,
            height: camera.5,
        },
        lights: ls,
        environment,
        strands: Strands {
            points: pts
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect(),
            radii: rad.to_vec(),
            offsets: off.to_vec(),
        },
        cards: build_cards(cards)?,
        triangles: match &triangles {
            None => Vec::new(),
            Some((p, a, m)) => {
                let (p, a, m) = (
                    slice(p, "triangles")?,
                    slice(a, "triangles")?,
                    slice(m, "triangles")?,
                );
                if p.len() != 3 * a.len() || a.len() % 3 != 0 || 3 * m.len() != a.len() {
                    return Err(PyValueError::new_err(
                        "triangles: expected 9 position, 3 albedo values and a mesh index per triangle",
                    ));
                }
                (0..a.len() / 3)
                    .map(|t| crate::raster::scene::OpaqueTri {
                        p: std::array::from_fn(|k| {
                            Vec3::new(p[9 * t + 3 * k], p[9 * t + 3 * k + 1], p[9 * t + 3 * k + 2])
                        }),
                        albedo: Vec3::new(a[3 * t], a[3 * t + 1], a[3 * t + 2]),
                        mesh: m[t],
                    })
                    .collect()
            }
        },
        spheres: spheres
            .into_iter()
            .map(|(c, r, a)| Sphere {
                center: c.into(),
                radius: r,
                albedo: a.into(),
            })
            .collect(),
        hair: shading,
    };
    let shadow_model = match shadow_model {
        "opacity" => crate::raster::shadow::ShadowModel::Opacity,
        "exponential" => crate::raster::shadow::ShadowModel::Exponential,
        other => {
            return Err(PyValueError::new_err(format!(
                "shadow_model: must be 'opacity' or 'exponential', got {other:?}"
            )))
        }
    };
    let opts = RenderOptions {
        transparency,
        shadow_map_size,
        shadow_model,
        shadow_density,
        pcf_radius,
        background: background.into(),
        vertex_shading,
        frustum_culling,
        backface_culling,
        opaque_culling,
        skip_unused,
        reuse_shadow_maps,
        light_cull_threshold,
    };
    let total = crate::raster::tile_count(&scene);
    let (done, cancel) = (AtomicUsize::new(0), AtomicBool::new(false));
    let result = std::thread::scope(|s| -> PyResult<_> {
        // The worker signals its end on a channel, so the wait returns as
        // soon as the image is done (and every 50 ms for progress and Ctrl-C).
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let rx = std::sync::Mutex::new(rx);
        let handle = s.spawn(|| {
            let r = crate::raster::render_with_progress(&scene, &opts, &done, &cancel);
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
            if let Err(e) = py.check_signals() {
                cancel.store(true, Ordering::Relaxed);
                let _ = handle.join();
                return Err(e);
            }
            if let Some(cb) = &progress {
                if let Err(e) = cb.call1((done.load(Ordering::Relaxed), total)) {
                    cancel.store(true, Ordering::Relaxed);
                    let _ = handle.join();
                    return Err(e);
                }
            }
            if finished {
                break;
            }
        }
        handle
            .join()
            .map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("render: the renderer panicked"))
    })?;
    let (image, stats) =
        result.ok_or_else(|| pyo3::exceptions::PyKeyboardInterrupt::new_err("render cancelled"))?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("segments", stats.segments)?;
    d.set_item("segments_visible", stats.segments_visible)?;
    d.set_item("vertices_shaded", stats.vertices_shaded)?;
    d.set_item("backfaces_culled", stats.backfaces_culled)?;
    d.set_item("fragments", stats.fragments)?;
    d.set_item("non_finite_pixels", stats.non_finite_pixels)?;
    d.set_item("culled_behind_opaque", stats.culled_behind_opaque)?;
    d.set_item("lights_culled", stats.lights_culled)?;
    d.set_item("light_cull_max_skipped", stats.light_cull_max_skipped)?;
    d.set_item("shadow_ms", stats.shadow_ms)?;
    d.set_item("shadow_maps_reused", stats.shadow_maps_reused)?;
    d.set_item("shadow_maps_skipped", stats.shadow_maps_skipped)?;
    d.set_item("setup_ms", stats.setup_ms)?;
    d.set_item("tiles_ms", stats.tiles_ms)?;
    d.set_item("total_ms", stats.total_ms)?;
    Ok((PyArray1::from_vec(py, image.data), d))
}

/// Writes a float RGB EXR from a flat (H*W*3) float32 array.
#[pyfunction]
fn write_exr(
    py: Python<'_>,
    path: std::path::PathBuf,
    width: usize,
    height: usize,
    data: PyReadonlyArray1<'_, f32>,
) -> PyResult<()> {
    let d = slice(&data, "image")?;
    if d.len() != width * height * 3 {
        return Err(PyValueError::new_err(format!(
            "image: expected {}x{}x3 values, got {}",
            height,
            width,
            d.len()
        )));
    }
    without_gil(py, || crate::image_io::write_exr(&path, width, height, d))
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.0))
}

/// Reads an EXR's RGB channels: (width, height, flat float32 array).
#[pyfunction]
fn read_exr(
    py: Python<'_>,
    path: std::path::PathBuf,
) -> PyResult<(usize, usize, Bound<'_, PyArray1<f32>>)> {
    let (w, h, d) = without_gil(py, || crate::image_io::read_exr(&path))
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.0))?;
    Ok((w, h, PyArray1::from_vec(py, d)))
}

/// Reads a PNG: (width, height, flat RGBA float32 array in [0, 1]).
#[pyfunction]
fn read_png(
    py: Python<'_>,
    path: std::path::PathBuf,
) -> PyResult<(usize, usize, Bound<'_, PyArray1<f32>>)> {
    let (w, h, d) = without_gil(py, || crate::image_io::read_png(&path))
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.0))?;
    Ok((w, h, PyArray1::from_vec(py, d)))
}

/// Writes an sRGB PNG preview of a flat (H*W*3) linear float32 image.
#[pyfunction]
fn write_png(
    py: Python<'_>,
    path: std::path::PathBuf,
    width: usize,
    height: usize,
    data: PyReadonlyArray1<'_, f32>,
    exposure: f32,
) -> PyResult<()> {
    let d = slice(&data, "image")?;
    if d.len() != width * height * 3 {
        return Err(PyValueError::new_err(format!(
            "image: expected {}x{}x3 values, got {}",
            height,
            width,
            d.len()
        )));
    }
    without_gil(py, || {
        crate::image_io::write_png(&path, width, height, d, exposure)
    })
    .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.0))
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

/// Runs later evaluations and renders on one thread (True) or all (False).
#[pyfunction]
fn set_single_threaded(on: bool) {
    crate::batch::set_single_threaded(on)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyChiangHair>()?;
    m.add_class::<PyKarisHair>()?;
    m.add_class::<PyDEonHair>()?;
    m.add_function(wrap_pyfunction!(lobe, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_png, m)?)?;
    m.add_function(wrap_pyfunction!(read_png, m)?)?;
    m.add_function(wrap_pyfunction!(i0e, m)?)?;
    m.add_function(wrap_pyfunction!(log_i0, m)?)?;
    m.add_function(wrap_pyfunction!(num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(set_single_threaded, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
