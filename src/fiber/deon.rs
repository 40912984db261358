//! The far-field reference that Karis's approximation targets: UE4's
//! `HairShadingRef()` with the same artist parameters.
//!
//! d'Eon, Francois, Hill, Letteri, Aubry, "An Energy-Conserving Hair
//! Reflectance Model", EGSR 2011 (M_p, and N_p as an integral over the offset
//! h with a Gaussian detector); d'Eon et al. 2014 for the azimuth-dependent R
//! width; the exact terms as Unreal Engine 4's shader source
//! `Engine/Shaders/Private/HairBsdf.ush` (`HairShadingRef()`) computes them.
//!
//! ```text
//! S = Σ_{p ∈ R, TT, TRT} M_p(θL, θV'_p; v_p) · N_p(φ)
//! M_p  d'Eon, v_p = B_p², B = (1, ½, 2)·r²; R: B_R·√2 cos(φ/2) and
//!      sin θV' = sin θV − 2 sin α_R (cos(φ/2) cos α_R cos θV + sin α_R sin θV);
//!      TT, TRT: θV' = θV − α_p
//! N_p(φ) = ½ ∫_{-1}^{1} A_p(h) D_{B_p}(φ − Ω_p(h)) dh,   Ω_p = 2p γt − 2γi + pπ,
//!      γi = asin h, γt = asin(h/η'), η' = √(η² − 1 + cos²θd)/cos θd,
//!      D the Gaussian detector (wrapped Gaussian of width B_p)
//! A_R  = F(√(½ + ½ V·L))
//! A_TT = (1−f)² T,  A_TRT = (1−f)² f T²,  f = F(cos θd √(1−h²)),
//!      T = exp(−2 μa cos γt / cos θt), μa = −¼ ln C, cos θt = √(1 − (sin θL/η)²)
//! ```
//! `F` is Schlick's Fresnel at η. With `h_samples = None` every N_p is
//! integrated over γ = asin h (removing the endpoint singularity) by adaptive
//! Gauss–Kronrod, with breakpoints at every peak (roots of
//! `φ − Ω_p = 2πk`) and at the TRT caustic, to 1e-8 relative (f64; 1e-5 in
//! f32); with `h_samples = Some(n)` it is UE's stratified estimate
//! `½ · (2/n) Σ_i A D` at `h_i = 2 (i + offset)/n − 1`.
//!
//! | parameter | default | range |
//! | --- | --- | --- |
//! | `base_color` C | — | each in [0, 1] |
//! | `roughness` r | 0.5 | [0, 1], clamped to ≥ 1/255 as UE |
//! | `shift` | 0.035 | [−0.25, 0.25] |
//! | `eta` | 1.55 | (1, 3] |
//! | `h_samples` | None (converged) | [1, 2^20] |
//! | `h_offset` | 0.5 | [0, 1) |
//! | `components` | R, TT, TRT | any subset (MS is not part of the reference) |
//!
//! Same vectors and frame as [`super::karis`]. A zero projection of L or V
//! on the normal plane gives cos φ = 0. Non-finite results are returned as 0.

use crate::fiber::frame::Vec3;
use crate::fiber::karis::Components;
use crate::fiber::lobes::{deon_mp, eta_prime, gaussian_detector, schlick_fresnel};
use crate::fiber::{param_error, ParamError};
use crate::math::{integrate_adaptive, safe_asin, Real};

/// Most h samples per lobe (2^20): UE's stratified estimate converges long
/// before (its default is a few dozen; the tests' brute-force reference
/// takes 200 000), and each sample costs one N_p term per pair: 10^9
/// samples took minutes per pair, 2^20 keep one pair at a fraction of a
/// second.
pub const MAX_H_SAMPLES: u32 = 1 << 20;

/// Parameters of [`DEonHair`].
#[derive(Debug, Clone, PartialEq)]
pub struct DEonParams {
    pub base_color: [f64; 3],
    pub roughness: f64,
    pub shift: f64,
    pub eta: f64,
    pub h_samples: Option<u32>,
    pub h_offset: f64,
    pub components: Components,
}

impl Default for DEonParams {
    fn default() -> Self {
        Self {
            base_color: [0.3, 0.15, 0.08],
            roughness: 0.5,
            shift: 0.035,
            eta: 1.55,
            h_samples: None,
            h_offset: 0.5,
            components: Components {
                ms: false,
                ..Components::ALL
            },
        }
    }
}

impl DEonParams {
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
        if !(0.0..=1.0).contains(&self.roughness) {
            return Err(param_error(
                "roughness",
                format!("must be in [0, 1], got {}", self.roughness),
            ));
        }
        if !(-0.25..=0.25).contains(&self.shift) {
            return Err(param_error(
                "shift",
                format!("must be in [-0.25, 0.25], got {}", self.shift),
            ));
        }
        if !(self.eta > 1.0 && self.eta <= 3.0) {
            return Err(param_error(
                "eta",
                format!("must be in (1, 3], got {}", self.eta),
            ));
        }
        if let Some(n) = self.h_samples {
            if !(1..=MAX_H_SAMPLES).contains(&n) {
                return Err(param_error(
                    "h_samples",
                    format!("must be None or in [1, {MAX_H_SAMPLES}], got {n}"),
                ));
            }
        }
        if !(0.0..1.0).contains(&self.h_offset) {
            return Err(param_error(
                "h_offset",
                format!("must be in [0, 1), got {}", self.h_offset),
            ));
        }
        if self.components.ms {
            return Err(param_error(
                "components",
                "DEonHair has no MS term (R, TT, TRT only)",
            ));
        }
        Ok(())
    }

    pub fn build<T: Real>(&self) -> Result<DEonHair<T>, ParamError> {
        self.validate()?;
        let r = self.roughness.clamp(1.0 / 255.0, 1.0);
        let r2 = r * r;
        let alpha = [-2.0 * self.shift, self.shift, 4.0 * self.shift];
        Ok(DEonHair {
            color: self.base_color.map(T::from_f64),
            mu_a: self
                .base_color
                .map(|c| T::from_f64(-0.25 * c.max(1e-300).ln())),
            b: [r2, 0.5 * r2, 2.0 * r2].map(T::from_f64),
            alpha: alpha.map(T::from_f64),
            sin_alpha_r: T::from_f64(alpha[0].sin()),
            cos_alpha_r: T::from_f64(alpha[0].cos()),
            eta: T::from_f64(self.eta),
            h_samples: self.h_samples,
            h_offset: T::from_f64(self.h_offset),
            components: self.components,
        })
    }
}

/// UE4's `HairShadingRef()`: d'Eon M_p and the h-integrated N_p.
#[derive(Debug, Clone)]
pub struct DEonHair<T: Real> {
    color: [T; 3],
    mu_a: [T; 3],
    b: [T; 3],
    alpha: [T; 3],
    sin_alpha_r: T,
    cos_alpha_r: T,
    eta: T,
    h_samples: Option<u32>,
    h_offset: T,
    components: Components,
}

/// Per-pair quantities shared by the lobes.
#[derive(Clone, Copy)]
struct Geometry<T> {
    vol: T,
    sin_l: T,
    sin_v: T,
    cos_theta_t: T,
    cos_theta_d: T,
    cos_half_phi: T,
    phi: T,
    eta_p: T,
}

#[inline(always)]
fn dot<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl<T: Real> DEonHair<T> {
    fn geometry(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>) -> Geometry<T> {
        let vol = dot(v, l);
        let sin_l = dot(t, l).max(-T::ONE).min(T::ONE);
        let sin_v = dot(t, v).max(-T::ONE).min(T::ONE);
        let cos_theta_t = (T::ONE - (sin_l / self.eta) * (sin_l / self.eta)).sqrt();
        let cos_theta_d = (T::HALF * (sin_v.asin() - sin_l.asin()).abs()).cos();
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
        let norm = (dot(&lp, &lp) * dot(&vp, &vp)).sqrt();
        let cos_phi = if norm > T::ZERO {
            (dot(&lp, &vp) / norm).max(-T::ONE).min(T::ONE)
        } else {
            T::ZERO
        };
        Geometry {
            vol,
            sin_l,
            sin_v,
            cos_theta_t,
            cos_theta_d,
            cos_half_phi: (T::HALF + T::HALF * cos_phi).max(T::ZERO).sqrt(),
            phi: cos_phi.acos(),
            eta_p: eta_prime(self.eta, cos_theta_d),
        }
    }

    /// Ω_p(γ) for γ = asin h.
    #[inline(always)]
    fn omega(p: usize, gamma: T, eta_p: T) -> T {
        let pf = T::from_f64(p as f64);
        T::TWO * pf * safe_asin(gamma.sin() / eta_p) - T::TWO * gamma + pf * T::PI
    }

    /// A_p(h) for p ≥ 1.
    #[inline(always)]
    fn attenuation(&self, p: usize, h: T, g: &Geometry<T>) -> [T; 3] {
        let gamma_t = safe_asin(h / g.eta_p);
        let f = schlick_fresnel(
            self.eta,
            g.cos_theta_d * (T::ONE - h * h).max(T::ZERO).sqrt(),
        );
        let fp = if p == 1 {
            (T::ONE - f) * (T::ONE - f)
        } else {
            (T::ONE - f) * (T::ONE - f) * f
        };
        let len = T::TWO * gamma_t.cos() / g.cos_theta_t;
        self.mu_a.map(|mu| {
            let t = (-mu * len).exp();
            if p == 1 {
                fp * t
            } else {
                fp * t * t
            }
        })
    }

    /// N_p(φ) (RGB) for lobe p.
    fn n_p(&self, p: usize, g: &Geometry<T>) -> [T; 3] {
        let bp = self.b[p];
        if p == 0 {
            // A_R does not depend on h: N_R = A_R · ½ ∫ D dh.
            let a = schlick_fresnel(self.eta, (T::HALF + T::HALF * g.vol).max(T::ZERO).sqrt());
            let [d] = self.integrate_h(
                |gamma| {
                    [gaussian_detector(bp, g.phi - Self::omega(0, gamma, g.eta_p)) * gamma.cos()]
                },
                0,
                g,
            );
            return [a * d; 3];
        }
        self.integrate_h(
            |gamma| {
                let w = gaussian_detector(bp, g.phi - Self::omega(p, gamma, g.eta_p)) * gamma.cos();
                self.attenuation(p, gamma.sin(), g).map(|a| a * w)
            },
            p,
            g,
        )
    }

    /// Offsets h per lobe evaluation: None converged (adaptive quadrature).
    pub fn h_samples(&self) -> Option<u32> {
        self.h_samples
    }

    /// ½ ∫_{-π/2}^{π/2} f(γ) dγ (f includes the Jacobian cos γ), converged or stratified.
    fn integrate_h<const N: usize>(
        &self,
        mut f: impl FnMut(T) -> [T; N],
        p: usize,
        g: &Geometry<T>,
    ) -> [T; N] {
        match self.h_samples {
            Some(n) => {
                // UE: h_i = 2 (i + offset)/n − 1, N = ½ · (2/n) Σ A D. f already
                // carries cos γ; divide it out to sum A·D at the h_i.
                let nf = T::from_f64(n as f64);
                let mut s = [T::ZERO; N];
                for i in 0..n {
                    // a batch stopped by Ctrl-C (its result is discarded)
                    if i % 4096 == 4095 && crate::batch::stopped() {
                        break;
                    }
                    let h = T::TWO * (T::from_f64(i as f64) + self.h_offset) / nf - T::ONE;
                    let gamma = h.asin();
                    let c = gamma.cos();
                    if c > T::ZERO {
                        let v = f(gamma);
                        for k in 0..N {
                            s[k] += v[k] / c;
                        }
                    }
                }
                s.map(|x| x / nf)
            }
            None => {
                let breaks = self.breakpoints(p, g);
                let tol = if T::EPSILON.to_f64() < 1e-10 {
                    1e-8
                } else {
                    1e-5
                };
                integrate_adaptive(f, &breaks, T::from_f64(tol), T::ZERO, 4000)
                    .0
                    .map(|x| T::HALF * x)
            }
        }
    }

    /// γ-breakpoints: a uniform grid, the peaks of D (roots of
    /// φ − Ω_p(γ) − 2πk) and the TRT caustic (Ω_p' = 0).
    fn breakpoints(&self, p: usize, g: &Geometry<T>) -> Vec<T> {
        const CELLS: usize = 48;
        let lo = -T::FRAC_PI_2;
        let width = T::PI / T::from_f64(CELLS as f64);
        let grid: Vec<T> = (0..=CELLS)
            .map(|i| lo + width * T::from_f64(i as f64))
            .collect();
        let omega: Vec<T> = grid.iter().map(|&x| Self::omega(p, x, g.eta_p)).collect();
        let mut out = grid.clone();
        let resid = |gamma: T, k: i32| {
            g.phi - Self::omega(p, gamma, g.eta_p) - T::TWO_PI * T::from_f64(k as f64)
        };
        for c in 0..CELLS {
            for k in -4..=4 {
                let shift = g.phi - T::TWO_PI * T::from_f64(k as f64);
                let (fa, fb) = (shift - omega[c], shift - omega[c + 1]);
                if fa == T::ZERO {
                    out.push(grid[c]);
                    continue;
                }
                if fa * fb > T::ZERO {
                    continue;
                }
                let (mut a, mut b, mut fa) = (grid[c], grid[c + 1], fa);
                for _ in 0..60 {
                    let m = T::HALF * (a + b);
                    let fm = resid(m, k);
                    if fm * fa > T::ZERO {
                        a = m;
                        fa = fm;
                    } else {
                        b = m;
                    }
                    if !(b - a > T::EPSILON * T::from_f64(4.0)) {
                        break;
                    }
                }
                out.push(T::HALF * (a + b));
            }
        }
        if p == 2 {
            // Caustic: Ω' = 4 cos γ / (η' cos γt) − 2 = 0  ⇔  cos²γ = (η'² − 1)/3 (with sin γt = sin γ/η').
            let c2 = (g.eta_p * g.eta_p - T::ONE) / T::from_f64(3.0);
            if c2 > T::ZERO && c2 < T::ONE {
                let gc = c2.sqrt().acos();
                out.push(gc);
                out.push(-gc);
            }
        }
        out.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        out.dedup_by(|a, b| (*a - *b).abs() <= T::EPSILON);
        out
    }

    /// M_p for lobe p.
    fn m_p(&self, p: usize, g: &Geometry<T>) -> T {
        let cos_l = (T::ONE - g.sin_l * g.sin_l).max(T::ZERO).sqrt();
        let (sin_vp, bp) = if p == 0 {
            let (sa, ca) = (self.sin_alpha_r, self.cos_alpha_r);
            let cos_v = (T::ONE - g.sin_v * g.sin_v).max(T::ZERO).sqrt();
            (
                g.sin_v - T::TWO * sa * (g.cos_half_phi * ca * cos_v + sa * g.sin_v),
                self.b[0] * T::from_f64(std::f64::consts::SQRT_2) * g.cos_half_phi,
            )
        } else {
            ((g.sin_v.asin() - self.alpha[p]).sin(), self.b[p])
        };
        let sin_vp = sin_vp.max(-T::ONE).min(T::ONE);
        let cos_vp = (T::ONE - sin_vp * sin_vp).max(T::ZERO).sqrt();
        deon_mp(g.sin_l, cos_l, sin_vp, cos_vp, bp * bp)
    }

    /// Lobes (R, TT, TRT), RGB each; disabled lobes are 0.
    pub fn lobes(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>) -> [[T; 3]; 3] {
        let g = self.geometry(l, v, t);
        let enabled = [self.components.r, self.components.tt, self.components.trt];
        let mut out = [[T::ZERO; 3]; 3];
        for p in 0..3 {
            if enabled[p] {
                let m = self.m_p(p, &g);
                let n = self.n_p(p, &g);
                out[p] = n.map(|x| {
                    let s = m * x;
                    if s.is_finite() {
                        s.max(T::ZERO)
                    } else {
                        T::ZERO
                    }
                });
            }
        }
        out
    }

    /// Sum of the enabled lobes.
    pub fn eval(&self, l: &Vec3<T>, v: &Vec3<T>, t: &Vec3<T>) -> [T; 3] {
        let s = self.lobes(l, v, t);
        std::array::from_fn(|c| s[0][c] + s[1][c] + s[2][c])
    }

    /// The base color.
    pub fn base_color(&self) -> [T; 3] {
        self.color
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(v: [f64; 3]) -> [f64; 3] {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    }

    /// Converged N_p equals a brute-force 20 000-node midpoint rule in γ.
    #[test]
    fn t01_converged_matches_brute_force() {
        let m: DEonHair<f64> = DEonParams {
            roughness: 0.4,
            ..Default::default()
        }
        .build()
        .unwrap();
        let (l, v, t) = (
            unit([0.3, 0.5, 0.8]),
            unit([-0.4, 0.2, 0.9]),
            unit([0.1, 1.0, 0.05]),
        );
        let g = m.geometry(&l, &v, &t);
        for p in 0..3 {
            let n = m.n_p(p, &g);
            let k = 20_000;
            let mut brute = [0.0; 3];
            for i in 0..k {
                let gamma = -std::f64::consts::FRAC_PI_2
                    + std::f64::consts::PI * (i as f64 + 0.5) / k as f64;
                let h = gamma.sin();
                let a = if p == 0 {
                    [schlick_fresnel(1.55, (0.5 + 0.5 * g.vol).sqrt()); 3]
                } else {
                    m.attenuation(p, h, &g)
                };
                let d =
                    gaussian_detector(m.b[p], g.phi - DEonHair::<f64>::omega(p, gamma, g.eta_p));
                for c in 0..3 {
                    brute[c] += 0.5 * a[c] * d * gamma.cos() * std::f64::consts::PI / k as f64;
                }
            }
            for c in 0..3 {
                assert!(
                    ((n[c] - brute[c]) / brute[c]).abs() < 1e-7,
                    "p={p} {n:?} {brute:?}"
                );
            }
        }
    }
}
