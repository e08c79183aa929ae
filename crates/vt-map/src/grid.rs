//! The log-odds occupancy grid: fixed capacity, runtime size, one `i8` per cell or, for one
//! sensor model, four bits ([`crate::store`]).
//!
//! # Frames
//! World ENU, metres, horizontal plane. Cell `(i, j)` is column `i` (east) and row `j` (north),
//! stored row-major at `j * width + i`, and covers the half-open square
//! `origin_m + [i, i+1) x [j, j+1) * resolution_m` (the same layout as `vt_plan::GridMap`).

use core::fmt;

use crate::store::{Bytes, CellStore, Nibbles};
use crate::{ray, LogOddsParams, MapError, Vec2};

/// Largest `width` or `height`, cells: cell indices stay exact in `f32` (2^24).
const MAX_SIDE_CELLS: usize = 1 << 24;

/// A log-odds occupancy grid of at most `CELLS` cells, one `i8` each (see [`crate::log_odds`]).
pub type OccupancyGrid<const CELLS: usize> = LogOddsGrid<Bytes<CELLS>>;

/// A log-odds occupancy grid of at most `2 * BYTES` cells, four bits each, for one sensor model
/// of at most 16 values ([`crate::store`]; build it with [`LogOddsGrid::adopt`]).
pub type PackedOccupancyGrid<const BYTES: usize> = LogOddsGrid<Nibbles<BYTES>>;

/// A log-odds occupancy grid over a cell store `S` ([`OccupancyGrid`], [`PackedOccupancyGrid`]).
///
/// A cell holds log-odds in 1/16 nat: `> 0` occupied, `< 0` free, `0` unknown. On the MCU,
/// build it in place: `static` or a field initialised with [`OccupancyGrid::empty`], then
/// [`OccupancyGrid::reset`]; [`OccupancyGrid::new`] returns the whole array by value.
#[derive(Clone)]
pub struct LogOddsGrid<S> {
    /// Log-odds, 1/16 nat, row-major; only the first `width * height` are in use.
    pub(crate) cells: S,
    /// Columns (east).
    pub(crate) width: usize,
    /// Rows (north).
    pub(crate) height: usize,
    /// Cell side, m.
    pub(crate) resolution_m: f32,
    /// Lower-left corner of cell `(0, 0)`, world ENU, m.
    pub(crate) origin_m: Vec2,
}

impl<S> fmt::Debug for LogOddsGrid<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("OccupancyGrid")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("resolution_m", &self.resolution_m)
            .field("origin_m", &(self.origin_m.x, self.origin_m.y))
            .finish_non_exhaustive()
    }
}

impl<const CELLS: usize> Default for OccupancyGrid<CELLS> {
    fn default() -> Self {
        Self::empty()
    }
}

impl<const CELLS: usize> OccupancyGrid<CELLS> {
    /// A grid of no cells whose every byte is zero (`resolution_m` 0): the storage a firmware
    /// keeps in `.bss`, with no image in flash, until [`OccupancyGrid::reset`] gives it a
    /// world. Nothing folds into it or reads from it before.
    pub const fn zeroed() -> Self {
        const { assert!(CELLS > 0, "an occupancy grid needs at least one cell") };
        Self { cells: Bytes([0; CELLS]), width: 0, height: 0, resolution_m: 0.0, origin_m: Vec2::new(0.0, 0.0) }
    }

    /// A grid of no cells (every query `None`, every scan ignored) until
    /// [`OccupancyGrid::reset`]; usable in a `static`.
    pub const fn empty() -> Self {
        const { assert!(CELLS > 0, "an occupancy grid needs at least one cell") };
        Self {
            cells: Bytes([0; CELLS]),
            width: 0,
            height: 0,
            resolution_m: 1.0,
            origin_m: Vec2::new(0.0, 0.0),
        }
    }

    /// A `width x height` grid of unknown cells of side `resolution_m` (m), cell `(0, 0)`'s
    /// lower-left corner at `origin_m` (world ENU, m).
    ///
    /// # Errors
    /// As [`OccupancyGrid::reset`].
    pub fn new(
        width: usize,
        height: usize,
        resolution_m: f32,
        origin_m: Vec2,
    ) -> Result<Self, MapError> {
        let mut g = Self::empty();
        g.reset(width, height, resolution_m, origin_m)?;
        Ok(g)
    }

    /// Log-odds of the cells in use, 1/16 nat, row-major (`j * width + i`).
    pub fn cells(&self) -> &[i8] {
        self.cells.0.get(..self.width * self.height).unwrap_or(&[])
    }
}

impl<const BYTES: usize> PackedOccupancyGrid<BYTES> {
    /// A grid of no cells and no sensor model whose every byte is zero, for `.bss`: give it a
    /// model ([`LogOddsGrid::adopt`]) and a world ([`LogOddsGrid::reset`]) before use; until
    /// then every scan is skipped.
    pub const fn zeroed() -> Self {
        const { assert!(BYTES > 0, "an occupancy grid needs at least one cell") };
        Self { cells: Nibbles::zeroed(), width: 0, height: 0, resolution_m: 0.0, origin_m: Vec2::new(0.0, 0.0) }
    }
}

impl<S> LogOddsGrid<S> {
    /// Bytes of RAM the grid takes (`size_of::<Self>()`).
    pub const fn ram_bytes() -> usize {
        core::mem::size_of::<Self>()
    }
}

impl<S: CellStore> LogOddsGrid<S> {
    /// Makes the grid fold scans of sensor model `params` (every cell forgotten when the
    /// store's coding changes; a byte grid holds any valid model).
    ///
    /// # Errors
    /// [`MapError::BadParams`] for an invalid model; [`MapError::TooManyStates`] when a
    /// packed grid cannot hold every value it reaches.
    pub fn adopt(&mut self, params: &LogOddsParams) -> Result<(), MapError> {
        self.cells.adopt(params)
    }

    /// Cells the grid can hold.
    pub fn capacity(&self) -> usize {
        self.cells.capacity()
    }

    /// Re-sizes the grid in place and forgets every cell (all unknown); on error nothing changes.
    ///
    /// # Errors
    /// [`MapError::BadParams`] for a zero `width` or `height` (or above 2^24), a non-finite or
    /// non-positive `resolution_m`, a non-finite `origin_m` or far corner;
    /// [`MapError::TooManyCells`] when `width * height > CELLS`.
    pub fn reset(
        &mut self,
        width: usize,
        height: usize,
        resolution_m: f32,
        origin_m: Vec2,
    ) -> Result<(), MapError> {
        let bad = |field| Err(MapError::BadParams { field });
        if width == 0 || width > MAX_SIDE_CELLS {
            return bad("width");
        }
        if height == 0 || height > MAX_SIDE_CELLS {
            return bad("height");
        }
        let needed = width.saturating_mul(height);
        if needed > self.cells.capacity() {
            return Err(MapError::TooManyCells {
                needed,
                capacity: self.cells.capacity(),
            });
        }
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return bad("resolution_m");
        }
        if !(origin_m.x.is_finite() && origin_m.y.is_finite()) {
            return bad("origin_m");
        }
        let far = origin_m + Vec2::new(width as f32, height as f32) * resolution_m;
        if !(far.x.is_finite() && far.y.is_finite()) {
            return bad("resolution_m");
        }
        self.width = width;
        self.height = height;
        self.resolution_m = resolution_m;
        self.origin_m = origin_m;
        self.clear();
        Ok(())
    }

    /// Forgets every cell (all unknown), keeping the geometry.
    pub fn clear(&mut self) {
        self.cells.clear();
    }

    /// Columns (east), cells.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows (north), cells.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Cell side, m.
    pub fn resolution_m(&self) -> f32 {
        self.resolution_m
    }

    /// Lower-left corner of cell `(0, 0)`, world ENU, m.
    pub fn origin_m(&self) -> Vec2 {
        self.origin_m
    }

    /// Cells in use, `width * height`.
    pub(crate) fn in_use(&self) -> usize {
        self.width * self.height
    }

    /// Grid coordinates of a world point: `(p - origin) / resolution`, cells.
    pub(crate) fn to_grid(&self, p_m: Vec2) -> Vec2 {
        (p_m - self.origin_m) / self.resolution_m
    }

    /// The cell holding world point `p_m` (ENU, m); `None` outside the grid or for NaN.
    pub fn cell_of(&self, p_m: Vec2) -> Option<(usize, usize)> {
        ray::cell_at(self.to_grid(p_m), self.width, self.height)
    }

    /// Row-major index of cell `(i, j)` if inside.
    pub(crate) fn index(&self, i: usize, j: usize) -> Option<usize> {
        (i < self.width && j < self.height).then(|| j * self.width + i)
    }

    /// Log-odds of cell `(i, j)`, 1/16 nat; `None` outside the grid.
    pub fn log_odds(&self, i: usize, j: usize) -> Option<i8> {
        self.cells.get(self.index(i, j)?)
    }

    /// Whether cell `(i, j)` is occupied (log-odds > 0); `false` outside the grid.
    pub fn is_occupied(&self, i: usize, j: usize) -> bool {
        self.log_odds(i, j).is_some_and(|l| l > 0)
    }

    /// Whether cell `(i, j)` is free (log-odds < 0); `false` outside the grid.
    pub fn is_free(&self, i: usize, j: usize) -> bool {
        self.log_odds(i, j).is_some_and(|l| l < 0)
    }

    /// Centre of cell `(i, j)`, world ENU, m; `None` outside the grid.
    pub fn cell_center_m(&self, i: usize, j: usize) -> Option<Vec2> {
        self.index(i, j)?;
        Some(self.origin_m + Vec2::new(i as f32 + 0.5, j as f32 + 0.5) * self.resolution_m)
    }

    /// Cells with log-odds > 0, counted: O(width x height). (A running count would cost the
    /// scan fold a compare per freed cell on the flight MCU, and only tests and reports ask.)
    pub fn occupied_count(&self) -> usize {
        (0..self.in_use()).filter(|&k| self.cells.get(k).is_some_and(|l| l > 0)).count()
    }

    /// The occupied cells (log-odds > 0) as bits, into `out`: cell `k` (row-major) in bit
    /// `k % 32` of word `k / 32`, set when occupied (unknown counts as free, as in
    /// [`Self::write_planner_cells`]): the input of `vt_plan::OccupancyMap`, at this grid's
    /// resolution. The words past the grid's last cell are cleared up to the end of its last
    /// word; the rest of `out` is untouched. Returns `(width, height)`.
    ///
    /// # Errors
    /// [`MapError::EmptyGrid`] before `reset`; [`MapError::OutputTooShort`] when `out` holds
    /// fewer words than the grid needs.
    pub fn write_planner_bits(&self, out: &mut [u32]) -> Result<(usize, usize), MapError> {
        if self.width == 0 || self.height == 0 {
            return Err(MapError::EmptyGrid);
        }
        let n = self.in_use();
        let words = n.div_ceil(32);
        let Some(dst) = out.get_mut(..words) else {
            return Err(MapError::OutputTooShort { needed: words, len: out.len() });
        };
        for (w, d) in dst.iter_mut().enumerate() {
            let first = 32 * w;
            let last = (first + 32).min(n);
            *d = (first..last).fold(0u32, |acc, k| acc | (u32::from(self.cells.is_occupied_at(k)) << (k - first)));
        }
        Ok((self.width, self.height))
    }

    /// Writes the planner's grid, `coarsen` times coarser, into `out`: `0.0` where any fine
    /// cell it covers is occupied, `f32::INFINITY` elsewhere (unknown counts as free: optimistic
    /// planning, the team re-plans as it sees more). Returns its `(width, height)`,
    /// `ceil(width / coarsen) x ceil(height / coarsen)`, row-major in `out[..width * height]`
    /// (the rest of `out` untouched): the input of `vt_plan::distance_transform`, with the same
    /// origin and resolution `coarsen * resolution_m` (the last column and row may reach past
    /// this grid; they count as free there). O(width x height).
    ///
    /// # Errors
    /// [`MapError::BadParams`] for `coarsen == 0`; [`MapError::EmptyGrid`] before `reset`;
    /// [`MapError::OutputTooShort`] when `out` is shorter than the coarse grid.
    pub fn write_planner_cells(
        &self,
        coarsen: usize,
        out: &mut [f32],
    ) -> Result<(usize, usize), MapError> {
        self.write_coarse(coarsen, out, 0.0, f32::INFINITY)
    }

    /// The planner's grid, `coarsen` times coarser, as `occupied` and `free` values.
    fn write_coarse<T: Copy>(
        &self,
        coarsen: usize,
        out: &mut [T],
        occupied: T,
        free: T,
    ) -> Result<(usize, usize), MapError> {
        if coarsen == 0 {
            return Err(MapError::BadParams { field: "coarsen" });
        }
        if self.width == 0 || self.height == 0 {
            return Err(MapError::EmptyGrid);
        }
        let (cw, ch) = (self.width.div_ceil(coarsen), self.height.div_ceil(coarsen));
        let needed = cw * ch;
        let Some(coarse) = out.get_mut(..needed) else {
            return Err(MapError::OutputTooShort {
                needed,
                len: out.len(),
            });
        };
        coarse.fill(free);
        for j in 0..self.height {
            for i in 0..self.width {
                if self.cells.is_occupied_at(j * self.width + i) {
                    if let Some(c) = coarse.get_mut((j / coarsen) * cw + i / coarsen) {
                        *c = occupied;
                    }
                }
            }
        }
        Ok((cw, ch))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Resolution of the test grids, m.
    const RES_M: f32 = 0.25;

    #[test]
    fn constructor_rejects_bad_geometry() {
        type G = OccupancyGrid<100>;
        let o = Vec2::new(0.0, 0.0);
        assert_eq!(
            G::new(11, 10, RES_M, o).err(),
            Some(MapError::TooManyCells {
                needed: 110,
                capacity: 100
            })
        );
        assert_eq!(
            G::new(usize::MAX, 2, RES_M, o).err(),
            Some(MapError::BadParams { field: "width" }),
            "above 2^24 columns"
        );
        assert_eq!(
            G::new(1 << 20, 1 << 20, RES_M, o).err(),
            Some(MapError::TooManyCells {
                needed: 1 << 40,
                capacity: 100
            })
        );
        assert_eq!(
            G::new(0, 10, RES_M, o).err(),
            Some(MapError::BadParams { field: "width" })
        );
        assert_eq!(
            G::new(10, 0, RES_M, o).err(),
            Some(MapError::BadParams { field: "height" })
        );
        for res in [0.0, -0.25, f32::NAN, f32::INFINITY] {
            assert_eq!(
                G::new(10, 10, res, o).err(),
                Some(MapError::BadParams {
                    field: "resolution_m"
                })
            );
        }
        assert_eq!(
            G::new(10, 10, 1e38, o).err(),
            Some(MapError::BadParams {
                field: "resolution_m"
            })
        );
        assert_eq!(
            G::new(10, 10, RES_M, Vec2::new(f32::NAN, 0.0)).err(),
            Some(MapError::BadParams { field: "origin_m" })
        );
        assert!(G::new(10, 10, RES_M, o).is_ok());
        assert!(G::new(100, 1, RES_M, o).is_ok());
    }

    #[test]
    fn failed_reset_leaves_the_grid_unchanged() {
        let mut g = OccupancyGrid::<100>::new(5, 4, RES_M, Vec2::new(1.0, 2.0)).unwrap();
        g.cells.0[3] = 20;
        assert!(g.reset(20, 20, RES_M, Vec2::new(0.0, 0.0)).is_err());
        assert_eq!((g.width(), g.height(), g.log_odds(3, 0)), (5, 4, Some(20)));
    }

    #[test]
    fn empty_grid_answers_nothing() {
        static EMPTY: OccupancyGrid<16> = OccupancyGrid::empty();
        assert_eq!(EMPTY.cell_of(Vec2::new(0.5, 0.5)), None);
        assert_eq!(EMPTY.log_odds(0, 0), None);
        assert!(EMPTY.cells().is_empty());
        let mut out = [0.0; 4];
        assert_eq!(
            EMPTY.write_planner_cells(1, &mut out),
            Err(MapError::EmptyGrid)
        );
    }

    #[test]
    fn cell_geometry_round_trips() {
        let g = OccupancyGrid::<1200>::new(40, 30, RES_M, Vec2::new(-3.0, 5.0)).unwrap();
        assert_eq!(g.cell_of(Vec2::new(-3.0, 5.0)), Some((0, 0)));
        assert_eq!(g.cell_of(Vec2::new(-2.74, 5.26)), Some((1, 1)));
        assert_eq!(
            g.cell_of(Vec2::new(7.0, 5.0)),
            None,
            "x = origin + width * res is outside"
        );
        assert_eq!(g.cell_of(Vec2::new(-3.01, 6.0)), None);
        assert_eq!(g.cell_of(Vec2::new(f32::NAN, 6.0)), None);
        for (i, j) in [(0, 0), (39, 29), (17, 4)] {
            let c = g.cell_center_m(i, j).unwrap();
            assert_eq!(g.cell_of(c), Some((i, j)));
        }
        assert_eq!(g.cell_center_m(40, 0), None);
        assert!(!g.is_occupied(40, 0) && !g.is_free(0, 30));
    }

    #[test]
    fn ram_is_the_cells_and_a_few_words() {
        let bytes = OccupancyGrid::<33_600>::ram_bytes();
        assert!((33_600..33_600 + 64).contains(&bytes), "{bytes}");
    }

    #[test]
    fn planner_bits_cross_their_words() {
        let mut g = OccupancyGrid::<210>::new(70, 3, RES_M, Vec2::new(0.0, 0.0)).unwrap();
        let occupied = [0usize, 31, 32, 63, 64, 69, 70, 139, 209];
        for &k in &occupied {
            g.cells.0[k] = 1;
        }
        g.cells.0[5] = -3; // free
        let mut bits = [0u32; 7];
        assert_eq!(g.write_planner_bits(&mut bits), Ok((70, 3)));
        for k in 0..210 {
            assert_eq!(bits[k / 32] >> (k % 32) & 1 == 1, occupied.contains(&k), "cell {k}");
        }
        assert_eq!(
            g.write_planner_bits(&mut bits[..6]),
            Err(MapError::OutputTooShort { needed: 7, len: 6 })
        );
    }

    #[test]
    fn planner_cells_fine_and_coarse() {
        let mut g = OccupancyGrid::<100>::new(5, 3, RES_M, Vec2::new(0.0, 0.0)).unwrap();
        let occupied = [(1, 0), (4, 2)];
        for &(i, j) in &occupied {
            g.cells.0[j * 5 + i] = 10;
        }
        g.cells.0[2] = -10; // free
        let mut out = [-1.0_f32; 16];
        assert_eq!(g.write_planner_cells(1, &mut out), Ok((5, 3)));
        for j in 0..3 {
            for i in 0..5 {
                let want = if occupied.contains(&(i, j)) {
                    0.0
                } else {
                    f32::INFINITY
                };
                assert_eq!(out[j * 5 + i], want, "({i}, {j})");
            }
        }
        assert_eq!(out[15], -1.0, "beyond the grid untouched");
        let mut bits = [u32::MAX; 2];
        assert_eq!(g.write_planner_bits(&mut bits), Ok((5, 3)));
        for (k, &f) in out.iter().take(15).enumerate() {
            assert_eq!(bits[0] >> k & 1 == 1, f == 0.0, "cell {k}");
        }
        assert_eq!(bits[0] >> 15, 0, "the last word cleared past the grid");
        assert_eq!(bits[1], u32::MAX, "beyond the last word untouched");
        assert!(g.write_planner_bits(&mut bits[..0]).is_err());
        let mut out = [-1.0_f32; 6];
        assert_eq!(g.write_planner_cells(2, &mut out), Ok((3, 2)));
        assert_eq!(
            out,
            [
                0.0,
                f32::INFINITY,
                f32::INFINITY,
                f32::INFINITY,
                f32::INFINITY,
                0.0
            ]
        );
        assert_eq!(
            g.write_planner_cells(2, &mut out[..5]),
            Err(MapError::OutputTooShort { needed: 6, len: 5 })
        );
        assert_eq!(
            g.write_planner_cells(0, &mut out),
            Err(MapError::BadParams { field: "coarsen" })
        );
        let mut one = [-1.0_f32; 1];
        assert_eq!(g.write_planner_cells(7, &mut one), Ok((1, 1)));
        assert_eq!(one, [0.0]);
    }
}
