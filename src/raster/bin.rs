//! Binning: which 16×16 screen tiles each primitive can reach, and per
//! tile the list of primitives to visit, in scene order.

use super::setup::Segment;

/// Tile edge in pixels.
pub const TILE: u32 = 16;

/// The tiles of an image.
#[derive(Debug, Clone, Copy)]
pub struct TileGrid {
    pub x: u32,
    pub y: u32,
}

impl TileGrid {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            x: width.div_ceil(TILE),
            y: height.div_ceil(TILE),
        }
    }

    pub fn count(&self) -> usize {
        (self.x * self.y) as usize
    }

    /// Tile coordinates of tile index `ti` (row-major).
    pub fn coords(&self, ti: usize) -> (u32, u32) {
        (ti as u32 % self.x, ti as u32 / self.x)
    }
}

/// An inclusive rectangle of tiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileRange {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

/// Tiles covered by a screen triangle's bounding box, or None when off screen.
pub fn triangle_tiles(p: &[[f32; 2]; 3], grid: TileGrid) -> Option<TileRange> {
    let (xs, ys) = (p.map(|q| q[0]), p.map(|q| q[1]));
    let x0 = xs[0].min(xs[1]).min(xs[2]);
    let x1 = xs[0].max(xs[1]).max(xs[2]);
    let y0 = ys[0].min(ys[1]).min(ys[2]);
    let y1 = ys[0].max(ys[1]).max(ys[2]);
    bbox_tiles(x0, x1, y0, y1, grid)
}

/// Tiles a segment's coverage can reach (its bounding box widened by
/// [`Segment::pad`]), or None when off screen.
pub fn segment_tiles(s: &Segment, grid: TileGrid) -> Option<TileRange> {
    let pad = s.pad();
    bbox_tiles(
        s.a[0].min(s.b[0]) - pad,
        s.a[0].max(s.b[0]) + pad,
        s.a[1].min(s.b[1]) - pad,
        s.a[1].max(s.b[1]) + pad,
        grid,
    )
}

/// Tiles overlapped by a pixel bounding box, or None when it is off screen
/// or not finite.
fn bbox_tiles(x0: f32, x1: f32, y0: f32, y1: f32, grid: TileGrid) -> Option<TileRange> {
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return None;
    }
    let (w, h) = ((grid.x * TILE) as f32, (grid.y * TILE) as f32);
    if x1 < 0.0 || y1 < 0.0 || x0 >= w || y0 >= h {
        return None;
    }
    let tx0 = (x0.max(0.0) as u32) / TILE;
    let ty0 = (y0.max(0.0) as u32) / TILE;
    let tx1 = (x1.min(w - 1.0) as u32) / TILE;
    let ty1 = (y1.min(h - 1.0) as u32) / TILE;
    Some(TileRange {
        x0: tx0,
        y0: ty0,
        x1: tx1.min(grid.x - 1),
        y1: ty1.min(grid.y - 1),
    })
}

/// Per tile, the indices of the primitives whose tile range covers it, in
/// primitive order: tile `t`'s are `items[offsets[t]..offsets[t + 1]]`.
#[derive(Debug, Clone, Default)]
pub struct Bins {
    offsets: Vec<usize>,
    items: Vec<u32>,
    /// Primitives that reach at least one tile.
    pub binned: usize,
}

impl Bins {
    /// The primitives binned to tile `t`, in primitive order.
    #[inline]
    pub fn tile(&self, t: usize) -> &[u32] {
        &self.items[self.offsets[t]..self.offsets[t + 1]]
    }
}

/// Bins primitives by their tile ranges (`ranges[i]` for primitive `i`),
/// in primitive order (so every tile sees its primitives in scene order,
/// whatever the thread count). In parallel: the primitives are cut into
/// chunks; per chunk and tile, a count; from the counts, where each chunk
/// writes in each tile's list; then the chunks fill their places.
pub fn bin_to_tiles(ranges: &[Option<TileRange>], grid: TileGrid) -> Bins {
    bin_listed(ranges, None, grid)
}

/// [`bin_to_tiles`] for the primitives `ids` (a permutation of the
/// indices of `ranges`) in that order: every tile sees them in the order
/// of `ids`.
pub fn bin_in_order(ranges: &[Option<TileRange>], ids: &[u32], grid: TileGrid) -> Bins {
    assert_eq!(
        ranges.len(),
        ids.len(),
        "ids: a permutation of the primitives"
    );
    bin_listed(ranges, Some(ids), grid)
}

/// Bins the primitives in the order of `ids` (their own order when None).
fn bin_listed(ranges: &[Option<TileRange>], ids: Option<&[u32]>, grid: TileGrid) -> Bins {
    use crate::threads::pool;
    use rayon::prelude::*;
    let tiles = grid.count();
    // the primitive at place `k` of the order
    let id = |k: usize| ids.map_or(k, |ids| ids[k] as usize);
    let chunk = (ranges.len() / (8 * crate::threads::num_threads()).max(1)).max(4096);
    let chunks: Vec<std::ops::Range<usize>> = (0..ranges.len())
        .step_by(chunk)
        .map(|k| k..(k + chunk).min(ranges.len()))
        .collect();
    let cover = |r: TileRange| {
        (r.y0..=r.y1).flat_map(move |ty| (r.x0..=r.x1).map(move |tx| (ty * grid.x + tx) as usize))
    };
    // counts[c][t]: entries of chunk c in tile t.
    let counts: Vec<Vec<u32>> = pool().install(|| {
        chunks
            .par_iter()
            .map(|c| {
                let mut n = vec![0u32; tiles];
                for r in c.clone().filter_map(|k| ranges[id(k)]) {
                    for t in cover(r) {
                        n[t] += 1;
                    }
                }
                n
            })
            .collect()
    });
    // Tile offsets, and where chunk c starts writing in tile t.
    let mut offsets = vec![0usize; tiles + 1];
    let mut starts: Vec<Vec<usize>> = vec![vec![0; tiles]; chunks.len()];
    let mut at = 0usize;
    for t in 0..tiles {
        offsets[t] = at;
        for (c, n) in counts.iter().enumerate() {
            starts[c][t] = at;
            at += n[t] as usize;
        }
    }
    offsets[tiles] = at;
    let mut items = vec![0u32; at];
    let binned = ranges.iter().filter(|r| r.is_some()).count();
    // Each chunk writes only its own places: share the buffer as a pointer.
    struct Shared(*mut u32);
    unsafe impl Sync for Shared {}
    let out = Shared(items.as_mut_ptr());
    pool().install(|| {
        chunks.par_iter().enumerate().for_each(|(c, part)| {
            let out = &out;
            let mut next = starts[c].clone();
            for k in part.clone() {
                let Some(r) = ranges[id(k)] else { continue };
                for t in cover(r) {
                    // SAFETY: chunk c's places in tile t are
                    // starts[c][t]..starts[c][t] + counts[c][t], disjoint
                    // from every other chunk's and inside `items`; it
                    // writes exactly counts[c][t] of them (the same
                    // ranges as counted).
                    unsafe { *out.0.add(next[t]) = id(k) as u32 };
                    next[t] += 1;
                }
            }
        })
    });
    Bins {
        offsets,
        items,
        binned,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. Binning in a given order: over 20 000 random tile ranges (a few
    ///    off screen) listed in a shuffled order, every tile's list is the
    ///    primitives whose range covers it, in that order (the sequential
    ///    count over the permutation), across the parallel chunks; with the
    ///    identity order it equals [`bin_to_tiles`].
    #[test]
    fn t01_binning_in_order_lists_each_tile_in_that_order() {
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = move |n: u32| {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            ((state.wrapping_mul(0x2545F4914F6CDD1D) >> 33) % n as u64) as u32
        };
        let grid = TileGrid { x: 13, y: 9 };
        let n = 20_000usize;
        let ranges: Vec<Option<TileRange>> = (0..n)
            .map(|_| {
                (rnd(20) != 0).then(|| {
                    let (x0, y0) = (rnd(grid.x), rnd(grid.y));
                    TileRange {
                        x0,
                        y0,
                        x1: (x0 + rnd(3)).min(grid.x - 1),
                        y1: (y0 + rnd(3)).min(grid.y - 1),
                    }
                })
            })
            .collect();
        let mut ids: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            ids.swap(i, rnd(i as u32 + 1) as usize);
        }
        let bins = bin_in_order(&ranges, &ids, grid);
        let covers = |r: &TileRange, t: usize| {
            let (tx, ty) = grid.coords(t);
            (r.x0..=r.x1).contains(&tx) && (r.y0..=r.y1).contains(&ty)
        };
        for t in 0..grid.count() {
            let want: Vec<u32> = ids
                .iter()
                .copied()
                .filter(|&i| ranges[i as usize].is_some_and(|r| covers(&r, t)))
                .collect();
            assert_eq!(bins.tile(t), &want[..], "tile {t}");
        }
        assert_eq!(bins.binned, ranges.iter().flatten().count());
        let identity: Vec<u32> = (0..n as u32).collect();
        let a = bin_in_order(&ranges, &identity, grid);
        let b = bin_to_tiles(&ranges, grid);
        assert_eq!((a.offsets, a.items), (b.offsets, b.items));
    }
}
