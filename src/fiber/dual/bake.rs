//! Baking a material's dual-scattering tables from its far field:
//! ChiangHair from its tabulated far field, KarisHair from its lobes.

use super::{DualTable, NG_COS, NG_PHI};
use crate::fiber::chiang::ChiangFarTable;
use crate::fiber::karis::{KarisHair, KarisParts};
use rayon::prelude::*;

/// The narrowest longitudinal Gaussian the integrals over `u_o` see.
/// KarisHair's R narrows to a line as φ → π (its width is
/// `√2 B_R cos(φ/2)`), which no fixed rule in `u_o` resolves; widening it
/// to this keeps its integral over `u_o` (1 when the peak lies inside
/// [−1, 1]) and adds at most `MIN_WIDTH²` to its variance.
const MIN_WIDTH: f32 = 0.02;

/// Nodes of the window of width π over which `N^G` averages `N̄_p`.
const WINDOW: usize = 128;

/// The canonical frame of a pair of directions given by (sin θ, cos θ) and
/// the azimuth between them: tangent `y`, the view in the x-y plane.
pub(super) fn canonical(view: (f32, f32), light: (f32, f32), phi: f32) -> [[f32; 3]; 3] {
    [
        [light.1 * phi.cos(), light.0, light.1 * phi.sin()],
        [view.1, view.0, 0.0],
        [0.0, 1.0, 0.0],
    ]
}

/// KarisHair's R, TT and TRT split into parts at the angles of a pair.
pub(super) fn karis_parts(
    model: &KarisHair<f32>,
    view: (f32, f32),
    light: (f32, f32),
    phi: f32,
) -> KarisParts<f32> {
    let [l, v, t] = canonical(view, light, phi);
    model.parts(&l, &v, &t)
}

/// `N^G_p` at every (cos, φ) node: `n(cos, φ')` averaged over
/// `φ' ∈ [φ − π/2, φ + π/2]` (midpoint rule, 128 nodes).
fn window_average(n: &(dyn Fn(f32, f32) -> [[f32; 3]; 3] + Sync)) -> Vec<[f32; 9]> {
    use std::f32::consts::PI;
    crate::threads::pool().install(|| {
        (0..NG_COS * NG_PHI)
            .into_par_iter()
            .map(|i| {
                let (c, j) = (i / NG_PHI, i % NG_PHI);
                let cos = c as f32 / (NG_COS - 1) as f32;
                let phi = PI * j as f32 / (NG_PHI - 1) as f32;
                let mut acc = [0.0f32; 9];
                for k in 0..WINDOW {
                    let d = PI * ((k as f32 + 0.5) / WINDOW as f32 - 0.5);
                    let at = crate::math::wrap_pi(phi + d).abs();
                    let np = n(cos, at);
                    for p in 0..3 {
                        for ch in 0..3 {
                            acc[3 * p + ch] += np[p][ch] / WINDOW as f32;
                        }
                    }
                }
                acc
            })
            .collect()
    })
}

impl DualTable {
    /// The tables of a ChiangHair far field (integrated from its table);
    /// `N^G` over the cosine of the view's θ.
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
        let ng = window_average(&|cos, phi| table.azimuthal(cos, phi).0);
        Self { terms, ng, d_b }
    }

    /// The tables of KarisHair's R, TT and TRT (its own multiple-scattering
    /// term left out: dual scattering replaces it); `N^G` over cos θd, each
    /// lobe's `rest_p` (everything but its longitudinal Gaussian) at the
    /// mirror pair `θV = θd, θL = −θd`.
    pub fn for_karis(model: &KarisHair<f32>, d_b: f32) -> Self {
        let model = model.single_scattering();
        let f = |u_l: f64, u_o: f64, phi: f64| {
            let cos = |u: f64| (1.0 - u * u).max(0.0).sqrt();
            let view = (u_o as f32, cos(u_o) as f32);
            let light = (u_l as f32, cos(u_l) as f32);
            karis_parts(&model, view, light, phi as f32)
                .total(MIN_WIDTH)
                .map(f64::from)
        };
        let terms = Self::terms_of(&f, d_b as f64);
        let ng = window_average(&|cos_d, phi| {
            let sin_d = (1.0 - cos_d * cos_d).max(0.0).sqrt();
            karis_parts(&model, (sin_d, cos_d), (-sin_d, cos_d), phi).rest
        });
        Self { terms, ng, d_b }
    }
}

/// The tables of KarisHair materials baked in this process, newest last
/// (a handful: a scene has one material, a sweep a few).
static KARIS_TABLES: std::sync::Mutex<Vec<(String, std::sync::Arc<DualTable>)>> =
    std::sync::Mutex::new(Vec::new());
const KARIS_KEPT: usize = 8;

impl DualTable {
    /// [`Self::for_karis`], kept for the next render of the same material
    /// and `d_b` (the key is the model's full parameter set).
    pub fn for_karis_cached(model: &KarisHair<f32>, d_b: f32) -> std::sync::Arc<Self> {
        let key = format!("{model:?} d_b={}", d_b.to_bits());
        let lock = || KARIS_TABLES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(table) = crate::lru::kept(&KARIS_TABLES, &key) {
            return table;
        }
        // baked without the lock: the bake runs on the thread pool, which
        // another caller waiting on the lock may belong to
        let table = std::sync::Arc::new(Self::for_karis(model, d_b));
        let mut held = lock();
        if !held.iter().any(|(k, _)| *k == key) {
            if held.len() >= KARIS_KEPT {
                held.remove(0);
            }
            held.push((key, table.clone()));
        }
        table
    }
}
