//! A tile's fragments waiting for their radiance: those shaded in one
//! batch at the end of the tile ([`Pending`]), and strand fragments waiting
//! for their vertices' radiance under on-demand per-vertex shading
//! ([`VertexPending`]).

use super::super::shade::{FetchScratch, Fiber, NearLight};
use glam::Vec3;

/// Strand fragments of a tile awaiting their vertices' radiance: pixel,
/// depth, coverage (alpha) and parameter along the segment, and the runs
/// of fragments of one segment (the segment, the run's first fragment).
#[derive(Default)]
pub(super) struct VertexPending {
    pub(super) k: Vec<u32>,
    pub(super) depth: Vec<f32>,
    pub(super) alpha: Vec<f32>,
    pub(super) tw: Vec<f32>,
    pub(super) runs: Vec<(u32, u32)>,
    /// The vertices the runs need (vertex, strand), and the buffers of
    /// their shading.
    pub(super) need: Vec<(u32, u32)>,
    pub(super) scratch: FetchScratch,
}

impl VertexPending {
    pub(super) fn clear(&mut self) {
        self.k.clear();
        self.depth.clear();
        self.alpha.clear();
        self.tw.clear();
        self.runs.clear();
    }

    #[inline]
    pub(super) fn push(&mut self, k: usize, depth: f32, alpha: f32, si: u32, tw: f32) {
        if self.runs.last().is_none_or(|r| r.0 != si) {
            self.runs.push((si, self.k.len() as u32));
        }
        self.k.push(k as u32);
        self.depth.push(depth);
        self.alpha.push(alpha);
        self.tw.push(tw);
    }
}

/// Hair fragments of a tile awaiting shading: pixel, depth, coverage
/// (alpha), world position, tangent, fiber.
#[derive(Default)]
pub(super) struct Pending {
    pub(super) k: Vec<u32>,
    pub(super) depth: Vec<f32>,
    pub(super) alpha: Vec<f32>,
    pub(super) p: Vec<Vec3>,
    pub(super) t: Vec<Vec3>,
    pub(super) fiber: Vec<Fiber>,
    /// Radiance: the interpolated per-vertex radiance, or NaN until the
    /// fragment is shaded.
    pub(super) color: Vec<Vec3>,
    /// Coverage mode: the screen line giving a sample's offset across the
    /// fiber ([`offset_line`]; NaN for cards), and with the near field the
    /// range of `lights` the fragment's samples shade by it.
    pub(super) line: Vec<[f32; 4]>,
    pub(super) near: Vec<(u32, u32)>,
    pub(super) lights: Vec<NearLight>,
}

impl Pending {
    pub(super) fn clear(&mut self) {
        self.k.clear();
        self.depth.clear();
        self.alpha.clear();
        self.p.clear();
        self.t.clear();
        self.fiber.clear();
        self.color.clear();
        self.line.clear();
        self.near.clear();
        self.lights.clear();
    }

    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn push(
        &mut self,
        k: usize,
        depth: f32,
        alpha: f32,
        p: Vec3,
        t: Vec3,
        fiber: Fiber,
    ) {
        self.k.push(k as u32);
        self.depth.push(depth);
        self.alpha.push(alpha);
        self.p.push(p);
        self.t.push(t);
        self.fiber.push(fiber);
    }
}
