//! Occupancy grids: the exact distance from every cell centre to the occupied squares, and
//! the clearance it gives anywhere.
//!
//! The transform is Felzenszwalb and Huttenlocher's ("Distance Transforms of Sampled
//! Functions", Theory of Computing 8, 2012): separable, one pass over the columns and one over
//! the rows, each a lower envelope of parabolas, O(width x height). Their kernel is the squared
//! distance between cell centres; here it is the squared distance from a centre to an occupied
//! cell's *square*, `g(t) = max(|t| - 1/2, 0)^2` per axis (t in cells), which the same
//! envelope computes exactly: for `t != 0`, `g(t) = (t - 1/2)^2` on one side and `(t + 1/2)^2`
//! on the other, parabolas centred half a cell from the occupied cell, and the wrong side's
//! parabola is always the larger (see `square_pass`).
#![allow(clippy::indexing_slicing)] // kernels only; every slice length is checked on entry

use crate::{ClearanceMap, NodeIndex, PlanError, Vec2};

/// Cell centres around a query on each side beyond the nearest two.
const RING: usize = 1;
/// Side of the block of cell centres whose discs bound the clearance.
const SIDE: usize = 2 + 2 * RING;
/// `sqrt(2) / 2`: distance from a cell's centre to its corner, in cells.
const HALF_DIAGONAL_CELLS: f32 = core::f32::consts::FRAC_1_SQRT_2;
/// Twice `union_depth`'s rounding guard, cells: how far below the simplest bound the union's
/// answer may come out.
const UNION_GUARD_CELLS: f32 = 2e-4;
/// How far a stored distance may lie below the exact one (the eighths' rounding down), plus
/// the union's rounding guard, cells: the upper bounds' allowance.
const FIELD_ROUNDING_CELLS: f32 = 0.125 + 1e-4;

/// Distance transform of a `width x height` grid to its occupied squares, in place.
///
/// Input: `cells[j * width + i]` is `0.0` for an occupied cell and anything positive
/// (`f32::INFINITY` by convention) for a free one. Output: the exact Euclidean distance from
/// each cell's centre to the nearest point of an occupied cell (a solid square), in cells:
/// `0` on occupied cells, `0.5` beside one, `f32::INFINITY` when no cell is occupied.
/// Work space, `n = max(width, height)`: `line` at least `3 n + 1` long, `v` at least `n + 1`,
/// `z` at least `n + 2`.
///
/// # Errors
/// [`PlanError::BadParams`] when a slice is too short or the grid is empty.
pub fn distance_transform<I: NodeIndex>(
    cells: &mut [f32],
    width: usize,
    height: usize,
    line: &mut [f32],
    v: &mut [I],
    z: &mut [f32],
) -> Result<(), PlanError> {
    let n = check_sizes(cells.len(), width, height, line, v, z)?;
    let (f, rest) = line.split_at_mut(n);
    let (d, h) = rest.split_at_mut(n);
    // Columns: squared distance to the nearest occupied square of the same column (a column
    // with none stays infinite, as the envelope of no parabola is).
    for i in 0..width {
        let mut occupied = false;
        for j in 0..height {
            let c = cells[j * width + i];
            f[j] = if c > 0.0 {
                f32::INFINITY
            } else {
                occupied = true;
                0.0
            };
        }
        if occupied {
            square_pass(&f[..height], &mut d[..height], h, v, z);
        }
        let col = if occupied { &d[..height] } else { &f[..height] };
        for (j, x) in col.iter().enumerate() {
            cells[j * width + i] = *x;
        }
    }
    // Rows: `min over columns q of g(i - q) + column value`.
    for j in 0..height {
        let row = &mut cells[j * width..(j + 1) * width];
        f[..width].copy_from_slice(row);
        square_pass(&f[..width], &mut d[..width], h, v, z);
        for (c, dd) in row.iter_mut().zip(d.iter()) {
            *c = vt_fpu::sqrt(*dd); // the root of +inf is +inf
        }
    }
    Ok(())
}

/// [`distance_transform`] into one byte a cell: `floor(8 d)` for the exact distance `d` in
/// cells, [`EIGHTHS_FAR`] from 31.875 cells on (read back by [`GridMap`] as a lower bound,
/// at most an eighth of a cell short), in place.
///
/// Input: `cells[j * width + i]` is `0` for an occupied cell and anything else for a free
/// one. The columns' distances are whole cells (two passes, up and down the rows); the rows
/// take the same envelope as [`distance_transform`]; `8 d = sqrt(64 d^2)` is rounded down
/// exactly in integers (`64 d^2` is whole: `d^2` is a sum of two squares of half-integers).
/// Work space as [`distance_transform`]'s.
///
/// # Errors
/// [`PlanError::BadParams`] when a slice is too short or the grid is empty.
pub fn distance_transform_eighths<I: NodeIndex>(
    cells: &mut [u8],
    width: usize,
    height: usize,
    line: &mut [f32],
    v: &mut [I],
    z: &mut [f32],
) -> Result<(), PlanError> {
    let n = check_sizes(cells.len(), width, height, line, v, z)?;
    // Columns: `u8::MAX` for none within 254 (no row pass can use more: the result is capped
    // below that).
    column_counts(cells, width, height);
    let (f, rest) = line.split_at_mut(n);
    let (d, h) = rest.split_at_mut(n);
    // Rows: the column distance `m` (whole cells) is `(m - 1/2)^2` to the square, squared.
    for j in 0..height {
        let row = &mut cells[j * width..(j + 1) * width];
        for (fx, &m) in f.iter_mut().zip(row.iter()) {
            *fx = COLUMN_SQUARES[usize::from(m)];
        }
        square_pass(&f[..width], &mut d[..width], h, v, z);
        for (c, dd) in row.iter_mut().zip(d.iter()) {
            *c = eighths(*dd);
        }
    }
    Ok(())
}

/// The squared distance to an occupied square `m` whole cells up or down a column:
/// `(m - 1/2)^2`, `0` for the cell itself; infinite from 33 cells on, where it reaches the
/// eighths' cap (31.875 cells) alone: such a column can only give a distance the cap holds
/// anyway, so the rows' envelopes leave it out (fewer parabolas; rows far from everything
/// take the envelope's empty path).
const COLUMN_SQUARES: [f32; 256] = {
    let mut t = [f32::INFINITY; 256];
    t[0] = 0.0;
    let mut m = 1;
    while m < 33 {
        let x = m as f32 - 0.5;
        t[m] = x * x;
        m += 1;
    }
    t
};

/// `floor(8 sqrt(d2))` capped at [`EIGHTHS_FAR`], exactly, for a squared distance `d2` that is a
/// multiple of 1/4 (or infinite): `64 d2 = n` is then a whole number below 2^16, and the
/// correctly rounded `sqrt(n) = 8 sqrt(d2)` (scaling by 64 is exact) never rounds up to the
/// next whole number (`sqrt(k^2 - 1) < k - 1/(2k)`, far more than half an `f32` ulp below `k`
/// for `k <= 255`), so truncation is the integer square root.
fn eighths(d2: f32) -> u8 {
    let far = f32::from(EIGHTHS_FAR);
    if 64.0 * d2 < far * far {
        (8.0 * vt_fpu::sqrt(d2)) as u8
    } else {
        EIGHTHS_FAR
    }
}

/// [`distance_transform`] into two bytes a cell: `q = 4 d^2` for the exact distance `d` in
/// cells (a whole number: `d^2` is a sum of two squares of half-integers, or of a half-integer
/// and zero), [`SQUARES_FAR`] from `4 d^2 >= 65,534` on (128 cells less a hair, 32 m at
/// 0.25 m: read back as that lower bound), [`SQUARES_NONE`] when no cell is occupied. Half the
/// memory of the `f32` field and the same planner: [`GridMap`] reads `sqrt(q / 4)`, bit for bit
/// the `f32` transform's value below the cap (its squared distances are these quarters,
/// exact in `f32`), in place.
///
/// Input: `cells[j * width + i]` is `0` for an occupied cell and anything else for a free
/// one. The columns' distances are whole cells (two passes, up and down the rows); the rows
/// take the same envelope as [`distance_transform`]. Work space as [`distance_transform`]'s.
///
/// # Errors
/// [`PlanError::BadParams`] when a slice is too short or the grid is empty.
pub fn distance_transform_squares<I: NodeIndex>(
    cells: &mut [u16],
    width: usize,
    height: usize,
    line: &mut [f32],
    v: &mut [I],
    z: &mut [f32],
) -> Result<(), PlanError> {
    let n = check_sizes(cells.len(), width, height, line, v, z)?;
    if height >= usize::from(u16::MAX) {
        return Err(PlanError::BadParams { field: "cells" });
    }
    // Columns: `u16::MAX` for none (below 65,535 rows no count saturates).
    column_counts(cells, width, height);
    let (f, rest) = line.split_at_mut(n);
    let (d, h) = rest.split_at_mut(n);
    // Rows: the column distance `m` (whole cells) is `(m - 1/2)^2` to the square, squared,
    // exactly as the `f32` transform's column pass gives it.
    for j in 0..height {
        let row = &mut cells[j * width..(j + 1) * width];
        for (fx, &m) in f.iter_mut().zip(row.iter()) {
            *fx = match m {
                0 => 0.0,
                u16::MAX => f32::INFINITY,
                _ => {
                    let x = f32::from(m) - 0.5;
                    x * x
                }
            };
        }
        square_pass(&f[..width], &mut d[..width], h, v, z);
        for (c, dd) in row.iter_mut().zip(d.iter()) {
            *c = quarter_squares(*dd);
        }
    }
    Ok(())
}

/// The largest squared distance the two-byte field holds, in quarters of a cell squared
/// (`4 d^2`): 16,383.5 cells^2 and beyond, read as that lower bound.
pub const SQUARES_FAR: u16 = u16::MAX - 1;
/// The two-byte field's value when no cell is occupied: infinitely far.
pub const SQUARES_NONE: u16 = u16::MAX;

/// `4 d2` as a whole number for a squared distance `d2` that is a multiple of 1/4, capped at
/// [`SQUARES_FAR`]; [`SQUARES_NONE`] for infinity (or NaN, which the envelope never gives).
fn quarter_squares(d2: f32) -> u16 {
    let q = 4.0 * d2;
    if q < f32::from(SQUARES_FAR) {
        q as u16
    } else if q.is_finite() {
        SQUARES_FAR
    } else {
        SQUARES_NONE
    }
}

/// A compact field's cell while its columns are counted: whole cells, saturating.
trait ColumnCount: Copy + Ord {
    /// The occupied cell's count, and the input's mark of an occupied cell.
    const ZERO: Self;
    /// No occupied cell within the type's range.
    const NONE: Self;
    /// One cell farther, saturating at [`Self::NONE`].
    fn next(self) -> Self;
}

impl ColumnCount for u8 {
    const ZERO: Self = 0;
    const NONE: Self = u8::MAX;
    fn next(self) -> Self {
        self.saturating_add(1)
    }
}

impl ColumnCount for u16 {
    const ZERO: Self = 0;
    const NONE: Self = u16::MAX;
    fn next(self) -> Self {
        self.saturating_add(1)
    }
}

/// The compact transforms' column pass, in place, by rows (contiguous): each cell becomes the
/// whole cells to the nearest occupied cell (input `ZERO`) of its column, up then down,
/// [`ColumnCount::NONE`] for none within the type's range.
fn column_counts<T: ColumnCount>(cells: &mut [T], width: usize, height: usize) {
    for c in cells[..width].iter_mut() {
        *c = if *c == T::ZERO { T::ZERO } else { T::NONE };
    }
    for j in 1..height {
        let (done, rest) = cells.split_at_mut(j * width);
        let above = &done[(j - 1) * width..];
        for (c, &a) in rest[..width].iter_mut().zip(above) {
            *c = if *c == T::ZERO { T::ZERO } else { a.next() };
        }
    }
    for j in (0..height - 1).rev() {
        let (upto, below) = cells.split_at_mut((j + 1) * width);
        for (c, &b) in upto[j * width..].iter_mut().zip(&below[..width]) {
            let b = b.next();
            if b < *c {
                *c = b;
            }
        }
    }
}

/// The transforms' size checks: a non-empty `width x height` grid of `len` cells and work
/// space for its longest line; returns that length.
fn check_sizes<I: NodeIndex>(len: usize, width: usize, height: usize, line: &[f32], v: &[I], z: &[f32]) -> Result<usize, PlanError> {
    let n = width.max(height);
    if width == 0 || height == 0 || width.checked_mul(height) != Some(len) {
        return Err(PlanError::BadParams { field: "cells" });
    }
    if line.len() < 3 * n + 1 || v.len() < n + 1 || z.len() < n + 2 || n + 1 > I::CAPACITY {
        return Err(PlanError::BadParams { field: "work space" });
    }
    Ok(n)
}

/// One axis of the square kernel: `d(x) = min_q g(x - q) + f(q)`, `g(t) = max(|t| - 1/2, 0)^2`.
///
/// `g(0) = 0` gives the `f(x)` term. For `t = x - q != 0`, `g(t) = min((t - 1/2)^2, (t + 1/2)^2)`
/// (the nearer parabola is the one on `q`'s side of `x`), so `d(x) = min(f(x), E(x))` with `E`
/// the lower envelope of parabolas at the half-integer sites `k + 1/2`, `k = -1..n-1`, of height
/// `min(f(k), f(k + 1))` (F&H's DT over those sites). `h`: `n + 1` long.
fn square_pass<I: NodeIndex>(f: &[f32], d: &mut [f32], h: &mut [f32], v: &mut [I], z: &mut [f32]) {
    let n = f.len();
    let at = |k: usize| -> f32 { f.get(k).copied().unwrap_or(f32::INFINITY) };
    // Site s = k + 1/2 for k = -1..n-1 is stored at index k + 1 (position idx - 1/2).
    for (idx, hk) in h.iter_mut().enumerate().take(n + 1) {
        let left = if idx == 0 { f32::INFINITY } else { at(idx - 1) };
        *hk = vt_fpu::min(left, at(idx));
    }
    envelope(&h[..=n], d, v, z, -0.5);
    for (dx, fx) in d.iter_mut().zip(f.iter()) {
        *dx = vt_fpu::min(*dx, *fx);
    }
}

/// F&H's DT: `d(x) = min_s (x - pos(s))^2 + h(s)` for integer `x` in `0..d.len()`, with the
/// sites at `pos(s) = s + offset`. Infinite heights take no part in the envelope. `v`: the
/// envelope's sites, `h.len()` long; `z`: its boundaries, `h.len() + 1` long.
fn envelope<I: NodeIndex>(h: &[f32], d: &mut [f32], v: &mut [I], z: &mut [f32], offset: f32) {
    if !lower_envelope(h, v, z, offset) {
        d.iter_mut().for_each(|x| *x = f32::INFINITY);
        return;
    }
    let pos = |s: usize| s as f32 + offset;
    let mut k = 0usize;
    for (x, dx_out) in d.iter_mut().enumerate() {
        let xf = x as f32;
        while z[k + 1] < xf {
            k += 1;
        }
        let p = v[k].node();
        let dx = xf - pos(p);
        *dx_out = dx * dx + h[p];
    }
}

/// The lower envelope of the parabolas `(x - pos(s))^2 + h(s)`, `pos(s) = s + offset`, over the
/// sites of finite height (F&H's construction): site `v[k]` is lowest on `z[k]..z[k + 1]`, the
/// last boundary `+inf`. `v`: `h.len()` long; `z`: `h.len() + 1`. False (and `v`, `z`
/// untouched) when every height is infinite.
pub(crate) fn lower_envelope<I: NodeIndex>(h: &[f32], v: &mut [I], z: &mut [f32], offset: f32) -> bool {
    let pos = |s: usize| s as f32 + offset;
    let mut k: usize = 0;
    let mut any = false;
    for (q, &hq) in h.iter().enumerate() {
        if !hq.is_finite() {
            continue;
        }
        if !any {
            any = true;
            v[0] = I::from_node(q);
            z[0] = f32::NEG_INFINITY;
            z[1] = f32::INFINITY;
            continue;
        }
        let qf = pos(q);
        loop {
            let p = v[k].node();
            let pf = pos(p);
            let s = ((hq + qf * qf) - (h[p] + pf * pf)) / (2.0 * (qf - pf));
            // z[0] = -inf: the envelope never empties.
            if k > 0 && s <= z[k] {
                k -= 1;
                continue;
            }
            k += 1;
            v[k] = I::from_node(q);
            z[k] = s;
            z[k + 1] = f32::INFINITY;
            break;
        }
    }
    any
}

/// The distances a [`GridMap`] reads, cells: exact `f32` ([`distance_transform`]) or `u8`
/// eighths of a cell rounded down ([`distance_transform_eighths`], a quarter of the memory).
pub trait DistanceCells {
    /// Distance from cell `k`'s centre (row-major) to the nearest occupied square, cells, or a
    /// lower bound of it; `None` outside the slice.
    fn distance_cells(&self, k: usize) -> Option<f32>;
    /// Whether cell `k` is occupied (its distance is zero); `None` outside the slice.
    #[inline]
    fn is_occupied(&self, k: usize) -> Option<bool> {
        self.distance_cells(k).map(|d| d <= 0.0)
    }
    /// Whether cell `k` holds the field's cap, a lower bound only (its disc's far side bounds
    /// nothing from above); false outside the slice.
    #[inline]
    fn is_capped(&self, _k: usize) -> bool {
        false
    }
}

impl DistanceCells for [f32] {
    #[inline]
    fn distance_cells(&self, k: usize) -> Option<f32> {
        self.get(k).copied()
    }
}

/// The largest distance the eighths hold, in eighths of a cell: 31.875 cells and beyond.
pub const EIGHTHS_FAR: u8 = u8::MAX;

impl DistanceCells for [u8] {
    /// `q / 8` cells: `floor(8 d) / 8` for the exact distance `d`, or 31.875 for
    /// [`EIGHTHS_FAR`] (`d` at least that).
    #[inline]
    fn distance_cells(&self, k: usize) -> Option<f32> {
        self.get(k).map(|&q| f32::from(q) * 0.125)
    }

    #[inline]
    fn is_occupied(&self, k: usize) -> Option<bool> {
        self.get(k).map(|&q| q == 0)
    }

    #[inline]
    fn is_capped(&self, k: usize) -> bool {
        self.get(k) == Some(&EIGHTHS_FAR)
    }
}

impl DistanceCells for [u16] {
    /// `sqrt(q / 4)` cells: the exact distance below [`SQUARES_FAR`] (the same `f32` as
    /// [`distance_transform`]'s: `q / 4` is its squared distance, exactly), 127.998 cells (a
    /// lower bound) at it, infinite for [`SQUARES_NONE`].
    #[inline]
    fn distance_cells(&self, k: usize) -> Option<f32> {
        self.get(k).map(|&q| if q == SQUARES_NONE { f32::INFINITY } else { vt_fpu::sqrt(f32::from(q) * 0.25) })
    }

    #[inline]
    fn is_occupied(&self, k: usize) -> Option<bool> {
        self.get(k).map(|&q| q == 0)
    }

    #[inline]
    fn is_capped(&self, k: usize) -> bool {
        self.get(k) == Some(&SQUARES_FAR)
    }
}

/// An occupancy grid with its distance transform: the clearance map of a raster.
///
/// Cell `(i, j)` (column `i` east, row `j` north, row-major `j * width + i`) covers the square
/// `origin + [i, i+1] x [j, j+1] resolution`. An occupied cell is a solid square.
#[derive(Debug, Clone, Copy)]
pub struct GridMap<'a, C: ?Sized + DistanceCells = [f32]> {
    /// Output of [`distance_transform`] (`[f32]`), [`distance_transform_squares`] (`[u16]`) or
    /// [`distance_transform_eighths`] (`[u8]`), cells.
    pub dist_cells: &'a C,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Cell side, m.
    pub resolution_m: f32,
    /// Lower-left corner of cell `(0, 0)`, m.
    pub origin_m: Vec2,
}

impl<C: ?Sized + DistanceCells> GridMap<'_, C> {
    /// Centre of cell `(i, j)`, m.
    pub fn cell_center_m(&self, i: usize, j: usize) -> Vec2 {
        self.origin_m + Vec2::new((i as f32 + 0.5) * self.resolution_m, (j as f32 + 0.5) * self.resolution_m)
    }
}

impl<C: ?Sized + DistanceCells> GridMap<'_, C> {
    /// Minus the distance from `rel` (centre coordinates: centre `(i, j)` at `(i, j)`) to its
    /// cell's centre and the half diagonal, m, when that cell is occupied (a point outside the
    /// grid counts in the edge cell nearest it); `None` when it is free. Both grid dimensions
    /// must be non-zero.
    pub(crate) fn inside_occupied_m(&self, rel: Vec2) -> Option<f32> {
        let own = |x: f32, n: usize| -> usize { if x < -0.5 { 0 } else { ((x + 0.5) as usize).min(n - 1) } };
        let (io, jo) = (own(rel.x, self.width), own(rel.y, self.height));
        if self.dist_cells.is_occupied(jo * self.width + io) == Some(true) {
            let c = Vec2::new(io as f32, jo as f32);
            Some(-(vt_fpu::norm(&(rel - c)) + HALF_DIAGONAL_CELLS) * self.resolution_m)
        } else {
            None
        }
    }
}

impl<C: ?Sized + DistanceCells> ClearanceMap for GridMap<'_, C> {
    fn bounds_m(&self) -> (Vec2, Vec2) {
        let size = Vec2::new(self.width as f32, self.height as f32) * self.resolution_m;
        (self.origin_m, self.origin_m + size)
    }

    /// A lower bound of the distance from `p` to the occupied squares, m, tight to a few
    /// hundredths of a cell a few cells away from them (docs/planning.md, "Grids").
    ///
    /// The transform gives, at each of the 4 x 4 cell centres `c_k` around `p`, the exact
    /// distance `r_k` to the occupied squares, so no occupied square meets the open disc
    /// `B(c_k, r_k)`, and none lies outside the grid. The distance from `p` to the part of the
    /// grid the discs leave uncovered is therefore a lower bound (`union_depth`). Inside an
    /// occupied cell the value is negative; `f32::INFINITY` when no cell is occupied.
    fn clearance_m(&self, p_m: Vec2) -> f32 {
        self.clearance_capped_m(p_m, f32::INFINITY)
    }

    /// The exact distance to the occupied squares at every node, in one sweep of the grid
    /// (`node_clearance`): at least the union of discs' bound.
    fn lattice_clearances_m<I: NodeIndex>(&self, lat: &crate::Lattice, out: &mut impl FnMut(usize, f32), space: crate::SweepSpace<'_, I>) -> bool {
        crate::node_clearance::lattice_clearances_m(self, lat, out, space)
    }

    /// As [`Self::clearance_m`], but a point whose simplest bound, `max_k r_k - |p - c_k|`,
    /// already reaches `cap_m` gets that bound without the union's boundary being searched.
    fn clearance_capped_m(&self, p_m: Vec2, cap_m: f32) -> f32 {
        let (rel, discs, depth) = match self.discs_around(p_m) {
            Ok(d) => d,
            Err(answer) => return answer,
        };
        let res = self.resolution_m;
        let simple = depth.iter().copied().fold(f32::NEG_INFINITY, vt_fpu::max);
        if simple * res >= cap_m {
            return simple * res;
        }
        // The grid's extent in centre coordinates: no occupied square lies beyond it.
        let (lo, hi) = (Vec2::new(-0.5, -0.5), Vec2::new(self.width as f32 - 0.5, self.height as f32 - 0.5));
        vt_fpu::max(union_depth(&discs, &depth, rel, lo, hi), 0.0) * res
    }

    /// From the 2 x 2 discs around the point alone (any disc bounds the distance both ways):
    /// below, the simplest bound `max_k r_k - |p - c_k|`, and where that stays under `enough_m`,
    /// the distance to the part of the grid the four discs leave uncovered, which holds the
    /// 16-disc union's, less the union's rounding guard twice over; above, the nearest disc's far
    /// side `min_k r_k + |p - c_k|` over the discs below the field's cap, which the distance to
    /// the occupied squares, and so the query, never exceeds (plus an eighth of a cell for a
    /// field rounded down; infinite when all four are at the cap). The union's
    /// bound counts only up to `cap_m`, where the query may answer its simplest bound.
    fn has_cheap_bounds(&self) -> bool {
        true
    }

    fn clearance_capped_bounds_m(&self, p_m: Vec2, cap_m: f32, enough_m: f32) -> (f32, f32) {
        let res = self.resolution_m;
        let rel = (p_m - self.origin_m) / res - Vec2::new(0.5, 0.5);
        if !(rel.x.is_finite() && rel.y.is_finite()) || self.width == 0 || self.height == 0 {
            return (f32::NEG_INFINITY, f32::NEG_INFINITY);
        }
        let low = |x: f32, n: usize| -> usize { if x < 0.0 { 0 } else { (x as usize).min(n - 1) } };
        let (i0, j0) = (low(rel.x, self.width), low(rel.y, self.height));
        let mut discs = [(Vec2::zeros(), 0.0f32); 4];
        let mut depth = [0.0f32; 4];
        // The far side of a disc at the field's cap bounds nothing from above.
        let mut far = f32::INFINITY;
        for (k, (slot, dk)) in discs.iter_mut().zip(depth.iter_mut()).enumerate() {
            let (i, j) = ((i0 + k % 2).min(self.width - 1), (j0 + k / 2).min(self.height - 1));
            let Some(r) = self.dist_cells.distance_cells(j * self.width + i) else {
                return (f32::NEG_INFINITY, f32::NEG_INFINITY);
            };
            if r == f32::INFINITY {
                return (f32::INFINITY, f32::INFINITY); // no occupied cell anywhere
            }
            let c = Vec2::new(i as f32, j as f32);
            *slot = (c, r);
            *dk = r - vt_fpu::norm(&(rel - c));
            if !self.dist_cells.is_capped(j * self.width + i) {
                far = vt_fpu::min(far, 2.0 * r - *dk);
            }
        }
        if let Some(inside) = self.inside_occupied_m(rel) {
            return (inside, inside);
        }
        let upper = (far + FIELD_ROUNDING_CELLS) * res;
        let simple = depth.iter().copied().fold(f32::NEG_INFINITY, vt_fpu::max);
        // The query's union may come out below the simplest bound by its rounding guard.
        if simple * res >= enough_m {
            return (vt_fpu::max(simple - UNION_GUARD_CELLS, 0.0) * res, upper);
        }
        let (lo, hi) = (Vec2::new(-0.5, -0.5), Vec2::new(self.width as f32 - 0.5, self.height as f32 - 0.5));
        let near = vt_fpu::max(union_depth(&discs, &depth, rel, lo, hi) - UNION_GUARD_CELLS, 0.0) * res;
        // At or above the cap the query may answer its simplest bound instead of the union.
        (vt_fpu::max(vt_fpu::max(simple - UNION_GUARD_CELLS, 0.0) * res, vt_fpu::min(near, cap_m)), upper)
    }
}

impl<C: ?Sized + DistanceCells> GridMap<'_, C> {
    /// The query's position in centre coordinates (centre `(i, j)` at `(i, j)`), the 4 x 4
    /// discs around it and how deep it lies in each (`r_k - |p - c_k|`, cells); `Err` with the
    /// query's answer where it needs no disc: `-inf` for a position that is not finite or an
    /// empty grid, `+inf` when no cell is occupied, the inside value in an occupied cell.
    #[allow(clippy::type_complexity)] // the three arrays the two bounds share
    fn discs_around(&self, p_m: Vec2) -> Result<(Vec2, [(Vec2, f32); SIDE * SIDE], [f32; SIDE * SIDE]), f32> {
        let res = self.resolution_m;
        let rel = (p_m - self.origin_m) / res - Vec2::new(0.5, 0.5);
        if !(rel.x.is_finite() && rel.y.is_finite()) || self.width == 0 || self.height == 0 {
            return Err(f32::NEG_INFINITY);
        }
        let lattice = |x: f32, n: usize| -> usize {
            let lo = if x < 0.0 { 0 } else { (x as usize).min(n - 1) };
            lo.saturating_sub(RING)
        };
        let (i0, j0) = (lattice(rel.x, self.width), lattice(rel.y, self.height));
        let mut discs = [(Vec2::zeros(), 0.0f32); SIDE * SIDE];
        for (k, slot) in discs.iter_mut().enumerate() {
            let (i, j) = ((i0 + k % SIDE).min(self.width - 1), (j0 + k / SIDE).min(self.height - 1));
            let Some(r) = self.dist_cells.distance_cells(j * self.width + i) else {
                return Err(f32::NEG_INFINITY);
            };
            if r == f32::INFINITY {
                return Err(f32::INFINITY); // no occupied cell anywhere
            }
            *slot = (Vec2::new(i as f32, j as f32), r);
        }
        if let Some(inside) = self.inside_occupied_m(rel) {
            return Err(inside);
        }
        // Disc k holds the ball of radius `depth[k] = r_k - |p - c_k|` around p.
        let mut depth = [0.0f32; SIDE * SIDE];
        for (dk, (c, r)) in depth.iter_mut().zip(discs.iter()) {
            *dk = r - vt_fpu::norm(&(rel - c));
        }
        Ok((rel, discs, depth))
    }
}

/// Distance from `p` to the part of the rectangle `lo..hi` that the open discs
/// `(centre, radius)` leave uncovered, or less (never more); `0` when no disc covers `p`.
///
/// The occupied squares lie in that part (the grid ends at the rectangle), so this is a lower
/// bound of the distance to them. Its nearest point to `p` lies on the uncovered part's
/// boundary: the point of a circle nearest `p`, a crossing of two circles, a crossing of a
/// circle and an edge, the foot of `p` on an edge, or a corner, whichever no disc covers.
/// `depth[k] = r_k - |p - c_k|`: how far inside disc k `p` lies (negative outside).
fn union_depth<const N: usize>(discs: &[(Vec2, f32); N], depth: &[f32; N], p: Vec2, lo: Vec2, hi: Vec2) -> f32 {
    /// A candidate point counts as covered, or outside the rectangle, only this far in or out
    /// (cells), so rounding can only lower the bound.
    const TOL: f32 = 1e-4;
    if !depth.iter().any(|d| *d > 0.0) {
        return 0.0;
    }
    let outside = |q: Vec2| q.x < lo.x - TOL || q.x > hi.x + TOL || q.y < lo.y - TOL || q.y > hi.y + TOL;
    let covered = |q: Vec2, skip: [usize; 2]| {
        outside(q)
            || discs.iter().enumerate().any(|(m, (c, r))| {
                let inner = r - TOL;
                !skip.contains(&m) && inner > 0.0 && (q - c).norm_squared() < inner * inner
            })
    };
    // The distance to `q` when it beats `best` and nothing covers `q`.
    let better = |q: Vec2, skip: [usize; 2], best: f32| -> f32 {
        let g2 = (q - p).norm_squared();
        if g2 < best * best && !covered(q, skip) {
            vt_fpu::sqrt(g2)
        } else {
            best
        }
    };
    let mut best = f32::INFINITY;
    let reaches_out = discs.iter().any(|(c, r)| c.x - r < lo.x || c.x + r > hi.x || c.y - r < lo.y || c.y + r > hi.y);
    // Every point of circle k is at least `gap[k]` from p: visit the circles nearest first and
    // stop at the first whose gap cannot beat the best so far (crossings lie on both circles).
    let gap = depth.map(f32::abs);
    let mut order = [0usize; N];
    for k in 0..N {
        // Insertion sort, ascending gap (16 entries).
        let mut at = k;
        while at > 0 && gap[order[at - 1]] > gap[k] {
            order[at] = order[at - 1];
            at -= 1;
        }
        order[at] = k;
    }
    for (idx, &k) in order.iter().enumerate() {
        if gap[k] >= best {
            break;
        }
        let (c, r) = discs[k];
        // The point of circle k nearest p (any point when p is its centre: all are at r, and the
        // disc lies in the union, so nothing uncovered is nearer; r is then a safe candidate).
        let off = p - c;
        let dist = vt_fpu::norm(&off);
        if dist > 1e-6 {
            best = better(c + off * (r / dist), [k, k], best);
        } else {
            best = vt_fpu::min(best, r);
        }
        // Where circle k crosses the circles visited before it.
        for &m in &order[..idx] {
            let (cm, rm) = discs[m];
            let dc = cm - c;
            let d = vt_fpu::norm(&dc);
            if d <= 1e-6 || d >= r + rm || d <= (r - rm).abs() {
                continue;
            }
            let a = (r * r - rm * rm + d * d) / (2.0 * d);
            let hh = vt_fpu::sqrt(vt_fpu::max(r * r - a * a, 0.0));
            let mid = c + dc * (a / d);
            let perp = Vec2::new(-dc.y, dc.x) * (hh / d);
            best = better(mid + perp, [k, m], best);
            best = better(mid - perp, [k, m], best);
        }
        // Where circle k crosses an edge of the rectangle.
        if reaches_out {
            for (x_edge, along_x) in [(lo.x, false), (hi.x, false), (lo.y, true), (hi.y, true)] {
                let (across, along) = if along_x { (c.y, c.x) } else { (c.x, c.y) };
                let h2 = r * r - (x_edge - across) * (x_edge - across);
                if h2 > 0.0 {
                    let h = vt_fpu::sqrt(h2);
                    for t in [along - h, along + h] {
                        best = better(if along_x { Vec2::new(t, x_edge) } else { Vec2::new(x_edge, t) }, [k, k], best);
                    }
                }
            }
        }
    }
    if reaches_out {
        // The feet of p on the edges, and the corners.
        let (px, py) = (p.x.clamp(lo.x, hi.x), p.y.clamp(lo.y, hi.y));
        for q in [Vec2::new(lo.x, py), Vec2::new(hi.x, py), Vec2::new(px, lo.y), Vec2::new(px, hi.y)] {
            best = better(q, [usize::MAX, usize::MAX], best);
        }
        for q in [lo, hi, Vec2::new(lo.x, hi.y), Vec2::new(hi.x, lo.y)] {
            best = better(q, [usize::MAX, usize::MAX], best);
        }
    }
    best
}

#[cfg(test)]
#[path = "grid_bounds_tests.rs"]
mod bounds_tests;

#[cfg(test)]
#[path = "grid_tests.rs"]
mod tests;
