//! Per-vertex shading on demand (`shading = "vertex"` with MLAB or sorted
//! transparency): a strand vertex is shaded when a tile first draws a
//! fragment of a segment that ends at it, not before the tiles for every
//! vertex in view.
//!
//! Most vertices in the view frustum are never read: hair behind the
//! opaque head or behind hair whose transmittance fell under the cut-off
//! draws no fragment (the demo head at 1280×720 reads 41% of the vertices
//! in view, the dense heads about 64%).
//!
//! A tile collects its strand fragments ([`crate::raster::tile`]), shades
//! the vertices they need that no tile has shaded yet in one batch on the
//! model's vector kernel, publishes them, and only then adds the fragments
//! to its layers in the order they were drawn. Each vertex is shaded with
//! the same inputs as [`super::shade_vertices`] (its position, the tangent
//! along its neighbours, its radius and fiber, the direction to the eye),
//! and a vector kernel lane depends on its own inputs alone, so its value
//! does not depend on the batch, the tile or the thread that shades it:
//! two tiles that shade the same vertex at once store the same bits. The
//! image equals the one shaded beforehand bit for bit (`vertices.rs` test
//! 1; `tests/test_render.py` test 24, on one thread and on all).

use super::vertices::{vertex_fiber, vertex_tangent};
use super::Shader;
use crate::raster::scene::Strands;
use glam::Vec3;
use std::sync::atomic::{AtomicU32, Ordering};

/// The radiance of each strand vertex, shaded on first use.
pub struct VertexColors<'a> {
    strands: &'a Strands,
    shader: &'a Shader<'a>,
    eye: Vec3,
    /// Per vertex: the radiance's bits and a word that is 1 once they are
    /// published.
    words: Vec<[AtomicU32; 4]>,
}

/// A thread's buffers for [`VertexColors::fetch`].
#[derive(Default)]
pub struct FetchScratch {
    todo: Vec<u32>,
    points: Vec<Vec3>,
    tangents: Vec<Vec3>,
    fibers: Vec<super::Fiber>,
    shaded: Vec<Vec3>,
}

impl<'a> VertexColors<'a> {
    /// No vertex shaded yet, for the vertices of `strands` seen from `eye`.
    pub fn new(strands: &'a Strands, shader: &'a Shader<'a>, eye: Vec3) -> Self {
        use rayon::prelude::*;
        let words = crate::threads::pool().install(|| {
            (0..strands.points.len())
                .into_par_iter()
                .map(|_| std::array::from_fn(|_| AtomicU32::new(0)))
                .collect()
        });
        Self {
            strands,
            shader,
            eye,
            words,
        }
    }

    /// The published radiance of vertex `i`, if it has been shaded.
    #[inline]
    fn get(&self, i: u32) -> Option<Vec3> {
        let w = &self.words[i as usize];
        (w[3].load(Ordering::Acquire) == 1).then(|| {
            Vec3::new(
                f32::from_bits(w[0].load(Ordering::Relaxed)),
                f32::from_bits(w[1].load(Ordering::Relaxed)),
                f32::from_bits(w[2].load(Ordering::Relaxed)),
            )
        })
    }

    /// Makes sure every vertex in `index` (pairs of a vertex and its
    /// strand; sorted and deduplicated here) is shaded: those not
    /// published yet are shaded in one batch on this thread and published.
    pub fn fetch(&self, index: &mut Vec<(u32, u32)>, scratch: &mut FetchScratch) {
        let st = self.strands;
        index.sort_unstable();
        index.dedup();
        scratch.todo.clear();
        scratch.points.clear();
        scratch.tangents.clear();
        scratch.fibers.clear();
        for &(i, s) in index.iter() {
            if self.words[i as usize][3].load(Ordering::Acquire) == 1 {
                continue;
            }
            scratch.todo.push(i);
            scratch.points.push(st.points[i as usize]);
            scratch
                .tangents
                .push(vertex_tangent(st, s as usize, i as usize));
            scratch
                .fibers
                .push(vertex_fiber(st, s as usize, i as usize));
        }
        if scratch.todo.is_empty() {
            return;
        }
        let n = scratch.todo.len();
        scratch.shaded.clear();
        scratch.shaded.resize(n, Vec3::ZERO);
        if self.shader.batches() {
            self.shader.shade_serial(
                &scratch.points,
                &scratch.tangents,
                &scratch.fibers,
                self.eye,
                &mut scratch.shaded,
            );
        } else {
            for j in 0..n {
                let p = scratch.points[j];
                scratch.shaded[j] = self.shader.shade(
                    p,
                    scratch.tangents[j],
                    (self.eye - p).normalize_or_zero(),
                    scratch.fibers[j],
                );
            }
        }
        for (&i, c) in scratch.todo.iter().zip(&scratch.shaded) {
            let w = &self.words[i as usize];
            for (slot, v) in w[..3].iter().zip(c.to_array()) {
                slot.store(v.to_bits(), Ordering::Relaxed);
            }
            w[3].store(1, Ordering::Release);
        }
    }

    /// The radiance of vertex `i`, after [`Self::fetch`] listed it.
    #[inline]
    pub fn color(&self, i: u32) -> Vec3 {
        self.get(i)
            .expect("vertex colour read before it was fetched")
    }

    /// How many vertices have been shaded.
    pub fn shaded_count(&self) -> usize {
        self.words
            .iter()
            .filter(|w| w[3].load(Ordering::Relaxed) == 1)
            .count()
    }
}
