//! Terms of the shading that vary slowly along a strand, computed at its
//! vertices and interpolated along each segment: the volume's multiple
//! scattering, and with `shading = "split"` the environment and dual
//! scattering's scattered light too.
//!
//! A vertex is computed once per render, by whichever fragment asks first,
//! with the vertex's own position, tangent (along its two neighbours),
//! radius and direction to the eye, so its value does not depend on the
//! fragment or the thread. With guide-strand lighting
//! ([`crate::raster::guides`]) only the guides' vertices are computed, and
//! every vertex is gathered from them. Along a segment the value at the parameter `u`
//! of the point's projection onto it is `(1 − u)·x_a + u·x_b`.
//!
//! Why it holds: these terms change over the distance at which the fiber
//! counts and the volume's cells change (several fiber diameters, a voxel),
//! and with the tangent and the view direction, which are constant along a
//! segment and nearly so between neighbours. What changes across a
//! fiber's width or at a shadow's edge (a light's unscattered single
//! scattering: its traced shadow ray, the near field at a sample's
//! offset) stays per fragment. The error is measured per head in
//! `docs/speed.md`.

use super::Fiber;
use crate::raster::guides::GuideMap;
use crate::raster::scene::Strands;
use crate::raster::setup::WorldSegment;
use crate::raster::shadow::NO_STRAND;
use glam::Vec3;
use std::sync::{Arc, OnceLock};

/// Per strand vertex, a term computed on first use.
pub(super) struct AtVertices<'a> {
    segments: &'a [WorldSegment],
    strands: &'a Strands,
    eye: Vec3,
    values: Vec<OnceLock<Vec3>>,
    /// With guide-strand lighting, computed at the guides' vertices alone
    /// and gathered from them ([`GuideMap::gather`]).
    guides: Option<Arc<GuideMap>>,
}

impl<'a> AtVertices<'a> {
    /// Empty values for the vertices of `strands` (whose world segments
    /// are `segments`), seen from `eye`, taken from `guides` when given.
    pub fn new(
        segments: &'a [WorldSegment],
        strands: &'a Strands,
        eye: Vec3,
        guides: Option<Arc<GuideMap>>,
    ) -> Self {
        Self {
            segments,
            strands,
            eye,
            values: (0..strands.points.len()).map(|_| OnceLock::new()).collect(),
            guides,
        }
    }

    /// The term at `p` on `fiber`: `f(q, t, v, fiber)` at the two vertices
    /// of the fiber's segment (each computed once, or gathered from the
    /// guides), interpolated; `None` where the point lies on no strand
    /// (cards).
    #[inline]
    pub fn read(
        &self,
        p: Vec3,
        fiber: Fiber,
        f: impl Fn(Vec3, Vec3, Vec3, Fiber) -> Vec3,
    ) -> Option<Vec3> {
        let s = strand_segment(self.segments, &fiber)?;
        let at = |i: usize| match &self.guides {
            Some(g) => g.gather(i, |j| self.value(j, g.owner(j), &f)),
            None => self.value(i, s.strand as usize, &f),
        };
        let d = s.b - s.a;
        let i = s.vertex as usize;
        let u = ((p - s.a).dot(d) / d.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        Some(at(i) * (1.0 - u) + at(i + 1) * u)
    }

    /// Vertex `i`'s value (of strand `strand`), computed on first use.
    #[inline]
    fn value(&self, i: usize, strand: usize, f: &impl Fn(Vec3, Vec3, Vec3, Fiber) -> Vec3) -> Vec3 {
        *self.values[i].get_or_init(|| {
            let (q, t, vertex) = vertex_frame(self.strands, i, strand);
            f(q, t, (self.eye - q).normalize_or_zero(), vertex)
        })
    }
}

/// The world segment a fragment of `fiber` lies on (None on cards).
#[inline]
pub(super) fn strand_segment<'s>(
    segments: &'s [WorldSegment],
    fiber: &Fiber,
) -> Option<&'s WorldSegment> {
    if fiber.strand == NO_STRAND {
        return None;
    }
    segments.get(fiber.segment as usize)
}

/// Vertex `i` of strand `strand`: its position, its tangent (along its two
/// neighbours) and its fiber (the segment starting at the vertex; at the
/// tip, the last one).
#[inline]
pub(super) fn vertex_frame(st: &Strands, i: usize, strand: usize) -> (Vec3, Vec3, Fiber) {
    let (first, last) = (
        st.offsets[strand] as usize,
        st.offsets[strand + 1] as usize - 1,
    );
    let q = st.points[i];
    let t = (st.points[(i + 1).min(last)] - st.points[i.saturating_sub(1).max(first)])
        .normalize_or_zero();
    let vertex = Fiber {
        radius: st.radii[i],
        strand: strand as u32,
        segment: (i.min(last - 1) - strand) as u32,
    };
    (q, t, vertex)
}
