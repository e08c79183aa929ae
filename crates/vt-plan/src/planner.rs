//! The planner: corridor search, generator curve through the disc intersections, half-widths
//! from the curve's clearance, and vt-tube's validation as the acceptance gate.
//!
//! # Guarantees (docs/planning.md)
//! For a [`ClearanceMap`] whose clearance is a lower bound of the true distance:
//! - every cross-section of the planned tube is obstacle-free with `margin_m` to spare: a
//!   section at curve point `gamma(s)` has half-widths `w(s) <= clearance(gamma(s)) - margin`,
//!   checked at samples `delta` apart with `delta / 2` subtracted (the clearance is 1-Lipschitz
//!   in the true geometry), and the smoothstep between waypoints never exceeds its ends;
//! - every half-width is at least `need_half_width_m`;
//! - `w |kappa| <= FOLD_FRACTION < 1`, the tube never folds;
//! - the curve starts at `start` and ends at `goal`;
//! - `vt_tube::Tube::from_waypoints` accepts the result (else an error is returned).

use crate::corridor::{Disc, MAX_DISCS};
use crate::search::{self, Lattice, NodeIndex, RadiusCell, RadiusRule, Workspace};
use crate::{ClearanceMap, PlanError, Vec2};
use vt_tube::spline::Spline;
use vt_tube::tube::MAX_WAYPOINTS;
use vt_tube::{Tube, Waypoint, DEFAULT_SAMPLES};

/// Largest `w |kappa|` a planned tube may have (vt-tube rejects `>= 1`; 10 % slack for the
/// curvature between the checked samples).
pub const FOLD_FRACTION: f32 = 0.9;
/// Most waypoints added where the curve strays from the corridor.
const MAX_REFINEMENTS: usize = 40;
/// Waypoints closer than this are merged, m (vt-tube rejects coincident waypoints).
const MIN_WAYPOINT_GAP_M: f32 = 0.05;

/// Planner parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanParams {
    /// Half-width every section must have, m: at least one UAV's safety radius plus the safety
    /// distance (Proposition 2).
    pub need_half_width_m: f32,
    /// Kept between the tube and every obstacle, m.
    pub margin_m: f32,
    /// Cap on a disc radius and a half-width, m.
    pub max_half_width_m: f32,
    /// Lattice spacing of the search, m (coarsened if the work space is too small).
    pub lattice_m: f32,
    /// Weight `k_w` of narrowness in the edge cost (0: shortest path).
    pub clearance_weight: f32,
}

impl Default for PlanParams {
    /// The paper team's need (`r_safe` 0.5 m + safety distance 0.4 m), the hand-made paper
    /// tube's 0.4 m margin and 5.5 m widest half-width, a 0.25 m lattice.
    fn default() -> Self {
        Self { need_half_width_m: 0.9, margin_m: 0.4, max_half_width_m: 5.5, lattice_m: 0.25, clearance_weight: 0.5 }
    }
}

impl PlanParams {
    fn validate(&self) -> Result<(), PlanError> {
        let ok = |x: f32| x.is_finite() && x > 0.0;
        if !ok(self.need_half_width_m) {
            return Err(PlanError::BadParams { field: "need_half_width_m" });
        }
        if !(self.margin_m.is_finite() && self.margin_m >= 0.0) {
            return Err(PlanError::BadParams { field: "margin_m" });
        }
        if !(ok(self.max_half_width_m) && self.max_half_width_m >= self.need_half_width_m) {
            return Err(PlanError::BadParams { field: "max_half_width_m" });
        }
        if !(ok(self.lattice_m) && self.lattice_m <= self.need_half_width_m) {
            return Err(PlanError::BadParams { field: "lattice_m" });
        }
        if !(self.clearance_weight.is_finite() && self.clearance_weight >= 0.0) {
            return Err(PlanError::BadParams { field: "clearance_weight" });
        }
        Ok(())
    }
}

/// Where a tube is narrowest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bottleneck {
    /// Point on the generator curve, m.
    pub pos_m: Vec2,
    /// Arc length there, m.
    pub s_m: f32,
    /// Half-width `(w_L + w_R) / 2` there, m.
    pub half_width_m: f32,
}

/// A planned tube: the waypoints vt-tube builds it from, the corridor, the bottleneck.
#[derive(Debug, Clone)]
pub struct PlannedTube {
    /// Waypoints `[x, y, w_L, w_R]` (symmetric widths), m.
    pub waypoints: heapless::Vec<Waypoint, MAX_WAYPOINTS>,
    /// The corridor's discs, start to goal.
    pub discs: heapless::Vec<Disc, MAX_DISCS>,
    /// Narrowest section of the tube.
    pub bottleneck: Bottleneck,
    /// Lattice spacing used, m.
    pub lattice_m: f32,
}

/// A position along the searched path: the start, a lattice node, or the goal.
#[derive(Debug, Clone, Copy, PartialEq)]
enum At {
    Start,
    Node(usize),
    Goal,
}

/// The searched path: start, lattice nodes (following parents), goal.
struct Path<'p, 'w, 'a, I: NodeIndex, R: RadiusCell> {
    ws: &'p Workspace<'w, I, R>,
    lat: &'a Lattice,
    start: Vec2,
    goal: Vec2,
    r_start: f32,
    r_goal: f32,
    first: usize,
    last: usize,
    len: usize,
}

impl<I: NodeIndex, R: RadiusCell> Path<'_, '_, '_, I, R> {
    fn next(&self, a: At) -> Option<At> {
        match a {
            At::Start => Some(At::Node(self.first)),
            At::Node(k) if k == self.last => Some(At::Goal),
            At::Node(k) => match self.ws.parent(self.lat, k) {
                Some(p) => Some(At::Node(p)),
                None => Some(At::Goal),
            },
            At::Goal => None,
        }
    }

    fn disc(&self, a: At, index: usize) -> Disc {
        let (center_m, radius_m) = match a {
            At::Start => (self.start, self.r_start),
            At::Goal => (self.goal, self.r_goal),
            At::Node(k) => (self.lat.point_m(k), search::cached_radius(self.ws, k)),
        };
        Disc { center_m, radius_m, path_index: index }
    }

    /// Point `index` along the path.
    fn point_at(&self, index: usize) -> Vec2 {
        let mut a = At::Start;
        for _ in 0..index {
            match self.next(a) {
                Some(n) => a = n,
                None => break,
            }
        }
        self.disc(a, index).center_m
    }
}

/// Plans a tube from `start_m` to `goal_m` on `map`.
///
/// # Errors
/// [`PlanError::OutsideMap`], [`PlanError::InsideObstacle`] for bad terminals;
/// [`PlanError::TooNarrow`] (the narrowest passage of the widest route) when no corridor holds
/// the required half-width; [`PlanError::TooManyDiscs`], [`PlanError::CurveLeavesCorridor`],
/// [`PlanError::Tube`] when the result cannot be made valid; [`PlanError::BadParams`],
/// [`PlanError::WorkspaceTooSmall`].
pub fn plan<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    start_m: Vec2,
    goal_m: Vec2,
    params: &PlanParams,
    ws: &mut Workspace<'_, I, R>,
) -> Result<PlannedTube, PlanError> {
    plan_in(map, start_m, goal_m, params, ws, &mut Tube::<DEFAULT_SAMPLES>::placeholder(), |x| x)
}

/// [`plan`], building the tube that checks the result in `check` (the tube tables, about
/// 8 KiB at the default size, so a flight MCU keeps them in a `static` and not on the stack),
/// from waypoints whose coordinates `snap` has put on a grid (a link's, m -> m; the identity for
/// none): the tube checked is then the tube a receiver of those waypoints builds. On success
/// `check` holds it; otherwise its contents are unspecified (rebuild it before use).
///
/// # Errors
/// As [`plan`].
pub fn plan_in<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    start_m: Vec2,
    goal_m: Vec2,
    params: &PlanParams,
    ws: &mut Workspace<'_, I, R>,
    check: &mut Tube<DEFAULT_SAMPLES>,
    snap: fn(f32) -> f32,
) -> Result<PlannedTube, PlanError> {
    params.validate()?;
    for (which, p) in [("start", start_m), ("goal", goal_m)] {
        if !(p.x.is_finite() && p.y.is_finite() && map.contains(p)) {
            return Err(PlanError::OutsideMap { which, x_m: p.x, y_m: p.y });
        }
        if !(map.clearance_m(p) > 0.0) {
            return Err(PlanError::InsideObstacle { which, x_m: p.x, y_m: p.y });
        }
    }
    let need = params.need_half_width_m;
    let rule = RadiusRule {
        margin_m: params.margin_m,
        max_radius_m: params.max_half_width_m,
        need_m: need,
        clearance_weight: params.clearance_weight,
    };
    let needed_m = 2.0 * (need + params.margin_m);
    // The reported width is below the need (the largest f32 below it when the passage held the
    // need on the lattice but not for the smooth curve).
    let too_narrow = |p: Vec2, r: f32| PlanError::TooNarrow {
        x_m: p.x,
        y_m: p.y,
        width_m: (2.0 * (r + params.margin_m).max(0.0)).min(f32::from_bits(needed_m.to_bits() - 1)),
        needed_m,
    };
    let (lo, hi) = map.bounds_m();
    let lat = Lattice::covering(lo, hi, params.lattice_m, ws.capacity())?;
    if lat.spacing_m > need {
        let size = hi - lo;
        let needed = ((size.x / params.lattice_m) as usize + 1).saturating_mul((size.y / params.lattice_m) as usize + 1);
        return Err(PlanError::WorkspaceTooSmall { needed });
    }
    let r_start = rule.radius_m(map, start_m);
    let r_goal = rule.radius_m(map, goal_m);
    if r_start < need {
        return Err(too_narrow(start_m, r_start));
    }
    if r_goal < need {
        return Err(too_narrow(goal_m, r_goal));
    }
    // Two passes (docs/planning.md, "Search"): first over nodes with one lattice step of slack
    // (`need + h`), so the smooth curve has room around the lattice path; then, if no such
    // corridor exists or the curve cannot be fitted in it, over nodes that just hold the need.
    let slack = lat.spacing_m;
    let mut last_err = too_narrow(start_m, r_start);
    // The disc radii depend on the map, the lattice, the margin and the cap, not on the need:
    // the second pass keeps those the first one computed. A grid gives them all at once, exact
    // (docs/planning.md, "Node radii in one sweep"); other maps, node by node as the search
    // reaches them.
    let mut radii_cached = search::sweep_radii(map, &lat, &rule, ws);
    for search_need in [need + slack, need] {
        let rule_k = RadiusRule { need_m: search_need, ..rule };
        // The cache holds a previous plan's radii until a search of this one resets it.
        let cached = radii_cached;
        let node_radius = |k: usize| {
            let r = if cached { search::cached_radius(ws, k) } else { f32::NAN };
            if r.is_nan() { rule_k.radius_m(map, lat.point_m(k)) } else { r }
        };
        let usable = |p: Vec2| lat.around(p).into_iter().flatten().find(|&k| node_radius(k) >= search_need);
        // The widest lattice node next to a terminal that has none wide enough.
        let best_near = |p: Vec2| lat.around(p).into_iter().flatten().map(node_radius).fold(f32::NEG_INFINITY, f32::max);
        let (first, last) = match (usable(start_m), usable(goal_m)) {
            (Some(f), Some(l)) => (f, l),
            (None, _) => {
                last_err = too_narrow(start_m, best_near(start_m));
                continue;
            }
            (_, None) => {
                last_err = too_narrow(goal_m, best_near(goal_m));
                continue;
            }
        };
        // Search from the goal so that the parents lead from the start to the goal.
        // With every radius known (a grid's sweep), a first pass that cannot reach the start is
        // known for it from a flood fill, at a fraction of the search's cost (the search opens
        // every node it can reach first); the same answer, so the same plan.
        let found = if radii_cached && search_need > need && !search::reachable(map, &lat, &rule_k, ws, last, first, true)? {
            false
        } else {
            search::astar_cached(map, &lat, &rule_k, ws, last, first, radii_cached)?
        };
        radii_cached = true;
        if !found {
            if search_need == need {
                let (k, r) = search::narrowest_passage(map, &lat, &rule_k, ws, first, last)?;
                return Err(too_narrow(lat.point_m(k), r));
            }
            continue;
        }
        match fit_path(map, &lat, ws, params, [start_m, goal_m], [r_start, r_goal], [first, last], (check, snap)) {
            Ok(t) => return Ok(t),
            // The smooth curve could not hold the width: the passage is too narrow for it there.
            Err(PlanError::CurveLeavesCorridor { x_m, y_m }) => {
                let at = Vec2::new(x_m, y_m);
                last_err = too_narrow(at, rule.radius_m(map, at));
            }
            Err(e) if search_need == need => return Err(e),
            Err(e) => last_err = e,
        }
    }
    Err(last_err)
}

/// Corridor, curve and widths along the lattice path found by the search (parents in `ws`).
#[allow(clippy::too_many_arguments)] // the search's result, the terminals and the tube's storage and grid
fn fit_path<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    lat: &Lattice,
    ws: &Workspace<'_, I, R>,
    params: &PlanParams,
    [start_m, goal_m]: [Vec2; 2],
    [r_start, r_goal]: [f32; 2],
    [first, last]: [usize; 2],
    (check, snap): (&mut Tube<DEFAULT_SAMPLES>, fn(f32) -> f32),
) -> Result<PlannedTube, PlanError> {
    let need = params.need_half_width_m;
    let mut path = Path { ws, lat, start: start_m, goal: goal_m, r_start, r_goal, first, last, len: 0 };
    path.len = {
        let mut n = 1;
        let mut a = At::Start;
        while let Some(b) = path.next(a) {
            a = b;
            n += 1;
        }
        n
    };
    let discs = chain(&path, need)?;
    let mut wps: heapless::Vec<(Vec2, usize), MAX_WAYPOINTS> = heapless::Vec::new();
    push_gap(&mut wps, start_m, 0)?;
    for pair in discs.windows(2) {
        if let [a, b] = pair {
            push_gap(&mut wps, a.lens_center_m(b), (a.path_index + b.path_index) / 2)?;
        }
    }
    // The goal replaces a lens centre that lies too close to it.
    if wps.last().is_some_and(|(p, _)| (p - goal_m).norm() < MIN_WAYPOINT_GAP_M) && wps.len() > 1 {
        wps.pop();
    }
    push_gap(&mut wps, goal_m, path.len - 1)?;

    let mut last_at = start_m;
    // The refinement before this one: where in the list it inserted (true) or removed a
    // waypoint, which, and where that fit strayed.
    let mut before: Option<(usize, (Vec2, usize), bool, Vec2)> = None;
    for round in 0..=MAX_REFINEMENTS {
        let change = match fit_widths(map, &wps, params, lat.spacing_m)? {
            Fit::Widths(widths) => {
                let mut out: heapless::Vec<Waypoint, MAX_WAYPOINTS> = heapless::Vec::new();
                for ((p, _), w) in wps.iter().zip(widths.iter()) {
                    out.push(Waypoint { pos_m: Vec2::new(snap(p.x), snap(p.y)), w_left_m: *w, w_right_m: *w })
                        .map_err(|_| PlanError::TooManyDiscs { capacity: MAX_DISCS })?;
                }
                check.rebuild(&out)?;
                let bottleneck = bottleneck_of(check);
                return Ok(PlannedTube { waypoints: out, discs, bottleneck, lattice_m: lat.spacing_m });
            }
            Fit::Strays { piece, at_m, fold: true } => {
                // Too tight a bend: drop the interior waypoint of the piece nearest to it (a
                // smoother curve), never the start or the goal.
                last_at = at_m;
                let n = wps.len();
                let cands = [piece, piece + 1].into_iter().filter(|&i| i > 0 && i + 1 < n);
                let Some(i) = cands.min_by(|&a, &b| {
                    let da = wps.get(a).map_or(f32::INFINITY, |w| (w.0 - at_m).norm_squared());
                    let db = wps.get(b).map_or(f32::INFINITY, |w| (w.0 - at_m).norm_squared());
                    da.total_cmp(&db)
                }) else {
                    return Err(PlanError::CurveLeavesCorridor { x_m: at_m.x, y_m: at_m.y });
                };
                (i, wps.remove(i), false)
            }
            Fit::Strays { piece, at_m, fold: false } => {
                last_at = at_m;
                // Insert the path point between the piece's ends nearest to where the curve strays.
                let (i0, i1) = match (wps.get(piece), wps.get(piece + 1)) {
                    (Some(a), Some(b)) => (a.1, b.1),
                    _ => return Err(PlanError::CurveLeavesCorridor { x_m: at_m.x, y_m: at_m.y }),
                };
                if i1 <= i0 + 1 {
                    return Err(PlanError::CurveLeavesCorridor { x_m: at_m.x, y_m: at_m.y });
                }
                // Never a point that coincides with the piece's ends (vt-tube rejects those).
                let ends = (wps.get(piece).map(|w| w.0), wps.get(piece + 1).map(|w| w.0));
                let apart = |q: Vec2| [ends.0, ends.1].into_iter().flatten().all(|e| (q - e).norm() >= MIN_WAYPOINT_GAP_M);
                let mut best: Option<(usize, f32)> = None;
                for i in i0 + 1..i1 {
                    let q = path.point_at(i);
                    let d = (q - at_m).norm_squared();
                    if apart(q) && best.is_none_or(|b| d < b.1) {
                        best = Some((i, d));
                    }
                }
                let Some((bi, _)) = best else {
                    return Err(PlanError::CurveLeavesCorridor { x_m: at_m.x, y_m: at_m.y });
                };
                let added = (path.point_at(bi), bi);
                wps.insert(piece + 1, added).map_err(|_| PlanError::TooManyDiscs { capacity: MAX_DISCS })?;
                (piece + 1, added, true)
            }
        };
        // This refinement undid the one before (the same waypoint inserted and removed at the
        // same place): the list is the one of two fits ago, so the fits alternate between the
        // last two until the rounds run out, and the last round's stray is known now (the same
        // answer as running them; docs/planning.md, "Half-widths").
        if let Some((at, wp, inserted, strayed)) = before {
            if at == change.0 && wp == change.1 && inserted != change.2 && shortcut::taken() {
                let end = if (MAX_REFINEMENTS - round).is_multiple_of(2) { last_at } else { strayed };
                return Err(PlanError::CurveLeavesCorridor { x_m: end.x, y_m: end.y });
            }
        }
        before = Some((change.0, change.1, change.2, last_at));
    }
    Err(PlanError::CurveLeavesCorridor { x_m: last_at.x, y_m: last_at.y })
}

/// Whether the refinements' shortcut is taken: always, but in tests that compare it with the
/// rounds run out (per test thread).
mod shortcut {
    #[cfg(test)]
    extern crate std;
    #[cfg(test)]
    std::thread_local! {
        /// Off in this thread, and how often it was taken.
        pub(crate) static STATE: core::cell::Cell<(bool, usize)> = const { core::cell::Cell::new((false, 0)) };
    }
    /// True where the shortcut may be taken (counted in tests).
    #[cfg(test)]
    pub(super) fn taken() -> bool {
        STATE.with(|s| {
            let (off, n) = s.get();
            s.set((off, n + usize::from(!off)));
            !off
        })
    }
    #[cfg(not(test))]
    pub(super) const fn taken() -> bool {
        true
    }
}
#[cfg(test)]
pub(crate) use shortcut::STATE as SHORTCUT_STATE;

/// Appends a waypoint unless it is within [`MIN_WAYPOINT_GAP_M`] of the previous one.
fn push_gap(wps: &mut heapless::Vec<(Vec2, usize), MAX_WAYPOINTS>, p: Vec2, index: usize) -> Result<(), PlanError> {
    if wps.last().is_some_and(|(q, _)| (p - q).norm() < MIN_WAYPOINT_GAP_M) {
        return Ok(());
    }
    wps.push((p, index)).map_err(|_| PlanError::TooManyDiscs { capacity: MAX_DISCS })
}

/// Greedy disc chain along the path: from the current disc, the farthest path point whose
/// disc chains to it ([`Disc::chains_to`]) with every path point in between inside the two
/// discs; at least the next point (progress).
fn chain<I: NodeIndex, R: RadiusCell>(path: &Path<'_, '_, '_, I, R>, need: f32) -> Result<heapless::Vec<Disc, MAX_DISCS>, PlanError> {
    let mut discs: heapless::Vec<Disc, MAX_DISCS> = heapless::Vec::new();
    let full = PlanError::TooManyDiscs { capacity: MAX_DISCS };
    let mut cur = (At::Start, 0usize);
    let mut cur_disc = path.disc(At::Start, 0);
    discs.push(cur_disc).map_err(|_| full)?;
    while cur.0 != At::Goal {
        let Some(first) = path.next(cur.0) else { break };
        let mut best = (first, cur.1 + 1);
        let mut cand = Some(best);
        while let Some((c, ci)) = cand {
            let d = path.disc(c, ci);
            if !cur_disc.chains_to(&d, need) {
                break;
            }
            // Every point strictly between lies in one of the two discs.
            let mut a = path.next(cur.0);
            let mut ai = cur.1 + 1;
            let mut inside = true;
            while let Some(x) = a {
                if ai >= ci {
                    break;
                }
                let p = path.disc(x, ai).center_m;
                if !(cur_disc.contains(p) || d.contains(p)) {
                    inside = false;
                    break;
                }
                a = path.next(x);
                ai += 1;
            }
            if !inside {
                break;
            }
            best = (c, ci);
            cand = path.next(c).map(|n| (n, ci + 1));
        }
        cur = best;
        cur_disc = path.disc(best.0, best.1);
        discs.push(cur_disc).map_err(|_| full)?;
    }
    Ok(discs)
}

#[allow(clippy::large_enum_variant)] // one value per fitting round, on the stack; boxing needs alloc
enum Fit {
    /// Half-width per waypoint, m.
    Widths(heapless::Vec<f32, MAX_WAYPOINTS>),
    /// Piece `piece` cannot hold the need near `at_m`: too close to an obstacle, or (`fold`)
    /// curved too tightly for the need (`w |kappa| <= FOLD_FRACTION`).
    Strays { piece: usize, at_m: Vec2, fold: bool },
}

/// Fits the spline through the waypoints and returns each waypoint's half-width: the smallest
/// allowance `min(clearance - margin - step/2, w_max, FOLD_FRACTION/|kappa|)` over the pieces
/// on either side (the smoothstep between two waypoints stays within their widths).
// Out of line: inlined, its spline and waypoints stayed in `fit_path`'s frame beside the check
// tube's build, which has a spline of its own (672 B more of the flight MCU's deepest stack).
#[inline(never)]
fn fit_widths<M: ClearanceMap>(
    map: &M,
    wps: &[(Vec2, usize)],
    params: &PlanParams,
    lattice_m: f32,
) -> Result<Fit, PlanError> {
    let mut tmp: heapless::Vec<Waypoint, MAX_WAYPOINTS> = heapless::Vec::new();
    for (p, _) in wps {
        tmp.push(Waypoint { pos_m: *p, w_left_m: 1.0, w_right_m: 1.0 })
            .map_err(|_| PlanError::TooManyDiscs { capacity: MAX_DISCS })?;
    }
    // Read where `new` left it: moved out of its `Result`, the spline (1.8 kB) was copied once
    // more on the flight MCU's deepest stack.
    let fitted = Spline::<MAX_WAYPOINTS>::new(&tmp);
    let spline = match &fitted {
        Ok(s) => s,
        Err(e) => return Err((*e).into()),
    };
    let delta = 0.5 * lattice_m;
    let need = params.need_half_width_m;
    // Sample k of piece j: its point, fold allowance and slack.
    let samples = |j: usize| {
        let (u0, u1) = (spline.knot(j), spline.knot(j + 1));
        let m = libm::ceilf(spline.arc_length(u0, u1) / delta).max(1.0) as usize;
        let du = (u1 - u0) / m as f32;
        let spline = &spline;
        let mut prev_step = 0.0f32;
        (0..=m).map(move |k| {
            let u = if k == m { u1 } else { u0 + du * k as f32 };
            let step = if k < m { spline.arc_length(u, u + du) } else { 0.0 };
            let (pos, d1, d2) = spline.eval(u);
            let speed = vt_fpu::norm(&d1);
            let kappa = if speed > 0.0 { (d1.x * d2.y - d1.y * d2.x) / (speed * speed * speed) } else { 0.0 };
            let fold = if kappa != 0.0 { FOLD_FRACTION / kappa.abs() } else { f32::INFINITY };
            let slack = params.margin_m + 0.5 * step.max(prev_step);
            prev_step = step;
            (pos, fold, slack)
        })
    };
    let cap = |slack: f32| params.max_half_width_m + slack;
    let allowance = |clear: f32, slack: f32, fold: f32| vt_fpu::min(vt_fpu::min(params.max_half_width_m, clear - slack), fold);
    // The exact allowance at a sample, and whether the fold bounds it (`-inf` for NaN).
    let exact = |pos: Vec2, fold: f32, slack: f32| {
        let clear = vt_fpu::min(params.max_half_width_m, map.clearance_capped_m(pos, cap(slack)) - slack);
        let allow = vt_fpu::min(clear, fold);
        (if allow.is_nan() { f32::NEG_INFINITY } else { allow }, fold < clear)
    };
    // A lower bound of the allowance, tightened until it reaches `enough` (an allowance).
    let lower = |pos: Vec2, fold: f32, slack: f32, enough: f32| allowance(map.clearance_capped_bounds_m(pos, cap(slack), enough + slack).0, slack, fold);
    // A piece's narrowest sample (the first of equals) and its position. The map's cheap upper
    // bounds give a width the narrowest does not exceed; a sample whose lower bound lies above
    // it, or above the narrowest so far, cannot be the narrowest, so its exact query is skipped
    // (the same widths bit for bit; docs/planning.md, "Fitting with bounds").
    let narrowest = |j: usize| {
        let upper = |(pos, fold, slack): (Vec2, f32, f32)| allowance(map.clearance_capped_bounds_m(pos, cap(slack), f32::NEG_INFINITY).1, slack, fold);
        let above = samples(j).map(upper).fold(f32::INFINITY, vt_fpu::min);
        let mut worst = (f32::INFINITY, Vec2::zeros(), false);
        for (pos, fold, slack) in samples(j) {
            let bar = vt_fpu::min(above, worst.0);
            if lower(pos, fold, slack, bar) > bar {
                continue;
            }
            let (allow, by_fold) = exact(pos, fold, slack);
            if allow < worst.0 {
                worst = (allow, pos, by_fold);
            }
        }
        worst
    };
    let pieces = spline.len().saturating_sub(1);
    // With cheap bounds, first the earliest piece that cannot hold the need: only a sample
    // whose lower bound lies below the need can show it, so the others need no exact query.
    if map.has_cheap_bounds() {
        for j in 0..pieces {
            let strays = samples(j).any(|(pos, fold, slack)| lower(pos, fold, slack, need) < need && exact(pos, fold, slack).0 < need);
            if strays {
                let (_, at_m, fold) = narrowest(j);
                return Ok(Fit::Strays { piece: j, at_m, fold });
            }
        }
    }
    // Each piece's narrowest (without bounds, the first piece below the need strays here).
    let mut piece_min: heapless::Vec<f32, MAX_WAYPOINTS> = heapless::Vec::new();
    for j in 0..pieces {
        let (w, at_m, fold) = narrowest(j);
        if w < need {
            return Ok(Fit::Strays { piece: j, at_m, fold });
        }
        piece_min.push(w).map_err(|_| PlanError::TooManyDiscs { capacity: MAX_DISCS })?;
    }
    let mut widths: heapless::Vec<f32, MAX_WAYPOINTS> = heapless::Vec::new();
    for i in 0..wps.len() {
        let left = if i > 0 { piece_min.get(i - 1).copied() } else { None };
        let right = piece_min.get(i).copied();
        let w = left.unwrap_or(f32::INFINITY).min(right.unwrap_or(f32::INFINITY));
        widths.push(w).map_err(|_| PlanError::TooManyDiscs { capacity: MAX_DISCS })?;
    }
    Ok(Fit::Widths(widths))
}

/// The narrowest sample of a tube.
pub fn bottleneck_of<const N: usize>(tube: &Tube<N>) -> Bottleneck {
    let ds = tube.ds_m();
    let mut b = Bottleneck { pos_m: Vec2::zeros(), s_m: 0.0, half_width_m: f32::INFINITY };
    for (k, smp) in tube.samples().iter().enumerate() {
        let w = 0.5 * (smp.w_left_m + smp.w_right_m);
        if w < b.half_width_m {
            b = Bottleneck { pos_m: smp.pos_m, s_m: k as f32 * ds, half_width_m: w };
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Obstacle, ObstacleMap};

    /// The 11 obstacles of scenarios/paper-10uav.toml (centre x, y, radius), m.
    pub(crate) const PAPER: [(f32, f32, f32); 11] = [
        (16.0, 6.6, 1.6), (16.0, -2.4, 1.6), (30.0, 1.5, 1.5), (30.0, -7.0, 1.5), (9.0, -7.8, 1.5), (4.0, 8.6, 1.2),
        (23.0, 7.6, 1.5), (23.0, -7.2, 1.4), (37.0, 5.6, 1.5), (37.0, -8.4, 1.3), (44.0, 8.6, 1.2),
    ];

    fn paper_obstacles() -> Vec<Obstacle<'static>> {
        PAPER.iter().map(|&(x, y, r)| Obstacle::Circle { center_m: Vec2::new(x, y), radius_m: r }).collect()
    }

    fn plan_on(map: &ObstacleMap<'_>, start: Vec2, goal: Vec2, p: &PlanParams) -> Result<PlannedTube, PlanError> {
        let cap = 1 << 16;
        let (mut f, mut u, mut s) = (vec![0.0; 3 * cap], vec![0u32; 2 * cap], vec![0u8; Workspace::<u32>::parent_bytes(cap)]);
        plan(map, start, goal, p, &mut Workspace::new(&mut f, &mut u, &mut s))
    }

    #[test]
    fn paper_map_gets_a_valid_tube_through_both_passages() {
        let obs = paper_obstacles();
        let map = ObstacleMap { min_m: Vec2::new(0.0, -10.0), max_m: Vec2::new(50.0, 10.0), obstacles: &obs };
        let p = PlanParams::default();
        let t = plan_on(&map, Vec2::new(2.0, 0.0), Vec2::new(48.0, 1.0), &p).unwrap();
        assert!(t.bottleneck.half_width_m >= p.need_half_width_m);
        let first = t.waypoints.first().unwrap().pos_m;
        let last = t.waypoints.last().unwrap().pos_m;
        assert_eq!((first, last), (Vec2::new(2.0, 0.0), Vec2::new(48.0, 1.0)));
        // Every cross-section point keeps the margin from every obstacle.
        let tube = Tube::<DEFAULT_SAMPLES>::from_waypoints(&t.waypoints).unwrap();
        for smp in tube.samples() {
            for q in [smp.left_boundary_m(), smp.right_boundary_m(), smp.pos_m] {
                assert!(map.clearance_m(q) >= p.margin_m - 0.02, "{q:?}");
            }
        }
        // Deterministic, bit for bit.
        let again = plan_on(&map, Vec2::new(2.0, 0.0), Vec2::new(48.0, 1.0), &p).unwrap();
        assert_eq!(t.waypoints, again.waypoints);
        println!("{} waypoints, {} discs, bottleneck {:?}", t.waypoints.len(), t.discs.len(), t.bottleneck);
        for w in &t.waypoints {
            println!("  [{:.2}, {:.2}, {:.2}]", w.pos_m.x, w.pos_m.y, w.w_left_m);
        }
    }

    #[test]
    fn closed_passage_is_refused_with_the_bottleneck() {
        // Two discs leave a 1.0 m gap at (10, 0); the team needs 2 (0.9 + 0.4) = 2.6 m.
        let obs = [
            Obstacle::Circle { center_m: Vec2::new(10.0, 3.0), radius_m: 2.5 },
            Obstacle::Circle { center_m: Vec2::new(10.0, -3.0), radius_m: 2.5 },
            Obstacle::Wall { a_m: Vec2::new(10.0, 5.0), b_m: Vec2::new(10.0, 20.0), thickness_m: 0.2 },
            Obstacle::Wall { a_m: Vec2::new(10.0, -5.0), b_m: Vec2::new(10.0, -20.0), thickness_m: 0.2 },
        ];
        let map = ObstacleMap { min_m: Vec2::new(0.0, -8.0), max_m: Vec2::new(20.0, 8.0), obstacles: &obs };
        let e = plan_on(&map, Vec2::new(2.0, 0.0), Vec2::new(18.0, 0.0), &PlanParams::default()).unwrap_err();
        match e {
            PlanError::TooNarrow { x_m, y_m, width_m, needed_m } => {
                assert!((x_m - 10.0).abs() <= 0.25 && y_m.abs() <= 0.25, "{e}");
                assert!((width_m - 1.0).abs() <= 0.25 + 1e-3, "{e}");
                assert!((needed_m - 2.6).abs() < 1e-5);
            }
            other => panic!("{other}"),
        }
    }

    #[test]
    fn bad_terminals_are_named() {
        let obs = paper_obstacles();
        let map = ObstacleMap { min_m: Vec2::new(0.0, -10.0), max_m: Vec2::new(50.0, 10.0), obstacles: &obs };
        let p = PlanParams::default();
        assert!(matches!(plan_on(&map, Vec2::new(-1.0, 0.0), Vec2::new(48.0, 1.0), &p), Err(PlanError::OutsideMap { which: "start", .. })));
        assert!(matches!(plan_on(&map, Vec2::new(2.0, 0.0), Vec2::new(16.0, 6.6), &p), Err(PlanError::InsideObstacle { which: "goal", .. })));
        assert!(matches!(plan_on(&map, Vec2::new(2.0, 0.0), Vec2::new(16.0, 4.6), &p), Err(PlanError::TooNarrow { .. })));
        let bad = PlanParams { lattice_m: 2.0, ..p };
        assert!(matches!(plan_on(&map, Vec2::new(2.0, 0.0), Vec2::new(48.0, 1.0), &bad), Err(PlanError::BadParams { field: "lattice_m" })));
    }
}
