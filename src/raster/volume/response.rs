//! A fiber's far-field response as a table over its three angles: what a
//! fragment of the volume's gather reads once per direction bin instead of
//! evaluating the model.
//!
//! A far-field fiber model depends on the view and the light only through
//! `sin θv = t·v`, `sin θl = t·l` and the azimuth φ between their
//! projections on the normal plane (in [0, π]). The table holds
//! `f(sin θv, sin θl, φ)` (RGB, the response to unit irradiance) at
//! [`NODES`] nodes per axis, uniform in each, read trilinearly.
//!
//! A direction bin's light is not one direction: it spreads about its
//! mean. Read at the mean alone, a response that peaks on the fiber's cone
//! (longitudinal widths of 0.1-0.3 rad against bins 0.3-0.5 rad across)
//! is read at its tails, too low on average (Jensen). So the table also
//! holds the response blurred over the light's direction by a Gaussian of
//! angular width σ, at [`SPREADS`] (σ = 0: the response itself). `(sin θl,
//! φ)` is an equal-area map of the light's sphere, so the blur is separable
//! there: σ / cos θl along φ (mirrored at 0 and π, as the response is
//! even in φ) and σ cos θl along `sin θl`. A bin whose light has mean
//! resultant length `R̄` (its mean direction's length over its fluence) is
//! read at the σ of the von Mises-Fisher distribution with that `R̄`:
//! `κ = R̄(3 − R̄²)/(1 − R̄²)` (Banerjee et al. 2005), `σ = 1/√κ`,
//! linearly between the two nearest spreads.

use glam::Vec3;

/// Nodes per axis.
pub const NODES: usize = 49;

/// arccos of `x` in [-1, 1] to 7e-5 rad (Abramowitz & Stegun 4.4.45; the
/// table's nodes are π/48 = 0.065 rad apart).
#[inline]
pub fn acos(x: f32) -> f32 {
    let a = x.abs().min(1.0);
    let r = (1.0 - a).sqrt()
        * (1.570_728_8 + a * (-0.212_114_4 + a * (0.074_261_0 + a * -0.018_729_3)));
    if x < 0.0 {
        std::f32::consts::PI - r
    } else {
        r
    }
}

/// Angular widths (rad) of the blurred tables; the last stands for any
/// wider spread (it is near uniform over the sphere).
pub const SPREADS: [f32; 6] = [0.0, 0.12, 0.25, 0.45, 0.8, 2.0];

/// The Gaussian width (rad) of the von Mises-Fisher distribution whose
/// mean resultant length is `r_bar` (clamped to the widest spread).
#[inline]
pub fn spread_of(r_bar: f32) -> f32 {
    let r = r_bar.clamp(0.0, 1.0);
    if r >= 1.0 {
        return 0.0;
    }
    let kappa = r * (3.0 - r * r) / (1.0 - r * r);
    if kappa <= 0.25 {
        SPREADS[SPREADS.len() - 1]
    } else {
        (1.0 / kappa.sqrt()).min(SPREADS[SPREADS.len() - 1])
    }
}

/// The sine axes' node `i`, in [-1, 1].
#[inline]
fn node(i: usize) -> f32 {
    -1.0 + 2.0 * i as f32 / (NODES - 1) as f32
}

/// The azimuth axis' node `i`, in [0, π].
#[inline]
fn phi_node(i: usize) -> f32 {
    std::f32::consts::PI * i as f32 / (NODES - 1) as f32
}

pub struct ResponseTable {
    /// [`SPREADS`] tables of `NODES³` entries.
    data: Vec<[f32; 3]>,
    /// Per view node, the response integrated over the light's sphere
    /// (the fiber's albedo towards that view, RGB): [`albedo_at`].
    albedo: Vec<[f32; 3]>,
}

impl ResponseTable {
    /// The table of `f(t, v, l)` (unit tangent, view and light), sampled
    /// with the tangent along y, the view in the y-z plane.
    pub fn new(f: impl Fn(Vec3, Vec3, Vec3) -> Vec3 + Sync) -> Self {
        use rayon::prelude::*;
        let n = NODES;
        let t = Vec3::Y;
        let data = crate::threads::pool().install(|| {
            (0..n * n * n)
                .into_par_iter()
                .map(|idx| {
                    let (iv, il, ip) = (idx / (n * n), (idx / n) % n, idx % n);
                    let (sv, sl) = (node(iv).clamp(-VIEW_EDGE, VIEW_EDGE), node(il));
                    let phi = phi_node(ip);
                    let cv = (1.0 - sv * sv).max(0.0).sqrt();
                    let cl = (1.0 - sl * sl).max(0.0).sqrt();
                    let v = Vec3::new(0.0, sv, cv);
                    let l = Vec3::new(cl * phi.sin(), sl, cl * phi.cos());
                    let r = f(t, v, l);
                    if r.is_finite() {
                        r.max(Vec3::ZERO).to_array()
                    } else {
                        [0.0; 3]
                    }
                })
                .collect::<Vec<[f32; 3]>>()
        });
        let levels: Vec<Vec<[f32; 3]>> = SPREADS[1..].iter().map(|&s| blurred(&data, s)).collect();
        let albedo = crate::threads::pool().install(|| {
            (0..n)
                .into_par_iter()
                .map(|iv| albedo_at(&f, node(iv)))
                .collect()
        });
        Self {
            albedo,
            data: data
                .into_iter()
                .chain(levels.into_iter().flatten())
                .collect(),
        }
    }

    /// The response integrated over the light's sphere at `sin θv`
    /// (linear between the view nodes): what a fiber seen from there
    /// scatters of a radiance of 1 from every direction.
    #[inline]
    pub fn albedo(&self, sv: f32) -> Vec3 {
        let scale = (NODES - 1) as f32;
        let u = ((sv + 1.0) * 0.5 * scale).clamp(0.0, scale);
        let i = (u as usize).min(NODES - 2);
        let (a, b) = (Vec3::from(self.albedo[i]), Vec3::from(self.albedo[i + 1]));
        a + (b - a) * (u - i as f32)
    }

    /// `f` at `sin θv`, `sin θl` and φ ∈ [0, π], blurred by the angular
    /// width `sigma` (linearly between the nearest [`SPREADS`]).
    #[inline]
    pub fn eval_spread(&self, sv: f32, sl: f32, phi: f32, sigma: f32) -> Vec3 {
        let last = SPREADS.len() - 1;
        let k = SPREADS[1..last].partition_point(|&s| s <= sigma);
        let (a, b) = (SPREADS[k], SPREADS[k + 1]);
        let w = ((sigma - a) / (b - a)).clamp(0.0, 1.0);
        let lo = self.eval_level(k, sv, sl, phi);
        if w == 0.0 {
            return lo;
        }
        lo + (self.eval_level(k + 1, sv, sl, phi) - lo) * w
    }

    /// Level `level`'s `f` at `sin θv`, `sin θl` and φ ∈ [0, π], trilinear.
    #[inline]
    fn eval_level(&self, level: usize, sv: f32, sl: f32, phi: f32) -> Vec3 {
        let n = NODES;
        let data = &self.data[level * n * n * n..(level + 1) * n * n * n];
        let scale = (n - 1) as f32;
        let pos = |x: f32, lo: f32, span: f32| {
            let u = ((x - lo) / span * scale).clamp(0.0, scale);
            let i = (u as usize).min(n - 2);
            (i, u - i as f32)
        };
        let (iv, fv) = pos(sv, -1.0, 2.0);
        let (il, fl) = pos(sl, -1.0, 2.0);
        let (ip, fp) = pos(phi, 0.0, std::f32::consts::PI);
        let at = |a: usize, b: usize, c: usize| Vec3::from(data[(a * n + b) * n + c]);
        let lerp = |a: Vec3, b: Vec3, f: f32| a + (b - a) * f;
        let c00 = lerp(at(iv, il, ip), at(iv, il, ip + 1), fp);
        let c01 = lerp(at(iv, il + 1, ip), at(iv, il + 1, ip + 1), fp);
        let c10 = lerp(at(iv + 1, il, ip), at(iv + 1, il, ip + 1), fp);
        let c11 = lerp(at(iv + 1, il + 1, ip), at(iv + 1, il + 1, ip + 1), fp);
        lerp(lerp(c00, c01, fl), lerp(c10, c11, fl), fv)
    }

    /// Bytes a table holds.
    pub const BYTES: usize = NODES * NODES * NODES * SPREADS.len() * 12;

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.data.len() * 12
    }
}

/// The end nodes' `|sin θv|` as the table evaluates them: a view along
/// the fiber has no azimuth (its projection on the normal plane is 0), and
/// read there the response was the azimuth-0 response all round, 1.56
/// times the albedo; 0.9999 is 0.8° off the fiber.
const VIEW_EDGE: f32 = 0.9999;

/// Gauss-Legendre nodes of [`albedo_at`]'s quadrature, in θl and in φ.
const ALBEDO_NODES: usize = 128;

/// `∫ f(t, v, l) dl` over the light's sphere for the view at `sin θv = sv`
/// (tangent along y, view in the y-z plane), RGB: Gauss-Legendre in θl
/// (weight cos θl) and in φ ∈ [0, π], twice for the mirrored half. Taken
/// from `f` itself, not the table: seen nearly along the fiber (|sin θv|
/// above 0.93) the lobes close in on the pole, narrower in `sin θl` than
/// the table's nodes, whose integral there was off by up to 50%; in θl
/// they stay β wide. Against a 400 × 800 equal-area sum over the sphere:
/// within 0.2% at every view (volume tests 4 and 5).
fn albedo_at(f: &(impl Fn(Vec3, Vec3, Vec3) -> Vec3 + Sync), sv: f32) -> [f32; 3] {
    use std::f64::consts::{FRAC_PI_2, PI};
    let (x, w) = crate::math::gauss_legendre(ALBEDO_NODES);
    let sv = sv.clamp(-VIEW_EDGE, VIEW_EDGE);
    let cv = (1.0 - sv * sv).max(0.0).sqrt();
    let v = Vec3::new(0.0, sv, cv);
    let mut sum = [0.0f64; 3];
    for (xi, wi) in x.iter().zip(&w) {
        let theta = xi * FRAC_PI_2;
        let (sl, cl) = (theta.sin(), theta.cos());
        for (xj, wj) in x.iter().zip(&w) {
            let phi = (xj + 1.0) * 0.5 * PI;
            let l = Vec3::new((cl * phi.sin()) as f32, sl as f32, (cl * phi.cos()) as f32);
            let r = f(Vec3::Y, v, l);
            let weight = wi * FRAC_PI_2 * cl * wj * 0.5 * PI * 2.0;
            for c in 0..3 {
                if r[c].is_finite() {
                    sum[c] += weight * r[c].max(0.0) as f64;
                }
            }
        }
    }
    sum.map(|s| s as f32)
}

/// The table `data` (one level) blurred over the light's direction by a
/// Gaussian of angular width `sigma`: along φ by `sigma / cos θl` (the
/// response mirrored at 0 and π), then along `sin θl` by `sigma cos θl`
/// (at least `sigma² / 2`, the width in `sin θl` of a cap of radius
/// `sigma` about the tangent), on the nodes with trapezoid weights: along
/// φ a convolution, along `sin θl` each node spreading its own light by its
/// own width, so that the integral over the sphere stays.
fn blurred(data: &[[f32; 3]], sigma: f32) -> Vec<[f32; 3]> {
    use rayon::prelude::*;
    use std::f32::consts::PI;
    let n = NODES;
    let trapezoid = |j: usize| if j == 0 || j == n - 1 { 0.5 } else { 1.0 };
    let gauss = |d: f32, s: f32| (-0.5 * (d / s) * (d / s)).exp();
    // along φ: per row il, weights[i][j] normalized over j
    let phi_w: Vec<f32> = (0..n)
        .flat_map(|il| {
            let cl = (1.0 - node(il) * node(il)).max(0.0).sqrt();
            let s = sigma / cl.max(1e-3);
            (0..n).flat_map(move |i| {
                let pi_ = phi_node(i);
                let w: Vec<f32> = (0..n)
                    .map(|j| {
                        let pj = phi_node(j);
                        // the distance on the circle to pj and to its mirror -pj
                        let around = |d: f32| {
                            let d = d.rem_euclid(2.0 * PI);
                            d.min(2.0 * PI - d)
                        };
                        trapezoid(j) * (gauss(around(pi_ - pj), s) + gauss(around(pi_ + pj), s))
                    })
                    .collect();
                let sum: f32 = w.iter().sum();
                w.into_iter().map(move |x| x / sum)
            })
        })
        .collect();
    // along sin θl, each node's light spread over its neighbours by its own
    // width (so that the integral over the sphere is kept): the weight of
    // source k at target i, [i][k]
    let mut sl_w = vec![0.0f32; n * n];
    for k in 0..n {
        let cl = (1.0 - node(k) * node(k)).max(0.0).sqrt();
        let s = (sigma * cl).max(0.5 * sigma * sigma).max(1e-4);
        let w: Vec<f32> = (0..n)
            .map(|i| trapezoid(i) * gauss(node(i) - node(k), s))
            .collect();
        let sum: f32 = w.iter().sum();
        for (i, wi) in w.into_iter().enumerate() {
            sl_w[i * n + k] = trapezoid(k) * wi / (sum * trapezoid(i));
        }
    }
    crate::threads::pool().install(|| {
        (0..n)
            .into_par_iter()
            .flat_map_iter(|iv| {
                let slice = &data[iv * n * n..(iv + 1) * n * n];
                // Σ_j w[j] x(j)
                let weighted = |w: &[f32], x: &dyn Fn(usize) -> [f32; 3]| {
                    w.iter().enumerate().fold([0.0f32; 3], |acc, (j, &wj)| {
                        let x = x(j);
                        std::array::from_fn(|c| acc[c] + wj * x[c])
                    })
                };
                // along φ, row by row
                let a: Vec<[f32; 3]> = (0..n * n)
                    .map(|r| {
                        // row il = r / n, target φ node r % n
                        let il = r / n;
                        weighted(&phi_w[r * n..(r + 1) * n], &|j| slice[il * n + j])
                    })
                    .collect();
                // along sin θl, column by column
                (0..n * n)
                    .map(|r| {
                        let (i, ip) = (r / n, r % n);
                        weighted(&sl_w[i * n..(i + 1) * n], &|k| a[k * n + ip])
                    })
                    .collect::<Vec<_>>()
            })
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. The fast arccos is within 7e-5 rad of the exact one.
    #[test]
    fn acos_within_its_bound() {
        for i in 0..=20000 {
            let x = -1.0 + 2.0 * i as f32 / 20000.0;
            assert!((acos(x) - x.acos()).abs() < 7e-5, "{x}");
        }
    }

    /// The integral over the light's sphere of a table level at the view
    /// node `iv` (the nodes are equal-area: dω = d(sin θl) dφ, twice for φ
    /// in [-π, π]).
    fn sphere_integral(t: &ResponseTable, level: usize, iv: usize) -> f32 {
        let n = NODES;
        let mut sum = 0.0;
        for il in 0..n {
            for ip in 0..n {
                let w = |j: usize| if j == 0 || j == n - 1 { 0.5 } else { 1.0 };
                sum += w(il) * w(ip) * t.data[((level * n + iv) * n + il) * n + ip][0];
            }
        }
        sum * (2.0 / (n - 1) as f32) * (std::f32::consts::PI / (n - 1) as f32) * 2.0
    }

    /// A peaked test response: a longitudinal Gaussian on the cone
    /// θl = -θv (width 0.15 rad) times an azimuthal bump at φ = 0.
    fn peaked() -> ResponseTable {
        ResponseTable::new(|t: Vec3, v: Vec3, l: Vec3| {
            let (tv, tl) = (t.dot(v).asin(), t.dot(l).asin());
            let vn = (v - t * t.dot(v)).normalize_or_zero();
            let ln = (l - t * t.dot(l)).normalize_or_zero();
            let phi = vn.dot(ln).clamp(-1.0, 1.0).acos();
            Vec3::splat((-0.5 * ((tl + tv) / 0.15).powi(2)).exp() * (1.0 + phi.cos()))
        })
    }

    /// 2. Blurring keeps the response's integral over the light's sphere
    ///    (what a uniform light field reads) within 1.5% at every spread
    ///    and view, and spreads its peak: the widest level is near flat.
    #[test]
    fn blur_keeps_the_integral() {
        let t = peaked();
        for iv in [4, 12, 24, 36, 44] {
            let base = sphere_integral(&t, 0, iv);
            for level in 1..SPREADS.len() {
                let b = sphere_integral(&t, level, iv);
                assert!(
                    (b / base - 1.0).abs() < 0.015,
                    "view {iv} level {level}: {b} vs {base}"
                );
            }
        }
        // per view, the peak falls level by level, and the widest level
        // varies by less than the Gaussian of 2 rad does over the sphere
        // (exp(-(pi/2)^2 / 2) = 0.29 at the antipode)
        let n = NODES;
        for iv in [4, 24, 44] {
            let range = |level: usize| {
                let s = &t.data[(level * n + iv) * n * n..(level * n + iv + 1) * n * n];
                s.iter()
                    .fold((f32::MAX, 0.0f32), |(a, b), x| (a.min(x[0]), b.max(x[0])))
            };
            for level in 1..SPREADS.len() {
                assert!(
                    range(level).1 < range(level - 1).1,
                    "view {iv} level {level}"
                );
            }
            let (lo, hi) = range(SPREADS.len() - 1);
            assert!(hi < 4.0 * lo, "view {iv}: widest level {lo}..{hi}");
        }
    }

    /// 3. The spread of a von Mises-Fisher distribution: 1/√κ for a
    ///    concentrated one (R̄ = 0.99: κ ≈ 100), the widest for R̄ → 0, and 0
    ///    for a single direction.
    #[test]
    fn spread_of_r_bar() {
        assert_eq!(spread_of(1.0), 0.0);
        assert!((spread_of(0.99) - 0.1).abs() < 0.005, "{}", spread_of(0.99));
        assert_eq!(spread_of(0.0), SPREADS[SPREADS.len() - 1]);
        assert!(spread_of(0.9) < spread_of(0.5));
    }
}
