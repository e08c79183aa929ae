//! True clearances (issue 27): surface to surface, at the plant rate, between the bodies'
//! envelopes, the tube's boundary and the world's real obstacles (docs/design.md, "Envelopes
//! and clearances").
//!
//! - A UAV is the sphere of radius `r_u` around its centre of mass
//!   ([`crate::scenario::UavSpec::envelope_radius_m`]), the load the sphere of radius `r_l`
//!   ([`crate::scenario::LoadSpec::envelope_radius_m`]), a cable the segment from the UAV's
//!   centre to the load's centre (the hook hangs 8 cm below the centre: at most 6 cm off it
//!   horizontally at the 45 deg tilt limit).
//! - UAV-UAV: `|p_i - p_j| - 2 r_u`. UAV-boundary: the horizontal distance to the tube's
//!   boundary at the UAV's section minus `r_u`.
//! - Obstacles are prisms from the ground to the ceiling, as the planner treats them: the
//!   clearance of a body is its horizontal distance to the nearest obstacle minus its radius, a
//!   cable's the smallest horizontal distance of its segment. Circles, polygons and walls
//!   (capsules, as in `vt_plan`) are exact; an occupancy grid gives the distance transform's
//!   lower bound, and a cable on a grid is sampled every half cell, less half a sample spacing,
//!   so it too is a lower bound.

use crate::scenario::{LoadedScenario, SimTube};
use boundary::{BoundaryAnchor, TubeSeen};
use nalgebra::{Vector2, Vector3};

mod boundary;

pub use crate::obstacles::Obstacles;

type V2 = Vector2<f64>;
type V3 = Vector3<f64>;

/// Relative slack of [`Measured::above`] (on squared distances): far above the rounding of
/// the distances it compares, so a clearance it skips could not have lowered the minimum.
const PRUNE_SLACK: f64 = 1e-6;

/// The last exact obstacle clearance of a point or a segment (ends `a`, `b`; a point has
/// `a == b`) and where it was measured. The clearance is 1-Lipschitz in the positions: a point
/// that moves by `d` comes at most `d` closer to any set, and so does a segment whose ends move
/// by at most `d` (each of its points moves by at most `d`). Until the ends have moved by more
/// than the clearance's excess over a limit, the clearance cannot fall below that limit and
/// need not be measured again.
#[derive(Debug, Clone, Copy)]
struct Measured {
    a: V2,
    b: V2,
    clearance_m: f64,
}

impl Measured {
    /// Nothing measured yet: never above any limit.
    const NONE: Self = Self { a: V2::new(0.0, 0.0), b: V2::new(0.0, 0.0), clearance_m: f64::NEG_INFINITY };

    /// True when a point or segment with ends `a`, `b` is certainly at `limit` (m) or more from
    /// the obstacles (with [`PRUNE_SLACK`] to spare).
    fn above(&self, a: V2, b: V2, limit: f64) -> bool {
        let slack = self.clearance_m - limit;
        if slack.is_nan() || slack <= 0.0 {
            return false;
        }
        let reach_sq = slack * slack * (1.0 - PRUNE_SLACK);
        (a - self.a).norm_squared() < reach_sq && (b - self.b).norm_squared() < reach_sq
    }
}

/// How far any UAV may move from the pair epoch's positions before a new epoch, m.
const EPOCH_MOVE_M: f64 = 0.25;

/// The closest pair of a team without all `n (n - 1) / 2` distances at every sample. At an
/// epoch every pair is measured and each UAV keeps its nearest neighbour's distance `D_i`;
/// after UAV `i` has moved `d_i` and the farthest-moved UAV `d_max`, every pair with `i` is at
/// least `D_i - d_i - d_max` apart (the triangle inequality), so only the pairs between UAVs
/// whose bound does not clear the limit are measured. The minimum is the brute force's, bit for
/// bit (tested).
#[derive(Debug, Clone, Default)]
struct ClosestPair {
    /// Positions at the epoch, m (empty: no epoch yet).
    at: Vec<V3>,
    /// Which UAVs were left out at the epoch.
    lost: Vec<bool>,
    /// Each UAV's nearest-neighbour distance at the epoch, m.
    nearest_m: Vec<f64>,
    /// Scratch: the UAVs whose pairs are measured this sample.
    near: Vec<usize>,
    /// Scratch: how far each UAV moved since the epoch, squared, m^2.
    moved: Vec<f64>,
}

/// Whether UAV `i` counts in the clearances: `lost` has it, and it has not lost thrust.
fn is_up(lost: &[bool], i: usize) -> bool {
    !lost.get(i).copied().unwrap_or(true)
}

impl ClosestPair {
    /// The smallest squared centre distance (m^2) among the pairs of UAVs not `lost` that could
    /// be closer than `limit_m` (m), or `+inf`; a value at or above `limit_m^2` may also come
    /// back (it changes no minimum below the limit).
    fn min_sq(&mut self, pos: &[V3], lost: &[bool], limit_m: f64) -> f64 {
        let up = |i: usize| is_up(lost, i);
        let same_team = self.at.len() == pos.len() && self.lost.len() == pos.len() && self.lost.iter().zip(0..).all(|(l, i)| *l != up(i));
        if !same_team {
            return self.epoch(pos, lost);
        }
        // Squared moves: one square root for the farthest (`sqrt` is monotone, so it is the
        // largest `|p - a|`, bit for bit), and a UAV's own only when `d - 2 d_max` does not
        // already clear the limit (`d - moved - d_max` is at least that, rounding included).
        self.moved.resize(pos.len(), 0.0);
        let mut sq_max = 0.0f64;
        for ((moved, p), a) in self.moved.iter_mut().zip(pos).zip(&self.at) {
            *moved = (p - a).norm_squared();
            sq_max = sq_max.max(*moved);
        }
        let d_max = sq_max.sqrt();
        if d_max.is_nan() || d_max > EPOCH_MOVE_M {
            return self.epoch(pos, lost);
        }
        self.near.clear();
        let limit = limit_m * (1.0 + PRUNE_SLACK) + PRUNE_SLACK;
        for (i, (moved_sq, d)) in self.moved.iter().zip(&self.nearest_m).enumerate() {
            let clears = d - d_max - d_max > limit || d - moved_sq.sqrt() - d_max > limit;
            if up(i) && !clears {
                self.near.push(i);
            }
        }
        let mut best = f64::INFINITY;
        for (k, &i) in self.near.iter().enumerate() {
            for &j in self.near.iter().skip(k + 1) {
                if let (Some(p), Some(q)) = (pos.get(i), pos.get(j)) {
                    best = best.min((p - q).norm_squared());
                }
            }
        }
        best
    }

    /// Every pair measured; the epoch restarts at `pos`.
    fn epoch(&mut self, pos: &[V3], lost: &[bool]) -> f64 {
        let up = |i: usize| is_up(lost, i);
        let n = pos.len();
        self.at.clear();
        self.at.extend_from_slice(pos);
        self.lost.clear();
        self.lost.extend((0..n).map(|i| !up(i)));
        self.nearest_m.clear();
        self.nearest_m.resize(n, f64::INFINITY);
        let mut best = f64::INFINITY;
        for (i, p) in pos.iter().enumerate().filter(|(i, _)| up(*i)) {
            for (j, q) in pos.iter().enumerate().skip(i + 1).filter(|(j, _)| up(*j)) {
                let d2 = (p - q).norm_squared();
                best = best.min(d2);
                let d = d2.sqrt();
                for k in [i, j] {
                    if let Some(near) = self.nearest_m.get_mut(k) {
                        *near = near.min(d);
                    }
                }
            }
        }
        best
    }
}

/// The smallest clearances of a flight so far, m (`+inf` before the first sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinClearances {
    /// UAV surface to UAV surface.
    pub uav_uav_m: f64,
    /// UAV surface to the tube's boundary (negative: the body crosses it).
    pub uav_boundary_m: f64,
    /// UAV bodies, the load and every attached cable against the obstacles.
    pub obstacle_m: f64,
}

/// Running surface-to-surface clearances of one flight.
#[derive(Debug, Clone)]
pub struct Clearances {
    uav_radius_m: f64,
    load_radius_m: f64,
    obstacles: Obstacles,
    /// Per UAV, the segment its last tube lookup answered (the next lookup's warm start).
    hints: Vec<usize>,
    /// Per UAV, what its last boundary measurement proves about the samples after it.
    boundary: Vec<Option<BoundaryAnchor>>,
    /// The tube the anchors that read all of it were made on.
    seen: TubeSeen,
    /// Tube lookups made (tests: how many the anchors saved).
    #[cfg(test)]
    lookups: usize,
    /// Per UAV, its last measured obstacle clearance (centre, before the envelope).
    uav_measured: Vec<Measured>,
    /// Per cable, its last measured obstacle clearance (UAV centre to load centre).
    cable_measured: Vec<Measured>,
    /// The load centre's last measured obstacle clearance.
    load_measured: Measured,
    /// The closest pair's bookkeeping.
    pairs: ClosestPair,
    min: MinClearances,
}

impl Clearances {
    /// Clearances for `n` UAVs of envelope radius `uav_radius_m` and a load of radius
    /// `load_radius_m` (m) among `obstacles`.
    pub fn new(n: usize, uav_radius_m: f64, load_radius_m: f64, obstacles: Obstacles) -> Self {
        let inf = f64::INFINITY;
        Self {
            uav_radius_m,
            load_radius_m,
            obstacles,
            hints: vec![0; n],
            boundary: vec![None; n],
            seen: TubeSeen::default(),
            #[cfg(test)]
            lookups: 0,
            uav_measured: vec![Measured::NONE; n],
            cable_measured: vec![Measured::NONE; n],
            load_measured: Measured::NONE,
            pairs: ClosestPair::default(),
            min: MinClearances { uav_uav_m: inf, uav_boundary_m: inf, obstacle_m: inf },
        }
    }

    /// The clearances of a flight of `ls` with UAVs flown as `model`, and whether the UAVs have
    /// an envelope (`rigid_body` by default; a `point_mass` team is the paper's points, judged
    /// on its centre distances). Success requires the clearances when they have one and the
    /// scenario gives `mission.clearance_floor_m`.
    pub fn for_flight(ls: &LoadedScenario, model: crate::models::UavModel) -> (Self, bool) {
        let s = &ls.scenario;
        let r = s.uavs.envelope_radius_m(model);
        (Self::new(s.cables.lengths_m.len(), r, s.load.envelope_radius_m(), Obstacles::of(ls)), r > 0.0)
    }

    /// One sample: UAV and load positions (m), which UAVs are down (`lost`, left out) and
    /// which cables are attached.
    pub fn sample(&mut self, uav_pos_m: &[V3], load_pos_m: &V3, lost: &[bool], attached: &[bool], tube: &SimTube) {
        let r = self.uav_radius_m;
        let m = &mut self.min;
        let up = |i: usize| is_up(lost, i);
        // The closest pair by squared distance, one square root: `sqrt(x) - 2 r` is monotone,
        // so this is the minimum over the pairs of `|p_i - p_j| - 2 r`, bit for bit.
        let pair_sq = self.pairs.min_sq(uav_pos_m, lost, m.uav_uav_m + 2.0 * r);
        self.seen.new_sample();
        for (i, p) in uav_pos_m.iter().enumerate().filter(|(i, _)| up(*i)) {
            let xy = p.xy();
            let q = vt_tube::Vec2::new(xy.x as f32, xy.y as f32);
            // The lookup is skipped only when it certainly keeps the hint and the minimum
            // (`boundary`): every lookup made is the brute force's, bit for bit.
            let anchor = self.boundary.get_mut(i);
            let skip = anchor.as_deref().and_then(Option::as_ref).is_some_and(|a| a.skips([f64::from(q.x), f64::from(q.y)], m.uav_boundary_m, tube, &mut self.seen));
            if !skip {
                let hint = self.hints.get(i).copied().unwrap_or(0);
                let mut measured = None;
                #[cfg(test)]
                {
                    self.lookups += 1;
                }
                match tube.locate(q, hint) {
                    Some(sec) => {
                        if let Some(h) = self.hints.get_mut(i) {
                            *h = sec.segment;
                        }
                        let d = sec.boundary_distance_m(q);
                        m.uav_boundary_m = m.uav_boundary_m.min(f64::from(d) - r);
                        let scan = anchor.as_deref().and_then(Option::as_ref).and_then(BoundaryAnchor::scan);
                        measured = BoundaryAnchor::new(tube, sec.segment, [q.x, q.y], d, r, m.uav_boundary_m, &mut self.seen, scan);
                    }
                    None => m.uav_boundary_m = f64::NEG_INFINITY,
                }
                if let Some(a) = anchor {
                    *a = measured;
                }
            }
            if let Some(seen) = self.uav_measured.get_mut(i) {
                if !seen.above(xy, xy, m.obstacle_m + r) {
                    *seen = Measured { a: xy, b: xy, clearance_m: self.obstacles.point_m(xy) };
                    m.obstacle_m = m.obstacle_m.min(seen.clearance_m - r);
                }
            }
        }
        if pair_sq < f64::INFINITY {
            m.uav_uav_m = m.uav_uav_m.min(pair_sq.sqrt() - 2.0 * r);
        }
        let load_xy = load_pos_m.xy();
        let rl = self.load_radius_m;
        if !self.load_measured.above(load_xy, load_xy, m.obstacle_m + rl) {
            self.load_measured = Measured { a: load_xy, b: load_xy, clearance_m: self.obstacles.point_m(load_xy) };
            m.obstacle_m = m.obstacle_m.min(self.load_measured.clearance_m - rl);
        }
        for ((p, _), seen) in uav_pos_m.iter().zip(attached).zip(self.cable_measured.iter_mut()).filter(|((_, a), _)| **a) {
            let xy = p.xy();
            if !seen.above(xy, load_xy, m.obstacle_m) {
                *seen = Measured { a: xy, b: load_xy, clearance_m: self.obstacles.segment_m(xy, load_xy) };
                m.obstacle_m = m.obstacle_m.min(seen.clearance_m);
            }
        }
    }

    /// Adds an obstacle that appeared (issue 28): every body is measured against it anew.
    pub fn add_obstacle(&mut self, shape: &crate::map::Shape) {
        self.obstacles.add(shape);
        self.uav_measured.iter_mut().chain(self.cable_measured.iter_mut()).for_each(|m| *m = Measured::NONE);
        self.load_measured = Measured::NONE;
    }

    /// The smallest clearances so far.
    pub fn min(&self) -> MinClearances {
        self.min
    }

    /// The UAV envelope radius, m.
    pub fn uav_radius_m(&self) -> f64 {
        self.uav_radius_m
    }

    /// The load envelope radius, m.
    pub fn load_radius_m(&self) -> f64 {
        self.load_radius_m
    }
}

#[cfg(test)]
mod tests;
