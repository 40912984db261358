//! Dual scattering: multiple scattering in a volume of fibers from the
//! single-fiber far field (Zinke, Yuksel, Weber and Keyser, "Dual
//! Scattering Approximation for Fast Multiple Scattering in Hair",
//! SIGGRAPH 2008).
//!
//! Light reaching a fiber inside hair has crossed `n` other fibers on its
//! way from the light. The *global* part is what those fibers scattered
//! forward (it keeps travelling away from the light, spread longitudinally);
//! the *local* part is what the fibers around the shading point scatter
//! back towards it. Both are built from averages of the far field `f` of
//! one fiber, integrated here over the sphere, never taken from constants.
//!
//! Two far fields are baked ([`FarField`]): ChiangHair's tabulated far field
//! (`N̄_p` over cos θ of the view) and KarisHair's R, TT and TRT (its own
//! multiple-scattering term left out, since dual scattering replaces it;
//! `N^G_p` over cos θd, each lobe's non-Gaussian part taken at the mirror
//! pair θV = θd, θL = −θd, and the forward spread widens each lobe's
//! Gaussian, `B_p² + σ²`). KarisHair's tables are baked per material on
//! first use (65 incidences, about 0.1 s) and kept for later renders.
//!
//! ## Quantities (per RGB channel, per incidence `u_l = sin θl`)
//!
//! Directions are measured by `u = sin θ` (θ from the fiber's normal
//! plane) and the azimuth φ between the projections of the two directions
//! on that plane (0: the same side, π: through the fiber); the solid angle
//! is `dω = du dφ`, over which `f` integrates to the fiber's albedo. The
//! deviation of a scattered direction from the mirror direction is
//! `x = u_o + u_l`.
//!
//! ```text
//! a_f(u_l) = ∫_{|φ|>π/2} f dω      a_b(u_l) = ∫_{|φ|<π/2} f dω         (attenuation)
//! α_f, β_f²: mean and variance of x over the forward half, weighted by f
//! α_b, β_b²: the same over the backward half
//! A_1 = a_b a_f² / (1 − a_f²)      A_3 = a_b³ a_f² / (1 − a_f²)³         (Zinke eqs. 11, 12)
//! A_b = A_1 + A_3                                                        (eq. 13)
//! Δ_b = α_b (1 − 2a_b²/(1 − a_f²)²) + α_f (2(1 − a_f²)² + 4a_f² a_b²)/(1 − a_f²)³   (eq. 14)
//! σ_b = (1 + d_b a_f²) (a_b √(2β_f² + β_b²) + a_b³ √(2β_f² + 3β_b²)) / (a_b + a_b³)  (eq. 16)
//! ```
//!
//! Where `a_f + a_b > 1` both are scaled to sum to 1: KarisHair is not
//! energy-conserving (white hair with specular 1 and roughness 0.1
//! scatters up to 1.27 of the light it receives), and a fiber that
//! returns more than it receives makes light grow with every fiber
//! crossed. ChiangHair's sum is 1 to quadrature error (3e-6) at most.
//!
//! `A_1` sums the paths that cross the shading point's neighbourhood with
//! one backward scattering and any even number of forward ones
//! (`a_b Σ_{k≥1} a_f^{2k}`), `A_3` those with three backward scatterings
//! (`a_b³ a_f² Σ_k C(k+2, 2) a_f^{2k}`); `tests` check both against the
//! series. Eq. 16 is printed with the denominator `a_b + a_b³(2β_f + 3β_b)`,
//! which adds a width to a pure number; the weights of the two square roots
//! are `a_b` and `a_b³`, so their sum is the denominator used here (σ_b is
//! then a weighted mean of the two paths' widths, scaled by the paper's
//! `1 + d_b a_f²`).
//!
//! ## Shading (per light, see [`DualTable::shade`])
//!
//! ```text
//! L = E · [ P0 (f + d_b f_back) + S d_f (f_scatter + d_b f_back') ]
//! S = c (e^{−n (1 − a_f)} − e^{−n})          (Poisson count of fibers, mean n; c: unoccluded by opaque geometry)
//! σ_f² = n β_f²
//! f_back  = A_b G(x − Δ_b; σ_b²) · [|φ| < π/2] / π
//! f_back' = A_b G(x − Δ_b; σ_b² + σ_f²) · (1 − |φ|/π) / π
//! f_scatter = Σ_p M_p(v_p + σ_f²) N^G_p(φ),   N^G_p(φ) = (1/π) ∫_{φ−π/2}^{φ+π/2} N̄_p
//! ```
//!
//! `P0` is the fraction of the light that reaches the point unscattered
//! (the renderer's shadow term), `S` the light scattered forward on the
//! way (Zinke's `T_f` less its unscattered part `e^{−n}`: scattered light
//! arrives from around the straight path, so a point receives it whether
//! or not its own path is blocked; with a traced shadow, `P0` is 0 or 1
//! and `S` does not depend on it), `G` the normalized Gaussian, `d_f`, `d_b`
//! Zinke's density factors. Forward-scattered light arrives from azimuths
//! within π/2 of the light's, uniformly, so `N^G` is `N̄_p` averaged over
//! that window, and the window's overlap with the backward half is the
//! triangle `1 − |φ|/π`.
//!
//! ## Two-stream back scattering (`render.dual_backscatter = "two_stream"`)
//!
//! Zinke's `A_b` assumes hair without end behind the point and drops what
//! leaves the neighbourhood backwards, so white hair in a white furnace
//! loses most of its light. The alternative treats each light's line
//! through the point as a slab of `n` fibers in front and `m` behind
//! ([`two_stream`], Kubelka–Munk in fiber counts): the forward stream `I⁺`
//! replaces `e^{−n(1−a_f)}` (its scattered part `I⁺ − e^{−n}`), and the
//! backward stream `I⁻` replaces `A_b`, reaching the fiber from the far side
//! (`φ → π − |φ|`, the same θ: back scattering keeps a ray's component
//! along the fibers):
//!
//! ```text
//! L = E · [ P0 f + d_f c (I⁺ − e^{−n}) f_scatter(σ_f²) + c I⁻ f_scatter(π − |φ|; σ_f² + β_b²) ]
//! ```
//!
//! with the spreads taken at the view's incidence. Without absorption and
//! with `d_f = 1` the two streams of opposite lights sum to the light, so
//! a white slab in a white furnace keeps it (tests 05, 06).

use crate::fiber::lobes::gaussian;
use crate::math::{gauss_legendre, grid_cell};
use rayon::prelude::*;
use std::f64::consts::PI;

mod bake;
mod shade;
#[cfg(test)]
mod tests;

pub use shade::{two_stream, FarField};

/// The way from a point inside hair to a light, in fibers: what dual
/// scattering needs of it besides the unscattered fraction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightPath {
    /// Expected fibers crossed towards the light (the fiber's own share
    /// left out).
    pub n: f32,
    /// Fraction of the way free of opaque geometry.
    pub clear: f32,
    /// Fibers beyond the point, away from the light, where they were
    /// counted (two-stream back scattering); `None`: Zinke's local `A_b`.
    pub behind: Option<f32>,
}

impl LightPath {
    /// No hair and nothing opaque on the way.
    pub const OPEN: LightPath = LightPath {
        n: 0.0,
        clear: 1.0,
        behind: None,
    };
}

/// Nodes over `u_l = sin θl ∈ [−1, 1]`.
pub const INCIDENCE_NODES: usize = 65;
/// Gauss–Legendre nodes over `u_o` and midpoint nodes over φ ∈ [0, π] in
/// the integrals of a_f, a_b and their moments.
const U_NODES: usize = 96;
const PHI_NODES: usize = 192;
/// Nodes of the N^G table over cos θ ∈ [0, 1] and φ ∈ [0, π].
const NG_COS: usize = 33;
const NG_PHI: usize = 65;

/// The dual-scattering averages at one incidence (RGB each).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DualTerms {
    pub a_f: [f32; 3],
    pub a_b: [f32; 3],
    pub alpha_f: [f32; 3],
    pub beta_f2: [f32; 3],
    pub alpha_b: [f32; 3],
    pub beta_b2: [f32; 3],
    /// A_b, Δ_b, σ_b² (eqs. 13, 14, 16).
    pub big_a_b: [f32; 3],
    pub delta_b: [f32; 3],
    pub sigma_b2: [f32; 3],
}

/// Front and back integrals of a far field at one incidence: per half,
/// (∫ f, mean x, variance of x) per channel.
#[derive(Debug, Clone, Copy, Default)]
pub struct HalfMoments {
    pub energy: [f64; 3],
    pub mean: [f64; 3],
    pub variance: [f64; 3],
}

/// Integrates `f(u_l, u_o, φ)` (RGB) over the sphere of outgoing
/// directions for incidence `u_l`, split into the forward (|φ| > π/2) and
/// backward halves; `f` must be even in φ.
pub fn half_moments(
    u_l: f64,
    f: &(dyn Fn(f64, f64, f64) -> [f64; 3] + Sync),
) -> (HalfMoments, HalfMoments) {
    let (x, w) = gauss_legendre(U_NODES);
    let dphi = PI / PHI_NODES as f64;
    // sums of w, w·x, w·x² per half and channel
    let mut s = [[[0.0f64; 3]; 3]; 2];
    for (uo, wu) in x.iter().zip(&w) {
        let dev = uo + u_l;
        for j in 0..PHI_NODES {
            let phi = (j as f64 + 0.5) * dphi;
            let half = usize::from(phi < 0.5 * PI);
            let v = f(u_l, *uo, phi);
            for c in 0..3 {
                // 2: φ and −φ
                let m = 2.0 * wu * dphi * v[c];
                s[half][0][c] += m;
                s[half][1][c] += m * dev;
                s[half][2][c] += m * dev * dev;
            }
        }
    }
    let moments = |s: &[[f64; 3]; 3]| {
        let mut m = HalfMoments::default();
        for c in 0..3 {
            m.energy[c] = s[0][c];
            if s[0][c] > 0.0 {
                m.mean[c] = s[1][c] / s[0][c];
                m.variance[c] = (s[2][c] / s[0][c] - m.mean[c] * m.mean[c]).max(0.0);
            }
        }
        m
    };
    (moments(&s[0]), moments(&s[1]))
}

/// A_1, A_3 (eqs. 11, 12) from the average attenuations.
pub fn backscatter_sums(a_f: f64, a_b: f64) -> (f64, f64) {
    let q = 1.0 - a_f * a_f;
    if q <= 0.0 {
        // a_f = 1 leaves nothing for a_b (a_f + a_b ≤ 1)
        return (0.0, 0.0);
    }
    (a_b * a_f * a_f / q, a_b.powi(3) * a_f * a_f / (q * q * q))
}

/// Δ_b (eq. 14).
pub fn backscatter_shift(a_f: f64, a_b: f64, alpha_f: f64, alpha_b: f64) -> f64 {
    let q = 1.0 - a_f * a_f;
    if q <= 0.0 {
        return alpha_b;
    }
    alpha_b * (1.0 - 2.0 * a_b * a_b / (q * q))
        + alpha_f * (2.0 * q * q + 4.0 * a_f * a_f * a_b * a_b) / (q * q * q)
}

/// σ_b² (eq. 16, with the denominator `a_b + a_b³`; see the module docs).
pub fn backscatter_variance(a_f: f64, a_b: f64, beta_f2: f64, beta_b2: f64, d_b: f64) -> f64 {
    let (w1, w3) = (a_b, a_b.powi(3));
    if w1 + w3 <= 0.0 {
        return beta_b2;
    }
    let s1 = (2.0 * beta_f2 + beta_b2).sqrt();
    let s3 = (2.0 * beta_f2 + 3.0 * beta_b2).sqrt();
    let sigma = (1.0 + d_b * a_f * a_f) * (w1 * s1 + w3 * s3) / (w1 + w3);
    sigma * sigma
}

/// Normalized Gaussian of variance `v` at `x`.
#[inline]
fn gauss(x: f32, v: f32) -> f32 {
    gaussian(v.max(1e-6).sqrt(), x)
}

/// Dual-scattering tables of one material.
#[derive(Debug, Clone)]
pub struct DualTable {
    /// Terms at `u_l = −1 + 2k/(INCIDENCE_NODES − 1)`.
    terms: Vec<DualTerms>,
    /// N^G_p (p < 3, RGB) at (cos θ node, φ node): `ng[c · NG_PHI + j]`.
    ng: Vec<[f32; 9]>,
    /// d_b used in σ_b² (eq. 16).
    d_b: f32,
}

impl DualTable {
    /// The terms at every incidence node of far field `f(u_l, u_o, φ)`.
    pub fn terms_of(f: &(dyn Fn(f64, f64, f64) -> [f64; 3] + Sync), d_b: f64) -> Vec<DualTerms> {
        crate::threads::pool().install(|| {
            (0..INCIDENCE_NODES)
                .into_par_iter()
                .map(|k| {
                    let u_l = -1.0 + 2.0 * k as f64 / (INCIDENCE_NODES - 1) as f64;
                    let (front, back) = half_moments(u_l, f);
                    let mut t = DualTerms::default();
                    for c in 0..3 {
                        // a far field that scatters more than it receives
                        // (KarisHair can: see the module docs) would make
                        // light grow with every fiber crossed
                        let sum = front.energy[c] + back.energy[c];
                        let cap = if sum > 1.0 { 1.0 / sum } else { 1.0 };
                        let (a_f, a_b) = (cap * front.energy[c], cap * back.energy[c]);
                        let (a1, a3) = backscatter_sums(a_f, a_b);
                        t.a_f[c] = a_f as f32;
                        t.a_b[c] = a_b as f32;
                        t.alpha_f[c] = front.mean[c] as f32;
                        t.beta_f2[c] = front.variance[c] as f32;
                        t.alpha_b[c] = back.mean[c] as f32;
                        t.beta_b2[c] = back.variance[c] as f32;
                        t.big_a_b[c] = (a1 + a3) as f32;
                        t.delta_b[c] =
                            backscatter_shift(a_f, a_b, front.mean[c], back.mean[c]) as f32;
                        t.sigma_b2[c] = backscatter_variance(
                            a_f,
                            a_b,
                            front.variance[c],
                            back.variance[c],
                            d_b,
                        ) as f32;
                    }
                    t
                })
                .collect()
        })
    }

    /// The terms at every incidence node.
    pub fn nodes(&self) -> &[DualTerms] {
        &self.terms
    }

    /// The terms at incidence `u_l` (linear between nodes).
    pub fn terms(&self, u_l: f32) -> DualTerms {
        let (k, w) = grid_cell(0.5 * (u_l + 1.0), INCIDENCE_NODES);
        let (a, b) = (&self.terms[k], &self.terms[k + 1]);
        let lerp = |x: &[f32; 3], y: &[f32; 3]| std::array::from_fn(|c| x[c] + w * (y[c] - x[c]));
        DualTerms {
            a_f: lerp(&a.a_f, &b.a_f),
            a_b: lerp(&a.a_b, &b.a_b),
            alpha_f: lerp(&a.alpha_f, &b.alpha_f),
            beta_f2: lerp(&a.beta_f2, &b.beta_f2),
            alpha_b: lerp(&a.alpha_b, &b.alpha_b),
            beta_b2: lerp(&a.beta_b2, &b.beta_b2),
            big_a_b: lerp(&a.big_a_b, &b.big_a_b),
            delta_b: lerp(&a.delta_b, &b.delta_b),
            sigma_b2: lerp(&a.sigma_b2, &b.sigma_b2),
        }
    }

    /// N^G_p (p < 3, RGB) at cos θ ∈ [0, 1] and |φ| ∈ [0, π] (bilinear).
    pub fn ng(&self, cos_theta: f32, phi: f32) -> [[f32; 3]; 3] {
        let (kc, fc) = grid_cell(cos_theta, NG_COS);
        let (kp, fp) = grid_cell(phi.abs() * std::f32::consts::FRAC_1_PI, NG_PHI);
        let at = |c: usize, j: usize| &self.ng[c * NG_PHI + j];
        let (n00, n01, n10, n11) = (
            at(kc, kp),
            at(kc, kp + 1),
            at(kc + 1, kp),
            at(kc + 1, kp + 1),
        );
        std::array::from_fn(|p| {
            std::array::from_fn(|ch| {
                let i = 3 * p + ch;
                (1.0 - fc) * ((1.0 - fp) * n00[i] + fp * n01[i])
                    + fc * ((1.0 - fp) * n10[i] + fp * n11[i])
            })
        })
    }
}
