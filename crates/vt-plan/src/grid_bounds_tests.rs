//! The grid's cheap bounds of its clearance query, and what the planner's fit does with them.

use crate::{distance_transform, distance_transform_eighths, distance_transform_squares, plan, ClearanceMap, DistanceCells, GridMap, Lattice, NodeIndex, PlanParams, SweepSpace, Vec2, Workspace};
use proptest::prelude::*;

/// A grid of `w x h` cells from `seed`, about `fill` of them occupied: the three fields.
fn fields(w: usize, h: usize, fill: f64, seed: u64) -> (Vec<f32>, Vec<u16>, Vec<u8>) {
    let mut rng = seed;
    let mut next = || {
        rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let occ: Vec<bool> = (0..w * h).map(|_| next() < fill).collect();
    let mut f: Vec<f32> = occ.iter().map(|&o| if o { 0.0 } else { f32::INFINITY }).collect();
    let mut q: Vec<u16> = occ.iter().map(|&o| u16::from(!o)).collect();
    let mut e: Vec<u8> = occ.iter().map(|&o| u8::from(!o)).collect();
    let n = w.max(h);
    let (mut line, mut v, mut z) = (vec![0.0; 3 * n + 1], vec![0usize; n + 1], vec![0.0; n + 2]);
    distance_transform(&mut f, w, h, &mut line, &mut v, &mut z).unwrap();
    distance_transform_squares(&mut q, w, h, &mut line, &mut v, &mut z).unwrap();
    distance_transform_eighths(&mut e, w, h, &mut line, &mut v, &mut z).unwrap();
    (f, q, e)
}

/// A grid of `w x h` cells with `n` solid blocks of 3-16 cells a side from `seed`: its
/// two-byte field.
fn blocks(w: usize, h: usize, n: usize, seed: u64) -> Vec<u16> {
    let mut rng = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut next = |m: usize| {
        rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((rng >> 33) as usize) % m
    };
    let mut q = vec![1u16; w * h];
    for _ in 0..n {
        let (bw, bh) = (3 + next(14), 3 + next(14));
        let (x0, y0) = (8 + next(w - 16), next(h));
        for j in y0..(y0 + bh).min(h) {
            for i in x0..(x0 + bw).min(w) {
                q[j * w + i] = 0;
            }
        }
    }
    let m = w.max(h);
    let (mut line, mut v, mut z) = (vec![0.0; 3 * m + 1], vec![0usize; m + 1], vec![0.0; m + 2]);
    distance_transform_squares(&mut q, w, h, &mut line, &mut v, &mut z).unwrap();
    q
}

fn grid<C: ?Sized + DistanceCells>(cells: &C, w: usize, h: usize) -> GridMap<'_, C> {
    GridMap { dist_cells: cells, width: w, height: h, resolution_m: 0.25, origin_m: Vec2::new(-1.0, 2.0) }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    /// Below and above the query at any point and cap, on every field, in and out of the grid.
    #[test]
    fn the_cheap_bounds_hold_the_query_between_them(
        w in 1usize..20, h in 1usize..20, fill in 0.0f64..0.5, seed in any::<u64>(),
        pts in proptest::collection::vec((-0.2f32..1.2, -0.2f32..1.2, 0.0f32..3.0, -1.0f32..3.0), 40),
    ) {
        let (f, q, e) = fields(w, h, fill, seed);
        let size = Vec2::new(w as f32, h as f32) * 0.25;
        for (fx, fy, cap, enough) in pts {
            let p = Vec2::new(-1.0, 2.0) + Vec2::new(fx * size.x, fy * size.y);
            for (name, c, (lo, hi)) in [
                ("f32", grid(&f[..], w, h).clearance_capped_m(p, cap), grid(&f[..], w, h).clearance_capped_bounds_m(p, cap, enough)),
                ("u16", grid(&q[..], w, h).clearance_capped_m(p, cap), grid(&q[..], w, h).clearance_capped_bounds_m(p, cap, enough)),
                ("u8", grid(&e[..], w, h).clearance_capped_m(p, cap), grid(&e[..], w, h).clearance_capped_bounds_m(p, cap, enough)),
            ] {
                prop_assert!(lo <= c && c <= hi, "{name} at {p:?}, cap {cap}, enough {enough}: {lo} <= {c} <= {hi}");
            }
        }
    }
}

/// Where the byte field holds its cap (31.875 cells and beyond, far from the one occupied
/// cell), its discs bound nothing from above: the upper bound still holds the query, with a
/// cap past the field's reach.
#[test]
fn the_upper_bound_holds_past_the_fields_cap() {
    let (w, h) = (90, 90);
    let mut e = vec![1u8; w * h];
    e[0] = 0;
    let m = w.max(h);
    let (mut line, mut v, mut z) = (vec![0.0; 3 * m + 1], vec![0usize; m + 1], vec![0.0; m + 2]);
    distance_transform_eighths(&mut e, w, h, &mut line, &mut v, &mut z).unwrap();
    let g = grid(&e[..], w, h);
    let mut capped = 0;
    for i in 0..40 {
        for j in 0..40 {
            let p = Vec2::new(-1.0, 2.0) + Vec2::new(10.0 + 0.13 * i as f32, 10.0 + 0.11 * j as f32);
            let c = g.clearance_capped_m(p, 1e3);
            let (lo, hi) = g.clearance_capped_bounds_m(p, 1e3, f32::NEG_INFINITY);
            assert!(lo <= c && c <= hi, "at {p:?}: {lo} <= {c} <= {hi}");
            capped += usize::from(hi == f32::INFINITY);
        }
    }
    assert!(capped > 0, "no point where all four discs are at the cap");
}

/// The grid with its clearance and its lattice sweep, but no cheap bounds: the fit then
/// queries every sample.
struct EverySample<'g, 'c>(&'g GridMap<'c, [u16]>);

impl ClearanceMap for EverySample<'_, '_> {
    fn bounds_m(&self) -> (Vec2, Vec2) {
        self.0.bounds_m()
    }
    fn clearance_m(&self, p_m: Vec2) -> f32 {
        self.0.clearance_m(p_m)
    }
    fn clearance_capped_m(&self, p_m: Vec2, cap_m: f32) -> f32 {
        self.0.clearance_capped_m(p_m, cap_m)
    }
    fn lattice_clearances_m<I: NodeIndex>(&self, lat: &Lattice, out: &mut impl FnMut(usize, f32), space: SweepSpace<'_, I>) -> bool {
        self.0.lattice_clearances_m(lat, out, space)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(60))]
    /// The fit skips a sample only where it cannot be its piece's narrowest: on random
    /// cluttered grids the planned tube, or the refusal, is bit for bit the one that queries
    /// every sample.
    #[test]
    fn the_fit_with_bounds_plans_bit_for_bit_as_without(seed in any::<u64>(), fill in 0.0f64..0.06) {
        let (w, h) = (120, 48);
        let (_, q, _) = fields(w, h, fill, seed);
        let g = grid(&q[..], w, h);
        let params = PlanParams { need_half_width_m: 0.5, margin_m: 0.3, max_half_width_m: 2.0, lattice_m: 0.25, clearance_weight: 0.5 };
        let (start, goal) = (Vec2::new(-0.5, 5.0), Vec2::new(28.5, 12.0));
        let run = |m: &dyn Fn(&mut Workspace<'_, u32>) -> Result<crate::PlannedTube, crate::PlanError>| {
            let (mut fl, mut ints, mut steps) = (vec![0.0f32; 3 * 8192], vec![0u32; 2 * 8192], vec![0u8; 4096]);
            m(&mut Workspace::new(&mut fl, &mut ints, &mut steps))
        };
        let with = run(&|ws| plan(&g, start, goal, &params, ws));
        let without = run(&|ws| plan(&EverySample(&g), start, goal, &params, ws));
        match (&with, &without) {
            (Ok(a), Ok(b)) => prop_assert_eq!(&a.waypoints, &b.waypoints),
            (Err(a), Err(b)) => prop_assert_eq!(format!("{a:?}"), format!("{b:?}")),
            _ => prop_assert!(false, "{with:?} against {without:?}"),
        }
    }
}

/// A refinement that undoes the one before it makes the fit alternate between two lists until
/// its rounds run out; the planner then answers the last round's refusal at once. On random
/// cluttered grids, and on grids with a bend too tight for the need, the answer is bit for bit
/// the one of running every round, and the shortcut is taken.
#[test]
fn the_undone_refinement_answers_as_the_rounds_run_out() {
    let mut taken = 0;
    let mut compared = 0;
    for seed in 0..400u64 {
        let (w, h) = (120, 48);
        let q = blocks(w, h, 4 + (seed % 9) as usize, seed);
        let g = grid(&q[..], w, h);
        let need = 0.4 + 0.1 * (seed % 7) as f32;
        let params = PlanParams { need_half_width_m: need, margin_m: 0.3, max_half_width_m: 2.0, lattice_m: 0.25, clearance_weight: 0.5 };
        let (start, goal) = (Vec2::new(-0.5, 5.0), Vec2::new(28.5, 12.0));
        let run = |off: bool| {
            crate::planner::SHORTCUT_STATE.with(|s| s.set((off, 0)));
            let (mut fl, mut ints, mut steps) = (vec![0.0f32; 3 * 8192], vec![0u32; 2 * 8192], vec![0u8; 4096]);
            let r = plan(&g, start, goal, &params, &mut Workspace::new(&mut fl, &mut ints, &mut steps));
            (r, crate::planner::SHORTCUT_STATE.with(|s| s.get().1))
        };
        let (with, n) = run(false);
        let (without, _) = run(true);
        taken += n;
        compared += 1;
        match (&with, &without) {
            (Ok(a), Ok(b)) => assert_eq!(a.waypoints, b.waypoints, "seed {seed}"),
            (Err(a), Err(b)) => assert_eq!(format!("{a:?}"), format!("{b:?}"), "seed {seed}"),
            _ => panic!("seed {seed}: {with:?} against {without:?}"),
        }
    }
    assert!(taken > 0, "no refinement undid the one before in {compared} plans");
    eprintln!("shortcut taken {taken} times in {compared} plans");
}
