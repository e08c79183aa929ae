//! Where a grid keeps its cells: one `i8` of log-odds per cell ([`Bytes`], any sensor model), or
//! four bits per cell ([`Nibbles`]) for a sensor model whose clamped hits and misses reach at
//! most 16 log-odds values from 0.
//!
//! # The 4-bit cell, exactly
//! From unknown (0), a cell only ever takes the values `hit` and `miss` reach through
//! [`LogOddsParams::apply`]: a finite set, closed under both. With the flight's model (hit +14,
//! miss -14, clamps -32 and +56) it has 14 values: -32, -28, -18, -14, -4, 0, 10, 14, 24, 28,
//! 38, 42, 52, 56. [`Nibbles`] numbers them (code 0 is the unknown 0) and stores the code, so the
//! map, and every scan folded into it, is bit for bit the byte map's at half its RAM
//! (`a_packed_map_is_the_byte_map` in the tests). A run of misses goes two cells a byte through
//! a 256-entry table. A scan with another model than the one the store was built for is not
//! folded (every beam skipped), never folded wrongly.

use crate::{lanes, LogOddsParams, MapError};

/// Most log-odds values a [`Nibbles`] store can hold (4 bits).
pub const MAX_STATES: usize = 16;

/// A grid's cell storage: log-odds in 1/16 nat, by row-major index.
pub trait CellStore {
    /// Cells it can hold.
    fn capacity(&self) -> usize;
    /// Log-odds of cell `idx`, 1/16 nat; `None` past the capacity.
    fn get(&self, idx: usize) -> Option<i8>;
    /// Sets cell `idx` (ignored past the capacity). `v` must be a value the store holds
    /// ([`CellStore::folds`]'s model reaches it); otherwise the nearest one is kept.
    fn set(&mut self, idx: usize, v: i8);
    /// `max(sat(c + miss), floor)` on `count` cells from `start` (clipped to the capacity).
    fn miss_run(&mut self, start: usize, count: usize, miss: i8, floor: i8);
    /// Whether cell `idx` is occupied (log-odds > 0); `false` past the capacity.
    fn is_occupied_at(&self, idx: usize) -> bool {
        self.get(idx).is_some_and(|l| l > 0)
    }
    /// Every cell unknown (0).
    fn clear(&mut self);
    /// Whether scans under `params` may be folded into it.
    fn folds(&self, params: &LogOddsParams) -> bool;
    /// Builds the store for `params` (forgetting every cell where the coding changes).
    ///
    /// # Errors
    /// [`MapError::BadParams`] for invalid params; [`MapError::TooManyStates`] when the
    /// store cannot hold every value `params` reach.
    fn adopt(&mut self, params: &LogOddsParams) -> Result<(), MapError>;
}

/// One `i8` per cell: any valid sensor model.
#[derive(Clone)]
pub struct Bytes<const CELLS: usize>(pub(crate) [i8; CELLS]);

impl<const CELLS: usize> CellStore for Bytes<CELLS> {
    fn capacity(&self) -> usize {
        CELLS
    }
    fn get(&self, idx: usize) -> Option<i8> {
        self.0.get(idx).copied()
    }
    fn set(&mut self, idx: usize, v: i8) {
        if let Some(c) = self.0.get_mut(idx) {
            *c = v;
        }
    }
    fn miss_run(&mut self, start: usize, count: usize, miss: i8, floor: i8) {
        let end = start.saturating_add(count).min(CELLS);
        if let Some(run) = self.0.get_mut(start.min(end)..end) {
            lanes::miss_run(run, miss, floor);
        }
    }
    fn clear(&mut self) {
        self.0.fill(0);
    }
    fn folds(&self, params: &LogOddsParams) -> bool {
        params.is_valid()
    }
    fn adopt(&mut self, params: &LogOddsParams) -> Result<(), MapError> {
        params.check()
    }
}

/// Four bits per cell, two cells a byte (cell `2k` in the low nibble of byte `k`): the values
/// one sensor model reaches (module doc), at most [`MAX_STATES`].
#[derive(Clone)]
pub struct Nibbles<const BYTES: usize> {
    /// The cells' codes.
    bytes: [u8; BYTES],
    /// The log-odds of each code, 1/16 nat (code 0 is 0).
    values: [i8; MAX_STATES],
    /// Codes in use (0: not built, only the unknown 0).
    states: u8,
    /// Bit `c` set when code `c` is occupied (log-odds > 0).
    occupied: u16,
    /// Code of each `i8` (index `v as u8`): its own, or the nearest value's.
    encode: [u8; 256],
    /// A byte's two codes after one miss each.
    miss_pair: [u8; 256],
    /// The model it was built for.
    params: LogOddsParams,
}

impl<const BYTES: usize> Nibbles<BYTES> {
    /// A store of all-zero bytes (every cell unknown, no model: no scan folds) for `.bss`.
    pub const fn zeroed() -> Self {
        Self {
            bytes: [0; BYTES],
            values: [0; MAX_STATES],
            states: 0,
            occupied: 0,
            encode: [0; 256],
            miss_pair: [0; 256],
            params: LogOddsParams { hit: 0, miss: 0, min: 0, max: 0 },
        }
    }

    /// Code of cell `idx`, if inside.
    fn code(&self, idx: usize) -> Option<u8> {
        self.bytes.get(idx / 2).map(|&b| if idx & 1 == 0 { b & 15 } else { b >> 4 })
    }

    /// Whether code `c` is occupied.
    pub(crate) fn code_is_occupied(&self, c: u8) -> bool {
        self.occupied >> (c & 15) & 1 == 1
    }

    /// Sets cell `idx`'s code.
    fn set_code(&mut self, idx: usize, c: u8) {
        if let Some(b) = self.bytes.get_mut(idx / 2) {
            *b = if idx & 1 == 0 { (*b & 0xf0) | (c & 15) } else { (*b & 15) | (c << 4) };
        }
    }

    /// The code after one miss of the built model.
    fn missed(&self, c: u8) -> u8 {
        self.miss_pair.get(usize::from(c & 15)).map_or(0, |&p| p & 15)
    }
}

impl<const BYTES: usize> CellStore for Nibbles<BYTES> {
    fn capacity(&self) -> usize {
        2 * BYTES
    }
    fn get(&self, idx: usize) -> Option<i8> {
        let c = self.code(idx)?;
        Some(self.values.get(usize::from(c)).copied().unwrap_or(0))
    }
    fn is_occupied_at(&self, idx: usize) -> bool {
        self.code(idx).is_some_and(|c| self.code_is_occupied(c))
    }
    fn set(&mut self, idx: usize, v: i8) {
        let c = self.encode.get(usize::from(v as u8)).copied().unwrap_or(0);
        self.set_code(idx, c);
    }
    fn miss_run(&mut self, start: usize, count: usize, miss: i8, floor: i8) {
        let end = start.saturating_add(count).min(2 * BYTES);
        let mut idx = start.min(end);
        if miss != self.params.miss || floor != self.params.min {
            // Another model's miss: cell by cell (never on the fold's path, which checks).
            while idx < end {
                if let Some(v) = self.get(idx) {
                    self.set(idx, lanes::miss_one(v, miss, floor));
                }
                idx += 1;
            }
            return;
        }
        if idx & 1 == 1 && idx < end {
            let c = self.code(idx).unwrap_or(0);
            self.set_code(idx, self.missed(c));
            idx += 1;
        }
        let pairs_end = idx + (end - idx) / 2 * 2;
        if let Some(run) = self.bytes.get_mut(idx / 2..pairs_end / 2) {
            for b in run {
                *b = self.miss_pair.get(usize::from(*b)).copied().unwrap_or(0);
            }
        }
        if pairs_end < end {
            let c = self.code(pairs_end).unwrap_or(0);
            self.set_code(pairs_end, self.missed(c));
        }
    }
    fn clear(&mut self) {
        self.bytes.fill(0);
    }
    fn folds(&self, params: &LogOddsParams) -> bool {
        self.states > 0 && *params == self.params
    }
    fn adopt(&mut self, params: &LogOddsParams) -> Result<(), MapError> {
        params.check()?;
        if self.folds(params) {
            return Ok(());
        }
        let (values, states) = reachable(params)?;
        self.values = values;
        self.states = states;
        self.params = *params;
        self.occupied = 0;
        let book = values.get(..usize::from(states)).unwrap_or(&[]);
        for (c, &v) in book.iter().enumerate() {
            if v > 0 {
                self.occupied |= 1 << c;
            }
        }
        for (k, e) in self.encode.iter_mut().enumerate() {
            let v = i16::from(k as u8 as i8);
            // The nearest value's code; on a tie, the lower code.
            let mut best = (i16::MAX, 0u8);
            for (c, &b) in book.iter().enumerate() {
                let d = (i16::from(b) - v).abs();
                if d < best.0 {
                    best = (d, c as u8);
                }
            }
            *e = best.1;
        }
        let mut missed = [0u8; MAX_STATES];
        for (m, &v) in missed.iter_mut().zip(book) {
            *m = self.encode.get(usize::from(params.apply(v, params.miss) as u8)).copied().unwrap_or(0);
        }
        for (k, p) in self.miss_pair.iter_mut().enumerate() {
            let lo = missed.get(k & 15).copied().unwrap_or(0);
            let hi = missed.get(k >> 4).copied().unwrap_or(0);
            *p = lo | hi << 4;
        }
        self.clear();
        Ok(())
    }
}

/// The log-odds values `params` reach from 0 by hits and misses, 0 first, and their count.
///
/// # Errors
/// [`MapError::TooManyStates`] past [`MAX_STATES`].
pub fn reachable(params: &LogOddsParams) -> Result<([i8; MAX_STATES], u8), MapError> {
    let mut values = [0i8; MAX_STATES];
    let mut n = 1usize;
    let mut k = 0usize;
    while k < n {
        let v = values.get(k).copied().unwrap_or(0);
        for next in [params.apply(v, params.hit), params.apply(v, params.miss)] {
            if values.get(..n).is_some_and(|seen| seen.contains(&next)) {
                continue;
            }
            match values.get_mut(n) {
                Some(slot) => *slot = next,
                None => return Err(MapError::TooManyStates { max: MAX_STATES }),
            }
            n += 1;
        }
        k += 1;
    }
    Ok((values, n as u8))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{OccupancyGrid, PackedOccupancyGrid, Return, Scan, SectorFold, Vec2, MAX_BEAMS};
    use proptest::prelude::*;

    /// Test grid columns (odd: rows start on either nibble).
    const W: usize = 61;
    /// Test grid rows.
    const H: usize = 47;
    /// Test grid cell side, m.
    const RES_M: f32 = 0.25;
    /// Sensor range of the test scans, m.
    const MAX_RANGE_M: f32 = 7.0;
    /// The flight's sensor model (the companion's: OctoMap's hit and clamps, a miss as strong as
    /// a hit).
    const FLIGHT: LogOddsParams = LogOddsParams { miss: -14, ..LogOddsParams::OCTOMAP };

    fn byte_grid() -> OccupancyGrid<{ W * H }> {
        OccupancyGrid::new(W, H, RES_M, Vec2::new(-2.0, -3.0)).unwrap()
    }

    fn packed_grid() -> PackedOccupancyGrid<{ (W * H).div_ceil(2) }> {
        let mut g = PackedOccupancyGrid::zeroed();
        g.adopt(&FLIGHT).unwrap();
        g.reset(W, H, RES_M, Vec2::new(-2.0, -3.0)).unwrap();
        g
    }

    /// A scan from `origin` of `returns` (range m, or clear when past the range).
    fn scan(origin: (f32, f32), first_rad: f32, inc_rad: f32, returns: &[f32]) -> Scan {
        let mut s = Scan::new(Vec2::new(origin.0, origin.1), first_rad, inc_rad, MAX_RANGE_M);
        for &r in returns {
            let ret = if r < MAX_RANGE_M { Return::Hit(r) } else { Return::Clear };
            s.returns.push(ret).unwrap();
        }
        s
    }

    #[test]
    fn the_flight_model_reaches_fourteen_values() {
        let (values, n) = reachable(&FLIGHT).unwrap();
        let mut got = values[..usize::from(n)].to_vec();
        assert_eq!(got[0], 0, "code 0 is the unknown cell");
        got.sort_unstable();
        assert_eq!(got, [-32, -28, -18, -14, -4, 0, 10, 14, 24, 28, 38, 42, 52, 56]);
        // Closed under a hit and a miss.
        for &v in &got {
            assert!(got.contains(&FLIGHT.apply(v, FLIGHT.hit)) && got.contains(&FLIGHT.apply(v, FLIGHT.miss)));
        }
    }

    #[test]
    fn a_model_of_more_than_sixteen_values_is_refused() {
        // OctoMap's own miss (-7) against its hit (+14) reaches every multiple of 7 in the clamps.
        assert_eq!(reachable(&LogOddsParams::OCTOMAP), Err(MapError::TooManyStates { max: MAX_STATES }));
        let mut g = PackedOccupancyGrid::<64>::zeroed();
        assert_eq!(g.adopt(&LogOddsParams::OCTOMAP), Err(MapError::TooManyStates { max: MAX_STATES }));
        let bad = LogOddsParams { hit: -3, ..FLIGHT };
        assert!(matches!(g.adopt(&bad), Err(MapError::BadParams { .. })));
    }

    #[test]
    fn a_packed_grid_folds_only_its_own_model() {
        let s = scan((3.0, 2.0), 0.1, 0.2, &[2.5, 3.0, 9.0, 4.0]);
        let fold = SectorFold { spread_range_m: 3.0, free_range_m: MAX_RANGE_M };
        // Before a model: nothing folds, every beam is skipped.
        let mut g = PackedOccupancyGrid::<{ (W * H).div_ceil(2) }>::zeroed();
        g.reset(W, H, RES_M, Vec2::new(-2.0, -3.0)).unwrap();
        let stats = g.integrate_sectors(&s, &FLIGHT, fold, |_, _| panic!("not folded"));
        assert_eq!((stats.beams_skipped, stats.cells_updated), (4, 0));
        // Another (valid) model than its own: skipped too, the map untouched.
        let mut g = packed_grid();
        let stats = g.integrate(&s, &LogOddsParams::OCTOMAP, |_, _| panic!("not folded"));
        assert_eq!((stats.beams_skipped, stats.cells_updated), (4, 0));
        assert_eq!(g.occupied_count(), 0);
        assert!((0..H).all(|j| (0..W).all(|i| g.log_odds(i, j) == Some(0))));
        // Its own: folded.
        let stats = g.integrate_sectors(&s, &FLIGHT, fold, |_, _| {});
        assert_eq!(stats.beams_skipped, 0);
        assert!(g.occupied_count() > 0);
    }

    #[test]
    fn a_miss_run_is_a_miss_on_each_cell_from_either_nibble() {
        let mut bytes = Bytes([0i8; 40]);
        let mut nibbles = Nibbles::<20>::zeroed();
        nibbles.adopt(&FLIGHT).unwrap();
        let (values, n) = reachable(&FLIGHT).unwrap();
        let book = &values[..usize::from(n)];
        let mut k = 0usize;
        for start in 0..9 {
            for count in 0..9 {
                // Every cell some reachable value, then the same run on both.
                for idx in 0..40 {
                    let v = book[(idx * 7 + k) % book.len()];
                    bytes.set(idx, v);
                    nibbles.set(idx, v);
                }
                k += 1;
                bytes.miss_run(start, count, FLIGHT.miss, FLIGHT.min);
                nibbles.miss_run(start, count, FLIGHT.miss, FLIGHT.min);
                for idx in 0..40 {
                    assert_eq!(nibbles.get(idx), bytes.get(idx), "start {start} count {count} cell {idx}");
                }
            }
        }
        // A run past the capacity is clipped, as the bytes' is.
        bytes.miss_run(35, 100, FLIGHT.miss, FLIGHT.min);
        nibbles.miss_run(35, 100, FLIGHT.miss, FLIGHT.min);
        assert!((0..40).all(|idx| nibbles.get(idx) == bytes.get(idx)));
        assert_eq!((nibbles.get(40), nibbles.is_occupied_at(40)), (None, false));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The same scans, ray by ray and by sectors, into a byte grid and a packed grid: the
        /// same log-odds in every cell, the same stats, the same newly occupied cells.
        #[test]
        fn a_packed_map_is_the_byte_map(
            scans in prop::collection::vec(
                (
                    (-1.0f32..13.0, -2.0f32..10.0),
                    -3.2f32..3.2,
                    0.05f32..0.3,
                    prop::collection::vec(0.3f32..9.0, 1..MAX_BEAMS),
                    any::<bool>(),
                ),
                1..24,
            ),
        ) {
            let mut bytes = byte_grid();
            let mut packed = packed_grid();
            let fold = SectorFold { spread_range_m: 3.0, free_range_m: MAX_RANGE_M };
            for (origin, first, inc, returns, sectors) in &scans {
                let s = scan(*origin, *first, *inc, returns);
                let (mut seen_b, mut seen_p) = (Vec::new(), Vec::new());
                let (sb, sp) = if *sectors {
                    (
                        bytes.integrate_sectors(&s, &FLIGHT, fold, |i, j| seen_b.push((i, j))),
                        packed.integrate_sectors(&s, &FLIGHT, fold, |i, j| seen_p.push((i, j))),
                    )
                } else {
                    (
                        bytes.integrate(&s, &FLIGHT, |i, j| seen_b.push((i, j))),
                        packed.integrate(&s, &FLIGHT, |i, j| seen_p.push((i, j))),
                    )
                };
                prop_assert_eq!(sb, sp);
                prop_assert_eq!(seen_b, seen_p);
            }
            for j in 0..H {
                for i in 0..W {
                    prop_assert_eq!(packed.log_odds(i, j), bytes.log_odds(i, j), "cell ({}, {})", i, j);
                    prop_assert_eq!(packed.is_occupied(i, j), bytes.is_occupied(i, j));
                }
            }
            prop_assert_eq!(packed.occupied_count(), bytes.occupied_count());
            let words = (W * H).div_ceil(32);
            let (mut bits_b, mut bits_p) = (vec![0u32; words], vec![0u32; words]);
            prop_assert_eq!(bytes.write_planner_bits(&mut bits_b), packed.write_planner_bits(&mut bits_p));
            prop_assert_eq!(bits_b, bits_p);
        }
    }
}
