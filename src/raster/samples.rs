//! Coverage samples: hair fibers drawn as the opaque sub-pixel geometry they
//! are (the A-buffer's coverage masks, Carpenter 1984, kept as per-sample
//! depth as in multisample anti-aliasing). A sample's depth is where the
//! ray through it meets the fiber's surface ([`strand_depth`]).
//!
//! Every pixel holds `n` sample points, a low-discrepancy set (the R2
//! sequence, Roberts 2018) shifted toroidally by a hash of the pixel, so
//! neighbouring pixels do not alias alike. A strand covers a sample when the
//! point lies within its true projected half-width of the centre line (no
//! one-pixel minimum, butt joints and a round tip as in [`super::coverage`]);
//! a card covers a sample when a hash of (triangle, pixel, sample) falls
//! below its texture's alpha (alpha to coverage). Each sample keeps the
//! nearest fragment; the opaque surface's depth starts every sample.
//!
//! A pixel is then the sum over the fragments that own samples of their
//! radiance times the fraction of samples they own, plus the opaque
//! surface's radiance times the fraction nobody covers. So disjoint strands
//! add up as their areas do, a strand hides exactly what lies behind it,
//! and only visible fragments are shaded. The estimate of a pixel's
//! coverage is unbiased (each sample point is uniform over the pixel); its
//! noise falls as 1/√n.

use super::bin::TILE;
use super::coverage::on_stretch_at;
use super::setup::Segment;
use crate::math::fract;
use glam::Vec3;

/// Inclusive range of the number of coverage samples per pixel.
pub const SAMPLES: (usize, usize) = (1, 256);

/// Owner of a sample no hair covers.
const NONE: u32 = u32::MAX;

/// Sample points of the pixels of one tile, in image coordinates. A
/// pixel's points are computed when it is first asked for
/// ([`Self::pixel_mut`], [`Self::fill`]): most of a tile's pixels may hold
/// no hair, and their points are then never needed.
pub struct SamplePoints {
    pub n: usize,
    /// The tile's first pixel.
    x0: u32,
    y0: u32,
    /// The R2 points in the unit square, before each pixel's shift.
    base: Vec<[f64; 2]>,
    /// `(x, y)` of sample `s` of tile pixel `k` at `k·n + s` (where `filled`).
    xy: Vec<[f32; 2]>,
    /// Which pixels' points are computed, a bit per tile pixel.
    filled: [u64; (TILE * TILE / 64) as usize],
}

/// A 32-bit integer hash (lowbias32, Wellons 2018).
#[inline]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// A hash of `x` as a number in [0, 1).
#[inline]
pub fn unit(x: u32) -> f32 {
    (hash32(x) >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

impl SamplePoints {
    /// The points of the `tw × th` pixels of the tile starting at
    /// `(x0, y0)`, all computed: R2 points shifted per pixel by a hash of
    /// its image coordinates (the same in every render and thread).
    pub fn new(n: usize, x0: u32, y0: u32, tw: u32, th: u32) -> Self {
        let mut pts = Self::lazy(n, x0, y0);
        for j in 0..th {
            for i in 0..tw {
                pts.fill((j * TILE + i) as usize);
            }
        }
        pts
    }

    /// The same points, none computed yet.
    pub fn lazy(n: usize, x0: u32, y0: u32) -> Self {
        // R2: the plastic number's inverse powers.
        const G: f64 = 1.324_717_957_244_746;
        let (a1, a2) = (1.0 / G, 1.0 / (G * G));
        let base: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let i = i as f64 + 1.0;
                [fract(0.5 + a1 * i), fract(0.5 + a2 * i)]
            })
            .collect();
        Self {
            n,
            x0,
            y0,
            base,
            xy: vec![[0.0f32; 2]; (TILE * TILE) as usize * n],
            filled: [0; (TILE * TILE / 64) as usize],
        }
    }

    /// Computes the points of tile pixel `k` unless they are.
    #[inline]
    pub fn fill(&mut self, k: usize) {
        if self.is_filled(k) {
            return;
        }
        self.filled[k / 64] |= 1 << (k % 64);
        let n = self.n;
        let (x, y) = (self.x0 + k as u32 % TILE, self.y0 + k as u32 / TILE);
        let seed = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77);
        let (u, v) = (unit(seed) as f64, unit(seed ^ 0x68E3_1DA4) as f64);
        // Fractions at most 1 − 2⁻¹⁰, so that x + fraction stays in
        // pixel x in f32 for every x below 2^14 (the largest image
        // side; f32's spacing below it is at most 2⁻¹⁰). Moves 0.1 % of the
        // points by under 0.001 pixel.
        let frac = |a: f64| (fract(a) as f32).min(1.0 - 1.0 / 1024.0);
        for (s, b) in self.base.iter().enumerate() {
            self.xy[k * n + s] = [x as f32 + frac(b[0] + u), y as f32 + frac(b[1] + v)];
        }
    }

    /// The sample points of tile pixel `k`, computed first if need be.
    #[inline]
    pub fn pixel_mut(&mut self, k: usize) -> &[[f32; 2]] {
        self.fill(k);
        &self.xy[k * self.n..(k + 1) * self.n]
    }

    /// The sample points of tile pixel `k`, which must be computed
    /// ([`Self::fill`]).
    #[inline]
    pub fn pixel(&self, k: usize) -> &[[f32; 2]] {
        debug_assert!(self.is_filled(k));
        &self.xy[k * self.n..(k + 1) * self.n]
    }

    /// The sample points of tile pixel `k` where they are computed.
    #[inline]
    pub fn computed(&self, k: usize) -> Option<&[[f32; 2]]> {
        self.is_filled(k)
            .then(|| &self.xy[k * self.n..(k + 1) * self.n])
    }

    #[inline]
    fn is_filled(&self, k: usize) -> bool {
        self.filled[k / 64] & (1 << (k % 64)) != 0
    }
}

/// Whether sample point `p` lies on segment `s`'s strand: within half its
/// projected width of the centre line, on this segment's stretch (butt
/// joints: a point belongs to one segment of a polyline; the tip is round).
#[inline]
pub fn strand_covers(s: &Segment, d: [f32; 2], inv_len2: f32, p: [f32; 2]) -> bool {
    strand_depth(s, d, inv_len2, 0.0, p).is_some()
}

/// Where sample point `p` lies on segment `s`'s strand ([`strand_covers`]):
/// the depth at which the ray through it meets the fiber's surface. That is
/// the depth of the centre line's point nearest the sample (perspective-
/// correct) less `lead·√(1 − h²)`, `h` the sample's offset across the
/// fiber and `lead` the depth a ray through the centre line travels inside
/// the fiber before reaching the axis (`r / sin α` for a fiber at angle
/// α to the ray, in depth units: [`surface_lead`]). A segment seen nearly
/// end-on spans a range of depths within one pixel, and the ray meets its
/// surface several radii before its axis: each sample takes the depth of
/// its own hit, so that the fibers in front own the samples they cover, as
/// the first hit of a ray through the sample would. (The strand pass
/// computes the same, bit for bit, on vector lanes:
/// [`SampleBuffer::cover_strand`].)
#[inline]
pub fn strand_depth(
    s: &Segment,
    d: [f32; 2],
    inv_len2: f32,
    lead: f32,
    p: [f32; 2],
) -> Option<f32> {
    let (hit, depth) = sample_hit(&StrandSamples::new(s, d, inv_len2, lead), p);
    hit.then_some(depth)
}

/// [`strand_depth`] without a branch: whether sample point `p` lies on the
/// strand, and the depth there (meaningless where it does not).
#[inline(always)]
fn sample_hit(seg: &StrandSamples, p: [f32; 2]) -> (bool, f32) {
    let StrandSamples {
        a,
        d,
        inv_len2,
        wa,
        dw,
        za,
        zb,
        lead,
        last,
        has_length,
    } = *seg;
    let t_raw = ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) * inv_len2;
    let t = t_raw.clamp(0.0, 1.0);
    let (cx, cy) = (a[0] + t * d[0] - p[0], a[1] + t * d[1] - p[1]);
    let half = 0.5 * (wa + dw * t);
    let (e2, h2) = (cx * cx + cy * cy, half * half);
    let axis = 1.0 / ((1.0 - t) / za + t / zb);
    let depth = axis - lead * (1.0 - e2 / h2).max(0.0).sqrt();
    let hit = (on_stretch_at(last, t_raw) | !has_length) & (e2 <= h2);
    (hit, depth)
}

/// What [`strand_depth`] reads of a segment, for [`SampleBuffer::cover_strand`].
#[derive(Debug, Clone, Copy)]
pub struct StrandSamples {
    a: [f32; 2],
    d: [f32; 2],
    inv_len2: f32,
    wa: f32,
    /// `wb − wa`
    dw: f32,
    za: f32,
    zb: f32,
    lead: f32,
    last: bool,
    has_length: bool,
}

impl StrandSamples {
    /// Segment `s` with its screen direction `d = b − a`, `1/|d|²` (0 for
    /// a point) and the fragment's `lead`.
    #[inline]
    pub fn new(s: &Segment, d: [f32; 2], inv_len2: f32, lead: f32) -> Self {
        Self {
            a: s.a,
            d,
            inv_len2,
            wa: s.wa,
            dw: s.wb - s.wa,
            za: s.za,
            zb: s.zb,
            lead,
            last: s.last,
            has_length: inv_len2 > 0.0,
        }
    }
}

/// The `lead` of [`strand_depth`] for a fiber of radius `r` and unit
/// tangent `t` at world point `p`, seen from `eye` at view depth `depth`:
/// `r / sin α` along the ray, times depth per unit of the ray's length.
/// 1/sin α is held to 16 (α ≥ 3.6°; a ray closer to the axis meets the
/// segment's end first).
#[inline]
pub fn surface_lead(r: f32, t: Vec3, p: Vec3, eye: Vec3, depth: f32) -> f32 {
    let to = p - eye;
    let dist = to.length();
    if !(dist > 0.0) {
        return 0.0;
    }
    let cos = (t.dot(to) / dist).abs().min(1.0);
    let sin = (1.0 - cos * cos).sqrt().max(1.0 / 16.0);
    r / sin * (depth / dist)
}

/// The nearest fragment per sample of a tile's pixels.
///
/// Fragments may arrive in any order: a sample goes to the nearest, and at
/// equal depth to the smaller key (the fragment's place in the scene's
/// order), never to hair at the opaque surface's own depth. So the owners
/// are the same whatever order the fragments are drawn in (the strand pass
/// draws each tile's segments nearest first).
pub struct SampleBuffer {
    pub n: usize,
    depth: Vec<f32>,
    owner: Vec<u32>,
    /// The owner's key per sample (0 where none: the opaque surface keeps
    /// its depth against hair at the same depth).
    key: Vec<u32>,
    /// Per pixel, the farthest of its samples' depths (NaN ignored).
    far: Vec<f32>,
}

/// A fragment offered to a pixel's samples: its `id` (what a sample's
/// owner names), its `key` in the scene's order, and a depth `depth_lo`
/// that none of its samples lies nearer than.
#[derive(Debug, Clone, Copy)]
pub struct Claim {
    pub id: u32,
    pub key: u32,
    pub depth_lo: f32,
}

impl Claim {
    /// Whether the fragment, at depth `at` on a sample now at `depth` with
    /// owner key `key`, takes it: nearer (and `depth_lo` nearer too, a
    /// bound that lets a caller skip a sample's depth), or as near with a
    /// smaller key.
    #[inline(always)]
    fn takes(&self, at: f32, depth: f32, key: u32) -> bool {
        ((self.depth_lo < depth) & (at < depth)) | ((at == depth) & (self.key < key))
    }
}

impl SampleBuffer {
    /// Every sample of pixel `k` starts at `opaque_depth[k]` with no owner.
    pub fn new(n: usize, opaque_depth: &[f32]) -> Self {
        let mut depth = Vec::with_capacity(opaque_depth.len() * n);
        for &d in opaque_depth {
            depth.extend(std::iter::repeat_n(d, n));
        }
        Self {
            n,
            owner: vec![NONE; depth.len()],
            key: vec![0; depth.len()],
            depth,
            far: opaque_depth.to_vec(),
        }
    }

    /// Whether a fragment none of whose sample depths lies below
    /// `depth_lo` could take a sample of pixel `k`: whether `depth_lo`
    /// lies no farther than the farthest of them. Where it does not,
    /// [`Self::cover`] and [`Self::cover_strand`] given that `depth_lo`
    /// take nothing ([`Claim::takes`]: each sample needs a depth at most
    /// its own, and `depth_lo` is below every depth the fragment has), so
    /// a caller may skip them.
    #[inline]
    pub fn may_take(&self, k: usize, depth_lo: f32) -> bool {
        depth_lo <= self.far[k]
    }

    /// The farthest of pixel `k`'s sample depths (NaN where no depth can
    /// take a sample: [`Self::may_take`]).
    #[inline]
    pub fn farthest(&self, k: usize) -> f32 {
        self.far[k]
    }

    /// Pixel `k`'s farthest sample depth, after it took samples.
    #[inline]
    fn update_far(&mut self, k: usize) {
        let base = k * self.n;
        self.far[k] = self.depth[base..base + self.n]
            .iter()
            .fold(f32::NEG_INFINITY, |m, &d| m.max(d));
    }

    /// Fragment `c` over the samples `s` of pixel `k` that it covers,
    /// `covers(s)` giving its depth there, where it lies nearest
    /// ([`Claim::takes`]); whether it took any. No depth `covers` gives is
    /// below `c.depth_lo`: samples already nearer are skipped without it.
    #[inline]
    pub fn cover(
        &mut self,
        k: usize,
        c: Claim,
        mut covers: impl FnMut(usize) -> Option<f32>,
    ) -> bool {
        let base = k * self.n;
        let mut took = false;
        for s in 0..self.n {
            let (dst, key) = (self.depth[base + s], self.key[base + s]);
            if !(c.depth_lo <= dst) {
                continue;
            }
            if let Some(depth) = covers(s) {
                if c.takes(depth, dst, key) {
                    self.depth[base + s] = depth;
                    self.owner[base + s] = c.id;
                    self.key[base + s] = c.key;
                    took = true;
                }
            }
        }
        if took {
            self.update_far(k);
        }
        took
    }

    /// [`Self::cover`] with [`strand_depth`] of `seg` at pixel `k`'s points
    /// `pts`: the same samples taken at the same depths, bit for bit, with
    /// every sample computed and kept or not by selection (no branch per
    /// sample, so that the loop runs on vector lanes).
    #[inline]
    pub fn cover_strand(
        &mut self,
        k: usize,
        c: Claim,
        pts: &[[f32; 2]],
        seg: &StrandSamples,
    ) -> bool {
        let base = k * self.n;
        let run = Run {
            depth: &mut self.depth[base..base + self.n],
            owner: &mut self.owner[base..base + self.n],
            key: &mut self.key[base..base + self.n],
            pts,
            claim: c,
        };
        let took = cover_strand_dispatch(run, seg);
        if took {
            self.update_far(k);
        }
        took
    }

    /// Samples owned per fragment (`counts[id]`, for ids below its length).
    pub fn counts(&self, counts: &mut [u32]) {
        for &o in &self.owner {
            if o != NONE {
                counts[o as usize] += 1;
            }
        }
    }

    /// The owners of pixel `k`'s samples (`None` where no hair covers one).
    #[inline]
    pub fn owners(&self, k: usize) -> impl Iterator<Item = Option<u32>> + '_ {
        self.owner[k * self.n..(k + 1) * self.n]
            .iter()
            .map(|&o| (o != NONE).then_some(o))
    }
}

/// [`cover_strand_lanes`] at the widest vector level the CPU has.
#[inline]
fn cover_strand_dispatch(run: Run<'_>, seg: &StrandSamples) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use crate::simd::Level;
        // SAFETY: Level::detect checked that the CPU has what each needs.
        match Level::detect() {
            Level::Avx512 => unsafe {
                return cover_strand_avx512(run, seg);
            },
            Level::Avx2 => unsafe {
                return cover_strand_avx2(run, seg);
            },
            Level::Portable => {}
        }
    }
    cover_strand_lanes::<4>(run, seg)
}

/// A pixel's samples (its slices of the buffer and its points) and the
/// fragment trying them.
struct Run<'a> {
    depth: &'a mut [f32],
    owner: &'a mut [u32],
    key: &'a mut [u32],
    pts: &'a [[f32; 2]],
    claim: Claim,
}

/// [`SampleBuffer::cover_strand`]'s loop over a pixel's samples, in chunks
/// of `W` samples of known length for the compiler to put on `W` vector
/// lanes (IEEE operations per lane, no fused multiply-add: the same bits at
/// any width).
#[inline(always)]
fn cover_strand_lanes<const W: usize>(run: Run<'_>, seg: &StrandSamples) -> bool {
    let Run {
        depth,
        owner,
        key,
        pts,
        claim,
    } = run;
    let whole = pts.len() / W * W;
    let mut took = false;
    for (((p, dst), own), kd) in pts[..whole]
        .chunks_exact(W)
        .zip(depth[..whole].chunks_exact_mut(W))
        .zip(owner[..whole].chunks_exact_mut(W))
        .zip(key[..whole].chunks_exact_mut(W))
    {
        let p: &[[f32; 2]; W] = p.try_into().expect("chunk of W");
        let dst: &mut [f32; W] = dst.try_into().expect("chunk of W");
        let own: &mut [u32; W] = own.try_into().expect("chunk of W");
        let kd: &mut [u32; W] = kd.try_into().expect("chunk of W");
        took |= cover_strand_run(dst, own, kd, p, claim, seg);
    }
    let rest = (&mut depth[whole..], &mut owner[whole..], &mut key[whole..]);
    took | cover_strand_run(rest.0, rest.1, rest.2, &pts[whole..], claim, seg)
}

/// The samples of one run: [`sample_hit`] at each, kept or not by
/// selection.
#[inline(always)]
fn cover_strand_run(
    depth: &mut [f32],
    owner: &mut [u32],
    key: &mut [u32],
    pts: &[[f32; 2]],
    claim: Claim,
    seg: &StrandSamples,
) -> bool {
    let mut took = false;
    for (((p, dst), own), kd) in pts
        .iter()
        .zip(depth.iter_mut())
        .zip(owner.iter_mut())
        .zip(key.iter_mut())
    {
        let (hit, at) = sample_hit(seg, *p);
        let take = hit & claim.takes(at, *dst, *kd);
        *dst = if take { at } else { *dst };
        *own = if take { claim.id } else { *own };
        *kd = if take { claim.key } else { *kd };
        took |= take;
    }
    took
}

/// [`cover_strand_lanes`] compiled with `$features` at `$w` lanes.
macro_rules! cover_strand_at {
    ($(#[$doc:meta])* $name:ident, $features:literal, $w:literal) => {
        $(#[$doc])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        unsafe fn $name(run: Run<'_>, seg: &StrandSamples) -> bool {
            cover_strand_lanes::<$w>(run, seg)
        }
    };
}
cover_strand_at!(
    /// AVX-512: a pixel's 16 samples at once.
    cover_strand_avx512,
    "avx512f,avx2",
    16
);
cover_strand_at!(
    /// AVX2: 8 samples at once.
    cover_strand_avx2,
    "avx2",
    8
);

#[cfg(test)]
mod tests;
