//! The exact clearance at every node of a lattice over an occupancy grid, in one sweep
//! (docs/planning.md, "Node radii in one sweep").
//!
//! In centre coordinates (centre `(i, j)` at `(i, j)`, the square of cell `(i, j)` spanning
//! `[i - 1/2, i + 1/2] x [j - 1/2, j + 1/2]`), the squared distance from a point `(x, y)` to the
//! occupied squares separates as the transform's does (Felzenszwalb and Huttenlocher 2012,
//! grid.rs), at a real point instead of a cell centre:
//!
//! `D^2(x, y) = min_q g(x - q) + V_y(q)`, `g(t) = max(|t| - 1/2, 0)^2`,
//!
//! with `V_y(q)` the squared distance from `y` to the nearest occupied square of column `q`. A
//! lattice row has one `y`. Its `V_y` over the columns comes from the nearest occupied row at
//! or below `y` and the nearest above, two row indices a column that only move up as the
//! lattice's rows do (each column is read once over the whole sweep). The minimum over the
//! columns is the transform's square pass at real `x`: the lower envelope of the parabolas at
//! the half-integer sites `s - 1/2` of height `min(V_y(s - 1), V_y(s))`, and `V_y` of the column
//! whose square holds `x` (`g = 0` there), evaluated at the row's nodes from west to east.
//!
//! The result is the distance itself, not a lower bound of it as the point query's union of
//! discs (`GridMap::clearance_capped_m`) is, so a node's radius is at least the point query's.
//! Cost: one read of every cell, and per lattice row an envelope over the grid's columns: about
//! 0.5 M Cortex-M4 instructions for the 70 x 30 m map's 4,096 nodes, where the point queries
//! cost about 4,000 each (docs/benchmarks.md).
#![allow(clippy::indexing_slicing)] // kernels only; every slice length is checked on entry

use crate::grid::{lower_envelope, DistanceCells, GridMap};
use crate::{Lattice, NodeIndex, Vec2};

/// How far inside the exact distance a node's clearance is put, cells, so rounding can only
/// lower it (the point query's tolerance).
pub(crate) const TOL_CELLS: f32 = 1e-4;

/// Work space of a map's lattice sweep ([`crate::ClearanceMap::lattice_clearances_m`]),
/// borrowed from the search's arrays, which are all free before a search starts. A grid of `W`
/// columns needs `floats` `2 W + 1` long, `bounds` `W + 2`, `sites` `W + 1`, `below` and
/// `above` `W` each.
#[derive(Debug)]
pub struct SweepSpace<'s, I: NodeIndex> {
    /// `V_y` of each column, then the envelope's heights.
    pub(crate) floats: &'s mut [f32],
    /// The envelope's boundaries.
    pub(crate) bounds: &'s mut [f32],
    /// The envelope's sites.
    pub(crate) sites: &'s mut [I],
    /// Per column, the nearest occupied row at or below the lattice row (`I::NONE`: none).
    pub(crate) below: &'s mut [I],
    /// Per column, the nearest occupied row above the lattice row (the grid's height: none).
    pub(crate) above: &'s mut [I],
}

/// The clearance of every node `k < lat.len()` of `lat` on `grid`, m, handed to `out(k, c)`: the
/// distance to the occupied squares less 1e-4 cells (at least 0), minus the distance to the
/// cell's centre and its half diagonal inside an occupied cell (as the point query),
/// `f32::INFINITY` when no cell is occupied. False when the grid is empty or a slice too
/// short (`out` never called), or a node's position is not finite (called for the nodes
/// before it).
pub(crate) fn lattice_clearances_m<C: ?Sized + DistanceCells, I: NodeIndex>(
    grid: &GridMap<'_, C>,
    lat: &Lattice,
    out: &mut impl FnMut(usize, f32),
    space: SweepSpace<'_, I>,
) -> bool {
    let (w, h) = (grid.width, grid.height);
    let fits = w > 0
        && h > 0
        && h < I::CAPACITY
        && space.floats.len() > 2 * w
        && space.bounds.len() > w + 1
        && space.sites.len() > w
        && space.below.len() >= w
        && space.above.len() >= w
        && grid.dist_cells.is_occupied(w * h - 1).is_some();
    if !fits {
        return false;
    }
    let SweepSpace { floats, bounds, sites, below, above } = space;
    let (col, heights) = floats.split_at_mut(w);
    let heights = &mut heights[..=w];
    let res = grid.resolution_m;
    let rel_of = |k: usize| (lat.point_m(k) - grid.origin_m) / res - Vec2::new(0.5, 0.5);
    let occupied = |i: usize, j: usize| grid.dist_cells.is_occupied(j * w + i) == Some(true);
    // The first occupied row of each column at or above `from`, `h` for none.
    let next_occupied = |i: usize, from: usize| (from..h).find(|&j| occupied(i, j)).unwrap_or(h);
    for i in 0..w {
        below[i] = I::NONE;
        above[i] = I::from_node(next_occupied(i, 0));
    }
    for jl in 0..lat.ny {
        let row0 = jl * lat.nx;
        let y = rel_of(row0).y;
        if !y.is_finite() {
            return false;
        }
        for i in 0..w {
            // Rows at or below y move from `above` to `below`.
            while above[i].node() < h && above[i].node() as f32 <= y {
                below[i] = above[i];
                above[i] = I::from_node(next_occupied(i, above[i].node() + 1));
            }
            let gap2 = |t: f32| if t > 0.0 { t * t } else { 0.0 };
            let down = if below[i] == I::NONE { f32::INFINITY } else { gap2(y - below[i].node() as f32 - 0.5) };
            let up = if above[i].node() >= h { f32::INFINITY } else { gap2(above[i].node() as f32 - y - 0.5) };
            col[i] = vt_fpu::min(down, up);
        }
        // Site s (position s - 1/2) holds the nearer of columns s - 1 and s (grid.rs, square_pass).
        for (s, hs) in heights.iter_mut().enumerate() {
            let left = if s == 0 { f32::INFINITY } else { col[s - 1] };
            *hs = vt_fpu::min(left, col.get(s).copied().unwrap_or(f32::INFINITY));
        }
        if !lower_envelope(heights, sites, bounds, -0.5) {
            // No occupied cell in the grid.
            (row0..row0 + lat.nx).for_each(|k| out(k, f32::INFINITY));
            continue;
        }
        let mut seg = 0usize;
        for k in row0..row0 + lat.nx {
            let rel = rel_of(k);
            if !rel.x.is_finite() {
                return false;
            }
            if let Some(inside) = grid.inside_occupied_m(rel) {
                out(k, inside);
                continue;
            }
            while bounds[seg + 1] < rel.x {
                seg += 1;
            }
            let site = sites[seg].node();
            let dx = rel.x - (site as f32 - 0.5);
            let mut d2 = dx * dx + heights[site];
            if rel.x >= -0.5 && rel.x <= w as f32 - 0.5 {
                // The column whose square holds x: no horizontal gap.
                d2 = vt_fpu::min(d2, col[((rel.x + 0.5) as usize).min(w - 1)]);
            }
            out(k, vt_fpu::max(vt_fpu::sqrt(d2) - TOL_CELLS, 0.0) * res);
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{distance_transform, distance_transform_squares, ClearanceMap};
    use proptest::prelude::*;

    /// Distance from `(x, y)` (centre coordinates) to the square of cell `(a, b)`, cells.
    fn box_distance(x: f32, y: f32, a: usize, b: usize) -> f32 {
        let gx = ((x - a as f32).abs() - 0.5).max(0.0);
        let gy = ((y - b as f32).abs() - 0.5).max(0.0);
        (gx * gx + gy * gy).sqrt()
    }

    /// The sweep over a lattice of `grid`, in a work space of the sizes it needs.
    fn sweep<C: ?Sized + DistanceCells>(grid: &GridMap<'_, C>, lat: &Lattice) -> Option<Vec<f32>> {
        let w = grid.width;
        let (mut floats, mut bounds) = (vec![0.0f32; 2 * w + 1], vec![0.0f32; w + 2]);
        let (mut sites, mut below, mut above) = (vec![0u32; w + 1], vec![0u32; w], vec![0u32; w]);
        let space = SweepSpace { floats: &mut floats, bounds: &mut bounds, sites: &mut sites, below: &mut below, above: &mut above };
        let mut out = vec![f32::NAN; lat.len()];
        let done = lattice_clearances_m(grid, lat, &mut |k, c| out[k] = c, space);
        done.then_some(out)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Every node's value is the exact distance to the occupied squares (brute force over
        /// every cell) and at least the point query's union-of-discs bound, on the `f32` and the
        /// two-byte fields alike, inside and outside occupied cells.
        #[test]
        fn the_sweep_is_the_exact_distance_and_never_below_the_point_query(
            w in 1usize..24, h in 1usize..24, fill in 0.0f64..0.4, seed in any::<u64>(),
            spacing in 0.3f32..2.5, ox in -0.6f32..0.6, oy in -0.6f32..0.6,
        ) {
            let res = 0.25f32;
            let mut rng = seed;
            let mut next = || { rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (rng >> 11) as f64 / (1u64 << 53) as f64 };
            let occ: Vec<bool> = (0..w * h).map(|_| next() < fill).collect();
            let mut f: Vec<f32> = occ.iter().map(|&o| if o { 0.0 } else { f32::INFINITY }).collect();
            let mut q: Vec<u16> = occ.iter().map(|&o| if o { 0 } else { 1 }).collect();
            let n = w.max(h);
            let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
            distance_transform(&mut f, w, h, &mut line, &mut v, &mut z).unwrap();
            distance_transform_squares(&mut q, w, h, &mut line, &mut v, &mut z).unwrap();
            let origin = Vec2::new(1.5, -2.0);
            let size = Vec2::new(w as f32, h as f32) * res;
            let lo = origin + Vec2::new(ox, oy) * res;
            let lat = Lattice::covering(lo, origin + size, spacing * res, 10_000).unwrap();
            let gf = GridMap { dist_cells: &f[..], width: w, height: h, resolution_m: res, origin_m: origin };
            let gq = GridMap { dist_cells: &q[..], width: w, height: h, resolution_m: res, origin_m: origin };
            let (sf, sq) = (sweep(&gf, &lat).unwrap(), sweep(&gq, &lat).unwrap());
            for k in 0..lat.len() {
                let p = lat.point_m(k);
                let rel = (p - origin) / res - Vec2::new(0.5, 0.5);
                let exact = (0..w * h).filter(|&c| occ[c]).map(|c| box_distance(rel.x, rel.y, c % w, c / w)).fold(f32::INFINITY, f32::min);
                let query = gf.clearance_m(p);
                prop_assert_eq!(sf[k].to_bits(), sq[k].to_bits(), "the two fields agree at node {}", k);
                if query < 0.0 {
                    prop_assert_eq!(sf[k].to_bits(), query.to_bits(), "inside an occupied cell, the query's value");
                } else if exact == f32::INFINITY {
                    prop_assert_eq!(sf[k], f32::INFINITY);
                } else {
                    prop_assert!((sf[k] - exact * res).abs() <= 1e-4, "node {k} at {rel:?}: {} against {}", sf[k], exact * res);
                    prop_assert!(sf[k] <= exact * res + 1e-6, "never above the true distance");
                    prop_assert!(sf[k] >= query - TOL_CELLS * res - 1e-6, "node {k}: {} below the query's {}", sf[k], query);
                }
            }
        }
    }

    #[test]
    fn degenerate_grids_and_short_spaces_are_refused() {
        let cells = [0.0f32; 4];
        let lat = Lattice::covering(Vec2::zeros(), Vec2::new(1.0, 1.0), 0.5, 100).unwrap();
        let empty = GridMap { dist_cells: &cells[..0], width: 0, height: 0, resolution_m: 0.5, origin_m: Vec2::zeros() };
        assert!(sweep(&empty, &lat).is_none());
        let short = GridMap { dist_cells: &cells[..3], width: 2, height: 2, resolution_m: 0.5, origin_m: Vec2::zeros() };
        assert!(sweep(&short, &lat).is_none(), "a field shorter than its grid");
        let g = GridMap { dist_cells: &cells[..], width: 2, height: 2, resolution_m: 0.5, origin_m: Vec2::zeros() };
        let (mut out, mut a, mut b, mut s, mut lo, mut hi) = (vec![0.0; lat.len()], [0.0f32; 4], [0.0f32; 4], [0u32; 3], [0u32; 2], [0u32; 2]);
        let space = SweepSpace { floats: &mut a, bounds: &mut b, sites: &mut s, below: &mut lo, above: &mut hi };
        assert!(!lattice_clearances_m(&g, &lat, &mut |k, c| out[k] = c, space), "floats 2 W + 1 long are needed");
        let (mut a, mut b) = ([0.0f32; 5], [0.0f32; 4]);
        let space = SweepSpace { floats: &mut a, bounds: &mut b, sites: &mut s, below: &mut lo, above: &mut hi };
        assert!(lattice_clearances_m(&g, &lat, &mut |k, c| out[k] = c, space));
        assert!(out.iter().all(|c| *c < 0.0), "every node of an occupied grid is inside it: {out:?}");
    }
}
