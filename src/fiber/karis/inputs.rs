//! The per-pair inputs of a batched [`KarisHair`](super::KarisHair)
//! evaluation, as flat arrays (the form the vector kernel and the batch
//! layer share).

use crate::math::Real;

/// Per-pair inputs of a batched [`KarisHair`] evaluation (each array holds N
/// values or one broadcast value: 1 / 3 for scalars / RGB).
pub struct KarisInputs<'a, T> {
    pub l: &'a [T],
    pub v: &'a [T],
    pub t: &'a [T],
    pub shadow: &'a [T],
    pub global_scattering: &'a [T],
    pub local_scattering: &'a [T],
    pub opaque_visibility: &'a [T],
}

impl<'a> KarisInputs<'a, f32> {
    /// Directions only, with the default transmittance (shadow 1, global
    /// scattering 1, local scattering 0, opaque visibility 1).
    pub fn directions(l: &'a [f32], v: &'a [f32], t: &'a [f32]) -> Self {
        Self {
            l,
            v,
            t,
            shadow: &[1.0],
            global_scattering: &[1.0; 3],
            local_scattering: &[0.0; 3],
            opaque_visibility: &[1.0],
        }
    }
}

impl<T: Real> KarisInputs<'_, T> {
    /// Number of pairs (the longest input).
    pub fn len(&self) -> usize {
        [
            self.l.len() / 3,
            self.v.len() / 3,
            self.t.len() / 3,
            self.shadow.len(),
            self.global_scattering.len() / 3,
            self.local_scattering.len() / 3,
            self.opaque_visibility.len(),
        ]
        .into_iter()
        .max()
        .unwrap_or(0)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
