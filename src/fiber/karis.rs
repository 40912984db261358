//! Karis 2016 real-time hair shading: UE4's `HairShading()`, term by term.
//!
//! B. Karis, "Physically Based Hair Shading in Unreal", SIGGRAPH 2016
//! course; the terms exactly as Unreal Engine 4's shader source
//! `Engine/Shaders/Private/HairBsdf.ush` (`HairShading()`) computes them.
//! World-space unit vectors: `L` (to the light), `V` (to the viewer), `T`
//! (fiber tangent). `sin θL = T·L`, `sin θV = T·V`,
//! `cos θd = cos(½|asin sin θV − asin sin θL|)`, `cos φ` between the
//! projections of L and V on the normal plane (UE's `+1e-4` guard included).
//!
//! ```text
//! R   = M_R · ¼cos(φ/2) · F(√(½ + ½ V·L)) · 2·Specular · lerp(1, Backlit, sat(−V·L))
//!       M_R = g(B_R·√2 cos(φ/2), sin θL + sin θV − 2 sin α_R (cos α_R cos(φ/2) cos θV + sin α_R sin θV))
//! TT  = g(B_TT, sin θL + sin θV − α_TT) · e^{−3.65 cos φ − 3.98} · (1−f)² · T_TT · Backlit
//!       a = 1/η', η' = 1.19/cos θd + 0.36 cos θd, h = cos(φ/2)(1 + a(0.6 − 0.8 cos φ)),
//!       f = F(cos θd √(1−h²)), T_TT = C^{√(1−(ha)²)/(2 cos θd)}
//! TRT = g(B_TRT, sin θL + sin θV − α_TRT) · e^{17 cos φ − 16.78} · (1−f)² f · C^{0.8/cos θd},  f = F(½ cos θd)
//! MS  : S ← GlobalScattering (S + LocalScattering) OpaqueVisibility + KK
//!       KK = √C · (1/π) lerp(sat((n·L + 1)/4), 1 − |T·L|, 0.33) · Scatter · (C / Luma(C))^{1−Shadow}
//! S   = max(S, 0)
//! ```
//! with `g` the normalized Gaussian, `F` Schlick's Fresnel at η = 1.55,
//! `α = (−2, 1, 4)·Shift`, `B = Area + (1, ½, 2)·r²`, `r = clamp(Roughness, 1/255, 1)`,
//! `n` the fake normal `normalize(V − T(T·V))`, `Luma = C·(0.3, 0.59, 0.11)`.
//!
//! | parameter | default | range |
//! | --- | --- | --- |
//! | `base_color` C (RGB) | (0.3, 0.15, 0.08) in Python | each in [0, 1] |
//! | `specular` | 0.5 | [0, 1] |
//! | `roughness` | 0.5 | [0, 1] (clamped to ≥ 1/255 as UE) |
//! | `scatter` | 0 | [0, 1] |
//! | `shift` | 0.035 | [−0.25, 0.25] |
//! | `backlit` | 1 | [0, 1] |
//! | `area` | 0 | [0, 1] |
//! | `components` | R, TT, TRT, MS | any subset |
//! | `separable_r` | true | `bUseSeparableR` |
//! | `absorption` | `Legacy` | `Legacy` (`pow(C, …)`), `Chiang` (as UE writes it), `ChiangCorrected` |
//! | `fast_asin` | false | UE's `asinFast` for θd |
//!
//! The non-legacy absorption as UE writes it is
//! `exp(−σa · 2 · |1 − (ha)²/cos θd|)`; the physically motivated form (and
//! what the legacy path's exponent has) is `exp(−σa · 2 √(1 − (ha)²)/cos θd)`:
//! the square root looks misplaced. `Chiang` reproduces UE, `ChiangCorrected`
//! uses the square root. σa comes from C by Chiang's map with β_n = 0.3.
//!
//! `eval` is the value UE multiplies by the light's irradiance-like
//! intensity (it contains no separate cosine). Degenerate geometry: a zero
//! projection of L or V on the normal plane gives cos φ = 0 (UE's guard); a
//! view along the tangent gives a zero fake normal (`n·L = 0`); C with zero
//! luma has tint 1. Non-finite results are returned as 0.

use crate::fiber::frame::Vec3;
use crate::fiber::lobes::{
    asin_fast, color_to_absorption, d_trt_fit, d_tt_fit, eta_prime_fit, gaussian, h_tt_fit,
    HAIR_LUMA,
};
use crate::fiber::{number_text, param_error, ParamError};
use crate::lighting::sh9_eval;
use crate::math::Real;

mod dispatch;
mod inputs;
pub(crate) mod simd;
pub use dispatch::LobeVisitor;
pub use inputs::KarisInputs;

/// Index of refraction fixed by the model (the η' fit is made for it).
pub const KARIS_ETA: f64 = 1.55;

/// Which lobes to evaluate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Components {
    pub r: bool,
    pub tt: bool,
    pub trt: bool,
    pub ms: bool,
}

impl Components {
    pub const ALL: Self = Self {
        r: true,
        tt: true,
        trt: true,
        ms: true,
    };
}

/// The TT absorption term.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Absorption {
    /// `pow(C, ½√(1 − (ha)²)/cos θd)` (`bUseLegacyAbsorption`).
    Legacy,
    /// `exp(−σa · 2 · |1 − (ha)²/cos θd|)`, as UE writes it.
    Chiang,
    /// `exp(−σa · 2 √(1 − (ha)²)/cos θd)`.
    ChiangCorrected,
}

/// Artist parameters of [`KarisHair`].
#[derive(Debug, Clone, PartialEq)]
pub struct KarisParams {
    pub base_color: [f64; 3],
    pub specular: f64,
    pub roughness: f64,
    pub scatter: f64,
    pub shift: f64,
    pub backlit: f64,
    pub area: f64,
    pub components: Components,
    pub separable_r: bool,
    pub absorption: Absorption,
    pub fast_asin: bool,
}

impl Default for KarisParams {
    fn default() -> Self {
        Self {
            base_color: [0.3, 0.15, 0.08],
            specular: 0.5,
            roughness: 0.5,
            scatter: 0.0,
            shift: 0.035,
            backlit: 1.0,
            area: 0.0,
            components: Components::ALL,
            separable_r: true,
            absorption: Absorption::Legacy,
            fast_asin: false,
        }
    }
}

fn check_range(name: &'static str, v: f64, lo: f64, hi: f64) -> Result<(), ParamError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(param_error(
            name,
            format!(
                "must be in [{}, {}], got {}",
                number_text(lo),
                number_text(hi),
                number_text(v)
            ),
        ))
    }
}

impl KarisParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        if self
            .base_color
            .iter()
            .any(|c| !c.is_finite() || !(0.0..=1.0).contains(c))
        {
            return Err(param_error(
                "base_color",
                format!(
                    "each component must be in [0, 1], got {:?}",
                    self.base_color
                ),
            ));
        }
        check_range("specular", self.specular, 0.0, 1.0)?;
        check_range("roughness", self.roughness, 0.0, 1.0)?;
        check_range("scatter", self.scatter, 0.0, 1.0)?;
        check_range("shift", self.shift, -0.25, 0.25)?;
        check_range("backlit", self.backlit, 0.0, 1.0)?;
        check_range("area", self.area, 0.0, 1.0)?;
        Ok(())
    }

    pub fn build<T: Real>(&self) -> Result<KarisHair<T>, ParamError> {
        self.validate()?;
        Ok(KarisHair::from_valid(self))
    }
}

/// Per-pair inputs beyond the directions (UE's `Shadow` and `FHairTransmittanceData`).
#[derive(Debug, Clone, Copy)]
pub struct Transmittance<T> {
    /// Shadow term of the Kajiya-Kay tint, 1 = unshadowed.
    pub shadow: T,
    pub global_scattering: [T; 3],
    pub local_scattering: [T; 3],
    pub opaque_visibility: T,
}

impl<T: Real> Default for Transmittance<T> {
    fn default() -> Self {
        Self {
            shadow: T::ONE,
            global_scattering: [T::ONE; 3],
            local_scattering: [T::ZERO; 3],
            opaque_visibility: T::ONE,
        }
    }
}

/// Lobe values of one evaluation. `ms` is everything the multiple-scattering
/// block adds (its rescaling of R+TT+TRT, local scattering and the Kajiya-Kay
/// term), so the four sum to the value before UE's final `max(S, 0)`.
#[derive(Debug, Clone, Copy, Default)]
pub struct KarisLobes<T> {
    pub r: [T; 3],
    pub tt: [T; 3],
    pub trt: [T; 3],
    pub ms: [T; 3],
}

impl<T: Real> KarisLobes<T> {
    /// R + TT + TRT + MS, clamped at 0 as UE does, non-finite to 0.
    #[inline(always)]
    pub fn total(&self) -> [T; 3] {
        std::array::from_fn(|c| {
            let s = self.r[c] + self.tt[c] + self.trt[c] + self.ms[c];
            if s.is_finite() {
                s.max(T::ZERO)
            } else {
                T::ZERO
            }
        })
    }
}

/// R, TT and TRT of one evaluation as `lobe_p = g(width_p, x − shift_p) · rest_p`
/// with `x = sin θL + sin θV` (see [`KarisHair::parts`]).
#[derive(Debug, Clone, Copy)]
pub struct KarisParts<T> {
    pub x: T,
    pub cos_theta_d: T,
    pub width: [T; 3],
    pub shift: [T; 3],
    pub rest: [[T; 3]; 3],
}

impl<T: Real> KarisParts<T> {
    /// R + TT + TRT, each lobe's Gaussian at least `min_width` wide
    /// (0: the lobes as they are).
    pub fn total(&self, min_width: T) -> [T; 3] {
        let m: [T; 3] =
            std::array::from_fn(|i| gaussian(self.width[i].max(min_width), self.x - self.shift[i]));
        std::array::from_fn(|c| {
            m[0] * self.rest[0][c] + m[1] * self.rest[1][c] + m[2] * self.rest[2][c]
        })
    }
}

/// The Karis / UE4 hair model for one parameter set.
#[derive(Debug, Clone)]
pub struct KarisHair<T: Real> {
    color: [T; 3],
    sqrt_color: [T; 3],
    /// Tint base C / Luma(C) (1 where Luma is 0).
    color_over_luma: [T; 3],
    sigma_a: [T; 3],
    specular2: T,
    scatter: T,
    backlit: T,
    alpha: [T; 3],
    sin_alpha_r: T,
    cos_alpha_r: T,
    b: [T; 3],
    f0: T,
    components: Components,
    separable_r: bool,
    absorption: Absorption,
    fast_asin: bool,
}

/// Geometry shared by every lobe.
#[derive(Clone, Copy)]
struct Geometry<T> {
    vol: T,
    sin_l: T,
    sin_v: T,
    cos_theta_d: T,
    cos_phi: T,
    cos_half_phi: T,
}

#[inline(always)]
fn dot<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn saturate<T: Real>(x: T) -> T {
    x.max(T::ZERO).min(T::ONE)
}

impl<T: Real> KarisHair<T> {
    fn from_valid(p: &KarisParams) -> Self {
        let r = p.roughness.clamp(1.0 / 255.0, 1.0);
        let r2 = r * r;
        let luma: f64 = (0..3).map(|c| p.base_color[c] * HAIR_LUMA[c]).sum();
        let alpha = [-2.0 * p.shift, p.shift, 4.0 * p.shift];
        Self {
            color: p.base_color.map(T::from_f64),
            sqrt_color: p.base_color.map(|c| T::from_f64(c.sqrt())),
            color_over_luma: p
                .base_color
                .map(|c| T::from_f64(if luma > 0.0 { c / luma } else { 1.0 })),
            sigma_a: p
                .base_color
                .map(|c| T::from_f64(color_to_absorption(c, 0.3))),
            specular2: T::from_f64(2.0 * p.specular),
            scatter: T::from_f64(p.scatter),
            backlit: T::from_f64(p.backlit),
            alpha: alpha.map(T::from_f64),
            sin_alpha_r: T::from_f64(alpha[0].sin()),
            cos_alpha_r: T::from_f64(alpha[0].cos()),
            b: [p.area + r2, p.area + 0.5 * r2, p.area + 2.0 * r2].map(T::from_f64),
            f0: T::from_f64(((1.0 - KARIS_ETA) / (1.0 + KARIS_ETA)).powi(2)),
            components: p.components,
            separable_r: p.separable_r,
            absorption: p.absorption,
            fast_asin: p.fast_asin,
        }
    }

    /// An upper bound of [`Self::eval`] over all directions under the
    /// default transmittance (shadow in [0, 1]): the sum of each enabled
    /// lobe's bound, `M_p ≤ 1/(√(2π) B)` (R: `cos(φ/2)` of N_p cancels the
    /// separable width's), N_p's fit at its peak (TT `e^{−0.33}`, TRT
    /// `e^{0.22}`), `F ≤ 1`, `(1−f)²f ≤ 4/27`, absorption ≤ 1, and the
    /// Kajiya-Kay term `Scatter/π · max √C · max(1, C/Luma)`.
    pub fn upper_bound(&self) -> f32 {
        let c = self.components;
        let to = |x: T| x.to_f64();
        let inv = 1.0 / (2.0 * std::f64::consts::PI).sqrt();
        let b = self.b.map(|b| to(b).max(crate::fiber::lobes::B_MIN));
        let mut s = 0.0;
        if c.r {
            let width = if self.separable_r {
                std::f64::consts::SQRT_2
            } else {
                1.0
            };
            s += inv / (width * b[0]) * 0.25 * to(self.specular2) * to(self.backlit).max(1.0);
        }
        if c.tt {
            s += inv / b[1] * (-0.33f64).exp() * to(self.backlit);
        }
        if c.trt {
            s += inv / b[2] * 0.22f64.exp() * 4.0 / 27.0;
        }
        if c.ms {
            let kk = (0..3)
                .map(|i| to(self.sqrt_color[i]) * to(self.color_over_luma[i]).max(1.0))
                .fold(0.0, f64::max);
            s += to(self.scatter) * std::f64::consts::FRAC_1_PI * kk;
        }
        // rounding margin of the f32 evaluation
        (s * 1.001) as f32
    }

    /// Whether θd uses UE's `asinFast` (such models use the scalar kernel).
    pub fn fast_asin(&self) -> bool {
        self.fast_asin
    }

    /// Whether Scatter is 0 (the Kajiya-Kay term vanishes).
    pub fn scatter_is_zero(&self) -> bool {
        self.scatter == T::ZERO
    }

    /// The lobes this model evaluates.
    pub fn components(&self) -> Components {
        self.components
    }

    /// The same model with other lobes enabled.
    pub fn with_components(&self, components: Components) -> Self {
        Self {
            components,
            ..self.clone()
        }
    }

    /// The same model without its own multiple-scattering term: R, TT and
    /// TRT alone (what dual and volume scattering scatter, and replace the
    /// term with).
    pub fn single_scattering(&self) -> Self {
        let mut c = self.components;
        c.ms = false;
        self.with_components(c)
    }

    /// Environment-lighting variant (Karis 2016): Backlit 0 (so R is
    /// multiplied by `saturate(1 + V·L)` and TT vanishes, and TT is not
    /// evaluated at all), and 0.2 added to each β.
    pub fn environment_variant(&self) -> Self {
        let mut m = self.clone();
        m.backlit = T::ZERO;
        m.b = self.b.map(|b| b + T::from_f64(0.2));
        m.components.tt = false;
        m
    }

    #[inline(always)]
    fn schlick(&self, x: T) -> T {
        let m = saturate(T::ONE - x);
        self.f0 + (T::ONE - self.f0) * m.powi(5)
    }

    #[inline(always)]
    fn geometry(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>) -> Geometry<T> {
        let vol = dot(v, l);
        let sin_l = dot(t, l).max(-T::ONE).min(T::ONE);
        let sin_v = dot(t, v).max(-T::ONE).min(T::ONE);
        let asin = |x: T| {
            if self.fast_asin {
                asin_fast(x)
            } else {
                x.asin()
            }
        };
        let cos_theta_d = (T::HALF * (asin(sin_v) - asin(sin_l)).abs()).cos();
        let lp = [
            l[0] - sin_l * t[0],
            l[1] - sin_l * t[1],
            l[2] - sin_l * t[2],
        ];
        let vp = [
            v[0] - sin_v * t[0],
            v[1] - sin_v * t[1],
            v[2] - sin_v * t[2],
        ];
        let cos_phi = dot(&lp, &vp) / (dot(&lp, &lp) * dot(&vp, &vp) + T::from_f64(1e-4)).sqrt();
        let cos_half_phi = saturate(T::HALF + T::HALF * cos_phi).sqrt();
        Geometry {
            vol,
            sin_l,
            sin_v,
            cos_theta_d,
            cos_phi,
            cos_half_phi,
        }
    }

    /// R as `g(width, x − shift) · rest` with `x = sin θL + sin θV`
    /// (the parts of [`KarisParts`]).
    #[inline(always)]
    fn parts_r(&self, g: &Geometry<T>) -> (T, T, T) {
        let (width, shift) = self.spread_r(g);
        let n_p = T::from_f64(0.25) * g.cos_half_phi;
        let f_p = self.schlick(saturate(T::HALF + T::HALF * g.vol).sqrt());
        let back = T::ONE + (self.backlit - T::ONE) * saturate(-g.vol);
        (width, shift, n_p * f_p * self.specular2 * back)
    }

    /// R's longitudinal Gaussian: (width, shift).
    #[inline(always)]
    fn spread_r(&self, g: &Geometry<T>) -> (T, T) {
        let (sa, ca) = (self.sin_alpha_r, self.cos_alpha_r);
        let cos_v = (T::ONE - g.sin_v * g.sin_v).max(T::ZERO).sqrt();
        let shift = T::TWO * sa * (ca * g.cos_half_phi * cos_v + sa * g.sin_v);
        let b_scale = if self.separable_r {
            T::from_f64(std::f64::consts::SQRT_2) * g.cos_half_phi
        } else {
            T::ONE
        };
        (self.b[0] * b_scale, shift)
    }

    #[inline(always)]
    fn lobe_r(&self, g: &Geometry<T>) -> T {
        let (width, shift, rest) = self.parts_r(g);
        gaussian(width, g.sin_l + g.sin_v - shift) * rest
    }

    /// TT without its M_p (width B_TT, shift α_TT).
    #[inline(always)]
    fn rest_tt(&self, g: &Geometry<T>) -> [T; 3] {
        let a = T::ONE / eta_prime_fit(g.cos_theta_d);
        let h = h_tt_fit(g.cos_phi, a);
        let f = self.schlick(g.cos_theta_d * saturate(T::ONE - h * h).sqrt());
        let f_p = (T::ONE - f) * (T::ONE - f);
        let ha2 = (h * a) * (h * a);
        let n_p = d_tt_fit(g.cos_phi);
        let k = n_p * f_p * self.backlit;
        let t_p: [T; 3] = match self.absorption {
            Absorption::Legacy => {
                let e = T::HALF * (T::ONE - ha2).max(T::ZERO).sqrt() / g.cos_theta_d;
                self.color.map(|c| pow(c, e))
            }
            Absorption::Chiang => {
                let len = T::TWO * (T::ONE - ha2 / g.cos_theta_d).abs();
                self.sigma_a.map(|s| (-s * len).exp())
            }
            Absorption::ChiangCorrected => {
                let len = T::TWO * (T::ONE - ha2).max(T::ZERO).sqrt() / g.cos_theta_d;
                self.sigma_a.map(|s| (-s * len).exp())
            }
        };
        t_p.map(|t| k * t)
    }

    #[inline(always)]
    fn lobe_tt(&self, g: &Geometry<T>) -> [T; 3] {
        let m_p = gaussian(self.b[1], g.sin_l + g.sin_v - self.alpha[1]);
        self.rest_tt(g).map(|x| m_p * x)
    }

    /// TRT without its M_p (width B_TRT, shift α_TRT).
    #[inline(always)]
    fn rest_trt(&self, g: &Geometry<T>) -> [T; 3] {
        let f = self.schlick(g.cos_theta_d * T::HALF);
        let f_p = (T::ONE - f) * (T::ONE - f) * f;
        let n_p = d_trt_fit(g.cos_phi);
        let e = T::from_f64(0.8) / g.cos_theta_d;
        let k = n_p * f_p;
        self.color.map(|c| k * pow(c, e))
    }

    #[inline(always)]
    fn lobe_trt(&self, g: &Geometry<T>) -> [T; 3] {
        let m_p = gaussian(self.b[2], g.sin_l + g.sin_v - self.alpha[2]);
        self.rest_trt(g).map(|x| m_p * x)
    }

    /// R, TT and TRT split into their longitudinal Gaussians and the rest
    /// (what dual scattering widens and what it averages over azimuth);
    /// disabled lobes have a zero rest.
    pub fn parts(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>) -> KarisParts<T> {
        let g = self.geometry(l, v, t);
        let c = self.components;
        let (w_r, s_r, rest_r) = self.parts_r(&g);
        let zero = [T::ZERO; 3];
        KarisParts {
            x: g.sin_l + g.sin_v,
            cos_theta_d: g.cos_theta_d,
            width: [w_r, self.b[1], self.b[2]],
            shift: [s_r, self.alpha[1], self.alpha[2]],
            rest: [
                if c.r { [rest_r; 3] } else { zero },
                if c.tt { self.rest_tt(&g) } else { zero },
                if c.trt { self.rest_trt(&g) } else { zero },
            ],
        }
    }

    /// [`Self::parts`] without the rests (left zero): the lobes'
    /// longitudinal Gaussians alone, at a fraction of the cost.
    pub fn spreads(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>) -> KarisParts<T> {
        let g = self.geometry(l, v, t);
        let (w_r, s_r) = self.spread_r(&g);
        KarisParts {
            x: g.sin_l + g.sin_v,
            cos_theta_d: g.cos_theta_d,
            width: [w_r, self.b[1], self.b[2]],
            shift: [s_r, self.alpha[1], self.alpha[2]],
            rest: [[T::ZERO; 3]; 3],
        }
    }

    /// Kajiya-Kay diffuse attenuation (UE's `KajiyaKayDiffuseAttenuation`).
    #[inline(always)]
    fn kajiya_kay(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>, shadow: T) -> [T; 3] {
        let kajiya = T::ONE - dot(t, l).abs();
        let vt = dot(v, t);
        let fake = [v[0] - t[0] * vt, v[1] - t[1] * vt, v[2] - t[2] * vt];
        let len = dot(&fake, &fake).sqrt();
        let n_dot_l = if len > T::ZERO {
            dot(&fake, l) / len
        } else {
            T::ZERO
        };
        // Wrap = 1: (n·L + 1) / (1 + 1)²
        let nol = saturate((n_dot_l + T::ONE) / T::from_f64(4.0));
        let diffuse = T::from_f64(std::f64::consts::FRAC_1_PI)
            * (nol + (kajiya - nol) * T::from_f64(0.33))
            * self.scatter;
        let e = T::ONE - shadow;
        std::array::from_fn(|c| self.sqrt_color[c] * diffuse * pow(self.color_over_luma[c], e))
    }

    /// All lobes, with the components fixed at compile time (a disabled lobe
    /// is not evaluated at all).
    #[inline(always)]
    pub fn lobes_static<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
        &self,
        l: &Vec3<T>,
        v: &Vec3<T>,
        t: &Vec3<T>,
        tr: &Transmittance<T>,
    ) -> KarisLobes<T> {
        let g = self.geometry(l, v, t);
        let mut out = KarisLobes::default();
        if R {
            out.r = [self.lobe_r(&g); 3];
        }
        if TT {
            out.tt = self.lobe_tt(&g);
        }
        if TRT {
            out.trt = self.lobe_trt(&g);
        }
        if MS {
            let kk = self.kajiya_kay(l, v, t, tr.shadow);
            for c in 0..3 {
                let single = out.r[c] + out.tt[c] + out.trt[c];
                let scaled = tr.global_scattering[c]
                    * (single + tr.local_scattering[c])
                    * tr.opaque_visibility;
                out.ms[c] = scaled - single + kk[c];
            }
        }
        out
    }

    /// Environment lighting (Karis 2016) for a model made by
    /// [`Self::environment_variant`]: the band-2 SH radiance in the fake-normal
    /// direction `n = normalize(V − T(T·V))` (clamped at 0: band-limited SH
    /// can ring negative), times π, times the BSDF with `L = n`. A view along
    /// the tangent (no fake normal) gives 0.
    #[inline(always)]
    pub fn env_lobes_static<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
        &self,
        v: &Vec3<T>,
        t: &Vec3<T>,
        sh: &[[T; 3]; 9],
    ) -> [T; 3] {
        let vt = dot(v, t);
        let n = [v[0] - t[0] * vt, v[1] - t[1] * vt, v[2] - t[2] * vt];
        let len = dot(&n, &n).sqrt();
        if !(len > T::ZERO) {
            return [T::ZERO; 3];
        }
        let l = n.map(|x| x / len);
        let radiance = sh9_eval(sh, &l).map(|x| x.max(T::ZERO));
        let f = self
            .lobes_static::<R, TT, TRT, MS>(&l, v, t, &Transmittance::default())
            .total();
        std::array::from_fn(|c| T::PI * radiance[c] * f[c])
    }

    /// All lobes, dispatching on the model's components (batch code uses
    /// [`Self::dispatch`] to hoist the dispatch out of its loop).
    pub fn lobes(
        &self,
        l: &Vec3<T>,
        v: &Vec3<T>,
        t: &Vec3<T>,
        tr: &Transmittance<T>,
    ) -> KarisLobes<T> {
        struct One<'a, T: Real>(&'a Vec3<T>, &'a Vec3<T>, &'a Vec3<T>, &'a Transmittance<T>);
        impl<T: Real> LobeVisitor<T> for One<'_, T> {
            type Out = KarisLobes<T>;
            fn visit<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
                self,
                m: &KarisHair<T>,
            ) -> KarisLobes<T> {
                m.lobes_static::<R, TT, TRT, MS>(self.0, self.1, self.2, self.3)
            }
        }
        self.dispatch(One(l, v, t, tr))
    }

    /// BSDF value: the sum of the enabled lobes, clamped at 0.
    pub fn eval(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>, tr: &Transmittance<T>) -> [T; 3] {
        self.lobes(l, v, t, tr).total()
    }
}

/// `c^e` with `0^0 = 1` and `0^e = 0` for e > 0 (HLSL `pow` on [0, 1] colors).
#[inline(always)]
fn pow<T: Real>(c: T, e: T) -> T {
    if c <= T::ZERO {
        if e <= T::ZERO {
            T::ONE
        } else {
            T::ZERO
        }
    } else {
        (e * c.ln()).exp()
    }
}

#[cfg(test)]
mod tests;
