//! The cells a segment crosses, exactly, in order: Amanatides and Woo's voxel traversal
//! ("A Fast Voxel Traversal Algorithm for Ray Tracing", Eurographics 1987).
//!
//! # Frames
//! Grid coordinates: world ENU minus the grid origin, divided by the resolution, so cell
//! `(i, j)` is the half-open square `[i, i+1) x [j, j+1)` (a point on a shared edge belongs to
//! the cell east or north of it, as `floor` says).
//!
//! Along the segment `a + t (b - a)`, `t` in `[0, 1]`, the next vertical grid line is crossed
//! at `t_x` and the next horizontal one at `t_y`; the walk steps into the neighbour across the
//! nearer one. Each `t` is computed afresh from the cell index (`(i + 1 - a_x) / d_x`), not
//! accumulated, so no error builds up along long rays.
//!
//! Which cells are visited: the start cell `floor(a)` (or, from outside, the first cell the
//! segment enters), every cell whose interior the segment crosses, and the cell holding `b`.
//! Exact ties are decided that way too: where the segment passes exactly through a grid corner
//! the walk steps diagonally, skipping the two cells that only touch the segment at that corner;
//! a segment ending exactly on a grid line ends in the cell `floor` gives its end point.

use crate::Vec2;

/// Corrections of the entry cell along one axis; rounding puts `floor` at most one cell off.
const ENTRY_REFINE_STEPS: usize = 3;

/// Visits, in order along the segment `a`-`b` (grid coordinates), the cells of a
/// `width x height` grid that it crosses; `visit(i, j)` returns `false` to stop the walk.
/// Returns the number of cells visited.
///
/// Only cells inside the grid are visited: a segment starting outside is clipped
/// (Liang-Barsky) and the walk ends where it leaves. Each cell is visited at most once (the
/// walk is monotone in `i` and in `j`). Cells visited: at most `|b_x - a_x| + |b_y - a_y| + 3`
/// and at most `width + height - 1`. Non-finite input or an empty grid visits nothing.
pub fn traverse(
    a: Vec2,
    b: Vec2,
    width: usize,
    height: usize,
    mut visit: impl FnMut(usize, usize) -> bool,
) -> usize {
    let d = b - a;
    if width == 0
        || height == 0
        || !(a.x.is_finite() && a.y.is_finite() && d.x.is_finite() && d.y.is_finite())
    {
        return 0;
    }
    let Some((t0, t1)) = clip(a, d, width as f32, height as f32) else {
        return 0;
    };
    let (sx, sy) = (step_of(d.x), step_of(d.y));
    let start = if let Some(c) = cell_at(a, width, height).filter(|_| t0 == 0.0) {
        Some(c)
    } else if t0 < t1 {
        entry_index(a.x, d.x, sx, t0, width).zip(entry_index(a.y, d.y, sy, t0, height))
    } else if t0 >= 1.0 {
        cell_at(b, width, height) // the segment only reaches the grid at its end point
    } else {
        None // it touches the grid's edge at one point between its ends
    };
    let Some((mut i, mut j)) = start else {
        return 0;
    };
    let mut tx = next_crossing(i, sx, a.x, d.x);
    let mut ty = next_crossing(j, sy, a.y, d.y);
    // The walk is monotone, so it ends within `width + height - 1` cells; the cap only makes
    // that bound independent of floating-point behaviour.
    let cap = width.saturating_add(height);
    let mut visited = 0;
    loop {
        visited += 1;
        if !visit(i, j) || visited >= cap {
            break;
        }
        let (x_ok, y_ok) = (may_step(tx, sx), may_step(ty, sy));
        let (step_x, step_y) = match (x_ok, y_ok) {
            (false, false) => break,
            (true, true) => (tx <= ty, ty <= tx), // both on an exact corner crossing
            other => other,
        };
        if step_x {
            let Some(k) = next_index(i, sx, width) else {
                break;
            };
            i = k;
            tx = next_crossing(i, sx, a.x, d.x);
        }
        if step_y {
            let Some(k) = next_index(j, sy, height) else {
                break;
            };
            j = k;
            ty = next_crossing(j, sy, a.y, d.y);
        }
    }
    visited
}

/// The cell holding the grid-coordinate point `g` (`floor`), if inside a `width x height` grid.
pub fn cell_at(g: Vec2, width: usize, height: usize) -> Option<(usize, usize)> {
    let index = |x: f32, n: usize| {
        let f = libm::floorf(x);
        (f >= 0.0 && f < n as f32).then_some(f as usize)
    };
    index(g.x, width).zip(index(g.y, height))
}

/// Liang-Barsky: the parameter interval `[t0, t1]` of `a + t d`, `t` in `[0, 1]`, inside the
/// closed box `[0, w] x [0, h]`, if any.
fn clip(a: Vec2, d: Vec2, w: f32, h: f32) -> Option<(f32, f32)> {
    let mut t0 = 0.0_f32;
    let mut t1 = 1.0_f32;
    // Each side as `p t <= q`.
    for (p, q) in [(-d.x, a.x), (d.x, w - a.x), (-d.y, a.y), (d.y, h - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else if p < 0.0 {
            t0 = t0.max(q / p);
        } else {
            t1 = t1.min(q / p);
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// `-1`, `0` or `+1`: the direction of the walk along one axis.
fn step_of(d: f32) -> i8 {
    if d > 0.0 {
        1
    } else if d < 0.0 {
        -1
    } else {
        0
    }
}

/// Index along one axis of the cell the segment `a + t d` is in just after `t0`, when it
/// enters the grid from outside at `t0`; `None` when it runs along the far edge (outside the
/// half-open grid).
///
/// `floor` of the entry point can be a cell off by rounding (and is wrong on a grid line when
/// moving down): the walk's own crossing times settle it, so ties at entry are decided as they
/// are along the walk.
fn entry_index(a: f32, d: f32, s: i8, t0: f32, n: usize) -> Option<usize> {
    if s == 0 {
        let f = libm::floorf(a);
        return (f >= 0.0 && f < n as f32).then_some(f as usize);
    }
    let f = libm::floorf(a + d * t0);
    let mut k = if !(f > 0.0) {
        0
    } else if f < n as f32 {
        f as usize
    } else {
        n - 1
    };
    for _ in 0..ENTRY_REFINE_STEPS {
        let step = if next_crossing(k, s, a, d) <= t0 {
            s // already past this cell's far side
        } else if next_crossing(k, -s, a, d) > t0 {
            -s // not yet at this cell's near side
        } else {
            break;
        };
        match next_index(k, step, n) {
            Some(m) => k = m,
            None => break,
        }
    }
    Some(k)
}

/// Parameter `t` at which the walk, in cell `k` moving `s`, crosses into the next cell.
fn next_crossing(k: usize, s: i8, a: f32, d: f32) -> f32 {
    match s {
        1 => ((k + 1) as f32 - a) / d,
        -1 => (k as f32 - a) / d,
        _ => f32::INFINITY,
    }
}

/// Whether a crossing at `t` lies on the segment: a point on a grid line belongs to the cell
/// above it, so at `t = 1` a positive step is taken and a negative one is not.
fn may_step(t: f32, s: i8) -> bool {
    match s {
        1 => t <= 1.0,
        -1 => t < 1.0,
        _ => false,
    }
}

/// The neighbour of `k` in direction `s` if inside `0..n`.
fn next_index(k: usize, s: i8, n: usize) -> Option<usize> {
    match s {
        1 => Some(k + 1).filter(|&m| m < n),
        -1 => k.checked_sub(1),
        _ => Some(k),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brute_force::{cells_crossed, core_is_crossed};
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    /// Grid used by the property tests, cells.
    const W: usize = 20;
    /// Grid used by the property tests, cells.
    const H: usize = 15;
    /// Depth below which a near-tie may go either way in `f32`, cells (f32 error is ~1e-5).
    const TIE_CELLS: f64 = 1e-3;

    fn walk(a: Vec2, b: Vec2, w: usize, h: usize) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        let n = traverse(a, b, w, h, |i, j| {
            out.push((i, j));
            true
        });
        assert_eq!(n, out.len());
        out
    }

    fn as64(v: Vec2) -> (f64, f64) {
        (f64::from(v.x), f64::from(v.y))
    }

    /// Consecutive cells are 4- or 8-neighbours and no cell repeats.
    fn assert_connected(cells: &[(usize, usize)]) {
        for w in cells.windows(2) {
            let (di, dj) = (w[0].0.abs_diff(w[1].0), w[0].1.abs_diff(w[1].1));
            assert!(di <= 1 && dj <= 1 && di + dj >= 1, "{cells:?}");
        }
        let set: BTreeSet<_> = cells.iter().collect();
        assert_eq!(set.len(), cells.len());
    }

    #[test]
    fn horizontal_ray_visits_its_row() {
        let cells = walk(Vec2::new(0.5, 2.5), Vec2::new(4.2, 2.5), 10, 5);
        assert_eq!(cells, [(0, 2), (1, 2), (2, 2), (3, 2), (4, 2)]);
    }

    #[test]
    fn diagonal_through_corners_steps_diagonally() {
        let cells = walk(Vec2::new(0.5, 0.5), Vec2::new(3.5, 3.5), 10, 10);
        assert_eq!(cells, [(0, 0), (1, 1), (2, 2), (3, 3)]);
        // Down-right through (1, 2): the corner point belongs by `floor` to (1, 2), but the
        // segment never enters it (nor (0, 1)).
        let cells = walk(Vec2::new(0.5, 2.5), Vec2::new(1.5, 1.5), 10, 10);
        assert_eq!(cells, [(0, 2), (1, 1)]);
    }

    #[test]
    fn end_on_grid_line_follows_floor() {
        assert_eq!(
            walk(Vec2::new(0.5, 0.5), Vec2::new(2.0, 0.5), 5, 5),
            [(0, 0), (1, 0), (2, 0)]
        );
        assert_eq!(
            walk(Vec2::new(2.5, 0.5), Vec2::new(1.0, 0.5), 5, 5),
            [(2, 0), (1, 0)]
        );
    }

    #[test]
    fn outside_and_grazing_segments() {
        // Entering from the east edge, leaving at the west edge.
        assert_eq!(
            walk(Vec2::new(7.0, 1.5), Vec2::new(-3.0, 1.5), 3, 3),
            [(2, 1), (1, 1), (0, 1)]
        );
        // Along the north edge (outside the half-open grid) and along the west edge (inside).
        assert!(walk(Vec2::new(-1.0, 3.0), Vec2::new(5.0, 3.0), 3, 3).is_empty());
        assert_eq!(
            walk(Vec2::new(0.0, -1.0), Vec2::new(0.0, 1.5), 3, 3),
            [(0, 0), (0, 1)]
        );
        // Through the lower-left corner only, from outside.
        assert!(walk(Vec2::new(-1.0, 1.0), Vec2::new(1.0, -1.0), 3, 3).is_empty());
        // Entirely outside, non-finite, empty grid.
        assert!(walk(Vec2::new(-5.0, -5.0), Vec2::new(-1.0, 10.0), 3, 3).is_empty());
        assert!(walk(Vec2::new(f32::NAN, 0.0), Vec2::new(1.0, 1.0), 3, 3).is_empty());
        assert!(walk(Vec2::new(0.5, 0.5), Vec2::new(f32::INFINITY, 1.0), 3, 3).is_empty());
        assert!(walk(Vec2::new(0.5, 0.5), Vec2::new(2.5, 1.0), 0, 3).is_empty());
        // A point segment inside visits its cell.
        assert_eq!(
            walk(Vec2::new(1.5, 1.5), Vec2::new(1.5, 1.5), 3, 3),
            [(1, 1)]
        );
    }

    #[test]
    fn visit_can_stop_the_walk() {
        let mut seen = 0;
        let n = traverse(Vec2::new(0.5, 0.5), Vec2::new(9.5, 0.5), 10, 1, |i, _| {
            seen += 1;
            i < 3
        });
        assert_eq!((n, seen), (4, 4));
    }

    #[test]
    fn huge_far_segment_is_bounded() {
        let n = traverse(
            Vec2::new(-1e30, -3e29),
            Vec2::new(1e30, 3e29),
            50,
            40,
            |_, _| true,
        );
        assert!(n < 50 + 40);
    }

    proptest! {
        /// Random segments, inside and outside the grid: the walk equals the brute force
        /// except for cells the segment only grazes (never crossing their core, the cell shrunk
        /// by `TIE_CELLS`), where f32 rounding of a near-tie may decide either way.
        #[test]
        fn walk_equals_brute_force(ax in -8.0f32..28.0, ay in -8.0f32..23.0, angle in -3.2f32..3.2, len in 0.0f32..40.0) {
            let a = Vec2::new(ax, ay);
            let b = a + Vec2::new(libm::cosf(angle), libm::sinf(angle)) * len;
            let got = walk(a, b, W, H);
            assert_connected(&got);
            let d = b - a;
            prop_assert!((got.len() as f32) <= d.x.abs() + d.y.abs() + 3.0);
            let got: BTreeSet<_> = got.into_iter().collect();
            let want = cells_crossed(as64(a), as64(b), W, H);
            for &(i, j) in got.symmetric_difference(&want) {
                prop_assert!(!core_is_crossed(as64(a), as64(b), i, j, TIE_CELLS), "cell ({i}, {j}) got {got:?} want {want:?}");
            }
        }

        /// Segments between half-integer points: every exact tie (corner crossings, ends on grid
        /// lines, rays along grid lines) is decided exactly as the brute force decides it.
        #[test]
        fn exact_ties_match_brute_force(ax in -6i32..46, ay in -6i32..36, dx in -12i32..13, dy in -12i32..13) {
            let a = Vec2::new(ax as f32 * 0.5, ay as f32 * 0.5);
            let b = a + Vec2::new(dx as f32 * 0.5, dy as f32 * 0.5);
            let got = walk(a, b, W, H);
            assert_connected(&got);
            let got: BTreeSet<_> = got.into_iter().collect();
            prop_assert_eq!(got, cells_crossed(as64(a), as64(b), W, H));
        }
    }
}
