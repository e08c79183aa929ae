//! Test oracles: the cells a segment crosses, found without the traversal, in `f64`.
//!
//! Grid coordinates as in [`crate::ray`]: cell `(i, j)` is `[i, i+1) x [j, j+1)`.

use std::collections::BTreeSet;

/// Cells of a `w x h` grid holding `a`, `b`, or a point of the open segment between two
/// consecutive grid-line crossings: exactly the cells whose interior the segment crosses plus
/// the cells of its two ends (a segment running along a grid line lies in the cell north or
/// east of it, as `floor` says).
pub fn cells_crossed(a: (f64, f64), b: (f64, f64), w: usize, h: usize) -> BTreeSet<(usize, usize)> {
    let d = (b.0 - a.0, b.1 - a.1);
    let mut ts = vec![0.0, 1.0];
    for (a0, d0) in [(a.0, d.0), (a.1, d.1)] {
        if d0 != 0.0 {
            let lo = a0.min(a0 + d0).floor() as i64;
            let hi = a0.max(a0 + d0).ceil() as i64;
            for k in lo..=hi {
                let t = (k as f64 - a0) / d0;
                if t > 0.0 && t < 1.0 {
                    ts.push(t);
                }
            }
        }
    }
    ts.sort_by(f64::total_cmp);
    ts.dedup();
    let mut out = BTreeSet::new();
    let mut add = |x: f64, y: f64| {
        let (fx, fy) = (x.floor(), y.floor());
        if fx >= 0.0 && fx < w as f64 && fy >= 0.0 && fy < h as f64 {
            out.insert((fx as usize, fy as usize));
        }
    };
    add(a.0, a.1);
    add(b.0, b.1);
    for win in ts.windows(2) {
        let tm = 0.5 * (win[0] + win[1]);
        add(a.0 + d.0 * tm, a.1 + d.1 * tm);
    }
    out
}

/// Cells of a `w x h` grid holding any of `n + 1` evenly spaced points of the segment `a`-`b`.
pub fn sampled_cells(
    a: (f64, f64),
    b: (f64, f64),
    w: usize,
    h: usize,
    n: usize,
) -> BTreeSet<(usize, usize)> {
    (0..=n)
        .filter_map(|k| {
            let t = k as f64 / n as f64;
            let (x, y) = (
                (a.0 + (b.0 - a.0) * t).floor(),
                (a.1 + (b.1 - a.1) * t).floor(),
            );
            (x >= 0.0 && x < w as f64 && y >= 0.0 && y < h as f64)
                .then_some((x as usize, y as usize))
        })
        .collect()
}

/// Whether the segment `a`-`b` meets cell `(i, j)` shrunk by `eps` on every side (its core).
pub fn core_is_crossed(a: (f64, f64), b: (f64, f64), i: usize, j: usize, eps: f64) -> bool {
    let (lo_x, hi_x) = (i as f64 + eps, i as f64 + 1.0 - eps);
    let (lo_y, hi_y) = (j as f64 + eps, j as f64 + 1.0 - eps);
    let d = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for (p, q) in [
        (-d.0, a.0 - lo_x),
        (d.0, hi_x - a.0),
        (-d.1, a.1 - lo_y),
        (d.1, hi_y - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else if p < 0.0 {
            t0 = t0.max(q / p);
        } else {
            t1 = t1.min(q / p);
        }
    }
    t0 <= t1
}
