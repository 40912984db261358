//! Guide-strand lighting (after Capcom's RE ENGINE strand renderer, which
//! lit 1,420 simulation guides instead of 23,115 strands): a fraction of
//! the strands, the guides, is shaded at its vertices, and every other
//! strand takes at each vertex the values of its nearest guides at the same
//! fraction of their length.
//!
//! It replaces what is computed at vertices. Under `shading = "split"`
//! that is the environment and multiple scattering; each light's
//! unscattered light stays per fragment. Under `"vertex"`, with
//! [`GuideTerms::All`], it is everything (RE4's way); with
//! [`GuideTerms::Scattered`], the same terms as under `split`, each strand
//! vertex shading its lights' unscattered light itself. A strand seen from
//! outside a shadowed head is lit more than its neighbours inside, so
//! `All` darkens it (`docs/guides.md`); a light's unscattered light, with
//! its own shadow, is what `Scattered` keeps per strand.
//!
//! Which strands guide: those given (strand indices; where none of them is
//! drawn, every strand is shaded), or a fraction f in (0, 1] of them:
//! - `every`: strands `0, k, 2k, ...` with `k = round(1/f)`;
//! - `clusters`: `round(f·N)` clusters of the strands by k-means (four
//!   Lloyd iterations from farthest-point samples of the strands), each
//!   represented by the member nearest its centre.
//!
//! A strand is described by its points at 0, 1/2 and 1 of its arc length
//! (nine numbers); "nearest" is the Euclidean distance between those. A
//! strand takes the [`NEIGHBOURS`] nearest guides, weighted by inverse
//! squared distance, and from each the value at its own vertex's arc-length
//! fraction, interpolated between the guide's two vertices around it. A
//! guide's own vertices keep their values, so f = 1 equals shading every
//! vertex.
//!
//! The taps depend on the strands alone: they are cached per geometry and
//! choice, as the lighting is ([`super::lighting`]).

use super::scene::Strands;
use crate::threads::pool;
use rayon::prelude::*;
use std::sync::{Arc, Mutex, OnceLock};

/// Guides a strand takes its values from.
pub const NEIGHBOURS: usize = 3;
/// Lloyd iterations of `clusters`.
const LLOYD_ITERATIONS: usize = 4;

/// How guides are chosen (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GuideChoice {
    Every,
    Clusters,
}

/// What a strand takes from its guides under `shading = "vertex"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GuideTerms {
    /// Everything (RE4): the guides' radiance.
    All,
    /// What `split` shading reads at vertices (the environment, multiple
    /// scattering); each strand vertex shades its lights' unscattered light
    /// itself, with its own shadow.
    Scattered,
}

/// Guide-strand lighting's settings: the fraction of the strands that
/// guide (1: every strand is shaded, no guides), how they are chosen, and
/// what the others take from them; or the guide strands themselves
/// (`given`, indices into the strands drawn).
#[derive(Debug, Clone, PartialEq)]
pub struct Guides {
    pub fraction: f32,
    pub choice: GuideChoice,
    pub terms: GuideTerms,
    pub given: Option<Arc<[u32]>>,
}

impl Default for Guides {
    fn default() -> Self {
        Self {
            fraction: 1.0,
            choice: GuideChoice::Every,
            terms: GuideTerms::Scattered,
            given: None,
        }
    }
}

impl Guides {
    /// Whether any strand takes its values from guides.
    pub fn on(&self) -> bool {
        self.fraction < 1.0 || self.given.is_some()
    }

    /// The same settings with the given guides renumbered for a subset of
    /// the strands (`kept`: the original index of each strand kept,
    /// ascending), sorted once each; guides not kept are dropped.
    pub fn for_subset(&self, kept: &[usize]) -> Self {
        let given = self.given.as_ref().map(|g| {
            let mut sub: Vec<u32> = g
                .iter()
                .filter_map(|&s| kept.binary_search(&(s as usize)).ok().map(|i| i as u32))
                .collect();
            sub.sort_unstable();
            sub.dedup();
            sub.into()
        });
        Self {
            given,
            ..self.clone()
        }
    }
}

/// One guide vertex pair a vertex reads: `(1 − t)·x[vertex] + t·x[vertex + 1]`,
/// weighted by `w` (the taps of a vertex sum to 1; unused taps weigh 0).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Tap {
    pub vertex: u32,
    pub t: f32,
    pub w: f32,
}

/// The last render's guide map and its key.
type Cache = Mutex<Option<(u64, Arc<GuideMap>)>>;

/// Per strand vertex, the guide vertices its value is made of.
pub struct GuideMap {
    /// The guide strands, ascending.
    pub guides: Vec<u32>,
    /// `NEIGHBOURS` taps per vertex (a guide's vertex: itself, weight 1).
    taps: Vec<[Tap; NEIGHBOURS]>,
    /// Per vertex, its strand.
    owner: Vec<u32>,
}

impl GuideMap {
    /// The taps of every vertex of `strands` with guides chosen by `g`.
    pub fn new(strands: &Strands, g: &Guides) -> Self {
        let n = strands.strand_count();
        let feats: Vec<Feature> = (0..n).map(|s| feature(strands, s)).collect();
        let guides = choose(&feats, g);
        let mut is_guide = vec![false; n];
        for &s in &guides {
            is_guide[s as usize] = true;
        }
        let arc = arc_fractions(strands);
        let index = Index::new(&feats, &guides);
        let per_strand: Vec<Vec<[Tap; NEIGHBOURS]>> = pool().install(|| {
            (0..n)
                .into_par_iter()
                .map(|s| {
                    let r = strands.offsets[s] as usize..strands.offsets[s + 1] as usize;
                    if is_guide[s] {
                        return r.map(|i| own_tap(i as u32)).collect();
                    }
                    let near = index.nearest(&feats[s]);
                    // Inverse squared distance, bounded where a guide
                    // coincides with the strand.
                    let eps = 1e-12 * (1.0 + feats[s].iter().map(|x| x * x).sum::<f32>());
                    let w: Vec<f32> = near.iter().map(|&(d2, _)| 1.0 / (d2 + eps)).collect();
                    let total: f32 = w.iter().sum();
                    r.map(|i| {
                        let mut taps = [Tap::default(); NEIGHBOURS];
                        for (k, &(_, gs)) in near.iter().enumerate() {
                            let (vertex, t) = locate(strands, &arc, gs as usize, arc[i]);
                            taps[k] = Tap {
                                vertex,
                                t,
                                w: w[k] / total,
                            };
                        }
                        taps
                    })
                    .collect()
                })
                .collect()
        });
        let mut owner = vec![0u32; strands.points.len()];
        for s in 0..n {
            owner[strands.offsets[s] as usize..strands.offsets[s + 1] as usize].fill(s as u32);
        }
        Self {
            guides,
            taps: per_strand.into_iter().flatten().collect(),
            owner,
        }
    }

    /// [`Self::new`], or the map the last render built for the same
    /// strands (`geometry`: their hash, [`super::shadow::geometry_hash`])
    /// and settings.
    pub fn cached(strands: &Strands, g: &Guides, geometry: u64) -> Arc<Self> {
        static CACHE: OnceLock<Cache> = OnceLock::new();
        let mut h = super::shadow::WordHash::default();
        h.word(geometry);
        h.word(g.fraction.to_bits() as u64);
        h.word(g.choice as u64);
        if let Some(given) = &g.given {
            h.floats(given.iter().map(|&s| f32::from_bits(s)));
        }
        let key = h.finish();
        let cache = CACHE.get_or_init(|| Mutex::new(None));
        if let Some((_, m)) = cache
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
            .filter(|(k, _)| *k == key)
        {
            return m.clone();
        }
        let built = Arc::new(Self::new(strands, g));
        *cache.lock().unwrap_or_else(|e| e.into_inner()) = Some((key, built.clone()));
        built
    }

    /// The strand of vertex `i`.
    #[inline]
    pub fn owner(&self, i: usize) -> usize {
        self.owner[i] as usize
    }

    /// The taps of vertex `i`.
    #[inline]
    pub fn taps(&self, i: usize) -> &[Tap; NEIGHBOURS] {
        &self.taps[i]
    }

    /// The value at vertex `i` from the values `x` of guide vertices.
    #[inline]
    pub fn gather(&self, i: usize, x: impl Fn(usize) -> glam::Vec3) -> glam::Vec3 {
        let mut out = glam::Vec3::ZERO;
        for tap in self.taps[i].iter().filter(|t| t.w > 0.0) {
            let a = tap.vertex as usize;
            let v = if tap.t > 0.0 {
                x(a) * (1.0 - tap.t) + x(a + 1) * tap.t
            } else {
                x(a)
            };
            out += v * tap.w;
        }
        out
    }

    /// The guide vertices that the vertices where `used` is set read
    /// (all vertices' when `None`).
    pub fn needed(&self, used: Option<&[bool]>) -> Vec<bool> {
        let mut out = vec![false; self.taps.len()];
        for (i, taps) in self.taps.iter().enumerate() {
            if used.is_some_and(|u| !u[i]) {
                continue;
            }
            for tap in taps.iter().filter(|t| t.w > 0.0) {
                out[tap.vertex as usize] = true;
                if tap.t > 0.0 {
                    out[tap.vertex as usize + 1] = true;
                }
            }
        }
        out
    }
}

fn own_tap(i: u32) -> [Tap; NEIGHBOURS] {
    let mut taps = [Tap::default(); NEIGHBOURS];
    taps[0] = Tap {
        vertex: i,
        t: 0.0,
        w: 1.0,
    };
    taps
}

/// A strand's points at 0, 1/2 and 1 of its arc length.
type Feature = [f32; 9];

fn feature(st: &Strands, s: usize) -> Feature {
    let p = &st.points[st.offsets[s] as usize..st.offsets[s + 1] as usize];
    let mut f = [0.0; 9];
    if p.is_empty() {
        return f;
    }
    let total: f32 = p.windows(2).map(|w| (w[1] - w[0]).length()).sum();
    let mid = {
        let (mut run, mut at) = (0.0, p[0]);
        for w in p.windows(2) {
            let l = (w[1] - w[0]).length();
            if run + l >= 0.5 * total && l > 0.0 {
                at = w[0].lerp(w[1], (0.5 * total - run) / l);
                break;
            }
            run += l;
        }
        at
    };
    for (k, q) in [p[0], mid, p[p.len() - 1]].iter().enumerate() {
        f[3 * k..3 * k + 3].copy_from_slice(&q.to_array());
    }
    f
}

fn dist2(a: &Feature, b: &Feature) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Per vertex, its arc-length fraction along its strand (0 at the root, 1
/// at the tip; by index where the strand has no length).
fn arc_fractions(st: &Strands) -> Vec<f32> {
    let mut out = vec![0.0; st.points.len()];
    for s in 0..st.strand_count() {
        let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
        let mut run = 0.0f64;
        for (i, x) in out.iter_mut().enumerate().take(i1).skip(i0 + 1) {
            run += (st.points[i] - st.points[i - 1]).length() as f64;
            *x = run as f32;
        }
        let n = (i1 - i0).max(2) - 1;
        for (j, x) in out[i0..i1].iter_mut().enumerate() {
            *x = if run > 0.0 {
                (*x as f64 / run) as f32
            } else {
                j as f32 / n as f32
            };
        }
    }
    out
}

/// Where on strand `s` the arc-length fraction `u` lies: its vertex before
/// and the parameter towards the next one.
fn locate(st: &Strands, arc: &[f32], s: usize, u: f32) -> (u32, f32) {
    let (i0, i1) = (st.offsets[s] as usize, st.offsets[s + 1] as usize);
    let a = &arc[i0..i1];
    // The last vertex at or before u.
    let j = a.partition_point(|&x| x <= u).saturating_sub(1);
    if j + 1 >= a.len() {
        return ((i0 + j) as u32, 0.0);
    }
    let span = a[j + 1] - a[j];
    let t = if span > 0.0 {
        ((u - a[j]) / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((i0 + j) as u32, t)
}

/// The guide strands for `g`, ascending.
fn choose(feats: &[Feature], g: &Guides) -> Vec<u32> {
    let n = feats.len();
    if n == 0 {
        return Vec::new();
    }
    if let Some(given) = &g.given {
        let mut guides: Vec<u32> = given
            .iter()
            .copied()
            .filter(|&s| (s as usize) < n)
            .collect();
        guides.sort_unstable();
        guides.dedup();
        if guides.is_empty() {
            return (0..n as u32).collect();
        }
        return guides;
    }
    let k = ((1.0 / g.fraction.max(f32::MIN_POSITIVE)).round() as usize).clamp(1, n);
    let every: Vec<u32> = (0..n).step_by(k).map(|s| s as u32).collect();
    if g.choice == GuideChoice::Every || g.fraction >= 1.0 {
        return every;
    }
    let count = ((g.fraction as f64 * n as f64).round() as usize).clamp(1, n);
    let mut centres: Vec<Feature> = farthest_points(feats, count)
        .into_iter()
        .map(|s| feats[s as usize])
        .collect();
    let mut owner = vec![0u32; n];
    for _ in 0..LLOYD_ITERATIONS {
        let ids: Vec<u32> = (0..centres.len() as u32).collect();
        let index = Index::new(&centres, &ids);
        owner = pool().install(|| feats.par_iter().map(|f| index.nearest_one(f).1).collect());
        let mut sum = vec![[0.0f64; 9]; centres.len()];
        let mut members = vec![0usize; centres.len()];
        for (f, &c) in feats.iter().zip(&owner) {
            members[c as usize] += 1;
            for (a, &x) in sum[c as usize].iter_mut().zip(f) {
                *a += x as f64;
            }
        }
        for ((c, s), &m) in centres.iter_mut().zip(&sum).zip(&members) {
            if m > 0 {
                for (x, &a) in c.iter_mut().zip(s) {
                    *x = (a / m as f64) as f32;
                }
            }
        }
    }
    // Each cluster's member nearest its centre.
    let mut best = vec![(f32::INFINITY, u32::MAX); centres.len()];
    for (s, (f, &c)) in feats.iter().zip(&owner).enumerate() {
        let d = dist2(f, &centres[c as usize]);
        if d < best[c as usize].0 {
            best[c as usize] = (d, s as u32);
        }
    }
    let mut guides: Vec<u32> = best
        .into_iter()
        .filter(|b| b.1 != u32::MAX)
        .map(|b| b.1)
        .collect();
    guides.sort_unstable();
    guides.dedup();
    guides
}

/// `count` strands spread over the features: strand 0, then repeatedly
/// the strand farthest from those chosen (ties: the lowest index).
fn farthest_points(feats: &[Feature], count: usize) -> Vec<u32> {
    let mut chosen = vec![0u32];
    let mut near: Vec<f32> = feats.iter().map(|f| dist2(f, &feats[0])).collect();
    while chosen.len() < count.min(feats.len()) {
        let (d, s) = pool().install(|| {
            near.par_iter().enumerate().map(|(s, &d)| (d, s)).reduce(
                || (f32::NEG_INFINITY, usize::MAX),
                |a, b| {
                    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
                        b
                    } else {
                        a
                    }
                },
            )
        });
        if d <= 0.0 {
            break; // every strand coincides with a chosen one
        }
        chosen.push(s as u32);
        let c = feats[s];
        pool().install(|| {
            near.par_iter_mut()
                .zip(feats)
                .for_each(|(m, f)| *m = m.min(dist2(f, &c)))
        });
    }
    chosen
}

/// Nearest-neighbour search over features: a uniform grid over their
/// middle points, searched in rings of cells outwards until no unvisited
/// cell can hold a nearer one (the distance between middle points bounds
/// the features' from below).
struct Index<'a> {
    feats: &'a [Feature],
    /// Members sorted by cell; `start[c]..start[c + 1]` are cell `c`'s.
    order: Vec<u32>,
    start: Vec<u32>,
    dims: [i64; 3],
    lo: [f32; 3],
    cell: f32,
}

impl<'a> Index<'a> {
    /// An index over `feats[m]` for the members `m` in `ids`.
    fn new(feats: &'a [Feature], ids: &[u32]) -> Self {
        let mid = |m: u32| {
            let f = &feats[m as usize];
            [f[3], f[4], f[5]]
        };
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for &m in ids {
            let p = mid(m);
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let ext: Vec<f32> = (0..3).map(|a| (hi[a] - lo[a]).max(0.0)).collect();
        let longest = ext.iter().cloned().fold(0.0f32, f32::max);
        // About two members per cell of the bounds, at most 128 a side.
        let cells = (ids.len() as f32 / 2.0).max(1.0);
        let volume: f32 = ext.iter().map(|e| e.max(longest * 1e-3)).product();
        let cell = if longest > 0.0 {
            (volume / cells).cbrt().max(longest / 128.0)
        } else {
            1.0
        };
        let dims = [0, 1, 2].map(|a| ((ext[a] / cell).floor() as i64 + 1).clamp(1, 129));
        let mut index = Self {
            feats,
            order: Vec::new(),
            start: Vec::new(),
            dims,
            lo: if ids.is_empty() { [0.0; 3] } else { lo },
            cell,
        };
        let total = (dims[0] * dims[1] * dims[2]) as usize;
        let cell_of: Vec<usize> = ids
            .iter()
            .map(|&m| index.flat(index.coords(mid(m))))
            .collect();
        let mut count = vec![0u32; total + 1];
        for &c in &cell_of {
            count[c + 1] += 1;
        }
        for c in 0..total {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut order = vec![0u32; ids.len()];
        for (&m, &c) in ids.iter().zip(&cell_of) {
            order[fill[c] as usize] = m;
            fill[c] += 1;
        }
        index.order = order;
        index.start = count;
        index
    }

    fn coords(&self, p: [f32; 3]) -> [i64; 3] {
        [0, 1, 2].map(|a| {
            (crate::math::floor((p[a] - self.lo[a]) / self.cell) as i64).clamp(0, self.dims[a] - 1)
        })
    }

    fn flat(&self, c: [i64; 3]) -> usize {
        ((c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]) as usize
    }

    /// The [`NEIGHBOURS`] nearest members to `q` (fewer if there are
    /// fewer): (squared distance, member), nearest first.
    fn nearest(&self, q: &Feature) -> Vec<(f32, u32)> {
        let mut best: Vec<(f32, u32)> = Vec::with_capacity(NEIGHBOURS + 1);
        self.search(q, NEIGHBOURS, &mut best);
        best
    }

    /// The nearest member to `q` ((∞, 0) without members).
    fn nearest_one(&self, q: &Feature) -> (f32, u32) {
        let mut best = Vec::with_capacity(2);
        self.search(q, 1, &mut best);
        best.first().copied().unwrap_or((f32::INFINITY, 0))
    }

    fn search(&self, q: &Feature, k: usize, best: &mut Vec<(f32, u32)>) {
        let c = self.coords([q[3], q[4], q[5]]);
        let max_ring = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=max_ring {
            let lo = c.map(|x| x - r);
            let hi = c.map(|x| x + r);
            for z in lo[2].max(0)..=hi[2].min(self.dims[2] - 1) {
                for y in lo[1].max(0)..=hi[1].min(self.dims[1] - 1) {
                    // Inside the ring in y and z: only its two x ends.
                    let inner = (y - c[1]).abs() < r && (z - c[2]).abs() < r;
                    let xs = lo[0].max(0)..=hi[0].min(self.dims[0] - 1);
                    for x in xs.filter(|&x| !inner || (x - c[0]).abs() == r) {
                        let cell = self.flat([x, y, z]);
                        for &m in
                            &self.order[self.start[cell] as usize..self.start[cell + 1] as usize]
                        {
                            let d = dist2(q, &self.feats[m as usize]);
                            if best.len() < k || d < best[best.len() - 1].0 {
                                let at = best.partition_point(|b| (b.0, b.1) < (d, m));
                                best.insert(at, (d, m));
                                best.truncate(k);
                            }
                        }
                    }
                }
            }
            // Every member in ring r + 1 or beyond is at least r cells away.
            let bound = r as f32 * self.cell;
            if best.len() == k && best[k - 1].0 <= bound * bound {
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests;
