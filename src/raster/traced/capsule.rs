//! A strand segment as the traced shadows test it: a capsule (the
//! segment's axis and its mean radius), and the ray tests on it.

use glam::Vec3;

#[derive(Debug, Clone, Copy)]
pub(super) struct Capsule {
    /// The axis `a + s·u`, s in [0, 1].
    pub(super) a: Vec3,
    /// The radius squared.
    pub(super) r2: f32,
    pub(super) u: Vec3,
    /// The radius of a sphere around the axis's midpoint holding the
    /// capsule (padded by 1e-4 relative, so that rounding never makes the
    /// sphere reject a ray the capsule test would accept).
    pub(super) reach: f32,
    /// The radius.
    pub(super) r: f32,
    pub(super) strand: u32,
    /// Index in the world segments.
    pub(super) segment: u32,
}

impl Capsule {
    /// Whether the ray (o, unit d, t in [0, t_max]) may meet the capsule
    /// (the cheap tests before [`capsule_hit`]): it passes the bounding
    /// sphere, and the ray's line passes the axis's line within the radius
    /// (both lines unbounded: a lower bound of the distance between ray
    /// and segment). Both are padded by 1e-4 relative, so that rounding
    /// never rejects a ray [`capsule_hit`] would accept.
    #[inline]
    pub(super) fn may_hit(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        let w = self.a + 0.5 * self.u - o;
        let t = w.dot(d).clamp(0.0, t_max);
        if (w - d * t).length_squared() > self.reach * self.reach {
            return false;
        }
        let n = d.cross(self.u);
        let s = (self.a - o).dot(n);
        s * s <= self.r2 * n.length_squared() * (1.0 + 1e-4) + 1e-30
    }
}
/// The ray parameter where the ray from `o` along unit `d` leaves the
/// capsule: the end of its interval inside the capsule (a convex set: the
/// latest exit of the finite cylinder and the two end balls the ray meets),
/// 0 when that lies behind the origin. For an origin inside the capsule or
/// on its surface.
pub(super) fn capsule_exit(o: Vec3, d: Vec3, c: &Capsule) -> f32 {
    // on the surface or outside it, heading away from the axis (a shadow
    // ray towards a light in front of the fiber): it leaves at once
    let w = o - c.a;
    let uu = c.u.dot(c.u);
    let s = if uu > 0.0 {
        (c.u.dot(w) / uu).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let radial = w - c.u * s;
    if radial.dot(d) >= 0.0 && radial.length_squared() >= c.r2 {
        return 0.0;
    }
    let mut t_out = 0.0f32;
    // the finite cylinder: the infinite tube's interval within the slab
    // between the end planes
    let len = c.u.length();
    if len > 0.0 {
        let axis = c.u / len;
        let w = o - c.a;
        let (s0, ds) = (w.dot(axis), d.dot(axis));
        let (wp, dp) = (w - axis * s0, d - axis * ds);
        let (a, b, cc) = (dp.dot(dp), 2.0 * wp.dot(dp), wp.dot(wp) - c.r2);
        let tube = if a < 1e-12 {
            (cc <= 0.0).then_some((f32::NEG_INFINITY, f32::INFINITY))
        } else {
            let disc = b * b - 4.0 * a * cc;
            (disc >= 0.0).then(|| {
                let q = disc.sqrt();
                ((-b - q) / (2.0 * a), (-b + q) / (2.0 * a))
            })
        };
        let slab = if ds.abs() < 1e-12 {
            (0.0..=len)
                .contains(&s0)
                .then_some((f32::NEG_INFINITY, f32::INFINITY))
        } else {
            let (ta, tb) = (-s0 / ds, (len - s0) / ds);
            Some((ta.min(tb), ta.max(tb)))
        };
        if let (Some(t), Some(s)) = (tube, slab) {
            let (lo, hi) = (t.0.max(s.0), t.1.min(s.1));
            if lo <= hi && hi.is_finite() {
                t_out = t_out.max(hi);
            }
        }
    }
    // the end balls
    for centre in [c.a, c.a + c.u] {
        let oc = o - centre;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - c.r2);
        if disc >= 0.0 {
            t_out = t_out.max(-b + disc.sqrt());
        }
    }
    t_out
}

/// Whether `o` lies inside the capsule.
#[inline]
pub(super) fn contains(o: Vec3, c: &Capsule) -> bool {
    let w = o - c.a;
    let (t, uu) = (c.u.dot(w), c.u.dot(c.u));
    if t <= 0.0 || uu <= 0.0 {
        w.length_squared() <= c.r2
    } else if t >= uu {
        (w - c.u).length_squared() <= c.r2
    } else {
        // |w|² − (u·w)²/|u|², times |u|²
        w.length_squared() * uu - t * t <= c.r2 * uu
    }
}

/// Whether the segment `a`–`b` meets the box `[lo, hi]` (slab test over
/// the segment's parameter in [0, 1]).
#[inline]
pub(super) fn segment_crosses_box(a: Vec3, b: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let u = b - a;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for k in 0..3 {
        if u[k] == 0.0 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return false;
            }
            continue;
        }
        let (e, f) = ((lo[k] - a[k]) / u[k], (hi[k] - a[k]) / u[k]);
        t0 = t0.max(e.min(f));
        t1 = t1.min(e.max(f));
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// Whether the ray (o, unit d, t in (0, t_max]) meets the capsule (its
/// closest approach to the segment is within the radius, and its origin is
/// outside the capsule): the ray parameter of that closest approach, or
/// None.
pub(super) fn capsule_hit(o: Vec3, d: Vec3, t_max: f32, s: &Capsule) -> Option<f32> {
    // Closest points between the ray and the segment (Ericson, 5.1.9).
    let u = s.u;
    let w = o - s.a;
    // A ray that starts inside the capsule leaves it unblocked: a point on
    // a visible fiber surface never lies inside another fiber (the camera
    // would have met that fiber first), so an origin inside one comes from
    // fibers that interpenetrate, or from a scalp point at a root. Counting
    // such capsules as occluders darkened a dense 10k-strand head lit from
    // above by 7 % against Mitsuba's direct light.
    let c = u.dot(u);
    let t0 = if c > 0.0 {
        (u.dot(w) / c).clamp(0.0, 1.0)
    } else {
        0.0
    };
    if (w - u * t0).length_squared() <= s.r2 {
        return None;
    }
    let (a, b, c) = (1.0, d.dot(u), u.dot(u));
    let (dd, e) = (d.dot(w), u.dot(w));
    let den = a * c - b * b;
    let mut sc = if den > 1e-12 {
        ((b * e - c * dd) / den).clamp(0.0, t_max)
    } else {
        0.0
    };
    let mut tc = if c > 0.0 {
        ((b * sc + e) / c).clamp(0.0, 1.0)
    } else {
        0.0
    };
    // Re-solve the ray parameter for the clamped segment parameter.
    sc = (u.dot(d) * tc - dd).clamp(0.0, t_max);
    if c > 0.0 {
        tc = ((b * sc + e) / c).clamp(0.0, 1.0);
    }
    let gap = (o + d * sc) - (s.a + u * tc);
    (gap.length_squared() <= s.r2).then_some(sc)
}
