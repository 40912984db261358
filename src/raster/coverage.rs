//! Coverage: which sample points a primitive covers and by how much. Strand
//! segments have analytic anti-aliased coverage (a box filter of one pixel
//! over the strand's width, butt joints, a round tip); triangles (cards,
//! meshes, shadow-map texels) are tested by barycentrics at sample centres;
//! spheres by a ray.

use super::bin::TILE;
use super::setup::Segment;
use super::view::View;
use crate::math::{ceil, floor};
use glam::Vec3;

/// An inclusive pixel rectangle, unclamped (may reach off screen).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelBox {
    pub x0: i64,
    pub x1: i64,
    pub y0: i64,
    pub y1: i64,
}

impl PixelBox {
    /// The part inside `[0, w) × [0, h)` after shifting by `(-ox, -oy)`
    /// (tile-local coordinates; empty ranges when outside).
    #[inline]
    pub fn local(&self, ox: u32, oy: u32, w: u32, h: u32) -> PixelBox {
        PixelBox {
            x0: (self.x0 - ox as i64).max(0),
            x1: (self.x1 - ox as i64).min(w as i64 - 1),
            y0: (self.y0 - oy as i64).max(0),
            y1: (self.y1 - oy as i64).min(h as i64 - 1),
        }
    }
}

/// A 2D triangle's signed doubled area and pixel bounding box, for
/// barycentric rasterization.
pub struct Tri2 {
    p: [[f32; 2]; 3],
    area: f32,
    /// Pixel bounds, unclamped.
    pub bounds: PixelBox,
}

impl Tri2 {
    /// None when degenerate or non-finite.
    pub fn new(p: [[f32; 2]; 3]) -> Option<Self> {
        let area =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
        if area.abs() < 1e-12 || !area.is_finite() {
            return None;
        }
        let (xs, ys) = (p.map(|q| q[0]), p.map(|q| q[1]));
        let bounds = PixelBox {
            x0: floor(xs[0].min(xs[1]).min(xs[2])) as i64,
            x1: ceil(xs[0].max(xs[1]).max(xs[2])) as i64,
            y0: floor(ys[0].min(ys[1]).min(ys[2])) as i64,
            y1: ceil(ys[0].max(ys[1]).max(ys[2])) as i64,
        };
        Some(Self { p, area, bounds })
    }

    /// Barycentric coordinates of `s`, or None outside the triangle.
    #[inline]
    pub fn barycentric(&self, s: [f32; 2]) -> Option<[f32; 3]> {
        let edge = |a: [f32; 2], b: [f32; 2]| {
            (b[0] - a[0]) * (s[1] - a[1]) - (s[0] - a[0]) * (b[1] - a[1])
        };
        let p = &self.p;
        let b = [
            edge(p[1], p[2]) / self.area,
            edge(p[2], p[0]) / self.area,
            edge(p[0], p[1]) / self.area,
        ];
        (b[0] >= 0.0 && b[1] >= 0.0 && b[2] >= 0.0).then_some(b)
    }
}

/// The pixels of the tile-local box `b` (tile origin `(ox, oy)`) whose
/// centres a projected triangle covers, as `(k, w, depth)`: the tile pixel
/// index, the perspective weights `w = b/z` (barycentrics over the corners'
/// view depths `z`) and the interpolated depth `1/Σw`.
#[inline]
pub fn triangle_pixels<'a>(
    tri: &'a Tri2,
    z: &'a [f32; 3],
    b: PixelBox,
    ox: u32,
    oy: u32,
) -> impl Iterator<Item = (usize, [f32; 3], f32)> + 'a {
    (b.y0..=b.y1)
        .flat_map(move |j| (b.x0..=b.x1).map(move |i| (i, j)))
        .filter_map(move |(i, j)| {
            let k = (j as u32 * TILE + i as u32) as usize;
            let p = [(ox as i64 + i) as f32 + 0.5, (oy as i64 + j) as f32 + 0.5];
            let bc = tri.barycentric(p)?;
            let w = [bc[0] / z[0], bc[1] / z[1], bc[2] / z[2]];
            Some((k, w, 1.0 / (w[0] + w[1] + w[2])))
        })
}

/// Nearest positive ray parameter of a ray-sphere hit from outside; None
/// when the ray misses, the sphere is behind, or the origin is inside it
/// (a sphere's inside is not drawn).
#[inline]
pub fn ray_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<f32> {
    let oc = o - c;
    let b = oc.dot(d);
    let cc = oc.length_squared() - r * r;
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let t0 = -b - disc.sqrt();
    (t0 > 0.0).then_some(t0)
}

/// A cone around the rays from the eye through the centres of a
/// rectangle of pixels, to skip the spheres no ray of it can hit.
pub struct RayCone {
    axis: Vec3,
    half_angle: f32,
}

impl RayCone {
    /// The cone of the `w × h` pixels from `(x0, y0)`: its axis is the mean
    /// of the four corner pixels' rays, its half-angle the largest angle
    /// from the axis to one of them (every other pixel's ray lies in their
    /// spherical quadrilateral, which a cap narrower than a hemisphere
    /// around the axis holds once it holds its corners).
    pub fn through_pixels(view: &View, x0: u32, y0: u32, w: u32, h: u32) -> Self {
        let (x1, y1) = (x0 + w.max(1) - 1, y0 + h.max(1) - 1);
        let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
            .map(|(x, y)| view.ray(x as f32 + 0.5, y as f32 + 0.5));
        let axis = (corners[0] + corners[1] + corners[2] + corners[3]).normalize();
        let cos_min = corners.iter().map(|c| c.dot(axis)).fold(1.0f32, f32::min);
        Self {
            axis,
            half_angle: cos_min.clamp(-1.0, 1.0).acos(),
        }
    }

    /// Whether a ray of the cone may hit the sphere `(center, radius)` from
    /// outside: false only when the sphere's angular extent seen from `eye`
    /// lies wholly outside the cone, by a margin of 1e-3 radian over f32
    /// rounding of the rays (errors near 1e-6), or when the eye is inside
    /// the sphere ([`ray_sphere`] reports no hit then). Non-finite input
    /// may hit.
    pub fn may_hit(&self, eye: Vec3, center: Vec3, radius: f32) -> bool {
        let to = center - eye;
        let dist = to.length();
        if !(dist > radius) {
            return !(dist <= radius);
        }
        let extent = (radius / dist).asin();
        let apart = (to / dist).dot(self.axis).clamp(-1.0, 1.0).acos();
        !(apart > self.half_angle + extent + 1e-3)
    }
}

/// The pixels of a row that a segment can cover: those whose centers lie
/// within `r` (the widest half-width plus the half-pixel filter) of the
/// segment's line, widened by 0.01 pixel against rounding. Conservative:
/// [`coverage`] still decides every pixel, so the image is the same as
/// visiting the whole bounding box.
pub struct RowSpan {
    a: [f32; 2],
    /// `dx/dy` of the line, and the half-width of a row's span `r|d|/|dy|`
    /// (once per segment: a row then costs a multiply-add).
    slope: f32,
    half: f32,
    /// The whole bounding box: a line nearly parallel to the rows, or a
    /// width not finite.
    whole: bool,
}

impl RowSpan {
    pub fn new(s: &Segment, r: f32) -> Self {
        let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
        let r_len = r * (d[0] * d[0] + d[1] * d[1]).sqrt();
        Self {
            a: s.a,
            slope: d[0] / d[1],
            half: r_len / d[1].abs(),
            whole: d[1].abs() < 1e-6 || !r_len.is_finite(),
        }
    }

    /// Tile-local pixel range `[lo, hi]` within `[bx0, bx1]` of the row
    /// whose centers have y = `py`, in the tile starting at `x0`; None if empty.
    #[inline]
    pub fn pixels(&self, py: f32, x0: u32, bx0: u32, bx1: u32) -> Option<(u32, u32)> {
        // |(x − ax) dy − (py − ay) dx| ≤ r|d| bounds x when dy ≠ 0.
        if self.whole {
            return Some((bx0, bx1));
        }
        let (c, half) = (self.a[0] + (py - self.a[1]) * self.slope, self.half);
        // Pixel centers x0 + i + 0.5 within [c − half, c + half], widened by
        // 0.01 pixel against rounding (f32 coordinates below 2^14 pixels
        // carry errors below 1e-3 pixel, the slope's rounding included): i
        // from ⌈c − half − x0 − 0.51⌉ to
        // ⌊c + half − x0 − 0.49⌋. Truncation stands in for both (⌊⌋ on the
        // clamped, non-negative values: at most one extra pixel; the
        // baseline ISA has no rounding instruction, floor/ceil are calls).
        let lo = c - half - x0 as f32 - 0.51;
        let hi = c + half - x0 as f32 - 0.49;
        if !(lo.is_finite() && hi.is_finite()) {
            return Some((bx0, bx1));
        }
        if hi < 0.0 {
            return None;
        }
        let lo = (lo.clamp(0.0, 1e6) as u32).max(bx0);
        let hi = (hi.min(1e6) as i64).min(bx1 as i64);
        (hi >= lo as i64).then_some((lo, hi as u32))
    }
}

/// The parameter along segment `s` of the centre-line point nearest a
/// sample whose unclamped parameter is `t_raw`, or None where the sample
/// belongs to a neighbouring segment: butt joints (each sample belongs to
/// one segment of a polyline, no double coverage at vertices) and a round
/// tip at the strand's end. A degenerate segment (`has_length` false)
/// keeps every sample, at t = 0.
#[inline]
pub fn on_stretch(s: &Segment, t_raw: f32, has_length: bool) -> Option<f32> {
    (on_stretch_at(s.last, t_raw) || !has_length).then(|| t_raw.clamp(0.0, 1.0))
}

/// Whether the raw parameter `t_raw` lies on a segment's stretch (the
/// strand's `last` segment runs on past its end): [`on_stretch`] without
/// a branch, for vector lanes.
#[inline(always)]
pub fn on_stretch_at(last: bool, t_raw: f32) -> bool {
    (t_raw >= 0.0) & (last | (t_raw < 1.0))
}

/// Coverage of pixel center `p` by segment `s`, and the screen parameter t
/// (what the tile's strand pass computes in two steps, depth tests between).
#[cfg(test)]
pub fn coverage(s: &Segment, p: [f32; 2]) -> Option<(f32, f32)> {
    let t = stretch_param(s, p)?;
    let cov = coverage_at(s, p, t);
    (cov > 0.0).then_some((cov, t))
}

/// The screen parameter t along segment `s` of the centre-line point
/// nearest pixel center `p`, or None where `p` belongs to a neighbouring
/// segment ([`on_stretch`]).
#[inline]
pub fn stretch_param(s: &Segment, p: [f32; 2]) -> Option<f32> {
    let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t_raw = if len2 > 0.0 {
        ((p[0] - s.a[0]) * d[0] + (p[1] - s.a[1]) * d[1]) / len2
    } else {
        0.0
    };
    on_stretch(s, t_raw, len2 > 0.0)
}

/// Coverage of pixel center `p` by segment `s` at the parameter `t` of
/// its nearest centre-line point (0 where it does not reach `p`): a box
/// filter of one pixel over the strand's width there.
#[inline]
pub fn coverage_at(s: &Segment, p: [f32; 2], t: f32) -> f32 {
    let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
    let c = [s.a[0] + t * d[0], s.a[1] + t * d[1]];
    let dist = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt();
    let mut w = s.wa + (s.wb - s.wa) * t;
    let mut scale = 1.0;
    if w < 1.0 {
        // Sub-pixel strand: one pixel wide, alpha scaled by its width.
        scale = w.max(0.0);
        w = 1.0;
    }
    (0.5 * w + 0.5 - dist).clamp(0.0, 1.0) * scale
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. The row span of a segment holds every pixel its coverage reaches:
    ///    over 20 000 random segments (lengths 0 to 40 pixels, all
    ///    directions including axis-aligned, widths from sub-pixel to 8
    ///    pixels, strand tips and not, positions up to 4000 pixels), every
    ///    pixel of the padded bounding box with non-zero coverage lies in
    ///    its row's span.
    #[test]
    fn t01_row_span_holds_every_covered_pixel() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut rnd = move || {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545F4914F6CDD1D) >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut covered, mut visited) = (0u64, 0u64);
        for n in 0..20_000 {
            let origin = if n % 2 == 0 { 0.0 } else { 4000.0 * rnd() };
            let a = [origin + 64.0 * rnd(), origin + 64.0 * rnd()];
            let (len, ang) = (40.0 * rnd(), std::f32::consts::TAU * rnd());
            let ang = match n % 5 {
                0 => 0.0,
                1 => std::f32::consts::FRAC_PI_2,
                _ => ang,
            };
            let b = [a[0] + len * ang.cos(), a[1] + len * ang.sin()];
            let w = |u: f32| if u < 0.5 { 2.0 * u } else { 16.0 * (u - 0.5) };
            let s = Segment::on_screen(a, b, (w(rnd()), w(rnd())), n % 3 == 0);
            let pad = s.pad();
            let span = RowSpan::new(&s, pad - 0.5);
            let x0 = ((a[0].min(b[0]) - pad).max(0.0) as u32 / TILE) * TILE;
            let y0 = (a[1].min(b[1]) - pad).max(0.0) as u32;
            let x1 = (a[0].max(b[0]) + pad) as u32;
            let y1 = (a[1].max(b[1]) + pad) as u32;
            for y in y0..=y1 {
                let py = y as f32 + 0.5;
                // The whole padded box as one wide "tile" starting at x0.
                let bx1 = x1 - x0;
                let r = span.pixels(py, x0, 0, bx1);
                for i in 0..=bx1 {
                    let p = [(x0 + i) as f32 + 0.5, py];
                    visited += 1;
                    if coverage(&s, p).is_some() {
                        covered += 1;
                        let (lo, hi) = r.unwrap_or_else(|| {
                            panic!("segment {n}: row {y} empty, pixel {i} covered")
                        });
                        assert!(
                            lo <= i && i <= hi,
                            "segment {n} {s:?}: row {y} span {lo}..={hi}, pixel {i} covered"
                        );
                    }
                }
            }
        }
        assert!(
            covered > 100_000 && visited > 2 * covered,
            "{covered} of {visited}"
        );
    }

    /// 2. A ray cone holds its pixels' rays: for 300 random views (eye,
    ///    direction, field of view 10°–120°, 16×16 tiles anywhere in a
    ///    640×360 image) and 20 spheres each (around the tile's rays and
    ///    anywhere, radii 0.01–2, eyes inside some), whenever a pixel's ray
    ///    hits a sphere, the tile's cone says it may.
    #[test]
    fn t02_ray_cone_holds_every_hit() {
        use crate::raster::scene::Camera;
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = move || {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545F4914F6CDD1D) >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut hits, mut skipped) = (0u64, 0u64);
        let v3 = |rnd: &mut dyn FnMut() -> f32, s: f32| {
            Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * s
        };
        for _ in 0..300 {
            let cam = Camera {
                position: v3(&mut rnd, 4.0),
                target: v3(&mut rnd, 4.0),
                up: Vec3::Y,
                fov_y: 10.0 + 110.0 * rnd(),
                width: 640,
                height: 360,
            };
            let view = View::new(&cam, 1.0);
            let (x0, y0) = ((rnd() * 39.0) as u32 * 16, (rnd() * 22.0) as u32 * 16);
            let (w, h) = (16.min(640 - x0), 16.min(360 - y0));
            let cone = RayCone::through_pixels(&view, x0, y0, w, h);
            for n in 0..20 {
                let ray = view.ray(x0 as f32 + 16.0 * rnd(), y0 as f32 + 16.0 * rnd());
                let center = if n % 2 == 0 {
                    view.eye + ray * (0.1 + 5.0 * rnd()) + v3(&mut rnd, 1.0)
                } else {
                    v3(&mut rnd, 8.0)
                };
                let radius = 0.01 + 2.0 * rnd() * rnd();
                let may = cone.may_hit(view.eye, center, radius);
                skipped += !may as u64;
                for j in 0..h {
                    for i in 0..w {
                        let r = view.ray((x0 + i) as f32 + 0.5, (y0 + j) as f32 + 0.5);
                        if ray_sphere(view.eye, r, center, radius).is_some() {
                            hits += 1;
                            assert!(may, "a hit at pixel ({i}, {j}) of a cone said to miss");
                        }
                    }
                }
            }
        }
        // Both outcomes occur often enough for the test to mean something.
        assert!(
            hits > 10_000 && skipped > 1_000,
            "{hits} hits, {skipped} skipped"
        );
    }
}
