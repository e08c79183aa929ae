//! Whole scans of simple scenes, and the map feeding the planner's distance transform.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use vt_map::{LogOddsParams, OccupancyGrid, Return, Scan, Vec2, MAX_BEAMS};
use vt_plan::{distance_transform, ClearanceMap, GridMap};

/// Cell side, m.
const RES_M: f32 = 0.25;
/// Grid side, cells (16 m).
const SIDE: usize = 64;
/// Angle between the 72 beams, rad (5 degrees).
const INCREMENT_RAD: f32 = 2.0 * core::f32::consts::PI / MAX_BEAMS as f32;
/// Sensor range, m.
const MAX_RANGE_M: f32 = 10.0;

type Grid = OccupancyGrid<{ SIDE * SIDE }>;

/// A 72-beam scan from `origin` of the scene `range_of(direction) -> Option<hit range>`.
fn scan_of(origin: Vec2, first_rad: f32, range_of: impl Fn(Vec2) -> Option<f32>) -> Scan {
    let mut s = Scan::new(origin, first_rad, INCREMENT_RAD, MAX_RANGE_M);
    for k in 0..MAX_BEAMS {
        let r = range_of(s.beam_direction(k)).filter(|&r| r <= MAX_RANGE_M);
        s.returns
            .push(r.map_or(Return::Clear, Return::Hit))
            .unwrap();
    }
    s
}

/// Range along unit `u` from `o` to the circle `(c, radius)`, if the ray meets it.
fn circle_range(o: Vec2, u: Vec2, c: Vec2, radius: f32) -> Option<f32> {
    let m = (c - o).dot(&u);
    let disc = m * m - ((c - o).norm_squared() - radius * radius);
    (disc >= 0.0 && m - disc.sqrt() > 0.0).then(|| m - disc.sqrt())
}

#[test]
fn circle_scan_marks_only_cells_near_the_circle() {
    const RADIUS_M: f32 = 1.0;
    const DISTANCE_M: f32 = 5.0;
    let diagonal_m = RES_M * core::f32::consts::SQRT_2;
    let mut g = Grid::new(SIDE, SIDE, RES_M, Vec2::new(0.0, 0.0)).unwrap();
    let o = Vec2::new(4.1, 7.9);
    let c = o + Vec2::new(libm::cosf(0.3), libm::sinf(0.3)) * DISTANCE_M;
    let s = scan_of(o, 0.01, |u| circle_range(o, u, c, RADIUS_M));
    let hits = s
        .returns
        .iter()
        .filter(|r| matches!(r, Return::Hit(_)))
        .count();
    assert!(
        hits >= 3,
        "the circle subtends +-11.5 degrees: {hits} beams"
    );
    let mut new_cells = Vec::new();
    let stats = g.integrate(&s, &LogOddsParams::default(), |i, j| new_cells.push((i, j)));
    assert_eq!(stats.beams_used, MAX_BEAMS);
    assert_eq!(new_cells.len(), g.occupied_count());
    assert!(g.occupied_count() >= 2);
    for j in 0..SIDE {
        for i in 0..SIDE {
            let from_c = (g.cell_center_m(i, j).unwrap() - c).norm();
            if g.is_occupied(i, j) {
                assert!(
                    (from_c - RADIUS_M).abs() <= diagonal_m,
                    "({i}, {j}) is {from_c} m from the centre"
                );
            }
            if g.is_free(i, j) {
                assert!(
                    from_c >= RADIUS_M - diagonal_m,
                    "({i}, {j}) free inside the circle"
                );
            }
        }
    }
}

#[test]
fn wall_scan_feeds_the_distance_transform() {
    const WALL_Y_M: f32 = 6.1;
    const COARSEN: usize = 2;
    let mut g = Grid::new(SIDE, SIDE, RES_M, Vec2::new(0.0, 0.0)).unwrap();
    let o = Vec2::new(5.05, 2.0);
    let mut s = scan_of(o, 0.0, |u| (u.y > 0.0).then(|| (WALL_Y_M - o.y) / u.y));
    s.max_range_m = 4.5; // the wall is seen only within +-24 degrees of north
    for r in s.returns.iter_mut() {
        if matches!(r, Return::Hit(x) if *x > 4.5) {
            *r = Return::Clear;
        }
    }
    for _ in 0..3 {
        g.integrate(&s, &LogOddsParams::default(), |_, _| {});
    }
    let mut cells = [0.0_f32; SIDE * SIDE];
    let (w, h) = g.write_planner_cells(COARSEN, &mut cells).unwrap();
    assert_eq!((w, h), (SIDE / COARSEN, SIDE / COARSEN));
    let cells = &mut cells[..w * h];
    let n = w.max(h);
    let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
    distance_transform(cells, w, h, &mut line, &mut v, &mut z).unwrap();
    let map = GridMap {
        dist_cells: cells,
        width: w,
        height: h,
        resolution_m: RES_M * COARSEN as f32,
        origin_m: g.origin_m(),
    };
    // The wall's cells start at y = 6.0 m (the 0.5 m coarse row holding y = 6.1).
    let clearance = map.clearance_m(Vec2::new(5.05, 4.0));
    assert!((clearance - 2.0).abs() < 0.05, "{clearance}");
    // Far from the wall, to the south, only the wall bounds the clearance.
    let far = map.clearance_m(Vec2::new(5.05, 1.0));
    assert!((far - 5.0).abs() < 0.05, "{far}");
}
