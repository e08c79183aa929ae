//! The distance transforms and the grid's clearance query, against brute force.

use super::*;
use proptest::prelude::*;

fn edt(cells: &mut [f32], w: usize, h: usize) {
    let n = w.max(h);
    let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
    distance_transform(cells, w, h, &mut line, &mut v, &mut z).unwrap();
}

#[test]
fn single_occupied_cell_gives_distances_to_its_square() {
    let (w, h) = (7, 5);
    let mut cells = vec![f32::INFINITY; w * h];
    cells[2 * w + 3] = 0.0;
    edt(&mut cells, w, h);
    for j in 0..h {
        for i in 0..w {
            let want = box_distance(i as f32, j as f32, 3, 2);
            assert!((cells[j * w + i] - want).abs() < 1e-5, "({i}, {j})");
        }
    }
}

#[test]
fn empty_grid_is_infinite_and_bad_sizes_are_errors() {
    let mut cells = vec![1.0; 6];
    edt(&mut cells, 3, 2);
    assert!(cells.iter().all(|d| *d == f32::INFINITY));
    let (mut line, mut v, mut z) = (vec![0.0; 2], vec![0usize; 1], vec![0.0; 1]);
    assert!(distance_transform(&mut cells, 3, 2, &mut line, &mut v, &mut z).is_err());
    assert!(distance_transform(&mut cells, 4, 2, &mut [0.0; 13], &mut [0usize; 5], &mut [0.0; 6]).is_err());
    assert!(distance_transform(&mut cells, 3, 2, &mut [0.0; 9], &mut [0usize; 4], &mut [0.0; 5]).is_err());
}

/// Distance in cells from the point `(x, y)` (centre coordinates) to the square of cell `(a, b)`.
fn box_distance(x: f32, y: f32, a: usize, b: usize) -> f32 {
    let gx = ((x - a as f32).abs() - 0.5).max(0.0);
    let gy = ((y - b as f32).abs() - 0.5).max(0.0);
    (gx * gx + gy * gy).sqrt()
}

/// Every squared distance a transform can give (multiples of 1/4) up to past the cap.
#[test]
fn eighths_round_every_quarter_square_down_exactly() {
    for k in 0u32..20_000 {
        let d2 = k as f32 * 0.25;
        let want = ((f64::from(k) * 16.0).sqrt().floor() as u32).min(255) as u8;
        assert_eq!(eighths(d2), want, "d2 {d2}");
    }
    assert_eq!(eighths(f32::INFINITY), EIGHTHS_FAR);
}

/// Far from everything the field holds its cap, a lower bound; past 65,534 rows it refuses.
#[test]
fn squares_cap_far_distances_from_below() {
    let (w, h) = (300, 2);
    let mut words = vec![1u16; w * h];
    words[0] = 0;
    let (mut line, mut v, mut z) = (vec![0.0; 3 * w + 1], vec![0usize; w + 1], vec![0.0; w + 2]);
    distance_transform_squares(&mut words, w, h, &mut line, &mut v, &mut z).unwrap();
    let mut exact: Vec<f32> = words.iter().map(|_| f32::INFINITY).collect();
    exact[0] = 0.0;
    edt(&mut exact, w, h);
    for (k, &e) in exact.iter().enumerate() {
        let back = words[..].distance_cells(k).unwrap();
        if e < 127.99 {
            assert_eq!(back.to_bits(), e.to_bits(), "cell {k}");
        } else {
            assert_eq!(words[k], SQUARES_FAR, "cell {k}");
            assert!(back <= e && back > 127.99, "cell {k}: {back} against {e}");
        }
    }
    let mut empty = vec![1u16; 6];
    distance_transform_squares(&mut empty, 3, 2, &mut line, &mut v, &mut z).unwrap();
    assert!(empty.iter().all(|&q| q == SQUARES_NONE));
    assert_eq!(empty[..].distance_cells(0), Some(f32::INFINITY));
    let tall = 1usize << 16;
    let mut column = vec![1u16; tall];
    let (mut line, mut v, mut z) = (vec![0.0; 3 * tall + 1], vec![0usize; tall + 1], vec![0.0; tall + 2]);
    assert!(distance_transform_squares(&mut column, 1, tall, &mut line, &mut v, &mut z).is_err());
}

proptest! {
    #[test]
    fn transform_equals_brute_force(w in 1usize..12, h in 1usize..12, bits in proptest::collection::vec(0u8..6, 144)) {
        let mut cells: Vec<f32> = (0..w * h).map(|k| if bits[k] == 0 { 0.0 } else { f32::INFINITY }).collect();
        let occ: Vec<(usize, usize)> = (0..w * h).filter(|&k| bits[k] == 0).map(|k| (k % w, k / w)).collect();
        edt(&mut cells, w, h);
        for j in 0..h {
            for i in 0..w {
                let want = occ.iter().map(|&(a, b)| box_distance(i as f32, j as f32, a, b)).fold(f32::INFINITY, f32::min);
                prop_assert!((cells[j * w + i] - want).abs() < 1e-4 || cells[j * w + i] == want);
            }
        }
    }

    /// The byte transform is the exact transform's distance rounded down to an eighth of a
    /// cell, capped at 31.875 cells; its clearance is a lower bound too, at most an eighth
    /// of a cell below the exact one's.
    #[test]
    fn eighths_are_the_exact_transform_rounded_down(w in 1usize..40, h in 1usize..40, bits in proptest::collection::vec(0u8..40, 1600), px in 0.0f32..20.0, py in 0.0f32..20.0) {
        let mut exact: Vec<f32> = (0..w * h).map(|k| if bits[k] == 0 { 0.0 } else { f32::INFINITY }).collect();
        let mut bytes: Vec<u8> = (0..w * h).map(|k| u8::from(bits[k] != 0)).collect();
        edt(&mut exact, w, h);
        let n = w.max(h);
        let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
        let mut with_u16_sites = bytes.clone();
        distance_transform_eighths(&mut bytes, w, h, &mut line, &mut v, &mut z).unwrap();
        // The flight MCU's two-byte envelope sites give the same field.
        distance_transform_eighths(&mut with_u16_sites, w, h, &mut line, &mut vec![0u16; n + 1], &mut z).unwrap();
        prop_assert_eq!(&with_u16_sites, &bytes);
        for k in 0..w * h {
            let want = if exact[k] >= 31.875 { EIGHTHS_FAR } else { (f64::from(exact[k]) * 8.0 + 1e-9).floor() as u8 };
            prop_assert_eq!(bytes[k], want, "cell {} exact {}", k, exact[k]);
        }
        let res = 0.5f32;
        let ge = GridMap { dist_cells: &exact[..], width: w, height: h, resolution_m: res, origin_m: Vec2::zeros() };
        let gb = GridMap { dist_cells: &bytes[..], width: w, height: h, resolution_m: res, origin_m: Vec2::zeros() };
        let p = Vec2::new(px, py);
        let (ce, cb) = (ge.clearance_m(p), gb.clearance_m(p));
        prop_assert!(cb <= ce + 1e-5, "bytes {} above exact {}", cb, ce);
        // Inside the grid and a cell or more from the occupied squares (nearer, or outside,
        // whether the discs cover the point at all can turn on the last eighth).
        let in_map = px <= w as f32 * res && py <= h as f32 * res;
        if in_map && ce.is_finite() && ce >= res && ce < 31.0 * res {
            prop_assert!(cb >= ce - 0.125 * res - 1e-4, "bytes {} exact {}", cb, ce);
        }
    }

    /// The two-byte transform reads back bit for bit as the `f32` transform (below its cap,
    /// which these grids never reach), and so does every clearance on it.
    #[test]
    fn squares_read_back_as_the_exact_transform(w in 1usize..40, h in 1usize..40, bits in proptest::collection::vec(0u8..40, 1600), px in -1.0f32..21.0, py in -1.0f32..21.0) {
        let mut exact: Vec<f32> = (0..w * h).map(|k| if bits[k] == 0 { 0.0 } else { f32::INFINITY }).collect();
        let mut words: Vec<u16> = (0..w * h).map(|k| u16::from(bits[k] != 0)).collect();
        edt(&mut exact, w, h);
        let n = w.max(h);
        let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
        distance_transform_squares(&mut words, w, h, &mut line, &mut v, &mut z).unwrap();
        for (k, e) in exact.iter().enumerate() {
            let back = words[..].distance_cells(k).unwrap();
            prop_assert_eq!(back.to_bits(), e.to_bits(), "cell {} exact {} read {}", k, e, back);
        }
        let res = 0.5f32;
        let ge = GridMap { dist_cells: &exact[..], width: w, height: h, resolution_m: res, origin_m: Vec2::zeros() };
        let gw = GridMap { dist_cells: &words[..], width: w, height: h, resolution_m: res, origin_m: Vec2::zeros() };
        let p = Vec2::new(px, py);
        prop_assert_eq!(ge.clearance_m(p).to_bits(), gw.clearance_m(p).to_bits());
    }

    /// Random occupied cells: the clearance never exceeds the true distance to the occupied
    /// squares, and at three cells or more from them it is within half a cell of it (clutter
    /// of single cells is the worst case; docs/planning.md, "Grids"), up to the map's edges.
    #[test]
    fn grid_clearance_is_a_tight_lower_bound(px in -1.0f32..6.0, py in -1.0f32..6.0, bits in proptest::collection::vec(0u8..12, 100)) {
        let (w, h, res) = (10, 10, 0.5f32);
        let mut cells: Vec<f32> = (0..w * h).map(|k| if bits[k] == 0 { 0.0 } else { f32::INFINITY }).collect();
        prop_assume!(cells.contains(&0.0));
        let occ: Vec<(usize, usize)> = (0..w * h).filter(|&k| bits[k] == 0).map(|k| (k % w, k / w)).collect();
        edt(&mut cells, w, h);
        let g = GridMap { dist_cells: &cells[..], width: w, height: h, resolution_m: res, origin_m: Vec2::zeros() };
        let p = Vec2::new(px, py);
        let (x, y) = (px / res - 0.5, py / res - 0.5);
        let truth = res * occ.iter().map(|&(a, b)| box_distance(x, y, a, b)).fold(f32::INFINITY, f32::min);
        let inside = occ.iter().any(|&(a, b)| box_distance(x, y, a, b) == 0.0);
        let cg = g.clearance_m(p);
        if inside {
            prop_assert!(cg <= 0.0, "inside an occupied square, clearance {}", cg);
        } else {
            prop_assert!(cg <= truth + 1e-5, "clearance {} above the truth {}", cg, truth);
            let in_map = (0.0..=5.0).contains(&px) && (0.0..=5.0).contains(&py);
            if truth >= 3.0 * res && in_map {
                prop_assert!(truth - cg <= 0.5 * res, "clearance {} far below the truth {}", cg, truth);
            }
        }
    }
}
