//! Strand level of detail (after Capcom's RE ENGINE strand renderer): a
//! fraction `f` of the strands is drawn, each `1/f` times as wide, so that
//! the hair's projected area, its opacity where strands overlap little, and
//! its fiber cross-section per unit volume (the density grid's and the
//! shadow maps' input) are kept.
//!
//! Which strands: each strand has a fixed rank `u ∈ [0, 1)`, a hash of its
//! index (the strands in a shuffled order, without reordering the scene),
//! and is drawn when `u < f`: a uniform subset whose members do not depend
//! on the scene's strand order beyond their indices, nested as `f` grows
//! (raising the fraction adds strands and never swaps them). The widths are
//! scaled by the total width over the kept strands' (radii summed over
//! vertices; about `1/f`), so that the total width is kept exactly.
//!
//! Shadow maps are drawn from every strand ([`casters`]): widened strands
//! overlap where the strands they stand for lay side by side, so maps of
//! the drawn strands alone let more light through (opacity maps at
//! 1280×720, `auto`: the dense head `auburn_key` at `f` 0.39 17-18%
//! brighter than with every strand drawn; with the maps of every strand
//! and the lookups below, the six dense heads' means are within 0.5-6.8%
//! of it and the 25k-strand demo head's within 0.3%, `docs/speed.md`). A
//! frame loop reuses the maps: they cost once per light (the demo head's
//! first frame 2.1 s instead of 1.1 s on 2 cores, later frames the same).
//! A drawn strand reads the maps (and every lookup made at a fiber's
//! surface) at the radius of the strands it stands for
//! (`Shader::with_lod_widen`): at its widened surface, `1/f` radii
//! towards the camera, backlit heads rendered twice as bright at 1/8 as
//! with every strand drawn.
//!
//! `auto` picks `f` from the strands' width and depth on screen: hair whose
//! strands are thinner than [`AUTO_WIDTH`] pixels is drawn with fewer,
//! wider strands, `f = clamp(w / AUTO_WIDTH, max(AUTO_MIN, AUTO_DEPTH / d),
//! 1)` with `w` the median projected strand width in pixels and `d` how
//! many strands deep the hair lies on screen on average ([`overlap`]).
//! Strands thinner than a pixel are what the rasterizer pays for most:
//! each covers at least a pixel-wide footprint, so a strand `w` pixels
//! wide costs about `w + 1` pixels per unit length, and `f` strands of
//! width `w/f` cost `w + f`. The depth bound keeps the drawn strands
//! [`AUTO_DEPTH`] deep: the error of a fraction grows as the drawn strands
//! stop overlapping (`docs/lod_tradeoff.md`: at 320×180 the dense heads,
//! about 5 deep, at `f` 1/8 rendered with 1.5-3.7 times the relMSE of every
//! strand drawn, at 0.4 with 1.1-1.8 times, at 0.7 with 1.0-1.2 times; the
//! 25k-strand demo head, about 13 deep, drawn 2 deep at 640×360 shows wide
//! bars and a blotchy crown where drawn 4 deep it does much less), and hair
//! whose strands lie apart (a few strands, a bundle seen from the side:
//! much less than one deep) is drawn whole, as thinning it would leave gaps
//! where strands were. Time against error over `f`: `hairshade bench
//! --render` (section `lod`) and `scripts/lod_tradeoff.py`.

use super::scene::{Camera, Strands};
use super::setup::{world_segments, WorldSegment};
#[cfg(test)]
use glam::Vec3;
use std::sync::OnceLock;

/// Projected width, in pixels, that `auto` widens thin strands to.
pub const AUTO_WIDTH: f32 = 2.0;
/// Smallest fraction `auto` picks.
pub const AUTO_MIN: f32 = 0.125;
/// How many strands deep `auto` keeps the drawn strands on screen, on
/// average ([`overlap`]): it draws no fewer than this over the strands'
/// depth, and every strand of hair less deep than this.
pub const AUTO_DEPTH: f32 = 4.0;

/// How many strands a render draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lod {
    /// This fraction of the strands, in (0, 1].
    Fraction(f32),
    /// The fraction from the strands' width on screen (module docs).
    Auto,
}

impl Default for Lod {
    fn default() -> Self {
        Lod::Fraction(1.0)
    }
}

/// Rank of strand `s` in [0, 1): a 64-bit mix of its index (splitmix64's
/// finalizer), the top 24 bits.
#[inline]
pub fn rank(s: usize) -> f32 {
    let mut z = (s as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// The fraction `lod` stands for with this camera, and under `auto` the
/// strands' overlap on screen it read ([`overlap`]).
pub fn choose(lod: Lod, strands: &Strands, camera: &Camera) -> (f32, Option<f32>) {
    match lod {
        Lod::Fraction(f) => (f.clamp(f32::MIN_POSITIVE, 1.0), None),
        Lod::Auto => {
            let d = overlap(strands, camera);
            let f = match (median_width_px(strands, camera), d) {
                (Some(w), Some(d)) => auto_fraction(w, d),
                _ => 1.0,
            };
            (f, d)
        }
    }
}

/// `auto`'s fraction for strands `w` pixels wide on screen lying `d` deep
/// ([`overlap`]): `clamp(w / AUTO_WIDTH, max(AUTO_MIN, AUTO_DEPTH / d), 1)`.
pub fn auto_fraction(w: f32, d: f32) -> f32 {
    let lo = if d > 0.0 {
        (AUTO_DEPTH / d).max(AUTO_MIN)
    } else {
        1.0
    };
    (w / AUTO_WIDTH).clamp(lo.min(1.0), 1.0)
}

/// Side, in pixels, of the cells [`overlap`] counts the hair's footprint in.
const OVERLAP_CELL: u32 = 8;
/// Strands per task of [`overlap`].
const OVERLAP_CHUNK: usize = 1024;
/// How many strands [`overlap`] projects first, evenly spaced.
const OVERLAP_SAMPLE: usize = 4096;
/// The depth on screen from which evenly spaced strands fill the whole's
/// footprint: a cell of 8×8 pixels then holds 32 square pixels of them, some
/// 4-32 stretches of strand a pixel to an eighth wide, so that one with
/// none is rare (under e^-4 where each lies independently).
const OVERLAP_SATURATED: f64 = 0.5;

/// How many strands lie over a pixel of the hair's footprint on screen, on
/// average: the strands' projected area (each segment in front of the
/// camera with an end in the image, its length on screen times its mean
/// width, in pixels) over the footprint's area, counted as the
/// [`OVERLAP_CELL`]-pixel cells of the image holding such a segment's ends
/// or points along it a cell apart.
/// Dense hair lies several strands deep (the dense test heads about 5,
/// the 25k-strand demo head about 13, nearly the same at every
/// resolution); strands apart from each other lie much less than one deep
/// (a strand a pixel wide crossing a cell covers an eighth of it). Of more
/// than [`OVERLAP_SAMPLE`] strands, evenly spaced ones are projected first,
/// and their depth scaled by the whole's count over theirs where they lie
/// deep enough to fill the whole's footprint; otherwise every strand is
/// projected. None without such a segment.
pub fn overlap(strands: &Strands, camera: &Camera) -> Option<f32> {
    let n = strands.strand_count();
    let step = n.div_ceil(OVERLAP_SAMPLE).max(1);
    if step > 1 {
        // every step-th strand: its depth is about 1/step of the whole's,
        // and where it still lies OVERLAP_SATURATED deep it fills the
        // whole's footprint (below)
        let (area, footprint) = projected(strands, camera, step)?;
        if area >= OVERLAP_SATURATED * footprint {
            return Some((step as f64 * area / footprint) as f32);
        }
    }
    let (area, footprint) = projected(strands, camera, 1)?;
    Some((area / footprint) as f32)
}

/// The projected area, in pixels, of every `step`-th strand (from the
/// first), and the area of the cells holding it ([`overlap`]); None
/// without a segment in the image.
fn projected(strands: &Strands, camera: &Camera, step: usize) -> Option<(f64, f64)> {
    let (w, h) = (camera.width.max(1), camera.height.max(1));
    let forward = (camera.target - camera.position).normalize_or_zero();
    let right = forward.cross(camera.up).normalize_or_zero();
    let up = right.cross(forward);
    let tan_half = (0.5 * camera.fov_y.to_radians()).tan();
    if !(tan_half > 0.0) || forward == glam::Vec3::ZERO || right == glam::Vec3::ZERO {
        return None;
    }
    // pixels per unit of (lateral offset / depth)
    let scale = 0.5 * h as f32 / tan_half;
    let (cw, ch) = (w.div_ceil(OVERLAP_CELL), h.div_ceil(OVERLAP_CELL));
    let words = ((cw * ch) as usize).div_ceil(64);
    let (wf, hf) = (w as f32, h as f32);
    let inside = |x: f32, y: f32| x >= 0.0 && y >= 0.0 && x < wf && y < hf;
    let cell = 1.0 / OVERLAP_CELL as f32;
    // One chunk of strands: its projected area and the cells it crosses
    // (fixed chunks, summed in order: the same result at every thread count).
    let chunk = |first: usize| -> (f64, Vec<u64>) {
        let mut cells = vec![0u64; words];
        let mut mark = |x: f32, y: f32| {
            if inside(x, y) {
                let c = (y * cell) as usize * cw as usize + (x * cell) as usize;
                cells[c / 64] |= 1 << (c % 64);
            }
        };
        let mut area = 0.0f64;
        for s in (first..(first + OVERLAP_CHUNK * step).min(strands.strand_count())).step_by(step) {
            let r = strands.offsets[s] as usize..strands.offsets[s + 1] as usize;
            // the previous vertex: x, y and width in pixels (z > 0)
            let mut prev: Option<(f32, f32, f32)> = None;
            for i in r {
                let d = strands.points[i] - camera.position;
                let z = d.dot(forward);
                if !(z > 0.0) {
                    prev = None;
                    continue;
                }
                let k = scale / z;
                let (x, y) = (0.5 * wf + k * d.dot(right), 0.5 * hf - k * d.dot(up));
                let wp = 2.0 * strands.radii[i] * k;
                if let Some((px, py, pw)) = prev {
                    if inside(x, y) || inside(px, py) {
                        let len = ((x - px) * (x - px) + (y - py) * (y - py)).sqrt();
                        area += (len * 0.5 * (wp + pw)) as f64;
                        // the cells along the segment: its ends, and points
                        // a cell apart between them
                        mark(x, y);
                        let steps = (len * cell).min(4096.0) as u32;
                        for j in 0..steps {
                            let t = (j as f32 + 0.5) / steps as f32;
                            mark(px + (x - px) * t, py + (y - py) * t);
                        }
                    }
                } else {
                    mark(x, y);
                }
                prev = Some((x, y, wp));
            }
        }
        (area, cells)
    };
    use rayon::prelude::*;
    let parts: Vec<(f64, Vec<u64>)> = (0..strands.strand_count())
        .into_par_iter()
        .step_by(OVERLAP_CHUNK * step)
        .map(chunk)
        .collect();
    let mut cells = vec![0u64; words];
    let mut area = 0.0f64;
    for (a, c) in &parts {
        area += a;
        for (x, y) in cells.iter_mut().zip(c) {
            *x |= y;
        }
    }
    let footprint = cells.iter().map(|c| c.count_ones()).sum::<u32>() as f64
        * (OVERLAP_CELL * OVERLAP_CELL) as f64;
    (footprint > 0.0 && area.is_finite()).then_some((area, footprint))
}

/// Median over (up to 4096 evenly spaced) strand vertices in front of the
/// camera of the strand's width in pixels there (`2r` over the pixel's
/// footprint at the vertex's depth); None without such vertices.
pub fn median_width_px(strands: &Strands, camera: &Camera) -> Option<f32> {
    let n = strands.points.len();
    if n == 0 {
        return None;
    }
    let forward = (camera.target - camera.position).normalize_or_zero();
    // Pixel footprint at depth z: 2 z tan(fov/2) / height.
    let per_depth = 2.0 * (0.5 * camera.fov_y.to_radians()).tan() / camera.height.max(1) as f32;
    let step = n.div_ceil(4096).max(1);
    let mut w: Vec<f32> = (0..n)
        .step_by(step)
        .filter_map(|i| {
            let z = (strands.points[i] - camera.position).dot(forward);
            (z > 0.0 && per_depth > 0.0).then(|| 2.0 * strands.radii[i] / (z * per_depth))
        })
        .filter(|x| x.is_finite())
        .collect();
    if w.is_empty() {
        return None;
    }
    let mid = w.len() / 2;
    Some(*w.select_nth_unstable_by(mid, f32::total_cmp).1)
}

/// The indices of the strands [`reduce`] keeps of `count` at fraction
/// `f`, ascending: those ranked below `f`, or where none is (f under
/// ~1/N) the lowest-ranked strand alone.
pub fn kept(count: usize, f: f32) -> Vec<usize> {
    let kept: Vec<usize> = (0..count).filter(|&s| rank(s) < f).collect();
    if kept.is_empty() && count > 0 {
        return vec![(0..count)
            .min_by(|&a, &b| rank(a).total_cmp(&rank(b)))
            .expect("count > 0")];
    }
    kept
}

/// The strands a level of detail draws ([`reduce`]).
pub struct Reduced {
    /// The kept strands, widened.
    pub strands: Strands,
    /// The original index of each ([`kept`]).
    pub kept: Vec<usize>,
    /// The factor their radii were widened by (about `1/f`).
    pub widen: f32,
}

/// The strands with rank below `f`, widened to keep the total width
/// (module docs); `None` when every strand is kept.
pub fn reduce(strands: &Strands, f: f32) -> Option<Reduced> {
    let count = strands.strand_count();
    if f >= 1.0 || count == 0 {
        return None;
    }
    let kept = kept(count, f);
    if kept.len() == count {
        return None;
    }
    let width = |s: usize| -> f64 {
        let r = strands.offsets[s] as usize..strands.offsets[s + 1] as usize;
        strands.radii[r].iter().map(|&x| x as f64).sum()
    };
    let kept_width: f64 = kept.iter().map(|&s| width(s)).sum();
    let total_width: f64 = (0..count).map(width).sum();
    let widen = if kept_width > 0.0 {
        (total_width / kept_width) as f32
    } else {
        1.0
    };
    let mut out = Strands {
        points: Vec::new(),
        radii: Vec::new(),
        offsets: vec![0],
    };
    for &s in &kept {
        let r = strands.offsets[s] as usize..strands.offsets[s + 1] as usize;
        out.points.extend_from_slice(&strands.points[r.clone()]);
        out.radii.extend(strands.radii[r].iter().map(|x| x * widen));
        out.offsets.push(out.points.len() as u32);
    }
    Some(Reduced {
        strands: out,
        kept,
        widen,
    })
}

/// What shadow maps are drawn from: the drawn strands' segments, or under
/// a level of detail every strand's ([`casters`]), made when a map is
/// first drawn (a frame that reuses its maps does not make them).
pub enum Casters<'a> {
    /// The drawn strands' segments.
    Drawn(&'a [WorldSegment]),
    /// Every strand of `all`, where `drawn` are the strands `kept` of it.
    Every {
        all: &'a Strands,
        drawn: &'a Strands,
        kept: &'a [usize],
        made: OnceLock<Vec<WorldSegment>>,
    },
}

impl<'a> Casters<'a> {
    /// Every strand of `all`, where `drawn` are the strands `kept` of it.
    pub fn every(all: &'a Strands, drawn: &'a Strands, kept: &'a [usize]) -> Self {
        Casters::Every {
            all,
            drawn,
            kept,
            made: OnceLock::new(),
        }
    }

    /// The segments (every strand's made on the first call).
    pub fn get(&self) -> &[WorldSegment] {
        match self {
            Casters::Drawn(segments) => segments,
            Casters::Every {
                all,
                drawn,
                kept,
                made,
            } => made.get_or_init(|| casters(all, drawn, kept)),
        }
    }
}

/// The world segments of every strand of `all`, numbered as the drawn
/// strands (`drawn`, the strands `kept` of `all` by [`reduce`]) are: a
/// kept strand's segments carry its index and vertices among the drawn
/// strands, so that a receiver knows its own; a left-out strand's carry
/// indices past every drawn one, so that no receiver takes it for its own.
pub fn casters(all: &Strands, drawn: &Strands, kept: &[usize]) -> Vec<WorldSegment> {
    let (strands, vertices) = (drawn.strand_count() as u32, drawn.points.len() as u32);
    let mut renumber: Vec<Option<(u32, u32)>> = vec![None; all.strand_count()];
    for (i, &s) in kept.iter().enumerate() {
        renumber[s] = Some((i as u32, drawn.offsets[i]));
    }
    let mut segments = world_segments(all);
    for seg in &mut segments {
        let s = seg.strand as usize;
        match renumber[s] {
            Some((i, first)) => {
                seg.vertex = first + (seg.vertex - all.offsets[s]);
                seg.strand = i;
            }
            None => {
                seg.vertex += vertices;
                seg.strand += strands;
            }
        }
    }
    segments
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strands(n: usize) -> Strands {
        let mut s = Strands {
            points: Vec::new(),
            radii: Vec::new(),
            offsets: vec![0],
        };
        for k in 0..n {
            for j in 0..4 {
                s.points
                    .push(Vec3::new(k as f32 * 0.01, j as f32 * 0.1, 0.0));
                s.radii.push(0.001 * (1.0 + (k % 3) as f32));
            }
            s.offsets.push(s.points.len() as u32);
        }
        s
    }

    /// A 1280×720 camera 2 units from the origin, looking down −z, and the
    /// side of its pixel at the origin.
    fn camera_1280() -> (Camera, f32) {
        let camera = Camera {
            position: Vec3::new(0.0, 0.0, 2.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 40.0,
            width: 1280,
            height: 720,
        };
        (camera, 2.0 * 2.0 * (20f32).to_radians().tan() / 720.0)
    }

    /// `n` parallel vertical strands of radius `r` at the origin's depth,
    /// spread evenly over a band 800 pixels wide and 400 tall (pixel side
    /// `px`) centred in [`camera_1280`]'s image, on cell boundaries.
    fn sheet(n: usize, r: f32, px: f32) -> Strands {
        let mut s = Strands {
            points: Vec::new(),
            radii: Vec::new(),
            offsets: vec![0],
        };
        for k in 0..n {
            let x = (-400.0 + 800.0 * (k as f32 + 0.5) / n as f32) * px;
            for j in 0..=8 {
                s.points
                    .push(Vec3::new(x, (-200.0 + 50.0 * j as f32) * px, 0.0));
                s.radii.push(r);
            }
            s.offsets.push(s.points.len() as u32);
        }
        s
    }

    /// 1. The kept subset is uniform (its share within 4 standard errors of
    ///    f at N = 20000), nested as f grows, and the total width (Σ radius
    ///    over vertices) is kept to f32 rounding (each radius is rounded
    ///    once, 6e-8 relative, summed in f64: 1e-6 allows for it).
    #[test]
    fn t01_subset_uniform_nested_width_kept() {
        let s = strands(20000);
        let total: f64 = s.radii.iter().map(|&r| r as f64).sum();
        let mut previous: Option<Vec<Vec3>> = None;
        for f in [0.1f32, 0.25, 0.5, 0.9] {
            let r = reduce(&s, f).unwrap().strands;
            let share = r.strand_count() as f64 / 20000.0;
            let se = (f as f64 * (1.0 - f as f64) / 20000.0).sqrt();
            assert!((share - f as f64).abs() < 4.0 * se, "f {f}: share {share}");
            let kept_total: f64 = r.radii.iter().map(|&x| x as f64).sum();
            assert!(
                (kept_total / total - 1.0).abs() < 1e-6,
                "{kept_total} vs {total}"
            );
            if let Some(p) = previous {
                // every strand of the smaller set is in the larger one
                let set: std::collections::HashSet<[u32; 3]> = r
                    .points
                    .iter()
                    .map(|v| v.to_array().map(f32::to_bits))
                    .collect();
                assert!(p
                    .iter()
                    .all(|v| set.contains(&v.to_array().map(f32::to_bits))));
            }
            previous = Some(r.points.clone());
        }
        assert!(reduce(&s, 1.0).is_none());
    }

    /// 2. A tiny fraction keeps one strand; the ranks lie in [0, 1).
    #[test]
    fn t02_tiny_fraction_and_ranks() {
        let s = strands(10);
        let r = reduce(&s, 1e-9).unwrap().strands;
        assert_eq!(r.strand_count(), 1);
        assert!((0..100000).map(rank).all(|u| (0.0..1.0).contains(&u)));
    }

    /// 3. The median width on screen: a strand of radius r at distance z
    ///    along the view axis is 2r / (2 z tan(fov/2) / height) pixels.
    #[test]
    fn t03_median_width_in_pixels() {
        let (camera, _) = camera_1280();
        let s = Strands {
            points: vec![Vec3::ZERO, Vec3::new(0.0, 0.1, 0.0)],
            radii: vec![0.001, 0.001],
            offsets: vec![0, 2],
        };
        let want = 0.002 / (2.0 * 2.0 * (20f32).to_radians().tan() / 720.0);
        let got = median_width_px(&s, &camera).unwrap();
        assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
        // a lone strand lies far less than AUTO_DEPTH deep: drawn whole
        assert!(overlap(&s, &camera).unwrap() < 0.1);
        assert_eq!(choose(Lod::Auto, &s, &camera).0, 1.0);
    }

    /// 4. Shadow casters under a level of detail: every strand's segments,
    ///    at their own places and widths; a kept strand's numbered as its
    ///    drawn copy (the same strand index and first vertex as the drawn
    ///    strands' own segments), a left-out strand's past every drawn one.
    #[test]
    fn t04_casters_every_strand_numbered_as_drawn() {
        let s = strands(300);
        let Reduced {
            strands: drawn,
            kept,
            ..
        } = reduce(&s, 0.3).unwrap();
        let every = casters(&s, &drawn, &kept);
        let all = world_segments(&s);
        let own = world_segments(&drawn);
        assert_eq!(every.len(), all.len());
        let mut drawn_met = 0;
        for (c, w) in every.iter().zip(&all) {
            assert_eq!((c.a, c.b, c.ra, c.rb), (w.a, w.b, w.ra, w.rb));
            match kept.binary_search(&(w.strand as usize)) {
                Ok(i) => {
                    // its drawn copy: same centre line, widened
                    let d = own
                        .iter()
                        .find(|d| d.strand == c.strand && d.vertex == c.vertex)
                        .expect("a kept strand's segment has its drawn copy");
                    assert_eq!(d.strand as usize, i);
                    assert_eq!((d.a, d.b), (c.a, c.b));
                    assert!(d.ra > c.ra);
                    drawn_met += 1;
                }
                Err(_) => {
                    assert!(c.strand as usize >= drawn.strand_count());
                    assert!(c.vertex as usize >= drawn.points.len());
                }
            }
        }
        assert_eq!(drawn_met, own.len());
        let lazy = Casters::every(&s, &drawn, &kept);
        assert_eq!(lazy.get().len(), all.len());
        assert_eq!(Casters::Drawn(&own).get().len(), own.len());
    }

    /// 5. A kept strand is lit at every fraction as it is with every strand
    ///    drawn: per-vertex shading of the drawn strands, with opacity maps
    ///    of every strand ([`casters`]) and lookups at the original radius
    ///    (`Shader::with_lod_widen`), equals the full scene's at the same
    ///    vertices to 1e-5 relative (the radius is widened and narrowed
    ///    again in f32, so a surface point can move by an ulp). The strands
    ///    shadow each other (asserted): at the widened radius, or with a
    ///    strand's own deposits taken for another's, the two differ.
    #[test]
    fn t05_kept_strands_are_lit_as_with_every_strand() {
        use crate::fiber::chiang::{ChiangFarTable, TableSize};
        use crate::raster::lighting::Lighting;
        use crate::raster::scene::{Cards, HairShading, Light, RenderOptions, Scene};
        use crate::raster::setup::scene_bounds;
        use crate::raster::shade::{shade_vertices, Shader};
        use crate::raster::shadow::{ShadowMap, ShadowModel};
        use std::sync::Arc;

        // A slab of strands 10 deep, lit from behind (the camera's side is +z)
        let mut all = Strands {
            points: Vec::new(),
            radii: Vec::new(),
            offsets: vec![0],
        };
        for s in 0..400 {
            let (x, z) = (
                (s % 40) as f32 * 0.01,
                (s / 40) as f32 * 0.004 + 0.0013 * (s % 7) as f32,
            );
            for k in 0..8 {
                all.points.push(Vec3::new(x, k as f32 * 0.05, z));
                all.radii.push(0.002);
            }
            all.offsets.push(all.points.len() as u32);
        }
        let m: crate::fiber::ChiangHair<f64> =
            crate::fiber::ChiangParams::default().build().unwrap();
        let hair = HairShading::ChiangFar(Arc::new(ChiangFarTable::new(
            &m,
            TableSize::for_scale(m.logistic_scale()),
        )));
        let scene = |strands: Strands| Scene {
            camera: Camera {
                position: Vec3::new(0.2, 0.2, 3.0),
                target: Vec3::new(0.2, 0.2, 0.0),
                up: Vec3::Y,
                fov_y: 30.0,
                width: 64,
                height: 64,
            },
            lights: vec![Light::Directional {
                direction: Vec3::new(0.1, 0.3, -1.0).normalize(),
                intensity: Vec3::splat(3.0),
                shadows: true,
            }],
            environment: None,
            strands,
            cards: Cards::default(),
            spheres: Vec::new(),
            triangles: Vec::new(),
            hair: hair.clone(),
        };
        let whole = scene(all.clone());
        let opts = RenderOptions {
            shadow_model: ShadowModel::Opacity,
            light_cull_threshold: 0.0,
            ..Default::default()
        };
        let bounds = scene_bounds(&whole);
        let eye = whole.camera.position;
        let map = |sc: &Scene, casters: &[WorldSegment]| {
            vec![ShadowMap::build(&sc.lights[0], sc, casters, bounds, &opts, None).map(Arc::new)]
        };
        let full_maps = map(&whole, &world_segments(&all));
        let full = shade_vertices(
            &whole,
            &Shader::new(&whole, &full_maps, Arc::new(Lighting::none(1)), None, &opts),
            eye,
            None,
        );
        let m = full_maps[0].as_ref().unwrap();
        let shadowed = all
            .points
            .iter()
            .filter(|&&p| m.visibility(p) < 0.5)
            .count();
        assert!(
            shadowed > all.points.len() / 2,
            "{shadowed} shadowed vertices"
        );
        for f in [0.5f32, 0.25, 0.125] {
            let Reduced {
                strands,
                kept,
                widen,
            } = reduce(&all, f).unwrap();
            assert!(widen > 0.5 / f);
            let drawn = scene(strands);
            let maps = map(&drawn, &casters(&all, &drawn.strands, &kept));
            let shader = Shader::new(&drawn, &maps, Arc::new(Lighting::none(1)), None, &opts)
                .with_lod_widen(widen);
            let got = shade_vertices(&drawn, &shader, eye, None);
            for (i, &s) in kept.iter().enumerate() {
                let (d0, a0) = (drawn.strands.offsets[i] as usize, all.offsets[s] as usize);
                for k in 0..8 {
                    let (g, w) = (got[d0 + k], full[a0 + k]);
                    assert!(
                        (g - w).abs().max_element() <= 1e-5 * w.max_element() + 1e-9,
                        "f {f}: strand {s} vertex {k}: {g} vs {w}"
                    );
                }
            }
        }
    }

    /// 6. `auto`'s fraction: the width bound, the depth bound and the clamps.
    #[test]
    fn t06_auto_fraction_bounds() {
        // thin and deep: the width decides, down to AUTO_MIN
        assert_eq!(auto_fraction(0.5, 100.0), 0.25);
        assert_eq!(auto_fraction(0.01, 100.0), AUTO_MIN);
        // thin and 5 deep: no fewer than AUTO_DEPTH / 5
        assert_eq!(auto_fraction(0.2, 5.0), AUTO_DEPTH / 5.0);
        // wide, or shallower than AUTO_DEPTH: every strand
        assert_eq!(auto_fraction(3.0, 100.0), 1.0);
        assert_eq!(auto_fraction(0.2, 1.5), 1.0);
        assert_eq!(auto_fraction(0.2, 0.0), 1.0);
    }

    /// 7. The overlap of a sheet of parallel strands facing the camera,
    ///    `n` strands side by side over a band `b` pixels wide, each `w`
    ///    pixels wide: `n w / b` strands deep, less the cells that the
    ///    band's edges may add.
    #[test]
    fn t07_overlap_of_a_sheet() {
        let (camera, px) = camera_1280();
        // a band 800 px wide (x) and 400 px tall (y), aligned to cells
        let n = 8000;
        let s = sheet(n, 0.5 * 0.8 * px, px);
        let want = n as f32 * 0.8 / 800.0;
        let got = overlap(&s, &camera).unwrap();
        // the band's edges lie on cell boundaries: each may add a row or
        // column of cells (a vertex on the boundary, or rounding past it)
        let lo = want * (400.0 * 800.0) / (416.0 * 816.0);
        assert!(got > 0.999 * lo && got < 1.001 * want, "{got} vs {want}");
        // 8 deep, 0.8 px wide: f = max(0.4, 4 / 8) = 0.5
        assert!((choose(Lod::Auto, &s, &camera).0 - 0.5).abs() < 0.02);
    }

    /// 8. Of many strands, the evenly spaced ones stand for the whole where
    ///    they fill its footprint (a dense sheet: within 2% of every strand
    ///    projected), and every strand is projected where they do not
    ///    (short strands scattered apart: the exact depth).
    #[test]
    fn t08_overlap_from_evenly_spaced_strands() {
        let (camera, px) = camera_1280();
        let exact = |s: &Strands| {
            let (a, f) = projected(s, &camera, 1).unwrap();
            (a / f) as f32
        };
        let n = 20000;
        let sheet = sheet(n, 0.25 * px, px);
        let (got, want) = (overlap(&sheet, &camera).unwrap(), exact(&sheet));
        assert!((got - want).abs() < 0.02 * want, "{got} vs {want}");
        let mut scattered = Strands {
            points: Vec::new(),
            radii: Vec::new(),
            offsets: vec![0],
        };
        for k in 0..n {
            let (u, v) = (rank(2 * k) - 0.5, rank(2 * k + 1) - 0.5);
            let p = Vec3::new(1200.0 * u * px, 700.0 * v * px, 0.0);
            scattered.points.push(p);
            scattered.points.push(p + Vec3::new(2.0 * px, 0.0, 0.0));
            scattered.radii.extend([0.25 * px; 2]);
            scattered.offsets.push(scattered.points.len() as u32);
        }
        let d = overlap(&scattered, &camera).unwrap();
        assert_eq!(d, exact(&scattered));
        assert!(d < 0.1, "{d}");
    }
}
