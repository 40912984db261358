//! Near-field single scattering per coverage sample (ChiangHair).
//!
//! The far field is the near field averaged over the offset `h ∈ [−1, 1]`
//! across the fiber, which is what a pixel sees of a fiber it sees whole.
//! In dense hair a fiber is often seen only in part: the fibers in front
//! hide one side of it, and the visible offsets are no longer uniform. The
//! R lobe is brightest towards the edges and TT at the centre, so the far
//! field made a top-lit black head 9 % too dark and a backlit blond one
//! 15 % too bright in single scattering against path tracing (Mitsuba,
//! max_depth 2, `docs/dense_hair.md`).
//!
//! With coverage samples each sample knows the fiber it sees and where:
//! its distance from the fiber's projected centre line over the projected
//! half width is `h` (signed along `u = t × v⊥`, with `v⊥` the view's
//! projection on the normal plane). The fiber's surface normal there is
//! `n = √(1 − h²) v⊥ + h u`, the frame of [`crate::fiber::frame`] is
//! `(t × n, t, n)`, and in it the near field of the model gives the
//! sample's unscattered single scattering of each light, as a path tracer's
//! hit does. Everything else of a fragment (the environment's directions,
//! dual scattering's scattered and back-scattered light, the light the head
//! reflects) stays in the far field, shaded once per fragment.
//!
//! A light's traced visibility is taken across the fiber: one shadow ray
//! from the surface point `p + r·n(h_k)` at the centre `h_k` of each of
//! [`VIS_OFFSETS`] equal bins of [−1, 1] that a bisection probes (the edges
//! and the centre, then wherever two probes disagree), and each sample
//! takes its bin's.
//! In dense hair the fibers around a fiber lie within a few radii of it, so
//! what reaches its surface changes around its circumference: on a backlit
//! wavy head, path-traced hits at the edges of the visible fibers (where
//! |h| is near one) see the light 3-5 times as often as those at the
//! centre, and one ray from the point facing the viewer made the rim 35 %
//! too dark (Mitsuba's own hits, traced through the same polylines: 0.054
//! of them see the light, the facing points 0.033). Shadow maps and fiber
//! counts stay per fragment.

use super::{Fiber, HairShading, Shader};
use crate::raster::setup::Segment;
use crate::raster::view::View;
use glam::Vec3;

/// The offsets across a fiber at which the near field samples a light's
/// traced visibility.
pub const VIS_OFFSETS: usize = 64;

/// The offsets probed first, evenly from edge to edge. On the dense and
/// held-out heads 5 probes give single scattering within 0.5 % of tracing
/// all 64 bins, 3 probes within 1.8 % (light through a gap between two
/// neighbours falls between probes that both see a neighbour), 9 within
/// 0.2 %, at 1.1x, 1.0x and 1.25x the frame time of 5.
const PROBES: usize = 5;

/// A light as the near field shades it at a fragment's samples.
#[derive(Debug, Clone, Copy)]
pub struct NearLight {
    /// Unit direction towards the light.
    pub dir: Vec3,
    /// Irradiance times what reaches the fragment by the shadow maps and
    /// fiber counts.
    pub irradiance: Vec3,
    /// The traced visibility per bin of offsets, bin k in bit k (all set
    /// without traced shadows).
    pub visible: u64,
}

/// The bin of offset `h ∈ [−1, 1]`.
#[inline]
fn offset_bin(h: f32) -> usize {
    (((h + 1.0) * 0.5 * VIS_OFFSETS as f32) as usize).min(VIS_OFFSETS - 1)
}

impl Shader<'_> {
    /// Whether coverage samples shade the lights' single scattering by the
    /// near field (ChiangHair, coverage samples, `render.near_field`).
    pub fn near_field(&self) -> bool {
        self.near
    }

    /// [`Shader::shade`] without the lights' unscattered single scattering,
    /// which [`Shader::near_single`] adds per sample; the lights that reach
    /// the point are pushed to `lights` as (direction, irradiance ×
    /// visibility, with the traced visibility per bin of offsets).
    pub fn shade_split(
        &self,
        p: Vec3,
        t: Vec3,
        v: Vec3,
        fiber: Fiber,
        lights: &mut Vec<NearLight>,
    ) -> Vec3 {
        self.shade_impl(p, t, v, fiber, Some(lights))
    }

    /// Light `li`'s traced visibility from the surface points of the fiber
    /// at axis point `p` (tangent `t`, seen from `v`) at the bins' centres
    /// (all 1 where the light's shadows are not traced).
    pub(super) fn offset_visibility(
        &self,
        li: usize,
        p: Vec3,
        t: Vec3,
        v: Vec3,
        fiber: &Fiber,
    ) -> u64 {
        let origin = |k: usize| {
            let h = -1.0 + (2 * k + 1) as f32 / VIS_OFFSETS as f32;
            surface_frame(t, v, h).map_or(p, |(_, n)| p + n * self.lookup_radius(fiber))
        };
        let visible = |k: usize| !self.traced_occluded(li, origin(k), fiber);
        // PROBES offsets from edge to edge first; then each interval whose
        // ends disagree is halved until its ends are neighbours (the edge
        // of a shadow located to one bin, 1/32 of the radius), and the bins
        // between two probes that agree take their value: PROBES rays for a
        // fiber in full light or in full shadow (most of them), 4 more per
        // shadow edge.
        let mut out = [false; VIS_OFFSETS];
        // probe k at bin k·(VIS_OFFSETS − 1)/(PROBES − 1)
        let at = |k: usize| k * (VIS_OFFSETS - 1) / (PROBES - 1);
        // (the intervals between probes, and at most log2 of the widest
        // more while one is halved)
        let mut stack = [(0usize, 0usize); PROBES + 8];
        let mut n = 0;
        // the probes' rays walked together where they can be (the same
        // answers: traced::bundle), else one by one
        let probes: [Vec3; PROBES] = std::array::from_fn(|k| origin(at(k)));
        let together = self.traced_occluded_bundle(li, p, &probes, fiber);
        for k in 0..PROBES {
            out[at(k)] = match together {
                Some(blocked) => blocked & (1 << k) == 0,
                None => visible(at(k)),
            };
            if k > 0 {
                stack[n] = (at(k - 1), at(k));
                n += 1;
            }
        }
        while n > 0 {
            n -= 1;
            let (lo, hi) = stack[n];
            let v_lo = out[lo];
            if v_lo == out[hi] {
                out[lo + 1..hi].fill(v_lo);
            } else if hi > lo + 1 {
                let m = (lo + hi) / 2;
                out[m] = visible(m);
                stack[n] = (lo, m);
                stack[n + 1] = (m, hi);
                n += 2;
            }
        }
        out.iter()
            .enumerate()
            .fold(0u64, |bits, (k, &lit)| bits | ((lit as u64) << k))
    }

    /// The unscattered single scattering towards `v` of `lights` (from
    /// [`Self::shade_split`]) by a fiber of tangent `t` seen at offset `h`.
    pub fn near_single(&self, t: Vec3, v: Vec3, h: f32, lights: &[NearLight]) -> Vec3 {
        let HairShading::ChiangFar(c) = &self.hair else {
            return Vec3::ZERO;
        };
        let Some((x, n)) = surface_frame(t, v, h) else {
            return Vec3::ZERO;
        };
        let local = |w: Vec3| [w.dot(x), w.dot(t), w.dot(n)];
        let wi = local(v);
        let model = c.model();
        let bin = offset_bin(h);
        let mut out = Vec3::ZERO;
        for l in lights {
            if l.visible >> bin & 1 == 1 {
                // Mitsuba's convention: wi towards the viewer, wo towards the light.
                out += Vec3::from(model.eval(&wi, &local(l.dir))) * l.irradiance;
            }
        }
        out
    }
}

/// The local x axis and the surface normal of a fiber of unit tangent `t`
/// seen from `v` at offset `h`: `n = √(1 − h²) v⊥ + h u`, `u = t × v⊥`,
/// `x = t × n` (None when `v` is along the fiber).
#[inline]
pub fn surface_frame(t: Vec3, v: Vec3, h: f32) -> Option<(Vec3, Vec3)> {
    let vp = (v - t * t.dot(v)).try_normalize()?;
    let u = t.cross(vp);
    let h = h.clamp(-1.0, 1.0);
    let n = vp * (1.0 - h * h).max(0.0).sqrt() + u * h;
    Some((t.cross(n), n))
}

/// The screen line of a strand fragment for the offset of a sample:
/// `[cx, cy, ux, uy]` with `h = (x − cx)·ux + (y − cy)·uy` for a sample at
/// `(x, y)` (clamped to [−1, 1] by the caller). `c` is the centre line's
/// point at screen parameter `ts` of segment `s`; `u` its unit normal on
/// screen, oriented as the world offset `t × v⊥` of the fiber at world point
/// `pw` (tangent `t`, radius `r`) projects, over the half width there.
pub fn offset_line(view: &View, s: &Segment, ts: f32, pw: Vec3, t: Vec3, r: f32) -> [f32; 4] {
    let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
    let c = [s.a[0] + ts * d[0], s.a[1] + ts * d[1]];
    let half = 0.5 * (s.wa + (s.wb - s.wa) * ts);
    let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
    if !(len > 0.0 && half > 0.0) {
        return [c[0], c[1], 0.0, 0.0];
    }
    let mut perp = [-d[1] / len, d[0] / len];
    let v = (view.eye - pw).normalize_or_zero();
    let u = t.cross((v - t * t.dot(v)).normalize_or_zero());
    let on_screen = |w: Vec3| view.project2(view.to_view(w));
    let (a, b) = (on_screen(pw), on_screen(pw + u * r.max(1e-6)));
    if (b[0] - a[0]) * perp[0] + (b[1] - a[1]) * perp[1] < 0.0 {
        perp = [-perp[0], -perp[1]];
    }
    [c[0], c[1], perp[0] / half, perp[1] / half]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fiber::chiang::{ChiangFarTable, TableSize};
    use crate::fiber::{ChiangHair, ChiangParams};
    use crate::raster::scene::Camera;

    /// 1. The near field averaged over uniform offsets is the far field:
    ///    over h ∈ [−1, 1] (Gauss–Legendre, 256 nodes; the near field's
    ///    narrowest azimuthal lobe, β_n = 0.3, is smooth at that spacing)
    ///    in the frame `surface_frame` builds, against the tabulated far
    ///    field (which matches the converged quadrature to 5e-4, issue
    ///    tests of `fiber::chiang::table`), for light and dark hair and
    ///    views and lights all round. Gate: 1% of the largest channel
    ///    plus 1e-4 absolute (measured below 0.4%).
    #[test]
    fn t01_offset_average_is_the_far_field() {
        let (hn, hw) = crate::math::gauss_legendre(256);
        for sigma_a in [[0.06, 0.1, 0.2], [1.5, 2.0, 3.0]] {
            let m: ChiangHair<f64> = ChiangParams {
                sigma_a: Some(sigma_a),
                azimuthal_roughness: 0.3,
                ..Default::default()
            }
            .build()
            .unwrap();
            let table = ChiangFarTable::new(&m, TableSize::for_scale(m.logistic_scale()));
            let model = table.model();
            let t = Vec3::new(0.3, 1.0, -0.2).normalize();
            for (v, l) in [
                (Vec3::new(0.0, 0.2, 1.0), Vec3::new(1.0, 0.5, 0.3)),
                (Vec3::new(0.6, -0.3, 0.7), Vec3::new(-0.5, 0.1, -0.8)),
                (Vec3::new(-0.2, 0.7, 0.4), Vec3::new(0.1, 0.9, 0.6)),
            ] {
                let (v, l) = (v.normalize(), l.normalize());
                let mut avg = Vec3::ZERO;
                for (h, w) in hn.iter().zip(&hw) {
                    let (x, n) = surface_frame(t, v, *h as f32).unwrap();
                    let local = |w: Vec3| [w.dot(x), w.dot(t), w.dot(n)];
                    avg += Vec3::from(model.eval(&local(v), &local(l))) * (0.5 * *w as f32);
                }
                let far = super::super::chiang_far(&table, t, v, l);
                let err = (avg - far).abs().max_element();

                assert!(
                    err <= 0.01 * far.max_element() + 1e-4,
                    "{sigma_a:?} v {v} l {l}: {avg} vs {far}"
                );
            }
        }
    }

    /// 2. The offset of a sample is where the fiber is: the world point
    ///    `p + u·r·h` (u = t × v⊥, r the radius), projected, gives back h
    ///    from the line of `offset_line`, on both sides, for fibers across
    ///    the view in several orientations (to 1e-3; measured 1.2e-4, the
    ///    perspective's curvature over the width and f32 rounding).
    #[test]
    fn t02_sample_offset_is_the_world_offset() {
        let cam = Camera {
            position: Vec3::new(0.3, 0.2, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 40.0,
            width: 640,
            height: 360,
        };
        let view = View::new(&cam, 1.0);
        let on_screen = |w: Vec3| view.project2(view.to_view(w));
        let r = 0.004;
        for (pa, pb) in [
            (Vec3::new(-0.5, 0.0, 0.0), Vec3::new(0.5, 0.1, 0.2)),
            (Vec3::new(0.1, -0.4, 0.3), Vec3::new(-0.2, 0.5, -0.1)),
            (Vec3::new(0.4, 0.3, -0.5), Vec3::new(-0.3, -0.2, 0.4)),
        ] {
            let (a, b) = (on_screen(pa), on_screen(pb));
            // widths as `setup::project_segments` draws them
            let tau = (view.to_view(pb) - view.to_view(pa)).normalize();
            let w = |p: Vec3| view.fiber_width(view.to_view(p), tau, r);
            let mut s = Segment::on_screen(a, b, (w(pa), w(pb)), false);
            s.pa = pa;
            s.pb = pb;
            let t = (pb - pa).normalize();
            // the centre of the segment in world and on screen
            let pw = (pa + pb) * 0.5;
            let c2 = on_screen(pw);
            let d = [b[0] - a[0], b[1] - a[1]];
            let ts = ((c2[0] - a[0]) * d[0] + (c2[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]);
            let line = offset_line(&view, &s, ts, pw, t, r);
            let v = (view.eye - pw).normalize();
            let u = t.cross((v - t * t.dot(v)).normalize());
            for h in [-0.8f32, -0.3, 0.5, 0.9] {
                let q = on_screen(pw + u * (r * h));
                let got = (q[0] - line[0]) * line[2] + (q[1] - line[1]) * line[3];
                assert!((got - h).abs() < 1e-3, "{h}: {got}");
            }
        }
    }
}
