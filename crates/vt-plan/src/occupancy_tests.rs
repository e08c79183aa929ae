use super::*;
use crate::{distance_transform, distance_transform_eighths, Lattice};
use proptest::prelude::*;

/// Distance from `(x, y)` (centre coordinates) to the square of cell `(a, b)`, cells.
fn box_distance(x: f32, y: f32, a: usize, b: usize) -> f32 {
    let gx = ((x - a as f32).abs() - 0.5).max(0.0);
    let gy = ((y - b as f32).abs() - 0.5).max(0.0);
    (gx * gx + gy * gy).sqrt()
}

fn to_bits(occ: &[bool]) -> Vec<u32> {
    let mut words = vec![0u32; OccupancyBits::words(occ.len())];
    for (k, &o) in occ.iter().enumerate() {
        if o {
            words[k / 32] |= 1 << (k % 32);
        }
    }
    words
}

/// A random field of `w x h` cells, a fraction `fill` occupied.
fn field(w: usize, h: usize, fill: f64, seed: u64) -> Vec<bool> {
    let mut rng = seed;
    let mut next = || {
        rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..w * h).map(|_| next() < fill).collect()
}

const RES: f32 = 0.25;

/// A map's lattice sweep, handed the node sink and the work space.
type SweepOf<'f> = &'f dyn Fn(&mut dyn FnMut(usize, f32), SweepSpace<'_, u32>) -> bool;

fn origin() -> Vec2 {
    Vec2::new(1.5, -2.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    /// Every query is the exact distance to the occupied squares (brute force over every cell)
    /// below the cap and the cap above it, inside an occupied cell the field map's value, and
    /// never below the one-byte field's disc union (the planner's map before).
    #[test]
    fn the_query_is_the_exact_distance_below_the_cap(
        w in 1usize..70, h in 1usize..40, fill in 0.0f64..0.3, seed in any::<u64>(),
        px in -0.2f32..1.2, py in -0.2f32..1.2, cap in 0.1f32..12.0,
    ) {
        let occ = field(w, h, fill, seed);
        let words = to_bits(&occ);
        let map = OccupancyMap { bits: OccupancyBits(&words), width: w, height: h, resolution_m: RES, origin_m: origin() };
        let mut bytes: Vec<u8> = occ.iter().map(|&o| u8::from(!o)).collect();
        let n = w.max(h);
        let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
        distance_transform_eighths(&mut bytes, w, h, &mut line, &mut v, &mut z).unwrap();
        let eighths = GridMap { dist_cells: &bytes[..], width: w, height: h, resolution_m: RES, origin_m: origin() };
        let p = origin() + Vec2::new(px * w as f32, py * h as f32) * RES;
        let rel = (p - origin()) / RES - Vec2::new(0.5, 0.5);
        let exact = (0..w * h).filter(|&c| occ[c]).map(|c| box_distance(rel.x, rel.y, c % w, c / w)).fold(f32::INFINITY, f32::min) * RES;
        let got = map.clearance_capped_m(p, cap);
        let field_value = eighths.clearance_capped_m(p, cap);
        if field_value < 0.0 {
            prop_assert_eq!(got.to_bits(), field_value.to_bits(), "inside an occupied cell, the field map's value");
        } else if exact >= cap {
            prop_assert!(got == cap || (got >= cap - 1e-4 * RES && got <= exact), "{} at cap {} (exact {})", got, cap, exact);
        } else {
            prop_assert!((got - exact).abs() <= 1e-4 * RES + 1e-5, "{} against {}", got, exact);
            prop_assert!(got <= exact + 1e-6, "never above the true distance");
            prop_assert!(got >= field_value.min(cap) - 1e-4 * RES - 1e-6, "{} below the field's {}", got, field_value);
        }
        let uncapped = map.clearance_m(p);
        if field_value >= 0.0 && exact.is_finite() {
            prop_assert!((uncapped - exact).abs() <= 1e-4 * RES + 1e-5, "uncapped {} against {}", uncapped, exact);
        } else if field_value >= 0.0 {
            prop_assert_eq!(uncapped, f32::INFINITY);
        }
    }

    /// The lattice sweep reads the bits as it reads a distance field's zeros: the same value at
    /// every node, bit for bit.
    #[test]
    fn the_sweep_on_bits_is_the_sweep_on_a_field(
        w in 1usize..60, h in 1usize..30, fill in 0.0f64..0.3, seed in any::<u64>(), spacing in 0.3f32..2.5,
    ) {
        let occ = field(w, h, fill, seed);
        let words = to_bits(&occ);
        let map = OccupancyMap { bits: OccupancyBits(&words), width: w, height: h, resolution_m: RES, origin_m: origin() };
        let mut f: Vec<f32> = occ.iter().map(|&o| if o { 0.0 } else { f32::INFINITY }).collect();
        let n = w.max(h);
        let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
        distance_transform(&mut f, w, h, &mut line, &mut v, &mut z).unwrap();
        let gf = GridMap { dist_cells: &f[..], width: w, height: h, resolution_m: RES, origin_m: origin() };
        let size = Vec2::new(w as f32, h as f32) * RES;
        let lat = Lattice::covering(origin(), origin() + size, spacing * RES, 10_000).unwrap();
        let sweep = |m: SweepOf<'_>| {
            let (mut floats, mut bounds) = (vec![0.0f32; 2 * w + 1], vec![0.0f32; w + 2]);
            let (mut sites, mut below, mut above) = (vec![0u32; w + 1], vec![0u32; w], vec![0u32; w]);
            let space = SweepSpace { floats: &mut floats, bounds: &mut bounds, sites: &mut sites, below: &mut below, above: &mut above };
            let mut out = vec![f32::NAN; lat.len()];
            assert!(m(&mut |k, c| out[k] = c, space));
            out
        };
        let on_bits = sweep(&|out, space| map.lattice_clearances_m(&lat, &mut |k, c| out(k, c), space));
        let on_field = sweep(&|out, space| gf.lattice_clearances_m(&lat, &mut |k, c| out(k, c), space));
        for (k, (a, b)) in on_bits.iter().zip(&on_field).enumerate() {
            prop_assert_eq!(a.to_bits(), b.to_bits(), "node {}", k);
        }
    }
}

#[test]
fn words_are_searched_across_their_boundaries() {
    let mut words = [0u32; 4];
    for k in [0usize, 31, 32, 63, 64, 100, 127] {
        words[k / 32] |= 1 << (k % 32);
    }
    let bits = OccupancyBits(&words);
    assert_eq!(bits.first_set(1, 127), Some(31));
    assert_eq!(bits.first_set(33, 63), Some(63));
    assert_eq!(bits.first_set(65, 99), None);
    assert_eq!(bits.first_set(65, 127), Some(100));
    assert_eq!(bits.first_set(128, 200), None, "beyond the words");
    assert_eq!(bits.last_set(0, 126), Some(100));
    assert_eq!(bits.last_set(33, 62), None);
    assert_eq!(bits.last_set(1, 62), Some(32));
    assert_eq!(bits.last_set(0, 30), Some(0));
    assert_eq!(bits.last_set(1, 30), None);
    assert_eq!(bits.last_set(5, 4), None, "an empty range");
    assert_eq!(bits.last_set(0, 500), None, "beyond the words");
}

#[test]
fn degenerate_maps_and_points_have_defined_answers() {
    let words = [0u32; 2];
    fn at(w: usize, h: usize, words: &[u32]) -> OccupancyMap<'_> {
        OccupancyMap { bits: OccupancyBits(words), width: w, height: h, resolution_m: RES, origin_m: Vec2::zeros() }
    }
    let p = Vec2::new(0.3, 0.3);
    assert_eq!(at(0, 0, &words).clearance_m(p), f32::NEG_INFINITY, "an empty grid");
    assert_eq!(at(10, 7, &words).clearance_m(p), f32::NEG_INFINITY, "bits shorter than the grid");
    assert_eq!(at(8, 8, &words).clearance_m(Vec2::new(f32::NAN, 0.0)), f32::NEG_INFINITY);
    assert_eq!(at(8, 8, &words).clearance_m(p), f32::INFINITY, "nothing occupied");
    assert_eq!(at(8, 8, &words).clearance_capped_m(p, 3.0), 3.0, "nothing within the cap");
    let one = [1u32 << 9, 0];
    let m = at(8, 8, &one);
    let free = Vec2::new(1.5, 1.5);
    assert_eq!(m.clearance_capped_m(free, -1.0), 0.0, "a cap that is not positive");
    assert_eq!(m.clearance_capped_m(free, f32::NAN), 0.0);
    // Cell (1, 1) occupied: its square spans [0.25, 0.5]^2; (0.3, 0.3) lies inside it.
    assert!(m.clearance_m(p) < 0.0);
    let outside = m.clearance_m(Vec2::new(-1.0, 0.375));
    assert!((outside - 1.25).abs() < 1e-4, "west of the grid, 1.25 m from the square: {outside}");
    assert_eq!(m.bounds_m(), (Vec2::zeros(), Vec2::new(2.0, 2.0)));
}
