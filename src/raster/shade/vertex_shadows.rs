//! Traced shadows decided at strand vertices: a light's shadow ray is
//! traced from each vertex of a segment (once per render, from the vertex's
//! surface point facing the eye), and a fragment of the segment takes the
//! answer where the two agree; it traces its own ray only where they
//! differ, at the segment's shadow edges (`render.shadows.traced.vertices`).
//!
//! A shadow ray per fragment costs a quarter of a `balanced` frame: about
//! one fragment per pixel, each walking the strands' grid towards each
//! light. A strand's vertices are several pixels apart on screen, and
//! along most segments what blocks the light does not change: a fiber on
//! the lit shell sees the light from end to end, one under it is blocked
//! from end to end. What the vertices cannot see is a shadow that starts
//! and ends between them (a single fiber crossing the segment's way to the
//! light): such a fragment takes its ends' answer. The error is measured
//! per head against per-fragment rays and against the truth in
//! `docs/speed.md`.
//!
//! A vertex's answer depends on the vertex alone (its position, tangent,
//! radius and the eye), not on which fragment asks first or on which
//! thread, so images are the same at every thread count.

use super::at_vertices::{strand_segment, vertex_frame};
use super::Fiber;
use crate::raster::scene::Strands;
use crate::raster::setup::WorldSegment;
use glam::Vec3;
use std::sync::atomic::{AtomicU8, Ordering};

/// Not traced yet, lit, blocked.
const UNKNOWN: u8 = 0;
const LIT: u8 = 1;
const BLOCKED: u8 = 2;

/// Per traced light and strand vertex, whether the vertex's shadow ray is
/// blocked (computed on first use).
pub(super) struct VertexShadows<'a> {
    segments: &'a [WorldSegment],
    strands: &'a Strands,
    eye: Vec3,
    /// Per light: its vertices' answers (empty for a light whose shadows
    /// are not traced).
    state: Vec<Vec<AtomicU8>>,
}

impl<'a> VertexShadows<'a> {
    /// Unknown answers for the vertices of `strands` (world segments
    /// `segments`), seen from `eye`, for the lights where `traced` is set.
    pub fn new(
        segments: &'a [WorldSegment],
        strands: &'a Strands,
        eye: Vec3,
        traced: impl Iterator<Item = bool>,
    ) -> Self {
        let n = strands.points.len();
        let state = traced
            .map(|on| {
                if on {
                    (0..n).map(|_| AtomicU8::new(UNKNOWN)).collect()
                } else {
                    Vec::new()
                }
            })
            .collect();
        Self {
            segments,
            strands,
            eye,
            state,
        }
    }

    /// Whether light `li` is blocked at a fragment of `fiber`'s segment
    /// where both of its vertices say the same (`blocked(origin, fiber)`
    /// traces a vertex's ray from the surface point at `origin(q, t, v,
    /// fiber)`); `None` where they differ, on cards, or for a light not
    /// traced here.
    #[inline]
    pub fn agreed(
        &self,
        li: usize,
        fiber: &Fiber,
        origin: impl Fn(Vec3, Vec3, Vec3, &Fiber) -> Vec3,
        blocked: impl Fn(Vec3, &Fiber) -> bool,
    ) -> Option<bool> {
        let state = self.state.get(li).filter(|s| !s.is_empty())?;
        let s = strand_segment(self.segments, fiber)?;
        let at = |i: usize| {
            let x = state[i].load(Ordering::Relaxed);
            if x != UNKNOWN {
                return x;
            }
            let (q, t, vertex) = vertex_frame(self.strands, i, s.strand as usize);
            let v = (self.eye - q).normalize_or_zero();
            let x = if blocked(origin(q, t, v, &vertex), &vertex) {
                BLOCKED
            } else {
                LIT
            };
            // (two threads that both trace store the same answer)
            state[i].store(x, Ordering::Relaxed);
            x
        };
        let i = s.vertex as usize;
        let a = at(i);
        (a == at(i + 1)).then_some(a == BLOCKED)
    }
}
