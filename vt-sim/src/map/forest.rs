//! Seeded random forests (circular trunks) for the planning campaign and benchmarks (issue 16).
//! splitmix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators",
//! OOPSLA 2014): the same seed gives the same forest on every machine.

use super::{Map, Shape};

/// splitmix64 step: advances `state` and returns the next draw.
pub fn next(state: &mut u64) -> u64 {
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

/// Grid step of [`corridor_exists`]'s flood fill, m.
pub const ORACLE_STEP_M: f64 = 0.1;

/// Whether a corridor of clearance `need_m` joins `start` and `goal` on `m`: a flood fill over
/// a [`ORACLE_STEP_M`] grid of exact clearances (independent of the planner's lattice, search
/// and curve fitting). The oracle of the planning and perception campaigns: a field is
/// solvable with a corridor of the planner's need plus one lattice step, and has no route
/// without one of the need less one step. Start or goal outside the bounds: `false`.
pub fn corridor_exists(m: &super::LoadedMap, start: [f64; 2], goal: [f64; 2], need_m: f32) -> bool {
    let b = m.bounds_m();
    let h = ORACLE_STEP_M;
    let (w, ht) = (((b[1] - b[0]) / h) as usize + 1, ((b[3] - b[2]) / h) as usize + 1);
    let cell = |p: [f64; 2]| {
        let (i, j) = (((p[0] - b[0]) / h).round(), ((p[1] - b[2]) / h).round());
        (i >= 0.0 && j >= 0.0 && (i as usize) < w && (j as usize) < ht).then(|| j as usize * w + i as usize)
    };
    let (Some(s), Some(g)) = (cell(start), cell(goal)) else {
        return false;
    };
    let free: Vec<bool> = (0..w * ht).map(|k| m.clearance_m([b[0] + (k % w) as f64 * h, b[2] + (k / w) as f64 * h]) >= need_m).collect();
    let mut seen = vec![false; w * ht];
    let mut stack = vec![s];
    while let Some(k) = stack.pop() {
        if k == g {
            return true;
        }
        if seen.get(k).copied().unwrap_or(true) || !free.get(k).copied().unwrap_or(false) {
            continue;
        }
        seen[k] = true;
        let (i, j) = (k % w, k / w);
        if i > 0 {
            stack.push(k - 1);
        }
        if i + 1 < w {
            stack.push(k + 1);
        }
        if j > 0 {
            stack.push(k - w);
        }
        if j + 1 < ht {
            stack.push(k + w);
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::LoadedMap;

    fn map(shapes: Vec<Shape>) -> LoadedMap {
        LoadedMap { source_name: "test".into(), map: Map::Geometric { bounds_m: [0.0, 20.0, 0.0, 10.0], shapes } }
    }

    #[test]
    fn the_oracle_finds_a_gap_exactly_as_wide_as_needed() {
        // A wall across x = 10 m of two circles, with a gap between them of 2 (r_gap) m.
        let wall = |gap: f64| {
            vec![
                Shape::Circle { center_m: [10.0, 0.0], radius_m: 5.0 - gap / 2.0 },
                Shape::Circle { center_m: [10.0, 10.0], radius_m: 5.0 - gap / 2.0 },
            ]
        };
        let (s, g) = ([2.0, 5.0], [18.0, 5.0]);
        assert!(corridor_exists(&map(vec![]), s, g, 1.0));
        assert!(corridor_exists(&map(wall(3.0)), s, g, 1.3), "a 3 m gap has 1.5 m of clearance at its middle");
        assert!(!corridor_exists(&map(wall(3.0)), s, g, 1.6));
        assert!(!corridor_exists(&map(wall(0.0)), s, g, 0.05), "closed");
        assert!(!corridor_exists(&map(vec![]), [-1.0, 5.0], g, 1.0), "start outside the bounds");
        assert!(!corridor_exists(&map(vec![]), s, [25.0, 5.0], 1.0), "goal outside the bounds");
    }
}
