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

/// Per tile, the indices of the primitives whose tile range covers it.
#[derive(Debug, Clone, Default)]
pub struct Bins {
    pub tiles: Vec<Vec<u32>>,
    /// Primitives that reach at least one tile.
    pub binned: usize,
}

/// Bins primitives by their tile ranges, in primitive order (so every
/// tile sees its primitives in scene order, whatever the thread count).
pub fn bin_to_tiles(ranges: impl Iterator<Item = Option<TileRange>>, grid: TileGrid) -> Bins {
    let mut tiles: Vec<Vec<u32>> = vec![Vec::new(); grid.count()];
    let mut binned = 0;
    for (i, r) in ranges.enumerate() {
        if let Some(r) = r {
            binned += 1;
            for ty in r.y0..=r.y1 {
                for tx in r.x0..=r.x1 {
                    tiles[(ty * grid.x + tx) as usize].push(i as u32);
                }
            }
        }
    }
    Bins { tiles, binned }
}
