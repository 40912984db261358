//! The fiber models as Python classes: each is built in both precisions
//! once, and every operation takes flat arrays of either (see
//! [`with_floats!`]). Shapes, broadcasting and the public docs live in
//! `python/hairshade/{chiang,karis,deon}.py`.

use super::convert::{
    by_name, compute, compute_costing, entries, interruptible, pairs, to_numpy, value_error,
    with_floats, without_gil, zeroed, Float, Floats,
};
use crate::batch::{
    chiang_eval, deon_eval, dir_at, karis_eval, karis_eval_env, map_pairs_rgb, map_pairs_scalar,
    par_map, sample_batch, Precision, SampleOut,
};
use crate::fiber::chiang::{azimuthal_scale, longitudinal_variance};
use crate::fiber::chiang::{ChiangFarTable, TableSize};
use crate::fiber::deon::{DEonHair, DEonParams};
use crate::fiber::dual::DualTable;
use crate::fiber::karis::{Absorption, Components, KarisHair, KarisInputs, KarisParams};
use crate::fiber::{ChiangHair, ChiangParams, I0Mode};
use numpy::PyArrayMethods;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;

/// The component flags named in `names` ("R", "TT", "TRT", "MS").
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

type Out<'py> = PyResult<Bound<'py, PyAny>>;

/// World-space light, view and tangent directions (a tuple of three flat
/// arrays) for KarisHair and DEonHair.
#[derive(FromPyObject)]
pub struct Directions<'py>(Floats<'py>, Floats<'py>, Floats<'py>);

/// The ChiangHair operations on pairs of directions.
#[derive(Clone, Copy)]
enum ChiangOp<'a> {
    Eval,
    /// The far field: by quadrature, or from a table.
    EvalFar(Option<&'a ChiangFarTable>),
    EvalFarLobes(Option<&'a ChiangFarTable>),
    Pdf,
}

impl PyChiangHair {
    /// `op` for every pair of `wi`, `wo` (0 for a pair with a degenerate
    /// direction), in parallel with the GIL released.
    fn per_pair<'py>(
        &self,
        py: Python<'py>,
        wi: Floats<'py>,
        wo: Floats<'py>,
        op: ChiangOp<'_>,
    ) -> Out<'py> {
        with_floats!(self.m, (wi, wo) => {
            let n = pairs(wi, wo)?;
            match op {
                ChiangOp::Eval => compute(py, 3 * n, |o| chiang_eval(m, wi, wo, o)),
                ChiangOp::EvalFar(None) => compute(py, 3 * n, |o| map_pairs_rgb(wi, wo, o, |a, b| m.eval_far(a, b))),
                ChiangOp::EvalFar(Some(t)) => compute(py, 3 * n, |o| Precision::chiang_far_table_eval(t, wi, wo, o)),
                ChiangOp::EvalFarLobes(table) => compute(py, 12 * n, |o| {
                    par_map(o, |i| match (dir_at(wi, i), dir_at(wo, i)) {
                        (Some(a), Some(b)) => {
                            let l = match table {
                                None => m.eval_far_lobes(&a, &b),
                                Some(t) => t.eval_lobes(&to_f32(&a), &to_f32(&b)).map(|x| x.map(from_f32)),
                            };
                            std::array::from_fn::<_, 12, _>(|k| l[k / 3][k % 3])
                        }
                        _ => [0.0; 12],
                    })
                }),
                ChiangOp::Pdf => compute(py, n, |o| map_pairs_scalar(wi, wo, o, |a, b| m.pdf(a, b))),
            }
        })
    }
}

/// Chiang 2016 hair BSDF (flat-array interface; see `hairshade.ChiangHair`).
#[pyclass(frozen, module = "hairshade._native", name = "ChiangHair")]
pub struct PyChiangHair {
    m32: ChiangHair<f32>,
    m64: ChiangHair<f64>,
    sigma_a: [f64; 3],
    /// The far-field table at the default grid, built on first use.
    table: std::sync::OnceLock<Arc<ChiangFarTable>>,
}

impl PyChiangHair {
    /// The default far-field table (built once, with the GIL released by
    /// the caller where it matters).
    pub(super) fn table(&self) -> Arc<ChiangFarTable> {
        self.table
            .get_or_init(|| {
                let size = TableSize::for_scale(self.m64.logistic_scale());
                Arc::new(ChiangFarTable::new(&self.m64, size))
            })
            .clone()
    }

    /// The table an operation uses: none (quadrature), the default, or one
    /// built for `size`.
    fn table_for(
        &self,
        py: Python<'_>,
        fast: bool,
        size: Option<(usize, usize, f64)>,
    ) -> PyResult<Option<Arc<ChiangFarTable>>> {
        if let Some((cos_theta, phi, panel_width)) = size {
            // bounds before anything is allocated: the default grid is 48 x
            // 64..1536 nodes; TABLE_NODES nodes hold 75 MB
            let (c, p) = (TABLE_COS_THETA, TABLE_PHI);
            if !(c.0..=c.1).contains(&cos_theta)
                || !(p.0..=p.1).contains(&phi)
                || cos_theta * phi > TABLE_NODES
                || !(panel_width.is_finite() && panel_width > 0.0 && panel_width <= 64.0)
            {
                return Err(PyValueError::new_err(format!(
                    "table: expected (cos_theta nodes in [{}, {}], phi nodes in [{}, {}], at most {} \
                     nodes in all, panel width in (0, 64]), got ({cos_theta}, {phi}, {panel_width})",
                    c.0, c.1, p.0, p.1, TABLE_NODES
                )));
            }
        }
        Ok(match (fast, size) {
            (false, _) => None,
            (true, None) => Some(without_gil(py, || self.table())),
            (true, Some((cos_theta, phi, panel_width))) => Some(Arc::new(without_gil(py, || {
                let size = TableSize {
                    cos_theta,
                    phi,
                    panel_width,
                };
                ChiangFarTable::new(&self.m64, size)
            }))),
        })
    }
}

/// Ranges of a far-field table's grid given to `eval_far` and its kin.
const TABLE_COS_THETA: (usize, usize) = (2, 1024);
const TABLE_PHI: (usize, usize) = (2, 8192);
const TABLE_NODES: usize = 1 << 21;

/// A direction in f32 (the tables' precision).
fn to_f32<T: Float>(w: &[T; 3]) -> [f32; 3] {
    w.map(|x| x.to_f64() as f32)
}

fn from_f32<T: Float>(x: f32) -> T {
    T::from_f64(x as f64)
}

#[pymethods]
impl PyChiangHair {
    #[new]
    #[pyo3(signature = (sigma_a, eumelanin, pheomelanin, longitudinal_roughness, azimuthal_roughness, scale_tilt, eta, i0, coat=0.0))]
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
        coat: f64,
    ) -> PyResult<Self> {
        let i0 = by_name(
            "i0",
            i0,
            &[("exact", I0Mode::Exact), ("mitsuba", I0Mode::Mitsuba)],
        )?;
        let p = ChiangParams {
            sigma_a,
            eumelanin,
            pheomelanin,
            longitudinal_roughness,
            coat,
            azimuthal_roughness,
            scale_tilt,
            eta,
            i0,
        };
        Ok(Self {
            m32: p.build().map_err(value_error)?,
            m64: p.build().map_err(value_error)?,
            sigma_a: p.absorption(),
            table: Default::default(),
        })
    }

    /// BSDF value, cosine included: 3 values per pair.
    fn eval<'py>(&self, py: Python<'py>, wi: Floats<'py>, wo: Floats<'py>) -> Out<'py> {
        self.per_pair(py, wi, wo, ChiangOp::Eval)
    }

    /// Far field (average over h): 3 values per pair; by quadrature, or
    /// with `fast` from the tabulated azimuthal terms (`table`: a grid
    /// (cos θ nodes, φ nodes, quadrature panel width in logistic scales)
    /// other than the default, built for this call).
    #[pyo3(signature = (wi, wo, fast=false, table=None))]
    fn eval_far<'py>(
        &self,
        py: Python<'py>,
        wi: Floats<'py>,
        wo: Floats<'py>,
        fast: bool,
        table: Option<(usize, usize, f64)>,
    ) -> Out<'py> {
        let t = self.table_for(py, fast, table)?;
        self.per_pair(py, wi, wo, ChiangOp::EvalFar(t.as_deref()))
    }

    /// Far field per lobe (R, TT, TRT, residual): 12 values per pair
    /// (`fast`, `table`: as `eval_far`).
    #[pyo3(signature = (wi, wo, fast=false, table=None))]
    fn eval_far_lobes<'py>(
        &self,
        py: Python<'py>,
        wi: Floats<'py>,
        wo: Floats<'py>,
        fast: bool,
        table: Option<(usize, usize, f64)>,
    ) -> Out<'py> {
        let t = self.table_for(py, fast, table)?;
        self.per_pair(py, wi, wo, ChiangOp::EvalFarLobes(t.as_deref()))
    }

    /// The default far-field table's grid (cos θ nodes, φ nodes) and bytes.
    #[getter]
    fn far_table_size(&self) -> (usize, usize, usize) {
        let t = self.table();
        (t.size().cos_theta, t.size().phi, t.bytes())
    }

    /// The dual-scattering terms over the incidence nodes (sin θ from -1 to
    /// 1): see [`dual_dict`].
    #[pyo3(signature = (back_density=1.0))]
    fn dual_terms<'py>(&self, py: Python<'py>, back_density: f64) -> PyResult<Bound<'py, PyDict>> {
        let d_b = back_density_arg(back_density)?;
        let dual = without_gil(py, || self.table().dual(d_b));
        dual_dict(py, &dual)
    }

    /// Solid-angle density of `sample`: one value per pair.
    fn pdf<'py>(&self, py: Python<'py>, wi: Floats<'py>, wo: Floats<'py>) -> Out<'py> {
        self.per_pair(py, wi, wo, ChiangOp::Pdf)
    }

    /// Importance sampling: (wo, weight, pdf), flat.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        wi: Floats<'py>,
        u1: Floats<'py>,
        u2: Floats<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        with_floats!(self.m, (wi, u1, u2) => {
            let n = u1.len();
            if n == 0 || u2.len() != 2 * n || !(wi.len() == 3 || wi.len() == 3 * n) {
                return Err(PyValueError::new_err(format!(
                    "wi, u1, u2: shapes ({}, 3), ({},), ({}, 2) do not match",
                    wi.len() / 3,
                    n,
                    u2.len() / 2
                )));
            }
            let (mut wo, mut weight, mut pdf) = (
                zeroed(3 * n, "sample: wo")?,
                zeroed(3 * n, "sample: weight")?,
                zeroed(n, "sample: pdf")?,
            );
            let (wo, weight, pdf) = interruptible(py, 7 * n, move || {
                let out = SampleOut { wo: &mut wo, weight: &mut weight, pdf: &mut pdf };
                sample_batch(wi, u1, u2, out, |a, x, y| m.sample(a, x, y));
                (wo, weight, pdf)
            })?;
            Ok((to_numpy(py, wo), to_numpy(py, weight), to_numpy(py, pdf)))
        })
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
    /// The absorption coefficient in use (RGB), from sigma_a or melanin.
    #[getter]
    fn sigma_a(&self) -> [f64; 3] {
        self.sigma_a
    }
}

/// Chiang eq. 7: the R lobe's longitudinal variance for roughness β_m.
#[pyfunction]
pub fn chiang_longitudinal_variance(beta_m: f64) -> f64 {
    longitudinal_variance(beta_m)
}

/// Chiang eq. 8: the logistic scale s for azimuthal roughness β_n.
#[pyfunction]
pub fn chiang_azimuthal_scale(beta_n: f64) -> f64 {
    azimuthal_scale(beta_n)
}

/// `back_density` checked to lie in [0, 1].
fn back_density_arg(back_density: f64) -> PyResult<f32> {
    if !(0.0..=1.0).contains(&back_density) {
        return Err(PyValueError::new_err(format!(
            "back_density: must be in [0, 1], got {back_density}"
        )));
    }
    Ok(back_density as f32)
}

/// A dual-scattering table's terms as a dict of float64 arrays:
/// (nodes,) for `sin_theta` and (nodes, 3) for each term (see
/// `crate::fiber::dual`).
fn dual_dict<'py>(py: Python<'py>, dual: &DualTable) -> PyResult<Bound<'py, PyDict>> {
    let nodes = dual.nodes();
    let d = PyDict::new(py);
    let k = nodes.len();
    let u: Vec<f64> = (0..k)
        .map(|i| -1.0 + 2.0 * i as f64 / (k - 1) as f64)
        .collect();
    d.set_item("sin_theta", numpy::PyArray1::from_vec(py, u))?;
    type Get = fn(&crate::fiber::dual::DualTerms) -> [f32; 3];
    let fields: [(&str, Get); 9] = [
        ("a_f", |t| t.a_f),
        ("a_b", |t| t.a_b),
        ("alpha_f", |t| t.alpha_f),
        ("beta_f2", |t| t.beta_f2),
        ("alpha_b", |t| t.alpha_b),
        ("beta_b2", |t| t.beta_b2),
        ("A_b", |t| t.big_a_b),
        ("delta_b", |t| t.delta_b),
        ("sigma_b2", |t| t.sigma_b2),
    ];
    for (name, get) in fields {
        let flat: Vec<f64> = nodes.iter().flat_map(|t| get(t).map(f64::from)).collect();
        let a = numpy::PyArray1::from_vec(py, flat).reshape([k, 3])?;
        d.set_item(name, a)?;
    }
    Ok(d)
}

/// Karis 2016 / UE4 hair shading (flat-array interface; see `hairshade.KarisHair`).
#[pyclass(frozen, module = "hairshade._native", name = "KarisHair")]
pub struct PyKarisHair {
    pub(super) m32: KarisHair<f32>,
    m64: KarisHair<f64>,
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
        let absorption = by_name(
            "absorption",
            absorption,
            &[
                ("legacy", Absorption::Legacy),
                ("chiang", Absorption::Chiang),
                ("chiang_corrected", Absorption::ChiangCorrected),
            ],
        )?;
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

    /// `S(L, V, T)` (3 values per pair), or with `lobes` R, TT, TRT, MS (12
    /// per pair). Every array holds one value (or triple) per pair or a
    /// single one that broadcasts.
    #[pyo3(signature = (lvt, shadow, global_scattering, local_scattering, opaque_visibility, lobes=false))]
    #[allow(clippy::too_many_arguments)]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        lvt: Directions<'py>,
        shadow: Floats<'py>,
        global_scattering: Floats<'py>,
        local_scattering: Floats<'py>,
        opaque_visibility: Floats<'py>,
        lobes: bool,
    ) -> Out<'py> {
        let Directions(l, v, t) = lvt;
        with_floats!(self.m, (l, v, t, shadow, global_scattering, local_scattering, opaque_visibility) => {
            let n = entries(&[
                (l, 3, "L"),
                (v, 3, "V"),
                (t, 3, "T"),
                (shadow, 1, "shadow"),
                (global_scattering, 3, "global_scattering"),
                (local_scattering, 3, "local_scattering"),
                (opaque_visibility, 1, "opaque_visibility"),
            ])?;
            let inp = KarisInputs { l, v, t, shadow, global_scattering, local_scattering, opaque_visibility };
            if lobes {
                compute(py, 12 * n, |o| karis_eval::<_, true>(m, &inp, o))
            } else {
                compute(py, 3 * n, |o| karis_eval::<_, false>(m, &inp, o))
            }
        })
    }

    /// Environment lighting of the SH environment `sh` (27 values): 3
    /// values per (V, T) pair.
    fn eval_env<'py>(
        &self,
        py: Python<'py>,
        v: Floats<'py>,
        t: Floats<'py>,
        sh: Floats<'py>,
    ) -> Out<'py> {
        with_floats!(self.m, (v, t, sh) => {
            let n = entries(&[(v, 3, "V"), (t, 3, "T")])?;
            if sh.len() != 27 {
                return Err(PyValueError::new_err(format!(
                    "sh: expected 9 RGB coefficients (27 values), got {}",
                    sh.len()
                )));
            }
            let coeffs = std::array::from_fn(|k| [sh[3 * k], sh[3 * k + 1], sh[3 * k + 2]]);
            compute(py, 3 * n, |o| karis_eval_env(m, v, t, &coeffs, o))
        })
    }

    /// The dual-scattering terms of R + TT + TRT (the model's own
    /// multiple-scattering term left out) over the incidence nodes: see
    /// [`dual_dict`]. Baked once per material and density and kept.
    #[pyo3(signature = (back_density=1.0))]
    fn dual_terms<'py>(&self, py: Python<'py>, back_density: f64) -> PyResult<Bound<'py, PyDict>> {
        let d_b = back_density_arg(back_density)?;
        let dual = without_gil(py, || DualTable::for_karis_cached(&self.m32, d_b));
        dual_dict(py, &dual)
    }
}

/// UE4 HairShadingRef (flat-array interface; see `hairshade.DEonHair`).
#[pyclass(frozen, module = "hairshade._native", name = "DEonHair")]
pub struct PyDEonHair {
    pub(super) m32: DEonHair<f32>,
    m64: DEonHair<f64>,
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

    /// `S(L, V, T)` (3 values per pair), or with `lobes` R, TT, TRT (9).
    #[pyo3(signature = (lvt, lobes=false))]
    fn eval<'py>(&self, py: Python<'py>, lvt: Directions<'py>, lobes: bool) -> Out<'py> {
        let Directions(l, v, t) = lvt;
        with_floats!(self.m, (l, v, t) => {
            let n = entries(&[(l, 3, "L"), (v, 3, "V"), (t, 3, "T")])?;
            let w = if lobes { 9 } else { 3 };
            // every offset of every pair counted: a converged pair (about
            // 1 ms) or 2^20 offsets take as long as thousands of cheap values
            let per_pair = m.h_samples().map_or(1 << 16, |h| h as usize);
            compute_costing(py, w * n, n.saturating_mul(per_pair), |o| {
                deon_eval(m, l, v, t, lobes, o)
            })
        })
    }
}
