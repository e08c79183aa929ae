use super::*;
use proptest::prelude::*;
use std::collections::BTreeMap;

/// Test grid columns.
const W: usize = 64;
/// Test grid rows.
const H: usize = 48;
/// Test grid cell side, m.
const RES_M: f32 = 0.25;
/// Sensor range of the test scans, m.
const MAX_RANGE_M: f32 = 7.0;
/// Distance from an edge or the arc within which a cell may go either way, cells (the
/// directions come by rotation in `f32`: 1e-5 rad at 30 cells is 3e-4 cells).
const TIE_CELLS: f64 = 5e-3;
/// Arc marking range of the tests, m.
const SPREAD_M: f32 = 3.0;

type Grid = crate::OccupancyGrid<{ W * H }>;

/// The tests' fold: arcs spread within `spread_m`, free space out to the sensor's range.
fn fold(spread_m: f32) -> SectorFold {
    SectorFold {
        spread_range_m: spread_m,
        free_range_m: MAX_RANGE_M,
    }
}

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

/// Where cell `(i, j)`'s centre lies with respect to sector `k`'s free space (the triangle of
/// the sensor and its edges at the free radius), in `f64`: `Some(true)` inside, `Some(false)`
/// outside, `None` within [`TIE_CELLS`] of its boundary.
fn in_free_sector(g: &Grid, s: &Scan, free_range_m: f32, k: usize, i: usize, j: usize) -> Option<bool> {
    let res = f64::from(RES_M);
    let o = g.origin_m();
    let a = ((f64::from(s.origin_m.x) - f64::from(o.x)) / res, (f64::from(s.origin_m.y) - f64::from(o.y)) / res);
    let radius = match s.usable_return(k)? {
        Return::Hit(r) if r < free_range_m => f64::from(r) / res - f64::from(HALF_DIAGONAL_CELLS),
        Return::Clear if s.max_range_m < free_range_m => f64::from(s.max_range_m) / res,
        _ => f64::from(free_range_m) / res,
    };
    if !(radius > 0.0) {
        return Some(false);
    }
    let width = f64::from(s.increment_rad).abs();
    let lo = f64::from(s.first_angle_rad) + k as f64 * f64::from(s.increment_rad) - width / 2.0;
    let corner = |ang: f64| (a.0 + radius * ang.cos(), a.1 + radius * ang.sin());
    let (p, q) = (corner(lo), corner(lo + width));
    let c = (i as f64 + 0.5, j as f64 + 0.5);
    // Signed distance of c to the left of each counter-clockwise edge.
    let side = |u: (f64, f64), v: (f64, f64)| {
        let e = (v.0 - u.0, v.1 - u.1);
        (e.0 * (c.1 - u.1) - e.1 * (c.0 - u.0)) / e.0.hypot(e.1)
    };
    let d = [side(a, p), side(p, q), side(q, a)];
    if d.iter().all(|&x| x > TIE_CELLS) {
        Some(true)
    } else if d.iter().any(|&x| x < -TIE_CELLS) {
        Some(false)
    } else {
        None
    }
}

/// For a scan into a fresh grid: every cell that holds no hit has `miss` times the number of
/// sectors whose free space holds its centre (cells within a tie of a boundary skipped).
fn check_free_space(g: &Grid, s: &Scan) -> Result<usize, TestCaseError> {
    check_free_space_to(g, s, MAX_RANGE_M)
}

/// [`check_free_space`] for a fold whose free space stops at `free_range_m`.
fn check_free_space_to(g: &Grid, s: &Scan, free_range_m: f32) -> Result<usize, TestCaseError> {
    let p = LogOddsParams::default();
    let mut checked = 0;
    for j in 0..H {
        for i in 0..W {
            let l = g.log_odds(i, j).unwrap();
            if l > 0 {
                continue;
            }
            let mut count = 0i32;
            let mut tie = false;
            for k in 0..s.returns.len() {
                match in_free_sector(g, s, free_range_m, k, i, j) {
                    Some(true) => count += 1,
                    Some(false) => {}
                    None => tie = true,
                }
            }
            if tie {
                continue;
            }
            let want = (count * i32::from(p.miss)).max(i32::from(p.min));
            prop_assert_eq!(i32::from(l), want, "cell ({}, {}): {} sectors", i, j, count);
            checked += 1;
        }
    }
    Ok(checked)
}

#[test]
fn a_clear_scan_frees_each_cell_of_its_disc_once() {
    let mut g = grid();
    let five = 5f32.to_radians();
    // 22 cells of range from near the grid's middle: the disc lies inside the grid.
    let s = Scan { max_range_m: 5.5, ..scan(Vec2::new(5.93, 2.87), 0.3, five, &[Return::Clear; MAX_BEAMS]) };
    let stats = g.integrate_sectors(&s, &LogOddsParams::default(), fold(SPREAD_M), |_, _| panic!("nothing is hit"));
    assert_eq!((stats.beams_used, stats.beams_skipped, stats.newly_occupied), (MAX_BEAMS, 0, 0));
    let checked = check_free_space(&g, &s).unwrap();
    assert!(checked > 2_000, "{checked}");
    // The disc is 22 cells in radius and the sectors' triangles tile it but for slivers at the
    // arc: the scan turns once, so its fan is filled as one polygon and every cell gets one
    // miss, those on the edges between sectors too.
    let r_cells = s.max_range_m / RES_M;
    let freed: Vec<i8> = g.cells().iter().copied().filter(|&l| l < 0).collect();
    let area = std::f32::consts::PI * r_cells * r_cells;
    assert!((freed.len() as f32 - area).abs() < 0.03 * area, "{} cells against {area}", freed.len());
    assert!(freed.iter().all(|&l| l == LogOddsParams::default().miss), "a cell freed twice");
    assert_eq!(stats.cells_updated, freed.len());
    // Sectors that overlap (two turns) are folded one by one: every cell twice.
    let mut g2 = grid();
    let twice = Scan { max_range_m: 5.5, ..scan(Vec2::new(5.93, 2.87), 0.3, 10f32.to_radians(), &[Return::Clear; MAX_BEAMS]) };
    g2.integrate_sectors(&twice, &LogOddsParams::default(), fold(SPREAD_M), |_, _| panic!("nothing is hit"));
    assert!(check_free_space(&g2, &twice).unwrap() > 2_000);
}

#[test]
fn hits_mark_the_arc_nearby_and_the_centre_far_off() {
    let p = LogOddsParams::default();
    let five = 5f32.to_radians();
    // Near: 2.5 m, 0.22 m of arc: one or two cells across it. Far: 6 m, beyond the spread.
    for (r, spread) in [(2.5f32, true), (6.0, false)] {
        let mut g = grid();
        let s = scan(Vec2::new(0.13, 0.21), 0.0, five, &[Return::Hit(r)]);
        let mut seen = Vec::new();
        let stats = g.integrate_sectors(&s, &p, fold(SPREAD_M), |i, j| seen.push((i, j)));
        let centre = g.cell_of(s.end_point_m(0).unwrap()).unwrap();
        assert!(seen.contains(&centre), "{seen:?} {centre:?}");
        assert_eq!(stats.newly_occupied, seen.len());
        if spread {
            assert!((1..=arc_points(five, r, RES_M, SPREAD_M)).contains(&seen.len()), "{seen:?}");
        } else {
            assert_eq!(seen, [centre]);
        }
        for &(i, j) in &seen {
            assert_eq!(g.log_odds(i, j), Some(p.hit));
            let c = g.cell_center_m(i, j).unwrap();
            assert!(((c - s.origin_m).norm() - r).abs() < 0.2, "hit cell ({i}, {j}) off the arc");
        }
        // Free space stops half a cell diagonal short of the hit.
        check_free_space(&g, &s).unwrap();
        let before = g.cell_of(s.origin_m + Vec2::new(r - 0.3, 0.0)).unwrap();
        assert!(g.is_free(before.0, before.1));
    }
}

#[test]
fn beams_stop_at_the_free_range_and_far_hits_are_dropped() {
    let p = LogOddsParams::default();
    let mut g = grid();
    let s = scan(Vec2::new(0.13, 0.21), 0.0, 5f32.to_radians(), &[Return::Hit(6.5), Return::Clear, Return::Hit(2.0)]);
    let cut = SectorFold { free_range_m: 3.0, ..fold(SPREAD_M) };
    let mut seen = Vec::new();
    g.integrate_sectors(&s, &p, cut, |i, j| seen.push((i, j)));
    assert!(seen.contains(&g.cell_of(s.end_point_m(2).unwrap()).unwrap()), "the near hit counts");
    assert!(!seen.contains(&g.cell_of(s.end_point_m(0).unwrap()).unwrap()), "the far one is dropped");
    check_free_space_to(&g, &s, 3.0).unwrap();
    let near = g.cell_of(s.origin_m + Vec2::new(2.8, 0.0)).unwrap();
    let beyond = g.cell_of(s.origin_m + Vec2::new(3.3, 0.0)).unwrap();
    assert!(g.is_free(near.0, near.1) && g.log_odds(beyond.0, beyond.1) == Some(0));
    // No free range, nothing.
    let mut g = grid();
    g.integrate_sectors(&s, &p, SectorFold { free_range_m: f32::NAN, ..fold(SPREAD_M) }, |_, _| panic!());
    assert!(g.cells().iter().all(|&l| l == 0));
}

#[test]
fn a_miss_never_erases_a_hit_of_the_same_scan() {
    let p = LogOddsParams::default();
    let mut g = grid();
    // Narrow sectors: the hit cell's centre lies in a clear neighbour's free space.
    let mut returns = [Return::Clear; 11];
    returns[5] = Return::Hit(2.0);
    let s = scan(Vec2::new(2.05, 4.07), -0.1, 0.02, &returns);
    let (hi, hj) = g.cell_of(s.end_point_m(5).unwrap()).unwrap();
    let freed_by = (0..11).filter(|&k| in_free_sector(&g, &s, MAX_RANGE_M, k, hi, hj) == Some(true)).count();
    assert!(freed_by >= 1, "the test needs a clear sector over the hit cell");
    g.integrate_sectors(&s, &p, fold(f32::NAN), |_, _| {});
    assert_eq!(g.log_odds(hi, hj), Some(p.hit));
    // A later clear scan is an ordinary miss, once per sector over it.
    let clear = scan(s.origin_m, -0.1, 0.02, &[Return::Clear; 11]);
    g.integrate_sectors(&clear, &p, fold(f32::NAN), |_, _| {});
    assert_eq!(i32::from(g.log_odds(hi, hj).unwrap()), i32::from(p.hit) + freed_by as i32 * i32::from(p.miss));
}

#[test]
fn rays_and_wide_sectors_fall_back_to_the_exact_rays() {
    let p = LogOddsParams::default();
    let returns = [Return::Hit(3.3), Return::Clear, Return::Hit(1.7)];
    for inc in [0.0f32, 1.6, -2.0] {
        let s = scan(Vec2::new(3.1, 2.2), 0.4, inc, &returns);
        let (mut a, mut b) = (grid(), grid());
        let sa = a.integrate_sectors(&s, &p, fold(SPREAD_M), |_, _| {});
        let sb = b.integrate(&s, &p, |_, _| {});
        assert_eq!(sa, sb);
        assert_eq!(a.cells(), b.cells(), "increment {inc}");
    }
}

#[test]
fn bad_input_is_skipped_and_far_sensors_touch_only_their_sectors() {
    let p = LogOddsParams::default();
    let good = [Return::Hit(2.0), Return::Clear];
    let mut g = grid();
    for s in [scan(Vec2::new(f32::NAN, 3.0), 0.0, 0.1, &good), scan(Vec2::new(3.0, 3.0), f32::INFINITY, 0.1, &good)] {
        let st = g.integrate_sectors(&s, &p, fold(SPREAD_M), |_, _| panic!());
        assert_eq!(st, IntegrateStats { beams_skipped: 2, ..Default::default() });
    }
    let inverted = LogOddsParams { hit: -3, ..Default::default() };
    let st = g.integrate_sectors(&scan(Vec2::new(3.0, 3.0), 0.0, 0.1, &good), &inverted, fold(SPREAD_M), |_, _| panic!());
    assert_eq!(st.beams_skipped, 2);
    assert!(g.cells().iter().all(|&l| l == 0));
    // Sensors far outside, and a NaN spread range (centres only).
    for o in [Vec2::new(-4.0, -5.0), Vec2::new(3.0, 1e6), Vec2::new(-1e20, 0.0), Vec2::new(1e30, -1e30)] {
        let mut g = grid();
        let s = scan(o, 0.2, 0.05, &[Return::Clear; 40]);
        g.integrate_sectors(&s, &p, fold(f32::NAN), |_, _| panic!());
        check_free_space(&g, &s).unwrap();
    }
    let mut empty = Grid::empty();
    let st = empty.integrate_sectors(&scan(Vec2::new(0.0, 0.0), 0.0, 0.1, &good), &p, fold(SPREAD_M), |_, _| panic!());
    assert_eq!((st.beams_used, st.cells_updated), (2, 0));
}

#[test]
fn sin_cos_falls_back_to_libm_beyond_the_reduction() {
    for x in [f32::MAX, -1e30, 1e5, 0.3] {
        let (s, c) = sin_cos(x);
        assert!(s.is_finite() && c.is_finite());
    }
}

#[test]
fn arc_points_are_a_cell_apart_within_the_spread_range() {
    let five = 5f32.to_radians();
    assert_eq!(arc_points(five, 1.0, 0.25, 6.0), 1);
    assert_eq!(arc_points(five, 2.0, 0.25, 6.0), 2);
    assert_eq!(arc_points(five, 5.9, 0.25, 6.0), 5);
    assert_eq!(arc_points(five, 6.1, 0.25, 6.0), 1);
    assert_eq!(arc_points(0.5, 6.0, 0.25, 6.0), MAX_ARC_POINTS);
    assert_eq!(arc_points(five, f32::NAN, 0.25, 6.0), 1);
    assert_eq!(arc_points(five, 3.0, 0.25, f32::NAN), 1);
}

proptest! {
    /// Scans that turn at most once (their fan is filled as one polygon), closing the circle or
    /// not, either way round, with unknown sectors and hits too close to free anything: the
    /// free space is the brute force's.
    #[test]
    fn the_fan_is_the_brute_force_sectors(
        x in -6.0f32..20.0, y in -7.0f32..12.0, first in -3.2f32..3.2, ccw in proptest::bool::ANY,
        closes in proptest::bool::ANY,
        ranges in proptest::collection::vec(prop_oneof![Just(-1.0f32), Just(0.0f32), 0.05f32..0.2, 0.05f32..MAX_RANGE_M], 6..=MAX_BEAMS),
    ) {
        let returns: Vec<Return> = ranges.iter().map(|&r| if r < 0.0 { Return::Unknown } else if r == 0.0 { Return::Clear } else { Return::Hit(r) }).collect();
        let turn = if closes { std::f32::consts::TAU } else { std::f32::consts::TAU * 0.7 };
        let inc = turn / returns.len() as f32 * if ccw { 1.0 } else { -1.0 };
        let mut g = grid();
        let s = scan(Vec2::new(x, y), first, inc, &returns);
        g.integrate_sectors(&s, &LogOddsParams::default(), fold(SPREAD_M), |_, _| {});
        check_free_space(&g, &s)?;
    }

    /// Any scan from anywhere (inside or outside the grid, either turning sense): the free
    /// space is the brute force's, every hit cell lies on its sector's arc, and the occupied
    /// count is the grid's.
    #[test]
    fn the_fold_is_the_brute_force_sectors(
        x in -6.0f32..20.0, y in -7.0f32..12.0, first in -3.2f32..3.2, inc in prop_oneof![-0.4f32..-0.01, 0.01f32..0.4],
        free_range_m in prop_oneof![Just(MAX_RANGE_M), 0.5f32..MAX_RANGE_M],
        ranges in proptest::collection::vec(prop_oneof![Just(-1.0f32), Just(0.0f32), 0.05f32..MAX_RANGE_M], 1..MAX_BEAMS),
    ) {
        let returns: Vec<Return> = ranges.iter().map(|&r| if r < 0.0 { Return::Unknown } else if r == 0.0 { Return::Clear } else { Return::Hit(r) }).collect();
        let mut g = grid();
        let s = scan(Vec2::new(x, y), first, inc, &returns);
        let mut seen = BTreeMap::new();
        let fold = SectorFold { free_range_m, ..fold(SPREAD_M) };
        let st = g.integrate_sectors(&s, &LogOddsParams::default(), fold, |i, j| *seen.entry((i, j)).or_insert(0) += 1);
        prop_assert_eq!(st.beams_used + st.beams_skipped, returns.len());
        check_free_space_to(&g, &s, free_range_m)?;
        let occupied: Vec<(usize, usize)> = (0..H).flat_map(|j| (0..W).map(move |i| (i, j))).filter(|&(i, j)| g.is_occupied(i, j)).collect();
        prop_assert_eq!(occupied.len(), g.occupied_count());
        prop_assert_eq!(occupied.len(), seen.len());
        for &(i, j) in &occupied {
            prop_assert_eq!(seen.get(&(i, j)), Some(&1));
            let c = g.cell_center_m(i, j).unwrap();
            let near_arc = (0..returns.len()).any(|k| match s.usable_return(k) {
                Some(Return::Hit(r)) if r < free_range_m => {
                    // Distance from the centre to the sector's arc, by sampling it finely.
                    let d = c - s.origin_m;
                    (0..=200).map(|u| {
                        let a = s.beam_angle_rad(k) + inc.abs() * (u as f32 / 200.0 - 0.5);
                        (d - Vec2::new(a.cos(), a.sin()) * r).norm()
                    }).fold(f32::INFINITY, f32::min) <= 0.71 * RES_M
                }
                _ => false,
            });
            prop_assert!(near_arc, "hit cell ({}, {}) on no arc", i, j);
        }
    }
}

