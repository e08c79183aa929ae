//! Mission metrics: safety distances, tensions, load altitude, formation; the `summary.json`
//! criteria. Filled by the mission loop ([`crate::mission`]) at the rates it documents.

use crate::clearance::Clearances;
use crate::scenario::{Scenario, SimTube};
use crate::sim::ControllerKind;
use crate::summary::{CableBreak, Summary};
use nalgebra::Vector3;
use vt_dissipative::{Formation, TrayParams};

type V3 = Vector3<f64>;

fn v3f(v: &V3) -> Vector3<f32> {
    Vector3::new(v.x as f32, v.y as f32, v.z as f32)
}

/// RMS over UAV node pairs of |current - rest length|, nodes by the tray projection (UAV
/// and load positions, m).
pub fn formation_error<const N: usize>(uav_pos_m: &[V3], load_pos_m: &V3, formation: &Formation<N>, tray: &TrayParams) -> f64 {
    use vt_dissipative::springs::NodeId;
    let load = v3f(load_pos_m);
    let nodes: Vec<_> = uav_pos_m.iter().map(|u| tray.project(&v3f(u), &load).0).collect();
    let (mut sum, mut count) = (0.0f64, 0usize);
    for i in 0..nodes.len() {
        for j in i + 1..nodes.len() {
            let l = f64::from((nodes[i] - nodes[j]).norm());
            let l0 = f64::from(formation.rest_length_m(NodeId::Uav(i), NodeId::Uav(j)));
            sum += (l - l0).powi(2);
            count += 1;
        }
    }
    if count == 0 { 0.0 } else { (sum / count as f64).sqrt() }
}

/// Where each body was last found along the tube: the segment hints of `Tube::locate`.
#[derive(Debug, Clone, Default)]
pub struct TubeHints {
    /// Per UAV.
    pub uav: Vec<usize>,
    /// The load.
    pub load: usize,
}

impl TubeHints {
    /// Hints for `n` UAVs, all at the tube's start.
    pub fn new(n: usize) -> Self {
        Self { uav: vec![0; n], load: 0 }
    }
}

/// Running metrics of a mission.
pub struct Metrics {
    n: usize,
    f_max: f64,
    /// Tension above which cable-time counts as over the rated capacity, N.
    rated: f64,
    above_rated_count: u64,
    /// Cables that broke (plant), in order.
    pub(crate) breaks: Vec<CableBreak>,
    /// Cables cut by an injected fault.
    pub(crate) snapped_by_fault: usize,
    settle_s: f64,
    alt_ref: f64,
    end_s: f32,
    /// The load's horizontal path so far, m, and where it was last sampled.
    pub(crate) load_path_m: f64,
    load_last_xy: Option<(f64, f64)>,
    /// `mission.end_tolerance_m`, m.
    end_tol: f32,
    now_uav_boundary: f64,
    now_load_boundary: f64,
    now_uav_uav: f64,
    min_uav_boundary: f64,
    min_load_boundary: f64,
    min_uav_uav: f64,
    max_alt_err: f64,
    max_tension: f64,
    tension_sum: f64,
    tension_count: u64,
    cap_count: u64,
    cv_sum: f64,
    cv_count: u64,
    pub(crate) max_thrust_fraction: f64,
    pub(crate) arrived: bool,
    /// The load-altitude criterion applies now (a ground start: in its transport phase only).
    pub(crate) judge_altitude: bool,
    pub(crate) nonfinite: bool,
    pub(crate) invalid_commands: u64,
    /// Surface-to-surface clearances at the plant rate (issue 27).
    pub(crate) clearances: Clearances,
    /// Success requires the clearances (UAVs with an envelope, the rigid-body plant's default).
    judge_clearances: bool,
}

impl Metrics {
    /// Metrics of a flight of `n` UAVs; `clearances` judged when `judge_clearances`.
    pub(crate) fn new(n: usize, f_max: f64, s: &Scenario, tube_len: f32, clearances: Clearances, judge_clearances: bool) -> Self {
        Self {
            clearances,
            judge_clearances,
            n,
            f_max,
            rated: f_max,
            above_rated_count: 0,
            breaks: Vec::new(),
            snapped_by_fault: 0,
            settle_s: s.mission.settle_time_s,
            alt_ref: s.load.altitude_m,
            end_s: tube_len - s.mission.end_tolerance_m as f32,
            end_tol: s.mission.end_tolerance_m as f32,
            load_path_m: 0.0,
            load_last_xy: None,
            now_uav_boundary: f64::INFINITY,
            now_load_boundary: f64::INFINITY,
            now_uav_uav: f64::INFINITY,
            min_uav_boundary: f64::INFINITY,
            min_load_boundary: f64::INFINITY,
            min_uav_uav: f64::INFINITY,
            max_alt_err: 0.0,
            max_tension: 0.0,
            tension_sum: 0.0,
            tension_count: 0,
            cap_count: 0,
            cv_sum: 0.0,
            cv_count: 0,
            max_thrust_fraction: 0.0,
            arrived: false,
            judge_altitude: true,
            nonfinite: false,
            invalid_commands: 0,
        }
    }

    /// Safety distances at one instant (UAV and load positions, m); UAVs that lost thrust
    /// (fallen) are left out.
    pub(crate) fn geometry(&mut self, t: f64, uav_pos_m: &[V3], load_pos_m: &V3, tube: &SimTube, hints: &mut TubeHints, lost: &[bool]) {
        let TubeHints { uav: uav_hints, load: load_hint } = hints;
        let xy = |v: &V3| vt_tube::Vec2::new(v.x as f32, v.y as f32);
        let mut ub = f64::INFINITY;
        for ((u, h), _) in uav_pos_m.iter().zip(uav_hints.iter_mut()).zip(lost.iter()).filter(|(_, l)| !**l) {
            let q = xy(u);
            match tube.locate(q, *h) {
                Some(sec) => {
                    *h = sec.segment;
                    ub = ub.min(f64::from(sec.boundary_distance_m(q)));
                }
                None => ub = f64::NEG_INFINITY,
            }
        }
        if let Some((x, y)) = self.load_last_xy {
            self.load_path_m += (load_pos_m.x - x).hypot(load_pos_m.y - y);
        }
        self.load_last_xy = Some((load_pos_m.x, load_pos_m.y));
        let ql = xy(load_pos_m);
        let lb = match tube.locate(ql, *load_hint) {
            Some(sec) => {
                *load_hint = sec.segment;
                if sec.s_m >= self.end_s {
                    self.arrived = true;
                }
                f64::from(sec.boundary_distance_m(ql))
            }
            None => f64::NEG_INFINITY,
        };
        let mut uu = f64::INFINITY;
        for i in 0..self.n {
            for j in i + 1..self.n {
                if !lost[i] && !lost[j] {
                    uu = uu.min((uav_pos_m[i] - uav_pos_m[j]).norm());
                }
            }
        }
        self.now_uav_boundary = ub;
        self.now_load_boundary = lb;
        self.now_uav_uav = uu;
        self.min_uav_boundary = self.min_uav_boundary.min(ub);
        self.min_load_boundary = self.min_load_boundary.min(lb);
        self.min_uav_uav = self.min_uav_uav.min(uu);
        if t >= self.settle_s && self.judge_altitude {
            self.max_alt_err = self.max_alt_err.max((load_pos_m.z - self.alt_ref).abs());
        }
    }

    pub(crate) fn tensions(&mut self, tensions: &[f64]) {
        for &x in tensions {
            self.max_tension = self.max_tension.max(x);
            self.tension_sum += x;
            self.tension_count += 1;
            if x >= self.f_max * (1.0 - 1e-9) {
                self.cap_count += 1;
            }
            if x > self.rated {
                self.above_rated_count += 1;
            }
        }
    }

    /// std/mean over the taut cables of one sample.
    pub(crate) fn tension_sample(&mut self, tensions: &[f64]) {
        const TAUT_N: f64 = 0.1;
        let taut: Vec<f64> = tensions.iter().copied().filter(|&x| x > TAUT_N).collect();
        if taut.len() >= 2 {
            let mean = taut.iter().sum::<f64>() / taut.len() as f64;
            let var = taut.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / taut.len() as f64;
            self.cv_sum += var.sqrt() / mean;
            self.cv_count += 1;
        }
    }

    /// The tube flown changed (issue 28): arrival is at the new tube's end.
    pub(crate) fn set_tube_length(&mut self, tube_len: f32) {
        self.end_s = tube_len - self.end_tol;
    }

    /// Sets the rated capacity, N (time above it is reported).
    pub(crate) fn set_rated(&mut self, rated_n: f64) {
        self.rated = rated_n;
    }

    /// Minimum UAV-boundary distance at the last geometry sample, m.
    pub(crate) fn now_uav_boundary(&self) -> f64 {
        self.now_uav_boundary
    }

    /// Load-boundary distance at the last geometry sample, m.
    pub(crate) fn now_load_boundary(&self) -> f64 {
        self.now_load_boundary
    }

    /// Minimum UAV-UAV distance at the last geometry sample, m.
    pub(crate) fn now_uav_uav(&self) -> f64 {
        self.now_uav_uav
    }

    /// The summary of the flight described by `end`.
    pub(crate) fn finish(self, s: &Scenario, end: &FlightEnd) -> Summary {
        let FlightEnd { kind, seed, sim_s, wall_s, formation_error, capacity_margin, completion, shortened, uav_model, cable_model } = *end;
        let floor = s.mission.safety_distance_m;
        let mut failures = Vec::new();
        if !self.arrived {
            failures.push(if shortened {
                "load did not reach the end terminal (flight shortened by --duration)".to_string()
            } else {
                "load did not reach the end terminal within the time limit".to_string()
            });
        }
        if self.min_load_boundary <= 0.0 {
            failures.push(format!("load left the tube (min boundary distance {:.2} m)", self.min_load_boundary));
        }
        if self.min_uav_boundary < floor {
            failures.push(format!("UAV within {:.2} m of the tube boundary (floor {floor} m)", self.min_uav_boundary));
        }
        if self.min_uav_uav < floor {
            failures.push(format!("UAVs within {:.2} m of each other (floor {floor} m)", self.min_uav_uav));
        }
        let c = self.clearances.min();
        if let (true, Some(cf)) = (self.judge_clearances, s.mission.clearance_floor_m) {
            for (what, x) in [("UAV-UAV", c.uav_uav_m), ("UAV-boundary", c.uav_boundary_m), ("obstacle", c.obstacle_m)] {
                if x < cf {
                    failures.push(format!("{what} clearance {x:.2} m (floor {cf} m)"));
                }
            }
        }
        if self.max_alt_err > s.mission.altitude_tolerance_m {
            failures.push(format!("load altitude error {:.2} m > {} m", self.max_alt_err, s.mission.altitude_tolerance_m));
        }
        if self.nonfinite {
            failures.push("non-finite state".to_string());
        }
        for b in &self.breaks {
            failures.push(format!("cable {} broke at t = {:.2} s ({:.1} N > breaking {:.0} N)", b.uav, b.time_s, b.tension_n, b.breaking_n));
        }
        let fin = |x: f64| if x.is_finite() { x } else { -1.0 };
        // A clearance with nothing to measure against (no obstacles, a single UAV) is NaN
        // (`null` in summary.json, so that it reads back the same); outside the tube, -1 as above.
        let clr = |x: f64| if x.is_finite() { x } else if x < 0.0 { -1.0 } else { f64::NAN };
        Summary {
            scenario: s.name.clone(),
            controller: kind.name().into(),
            seed,
            success: failures.is_empty(),
            failures,
            reached_end: self.arrived,
            completion_time_s: completion,
            min_uav_boundary_m: fin(self.min_uav_boundary),
            min_load_boundary_m: fin(self.min_load_boundary),
            min_uav_uav_m: fin(self.min_uav_uav),
            min_uav_uav_clearance_m: clr(c.uav_uav_m),
            min_uav_boundary_clearance_m: clr(c.uav_boundary_m),
            min_obstacle_clearance_m: clr(c.obstacle_m),
            uav_body_radius_m: self.clearances.uav_radius_m(),
            load_radius_m: self.clearances.load_radius_m(),
            max_tension_n: self.max_tension,
            mean_tension_n: if self.tension_count > 0 { self.tension_sum / self.tension_count as f64 } else { 0.0 },
            tension_cv_mean: if self.cv_count > 0 { self.cv_sum / self.cv_count as f64 } else { 0.0 },
            time_at_cap_fraction: if self.tension_count > 0 { self.cap_count as f64 / self.tension_count as f64 } else { 0.0 },
            max_load_altitude_error_m: self.max_alt_err,
            max_thrust_fraction: self.max_thrust_fraction,
            formation_error_end_m: formation_error,
            capacity_margin,
            sim_time_s: sim_s,
            wall_time_s: wall_s,
            realtime_factor: if wall_s > 0.0 { sim_s / wall_s } else { f64::INFINITY },
            n_uavs: self.n,
            f_max_n: self.f_max,
            load_mass_kg: s.load.mass_kg,
            true_load_mass_kg: s.load.plant_mass_kg(),
            nonfinite: self.nonfinite,
            invalid_commands: self.invalid_commands,
            plant: "host".into(),
            uav_model: uav_model.into(),
            cable_model: cable_model.into(),
            rated_n: self.rated,
            time_above_rated_fraction: if self.tension_count > 0 { self.above_rated_count as f64 / self.tension_count as f64 } else { 0.0 },
            cables_broken: self.breaks.len(),
            cable_breaks: self.breaks,
            cables_cut_by_fault: self.snapped_by_fault,
            outcome: "flown".into(),
            start: s.mission.start.name().into(),
            phases: Vec::new(),
            lift_peak_tension_n: None,
            lift_share_spread: None,
            touchdown_speed_mps: None,
            perception: None,
        }
    }
}

/// How a flight ended and what it flew, for [`Metrics::finish`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct FlightEnd {
    /// Controller.
    pub kind: ControllerKind,
    /// Seed.
    pub seed: u64,
    /// Simulated time, s.
    pub sim_s: f64,
    /// Wall time of the loop, s.
    pub wall_s: f64,
    /// Formation error at the end, m.
    pub formation_error: f64,
    /// Capacity margin at take-off.
    pub capacity_margin: f64,
    /// Arrival time, s.
    pub completion: Option<f64>,
    /// Cut short by a duration limit.
    pub shortened: bool,
    /// UAV model name.
    pub uav_model: &'static str,
    /// Cable model name.
    pub cable_model: &'static str,
}
