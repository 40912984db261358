//! The end of a tile: its strand fragments given their vertices' radiance
//! (on-demand per-vertex shading), its collected hair fragments shaded (in
//! one batch where the model has a vector kernel; in coverage mode only
//! those that own a sample), and the resolve of every pixel (the transparency layers
//! composited over the opaque surface; non-finite pixels become 0 and are
//! counted).

use super::pending::Pending;
use super::{Tile, TileMemory, TileResult};
use crate::raster::bin::TILE;
use crate::raster::samples::SAMPLES;
use crate::raster::shade::{Fiber, Shader};
use crate::raster::shadow::ShadowModel;
use glam::Vec3;

impl Tile<'_> {
    /// The collected strand fragments (on-demand per-vertex shading): the
    /// vertices of their segments that no tile has shaded yet, shaded in
    /// one batch, then every fragment added to the layers in the order it
    /// was drawn, with the radiance per-vertex shading gives it (as if
    /// every vertex had been shaded before the tiles: the same bits).
    pub(super) fn add_vertex_shaded(&mut self) {
        let Some(colors) = self.ctx.vertex_colors else {
            return;
        };
        let segs = self.ctx.segs;
        let vp = &mut self.vertex_pending;
        if vp.k.is_empty() {
            return;
        }
        // An end clipped at the near plane carries its own radiance
        // (shaded where it lies before the tiles); the others are vertices.
        vp.need.clear();
        for &(si, _) in &vp.runs {
            let s = &segs[si as usize];
            if s.ta == 0.0 {
                vp.need.push((s.i, s.strand));
            }
            if s.tb == 1.0 {
                vp.need.push((s.i + 1, s.strand));
            }
        }
        colors.fetch(&mut vp.need, &mut vp.scratch);
        for (r, &(si, start)) in vp.runs.iter().enumerate() {
            let s = &segs[si as usize];
            let ca = if s.ta == 0.0 { colors.color(s.i) } else { s.ca };
            let cb = if s.tb == 1.0 {
                colors.color(s.i + 1)
            } else {
                s.cb
            };
            let end = vp.runs.get(r + 1).map_or(vp.k.len(), |x| x.1 as usize);
            for f in start as usize..end {
                let c = ca + (cb - ca) * vp.tw[f];
                self.layers
                    .add(vp.k[f] as usize, vp.depth[f], c, vp.alpha[f]);
            }
        }
    }

    /// The collected fragments, shaded in one batch and composited in the
    /// order they were produced.
    pub(super) fn shade_pending(&mut self) {
        if self.samples.is_some() {
            self.shade_visible();
            return;
        }
        if !self.deferred {
            return;
        }
        let p = &mut self.pending;
        // the fragments without per-vertex radiance, in one batch; then all in order
        let todo: Vec<usize> = (0..p.k.len()).filter(|&i| p.color[i].is_nan()).collect();
        shade_batch(self.ctx.shader, self.ctx.view.eye, p, &todo);
        for i in 0..p.k.len() {
            self.layers
                .add(p.k[i] as usize, p.depth[i], p.color[i], p.alpha[i]);
        }
    }

    /// Coverage mode: the fragments that own a sample, shaded (in one batch
    /// where the model has a vector kernel); the others are never shaded.
    fn shade_visible(&mut self) {
        let Some((_, buf)) = &self.samples else {
            return;
        };
        let p = &mut self.pending;
        let mut counts = vec![0u32; p.k.len()];
        buf.counts(&mut counts);
        // (strand fragments under per-vertex shading carry their radiance)
        let visible: Vec<usize> = (0..counts.len())
            .filter(|&i| counts[i] > 0 && p.color[i].is_nan())
            .collect();
        let eye = self.ctx.view.eye;
        p.near.clear();
        p.near.resize(p.k.len(), (0, 0));
        p.lights.clear();
        if self.ctx.shader.near_field() {
            // strands: all but the lights' single scattering, which each
            // sample adds by the near field (`pixel`)
            for &i in &visible {
                let v = (eye - p.p[i]).normalize_or_zero();
                p.color[i] = if p.line[i][0].is_nan() {
                    self.ctx.shader.shade(p.p[i], p.t[i], v, p.fiber[i])
                } else {
                    let start = p.lights.len() as u32;
                    let c =
                        self.ctx
                            .shader
                            .shade_split(p.p[i], p.t[i], v, p.fiber[i], &mut p.lights);
                    p.near[i] = (start, p.lights.len() as u32);
                    c
                };
            }
        } else if self.ctx.shader.batches() {
            shade_batch(self.ctx.shader, eye, p, &visible);
        } else {
            for &i in &visible {
                p.color[i] = self.ctx.shader.shade(
                    p.p[i],
                    p.t[i],
                    (eye - p.p[i]).normalize_or_zero(),
                    p.fiber[i],
                );
            }
        }
    }

    /// Pixel `k`: the layers composited over the opaque radiance, or in
    /// coverage mode the mean over its samples of the owner's radiance
    /// (the opaque radiance where no hair covers a sample). The opaque
    /// radiance is computed only where it is seen: where the hair's
    /// transmittance is above 0, or above the hair-culling cutoff (which
    /// bounds what is left out by cutoff × its radiance, as for the hair
    /// behind).
    fn pixel(&mut self, k: usize) -> Vec3 {
        // Traced shadows are exact per point: an opaque surface is then
        // shaded where each uncovered sample sees it, not once at the pixel
        // centre (a fiber's shadow is thinner than a pixel; one point made
        // it 0 or 1 for the whole pixel).
        let per_sample =
            self.surface[k].is_some() && self.ctx.opts.shadow_model == ShadowModel::Traced;
        // The points are read for a surface shaded per sample and for the
        // near field of the fragments owning samples, whose pixels computed
        // them when the fragments covered them; a pixel with neither never
        // computes them, and reads NaN (none of it is read).
        if per_sample {
            if let Some((pts, _)) = &mut self.samples {
                pts.fill(k);
            }
        }
        match &self.samples {
            Some((pts, buf)) => {
                const UNREAD: [[f32; 2]; SAMPLES.1] = [[f32::NAN; 2]; SAMPLES.1];
                let points = pts.computed(k).unwrap_or(&UNREAD[..buf.n]);
                let mut c = Vec3::ZERO;
                let mut uncovered = 0u32;
                let pd = &self.pending;
                for (o, xy) in buf.owners(k).zip(points) {
                    match o {
                        Some(i) if pd.near.get(i as usize).is_some_and(|r| r.1 > r.0) => {
                            // the near field at the sample's offset
                            let i = i as usize;
                            let (l, (a, b)) = (pd.line[i], pd.near[i]);
                            let h = (xy[0] - l[0]) * l[2] + (xy[1] - l[1]) * l[3];
                            let v = (self.ctx.view.eye - pd.p[i]).normalize_or_zero();
                            let lights = &pd.lights[a as usize..b as usize];
                            c += pd.color[i]
                                + self.ctx.shader.near_single(
                                    pd.t[i],
                                    v,
                                    h.clamp(-1.0, 1.0),
                                    lights,
                                );
                        }
                        Some(i) => c += pd.color[i as usize],
                        None if per_sample => c += self.surface_at(k, *xy),
                        None => uncovered += 1,
                    }
                }
                if uncovered > 0 {
                    c += self.base(k) * uncovered as f32;
                }
                c / buf.n as f32
            }
            None => {
                let (c, t) = self.layers.composite(k);
                if t > self.ctx.opts.hair_cull_transmittance.max(0.0) {
                    c + self.base(k) * t
                } else {
                    c
                }
            }
        }
    }

    /// The pixels resolved (non-finite pixels become 0 and are counted),
    /// and the tile's buffers for the next tile.
    pub(super) fn resolve(mut self) -> (TileResult, TileMemory) {
        let mut pixels = vec![0.0f32; (TILE * TILE * 3) as usize];
        let mut non_finite = 0u64;
        for j in 0..self.th {
            for i in 0..self.tw {
                let k = (j * TILE + i) as usize;
                let col = self.pixel(k);
                if col.is_finite() {
                    pixels[3 * k..3 * k + 3].copy_from_slice(&col.to_array());
                } else {
                    non_finite += 1;
                }
            }
        }
        let result = TileResult {
            pixels,
            fragments: self.fragments,
            non_finite,
            culled: self.culled,
            hair_culled: self.hair_culled,
        };
        let memory = TileMemory {
            opaque_depth: self.opaque_depth,
            surface: self.surface,
            layers: Some(self.layers),
            pending: self.pending,
            hair: self.hair.or(self.spare_hair),
            vertex_pending: self.vertex_pending,
        };
        (result, memory)
    }
}

/// Shades the pending fragments `which` on the model's vector kernel (one
/// batch) into their `color`.
fn shade_batch(shader: &Shader, eye: Vec3, p: &mut Pending, which: &[usize]) {
    if which.is_empty() {
        return;
    }
    let pts: Vec<Vec3> = which.iter().map(|&i| p.p[i]).collect();
    let tan: Vec<Vec3> = which.iter().map(|&i| p.t[i]).collect();
    let fib: Vec<Fiber> = which.iter().map(|&i| p.fiber[i]).collect();
    let mut colors = vec![Vec3::ZERO; which.len()];
    shader.shade_serial(&pts, &tan, &fib, eye, &mut colors);
    for (&i, c) in which.iter().zip(colors) {
        p.color[i] = c;
    }
}
