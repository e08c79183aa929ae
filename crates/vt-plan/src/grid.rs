//! Occupancy grids: the exact Euclidean distance transform and the clearance it gives.
//!
//! Felzenszwalb and Huttenlocher, "Distance Transforms of Sampled Functions", Theory of
//! Computing 8 (2012), algorithm DT (lower envelope of parabolas), one pass over the columns
//! and one over the rows: O(width x height), exact squared distances between cell centres.
#![allow(clippy::indexing_slicing)] // kernels only; every slice length is checked on entry

use crate::{ClearanceMap, PlanError, Vec2};

/// `sqrt(2) / 2`: distance from a cell's centre to its corner, in cells.
const HALF_DIAGONAL_CELLS: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// Euclidean distance transform of a `width x height` grid, in place.
///
/// Input: `cells[j * width + i]` is `0.0` for an occupied cell and anything positive
/// (`f32::INFINITY` by convention) for a free one. Output: the distance from each cell's
/// centre to the nearest occupied cell's centre, in cells (`f32::INFINITY` when no cell is
/// occupied). Work space: `line` at least `2 max(width, height)` long, `v` at least
/// `max(width, height)`, `z` at least `max(width, height) + 1`.
///
/// # Errors
/// [`PlanError::BadParams`] when a slice is too short or the grid is empty.
pub fn distance_transform(
    cells: &mut [f32],
    width: usize,
    height: usize,
    line: &mut [f32],
    v: &mut [usize],
    z: &mut [f32],
) -> Result<(), PlanError> {
    let n = width.max(height);
    if width == 0 || height == 0 || width.checked_mul(height) != Some(cells.len()) {
        return Err(PlanError::BadParams { field: "cells" });
    }
    if line.len() < 2 * n || v.len() < n || z.len() < n + 1 {
        return Err(PlanError::BadParams { field: "work space" });
    }
    for c in cells.iter_mut() {
        *c = if *c > 0.0 { f32::INFINITY } else { 0.0 };
    }
    let (f, d) = line.split_at_mut(n);
    // Columns.
    for i in 0..width {
        for j in 0..height {
            f[j] = cells[j * width + i];
        }
        envelope_1d(&f[..height], &mut d[..height], v, z);
        for j in 0..height {
            cells[j * width + i] = d[j];
        }
    }
    // Rows.
    for j in 0..height {
        let row = &mut cells[j * width..(j + 1) * width];
        f[..width].copy_from_slice(row);
        envelope_1d(&f[..width], &mut d[..width], v, z);
        for (c, dd) in row.iter_mut().zip(d.iter()) {
            *c = if dd.is_finite() { vt_fpu::sqrt(*dd) } else { f32::INFINITY };
        }
    }
    Ok(())
}

/// One-dimensional squared distance transform `d(q) = min_p (q - p)^2 + f(p)` (F&H, DT(f)).
/// Infinite samples take no part in the envelope.
fn envelope_1d(f: &[f32], d: &mut [f32], v: &mut [usize], z: &mut [f32]) {
    let n = f.len();
    let mut k: usize = 0;
    let mut any = false;
    for q in 0..n {
        if !f[q].is_finite() {
            continue;
        }
        if !any {
            any = true;
            v[0] = q;
            z[0] = f32::NEG_INFINITY;
            z[1] = f32::INFINITY;
            continue;
        }
        let qf = q as f32;
        loop {
            let p = v[k];
            let pf = p as f32;
            let s = ((f[q] + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf));
            // z[0] = -inf: the envelope never empties.
            if k > 0 && s <= z[k] {
                k -= 1;
                continue;
            }
            k += 1;
            v[k] = q;
            z[k] = s;
            z[k + 1] = f32::INFINITY;
            break;
        }
    }
    if !any {
        d.iter_mut().for_each(|x| *x = f32::INFINITY);
        return;
    }
    let mut k = 0usize;
    for (q, dq_out) in d.iter_mut().enumerate().take(n) {
        let qf = q as f32;
        while z[k + 1] < qf {
            k += 1;
        }
        let p = v[k];
        let dq = qf - p as f32;
        *dq_out = dq * dq + f[p];
    }
}

/// An occupancy grid with its distance transform: the clearance map of a raster.
///
/// Cell `(i, j)` (column `i` east, row `j` north, row-major `j * width + i`) covers the square
/// `origin + [i, i+1] x [j, j+1] resolution`. An occupied cell is a solid square.
#[derive(Debug, Clone, Copy)]
pub struct GridMap<'a> {
    /// Output of [`distance_transform`], cells.
    pub dist_cells: &'a [f32],
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Cell side, m.
    pub resolution_m: f32,
    /// Lower-left corner of cell `(0, 0)`, m.
    pub origin_m: Vec2,
}

impl GridMap<'_> {
    /// Centre of cell `(i, j)`, m.
    pub fn cell_center_m(&self, i: usize, j: usize) -> Vec2 {
        self.origin_m + Vec2::new((i as f32 + 0.5) * self.resolution_m, (j as f32 + 0.5) * self.resolution_m)
    }
}

impl ClearanceMap for GridMap<'_> {
    fn bounds_m(&self) -> (Vec2, Vec2) {
        let size = Vec2::new(self.width as f32, self.height as f32) * self.resolution_m;
        (self.origin_m, self.origin_m + size)
    }

    /// `D res - |p - c| - res sqrt(2)/2`, `c` the centre of the cell nearest `p`, `D` its
    /// transform value: the nearest occupied centre is at least `D res - |p - c|` from `p`
    /// (triangle inequality), and its square reaches `res sqrt(2)/2` closer. A lower bound.
    fn clearance_m(&self, p_m: Vec2) -> f32 {
        let rel = (p_m - self.origin_m) / self.resolution_m;
        let clamp_cell = |x: f32, n: usize| -> usize {
            if x.is_nan() || x < 0.0 {
                0
            } else {
                (x as usize).min(n.saturating_sub(1))
            }
        };
        let i = clamp_cell(rel.x, self.width);
        let j = clamp_cell(rel.y, self.height);
        let d = match self.dist_cells.get(j * self.width + i) {
            Some(d) => *d,
            None => return f32::NEG_INFINITY,
        };
        if d == f32::INFINITY {
            return f32::INFINITY;
        }
        let c = self.cell_center_m(i, j);
        d * self.resolution_m - vt_fpu::norm(&(p_m - c)) - HALF_DIAGONAL_CELLS * self.resolution_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn edt(cells: &mut [f32], w: usize, h: usize) {
        let n = w.max(h);
        let (mut line, mut v, mut z) = (vec![0.0; 2 * n], vec![0; n], vec![0.0; n + 1]);
        distance_transform(cells, w, h, &mut line, &mut v, &mut z).unwrap();
    }

    #[test]
    fn single_occupied_cell_gives_euclidean_distances() {
        let (w, h) = (7, 5);
        let mut cells = vec![f32::INFINITY; w * h];
        cells[2 * w + 3] = 0.0;
        edt(&mut cells, w, h);
        for j in 0..h {
            for i in 0..w {
                let want = ((i as f32 - 3.0).powi(2) + (j as f32 - 2.0).powi(2)).sqrt();
                assert!((cells[j * w + i] - want).abs() < 1e-5, "({i}, {j})");
            }
        }
    }

    #[test]
    fn empty_grid_is_infinite_and_bad_sizes_are_errors() {
        let mut cells = vec![1.0; 6];
        edt(&mut cells, 3, 2);
        assert!(cells.iter().all(|d| *d == f32::INFINITY));
        let (mut line, mut v, mut z) = (vec![0.0; 2], vec![0; 1], vec![0.0; 1]);
        assert!(distance_transform(&mut cells, 3, 2, &mut line, &mut v, &mut z).is_err());
        assert!(distance_transform(&mut cells, 4, 2, &mut [0.0; 8], &mut [0; 4], &mut [0.0; 5]).is_err());
    }

    proptest! {
        #[test]
        fn transform_equals_brute_force(w in 1usize..12, h in 1usize..12, bits in proptest::collection::vec(0u8..6, 144)) {
            let mut cells: Vec<f32> = (0..w * h).map(|k| if bits[k] == 0 { 0.0 } else { f32::INFINITY }).collect();
            let occ: Vec<(usize, usize)> = (0..w * h).filter(|&k| bits[k] == 0).map(|k| (k % w, k / w)).collect();
            edt(&mut cells, w, h);
            for j in 0..h {
                for i in 0..w {
                    let want = occ.iter().map(|&(a, b)| ((a as f32 - i as f32).powi(2) + (b as f32 - j as f32).powi(2)).sqrt())
                        .fold(f32::INFINITY, f32::min);
                    prop_assert!((cells[j * w + i] - want).abs() < 1e-4 || cells[j * w + i] == want);
                }
            }
        }

        #[test]
        fn grid_clearance_is_a_lower_bound(px in 0.0f32..5.0, py in 0.0f32..5.0, ox in 0usize..10, oy in 0usize..10) {
            // One occupied cell (ox, oy) of a 10 x 10 grid at 0.5 m: true distance to its square.
            let (w, h, res) = (10, 10, 0.5f32);
            let mut cells = vec![f32::INFINITY; w * h];
            cells[oy * w + ox] = 0.0;
            edt(&mut cells, w, h);
            let g = GridMap { dist_cells: &cells, width: w, height: h, resolution_m: res, origin_m: Vec2::zeros() };
            let lo = Vec2::new(ox as f32 * res, oy as f32 * res);
            let hi = lo + Vec2::new(res, res);
            let p = Vec2::new(px, py);
            let q = Vec2::new(p.x.clamp(lo.x, hi.x), p.y.clamp(lo.y, hi.y));
            let truth = (p - q).norm();
            prop_assert!(g.clearance_m(p) <= truth + 1e-5);
            prop_assert!(g.clearance_m(p) >= truth - 2.0 * res * 1.5);
        }
    }
}
