//! Ray-traced hair shadows: the exact visibility of a point through the
//! strands (each segment a capsule of its mean radius), by a 3D DDA through
//! a uniform grid of segment lists. The reference the shadow-map models are
//! measured against (shadow model `traced`), not a real-time path.

use super::setup::WorldSegment;
use glam::Vec3;

mod bundle;
mod capsule;

use capsule::{capsule_exit, capsule_hit, contains, segment_crosses_box, Capsule};

/// Strand segments binned to a uniform grid of cells.
#[derive(Debug, Clone)]
pub struct SegmentGrid {
    origin: Vec3,
    cell: f32,
    dims: [usize; 3],
    /// CSR: the segments of cell c are `items[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
    segments: Vec<Capsule>,
    /// Per world segment, its capsule's index in `segments` (u32::MAX: a
    /// segment left out as not finite).
    capsule_of: Vec<u32>,
    /// Per block of `BLOCK`³ cells, whether all of them are empty (a ray
    /// crosses such a block in one step).
    empty_block: Vec<bool>,
    block_dims: [usize; 3],
    /// Segments either side of one that may overlap it (1 unless segments
    /// are shorter than a fiber's diameter; at most [`TUBE_NEAR`]).
    tube_near: usize,
    /// How much farther than its radius each capsule is listed, the box
    /// grown by as much (the parallel rays of [`Self::occluded_bundle`]).
    spread: f32,
    /// Whether every capsule lies inside the box (none left out of it as
    /// an outlier).
    all_inside: bool,
}

/// The most (cell, segment) entries the grid's cell boxes may hold in all
/// (8 bytes each while the grid is built: 512 MiB).
const MAX_ENTRIES: usize = 1 << 26;

/// Capsules a task of the grid's build takes.
const BUILD_CHUNK: usize = 8192;

/// Cells a side of the blocks the walk skips when empty.
const BLOCK: usize = 4;

/// Cells a block holds.
const BRICK: usize = BLOCK * BLOCK * BLOCK;

/// The index of cell `c` in the grid's lists: its block's cells are
/// stored together (block after block in x, y, z order, and in a block
/// its cells in the same order).
#[inline]
fn brick_index(c: [usize; 3], block_dims: [usize; 3]) -> usize {
    let [b, l] = [c.map(|k| k / BLOCK), c.map(|k| k % BLOCK)];
    (((b[2] * block_dims[1] + b[1]) * block_dims[0] + b[0]) * BLOCK + l[2]) * BLOCK * BLOCK
        + l[1] * BLOCK
        + l[0]
}

/// What a ray passes unblocked: its own strand up to `t_own`, and each
/// strand of `inside` up to its parameter.
struct Passes {
    strand: u32,
    t_own: f32,
    inside: [(u32, f32); 8],
    n_inside: usize,
}

impl Passes {
    #[inline]
    fn passed(&self, strand: u32, t: f32) -> bool {
        (strand == self.strand && t <= self.t_own)
            || self.inside[..self.n_inside]
                .iter()
                .any(|&(st, t_leave)| st == strand && t <= t_leave)
    }
}

impl SegmentGrid {
    /// The grid of `segments` over their box without outliers
    /// ([`super::setup::robust_box`]: segments beyond it are met only
    /// inside it), cells a quarter of the median segment length wide (at
    /// most 256 cells a side); None without segments.
    pub fn new(segments: &[WorldSegment]) -> Option<Self> {
        Self::with_spread(segments, 0.0)
    }

    /// [`Self::new`] with each capsule listed in the cells within
    /// `spread` beyond its radius, and the box grown by `spread`, so that
    /// rays parallel to one another and within `spread` of a middle ray
    /// can walk that ray's cells together ([`Self::occluded_bundle`]).
    pub fn with_spread(segments: &[WorldSegment], spread: f32) -> Option<Self> {
        let spread = if spread.is_finite() {
            spread.max(0.0)
        } else {
            0.0
        };
        use rayon::prelude::*;
        let pool = crate::threads::pool();
        // (each pass below in parallel, with the same result on any number
        // of threads: on one thread the grid of a head's 400 000 segments
        // took 0.5 s of the first frame)
        let mut caps: Vec<Capsule> = pool.install(|| {
            segments
                .par_iter()
                .enumerate()
                .filter(|(_, s)| {
                    s.a.is_finite() && s.b.is_finite() && s.ra.is_finite() && s.rb.is_finite()
                })
                .map(|(i, s)| {
                    let r = 0.5 * (s.ra + s.rb).max(0.0);
                    let reach = (0.5 * (s.b - s.a).length() + r) * (1.0 + 1e-4) + 1e-30;
                    Capsule {
                        a: s.a,
                        r2: r * r,
                        u: s.b - s.a,
                        reach,
                        r,
                        strand: s.strand,
                        segment: i as u32,
                    }
                })
                .collect()
        });
        if caps.is_empty() {
            return None;
        }
        // The box of the strands without outliers (a stray strand 1e18 away
        // made every cell hold all the hair), cells from the median segment
        // length (the mean took that strand's length in).
        let (ends, radii): (Vec<Vec3>, Vec<f32>) = pool.install(|| {
            caps.par_iter()
                .flat_map_iter(|c| {
                    let r = c.r2.sqrt();
                    [(c.a, r), (c.a + c.u, r)]
                })
                .unzip()
        });
        let (lo, hi) = super::setup::robust_box(&ends, &radii)?;
        let all_inside = pool.install(|| {
            caps.par_iter().all(|c| {
                let (end, r) = (c.a + c.u, Vec3::splat(c.r));
                (c.a.min(end) - r).cmpge(lo).all() && (c.a.max(end) + r).cmple(hi).all()
            })
        });
        let (lo, hi) = (lo - Vec3::splat(spread), hi + Vec3::splat(spread));
        let mut lengths: Vec<f32> = caps.iter().map(|c| c.u.length()).collect();
        let k = (lengths.len() - 1) / 2;
        let median_len = *lengths.select_nth_unstable_by(k, f32::total_cmp).1;
        let extent = (hi - lo).max_element().max(1e-6);
        // A quarter of the mean segment length: fewer candidates per cell,
        // for more cells on the way and more list entries (1280x720 demo
        // head, balanced, split shading: 1.31 s against 1.34-1.40 s at
        // 0.35 and 1.39-1.45 s at 0.5; 97 bytes a segment against 60 at
        // 0.5).
        let mut cell = (0.25 * median_len).max(extent / 256.0).max(1e-6);
        // Fibers far thicker than their segments are long (a radius of 4 on
        // segments 0.05 long) listed each capsule in millions of cells: 11 GB
        // and 40 s for five strands. The cells grow until the capsules'
        // boxes cover at most MAX_ENTRIES of them in all.
        // (summed in fixed chunks, the chunks' sums in order: the same
        // total on any number of threads)
        let entries = |cell: f32| -> f64 {
            let sums: Vec<f64> = pool.install(|| {
                caps.par_chunks(BUILD_CHUNK)
                    .map(|chunk| {
                        chunk
                            .iter()
                            .map(|c| {
                                let ext = c.u.abs() + Vec3::splat(2.0 * (c.r + spread));
                                ext.to_array()
                                    .iter()
                                    .map(|e| ((e / cell).min(256.0) as f64 + 2.0).min(257.0))
                                    .product::<f64>()
                            })
                            .sum()
                    })
                    .collect()
            });
            sums.iter().sum()
        };
        for _ in 0..16 {
            let n = entries(cell);
            if n <= MAX_ENTRIES as f64 {
                break;
            }
            cell *= ((n / MAX_ENTRIES as f64).cbrt() as f32).max(1.25);
        }
        let dims = ((hi - lo) / cell)
            .to_array()
            .map(|e| (e.ceil() as usize).max(1));
        // cells stored block by block ([`brick_index`]): the cells a ray
        // walks through in a block lie in a few cache lines
        let block_dims = dims.map(|n| n.div_ceil(BLOCK));
        let blocks = block_dims[0] * block_dims[1] * block_dims[2];
        let count = blocks * BRICK;
        let cell_of = |p: Vec3| -> [usize; 3] {
            let g = (p - lo) / cell;
            [0, 1, 2].map(|k| (g[k].max(0.0) as usize).min(dims[k] - 1))
        };
        // The capsules in Morton order of their midpoints' cells, so that a
        // cell's list reads nearby memory, and the cells along a ray read
        // the same few cache lines (in strand order, a cell's capsules lay
        // across the whole array).
        // (keys distinct: the same order on any number of threads)
        pool.install(|| {
            caps.par_sort_by_cached_key(|c| {
                let [x, y, z] = cell_of(c.a + 0.5 * c.u);
                (morton_code([x, y, z].map(|a| a as u32)), c.segment)
            })
        });
        let mut capsule_of = vec![u32::MAX; segments.len()];
        for (k, c) in caps.iter().enumerate() {
            capsule_of[c.segment as usize] = k as u32;
        }
        // Each capsule into the cells its axis passes within its radius
        // of: those whose box, grown by the radius (and 1e-3 of a cell
        // against rounding), the segment crosses (a slab test). The grown
        // box holds every point within the radius of the cell, so a cell
        // left out holds no point of the capsule.
        let pad = 1e-3 * cell;
        let cells_of = |i: usize, c: &Capsule, lists: &mut Vec<(u32, u32)>| {
            let (end, r) = (c.a + c.u, c.r + spread);
            let (a, b) = (
                cell_of(c.a.min(end) - Vec3::splat(r)),
                cell_of(c.a.max(end) + Vec3::splat(r)),
            );
            let grow = Vec3::splat(r + pad);
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        let lo_c = lo + Vec3::new(x as f32, y as f32, z as f32) * cell;
                        if segment_crosses_box(
                            c.a,
                            end,
                            lo_c - grow,
                            lo_c + Vec3::splat(cell) + grow,
                        ) {
                            lists.push((brick_index([x, y, z], block_dims) as u32, i as u32));
                        }
                    }
                }
            }
        };
        // (each chunk's pairs, concatenated in order; pairs distinct: the
        // same sorted list on any number of threads)
        let mut lists: Vec<(u32, u32)> = pool.install(|| {
            let parts: Vec<Vec<(u32, u32)>> = caps
                .par_chunks(BUILD_CHUNK)
                .enumerate()
                .map(|(k, chunk)| {
                    let mut part = Vec::new();
                    for (j, c) in chunk.iter().enumerate() {
                        cells_of(k * BUILD_CHUNK + j, c, &mut part);
                    }
                    part
                })
                .collect();
            crate::threads::concat_ordered(
                parts.len(),
                |k| parts[k].len(),
                |k, push| {
                    for &e in &parts[k] {
                        push(e)
                    }
                },
            )
        });
        pool.install(|| lists.par_sort_unstable());
        let mut start = vec![0u32; count + 1];
        for &(c, _) in &lists {
            start[c as usize + 1] += 1;
        }
        for c in 0..count {
            start[c + 1] += start[c];
        }
        let items: Vec<u32> = pool.install(|| lists.par_iter().map(|&(_, i)| i).collect());
        let empty_block: Vec<bool> = (0..blocks)
            .map(|b| start[b * BRICK] == start[(b + 1) * BRICK])
            .collect();
        // capsules k segments apart overlap only if the k - 1 between them
        // are shorter than the two radii
        let shortest = caps
            .iter()
            .map(|c| c.u.length() / c.r2.sqrt().max(1e-30))
            .fold(f32::INFINITY, f32::min);
        let tube_near = if shortest >= 2.0 {
            1
        } else {
            TUBE_NEAR.min(1 + (2.0 / shortest.max(1e-6)).ceil() as usize)
        };
        Some(Self {
            origin: lo,
            cell,
            dims,
            start,
            items,
            segments: caps,
            capsule_of,
            empty_block,
            block_dims,
            tube_near,
            spread,
            all_inside,
        })
    }

    /// The ray parameter where a ray that starts inside (or on) capsule
    /// `k` first leaves its strand's tube: it leaves capsule `k`, then each
    /// capsule of the same strand that holds the point where it is, until it
    /// is in none. The union of a strand's capsules is its tube, so where the
    /// strand is cut into segments does not matter.
    #[inline(never)]
    fn strand_exit(&self, o: Vec3, d: Vec3, k: usize) -> f32 {
        let strand = self.segments[k].strand;
        let mut t = capsule_exit(o, d, &self.segments[k]);
        let mut cur = self.segments[k].segment as usize;
        let last = self.capsule_of.len() - 1;
        for _ in 0..MAX_TUBE_STEPS {
            let p = o + d * t;
            let mut next = (t, cur);
            for j in cur.saturating_sub(self.tube_near)..=(cur + self.tube_near).min(last) {
                let Some(c) = self.segments.get(self.capsule_of[j] as usize) else {
                    continue;
                };
                if j != cur && c.strand == strand && contains(p, c) {
                    let e = capsule_exit(o, d, c);
                    if e > next.0 {
                        next = (e, j);
                    }
                }
            }
            if next.0 <= t {
                break;
            }
            (t, cur) = next;
        }
        t
    }

    /// Where a ray from a point of `fiber` leaves its own strand's tube
    /// ([`Self::strand_exit`] from the fiber's own segment; 0 for a point on
    /// no strand).
    fn own_strand_exit(&self, o: Vec3, d: Vec3, fiber: &super::shade::Fiber) -> f32 {
        match self.capsule_of.get(fiber.segment as usize) {
            Some(&k)
                if self
                    .segments
                    .get(k as usize)
                    .is_some_and(|c| c.strand == fiber.strand) =>
            {
                self.strand_exit(o, d, k as usize)
            }
            _ => 0.0,
        }
    }

    /// Bytes held by the grid.
    pub fn bytes(&self) -> usize {
        (self.start.len() + self.items.len() + self.capsule_of.len()) * 4
            + self.segments.len() * std::mem::size_of::<Capsule>()
            + self.empty_block.len()
    }

    /// Whether the ray from `o` along unit `d`, up to `t_max`, meets a
    /// strand after leaving the receiver's own `fiber`. The ray passes its
    /// own strand until it first leaves that strand's tube (light from
    /// behind the fiber runs through it, nearly along it through several
    /// segments): the fiber scatters as one surface event, as in a path
    /// tracer, where light through a fiber from behind reaches the camera
    /// (so a ray leaving a curve from inside is not stopped by it). After
    /// that its own strand shadows like any other where the ray enters it
    /// again (a bend or a curl turning back).
    /// The rule is the tube's, not the segments': the same strand cut into
    /// more segments casts the same shadows.
    pub fn occluded(&self, o: Vec3, d: Vec3, t_max: f32, fiber: &super::shade::Fiber) -> bool {
        self.occluded_with(o, d, t_max, fiber, false)
    }

    /// [`Self::occluded`], or with `own_strand_passes` Cycles' rule: the
    /// ray passes its whole own strand (`render.shadows.traced.own_strand`
    /// "passes", for comparing with Cycles).
    pub fn occluded_with(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        fiber: &super::shade::Fiber,
        own_strand_passes: bool,
    ) -> bool {
        let Some(entry) = self.enter(o, d, t_max) else {
            return false;
        };
        // what the ray passes, found at its first hit (most rays toward a
        // light in front of the fiber meet nothing)
        let mut passes: Option<Passes> = None;
        self.walk(o, d, t_max, entry, |items, _| {
            items.iter().any(|&i| {
                let s = &self.segments[i as usize];
                s.may_hit(o, d, t_max)
                    && capsule_hit(o, d, t_max, s).is_some_and(|t| {
                        !passes
                            .get_or_insert_with(|| {
                                self.passes(o, d, entry, fiber, own_strand_passes)
                            })
                            .passed(s.strand, t)
                    })
            })
        })
    }

    /// The first segment the ray from `o` along unit `d` meets before
    /// `t_max`, passing what [`Self::occluded`] passes: the ray parameter
    /// of its closest approach to the axis (within a radius of where the
    /// ray enters the fiber), and the fiber met (its unit tangent, strand
    /// and segment).
    pub fn first_hit(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        fiber: &super::shade::Fiber,
    ) -> Option<(f32, Vec3, super::shade::Fiber)> {
        let entry = self.enter(o, d, t_max)?;
        let passes = self.passes(o, d, entry, fiber, false);
        let mut best: Option<(f32, u32)> = None;
        self.walk(o, d, t_max, entry, |items, t_cell_exit| {
            for &i in items {
                let s = &self.segments[i as usize];
                let t_best = best.map_or(t_max, |b| b.0);
                // (the hit's parameter is read up to t_max, not t_best: a
                // capsule met before the best's closest approach but with
                // its own beyond it would otherwise be clamped to a tie,
                // and the order of the lists would decide)
                if s.may_hit(o, d, t_best) {
                    if let Some(t) = capsule_hit(o, d, t_max, s) {
                        // the nearer; at equal distance (the joint of two
                        // segments) the earlier segment, whatever the order
                        // of the lists
                        let nearer = |b: (f32, u32)| {
                            t < b.0 || (t == b.0 && s.segment < self.segments[b.1 as usize].segment)
                        };
                        if !passes.passed(s.strand, t) && best.is_none_or(nearer) {
                            best = Some((t, i));
                        }
                    }
                }
            }
            // a hit within this cell is the first: later cells lie beyond it
            best.is_some_and(|b| b.0 <= t_cell_exit)
        });
        best.map(|(t, i)| {
            let s = &self.segments[i as usize];
            (
                t,
                s.u.normalize_or_zero(),
                super::shade::Fiber {
                    radius: s.r2.sqrt(),
                    strand: s.strand,
                    segment: s.segment,
                },
            )
        })
    }

    /// What a ray from a point of `fiber` passes (its own strand until it
    /// leaves the strand's tube, or all of it with `own_strand_passes`;
    /// strands whose tube holds the origin, until it leaves them).
    fn passes(
        &self,
        o: Vec3,
        d: Vec3,
        (t_enter, c): (f32, [i64; 3]),
        fiber: &super::shade::Fiber,
        own_strand_passes: bool,
    ) -> Passes {
        let mut p = Passes {
            strand: fiber.strand,
            t_own: if own_strand_passes {
                f32::INFINITY
            } else {
                self.own_strand_exit(o, d, fiber)
            },
            inside: [(u32::MAX, 0.0f32); 8],
            n_inside: 0,
        };
        // Other strands whose tube the ray starts in (fibers that
        // interpenetrate): each is passed as the own strand is, until the
        // ray leaves its tube (a path tracer's ray leaves a curve it starts
        // inside unblocked).
        if t_enter == 0.0 {
            let ci = self.cell_index(c);
            for &i in &self.items[self.start[ci] as usize..self.start[ci + 1] as usize] {
                let s = &self.segments[i as usize];
                if s.strand != fiber.strand && contains(o, s) {
                    let t_leave = self.strand_exit(o, d, i as usize);
                    if let Some(e) = p.inside[..p.n_inside].iter_mut().find(|e| e.0 == s.strand) {
                        e.1 = e.1.max(t_leave);
                    } else if p.n_inside < p.inside.len() {
                        p.inside[p.n_inside] = (s.strand, t_leave);
                        p.n_inside += 1;
                    }
                }
            }
        }
        p
    }

    /// The grid cell where the ray from `o` along `d` enters the grid's box
    /// (at `t_enter` ≥ 0), if it does before `t_max`.
    fn enter(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, [i64; 3])> {
        let hi = self.origin
            + Vec3::new(
                self.dims[0] as f32,
                self.dims[1] as f32,
                self.dims[2] as f32,
            ) * self.cell;
        let inv = Vec3::ONE / d;
        let (t0, t1) = ((self.origin - o) * inv, (hi - o) * inv);
        let t_enter = t0.min(t1).max_element().max(0.0);
        let t_exit = t0.max(t1).min_element().min(t_max);
        if !(t_enter <= t_exit) {
            return None;
        }
        let g = (o + d * t_enter - self.origin) / self.cell;
        Some((
            t_enter,
            [0, 1, 2].map(|k| (g[k].max(0.0) as i64).min(self.dims[k] as i64 - 1)),
        ))
    }

    /// The items of the cells the ray passes through from where it enters
    /// the grid (`entry`, from [`Self::enter`]), in order (a 3D DDA,
    /// Amanatides & Woo; empty blocks crossed in one step), until `visit`
    /// returns true (then true) or the ray leaves the grid or passes
    /// `t_max`. `visit` gets the cell's items and the ray parameter where
    /// the ray leaves the cell.
    fn walk(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        (t_enter, mut c): (f32, [i64; 3]),
        mut visit: impl FnMut(&[u32], f32) -> bool,
    ) -> bool {
        let inv = Vec3::ONE / d;
        let step = [0, 1, 2].map(|k| if d[k] > 0.0 { 1i64 } else { -1 });
        // Ray parameter of the next cell boundary along axis k from cell
        // coordinate `ck`, and of a cell's width.
        let boundary = |k: usize, ck: i64| {
            if d[k] != 0.0 {
                (self.origin[k] + (ck + (step[k] > 0) as i64) as f32 * self.cell - o[k]) * inv[k]
            } else {
                f32::INFINITY
            }
        };
        let mut next = [0, 1, 2].map(|k| boundary(k, c[k]));
        let delta = [0, 1, 2].map(|k| {
            if d[k] != 0.0 {
                self.cell * inv[k].abs()
            } else {
                f32::INFINITY
            }
        });
        let mut t = t_enter;
        while t <= t_max {
            let b = [0, 1, 2].map(|k| c[k] as usize / BLOCK);
            if self.empty_block[self.cell_index(c) / BRICK] {
                // an empty block: on to the cell where the ray leaves it
                let mut a = 0;
                let mut t_out = f32::INFINITY;
                for k in 0..3 {
                    // (the block's last cell along k, as a cell's far face)
                    let last = if step[k] > 0 {
                        ((b[k] + 1) * BLOCK) as i64 - 1
                    } else {
                        (b[k] * BLOCK) as i64
                    };
                    let tk = boundary(k, last);
                    if tk < t_out {
                        (t_out, a) = (tk, k);
                    }
                }
                if !(t_out <= t_max) {
                    return false;
                }
                let g = (o + d * t_out - self.origin) / self.cell;
                for k in 0..3 {
                    c[k] = if k == a {
                        if step[k] > 0 {
                            ((b[k] + 1) * BLOCK) as i64
                        } else {
                            (b[k] * BLOCK) as i64 - 1
                        }
                    } else {
                        let lo = (b[k] * BLOCK) as i64;
                        let hi = (((b[k] + 1) * BLOCK).min(self.dims[k]) - 1) as i64;
                        (crate::math::floor(g[k]) as i64).clamp(lo, hi)
                    };
                    if c[k] < 0 || c[k] >= self.dims[k] as i64 {
                        return false;
                    }
                    next[k] = boundary(k, c[k]);
                }
                t = t_out;
                continue;
            }
            let ci = self.cell_index(c);
            let t_exit = next[0].min(next[1]).min(next[2]);
            if visit(
                &self.items[self.start[ci] as usize..self.start[ci + 1] as usize],
                t_exit,
            ) {
                return true;
            }
            let k = if next[0] < next[1] {
                if next[0] < next[2] {
                    0
                } else {
                    2
                }
            } else if next[1] < next[2] {
                1
            } else {
                2
            };
            t = next[k];
            next[k] += delta[k];
            c[k] += step[k];
            if c[k] < 0 || c[k] >= self.dims[k] as i64 {
                break;
            }
        }
        false
    }

    /// The index of the cell at grid coordinates `c` (inside the grid).
    #[inline]
    fn cell_index(&self, c: [i64; 3]) -> usize {
        brick_index(c.map(|k| k as usize), self.block_dims)
    }
}

/// Segments either side of a capsule that a strand's tube is followed
/// through at most (all that may overlap it down to segments two thirds
/// of a fiber's diameter long).
const TUBE_NEAR: usize = 3;

/// Capsules a ray inside its own strand's tube follows at most.
const MAX_TUBE_STEPS: usize = 1 << 12;

/// The bits of `v` (21 at most) spread to every third bit (a Morton code's
/// one axis).
fn morton3(v: u32) -> u64 {
    let mut x = u64::from(v) & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The Morton code of grid coordinates (21 bits each at most): their
/// bits interleaved, x lowest.
pub(crate) fn morton_code([x, y, z]: [u32; 3]) -> u64 {
    morton3(x) | morton3(y) << 1 | morton3(z) << 2
}

#[cfg(test)]
mod tests;
