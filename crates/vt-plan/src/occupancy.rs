//! Exact clearance on an occupancy grid of one bit a cell (docs/planning.md, "The planner's
//! grid in bits"): the flight MCU's planner needs no distance field.
//!
//! A point's distance to the occupied squares is found row by row, outward from the point's
//! own row: row `j` is `g_y = max(|y - j| - 1/2, 0)` away vertically, and within it only the
//! occupied cells nearest the point's column on either side can be the nearest (the horizontal
//! gap `g_x = max(|x - i| - 1/2, 0)` grows away from it), found a word of 32 cells at a time.
//! Once `g_y^2` reaches the best squared distance so far, no farther row can improve it. The
//! result is the exact distance (less the lattice sweep's 1e-4-cell rounding guard), not the
//! lower bound a distance field's disc union gives ([`crate::GridMap`]), and the lattice sweep
//! (`node_clearance`) reads the same bits.
//!
//! Cost: a row a cell of the distance (or of the cap) either way, a word or two each: about a
//! thousand Cortex-M4 instructions a query at the planner's 6 m cap on a 0.25 m grid, against
//! about 4,000 for the field's union and 3.5 M for the field itself (docs/benchmarks.md).

use crate::grid::{DistanceCells, GridMap};
use crate::map::ClearanceMap;
use crate::node_clearance::TOL_CELLS;
use crate::{Lattice, NodeIndex, SweepSpace, Vec2};

/// Occupancy in bits: cell `k` (row-major) is occupied when bit `k % 32` of word `k / 32` is
/// set. As [`DistanceCells`], an occupied cell is at 0 and a free one at 1/2 cell, the lower
/// bound its own square gives (so a [`GridMap`] over bits is valid but loose; use
/// [`OccupancyMap`] for distances).
#[derive(Debug, Clone, Copy)]
pub struct OccupancyBits<'a>(pub &'a [u32]);

impl OccupancyBits<'_> {
    /// Words `cells` bits need.
    pub const fn words(cells: usize) -> usize {
        cells.div_ceil(32)
    }

    /// Whether cell `k` is occupied; `None` beyond the words.
    #[inline]
    fn bit(&self, k: usize) -> Option<bool> {
        self.0.get(k / 32).map(|w| (w >> (k % 32)) & 1 == 1)
    }

    /// The first set bit in `lo..=hi` (global bit indices).
    fn first_set(&self, lo: usize, hi: usize) -> Option<usize> {
        let mut k = lo;
        while k <= hi {
            let word = self.0.get(k / 32)? >> (k % 32);
            if word != 0 {
                let c = k + word.trailing_zeros() as usize;
                return (c <= hi).then_some(c);
            }
            k = (k / 32 + 1) * 32;
        }
        None
    }

    /// The last set bit in `lo..=hi` (global bit indices).
    fn last_set(&self, lo: usize, hi: usize) -> Option<usize> {
        if lo > hi {
            return None;
        }
        let mut k = hi;
        loop {
            let word = self.0.get(k / 32)? << (31 - k % 32);
            if word != 0 {
                let c = k - word.leading_zeros() as usize;
                return (c >= lo).then_some(c);
            }
            let start = k / 32 * 32;
            if start <= lo || start == 0 {
                return None;
            }
            k = start - 1;
        }
    }
}

impl DistanceCells for OccupancyBits<'_> {
    #[inline]
    fn distance_cells(&self, k: usize) -> Option<f32> {
        self.bit(k).map(|o| if o { 0.0 } else { 0.5 })
    }

    #[inline]
    fn is_occupied(&self, k: usize) -> Option<bool> {
        self.bit(k)
    }

    /// A free cell's 1/2 bounds nothing from above.
    #[inline]
    fn is_capped(&self, k: usize) -> bool {
        self.bit(k) == Some(false)
    }
}

/// An occupancy grid in bits with exact clearance queries. Cell `(i, j)` covers the square
/// `origin + [i, i+1] x [j, j+1] resolution`, as [`GridMap`]'s; an occupied cell is solid.
#[derive(Debug, Clone, Copy)]
pub struct OccupancyMap<'a> {
    /// The cells, `width x height` bits row-major.
    pub bits: OccupancyBits<'a>,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Cell side, m.
    pub resolution_m: f32,
    /// Lower-left corner of cell `(0, 0)`, m.
    pub origin_m: Vec2,
}

impl<'a> OccupancyMap<'a> {
    /// The same cells as a [`GridMap`] (the lattice sweep and the inside rule).
    fn grid(&self) -> GridMap<'_, OccupancyBits<'a>> {
        GridMap { dist_cells: &self.bits, width: self.width, height: self.height, resolution_m: self.resolution_m, origin_m: self.origin_m }
    }

    /// The squared distance from `rel` (centre coordinates: centre `(i, j)` at `(i, j)`) to the
    /// nearest occupied square, cells^2, when it is below `limit2`; `limit2` otherwise. `rel`
    /// finite, the grid non-empty and held by the bits.
    fn nearest_d2(&self, rel: Vec2, limit2: f32) -> f32 {
        let (w, h) = (self.width, self.height);
        // The cell holding a coordinate, the edge cell for one outside the grid.
        let own = |x: f32, n: usize| -> usize { if x < -0.5 { 0 } else { ((x + 0.5) as usize).min(n - 1) } };
        let gap = |t: f32| if t > 0.0 { t } else { 0.0 };
        let (ic, jc) = (own(rel.x, w), own(rel.y, h));
        let mut best = limit2;
        let row = |j: usize, best: &mut f32| {
            let gy = gap((rel.y - j as f32).abs() - 0.5);
            let rest = *best - gy * gy;
            if !(rest > 0.0) {
                return false;
            }
            // Columns whose gap is below the rest: |x - i| < sqrt(rest) + 1/2.
            let reach = vt_fpu::sqrt(rest) + 0.5;
            let lo = rel.x - reach;
            let hi = rel.x + reach;
            if !(hi >= 0.0 && lo <= (w - 1) as f32) {
                return true;
            }
            let i_lo = if lo > 0.0 { libm::ceilf(lo) as usize } else { 0 };
            let i_hi = if hi < (w - 1) as f32 { hi as usize } else { w - 1 };
            let base = j * w;
            let mut consider = |i: usize| {
                let gx = gap((rel.x - i as f32).abs() - 0.5);
                let d2 = gx * gx + gy * gy;
                if d2 < *best {
                    *best = d2;
                }
            };
            let right_from = ic.max(i_lo);
            if right_from <= i_hi {
                if let Some(k) = self.bits.first_set(base + right_from, base + i_hi) {
                    consider(k - base);
                }
            }
            let left_to = ic.min(i_hi + 1);
            if left_to > i_lo {
                if let Some(k) = self.bits.last_set(base + i_lo, base + left_to - 1) {
                    consider(k - base);
                }
            }
            true
        };
        // Outward from the point's row, both ways at once; a side stops at its first row too
        // far away (the gaps only grow from there).
        let (mut up, mut down) = (true, jc > 0);
        let mut t = 0usize;
        while up || down {
            if up {
                up = jc + t < h && row(jc + t, &mut best);
            }
            if down && t > 0 {
                down = t <= jc && row(jc - t, &mut best);
            }
            t += 1;
        }
        best
    }
}

impl ClearanceMap for OccupancyMap<'_> {
    fn bounds_m(&self) -> (Vec2, Vec2) {
        self.grid().bounds_m()
    }

    /// The distance from `p` to the occupied squares, m, exact but for a 1e-4-cell guard;
    /// negative inside an occupied cell (as [`GridMap`]'s), `f32::INFINITY` when none is
    /// occupied, `-inf` for a point that is not finite or a grid its bits do not hold.
    fn clearance_m(&self, p_m: Vec2) -> f32 {
        self.clearance_capped_m(p_m, f32::INFINITY)
    }

    /// As [`Self::clearance_m`] where the distance is below `cap_m`; `cap_m` (0 for a cap that
    /// is not positive) where it is not.
    fn clearance_capped_m(&self, p_m: Vec2, cap_m: f32) -> f32 {
        let (w, h) = (self.width, self.height);
        let res = self.resolution_m;
        let rel = (p_m - self.origin_m) / res - Vec2::new(0.5, 0.5);
        let held = w > 0 && h > 0 && self.bits.bit(w * h - 1).is_some();
        if !(rel.x.is_finite() && rel.y.is_finite() && held) {
            return f32::NEG_INFINITY;
        }
        if let Some(inside) = self.grid().inside_occupied_m(rel) {
            return inside;
        }
        if !(cap_m > 0.0) {
            return 0.0;
        }
        let limit = cap_m / res;
        let limit2 = limit * limit;
        let d2 = self.nearest_d2(rel, limit2);
        if d2 < limit2 {
            vt_fpu::max(vt_fpu::sqrt(d2) - TOL_CELLS, 0.0) * res
        } else {
            cap_m
        }
    }

    /// The exact distance at every node in one sweep of the bits (`node_clearance`).
    fn lattice_clearances_m<I: NodeIndex>(&self, lat: &Lattice, out: &mut impl FnMut(usize, f32), space: SweepSpace<'_, I>) -> bool {
        crate::node_clearance::lattice_clearances_m(&self.grid(), lat, out, space)
    }
}

#[cfg(test)]
#[path = "occupancy_tests.rs"]
mod tests;
