//! Shading with the dual-scattering tables: the effective far field of a
//! fiber inside hair (see the module docs of [`super`]).

use super::bake::{canonical, karis_parts};
use super::{gauss, DualTable, DualTerms, LightPath};
use crate::fiber::chiang::ChiangFarTable;
use crate::fiber::frame::FiberAngles;
use crate::fiber::karis::KarisHair;
use crate::fiber::lobes::gaussian;

/// The far field a [`DualTable`] was baked from, which shades with it.
#[derive(Debug, Clone, Copy)]
pub enum FarField<'a> {
    Chiang(&'a ChiangFarTable),
    /// R, TT and TRT (the model's own multiple-scattering term is not used).
    Karis(&'a KarisHair<f32>),
}

impl FarField<'_> {
    /// The single scattering of the pair (RGB).
    pub fn single(&self, view: (f32, f32), light: (f32, f32), phi: f32) -> [f32; 3] {
        match self {
            FarField::Chiang(table) => {
                let l = table.lobes_from_angles(view, light, phi);
                std::array::from_fn(|c| l[0][c] + l[1][c] + l[2][c] + l[3][c])
            }
            FarField::Karis(model) => karis_parts(model, view, light, phi).total(0.0),
        }
    }

    /// The response to forward-scattered light arriving at azimuth `phi`
    /// with the longitudinal spread `sigma2`: `Σ_p M_p(v_p + σ²) N^G_p(φ)`
    /// (ChiangHair: Ā_3 is constant in φ, its window average is itself;
    /// KarisHair: each lobe's Gaussian widened, `B_p² + σ²`).
    pub fn scatter_response(
        &self,
        dual: &DualTable,
        view: (f32, f32),
        light: (f32, f32),
        sigma2: f32,
        phi: f32,
    ) -> [f32; 3] {
        match self {
            FarField::Chiang(table) => {
                let m_g = table.model().longitudinal_widened(view, light, sigma2);
                let ng = dual.ng(view.1, phi);
                let a3 = table.azimuthal(view.1, phi).1;
                std::array::from_fn(|c| {
                    m_g[0] * ng[0][c] + m_g[1] * ng[1][c] + m_g[2] * ng[2][c] + m_g[3] * a3[c]
                })
            }
            FarField::Karis(model) => {
                let [l, v, t] = canonical(view, light, phi);
                let p = model.spreads(&l, &v, &t);
                let ng = dual.ng(p.cos_theta_d, phi);
                let m = std::array::from_fn::<f32, 3, _>(|i| {
                    gaussian((p.width[i] * p.width[i] + sigma2).sqrt(), p.x - p.shift[i])
                });
                std::array::from_fn(|c| m[0] * ng[0][c] + m[1] * ng[1][c] + m[2] * ng[2][c])
            }
        }
    }

    /// `∫ f(v, ω) dω` over the directions ω whose azimuth lies within π/2 of
    /// `phi` (every θ): with `∫ M_p du = 1` it is
    /// `π Σ_{p<3} N^G_p(φ) (+ Ā_3 / 2)`, the residual p ≥ 3 of ChiangHair
    /// spread evenly over the 2π of azimuth.
    pub fn half_space(&self, dual: &DualTable, view: (f32, f32), phi: f32) -> [f32; 3] {
        let (cos, a3) = match self {
            FarField::Chiang(table) => (view.1, table.azimuthal(view.1, phi).1),
            // θd of the view and a direction in the normal plane
            FarField::Karis(_) => ((0.5 * view.0.clamp(-1.0, 1.0).asin()).cos(), [0.0; 3]),
        };
        let ng = dual.ng(cos, phi);
        std::array::from_fn(|c| {
            (ng[0][c] + ng[1][c] + ng[2][c]) * std::f32::consts::PI + 0.5 * a3[c]
        })
    }
}

impl DualTable {
    /// The effective far field of a fiber inside hair (RGB; the
    /// radiance towards the viewer is `E ·` this) for the pair of
    /// directions `g`: `p0` the unscattered fraction of the light, `path`
    /// the fibers crossed towards it and the part of the way free of
    /// opaque geometry; `d_f` the forward density factor (`d_b` is the
    /// table's). With `path.behind`, the fibers beyond the point away from
    /// the light, the back scattering is the two-stream slab's instead of
    /// Zinke's local `A_b` (see [`two_stream`]).
    pub fn shade(
        &self,
        far: FarField,
        g: &FiberAngles,
        p0: f32,
        path: LightPath,
        d_f: f32,
    ) -> [f32; 3] {
        let (direct, scattered) = self.shade_parts(far, g, p0, path, d_f, true);
        std::array::from_fn(|c| direct[c] + scattered[c])
    }

    /// [`Self::shade`] in its two parts: the light that arrives unscattered
    /// (`p0`, times the single scattering and, under local back
    /// scattering, Zinke's back term) and the light the fibers on the way
    /// scattered forward or back (independent of `p0`, and of the point's
    /// own shadow; with `scattered` false it is not computed). Each part
    /// is non-negative and finite (a non-finite channel reads 0).
    pub fn shade_parts(
        &self,
        far: FarField,
        g: &FiberAngles,
        p0: f32,
        path: LightPath,
        d_f: f32,
        scattered: bool,
    ) -> ([f32; 3], [f32; 3]) {
        use std::f32::consts::FRAC_1_PI;
        let (view, light, phi) = (g.view, g.light, g.phi);
        let (n, clear) = (path.n, path.clear);
        let t = self.terms(light.0);
        if path.behind.is_some() {
            return self.two_stream_parts(far, &t, g, p0, path, d_f, scattered);
        }
        let x = view.0 + light.0;
        let d_b = self.d_b;
        let direct = if p0 > 0.0 {
            let single = far.single(view, light, phi);
            let back = self.local_back(&t, g);
            std::array::from_fn(|c| finite(p0 * (single[c] + back[c])))
        } else {
            [0.0; 3]
        };
        if !scattered {
            return (direct, [0.0; 3]);
        }
        let n = n.max(0.0);
        let beta_f2 = (t.beta_f2[0] + t.beta_f2[1] + t.beta_f2[2]) / 3.0;
        // forward spread after n fibers (bounded: beyond ~4 the lobes are flat)
        let sigma_f2 = (n * beta_f2).min(4.0);
        let weight: [f32; 3] =
            std::array::from_fn(|c| clear * ((-n * (1.0 - t.a_f[c])).exp() - (-n).exp()).max(0.0));
        let f_scatter = where_any(&weight, || {
            far.scatter_response(self, view, light, sigma_f2, phi)
        });
        let scattered = std::array::from_fn(|c| {
            if weight[c] > 0.0 {
                let back_s = t.big_a_b[c]
                    * gauss(x - t.delta_b[c], t.sigma_b2[c] + sigma_f2)
                    * (1.0 - phi.abs() * FRAC_1_PI)
                    * FRAC_1_PI;
                finite(weight[c] * d_f * (f_scatter[c] + d_b * back_s))
            } else {
                0.0
            }
        });
        (direct, scattered)
    }

    /// The direct part's back scattering per unit of unscattered light
    /// (local back scattering, Zinke's `d_b A_b(θ) G(θh − Δ_b, σ_b²) / π` on
    /// the light's side of the fiber), `t` the terms at the light's
    /// incidence (`self.terms(g.light.0)`). What the direct part adds to the
    /// single scattering when the way to the light has no `behind`.
    #[inline]
    pub fn local_back(&self, t: &DualTerms, g: &FiberAngles) -> [f32; 3] {
        use std::f32::consts::{FRAC_1_PI, FRAC_PI_2};
        let x = g.view.0 + g.light.0;
        let back_side = if g.phi.abs() < FRAC_PI_2 { 1.0 } else { 0.0 };
        std::array::from_fn(|c| {
            let back =
                t.big_a_b[c] * gauss(x - t.delta_b[c], t.sigma_b2[c]) * back_side * FRAC_1_PI;
            self.d_b * back
        })
    }

    /// [`Self::shade_parts`] with the two-stream back scattering: the
    /// forward stream `I⁺` (its scattered part `I⁺ − e^{−n}`, spread by
    /// `σ_f²` as Zinke's) and the backward stream `I⁻`, which reaches the
    /// fiber from the far side (azimuth `π − |φ|`) after one backward
    /// scattering and the forward ones around it (spread `β_b² + σ_f²`).
    #[allow(clippy::too_many_arguments)]
    fn two_stream_parts(
        &self,
        far: FarField,
        t: &DualTerms,
        g: &FiberAngles,
        p0: f32,
        path: LightPath,
        d_f: f32,
        scattered: bool,
    ) -> ([f32; 3], [f32; 3]) {
        let (view, light, phi) = (g.view, g.light, g.phi);
        let direct = if p0 > 0.0 {
            let single = far.single(view, light, phi);
            single.map(|s| finite(p0 * s))
        } else {
            [0.0; 3]
        };
        if !scattered {
            return (direct, [0.0; 3]);
        }
        let clear = path.clear;
        let (n, m) = (path.n.max(0.0), path.behind.unwrap_or(0.0).max(0.0));
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
        let f_fwd = where_any(&fwd, || {
            far.scatter_response(self, view, light, sigma_f2, phi.abs())
        });
        let f_bwd = where_any(&bwd, || {
            far.scatter_response(
                self,
                view,
                light,
                sigma_b2,
                std::f32::consts::PI - phi.abs(),
            )
        });
        let scattered =
            std::array::from_fn(|c| finite(d_f * fwd[c] * f_fwd[c] + bwd[c] * f_bwd[c]));
        (direct, scattered)
    }
}

/// `v` where finite and positive, else 0.
#[inline]
fn finite(v: f32) -> f32 {
    if v.is_finite() {
        v.max(0.0)
    } else {
        0.0
    }
}

/// `response()` where some channel of `weights` is positive (it is then
/// read), else 0 (not evaluated: the scatter response is the costly part).
#[inline]
fn where_any(weights: &[f32; 3], response: impl FnOnce() -> [f32; 3]) -> [f32; 3] {
    if weights.iter().any(|&w| w > 0.0) {
        response()
    } else {
        [0.0; 3]
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
