//! The tallies' noise filtered in space: a local linear fit over each
//! cell's 3×3×3 neighbourhood.

use super::medium;
use crate::threads::pool;
use glam::Vec3;
use rayon::prelude::*;

/// The fluence filtered over each cell's 3×3×3 neighbourhood by a local
/// linear fit: per cell, the weighted least-squares plane through its
/// neighbours' values at their fibers' mean positions
/// ([`medium::Cells::centroid`]), weighted 1 (the cell), 1/2 (its faces)
/// and 1/4 (edges and corners) times each cell's fibers
/// ([`medium::Cells::weight`]); its value at the cell's own fibers is the
/// filtered fluence. A plain weighted mean is biased at the hair's
/// surface, where every neighbour lies on the inner side; the plane is
/// not. Measured (48 cells, 2^18 photons, medium transport, relMSE against
/// the truth, weighted mean -> plane): clumped_blond_key 3.96e-3 ->
/// 3.59e-3, curly_blond_env 4.51e-3 -> 4.02e-3, wavy_blond_rim 4.15e-3 ->
/// 4.08e-3; within 0.17e-3 either way on the separated heads. The plane's
/// slope carried on to each fragment's position as well (a gradient per
/// cell) pushed the straight key-lit separated head's multiple scattering
/// from 1.15 to 1.21 of the truth's in red, and is not used.
///
/// `block` rows a cell (its bins times its groups) of `words` floats
/// each (RGB, then the summed direction where it is tallied): a cell's
/// rows are one contiguous block, and every neighbour's block is added to
/// the cell's whole at once (one coefficient over the block).
///
/// `out` (as long as `fluence`) receives the result: every row is
/// written, none read, so it may be a buffer of an earlier pass.
pub(super) fn smooth(
    m: &medium::Cells,
    fluence: &[f32],
    out: &mut [f32],
    block: usize,
    words: usize,
) {
    assert_eq!(out.len(), fluence.len());
    let d = m.dims;
    let span = block * words;
    if span == 0 {
        return;
    }
    // Each cell's rows are summed in a scratch block and written once: the
    // output's fresh zero pages are then written before they are read (a
    // read first maps the shared zero page, and the write after it costs a
    // second fault and a TLB flush on every thread: 17% of a balanced
    // blond_back frame, measured).
    pool().install(|| {
        out.par_chunks_mut(span).enumerate().for_each_init(
            || (Vec::with_capacity(27), vec![0.0f32; span]),
            |(nbrs, acc): &mut (Vec<(usize, f32, Vec3)>, Vec<f32>), (s, rows)| {
                let v = m.cell_of[s] as usize;
                let [i, j, k] = medium::grid_coords(d, v).map(|x| x as i64);
                // the neighbours: slot, weight, position from this cell's fibers
                nbrs.clear();
                let own = m.centroid[s];
                for dk in -1i64..=1 {
                    for dj in -1i64..=1 {
                        for di in -1i64..=1 {
                            let Some(n) = medium::dense_index(d, i + di, j + dj, k + dk) else {
                                continue;
                            };
                            let ns = m.slot[n];
                            if ns == u32::MAX {
                                continue;
                            }
                            let w = [1.0f32, 0.5, 0.25]
                                [(di.abs() + dj.abs() + dk.abs()).min(2) as usize]
                                * m.weight[ns as usize];
                            let x = Vec3::new(di as f32, dj as f32, dk as f32)
                                + m.centroid[ns as usize]
                                - own;
                            nbrs.push((ns as usize, w, x));
                        }
                    }
                }
                let l = local_linear(nbrs);
                acc.fill(0.0);
                for (&(ns, _, _), &c) in nbrs.iter().zip(&l) {
                    for (a, x) in acc.iter_mut().zip(&fluence[ns * span..(ns + 1) * span]) {
                        *a += c * x;
                    }
                }
                for (row, a) in rows.chunks_exact_mut(words).zip(acc.chunks_exact(words)) {
                    // the plane may dip below zero where the light falls off fast
                    for (q, (r, &x)) in row.iter_mut().zip(a).enumerate() {
                        *r = if q < 3 { x.max(0.0) } else { x };
                    }
                }
            },
        );
    });
}

/// The damping of [`local_linear`]'s slope, per unit weight (cells²): a
/// full neighbourhood's spread is about 0.6 cells² a side and a surface
/// cell's about 0.25 across the surface, so a slope is shrunk by 2-4%
/// there, and one across a thin neighbourhood (whose fibers' positions
/// differ little that way) stays small. Measured with the slope carried
/// to each fragment, medium transport at 48 cells: 0.05 gave
/// clumped_blond_key relMSE 3.54e-3 and wavy_blond_rim 4.01e-3; 0.01:
/// 3.44e-3 and 3.96e-3.
const RIDGE: f64 = 0.01;

/// The equivalent kernel of a weighted least-squares plane through
/// `(slot, weight, position)` points: per point, its coefficient in the
/// plane's value at the origin. The slope's normal equations are damped
/// by [`RIDGE`] times the weight (so that a flat or thin neighbourhood
/// has no slope across itself).
pub(super) fn local_linear(pts: &[(usize, f32, Vec3)]) -> Vec<f32> {
    let wsum: f64 = pts.iter().map(|p| p.1 as f64).sum();
    if wsum <= 0.0 {
        return vec![0.0; pts.len()];
    }
    // normal equations M c = Σ w X y, X = (1, x, y, z)
    let mut a = [[0.0f64; 4]; 4];
    for &(_, w, x) in pts {
        let xs = [1.0, x.x as f64, x.y as f64, x.z as f64];
        for r in 0..4 {
            for c in 0..4 {
                a[r][c] += w as f64 * xs[r] * xs[c];
            }
        }
    }
    for r in 1..4 {
        a[r][r] += RIDGE * wsum;
    }
    // the intercept's row of M⁻¹, times each point's X and weight
    let inv = invert4(a);
    pts.iter()
        .map(|&(_, w, x)| {
            let xs = [1.0, x.x as f64, x.y as f64, x.z as f64];
            (w as f64 * (0..4).map(|q| inv[0][q] * xs[q]).sum::<f64>()) as f32
        })
        .collect()
}

/// The inverse of a symmetric positive definite 4×4 matrix (Gauss-Jordan).
fn invert4(mut a: [[f64; 4]; 4]) -> [[f64; 4]; 4] {
    let mut inv = [[0.0f64; 4]; 4];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for c in 0..4 {
        let p = (c..4)
            .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
            .unwrap_or(c);
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        if d.abs() < 1e-300 {
            continue;
        }
        for q in 0..4 {
            a[c][q] /= d;
            inv[c][q] /= d;
        }
        for r in 0..4 {
            if r != c {
                let f = a[r][c];
                for q in 0..4 {
                    a[r][q] -= f * a[c][q];
                    inv[r][q] -= f * inv[c][q];
                }
            }
        }
    }
    inv
}
