//! Folding a range scan into the grid: each beam frees the cells it crosses and occupies the
//! cell where it hit (inverse sensor model of Hornung et al. 2013, section 3.1).

use crate::store::CellStore;
use crate::{ray, LogOddsGrid, LogOddsParams, Return, Scan, Vec2, MAX_BEAMS};

/// Words of the hit-cell filter in [`LogOddsGrid::integrate`] (32 x 32 = 1,024 bits).
const HIT_FILTER_WORDS: usize = 32;

/// What one [`LogOddsGrid::integrate`] call did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IntegrateStats {
    /// Beams with a usable return (a valid `Hit` or `Clear`), whether or not they reached the grid.
    pub beams_used: usize,
    /// Beams ignored: `Unknown`, a NaN, infinite, non-positive or beyond-range `Hit`, or every
    /// beam of a scan with invalid geometry or of a call with invalid [`LogOddsParams`].
    pub beams_skipped: usize,
    /// Cell updates applied (a hit or a miss; one cell may be updated by several beams).
    pub cells_updated: usize,
    /// Cells that went from not occupied to occupied (`on_new_occupied` calls).
    pub newly_occupied: usize,
}

/// One usable beam in grid coordinates.
#[derive(Clone, Copy)]
struct BeamRay {
    /// Sensor, cells.
    a: Vec2,
    /// End of the ray (hit point or max range), cells.
    b: Vec2,
    /// For a hit, the cell holding the hit point when inside the grid.
    hit_cell: Option<(usize, usize)>,
}

impl<S: CellStore> LogOddsGrid<S> {
    /// Folds one scan into the grid; `on_new_occupied(i, j)` is called each time a cell goes
    /// from not occupied (log-odds <= 0) to occupied (> 0), so the caller can test newly seen
    /// obstacles against its tube.
    ///
    /// Per beam, along its ray from the sensor (walked exactly, [`crate::ray::traverse`]):
    /// - `Hit(r)`, `r` finite in `(0, max_range_m]`: every cell crossed before the one holding
    ///   the hit point gets `params.miss`, that cell gets `params.hit`;
    /// - `Clear`: every cell crossed out to `max_range_m` gets `params.miss`;
    /// - anything else: skipped, nothing touched.
    ///
    /// Only cells inside the grid are touched (a sensor outside it, or a ray leaving it, is
    /// clipped; far beyond ~10^6 cells from the grid, `f32` makes the walk approximate but it
    /// stays inside and bounded). The hit cell is found in grid coordinates, so on a cell edge
    /// it may differ from [`LogOddsGrid::cell_of`] of [`Scan::end_point_m`] by rounding. Each beam updates a cell at most once. No beam's miss touches a cell that holds
    /// a hit of the same scan (OctoMap's rule: occupied wins within a scan), so a ray grazing the
    /// corner of a neighbour's hit cell does not erase it; every usable hit still adds `hit`,
    /// so a cell hit by three beams gets three. Invalid `params` or scan geometry
    /// ([`Scan::is_geometry_valid`]) skip the whole scan.
    ///
    /// Cost: per beam at most `|dx| + |dy| + 3` cells (`dx, dy`: the ray's extent in cells,
    /// so `<= 1.42 R / resolution + 3` for range `R`) and at most `width + height - 1`; per cell
    /// a saturating add, a bit test and, when the bit is set, a binary search among the scan's
    /// <= 72 hit cells.
    pub fn integrate(
        &mut self,
        scan: &Scan,
        params: &LogOddsParams,
        mut on_new_occupied: impl FnMut(usize, usize),
    ) -> IntegrateStats {
        let mut stats = IntegrateStats::default();
        let beams = scan.returns.len();
        if !self.cells.folds(params) || !scan.is_geometry_valid() {
            stats.beams_skipped = beams;
            return stats;
        }
        // Each beam's ray, once (a sine and a cosine each: hundreds of instructions on the
        // Cortex-M4), and the scan's hit cells, sorted: misses never touch them.
        let mut rays: [Option<BeamRay>; MAX_BEAMS] = [None; MAX_BEAMS];
        for (k, slot) in rays.iter_mut().enumerate().take(beams) {
            *slot = self.beam_in_grid(scan, k);
        }
        let mut hit_cells: heapless::Vec<usize, MAX_BEAMS> = heapless::Vec::new();
        for ray in rays.iter().take(beams) {
            if let Some(BeamRay {
                hit_cell: Some((i, j)),
                ..
            }) = *ray
            {
                if let Some(idx) = self.index(i, j) {
                    // Cannot fail: at most one per beam, and a scan holds at most MAX_BEAMS.
                    let _ = hit_cells.push(idx);
                }
            }
        }
        hit_cells.sort_unstable();
        // A 1,024-bit filter of the hit cells (index mod 1,024): a cell whose bit is clear is
        // not a hit cell, and most cells are not, so the binary search runs only on a set bit.
        let mut filter = [0u32; HIT_FILTER_WORDS];
        for &idx in &hit_cells {
            if let Some(w) = filter.get_mut((idx >> 5) % HIT_FILTER_WORDS) {
                *w |= 1 << (idx & 31);
            }
        }
        let may_be_hit = |idx: usize| filter.get((idx >> 5) % HIT_FILTER_WORDS).is_some_and(|w| w & (1 << (idx & 31)) != 0);
        for ray in rays.iter().take(beams) {
            let Some(BeamRay {
                a,
                b,
                hit_cell: own_hit,
            }) = *ray
            else {
                stats.beams_skipped += 1;
                continue;
            };
            stats.beams_used += 1;
            let width = self.width;
            ray::traverse(a, b, self.width, self.height, |i, j| {
                if Some((i, j)) == own_hit {
                    return false;
                }
                let idx = j * width + i;
                if !may_be_hit(idx) || hit_cells.binary_search(&idx).is_err() {
                    self.update(i, j, params.miss, params, &mut stats, &mut on_new_occupied);
                }
                true
            });
            if let Some((i, j)) = own_hit {
                self.update(i, j, params.hit, params, &mut stats, &mut on_new_occupied);
            }
        }
        stats
    }

    /// Beam `k`'s ray in grid coordinates; `None` when the beam is not usable.
    fn beam_in_grid(&self, scan: &Scan, k: usize) -> Option<BeamRay> {
        let (range_m, is_hit) = match scan.usable_return(k)? {
            Return::Hit(r) => (r, true),
            Return::Clear | Return::Unknown => (scan.max_range_m, false),
        };
        let a = self.to_grid(scan.origin_m);
        let b = a + scan.beam_direction(k) * (range_m / self.resolution_m);
        let hit_cell = if is_hit {
            ray::cell_at(b, self.width, self.height)
        } else {
            None
        };
        Some(BeamRay { a, b, hit_cell })
    }

    /// Adds `delta` to cell `(i, j)` (saturating, clamped), reporting a new occupied cell.
    pub(crate) fn update(
        &mut self,
        i: usize,
        j: usize,
        delta: i8,
        params: &LogOddsParams,
        stats: &mut IntegrateStats,
        on_new_occupied: &mut impl FnMut(usize, usize),
    ) {
        let Some(idx) = self.index(i, j) else {
            return;
        };
        let Some(old) = self.cells.get(idx) else {
            return;
        };
        let new = params.apply(old, delta);
        self.cells.set(idx, new);
        stats.cells_updated += 1;
        if old <= 0 && new > 0 {
            stats.newly_occupied += 1;
            on_new_occupied(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brute_force::{cells_crossed, core_is_crossed, sampled_cells};
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    /// Test grid: columns, rows, capacity.
    const W: usize = 60;
    /// Test grid rows.
    const H: usize = 48;
    /// Test grid cell side, m.
    const RES_M: f32 = 0.25;
    /// Depth below which a near-tie may go either way in `f32`, cells.
    const TIE_CELLS: f64 = 1e-3;
    /// Sensor range of the test scans, m.
    const MAX_RANGE_M: f32 = 8.0;

    type Grid = crate::OccupancyGrid<{ W * H }>;

    fn grid() -> Grid {
        Grid::new(W, H, RES_M, Vec2::new(-2.0, -3.0)).unwrap()
    }

    fn scan(origin_m: Vec2, first_rad: f32, inc_rad: f32, returns: &[Return]) -> Scan {
        let mut s = Scan::new(origin_m, first_rad, inc_rad, MAX_RANGE_M);
        for r in returns {
            s.returns.push(*r).unwrap();
        }
        s
    }

    /// Cells whose log-odds are not 0, with their values.
    fn touched(g: &Grid) -> Vec<((usize, usize), i8)> {
        g.cells()
            .iter()
            .enumerate()
            .filter(|(_, &l)| l != 0)
            .map(|(k, &l)| ((k % W, k / W), l))
            .collect()
    }

    /// Beam `k`'s ray in grid coordinates, in f64 from the scan's f32 numbers.
    fn ray64(g: &Grid, s: &Scan, k: usize) -> ((f64, f64), (f64, f64)) {
        let o = g.origin_m();
        let res = f64::from(RES_M);
        let a = (
            (f64::from(s.origin_m.x) - f64::from(o.x)) / res,
            (f64::from(s.origin_m.y) - f64::from(o.y)) / res,
        );
        let r = match s.returns[k] {
            Return::Hit(r) => f64::from(r),
            _ => f64::from(s.max_range_m),
        };
        let ang = f64::from(s.first_angle_rad) + k as f64 * f64::from(s.increment_rad);
        (a, (a.0 + ang.cos() * r / res, a.1 + ang.sin() * r / res))
    }

    #[test]
    fn single_hit_marks_the_sampled_cells() {
        let mut g = grid();
        let s = scan(Vec2::new(1.13, 2.71), 0.37, 0.0, &[Return::Hit(4.3)]);
        let stats = g.integrate(&s, &LogOddsParams::default(), |_, _| {});
        let (a, b) = ray64(&g, &s, 0);
        let want = sampled_cells(a, b, W, H, 200_000);
        let got = touched(&g);
        assert_eq!(got.iter().map(|&(c, _)| c).collect::<BTreeSet<_>>(), want);
        let hit_cell = g.cell_of(s.end_point_m(0).unwrap()).unwrap();
        for &(c, l) in &got {
            assert_eq!(l, if c == hit_cell { 14 } else { -7 }, "{c:?}");
        }
        assert_eq!(
            stats,
            IntegrateStats {
                beams_used: 1,
                beams_skipped: 0,
                cells_updated: want.len(),
                newly_occupied: 1
            }
        );
        assert_eq!(g.occupied_count(), 1);
    }

    #[test]
    fn clear_beam_frees_out_to_max_range() {
        let mut g = grid();
        let s = scan(Vec2::new(0.61, 0.93), 0.45, 0.0, &[Return::Clear]);
        g.integrate(&s, &LogOddsParams::default(), |_, _| {
            panic!("a clear beam occupies nothing")
        });
        let (a, b) = ray64(&g, &s, 0);
        let got: BTreeSet<_> = touched(&g)
            .iter()
            .map(|&(c, l)| (assert_eq!(l, -7), c).1)
            .collect();
        assert_eq!(got, sampled_cells(a, b, W, H, 200_000));
        assert!(g.is_free(
            g.cell_of(s.end_point_m(0).unwrap()).unwrap().0,
            g.cell_of(s.end_point_m(0).unwrap()).unwrap().1
        ));
        assert_eq!(g.occupied_count(), 0);
    }

    #[test]
    fn unusable_returns_touch_nothing() {
        let mut g = grid();
        let bad = [
            Return::Unknown,
            Return::Hit(f32::NAN),
            Return::Hit(-1.0),
            Return::Hit(f32::INFINITY),
            Return::Hit(f32::NEG_INFINITY),
            Return::Hit(0.0),
            Return::Hit(MAX_RANGE_M + 0.1),
        ];
        let s = scan(Vec2::new(3.0, 3.0), 0.0, 0.5, &bad);
        let stats = g.integrate(&s, &LogOddsParams::default(), |_, _| panic!());
        assert_eq!(
            stats,
            IntegrateStats {
                beams_skipped: bad.len(),
                ..Default::default()
            }
        );
        // A usable scan with invalid geometry or params is skipped whole.
        let good = [Return::Hit(2.0), Return::Clear];
        for s in [
            scan(Vec2::new(f32::NAN, 3.0), 0.0, 0.5, &good),
            scan(Vec2::new(3.0, 3.0), 0.0, f32::INFINITY, &good),
        ] {
            let stats = g.integrate(&s, &LogOddsParams::default(), |_, _| panic!());
            assert_eq!(
                stats,
                IntegrateStats {
                    beams_skipped: 2,
                    ..Default::default()
                }
            );
        }
        let inverted = LogOddsParams {
            hit: -3,
            ..Default::default()
        };
        let stats = g.integrate(
            &scan(Vec2::new(3.0, 3.0), 0.0, 0.5, &good),
            &inverted,
            |_, _| panic!(),
        );
        assert_eq!(stats.beams_skipped, 2);
        assert!(touched(&g).is_empty());
        // An empty grid uses the beams and touches nothing.
        let mut empty = Grid::empty();
        let stats = empty.integrate(
            &scan(Vec2::new(0.0, 0.0), 0.0, 0.5, &good),
            &LogOddsParams::default(),
            |_, _| panic!(),
        );
        assert_eq!((stats.beams_used, stats.cells_updated), (2, 0));
    }

    #[test]
    fn rays_from_outside_touch_only_crossed_cells() {
        let five_deg = 5f32.to_radians();
        for origin in [
            Vec2::new(-6.0, -7.0),
            Vec2::new(14.5, 2.0),
            Vec2::new(3.0, 1e6),
            Vec2::new(-1e20, 0.0),
        ] {
            let mut g = grid();
            let returns: Vec<Return> = (0..MAX_BEAMS)
                .map(|k| {
                    if k % 2 == 0 {
                        Return::Clear
                    } else {
                        Return::Hit(7.9)
                    }
                })
                .collect();
            let s = scan(origin, 0.01, five_deg, &returns);
            let stats = g.integrate(&s, &LogOddsParams::default(), |_, _| {});
            let mut allowed = BTreeSet::new();
            for k in 0..MAX_BEAMS {
                let (a, b) = ray64(&g, &s, k);
                allowed.extend(cells_crossed(a, b, W, H));
            }
            let got = touched(&g);
            assert!(got.iter().all(|(c, _)| allowed.contains(c)), "{origin:?}");
            assert_eq!(stats.beams_used, MAX_BEAMS);
            assert!(stats.cells_updated >= got.len());
        }
    }

    #[test]
    fn clamping_saturates_and_lets_an_occupied_cell_clear() {
        let mut g = grid();
        let p = LogOddsParams::default();
        let o = Vec2::new(0.1, 0.1);
        let hit = scan(o, 0.2, 0.0, &[Return::Hit(3.0)]);
        for _ in 0..20 {
            g.integrate(&hit, &p, |_, _| {});
        }
        let (hi, hj) = g.cell_of(hit.end_point_m(0).unwrap()).unwrap();
        let (si, sj) = g.cell_of(o).unwrap();
        assert_eq!(
            (g.log_odds(hi, hj), g.log_odds(si, sj)),
            (Some(p.max), Some(p.min))
        );
        // The obstacle leaves: the beam now sees through. 8 misses from +56 reach 0 (unknown),
        // the 9th makes the cell free.
        let clear = scan(o, 0.2, 0.0, &[Return::Clear]);
        for n in 1..=9 {
            g.integrate(&clear, &p, |_, _| {});
            assert_eq!(g.is_occupied(hi, hj), n < 8, "after {n} misses");
        }
        assert!(g.is_free(hi, hj));
        assert_eq!(g.occupied_count(), 0);
    }

    #[test]
    fn new_occupied_fires_once_per_cell_and_hits_survive_grazing_misses() {
        let mut g = grid();
        let p = LogOddsParams::default();
        // A wall 3 m east of the sensor, 9 beams across it, plus clear beams around them that
        // cross cells next to the hits.
        let o = Vec2::new(2.05, 4.07);
        let mut returns = Vec::new();
        for k in 0..9 {
            let ang = -0.4 + 0.1 * k as f32;
            returns.push(Return::Hit(3.0 / libm::cosf(ang)));
        }
        let s = scan(o, -0.4, 0.1, &returns);
        let mut calls = Vec::new();
        let stats = g.integrate(&s, &p, |i, j| calls.push((i, j)));
        let occupied: BTreeSet<_> = touched(&g)
            .into_iter()
            .filter(|&(_, l)| l > 0)
            .map(|(c, _)| c)
            .collect();
        assert_eq!(calls.iter().copied().collect::<BTreeSet<_>>(), occupied);
        assert_eq!(
            (calls.len(), stats.newly_occupied, g.occupied_count()),
            (occupied.len(), occupied.len(), occupied.len())
        );
        assert!(occupied.len() >= 5);
        let mut again = 0;
        g.integrate(&s, &p, |_, _| again += 1);
        assert_eq!(again, 0, "already occupied cells are not new");
    }

    #[test]
    fn a_miss_never_erases_a_hit_of_the_same_scan() {
        let mut g = grid();
        let p = LogOddsParams::default();
        let o = Vec2::new(2.05, 4.07);
        // Beam 0 hits 3 m east; beam 1, in the same direction, sees through (a grazing ray).
        let s = scan(o, 0.0, 0.0, &[Return::Hit(3.0), Return::Clear]);
        g.integrate(&s, &p, |_, _| {});
        let (hi, hj) = g.cell_of(s.end_point_m(0).unwrap()).unwrap();
        let (si, sj) = g.cell_of(o).unwrap();
        assert_eq!(
            g.log_odds(hi, hj),
            Some(p.hit),
            "the clear beam skips the hit cell"
        );
        assert_eq!(
            g.log_odds(si, sj),
            Some(2 * p.miss),
            "both beams free the sensor's cell"
        );
        assert_eq!(
            g.log_odds(hi + 1, hj),
            Some(p.miss),
            "beyond the hit only the clear beam"
        );
        // From another scan the same clear beam is an ordinary miss.
        g.integrate(&scan(o, 0.0, 0.0, &[Return::Clear]), &p, |_, _| {});
        assert_eq!(g.log_odds(hi, hj), Some(p.hit + p.miss));
    }

    proptest! {
        /// One hit beam from anywhere (inside or outside the grid): the cells touched are the
        /// brute-force set (near-ties aside, `TIE_CELLS`), all free but the hit cell.
        #[test]
        fn hit_beam_touches_the_brute_force_cells(x in -6.0f32..18.0, y in -7.0f32..13.0, ang in -3.2f32..3.2, r in 0.01f32..MAX_RANGE_M) {
            let mut g = grid();
            let s = scan(Vec2::new(x, y), ang, 0.0, &[Return::Hit(r)]);
            g.integrate(&s, &LogOddsParams::default(), |_, _| {});
            let (a, b) = ray64(&g, &s, 0);
            let got = touched(&g);
            let got_set: BTreeSet<_> = got.iter().map(|&(c, _)| c).collect();
            let want = cells_crossed(a, b, W, H);
            for &(i, j) in got_set.symmetric_difference(&want) {
                prop_assert!(!core_is_crossed(a, b, i, j, TIE_CELLS), "({i}, {j}): got {got_set:?} want {want:?}");
            }
            let hits: Vec<_> = got.iter().filter(|&&(_, l)| l > 0).map(|&(c, _)| c).collect();
            prop_assert!(got.iter().all(|&(_, l)| l == 14 || l == -7));
            prop_assert!(hits.len() <= 1);
            let end = (b.0.floor(), b.1.floor());
            let end_clear = (b.0 - end.0).min(end.0 + 1.0 - b.0) > TIE_CELLS && (b.1 - end.1).min(end.1 + 1.0 - b.1) > TIE_CELLS;
            if end_clear && end.0 >= 0.0 && end.1 >= 0.0 && end.0 < W as f64 && end.1 < H as f64 {
                prop_assert_eq!(hits, vec![(end.0 as usize, end.1 as usize)]);
            } else if end_clear {
                prop_assert!(hits.is_empty());
            }
        }
    }
}
