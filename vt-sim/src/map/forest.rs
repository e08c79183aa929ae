//! Seeded random forests (circular trunks) for the planning campaign and benchmarks (issue 16).
//! splitmix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators",
//! OOPSLA 2014): the same seed gives the same forest on every machine.

use super::{Map, Shape};

/// splitmix64 step.
fn next(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in `[lo, hi)`.
fn uniform(state: &mut u64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * ((next(state) >> 11) as f64 / (1u64 << 53) as f64)
}

/// A forest: `n` trunks of radius `radius_m` (uniform in `[min, max]`) uniform in `bounds_m`
/// `[x_min, x_max, y_min, y_max]`, none within `clear_m` of a point of `keep_clear` (start and
/// goal terminals; fewer if they cannot be placed).
pub fn forest(seed: u64, n: usize, bounds_m: [f64; 4], radius_m: [f64; 2], keep_clear: &[[f64; 2]], clear_m: f64) -> Map {
    let mut st = seed;
    let mut shapes = Vec::with_capacity(n);
    // Bounded: a keep-clear zone covering the whole rectangle gives fewer trunks, not a hang.
    for _ in 0..n.saturating_mul(1000) {
        if shapes.len() >= n {
            break;
        }
        let c = [uniform(&mut st, bounds_m[0], bounds_m[1]), uniform(&mut st, bounds_m[2], bounds_m[3])];
        let r = uniform(&mut st, radius_m[0], radius_m[1]);
        if keep_clear.iter().all(|k| (c[0] - k[0]).hypot(c[1] - k[1]) > clear_m + r) {
            shapes.push(Shape::Circle { center_m: c, radius_m: r });
        }
    }
    Map::Geometric { bounds_m, shapes }
}
