//! Tests of the lattice searches and their work space (`search.rs`).

use super::*;
use crate::{Obstacle, ObstacleMap};

/// A wall across a 20 x 10 m map from its south edge, with a gap at its north end.
const WALL: [Obstacle<'static>; 1] = [Obstacle::Wall { a_m: Vec2::new(10.0, -1.0), b_m: Vec2::new(10.0, 8.5), thickness_m: 0.2 }];

fn wall_map() -> ObstacleMap<'static> {
    ObstacleMap { min_m: Vec2::new(0.0, 0.0), max_m: Vec2::new(20.0, 10.0), obstacles: &WALL }
}

fn rule(need: f32) -> RadiusRule {
    RadiusRule { margin_m: 0.0, max_radius_m: 5.0, need_m: need, clearance_weight: 0.5 }
}

#[test]
fn lattice_coarsens_to_capacity_and_finds_cells() {
    let l = Lattice::covering(Vec2::zeros(), Vec2::new(10.0, 5.0), 0.5, 1000).unwrap();
    assert_eq!((l.nx, l.ny), (21, 11));
    let c = Lattice::covering(Vec2::zeros(), Vec2::new(10.0, 5.0), 0.1, 1000).unwrap();
    assert!(c.len() <= 1000 && c.spacing_m > 0.2);
    let a = l.around(Vec2::new(1.1, 0.4));
    assert_eq!(a[0], Some(2 + 21)); // (1.0, 0.5)
    assert!(a.iter().all(Option::is_some));
}

#[test]
fn astar_goes_around_a_wall_and_maximin_finds_the_gap() {
    // A wall across x = 10 ending at y = 8.6; the map is 20 x 10, so the gap above the end
    // has 1.4 m of clearance.
    let map = wall_map();
    let lat = Lattice::covering(map.min_m, map.max_m, 0.25, 4096).unwrap();
    let (mut f, mut u, mut s) = (vec![0.0; 3 * 4096], vec![0; 2 * 4096], vec![0; 2048]);
    let mut ws: Workspace<'_, u32> = Workspace::new(&mut f, &mut u, &mut s);
    let from = lat.around(Vec2::new(2.0, 2.0))[0].unwrap();
    let to = lat.around(Vec2::new(18.0, 2.0))[0].unwrap();
    assert!(astar(&map, &lat, &rule(0.5), &mut ws, from, to).unwrap());
    // The path passes above the wall's end.
    let mut k = to;
    let mut top = f32::MIN;
    while let Some(p) = ws.parent(&lat, k) {
        top = top.max(lat.point_m(k).y);
        k = p;
    }
    assert_eq!(k, from);
    assert!(top > 8.6);
    // A need wider than the gap is refused, and the widest path's narrowest node is the gap.
    assert!(!astar(&map, &lat, &rule(1.5), &mut ws, from, to).unwrap());
    let (k, r) = narrowest_passage(&map, &lat, &rule(1.5), &mut ws, from, to).unwrap();
    let p = lat.point_m(k);
    assert!((p.x - 10.0).abs() <= 0.5 && p.y > 8.6, "{p:?}");
    assert!(r > 1.1 && r <= 1.4, "{r}");
}

/// The flood fill answers as the search does, at every need from a pass through the gap to
/// none, and between nodes walled off from each other.
#[test]
fn the_flood_fill_reaches_what_the_search_reaches() {
    let obs = [
        Obstacle::Wall { a_m: Vec2::new(10.0, -1.0), b_m: Vec2::new(10.0, 8.5), thickness_m: 0.2 },
        Obstacle::Circle { center_m: Vec2::new(4.0, 5.0), radius_m: 1.5 },
        Obstacle::Wall { a_m: Vec2::new(15.0, 4.0), b_m: Vec2::new(15.0, 11.0), thickness_m: 0.2 },
    ];
    let map = ObstacleMap { min_m: Vec2::zeros(), max_m: Vec2::new(20.0, 10.0), obstacles: &obs };
    let lat = Lattice::covering(map.min_m, map.max_m, 0.25, 4096).unwrap();
    let (mut f, mut u, mut s) = (vec![0.0; 3 * 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let mut ws = Workspace::new(&mut f, &mut u, &mut s);
    let at = |x: f32, y: f32| lat.around(Vec2::new(x, y))[0].unwrap();
    let (mut reached, mut refused) = (0, 0);
    for (from, to) in [(at(2.0, 2.0), at(18.0, 2.0)), (at(2.0, 8.0), at(12.0, 8.0)), (at(12.0, 8.0), at(18.0, 8.0)), (at(18.0, 9.0), at(2.0, 1.0))] {
        for need in [0.2, 0.5, 0.7, 0.9, 1.2, 1.5, 3.0] {
            let by_search = astar(&map, &lat, &rule(need), &mut ws, from, to).unwrap();
            let by_fill = reachable(&map, &lat, &rule(need), &mut ws, from, to, true).unwrap();
            assert_eq!(by_fill, by_search, "{from} -> {to} at {need}");
            if by_search { reached += 1 } else { refused += 1 }
        }
    }
    assert!(reached > 3 && refused > 3, "{reached} reached, {refused} refused");
}

/// A byte cell never stands for more than the radius it was given (inside an obstacle, for
/// `-margin`), and for less by at most one unit (`(r_max + margin) / 254`) inside
/// `[-margin, r_max]`; unknown is NaN.
#[test]
fn byte_radii_round_down_by_less_than_a_unit() {
    let rule = RadiusRule { margin_m: 0.3, max_radius_m: 5.5, need_m: 1.0, clearance_weight: 0.5 };
    let unit = (5.5 + 0.3) / 254.0;
    assert!(<u8 as RadiusCell>::UNKNOWN.decode(&rule).is_nan());
    for k in 0..=20_000 {
        let r = -0.5 + 6.5 * k as f32 / 20_000.0;
        let back = u8::encode(r, &rule).decode(&rule);
        assert!(back <= r.max(-0.3), "{r} -> {back}");
        if (-0.3..=5.5).contains(&r) {
            assert!(back > r - unit - 1e-5, "{r} -> {back}");
        }
    }
    assert_eq!(u8::encode(f32::NEG_INFINITY, &rule), 0);
    assert_eq!(u8::encode(f32::INFINITY, &rule).decode(&rule), 5.5);
    let zero = RadiusRule { margin_m: 0.0, max_radius_m: 0.0, ..rule };
    assert_eq!(u8::encode(1.0, &zero), 0, "a degenerate unit blocks");
}

/// The MCU's byte radii search as the host's `f32` ones but for needs within a unit of a
/// passage: the same routes found and refused, the narrowest passage at most a unit
/// narrower.
#[test]
fn byte_radii_search_as_f32_ones_within_a_unit() {
    let map = wall_map();
    let lat = Lattice::covering(map.min_m, map.max_m, 0.25, 4096).unwrap();
    let (mut f4, mut u4, mut s4) = (vec![0.0; 3 * 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let (mut r1, mut f1, mut u1, mut s1) = (vec![0u8; 4096], vec![0.0; 2 * 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let mut w4 = Workspace::new(&mut f4, &mut u4, &mut s4);
    let mut w1 = Workspace::with_radii(&mut r1, &mut f1, &mut u1, &mut s1);
    assert_eq!(w1.capacity(), 4096);
    let from = lat.around(Vec2::new(2.0, 2.0))[0].unwrap();
    let to = lat.around(Vec2::new(18.0, 2.0))[0].unwrap();
    let unit = 5.0 / 254.0;
    let (_, gap) = narrowest_passage(&map, &lat, &rule(1.5), &mut w4, from, to).unwrap();
    let (_, gap1) = narrowest_passage(&map, &lat, &rule(1.5), &mut w1, from, to).unwrap();
    assert!(gap1 <= gap && gap1 > gap - unit - 1e-5, "{gap1} against {gap}");
    for need in [0.3, 0.8, gap - 2.0 * unit, gap + 0.01, 2.0] {
        let a = astar(&map, &lat, &rule(need), &mut w4, from, to).unwrap();
        let b = astar(&map, &lat, &rule(need), &mut w1, from, to).unwrap();
        assert_eq!(a, b, "need {need}");
    }
}

/// The test field's columns and rows.
const FIELD_W: usize = 60;
const FIELD_H: usize = 40;

/// A distance field over `FIELD_W x FIELD_H` cells: a wall from the south edge at column 30 and
/// cells scattered one in about `every`.
fn scattered_field(every: usize) -> Vec<f32> {
    let (w, h) = (FIELD_W, FIELD_H);
    let occ = |i: usize, j: usize| (i * 7 + j * 13).is_multiple_of(every) || (i == 30 && j < 30);
    let mut f: Vec<f32> = (0..w * h).map(|c| if occ(c % w, c / w) { 0.0 } else { f32::INFINITY }).collect();
    let n = w.max(h);
    let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
    crate::distance_transform(&mut f, w, h, &mut line, &mut v, &mut z).unwrap();
    f
}

/// On a grid, the byte cells' sweep (through the costs and keys) gives every node the
/// encoding of the `f32` sweep's radius, exactly.
#[test]
fn the_byte_sweep_encodes_the_f32_sweep() {
    let f = scattered_field(23);
    let grid = crate::GridMap { dist_cells: &f[..], width: FIELD_W, height: FIELD_H, resolution_m: 0.25, origin_m: Vec2::new(-1.0, 2.0) };
    let lat = Lattice::covering(Vec2::new(-1.0, 2.0), Vec2::new(14.0, 12.0), 0.3, 4096).unwrap();
    let rule = RadiusRule { margin_m: 0.2, max_radius_m: 2.0, need_m: 0.5, clearance_weight: 0.5 };
    let (mut f4, mut u4, mut s4) = (vec![0.0; 3 * 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let (mut r1, mut f1, mut u1, mut s1) = (vec![0u8; 4096], vec![0.0; 2 * 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let mut w4 = Workspace::new(&mut f4, &mut u4, &mut s4);
    let mut w1 = Workspace::with_radii(&mut r1, &mut f1, &mut u1, &mut s1);
    assert!(sweep_radii(&grid, &lat, &rule, &mut w4) && sweep_radii(&grid, &lat, &rule, &mut w1));
    let mut blocked = 0;
    for k in 0..lat.len() {
        let r = cached_radius(&w4, k);
        assert_eq!(cached_radius(&w1, k).to_bits(), u8::encode(r, &rule).decode(&rule).to_bits(), "node {k}");
        blocked += usize::from(r < 0.0);
    }
    assert!(blocked > 10 && blocked < lat.len() / 2, "{blocked} blocked nodes");
}

/// The MCU's two-byte indices give the host's search, parent for parent.
#[test]
fn two_byte_indices_search_as_four_byte_ones() {
    let map = wall_map();
    let lat = Lattice::covering(map.min_m, map.max_m, 0.25, 4096).unwrap();
    let (mut f4, mut u4, mut s4) = (vec![0.0; 3 * 4096], vec![0u32; 2 * 4096], vec![0; 2048]);
    let (mut f2, mut u2, mut s2) = (vec![0.0; 3 * 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let mut w4 = Workspace::new(&mut f4, &mut u4, &mut s4);
    let mut w2 = Workspace::new(&mut f2, &mut u2, &mut s2);
    assert_eq!(w2.capacity(), 4096);
    let from = lat.around(Vec2::new(2.0, 2.0))[0].unwrap();
    let to = lat.around(Vec2::new(18.0, 2.0))[0].unwrap();
    assert!(astar(&map, &lat, &rule(0.5), &mut w4, from, to).unwrap());
    assert!(astar(&map, &lat, &rule(0.5), &mut w2, from, to).unwrap());
    let mut with_parent = 0;
    for k in 0..lat.len() {
        assert_eq!(w4.parent(&lat, k), w2.parent(&lat, k), "node {k}");
        with_parent += usize::from(w4.parent(&lat, k).is_some());
    }
    assert!(with_parent > 100, "{with_parent} nodes with a parent");
    assert_eq!(narrowest_passage(&map, &lat, &rule(1.5), &mut w4, from, to).unwrap(), narrowest_passage(&map, &lat, &rule(1.5), &mut w2, from, to).unwrap());
    // A work space never takes more nodes than its indices can name beside their marks.
    let (mut f, mut u, mut s) = (vec![0.0; 3 * 70_000], vec![0u16; 2 * 70_000], vec![0; 35_000]);
    assert_eq!(Workspace::new(&mut f, &mut u, &mut s).capacity(), usize::from(u16::MAX) - 2);
}

/// The search's cost along the parents from `to` back to `from` (the edge cost of `astar`),
/// and its steps.
fn path_cost<I: NodeIndex, R: RadiusCell>(ws: &Workspace<'_, I, R>, lat: &Lattice, rule: &RadiusRule, from: usize, to: usize) -> (f32, usize) {
    let (mut k, mut total, mut steps) = (to, 0.0f32, 0);
    while k != from {
        steps += 1;
        let p = ws.parent(lat, k).expect("a path");
        let len = (lat.point_m(k) - lat.point_m(p)).norm();
        let r = cached_radius(ws, k).min(cached_radius(ws, p));
        total += len * (1.0 + rule.clearance_weight * (rule.max_radius_m / r - 1.0));
        k = p;
    }
    (total, steps)
}

/// A work space of keys alone (the flight MCU's) sweeps the same radii through its keys, finds
/// a route wherever the one with costs does, as cheap but for its grid of 2^-8 (at most half a
/// step of it an edge and the heuristic's rounding at both ends), and the same narrowest
/// passage bit for bit (the widest path's cost is its key negated, exact).
#[test]
fn keys_alone_search_as_keys_and_costs() {
    let f = scattered_field(61);
    let grid = crate::GridMap { dist_cells: &f[..], width: FIELD_W, height: FIELD_H, resolution_m: 0.25, origin_m: Vec2::new(-1.0, 2.0) };
    let lat = Lattice::covering(Vec2::new(-1.0, 2.0), Vec2::new(14.0, 12.0), 0.3, 4096).unwrap();
    let rule = |need: f32| RadiusRule { margin_m: 0.2, max_radius_m: 2.0, need_m: need, clearance_weight: 0.5 };
    let (mut r2, mut f2, mut u2, mut s2) = (vec![0u8; 4096], vec![0.0; 2 * 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let (mut r1, mut f1, mut u1, mut s1) = (vec![0u8; 4096], vec![0.0; 4096], vec![0u16; 2 * 4096], vec![0; 2048]);
    let mut both = Workspace::with_radii(&mut r2, &mut f2, &mut u2, &mut s2);
    let mut keys = Workspace::keys_only(&mut r1, &mut f1, &mut u1, &mut s1);
    assert_eq!(keys.capacity(), 4096);
    assert!(sweep_radii(&grid, &lat, &rule(0.5), &mut both) && sweep_radii(&grid, &lat, &rule(0.5), &mut keys));
    for k in 0..lat.len() {
        assert_eq!(cached_radius(&both, k).to_bits(), cached_radius(&keys, k).to_bits(), "node {k}");
    }
    // The widest nodes west and east of the wall.
    let widest = |west: bool| (0..lat.len()).filter(|&k| (lat.point_m(k).x < 3.0) == west && (lat.point_m(k).x > 11.0) != west).max_by(|&a, &b| cached_radius(&both, a).total_cmp(&cached_radius(&both, b))).unwrap();
    let (from, to) = (widest(true), widest(false));
    let mut found = 0;
    for need in [0.0, 0.2, 0.4, 0.6, 0.8, 1.2] {
        let a = astar_cached(&grid, &lat, &rule(need), &mut both, from, to, true).unwrap();
        let b = astar_cached(&grid, &lat, &rule(need), &mut keys, from, to, true).unwrap();
        assert_eq!(a, b, "need {need}");
        if a {
            found += 1;
            let ((ca, _), (cb, steps)) = (path_cost(&both, &lat, &rule(need), from, to), path_cost(&keys, &lat, &rule(need), from, to));
            let grid = (steps + 2) as f32 / 256.0;
            assert!(cb >= ca - 1e-4 * ca && cb <= ca + grid + 1e-4 * ca, "need {need}: {cb} against {ca} ({steps} steps)");
        }
        let pa = narrowest_passage(&grid, &lat, &rule(need), &mut both, from, to).unwrap();
        let pb = narrowest_passage(&grid, &lat, &rule(need), &mut keys, from, to).unwrap();
        assert_eq!((pa.0, pa.1.to_bits()), (pb.0, pb.1.to_bits()), "need {need}");
    }
    assert!((2..6).contains(&found), "{found} needs with a route");
}

/// The keys' grid: values on it add and subtract exactly below 2^16, and a value is moved by at
/// most half its step.
#[test]
fn the_key_grid_adds_and_subtracts_exactly() {
    let mut rng = 7u64;
    let mut next = || {
        rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..10_000 {
        let (a, b) = ((next() * 20_000.0) as f32, (next() * 20_000.0) as f32);
        let (qa, qb) = (on_key_grid(a), on_key_grid(b));
        assert!((qa - a).abs() <= 1.0 / 512.0 && (qb - b).abs() <= 1.0 / 512.0, "{a} -> {qa}");
        assert_eq!(f64::from(qa + qb), f64::from(qa) + f64::from(qb), "{qa} + {qb}");
        assert_eq!((qa + qb) - qb, qa);
    }
    assert_eq!(on_key_grid(f32::INFINITY), f32::INFINITY);
    assert!(on_key_grid(f32::NAN).is_nan());
}
