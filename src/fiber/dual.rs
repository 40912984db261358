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
//! ## Shading (per light, see [`DualTable::shade_chiang`])
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

use super::chiang::ChiangFarTable;
use crate::fiber::lobes::gaussian;
use crate::math::{gauss_legendre, grid_cell};
use rayon::prelude::*;
use std::f64::consts::PI;

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
    /// The tables of a ChiangHair far field (integrated from its table).
    pub fn for_chiang(table: &ChiangFarTable, d_b: f32) -> Self {
        let f = |u_l: f64, u_o: f64, phi: f64| {
            let cos = |u: f64| (1.0 - u * u).max(0.0).sqrt();
            let l = table.lobes_from_angles(
                (u_l as f32, cos(u_l) as f32),
                (u_o as f32, cos(u_o) as f32),
                phi as f32,
            );
            std::array::from_fn(|c| (l[0][c] + l[1][c] + l[2][c] + l[3][c]) as f64)
        };
        let terms = Self::terms_of(&f, d_b as f64);
        // N^G: N̄_p averaged over a window of width π around φ.
        let k_win = 128;
        let ng = crate::threads::pool().install(|| {
            (0..NG_COS * NG_PHI)
                .into_par_iter()
                .map(|i| {
                    let (c, j) = (i / NG_PHI, i % NG_PHI);
                    let cos = c as f32 / (NG_COS - 1) as f32;
                    let phi = std::f32::consts::PI * j as f32 / (NG_PHI - 1) as f32;
                    let mut acc = [0.0f32; 9];
                    for k in 0..k_win {
                        let d = std::f32::consts::PI * ((k as f32 + 0.5) / k_win as f32 - 0.5);
                        let at = crate::math::wrap_pi(phi + d).abs();
                        let (n, _) = table.azimuthal(cos, at);
                        for p in 0..3 {
                            for ch in 0..3 {
                                acc[3 * p + ch] += n[p][ch] / k_win as f32;
                            }
                        }
                    }
                    acc
                })
                .collect()
        });
        Self { terms, ng, d_b }
    }

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
                        let (a_f, a_b) = (front.energy[c], back.energy[c]);
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

    /// The effective far field of a ChiangHair fiber inside hair (RGB; the
    /// radiance towards the viewer is `E ·` this): `view` and `light` are
    /// (sin θ, cos θ) of the two directions, `phi` ∈ [0, π] the azimuth
    /// between them, `p0` the unscattered fraction of the light, `n` the
    /// fibers crossed towards the light, `clear` the fraction of that path
    /// free of opaque geometry; `d_f` the forward density factor (`d_b` is
    /// the table's). With `behind`, the fibers beyond the point away from
    /// the light, the back scattering is the two-stream slab's instead of
    /// Zinke's local `A_b` (see [`two_stream`]).
    #[allow(clippy::too_many_arguments)]
    pub fn shade_chiang(
        &self,
        table: &ChiangFarTable,
        view: (f32, f32),
        light: (f32, f32),
        phi: f32,
        p0: f32,
        n: f32,
        clear: f32,
        d_f: f32,
        behind: Option<f32>,
    ) -> [f32; 3] {
        use std::f32::consts::{FRAC_1_PI, FRAC_PI_2};
        let lobes = table.lobes_from_angles(view, light, phi);
        let t = self.terms(light.0);
        if let Some(m) = behind {
            return self
                .shade_two_stream(table, &t, &lobes, view, light, phi, p0, n, m, clear, d_f);
        }
        let x = view.0 + light.0;
        let back_side = if phi.abs() < FRAC_PI_2 { 1.0 } else { 0.0 };
        let mut out = [0.0f32; 3];
        let n = n.max(0.0);
        let beta_f2 = (t.beta_f2[0] + t.beta_f2[1] + t.beta_f2[2]) / 3.0;
        // forward spread after n fibers (bounded: beyond ~4 the lobes are flat)
        let sigma_f2 = (n * beta_f2).min(4.0);
        let scattered: [f32; 3] =
            std::array::from_fn(|c| clear * ((-n * (1.0 - t.a_f[c])).exp() - (-n).exp()).max(0.0));
        let f_scatter = if scattered.iter().any(|&s| s > 0.0) {
            self.scatter_response(table, view, light, sigma_f2, phi)
        } else {
            [0.0; 3]
        };
        let d_b = self.d_b;
        for c in 0..3 {
            let single = lobes[0][c] + lobes[1][c] + lobes[2][c] + lobes[3][c];
            let dev = x - t.delta_b[c];
            let back = t.big_a_b[c] * gauss(dev, t.sigma_b2[c]) * back_side * FRAC_1_PI;
            let mut v = p0 * (single + d_b * back);
            if scattered[c] > 0.0 {
                let back_s = t.big_a_b[c]
                    * gauss(dev, t.sigma_b2[c] + sigma_f2)
                    * (1.0 - phi.abs() * FRAC_1_PI)
                    * FRAC_1_PI;
                v += scattered[c] * d_f * (f_scatter[c] + d_b * back_s);
            }
            out[c] = if v.is_finite() { v.max(0.0) } else { 0.0 };
        }
        out
    }
}

impl DualTable {
    /// The response to forward-scattered light arriving at azimuth `phi`
    /// with the longitudinal spread `sigma2`: `Σ_p M_p(v_p + σ²) N^G_p(φ)`
    /// (Ā_3 is constant in φ: its window average is itself).
    fn scatter_response(
        &self,
        table: &ChiangFarTable,
        view: (f32, f32),
        light: (f32, f32),
        sigma2: f32,
        phi: f32,
    ) -> [f32; 3] {
        let m_g = table.model().longitudinal_widened(view, light, sigma2);
        let ng = self.ng(view.1, phi);
        let a3 = table.azimuthal(view.1, phi).1;
        std::array::from_fn(|c| {
            m_g[0] * ng[0][c] + m_g[1] * ng[1][c] + m_g[2] * ng[2][c] + m_g[3] * a3[c]
        })
    }

    /// [`Self::shade_chiang`] with the two-stream back scattering: the
    /// forward stream `I⁺` (its scattered part `I⁺ − e^{−n}`, spread by
    /// `σ_f²` as Zinke's) and the backward stream `I⁻`, which reaches the
    /// fiber from the far side (azimuth `π − |φ|`) after one backward
    /// scattering and the forward ones around it (spread `β_b² + σ_f²`).
    #[allow(clippy::too_many_arguments)]
    fn shade_two_stream(
        &self,
        table: &ChiangFarTable,
        t: &DualTerms,
        lobes: &[[f32; 3]; 4],
        view: (f32, f32),
        light: (f32, f32),
        phi: f32,
        p0: f32,
        n: f32,
        m: f32,
        clear: f32,
        d_f: f32,
    ) -> [f32; 3] {
        let (n, m) = (n.max(0.0), m.max(0.0));
        let mean = |x: &[f32; 3]| (x[0] + x[1] + x[2]) / 3.0;
        // The spreads are taken at the view's incidence, not the light's:
        // for one view they are then the same for every light direction and
        // the widened lobes keep their integral over the lights (widths
        // that follow the light's θ lose 6% of a white furnace at n = 5).
        let tv = self.terms(view.0);
        let sigma_f2 = (n * mean(&tv.beta_f2)).min(4.0);
        let sigma_b2 = (sigma_f2 + mean(&tv.beta_b2)).min(4.0);
        let mut fwd = [0.0f32; 3];
        let mut bwd = [0.0f32; 3];
        for c in 0..3 {
            let (i_plus, i_minus) = two_stream(t.a_f[c], t.a_b[c], n, m);
            fwd[c] = clear * (i_plus - (-n).exp()).max(0.0);
            bwd[c] = clear * i_minus;
        }
        let f_fwd = if fwd.iter().any(|&s| s > 0.0) {
            self.scatter_response(table, view, light, sigma_f2, phi.abs())
        } else {
            [0.0; 3]
        };
        let f_bwd = if bwd.iter().any(|&s| s > 0.0) {
            self.scatter_response(
                table,
                view,
                light,
                sigma_b2,
                std::f32::consts::PI - phi.abs(),
            )
        } else {
            [0.0; 3]
        };
        std::array::from_fn(|c| {
            let single = lobes[0][c] + lobes[1][c] + lobes[2][c] + lobes[3][c];
            let v = p0 * single + d_f * fwd[c] * f_fwd[c] + bwd[c] * f_bwd[c];
            if v.is_finite() {
                v.max(0.0)
            } else {
                0.0
            }
        })
    }
}

/// The two streams of light in a slab of fibers lit on one face, at a point
/// `n` fibers deep with `m` more behind it (Kubelka–Munk in fiber-count
/// units): per fiber crossed a stream keeps `a_f` going its way, turns `a_b`
/// back and loses the rest, so with `κ = 1 − a_f`, `k = √(κ² − a_b²)`
///
/// ```text
/// dI⁺/dn = −κ I⁺ + a_b I⁻      dI⁻/dn = κ I⁻ − a_b I⁺      I⁺(0) = 1, I⁻(n + m) = 0
/// I⁺ = e^{−kn} (1 + (κ − k) g(m)) / D     I⁻ = a_b e^{−kn} g(m) / D
/// D = 1 + (κ − k) g(n + m),   g(x) = (1 − e^{−2kx}) / 2k   (x when k = 0)
/// ```
///
/// Returns `(I⁺, I⁻)`, fractions of the light entering the slab. Without
/// absorption (`a_f + a_b = 1`) the streams of two opposite lights at a
/// point sum to one (`I⁺(n, m) + I⁻(m, n) = 1`): a white slab in a white
/// furnace keeps its light.
pub fn two_stream(a_f: f32, a_b: f32, n: f32, m: f32) -> (f32, f32) {
    let kappa = (1.0 - a_f).clamp(0.0, 1.0);
    let s = a_b.clamp(0.0, kappa);
    let k = ((kappa - s) * (kappa + s)).max(0.0).sqrt();
    let g = |x: f32| {
        let kx = k * x;
        if kx < 1e-3 {
            x * (1.0 - kx * (1.0 - 2.0 / 3.0 * kx))
        } else {
            -(-2.0 * kx).exp_m1() / (2.0 * k)
        }
    };
    let c = kappa - k;
    let den = 1.0 + c * g(n + m);
    let e = (-k * n).exp();
    (e * (1.0 + c * g(m)) / den, s * e * g(m) / den)
}

#[cfg(test)]
mod tests {
    use super::*;

    // 01: A_1 and A_3 equal the path sums they stand for (series to 1e-12).
    #[test]
    fn t01_backscatter_sums_are_the_series() {
        for &(a_f, a_b) in &[(0.3, 0.2), (0.7, 0.25), (0.9, 0.08), (0.05, 0.9)] {
            let x: f64 = a_f * a_f;
            let a1: f64 = (1..4000).map(|k| a_b * x.powi(k)).sum();
            let a3: f64 = (0..4000i32)
                .map(|k| a_b.powi(3) * x * ((k + 1) * (k + 2) / 2) as f64 * x.powi(k))
                .sum();
            let (s1, s3) = backscatter_sums(a_f, a_b);
            assert!(
                (s1 - a1).abs() < 1e-12 * a1.max(1.0),
                "{a_f} {a_b}: {s1} vs {a1}"
            );
            assert!(
                (s3 - a3).abs() < 1e-10 * a3.max(1.0),
                "{a_f} {a_b}: {s3} vs {a3}"
            );
        }
    }

    // 02: σ_b is the weighted mean of the two paths' widths times
    // (1 + d_b a_f²); equal widths give that width back.
    #[test]
    fn t02_backscatter_variance() {
        let (bf2, bb2): (f64, f64) = (0.04, 0.09);
        let s1 = (2.0 * bf2 + bb2).sqrt();
        let s3 = (2.0f64 * bf2 + 3.0 * bb2).sqrt();
        let (a_f, a_b, d_b) = (0.6, 0.3, 0.7);
        let want = ((1.0 + d_b * a_f * a_f) * (a_b * s1 + a_b * a_b * a_b * s3)
            / (a_b + a_b.powi(3)))
        .powi(2);
        assert!((backscatter_variance(a_f, a_b, bf2, bb2, d_b) - want).abs() < 1e-15);
        // β_f = 0: both paths' widths are multiples of β_b
        let v = backscatter_variance(0.0, 0.5, 0.0, 0.01, 0.7);
        let want = ((0.5 * 0.1 + 0.125 * 3f64.sqrt() * 0.1) / 0.625).powi(2);
        assert!((v - want).abs() < 1e-15);
    }

    // 03: Δ_b with no forward shift and a_f = 0 is α_b (1 − 2 a_b²), the
    // forward shift counts twice (two forward passes per path) there; with
    // equal shifts the two weights add up as the formula says.
    #[test]
    fn t03_backscatter_shift() {
        assert!(
            (backscatter_shift(0.0, 0.4, 0.0, -0.1) - (-0.1 * (1.0 - 2.0 * 0.16))).abs() < 1e-15
        );
        assert!((backscatter_shift(0.0, 0.4, 0.3, 0.0) - 0.6).abs() < 1e-15);
        let (a_f, a_b): (f64, f64) = (0.5, 0.3);
        let q = 1.0 - a_f * a_f;
        let w = (1.0 - 2.0 * a_b * a_b / (q * q))
            + (2.0 * q * q + 4.0 * a_f * a_f * a_b * a_b) / q.powi(3);
        assert!((backscatter_shift(a_f, a_b, 0.2, 0.2) - 0.2 * w).abs() < 1e-15);
    }

    // 04: the moments of a known field: f = 1/(4π) (isotropic, albedo 1)
    // splits in halves of 1/2 each, x = u_o + u_l has mean u_l and
    // variance 1/3 on each half.
    #[test]
    fn t04_half_moments_isotropic() {
        let f = |_: f64, _: f64, _: f64| [1.0 / (4.0 * PI); 3];
        for &u in &[-0.8, 0.0, 0.35] {
            let (fr, bk) = half_moments(u, &f);
            for m in [fr, bk] {
                assert!((m.energy[0] - 0.5).abs() < 1e-12);
                assert!((m.mean[1] - u).abs() < 1e-12);
                assert!((m.variance[2] - 1.0 / 3.0).abs() < 1e-12);
            }
        }
    }

    // 05: the two-stream slab: its closed form solves the two equations
    // (central differences, relative 1e-3 of the stream, f64 steps in f32),
    // keeps the boundary values, and without absorption the streams of
    // opposite lights sum to 1 (f32 rounding: 1e-5).
    #[test]
    fn t05_two_stream() {
        for &(a_f, a_b) in &[(0.8f32, 0.2f32), (0.6, 0.1), (0.31, 0.69), (0.95, 0.01)] {
            for &(n, m) in &[(0.0f32, 5.0f32), (3.0, 4.0), (20.0, 0.0), (0.5, 60.0)] {
                let (p, q) = two_stream(a_f, a_b, n, m);
                let kappa = 1.0 - a_f;
                if n > 0.0 && m > 0.0 {
                    let h = 1e-2;
                    let (p1, q1) = two_stream(a_f, a_b, n + h, m - h);
                    let (p0, q0) = two_stream(a_f, a_b, n - h, m + h);
                    let (dp, dq) = ((p1 - p0) / (2.0 * h), (q1 - q0) / (2.0 * h));
                    let tol = 1e-3 * p.max(1e-3);
                    assert!(
                        (dp - (-kappa * p + a_b * q)).abs() < tol,
                        "{a_f} {a_b} {n} {m}: dI+"
                    );
                    assert!(
                        (dq - (kappa * q - a_b * p)).abs() < tol,
                        "{a_f} {a_b} {n} {m}: dI-"
                    );
                }
                if n == 0.0 {
                    assert!((p - 1.0).abs() < 1e-6);
                }
                if m == 0.0 {
                    assert_eq!(q, 0.0);
                }
                if a_f + a_b == 1.0 {
                    let (p2, q2) = two_stream(a_f, a_b, m, n);
                    assert!(
                        (p + q2 - 1.0).abs() < 1e-5,
                        "{a_f} {a_b} {n} {m}: {p} + {q2}"
                    );
                    assert!((p2 + q - 1.0).abs() < 1e-5);
                }
            }
        }
    }

    // 06: a white fiber (σa = 0) inside white hair whose streams come with
    // the same (n, m) from every direction scatters all of a constant
    // environment: the integral over light directions of shade_chiang with
    // the two-stream back scattering is 1.
    #[test]
    fn t06_two_stream_white_furnace() {
        use crate::fiber::chiang::TableSize;
        use crate::fiber::{ChiangHair, ChiangParams};
        let m: ChiangHair<f64> = ChiangParams {
            sigma_a: Some([0.0; 3]),
            ..Default::default()
        }
        .build()
        .unwrap();
        let table = ChiangFarTable::new(&m, TableSize::for_scale(m.logistic_scale()));
        let dual = table.dual(1.0);
        let (un, uw) = gauss_legendre(96);
        let k_phi = 512;
        for &(n, mm) in &[(0.0f32, 0.0f32), (5.0, 5.0), (20.0, 20.0), (2.0, 30.0)] {
            for &theta_v in &[0.0f32, 0.5, -1.1] {
                let view = (theta_v.sin(), theta_v.cos());
                let mut sum = 0.0f64;
                for (u, wu) in un.iter().zip(&uw) {
                    let light = (*u as f32, (1.0 - u * u).max(0.0).sqrt() as f32);
                    for j in 0..k_phi {
                        let phi = PI as f32 * (j as f32 + 0.5) / k_phi as f32;
                        let p0 = (-n).exp();
                        // the light from the mirror direction arrives
                        // with the counts swapped (its I⁻ is this one's pair)
                        let a =
                            dual.shade_chiang(&table, view, light, phi, p0, n, 1.0, 1.0, Some(mm));
                        let b = dual.shade_chiang(
                            &table,
                            view,
                            light,
                            phi,
                            (-mm).exp(),
                            mm,
                            1.0,
                            1.0,
                            Some(n),
                        );
                        sum += 0.5 * (a[1] + b[1]) as f64 * wu * 2.0 * PI / k_phi as f64;
                    }
                }
                eprintln!("n {n} m {mm} θv {theta_v}: {sum}");
                assert!((sum - 1.0).abs() < 0.02, "n {n} m {mm} θ {theta_v}: {sum}");
            }
        }
    }
}
