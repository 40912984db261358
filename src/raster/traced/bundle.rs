//! Parallel shadow rays walked together: the near field's probes of one
//! light across one fiber (`shade::near`) start within a fiber radius of
//! the fiber's axis and run the same way. One walk along the middle ray
//! gathers the capsules that may block any of them, each tested once
//! against the bundle's reach, and only those are tested per ray.
//!
//! Exact, given a grid listed with [`SegmentGrid::with_spread`] at least
//! the bundle's spread and no capsule outside the grid's box: a ray's hit
//! lies within `spread` of a point `y` of the middle ray, `y` lies in the
//! (grown) box, and the cell holding `y` lists the capsule (it lies within
//! its radius plus `spread` of the capsule's axis). So every capsule a
//! ray's own walk would find blocking it is found, and tested by the same
//! functions ([`Capsule::may_hit`], [`capsule_hit`], the ray's own
//! [`Passes`]).

use super::{capsule_hit, Capsule, Passes, SegmentGrid};
use crate::raster::shade::Fiber;
use glam::Vec3;

/// The most rays in one bundle.
pub const MAX_RAYS: usize = 8;

impl SegmentGrid {
    /// [`Self::occluded_with`] for the rays from `origins` (at most
    /// [`MAX_RAYS`]) along one unit direction `d` to `t_max`, all within
    /// `spread` of the line through `axis` along `d`, from the points of
    /// one `fiber`: bit `k` set where ray `k` is blocked. None where the
    /// grid cannot take the bundle (listed for less spread, or capsules
    /// outside its box): each ray then walks alone.
    pub fn occluded_bundle(
        &self,
        axis: Vec3,
        origins: &[Vec3],
        d: Vec3,
        t_max: f32,
        fiber: &Fiber,
        own_strand_passes: bool,
    ) -> Option<u32> {
        let n = origins.len();
        // the origins' distance from the axis bounds each ray's from the
        // middle ray (1e-4 relative and 1e-6 of a unit of room for rounding)
        let spread = origins
            .iter()
            .map(|&o| (o - axis).length())
            .fold(0.0f32, f32::max)
            * (1.0 + 1e-4)
            + 1e-6;
        if n > MAX_RAYS || !self.all_inside || !(spread <= self.spread) || !d.is_finite() {
            return None;
        }
        // each ray's entry, as its own walk has it (none: not blocked)
        let mut entry = [None; MAX_RAYS];
        let mut open = 0u32;
        for (k, &o) in origins.iter().enumerate() {
            entry[k] = self.enter(o, d, t_max);
            open |= (entry[k].is_some() as u32) << k;
        }
        if open == 0 {
            return Some(0);
        }
        // the middle ray from behind every origin to beyond every end
        let start = axis - d * spread;
        let t_mid = t_max + 2.0 * spread;
        let Some(mid_entry) = self.enter(start, d, t_mid) else {
            // (cannot happen: an origin's ray meets the box, and the box
            // is grown by the spread)
            return None;
        };
        let mut passes: [Option<Passes>; MAX_RAYS] = Default::default();
        let mut blocked = 0u32;
        self.walk(start, d, t_mid, mid_entry, |items, _| {
            for &i in items {
                let s = &self.segments[i as usize];
                if !within_reach(s, start, d, t_mid, spread) {
                    continue;
                }
                let mut todo = open & !blocked;
                while todo != 0 {
                    let k = todo.trailing_zeros() as usize;
                    todo &= todo - 1;
                    let (o, e) = (origins[k], entry[k].expect("open rays entered"));
                    let hit = s.may_hit(o, d, t_max)
                        && capsule_hit(o, d, t_max, s).is_some_and(|t| {
                            !passes[k]
                                .get_or_insert_with(|| {
                                    self.passes(o, d, e, fiber, own_strand_passes)
                                })
                                .passed(s.strand, t)
                        });
                    blocked |= (hit as u32) << k;
                }
                if blocked == open {
                    return true;
                }
            }
            false
        });
        Some(blocked)
    }
}

/// Whether a ray within `spread` of the segment from `o` along unit `d`
/// to `t_max` may meet capsule `s` ([`Capsule::may_hit`]'s two bounds
/// widened by `spread`: the bounding sphere, and the distance between the
/// lines; both padded by 1e-4 relative).
#[inline]
fn within_reach(s: &Capsule, o: Vec3, d: Vec3, t_max: f32, spread: f32) -> bool {
    let w = s.a + 0.5 * s.u - o;
    let t = w.dot(d).clamp(0.0, t_max);
    let reach = s.reach + spread;
    if (w - d * t).length_squared() > reach * reach * (1.0 + 1e-4) {
        return false;
    }
    let n = d.cross(s.u);
    let q = (s.a - o).dot(n);
    let r = s.r + spread;
    q * q <= r * r * n.length_squared() * (1.0 + 1e-4) + 1e-30
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::setup::WorldSegment;

    fn rnd(state: &mut u64) -> f32 {
        *state ^= *state >> 12;
        *state ^= *state << 25;
        *state ^= *state >> 27;
        (state.wrapping_mul(0x2545F4914F6CDD1D) >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Wavy strands of 8 segments, radius `r`, packed in a unit cube (they
    /// cross and interpenetrate).
    fn strands(st: &mut u64, n: u32, r: f32) -> Vec<WorldSegment> {
        let mut segs = Vec::new();
        for k in 0..n {
            let mut a = Vec3::new(rnd(st), rnd(st), rnd(st));
            let dir = (Vec3::new(rnd(st), rnd(st), rnd(st)) - 0.5).normalize();
            for i in 0..8 {
                let wiggle = (Vec3::new(rnd(st), rnd(st), rnd(st)) - 0.5) * 0.03;
                let b = a + dir * 0.04 + wiggle;
                segs.push(WorldSegment {
                    a,
                    b,
                    ra: r,
                    rb: r,
                    strand: k,
                    vertex: k * 9 + i,
                });
                a = b;
            }
        }
        segs
    }

    /// 1. Five rays along one direction from the surface of one fiber, walked
    ///    together, are blocked exactly where each walked alone is: 3000
    ///    bundles on 600 random wavy strands (a third of them blocked, some
    ///    not, a fifth split), the origins on the receiver's own fiber (its
    ///    own strand's tube passed as alone) and some inside other fibers,
    ///    for both own-strand rules. A grid listed for less spread, or with
    ///    a strand outside its box, declines the bundle.
    #[test]
    fn t01_bundle_equals_each_ray_alone() {
        let mut st = 0x9e37_79b9_7f4a_7c15u64;
        let r = 0.004;
        let segs = strands(&mut st, 600, r);
        let grid = SegmentGrid::with_spread(&segs, r * 1.001 + 1e-5).unwrap();
        let (mut blocked, mut split, mut total) = (0, 0, 0);
        for n in 0..3000 {
            let si = (rnd(&mut st) * segs.len() as f32) as usize % segs.len();
            let s = &segs[si];
            let axis = s.a + (s.b - s.a) * rnd(&mut st);
            let t = (s.b - s.a).normalize();
            let d = (Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - 0.5).normalize();
            let side = t.cross(d).normalize();
            let facing = t.cross(side);
            let origins: Vec<Vec3> = (0..5)
                .map(|k| {
                    let h = -1.0 + (2 * k + 1) as f32 / 5.0;
                    let n = side * h + facing * (1.0 - h * h).sqrt();
                    axis + n * r
                })
                .collect();
            let fiber = Fiber {
                radius: r,
                strand: s.strand,
                segment: si as u32,
            };
            let passes = n % 2 == 0;
            let together = grid
                .occluded_bundle(axis, &origins, d, f32::INFINITY, &fiber, passes)
                .expect("the grid takes the bundle");
            let alone = origins.iter().enumerate().fold(0u32, |m, (k, &o)| {
                m | ((grid.occluded_with(o, d, f32::INFINITY, &fiber, passes) as u32) << k)
            });
            assert_eq!(together, alone, "bundle {n}");
            blocked += together.count_ones();
            split += (together != 0 && together != 0b11111) as u32;
            total += 5;
        }
        assert!(
            blocked > total / 5 && blocked < total * 4 / 5,
            "{blocked} of {total}"
        );
        assert!(split > 100, "{split} bundles partly blocked");
        // declined: listed for less spread, or a strand outside the box
        let origins = [Vec3::splat(0.5), Vec3::splat(0.5) + Vec3::X * 2.0 * r];
        let fiber = Fiber {
            radius: r,
            strand: 0,
            segment: 0,
        };
        let narrow = SegmentGrid::new(&segs).unwrap();
        assert!(narrow
            .occluded_bundle(Vec3::splat(0.5), &origins, Vec3::Y, 1.0, &fiber, false)
            .is_none());
        let mut far = segs.clone();
        far.push(WorldSegment {
            a: Vec3::splat(1e6),
            b: Vec3::splat(1e6 + 0.04),
            ra: r,
            rb: r,
            strand: 600,
            vertex: 9 * 600,
        });
        let outlier = SegmentGrid::with_spread(&far, 1.0).unwrap();
        assert!(outlier
            .occluded_bundle(Vec3::splat(0.5), &origins, Vec3::Y, 1.0, &fiber, false)
            .is_none());
    }
}
