//! ChiangHair's far field from tables: the azimuthal terms averaged over
//! the fiber offset h, precomputed per material; the longitudinal terms
//! stay analytic.
//!
//! The far field ([`ChiangHair::eval_far`]) is
//!
//! ```text
//! f(wi, wo) = Σ_{p<3} M_p(θi', θo) N̄_p(θi, Δφ) + M_3(θi, θo)/2π · Ā_3(θi)
//! N̄_p(θi, φ) = ½ ∫ A_p(θi, h) N_p(φ − Φ_p(h, θi)) dh,   Ā_3(θi) = ½ ∫ A_3(θi, h) dh
//! ```
//!
//! `N̄_p` (RGB, through the absorption in `A_p`) depends on θi only through
//! cos θi (every term of `A_p` and `Φ_p` is even in θi), and is even in φ
//! (`Φ_p(−h) = −Φ_p(h)` and `A_p` is even in h). The table holds it on a
//! uniform grid of `cos θi ∈ [0, 1]` × `φ ∈ [0, π]`, each node integrated
//! by the model's own converged far-field rule, and interpolates
//! bilinearly; `Ā_3` likewise over cos θi. The φ resolution follows the
//! logistic scale s (the narrowest feature of `N̄_p` is about s wide):
//! see [`TableSize::for_scale`], and `tests/test_chiang_table.py` for the
//! measured error against the converged quadrature.
//!
//! `M_p` is d'Eon's, evaluated exactly as in `eval` (exact I0).

use super::{ChiangHair, Geometry, P_MAX};
use crate::fiber::frame::Vec3;
use crate::math::{grid_cell, trimmed_logistic, wrap_pi};
use rayon::prelude::*;

/// Grid of a [`ChiangFarTable`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableSize {
    /// Nodes over cos θi ∈ [0, 1] (at least 2).
    pub cos_theta: usize,
    /// Nodes over φ ∈ [0, π] (at least 2).
    pub phi: usize,
    /// Width of the quadrature panels over γ, in logistic scales.
    pub panel_width: f64,
}

impl TableSize {
    /// The default grid for logistic scale `s`: φ spacing s/8 (linear
    /// interpolation error of a logistic of scale s below ~1e-3 of its
    /// peak: h²/8 · max|N''|/max N with max|N''| ≈ N(0)/(2s²); measured
    /// 6π/s and 12π/s nodes give the same error, which the cos θi grid
    /// bounds), 64 to 1536 nodes; 48 nodes over cos θi (32 give 4–6× the
    /// error: the TRT caustics move with θi, and merge near θi ≈ 50° for
    /// η = 1.55); panels of 3 s over γ (0.9 s, the far-field rule's, give
    /// the same table to f32 precision). Relative L2 error against the
    /// converged quadrature over the error-table grid: at most 4.9e-4 over
    /// the 21 materials of `tests/test_chiang_table.py`.
    pub fn for_scale(s: f64) -> Self {
        let phi = ((8.0 * std::f64::consts::PI / s).ceil() as usize + 1).clamp(64, 1536);
        Self {
            cos_theta: 48,
            phi,
            panel_width: 3.0,
        }
    }
}

/// Values per grid node: N̄_p for p = 0, 1, 2, RGB each.
const NODE: usize = 3 * 3;

/// The far field of one [`ChiangHair`] from tables (see the module docs).
#[derive(Debug)]
pub struct ChiangFarTable {
    /// The model: longitudinal terms.
    model: ChiangHair<f32>,
    size: TableSize,
    /// N̄_p at node (c, φ): `n[(c · size.phi + φ) · NODE + 3p + channel]`.
    n: Vec<f32>,
    /// Ā_3 per cos θi node.
    a3: Vec<[f32; 3]>,
    /// The dual-scattering tables, built on first use, with their d_b.
    dual: std::sync::Mutex<Option<(f32, std::sync::Arc<crate::fiber::dual::DualTable>)>>,
}

impl Clone for ChiangFarTable {
    fn clone(&self) -> Self {
        Self {
            model: self.model.clone(),
            size: self.size,
            n: self.n.clone(),
            a3: self.a3.clone(),
            dual: std::sync::Mutex::new(self.dual.lock().map(|d| d.clone()).unwrap_or(None)),
        }
    }
}

impl ChiangFarTable {
    /// Builds the table of `model` (integrated in f64 by its far-field
    /// rule), in parallel on the pool.
    pub fn new(model: &ChiangHair<f64>, size: TableSize) -> Self {
        let size = TableSize {
            cos_theta: size.cos_theta.max(2),
            phi: size.phi.max(2),
            panel_width: size.panel_width.clamp(0.1, 10.0),
        };
        let rule = table_rule(model.s, size.panel_width);
        let per_c: Vec<(Vec<f32>, [f32; 3])> = crate::threads::pool().install(|| {
            (0..size.cos_theta)
                .into_par_iter()
                .map(|k| model.far_row(k as f64 / (size.cos_theta - 1) as f64, size.phi, &rule))
                .collect()
        });
        let mut n = Vec::with_capacity(size.cos_theta * size.phi * NODE);
        let mut a3 = Vec::with_capacity(size.cos_theta);
        for (row, a) in per_c {
            n.extend(row);
            a3.push(a);
        }
        Self {
            model: model.cast(),
            size,
            n,
            a3,
            dual: std::sync::Mutex::new(None),
        }
    }

    /// The material's dual-scattering tables for back density `d_b`
    /// (built from this table on first use, ~10-50 ms, then kept).
    pub fn dual(&self, d_b: f32) -> std::sync::Arc<crate::fiber::dual::DualTable> {
        let mut held = self.dual.lock().unwrap_or_else(|e| e.into_inner());
        match &*held {
            Some((d, t)) if *d == d_b => t.clone(),
            _ => {
                let t = std::sync::Arc::new(crate::fiber::dual::DualTable::for_chiang(self, d_b));
                *held = Some((d_b, t.clone()));
                t
            }
        }
    }

    /// The grid.
    pub fn size(&self) -> TableSize {
        self.size
    }

    /// The model the table was built for.
    pub fn model(&self) -> &ChiangHair<f32> {
        &self.model
    }

    /// Bytes held by the table.
    pub fn bytes(&self) -> usize {
        4 * (self.n.len() + 3 * self.a3.len())
    }

    /// N̄_p (p = 0, 1, 2, RGB) and Ā_3 at `cos θi` ∈ [0, 1] and `|φ|` ∈ [0, π].
    #[inline]
    pub fn azimuthal(&self, cos_theta_i: f32, phi: f32) -> ([[f32; 3]; 3], [f32; 3]) {
        let (kc, fc) = grid_cell(cos_theta_i, self.size.cos_theta);
        let (kp, fp) = grid_cell(phi * std::f32::consts::FRAC_1_PI, self.size.phi);
        let row = self.size.phi;
        let at = |c: usize, p: usize| &self.n[(c * row + p) * NODE..(c * row + p + 1) * NODE];
        let (n00, n01, n10, n11) = (
            at(kc, kp),
            at(kc, kp + 1),
            at(kc + 1, kp),
            at(kc + 1, kp + 1),
        );
        let (w00, w01, w10, w11) = (
            (1.0 - fc) * (1.0 - fp),
            (1.0 - fc) * fp,
            fc * (1.0 - fp),
            fc * fp,
        );
        let mut n = [[0.0f32; 3]; 3];
        for (p, np) in n.iter_mut().enumerate() {
            for (ch, v) in np.iter_mut().enumerate() {
                let i = 3 * p + ch;
                *v = w00 * n00[i] + w01 * n01[i] + w10 * n10[i] + w11 * n11[i];
            }
        }
        let (a, b) = (self.a3[kc], self.a3[kc + 1]);
        (n, std::array::from_fn(|ch| a[ch] + fc * (b[ch] - a[ch])))
    }

    /// The far field split into R, TT, TRT and the residual, RGB each, for
    /// unit `wi`, `wo` in the fiber frame (as [`ChiangHair::eval_far_lobes`]).
    #[inline]
    pub fn eval_lobes(&self, wi: &Vec3<f32>, wo: &Vec3<f32>) -> [[f32; 3]; P_MAX + 1] {
        let g = ChiangHair::<f32>::geometry(wi, wo);
        self.lobes_at(&g)
    }

    /// [`Self::eval_lobes`] from the angles: sin and cos of θi and θo (cos
    /// ≥ 0) and φo − φi (any value: wrapped here).
    #[inline]
    pub fn lobes_from_angles(
        &self,
        (sin_theta_i, cos_theta_i): (f32, f32),
        (sin_theta_o, cos_theta_o): (f32, f32),
        delta_phi: f32,
    ) -> [[f32; 3]; P_MAX + 1] {
        self.lobes_at(&Geometry {
            sin_theta_i,
            cos_theta_i,
            sin_theta_o,
            cos_theta_o,
            delta_phi,
        })
    }

    #[inline]
    fn lobes_at(&self, g: &Geometry<f32>) -> [[f32; 3]; P_MAX + 1] {
        let m = self.model.longitudinal_terms(g);
        let (n, a3) = self.azimuthal(g.cos_theta_i, wrap_pi(g.delta_phi).abs());
        let mut out = [[0.0f32; 3]; P_MAX + 1];
        for p in 0..P_MAX {
            out[p] = n[p].map(|x| m[p] * x);
        }
        out[P_MAX] = a3.map(|x| m[P_MAX] * x);
        out.map(|l| l.map(|x| if x.is_finite() { x } else { 0.0 }))
    }

    /// The far field (RGB), as [`ChiangHair::eval_far`].
    #[inline]
    pub fn eval(&self, wi: &Vec3<f32>, wo: &Vec3<f32>) -> [f32; 3] {
        let l = self.eval_lobes(wi, wo);
        std::array::from_fn(|c| l[0][c] + l[1][c] + l[2][c] + l[3][c])
    }
}

impl ChiangHair<f64> {
    /// One row of the table: N̄_p at `cos θi = c` over `phi` nodes of
    /// [0, π] (`NODE` values each), and Ā_3, by the quadrature `rule` over
    /// γ (nodes `(γ, sin γ, cos γ, weight)`). Each node's logistic is summed
    /// only within [`CUTOFF`] scales of its centre (its tail beyond is below
    /// e^-16 of its peak).
    fn far_row(&self, c: f64, phi: usize, rule: &[[f64; 4]]) -> (Vec<f32>, [f32; 3]) {
        use std::f64::consts::{PI, TAU};
        let sin_theta_i = (1.0 - c * c).max(0.0).sqrt();
        let mut row = vec![0.0f64; phi * NODE];
        let mut a3 = [0.0f64; 3];
        let step = PI / (phi - 1) as f64;
        // The trimmed logistic is evaluated at the difference wrapped into
        // [−π, π): within reach of the centre or of one of its images ±2π,
        // and never beyond π of it.
        let reach = (CUTOFF * self.s).min(PI);
        for &[gamma_i, h, cos_gamma_i, weight] in rule {
            let (gamma_t, transmittance) = self.transmission(sin_theta_i, c, h);
            let a = self.attenuation(c, cos_gamma_i, transmittance);
            for p in 0..P_MAX {
                let pf = p as f64;
                let centre = wrap_pi(2.0 * pf * gamma_t - 2.0 * gamma_i + pf * PI);
                let wa = a[p].map(|x| weight * x);
                // The φ nodes within reach of the centre or of its images ±2π.
                for image in [centre - TAU, centre, centre + TAU] {
                    let lo = ((image - reach) / step).ceil().max(0.0);
                    let hi = ((image + reach) / step).floor().min((phi - 1) as f64);
                    if !(lo <= hi) {
                        continue;
                    }
                    for j in lo as usize..=hi as usize {
                        let x = j as f64 * step - image;
                        if x >= PI {
                            continue; // counted with the next image as −π
                        }
                        let d = trimmed_logistic(x, self.s, self.inv_norm);
                        let node = &mut row[j * NODE + 3 * p..j * NODE + 3 * p + 3];
                        for ch in 0..3 {
                            node[ch] += wa[ch] * d;
                        }
                    }
                }
            }
            for ch in 0..3 {
                a3[ch] += weight * a[P_MAX][ch];
            }
        }
        let clean = |x: f64| if x.is_finite() { x as f32 } else { 0.0 };
        (row.into_iter().map(clean).collect(), a3.map(clean))
    }
}

/// Logistic scales within which a quadrature node's azimuthal term is summed.
const CUTOFF: f64 = 16.0;

/// The quadrature over γ the table integrates with: composite
/// Gauss–Legendre, 8 nodes per panel, panels `width · s` wide (at least
/// 24), weights `½ w cos γ`.
pub fn table_rule(s: f64, width: f64) -> Vec<[f64; 4]> {
    let panels = ((std::f64::consts::PI / (width * s)).ceil() as usize).clamp(12, 4096);
    super::composite_gamma_rule(panels, 8)
        .into_iter()
        .map(|(g, w)| [g, g.sin(), g.cos(), w])
        .collect()
}
