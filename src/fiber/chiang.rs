//! Chiang et al. 2016 near-field hair BSDF, as Mitsuba 3's `hair` plugin
//! defines it, with the scale tilt's sign made physical (below).
//!
//! M. J.-Y. Chiang, B. Bitterli, C. Tappan, B. Burley, "A Practical and
//! Controllable Hair and Fur Model for Production Path Tracing", CGF 35(2),
//! 2016; longitudinal term from d'Eon et al., "An Energy-Conserving Hair
//! Reflectance Model", EGSR 2011.
//!
//! ```text
//! f(wi, wo) = Σ_{p=0}^{2} M_p(θi', θo; v_p) A_p(θi, h) N_p(Δφ; h, s)
//!           + M_3(θi, θo; v_3) A_3(θi, h) / 2π
//! ```
//!
//! - `M_p` (d'Eon): `κ/(2 sinh κ) · e^{-sin θi' sin θo κ} · I0(cos θi' cos θo κ)`,
//!   `κ = 1/v_p`; θi' is θi tilted by the cuticle scales (+2α, −α, −4α for
//!   R, TT, TRT, θ positive towards +y).
//! - The tilt's sign: the scales' free edges point to the tip, so a scale's
//!   surface leans towards the root and R peaks at θi + θo = −2α (Marschner
//!   et al. 2003, §4); with the tangent y running from a strand's first
//!   point (its root) to its last, a positive `scale_tilt` shifts R towards
//!   the root (−y), as UE's shift does in [`super::karis`]. Mitsuba's and
//!   pbrt-v4's `hair` tilt the other way on the same tangent (R at
//!   θi + θo = +2α): this model with α equals theirs with −α, and the
//!   Mitsuba bridge passes −α (`docs/tilt.md` measures all three and
//!   Cycles, which tilts as this model does).
//! - `A_p`: Fresnel `f` at `cos θi · cos γi`; `A_0 = f`,
//!   `A_1 = (1-f)² T`, `A_2 = A_1 T f`, `A_3 = A_2 f T / (1 - T f)` with
//!   `T = exp(-σa · 2 cos γt / cos θt)`.
//! - `N_p`: trimmed logistic of scale `s` around the perfect-specular
//!   azimuth `Φ_p = 2p γt - 2γi + pπ`.
//! - Roughness maps (Chiang eq. 7, 8):
//!   `v_0 = (0.726 β_m + 0.812 β_m² + 3.7 β_m^20)²`, `v_1 = v_0/4`, `v_2 = v_3 = 4 v_0`;
//!   `s = √(π/8) (0.265 β_n + 1.194 β_n² + 5.372 β_n^22)`.
//!
//! | parameter | default | range |
//! | --- | --- | --- |
//! | `sigma_a` (RGB, per unit fiber radius) | melanin | each ≥ 0, finite; exclusive with melanin |
//! | `eumelanin`, `pheomelanin` | 1.3, 0.2 | ≥ 0, finite |
//! | `longitudinal_roughness` β_m | 0.3 | [0, 1]; values below 1e-3 use 1e-3 |
//! | `coat` c (Blender's Coat: R's β_m is (1 − c) β_m) | 0 | [0, 1] |
//! | `azimuthal_roughness` β_n | 0.3 | [0, 1]; values below 1e-3 use 1e-3 |
//! | `scale_tilt` α (degrees; > 0: R towards the root) | 2 | [-90, 90] |
//! | `eta` (interior / exterior) | 1.55 | > 0, finite, ≠ 1 |
//! | `i0` | exact | `Exact` or `Mitsuba` |
//!
//! Roughness 0 would make the lobes Dirac deltas that no `eval` can
//! represent (Mitsuba then returns 0 everywhere through its NaN guard); the
//! floor 1e-3 keeps them finite functions about 0.04° wide.
//!
//! Frame: [`super::frame`] (y = tangent, z = normal; h derived from `wi`).
//! `eval` **includes** the projected-solid-angle cosine exactly as Mitsuba's
//! `hair::eval` does (it is the value whose integral over the sphere of `wo`
//! is the albedo); `pdf` is per solid angle. Non-finite results (which only
//! degenerate inputs produce) are returned as 0, as Mitsuba does.
//!
//! `I0Mode::Exact` evaluates `M_p` in a form with no overflow and no
//! cancellation for any κ: `κ / (1 - e^{-2κ}) · e^{-κ/2 |d|²} · i0e(c)` with
//! `|d|² = (cos θi' - cos θo)² + (sin θi' + sin θo)²` (= `2 - 2cos(θi'+θo)`).
//! `I0Mode::Mitsuba` reproduces Mitsuba's truncated series, its switch to
//! an asymptotic `log I0` at 12 and its `κ > 10` branch, constants included.

mod far;
mod sample;
pub(crate) mod simd;
mod table;
mod table_simd;
pub use far::{composite_gamma_rule, far_field_nodes};
pub use table::{ChiangFarTable, TableSize};
pub use table_simd::{eval_range as table_eval_range, Pairs};

use crate::fiber::frame::{azimuth, offset, sin_cos_theta, Vec3};
use crate::fiber::lobes::{deon_mp, deon_mp_mitsuba};
use crate::fiber::{number_text, param_error, ParamError};
use crate::math::{
    circ, fresnel_dielectric, safe_asin, safe_sqrt, trimmed_logistic, trimmed_logistic_inv_norm,
    wrap_pi, Real,
};

/// Number of explicitly modelled lobes (R, TT, TRT); index `P_MAX` is the residual.
pub const P_MAX: usize = 3;

/// Smallest roughness used; smaller values (including 0) are raised to it.
pub const ROUGHNESS_MIN: f64 = 1e-3;

/// Eumelanin absorption per unit concentration and fiber radius (d'Eon 2011, RGB).
pub const EUMELANIN_SIGMA_A: [f64; 3] = [0.419, 0.697, 1.37];
/// Pheomelanin absorption per unit concentration and fiber radius (d'Eon 2011, RGB).
pub const PHEOMELANIN_SIGMA_A: [f64; 3] = [0.187, 0.4, 1.05];

/// Rec. 709 luminance weights, as Mitsuba's `luminance()` (used to choose a lobe when sampling).
const LUMINANCE: [f64; 3] = [0.212671, 0.715160, 0.072169];

/// How the longitudinal term evaluates the Bessel function I0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum I0Mode {
    /// Accurate to a few ulps for every argument (default).
    Exact,
    /// Mitsuba 3's truncated series and asymptotic switch, for tight comparisons.
    Mitsuba,
}

/// Artist-facing parameters of [`ChiangHair`], validated by [`ChiangParams::build`].
#[derive(Debug, Clone, PartialEq)]
pub struct ChiangParams {
    /// Absorption coefficient per unit fiber radius (RGB); `None` uses melanin.
    pub sigma_a: Option<[f64; 3]>,
    /// Eumelanin concentration; `None`: 1.3 (when `sigma_a` is `None`).
    pub eumelanin: Option<f64>,
    /// Pheomelanin concentration; `None`: 0.2 (when `sigma_a` is `None`).
    pub pheomelanin: Option<f64>,
    /// β_m in [0, 1].
    pub longitudinal_roughness: f64,
    /// Blender's Coat c in [0, 1]: R's longitudinal roughness is (1 − c) β_m
    /// (Cycles' `m0_roughness`); 0 is Chiang's model.
    pub coat: f64,
    /// β_n in [0, 1].
    pub azimuthal_roughness: f64,
    /// Cuticle scale angle α in degrees.
    pub scale_tilt: f64,
    /// Relative index of refraction (interior / exterior).
    pub eta: f64,
    /// Bessel function evaluation.
    pub i0: I0Mode,
}

impl Default for ChiangParams {
    fn default() -> Self {
        Self {
            sigma_a: None,
            eumelanin: None,
            pheomelanin: None,
            longitudinal_roughness: 0.3,
            coat: 0.0,
            azimuthal_roughness: 0.3,
            scale_tilt: 2.0,
            eta: 1.55,
            i0: I0Mode::Exact,
        }
    }
}

impl ChiangParams {
    /// The absorption coefficient these parameters describe (RGB).
    pub fn absorption(&self) -> [f64; 3] {
        match self.sigma_a {
            Some(s) => s,
            None => {
                let eu = self.eumelanin.unwrap_or(1.3);
                let pheo = self.pheomelanin.unwrap_or(0.2);
                std::array::from_fn(|c| eu * EUMELANIN_SIGMA_A[c] + pheo * PHEOMELANIN_SIGMA_A[c])
            }
        }
    }

    /// Checks every parameter and precomputes the model.
    pub fn build<T: Real>(&self) -> Result<ChiangHair<T>, ParamError> {
        self.validate()?;
        Ok(ChiangHair::from_valid(self))
    }

    /// Checks every parameter against its allowed range.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.sigma_a.is_some() && (self.eumelanin.is_some() || self.pheomelanin.is_some()) {
            return Err(param_error(
                "sigma_a",
                "give either sigma_a or eumelanin/pheomelanin, not both",
            ));
        }
        if let Some(s) = self.sigma_a {
            if s.iter().any(|x| !x.is_finite() || *x < 0.0) {
                return Err(param_error(
                    "sigma_a",
                    format!("each component must be finite and >= 0, got {s:?}"),
                ));
            }
        }
        for (name, v) in [
            ("eumelanin", self.eumelanin),
            ("pheomelanin", self.pheomelanin),
        ] {
            if let Some(v) = v {
                if !v.is_finite() || v < 0.0 {
                    return Err(param_error(
                        name,
                        format!("must be finite and >= 0, got {}", number_text(v)),
                    ));
                }
            }
        }
        for (name, v) in [
            ("longitudinal_roughness", self.longitudinal_roughness),
            ("azimuthal_roughness", self.azimuthal_roughness),
            ("coat", self.coat),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(param_error(
                    name,
                    format!("must be in [0, 1], got {}", number_text(v)),
                ));
            }
        }
        if !(-90.0..=90.0).contains(&self.scale_tilt) {
            return Err(param_error(
                "scale_tilt",
                format!("must be in [-90, 90] degrees, got {}", self.scale_tilt),
            ));
        }
        if !self.eta.is_finite() || self.eta <= 0.0 || self.eta == 1.0 {
            return Err(param_error(
                "eta",
                format!("must be finite, > 0 and != 1, got {}", self.eta),
            ));
        }
        Ok(())
    }
}

/// Longitudinal variance of lobe 0 (Chiang eq. 7).
pub fn longitudinal_variance(beta_m: f64) -> f64 {
    let b = beta_m.max(ROUGHNESS_MIN);
    (0.726 * b + 0.812 * b * b + 3.7 * b.powi(20)).powi(2)
}

/// Logistic scale s of the azimuthal term (Chiang eq. 8).
pub fn azimuthal_scale(beta_n: f64) -> f64 {
    let b = beta_n.max(ROUGHNESS_MIN);
    (std::f64::consts::PI / 8.0).sqrt() * (0.265 * b + 1.194 * b * b + 5.372 * b.powi(22))
}

/// The Chiang 2016 hair BSDF, precomputed for one parameter set.
#[derive(Debug, Clone)]
pub struct ChiangHair<T: Real> {
    /// Longitudinal variance per lobe (R, TT, TRT, residual).
    v: [T; P_MAX + 1],
    /// Logistic scale of N_p.
    s: T,
    /// 1 / (logistic CDF(π) - CDF(-π)).
    inv_norm: T,
    /// sin and cos of α, 2α, 4α.
    sin_2k_alpha: [T; 3],
    cos_2k_alpha: [T; 3],
    eta: T,
    sigma_a: [T; 3],
    i0: I0Mode,
    /// Far-field quadrature over γ ∈ [-π/2, π/2]: (γ, sin γ, cos γ, ½ w cos γ).
    far_nodes: Vec<[T; 4]>,
}

/// Per-direction-pair geometry the model depends on.
#[derive(Debug, Clone, Copy)]
struct Geometry<T> {
    sin_theta_i: T,
    cos_theta_i: T,
    sin_theta_o: T,
    cos_theta_o: T,
    /// φo − φi
    delta_phi: T,
}

impl<T: Real> ChiangHair<T> {
    fn from_valid(p: &ChiangParams) -> Self {
        let v0 = longitudinal_variance(p.longitudinal_roughness);
        // R's variance: with a coat, from the roughness (1 − c) β_m
        let v_r = if p.coat > 0.0 {
            longitudinal_variance((1.0 - p.coat) * p.longitudinal_roughness)
        } else {
            v0
        };
        let s = azimuthal_scale(p.azimuthal_roughness);
        // physical sign: Mitsuba's α is −scale_tilt (module docs)
        let alpha = -p.scale_tilt.to_radians();
        let mut sin_2k = [alpha.sin(), 0.0, 0.0];
        let mut cos_2k = [circ(alpha.sin()), 0.0, 0.0];
        for i in 1..3 {
            sin_2k[i] = 2.0 * cos_2k[i - 1] * sin_2k[i - 1];
            cos_2k[i] = cos_2k[i - 1].powi(2) - sin_2k[i - 1].powi(2);
        }
        let sigma_a = p.absorption();
        Self {
            v: [v_r, 0.25 * v0, 4.0 * v0, 4.0 * v0].map(T::from_f64),
            s: T::from_f64(s),
            inv_norm: T::from_f64(trimmed_logistic_inv_norm(s)),
            sin_2k_alpha: sin_2k.map(T::from_f64),
            cos_2k_alpha: cos_2k.map(T::from_f64),
            eta: T::from_f64(p.eta),
            sigma_a: sigma_a.map(T::from_f64),
            i0: p.i0,
            far_nodes: far_field_nodes(s)
                .into_iter()
                .map(|(g, w)| [g, g.sin(), g.cos(), w].map(T::from_f64))
                .collect(),
        }
    }

    /// The same model in precision `U` (the constants are computed in f64
    /// and rounded once, as [`ChiangParams::build`] does, so
    /// `build::<f64>()?.cast::<f32>()` equals `build::<f32>()?`).
    pub fn cast<U: Real>(&self) -> ChiangHair<U> {
        let c = |x: T| U::from_f64(x.to_f64());
        ChiangHair {
            v: self.v.map(c),
            s: c(self.s),
            inv_norm: c(self.inv_norm),
            sin_2k_alpha: self.sin_2k_alpha.map(c),
            cos_2k_alpha: self.cos_2k_alpha.map(c),
            eta: c(self.eta),
            sigma_a: self.sigma_a.map(c),
            i0: self.i0,
            far_nodes: self.far_nodes.iter().map(|n| n.map(c)).collect(),
        }
    }

    /// Number of γ nodes `eval_far` integrates over.
    pub fn far_field_order(&self) -> usize {
        self.far_nodes.len()
    }

    /// Longitudinal variances (R, TT, TRT, residual).
    pub fn variances(&self) -> [T; P_MAX + 1] {
        self.v
    }

    /// Logistic scale of the azimuthal term.
    pub fn logistic_scale(&self) -> T {
        self.s
    }

    /// How the longitudinal term evaluates I0.
    pub fn i0_mode(&self) -> I0Mode {
        self.i0
    }

    /// `(sin θi', cos θi')`: θi tilted by the cuticle scales for lobe `p`.
    #[inline(always)]
    fn reframe_with_scales(&self, sin_theta_i: T, cos_theta_i: T, p: usize) -> (T, T) {
        let (sin_ip, cos_ip) = match p {
            // R: −2α in Mitsuba's α (+2 scale_tilt)
            0 => (
                sin_theta_i * self.cos_2k_alpha[1] - cos_theta_i * self.sin_2k_alpha[1],
                cos_theta_i * self.cos_2k_alpha[1] + sin_theta_i * self.sin_2k_alpha[1],
            ),
            // TT: +α
            1 => (
                sin_theta_i * self.cos_2k_alpha[0] + cos_theta_i * self.sin_2k_alpha[0],
                cos_theta_i * self.cos_2k_alpha[0] - sin_theta_i * self.sin_2k_alpha[0],
            ),
            // TRT: +4α
            2 => (
                sin_theta_i * self.cos_2k_alpha[2] + cos_theta_i * self.sin_2k_alpha[2],
                cos_theta_i * self.cos_2k_alpha[2] - sin_theta_i * self.sin_2k_alpha[2],
            ),
            _ => (sin_theta_i, cos_theta_i),
        };
        (sin_ip, cos_ip.abs())
    }

    /// Longitudinal scattering M_p (a density in sin θo, without Mitsuba's 1/2π).
    #[inline(always)]
    fn m_p(&self, sin_theta_i: T, cos_theta_i: T, sin_theta_o: T, cos_theta_o: T, v: T) -> T {
        match self.i0 {
            I0Mode::Exact => deon_mp(sin_theta_i, cos_theta_i, sin_theta_o, cos_theta_o, v),
            I0Mode::Mitsuba => {
                deon_mp_mitsuba(sin_theta_i, cos_theta_i, sin_theta_o, cos_theta_o, v)
            }
        }
    }

    /// Azimuthal scattering N_p for lobe p < P_MAX.
    #[inline(always)]
    fn n_p(&self, delta_phi: T, p: usize, gamma_i: T, gamma_t: T) -> T {
        let pf = T::from_f64(p as f64);
        let phi = delta_phi - (T::TWO * pf * gamma_t - T::TWO * gamma_i + pf * T::PI);
        trimmed_logistic(wrap_pi(phi), self.s, self.inv_norm)
    }

    /// γt and the transmittance of one pass through the fiber, for h.
    #[inline(always)]
    fn transmission(&self, sin_theta_i: T, cos_theta_i: T, h: T) -> (T, [T; 3]) {
        // Refraction in the longitudinal plane (Bravais).
        let sin_theta_t = sin_theta_i / self.eta;
        let cos_theta_t = circ(sin_theta_t);
        // Modified index for the azimuthal plane.
        let eta_p = safe_sqrt(self.eta * self.eta - sin_theta_i * sin_theta_i) / cos_theta_i;
        let sin_gamma_t = h / eta_p;
        let cos_gamma_t = circ(sin_gamma_t);
        let gamma_t = safe_asin(sin_gamma_t);
        let length = T::TWO * cos_gamma_t / cos_theta_t;
        (gamma_t, self.sigma_a.map(|sa| (-sa * length).exp()))
    }

    /// A_p for p = 0..=P_MAX.
    #[inline(always)]
    fn attenuation(
        &self,
        cos_theta_i: T,
        cos_gamma_i: T,
        transmittance: [T; 3],
    ) -> [[T; 3]; P_MAX + 1] {
        let f = fresnel_dielectric(cos_theta_i * cos_gamma_i.abs(), self.eta);
        let mut a = [[T::ZERO; 3]; P_MAX + 1];
        for c in 0..3 {
            let t = transmittance[c];
            a[0][c] = f;
            a[1][c] = (T::ONE - f) * (T::ONE - f) * t;
            a[2][c] = a[1][c] * t * f;
            let denom = T::ONE - t * f;
            // Geometric series of the remaining paths; 0 where it degenerates
            // (f = 1 at grazing incidence with no absorption: A_2 is 0 then).
            a[3][c] = if denom > T::ZERO {
                a[2][c] * f * t / denom
            } else {
                T::ZERO
            };
        }
        a
    }

    /// Lobe-selection probabilities: luminance of A_p, normalized.
    #[inline(always)]
    fn attenuation_pdf(a: &[[T; 3]; P_MAX + 1]) -> [T; P_MAX + 1] {
        let lum = a.map(|ap| {
            ap[0] * T::from_f64(LUMINANCE[0])
                + ap[1] * T::from_f64(LUMINANCE[1])
                + ap[2] * T::from_f64(LUMINANCE[2])
        });
        let sum = lum[0] + lum[1] + lum[2] + lum[3];
        if sum > T::ZERO {
            lum.map(|l| l / sum)
        } else {
            [T::ZERO; P_MAX + 1]
        }
    }

    /// M_p for the three explicit lobes and the residual (residual includes 1/2π).
    #[inline(always)]
    fn longitudinal_terms(&self, g: &Geometry<T>) -> [T; P_MAX + 1] {
        let mut m = [T::ZERO; P_MAX + 1];
        for (p, mp) in m.iter_mut().enumerate().take(P_MAX) {
            let (sin_ip, cos_ip) = self.reframe_with_scales(g.sin_theta_i, g.cos_theta_i, p);
            *mp = self.m_p(sin_ip, cos_ip, g.sin_theta_o, g.cos_theta_o, self.v[p]);
        }
        m[P_MAX] = self.m_p(
            g.sin_theta_i,
            g.cos_theta_i,
            g.sin_theta_o,
            g.cos_theta_o,
            self.v[P_MAX],
        ) * T::INV_TWO_PI;
        m
    }

    /// [`Self::longitudinal_terms`] with every lobe's variance raised by
    /// `extra_v` (the longitudinal spread of light forward-scattered by
    /// other fibers: dual scattering), from (sin θ, cos θ) of wi and wo.
    pub fn longitudinal_widened(&self, wi: (T, T), wo: (T, T), extra_v: T) -> [T; P_MAX + 1] {
        let mut m = [T::ZERO; P_MAX + 1];
        for (p, mp) in m.iter_mut().enumerate().take(P_MAX) {
            let (sin_ip, cos_ip) = self.reframe_with_scales(wi.0, wi.1, p);
            *mp = deon_mp(sin_ip, cos_ip, wo.0, wo.1, self.v[p] + extra_v);
        }
        m[P_MAX] = deon_mp(wi.0, wi.1, wo.0, wo.1, self.v[P_MAX] + extra_v) * T::INV_TWO_PI;
        m
    }

    /// M_p N_p per explicit lobe and the residual's M/2π, for one h.
    #[inline(always)]
    fn lobe_densities(
        &self,
        g: &Geometry<T>,
        m: &[T; P_MAX + 1],
        gamma_i: T,
        gamma_t: T,
    ) -> [T; P_MAX + 1] {
        let mut d = *m;
        for (p, dp) in d.iter_mut().enumerate().take(P_MAX) {
            *dp *= self.n_p(g.delta_phi, p, gamma_i, gamma_t);
        }
        d
    }

    #[inline(always)]
    fn geometry(wi: &Vec3<T>, wo: &Vec3<T>) -> Geometry<T> {
        let (sin_theta_i, cos_theta_i) = sin_cos_theta(wi);
        let (sin_theta_o, cos_theta_o) = sin_cos_theta(wo);
        Geometry {
            sin_theta_i,
            cos_theta_i,
            sin_theta_o,
            cos_theta_o,
            delta_phi: azimuth(wo) - azimuth(wi),
        }
    }

    /// BSDF value (RGB) for unit `wi`, `wo` in the fiber frame.
    #[inline]
    pub fn eval(&self, wi: &Vec3<T>, wo: &Vec3<T>) -> [T; 3] {
        let g = Self::geometry(wi, wo);
        let (gamma_i, h, cos_gamma_i) = offset(wi);
        let (gamma_t, transmittance) = self.transmission(g.sin_theta_i, g.cos_theta_i, h);
        let a = self.attenuation(g.cos_theta_i, cos_gamma_i, transmittance);
        let d = self.lobe_densities(&g, &self.longitudinal_terms(&g), gamma_i, gamma_t);
        finite_or_zero3(std::array::from_fn(|c| {
            a[0][c] * d[0] + a[1][c] * d[1] + a[2][c] * d[2] + a[3][c] * d[3]
        }))
    }

    /// Density (per solid angle) with which [`Self::sample`] returns `wo`.
    #[inline]
    pub fn pdf(&self, wi: &Vec3<T>, wo: &Vec3<T>) -> T {
        let g = Self::geometry(wi, wo);
        let (gamma_i, h, cos_gamma_i) = offset(wi);
        let (gamma_t, transmittance) = self.transmission(g.sin_theta_i, g.cos_theta_i, h);
        let a_pdf =
            Self::attenuation_pdf(&self.attenuation(g.cos_theta_i, cos_gamma_i, transmittance));
        let d = self.lobe_densities(&g, &self.longitudinal_terms(&g), gamma_i, gamma_t);
        finite_or_zero(a_pdf[0] * d[0] + a_pdf[1] * d[1] + a_pdf[2] * d[2] + a_pdf[3] * d[3])
    }
}

#[inline(always)]
fn finite_or_zero<T: Real>(x: T) -> T {
    if x.is_finite() {
        x
    } else {
        T::ZERO
    }
}

#[inline(always)]
fn finite_or_zero3<T: Real>(x: [T; 3]) -> [T; 3] {
    if x.iter().all(|v| v.is_finite()) {
        x
    } else {
        [T::ZERO; 3]
    }
}

#[cfg(test)]
mod tests;
