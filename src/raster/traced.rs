//! Ray-traced hair shadows: the exact visibility of a point through the
//! strands (each segment a capsule of its mean radius), by a 3D DDA through
//! a uniform grid of segment lists. The reference the shadow-map models are
//! measured against (shadow model `traced`), not a real-time path.

use super::setup::WorldSegment;
use glam::Vec3;

mod bundle;

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

#[derive(Debug, Clone, Copy)]
struct Capsule {
    /// The axis `a + s·u`, s in [0, 1].
    a: Vec3,
    /// The radius squared.
    r2: f32,
    u: Vec3,
    /// The radius of a sphere around the axis's midpoint holding the
    /// capsule (padded by 1e-4 relative, so that rounding never makes the
    /// sphere reject a ray the capsule test would accept).
    reach: f32,
    /// The radius.
    r: f32,
    strand: u32,
    /// Index in the world segments.
    segment: u32,
}

impl Capsule {
    /// Whether the ray (o, unit d, t in [0, t_max]) may meet the capsule
    /// (the cheap tests before [`capsule_hit`]): it passes the bounding
    /// sphere, and the ray's line passes the axis's line within the radius
    /// (both lines unbounded: a lower bound of the distance between ray
    /// and segment). Both are padded by 1e-4 relative, so that rounding
    /// never rejects a ray [`capsule_hit`] would accept.
    #[inline]
    fn may_hit(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
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
                (
                    morton3(x as u32) | morton3(y as u32) << 1 | morton3(z as u32) << 2,
                    c.segment,
                )
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

/// The ray parameter where the ray from `o` along unit `d` leaves the
/// capsule: the end of its interval inside the capsule (a convex set: the
/// latest exit of the finite cylinder and the two end balls the ray meets),
/// 0 when that lies behind the origin. For an origin inside the capsule or
/// on its surface.
fn capsule_exit(o: Vec3, d: Vec3, c: &Capsule) -> f32 {
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
fn contains(o: Vec3, c: &Capsule) -> bool {
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
fn segment_crosses_box(a: Vec3, b: Vec3, lo: Vec3, hi: Vec3) -> bool {
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
#[inline(always)]
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

fn capsule_hit(o: Vec3, d: Vec3, t_max: f32, s: &Capsule) -> Option<f32> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::shade::Fiber;

    fn rnd(state: &mut u64) -> f32 {
        *state ^= *state >> 12;
        *state ^= *state << 25;
        *state ^= *state >> 27;
        (state.wrapping_mul(0x2545F4914F6CDD1D) >> 40) as f32 / (1u64 << 24) as f32
    }

    /// `n` segments of radius `r` starting in the unit cube, each
    /// `spread` at most along each axis, `per_strand` to a strand.
    fn random_segments(
        st: &mut u64,
        n: u32,
        spread: f32,
        r: f32,
        per_strand: u32,
    ) -> Vec<WorldSegment> {
        (0..n)
            .map(|i| {
                let a = Vec3::new(rnd(st), rnd(st), rnd(st));
                let b = a + (Vec3::new(rnd(st), rnd(st), rnd(st)) - 0.5) * spread;
                WorldSegment {
                    a,
                    b,
                    ra: r,
                    rb: r,
                    strand: i / per_strand,
                    vertex: 0,
                }
            })
            .collect()
    }

    /// Distance from the point at ray parameter s to the segment (dense
    /// sampling of the segment: an independent brute force).
    fn ray_segment_gap(o: Vec3, d: Vec3, t_max: f32, s: &Capsule) -> f32 {
        let mut best = f32::INFINITY;
        for i in 0..=400 {
            let q = s.a + s.u * (i as f32 / 400.0);
            let t = (q - o).dot(d).clamp(0.0, t_max);
            best = best.min((o + d * t - q).length());
        }
        best
    }

    /// 1. The grid traversal finds an occluder exactly when a brute-force
    ///    test over every capsule does (rays whose closest approach is
    ///    within 2% of a radius of the surface are skipped: the dense
    ///    sampling of the reference is that coarse).
    #[test]
    fn t01_grid_agrees_with_brute_force() {
        let mut st = 0x1234_5678_9abc_def0u64;
        let segs = random_segments(&mut st, 400, 0.2, 0.01, 4);
        let grid = SegmentGrid::new(&segs).unwrap();
        let (mut hits, mut checked) = (0, 0);
        for _ in 0..3000 {
            let o = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) * 1.4 - 0.2;
            let d = (Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - 0.5).normalize();
            let own = Fiber {
                radius: 0.0,
                strand: u32::MAX - 1,
                segment: 0,
            };
            // Capsules holding the origin do not block (brute force: the
            // gap at t = 0).
            let gaps: Vec<f32> = grid
                .segments
                .iter()
                .filter(|c| ray_segment_gap(o, d, 0.0, c) > c.r2.sqrt())
                .map(|c| ray_segment_gap(o, d, f32::INFINITY, c) - c.r2.sqrt())
                .collect();
            if gaps.iter().any(|g| g.abs() < 2e-4)
                || grid
                    .segments
                    .iter()
                    .any(|c| (ray_segment_gap(o, d, 0.0, c) - c.r2.sqrt()).abs() < 2e-4)
            {
                continue;
            }
            let want = gaps.iter().any(|&g| g < 0.0);
            assert_eq!(
                grid.occluded(o, d, f32::INFINITY, &own),
                want,
                "ray {o} {d}"
            );
            hits += want as u32;
            checked += 1;
        }
        assert!(
            checked > 2500 && hits > 300 && hits < checked - 300,
            "{hits} of {checked}"
        );
    }

    /// 2. A ray from inside a capsule is not blocked by it, and is by a
    ///    capsule it meets farther on.
    #[test]
    fn t02_origin_inside_leaves_unblocked() {
        let seg = |z: f32, strand| WorldSegment {
            a: Vec3::new(-1.0, 0.0, z),
            b: Vec3::new(1.0, 0.0, z),
            ra: 0.1,
            rb: 0.1,
            strand,
            vertex: 0,
        };
        let own = Fiber {
            radius: 0.0,
            strand: u32::MAX - 1,
            segment: 0,
        };
        let o = Vec3::new(0.0, 0.05, 0.0);
        let up = Vec3::Y;
        let inside = SegmentGrid::new(&[seg(0.0, 0)]).unwrap();
        assert!(!inside.occluded(o, up, f32::INFINITY, &own));
        assert!(!inside.occluded(o, -up, f32::INFINITY, &own));
        let above = SegmentGrid::new(&[
            seg(0.0, 0),
            WorldSegment {
                a: Vec3::new(-1.0, 0.5, 0.0),
                b: Vec3::new(1.0, 0.5, 0.0),
                ..seg(0.0, 1)
            },
        ])
        .unwrap();
        assert!(above.occluded(o, up, f32::INFINITY, &own));
        assert!(!above.occluded(o, -up, f32::INFINITY, &own));
    }

    /// 3. A ray that runs inside its own fiber (light from behind, nearly
    ///    along a strand of short segments) passes the rest of its own
    ///    strand; another strand on its way, and its own strand turning back
    ///    across it outside the tube, still shadow it.
    #[test]
    fn t03_a_ray_inside_its_own_fiber_passes_its_strand() {
        let r = 0.01;
        // strand 0: 40 segments of 0.05 along x; strand 1 crosses at x = 1.5
        let mut segs: Vec<WorldSegment> = (0..40)
            .map(|i| WorldSegment {
                a: Vec3::new(i as f32 * 0.05, 0.0, 0.0),
                b: Vec3::new((i + 1) as f32 * 0.05, 0.0, 0.0),
                ra: r,
                rb: r,
                strand: 0,
                vertex: 0,
            })
            .collect();
        let own = Fiber {
            radius: r,
            strand: 0,
            segment: 10,
        };
        // on segment 10's surface (x = 0.525, y = r), into the fiber, 0.5 degrees off its axis
        let o = Vec3::new(0.525, r, 0.0);
        let d = Vec3::new(1.0, -0.00873, 0.0).normalize();
        // a segment across the x axis at `x`, from -half to half in y
        let across = |x: f32, half: f32, strand: u32| WorldSegment {
            a: Vec3::new(x, -half, 0.0),
            b: Vec3::new(x, half, 0.0),
            ra: r,
            rb: r,
            strand,
            vertex: 0,
        };
        let grid = SegmentGrid::new(&segs).unwrap();
        assert!(
            !grid.occluded(o, d, f32::INFINITY, &own),
            "own strand ahead, inside the tube"
        );
        segs.push(across(1.5, 0.5, 1));
        let crossed = SegmentGrid::new(&segs).unwrap();
        assert!(
            crossed.occluded(o, d, f32::INFINITY, &own),
            "another strand on the way"
        );
        // the own strand turning back across the ray beyond where the ray
        // leaves its tube (at the strand's end, x = 2.01)
        segs.pop();
        segs.push(across(3.0, 0.3, 0));
        let curl = SegmentGrid::new(&segs).unwrap();
        assert!(
            curl.occluded(o, d, f32::INFINITY, &own),
            "own strand outside the tube"
        );
    }

    /// 4. A ray that starts inside another strand's tube (fibers that
    ///    interpenetrate) passes that strand until it leaves the tube, as it
    ///    passes its own; a third strand on the way still shadows it.
    #[test]
    fn t04_a_ray_starting_inside_another_fiber_passes_it() {
        let r = 0.01;
        let strand = |k: u32, y: f32| {
            (0..40).map(move |i| WorldSegment {
                a: Vec3::new(i as f32 * 0.05, y, 0.0),
                b: Vec3::new((i + 1) as f32 * 0.05, y, 0.0),
                ra: r,
                rb: r,
                strand: k,
                vertex: 0,
            })
        };
        // the receiver on strand 0 at x = 0.525; strand 1 runs 0.5 r beside it
        let mut segs: Vec<WorldSegment> = strand(0, 0.0).chain(strand(1, 0.005)).collect();
        let own = Fiber {
            radius: r,
            strand: 0,
            segment: 10,
        };
        let o = Vec3::new(0.525, r, 0.0); // inside strand 1's tube (0.005 from its axis)
        let d = Vec3::new(1.0, -0.00873, 0.0).normalize();
        let grid = SegmentGrid::new(&segs).unwrap();
        assert!(
            !grid.occluded(o, d, f32::INFINITY, &own),
            "strand 1, started inside"
        );
        segs.extend((0..1).map(|_| WorldSegment {
            a: Vec3::new(1.5, -0.5, 0.0),
            b: Vec3::new(1.5, 0.5, 0.0),
            ra: r,
            rb: r,
            strand: 2,
            vertex: 0,
        }));
        let crossed = SegmentGrid::new(&segs).unwrap();
        assert!(
            crossed.occluded(o, d, f32::INFINITY, &own),
            "strand 2 on the way"
        );
    }

    /// 5. [`capsule_exit`] from a point inside a capsule is where a fine
    ///    march along the ray leaves it (an independent brute force: the
    ///    distance to the axis sampled every 1e-5 of the capsule's length,
    ///    so the two agree within that step).
    #[test]
    fn t05_capsule_exit_agrees_with_a_march() {
        let mut st = 0x0dd_ba11u64;
        let mut checked = 0;
        for _ in 0..300 {
            let a = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st));
            let u = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5);
            let r = 0.02 + 0.2 * rnd(&mut st);
            let c = Capsule {
                a,
                r2: r * r,
                u,
                reach: 0.0,
                r,
                strand: 0,
                segment: 0,
            };
            // a point inside: on the axis, pushed out by less than the radius
            let side = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5);
            let o = a + u * (1.2 * rnd(&mut st) - 0.1) + side.normalize() * r * 0.9 * rnd(&mut st);
            if !contains(o, &c) {
                continue;
            }
            let d = (Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5))
                .normalize();
            let step = 1e-5 * (u.length() + 2.0 * r);
            let mut t = 0.0;
            while contains(o + d * (t + step), &c) {
                t += step;
            }
            let e = capsule_exit(o, d, &c);
            assert!(
                (e - t).abs() <= 2.0 * step + 1e-5,
                "exit {e} against the march's {t}"
            );
            checked += 1;
        }
        assert!(checked > 100, "{checked} points inside");
    }

    /// 6. A strand's shadows are its tube's: the same bent strand cut into
    ///    4 collinear pieces a segment shadows the same rays from points on
    ///    its surface (rays towards the fiber and away from it, the strand
    ///    bending back across them or not). The rays that graze the tube,
    ///    within 1e-3 of a radius of its surface where one grid and not the
    ///    other would call them blocked, are left out (rounding of the two
    ///    geometries' tests); counted, they are a few in a thousand.
    #[test]
    fn t06_cutting_a_strand_into_pieces_keeps_its_shadows() {
        let r = 0.02;
        // a wave with bends of up to 40 degrees between segments, and a curl
        let points: Vec<Vec3> = (0..=24)
            .map(|i| {
                let x = i as f32 * 0.1;
                Vec3::new(x, 0.15 * (3.0 * x).sin(), 0.12 * (5.0 * x).cos())
            })
            .collect();
        let strand = |pieces: usize| -> Vec<WorldSegment> {
            points
                .windows(2)
                .flat_map(|w| {
                    (0..pieces).map(move |k| WorldSegment {
                        a: w[0] + (w[1] - w[0]) * (k as f32 / pieces as f32),
                        b: w[0] + (w[1] - w[0]) * ((k + 1) as f32 / pieces as f32),
                        ra: r,
                        rb: r,
                        strand: 0,
                        vertex: 0,
                    })
                })
                .collect()
        };
        let (whole, cut) = (strand(1), strand(4));
        let (g1, g4) = (
            SegmentGrid::new(&whole).unwrap(),
            SegmentGrid::new(&cut).unwrap(),
        );
        // the distance from the strand's axis to the ray beyond where the
        // ray leaves the tube, at its least (a march): near r, the ray grazes
        // the tube
        let graze = |o: Vec3, d: Vec3| {
            let dist = |p: Vec3| {
                whole
                    .iter()
                    .map(|s| {
                        let u = s.b - s.a;
                        let t = ((p - s.a).dot(u) / u.length_squared()).clamp(0.0, 1.0);
                        (p - s.a - u * t).length()
                    })
                    .fold(f32::INFINITY, f32::min)
            };
            let mut t = 0.0;
            let mut near = f32::INFINITY;
            let mut outside = false;
            while t < 4.0 {
                let x = dist(o + d * t);
                outside |= x > r * (1.0 + 1e-3);
                if outside {
                    near = near.min(x);
                }
                t += 2e-4;
            }
            (near - r).abs() < 1e-3 * r
        };
        let mut st = 0xC0_7_u64;
        let (mut same, mut blocked, mut grazing) = (0, 0, 0);
        for _ in 0..2000 {
            let seg = ((rnd(&mut st) * 24.0) as usize).min(23);
            let f = rnd(&mut st);
            let (a, b) = (points[seg], points[seg + 1]);
            let axis = (b - a).normalize();
            let (e1, e2) = axis.any_orthonormal_pair();
            let phi = std::f32::consts::TAU * rnd(&mut st);
            let o = a + (b - a) * f + (e1 * phi.cos() + e2 * phi.sin()) * r;
            // half the rays nearly along the strand (light from behind it)
            let d = if rnd(&mut st) < 0.5 {
                let off = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - Vec3::splat(0.5);
                (axis * if rnd(&mut st) < 0.5 { 1.0 } else { -1.0 } + off * 0.4).normalize()
            } else {
                let z = 1.0 - 2.0 * rnd(&mut st);
                let s = (1.0 - z * z).sqrt();
                let p = std::f32::consts::TAU * rnd(&mut st);
                Vec3::new(s * p.cos(), s * p.sin(), z)
            };
            let piece = ((f * 4.0) as usize).min(3);
            let own1 = Fiber {
                radius: r,
                strand: 0,
                segment: seg as u32,
            };
            let own4 = Fiber {
                segment: (seg * 4 + piece) as u32,
                ..own1
            };
            let b1 = g1.occluded(o, d, f32::INFINITY, &own1);
            let b4 = g4.occluded(o, d, f32::INFINITY, &own4);
            if b1 == b4 {
                same += 1;
                blocked += b1 as usize;
            } else {
                assert!(graze(o, d), "o {o} d {d}: whole {b1}, cut {b4}");
                grazing += 1;
            }
        }
        // the strand bends back across some rays: the test sees shadows
        assert!(blocked > 50, "{blocked} of {same} blocked");
        assert!(grazing <= 10, "{grazing} grazing rays differ");
    }

    /// 7. The first fiber a ray meets is the brute force's: over every
    ///    capsule, the least closest approach (each capsule's own, read up
    ///    to t_max), at equal distance the earlier segment. Exactly, not
    ///    within a tolerance: the grid tests the same capsules with the same
    ///    arithmetic, so the order its lists hold them in (Morton order of
    ///    their midpoints, not the strands') must not show.
    #[test]
    fn t07_first_hit_is_the_nearest_in_any_order() {
        let mut st = 0x0bad_cafe_1234_5678u64;
        let segs = random_segments(&mut st, 600, 0.15, 0.012, 6);
        let grid = SegmentGrid::new(&segs).unwrap();
        let own = Fiber {
            radius: 0.0,
            strand: u32::MAX - 1,
            segment: u32::MAX - 1,
        };
        let (mut met, mut rays) = (0, 0);
        for _ in 0..3000 {
            let o = Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) * 1.2 - 0.1;
            let d = (Vec3::new(rnd(&mut st), rnd(&mut st), rnd(&mut st)) - 0.5).normalize();
            let t_max = 0.2 + rnd(&mut st);
            if grid.segments.iter().any(|c| contains(o, c)) {
                continue; // (what a ray starting inside a fiber passes: t03, t04)
            }
            let want = grid
                .segments
                .iter()
                .filter_map(|c| capsule_hit(o, d, t_max, c).map(|t| (t, c.segment)))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let got = grid
                .first_hit(o, d, t_max, &own)
                .map(|h| (h.0, h.2.segment));
            assert_eq!(got, want, "ray {o} {d} to {t_max}");
            met += want.is_some() as u32;
            rays += 1;
        }
        assert!(
            rays > 2500 && met > 300 && met < rays - 300,
            "{met} of {rays}"
        );
    }

    /// 8. The grid built in parallel is the same on one thread and on all:
    ///    its capsules in the same order, the same cells and lists, with
    ///    and without spread (40 000 segments, several build chunks; a
    ///    NaN segment left out in both).
    #[test]
    fn t08_grid_independent_of_threads() {
        let mut st = 0x0dd_ba11u64;
        let mut segs = random_segments(&mut st, 40_000, 0.05, 0.002, 16);
        segs[777].a = Vec3::new(f32::NAN, 0.0, 0.0);
        for spread in [0.0, 0.004] {
            let key = |g: &SegmentGrid| {
                let caps: Vec<(u32, u32)> =
                    g.segments.iter().map(|c| (c.segment, c.strand)).collect();
                (
                    caps,
                    g.start.clone(),
                    g.items.clone(),
                    g.capsule_of.clone(),
                    g.cell.to_bits(),
                    g.dims,
                )
            };
            let all = key(&SegmentGrid::with_spread(&segs, spread).unwrap());
            crate::threads::set_single_threaded(true);
            let one = key(&SegmentGrid::with_spread(&segs, spread).unwrap());
            crate::threads::set_single_threaded(false);
            assert!(all.0.len() == segs.len() - 1 && all.2.len() > all.0.len());
            assert!(all == one, "spread {spread}");
        }
    }
}
