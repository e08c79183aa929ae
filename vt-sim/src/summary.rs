//! Mission metrics and the `summary.json` contract.

use serde::{Deserialize, Deserializer, Serialize};

/// The run summary written to `summary.json` (a contract other tools read; read back by
/// `host-sim sweep merge`, where a non-finite number, written as `null`, reads as NaN).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// `dissipative` or `baseline`.
    pub controller: String,
    /// Seed of the run.
    pub seed: u64,
    /// All success criteria hold.
    pub success: bool,
    /// Why not, one entry per failed criterion.
    pub failures: Vec<String>,
    /// The load reached the end terminal.
    pub reached_end: bool,
    /// Time the load reached the end terminal, s (`null` if never).
    pub completion_time_s: Option<f64>,
    /// Minimum UAV distance to the tube boundary (horizontal), m.
    #[serde(deserialize_with = "f64_or_nan")]
    pub min_uav_boundary_m: f64,
    /// Minimum load distance to the tube boundary (horizontal), m.
    #[serde(deserialize_with = "f64_or_nan")]
    pub min_load_boundary_m: f64,
    /// Minimum UAV-UAV distance (3-D), m.
    #[serde(deserialize_with = "f64_or_nan")]
    pub min_uav_uav_m: f64,
    /// Smallest UAV-UAV clearance, surface to surface (envelopes `uav_body_radius_m`), at the
    /// plant rate, m (issue 27).
    #[serde(default = "nan", deserialize_with = "f64_or_nan")]
    pub min_uav_uav_clearance_m: f64,
    /// Smallest clearance of a UAV's envelope to the tube boundary, at the plant rate, m.
    #[serde(default = "nan", deserialize_with = "f64_or_nan")]
    pub min_uav_boundary_clearance_m: f64,
    /// Smallest clearance of the UAV bodies, the load (`load_radius_m`) and every attached cable
    /// to the world's real obstacles, at the plant rate, m (`null` when the world has none).
    #[serde(default = "nan", deserialize_with = "f64_or_nan")]
    pub min_obstacle_clearance_m: f64,
    /// UAV envelope radius the clearances used, m (0: points, the paper's).
    #[serde(default = "nan", deserialize_with = "f64_or_nan")]
    pub uav_body_radius_m: f64,
    /// Load envelope radius, m.
    #[serde(default = "nan", deserialize_with = "f64_or_nan")]
    pub load_radius_m: f64,
    /// Maximum cable tension, N.
    #[serde(deserialize_with = "f64_or_nan")]
    pub max_tension_n: f64,
    /// Mean cable tension over time and cables, N.
    #[serde(deserialize_with = "f64_or_nan")]
    pub mean_tension_n: f64,
    /// Time-mean of std/mean over taut cables.
    #[serde(deserialize_with = "f64_or_nan")]
    pub tension_cv_mean: f64,
    /// Fraction of cable-time spent at the `f_max` cap.
    #[serde(deserialize_with = "f64_or_nan")]
    pub time_at_cap_fraction: f64,
    /// Maximum load altitude error after take-off settling, m.
    #[serde(deserialize_with = "f64_or_nan")]
    pub max_load_altitude_error_m: f64,
    /// Maximum thrust over thrust limit.
    #[serde(deserialize_with = "f64_or_nan")]
    pub max_thrust_fraction: f64,
    /// RMS over UAV node pairs of |current - rest length| at the end of the run, m.
    #[serde(deserialize_with = "f64_or_nan")]
    pub formation_error_end_m: f64,
    /// Vertical capacity of the capped cables at the take-off lean over the load's weight.
    #[serde(deserialize_with = "f64_or_nan")]
    pub capacity_margin: f64,
    /// Simulated time, s.
    #[serde(deserialize_with = "f64_or_nan")]
    pub sim_time_s: f64,
    /// Wall-clock time of the simulation loop, s.
    #[serde(deserialize_with = "f64_or_nan")]
    pub wall_time_s: f64,
    /// Simulated seconds per wall second.
    #[serde(deserialize_with = "f64_or_nan")]
    pub realtime_factor: f64,
    /// Number of UAVs.
    pub n_uavs: usize,
    /// Cable capacity, N.
    #[serde(deserialize_with = "f64_or_nan")]
    pub f_max_n: f64,
    /// Load mass, kg (as declared to the controllers: the scenario's `load.mass_kg`).
    #[serde(deserialize_with = "f64_or_nan")]
    pub load_mass_kg: f64,
    /// Load mass the plant flew, kg, before disturbance draws (`load.true_mass_kg`, else the
    /// declared mass; issue 15).
    #[serde(deserialize_with = "f64_or_nan")]
    pub true_load_mass_kg: f64,
    /// A non-finite value appeared in the plant state.
    pub nonfinite: bool,
    /// High-level commands that fell back to hold (invalid input or non-finite synthesis).
    pub invalid_commands: u64,
    /// Whose physics flew the mission: `host` (host-sim's plant) or `rotorpy` (RotorPy behind
    /// `host-sim sitl --plant rotorpy`, scored with `host-sim score`; docs/plant.md).
    pub plant: String,
    /// UAV model of the plant (`rigid_body` or `point_mass`, docs/plant.md).
    pub uav_model: String,
    /// Cable model of the plant (`elastic` or `paper_clamp`, docs/plant.md).
    pub cable_model: String,
    /// Rated cable capacity, N (the paper's per-UAV `f_max`).
    #[serde(deserialize_with = "f64_or_nan")]
    pub rated_n: f64,
    /// Fraction of cable-time with the tension above `rated_n` (0 for `paper_clamp`, which caps it).
    #[serde(deserialize_with = "f64_or_nan")]
    pub time_above_rated_fraction: f64,
    /// Cables that broke (tension above `breaking_n`; an injected `cable_snap` fault is not counted).
    pub cables_broken: usize,
    /// Each break: cable, time, tension.
    pub cable_breaks: Vec<CableBreak>,
    /// Cables cut by injected `cable_snap` faults.
    pub cables_cut_by_fault: usize,
    /// `flown`; `refused` before take-off (a campaign's run whose declared wind the team
    /// cannot hold: nothing flew, the distances are NaN; issue 29) or on the ground (a ground
    /// start's arming or lift); `set_down`: a ground start set the load down before the end
    /// because the team could not hold the tube.
    #[serde(default = "flown")]
    pub outcome: String,
    /// Where the mission started: `air` (the paper) or `ground` (issue 27).
    #[serde(default = "air")]
    pub start: String,
    /// Ground start: each phase the team entered, in order, with when the first UAV entered it
    /// and the load's swing then (empty for an air start).
    #[serde(default)]
    pub phases: Vec<PhaseMark>,
    /// Ground start: the highest cable tension from the start until the transport began (the
    /// snatch of the lift), N.
    #[serde(default)]
    pub lift_peak_tension_n: Option<f64>,
    /// Ground start: `(max - min) / mean` of the cable tensions when the load left the ground.
    #[serde(default)]
    pub lift_share_spread: Option<f64>,
    /// Ground start: the load's downward speed when it touched the ground again, m/s.
    #[serde(default)]
    pub touchdown_speed_mps: Option<f64>,
    /// Issue 28: what the team's onboard perception did (`None`: the map was known).
    #[serde(default)]
    pub perception: Option<PerceptionSummary>,
}

/// Issue 28: a flight whose tube was generated in flight.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PerceptionSummary {
    /// Re-plans started by the team's planner.
    pub replans: u32,
    /// Re-plans that gave a tube.
    pub planned: u32,
    /// Switches to a new tube, summed over the companions.
    pub tube_switches: u32,
    /// Offers a companion declined (it kept its tube), summed over the companions.
    pub tubes_kept: u32,
    /// The flight failed for want of a route: the team held in place for it and the load
    /// never reached the goal (held at the end, or the time ran out after it held).
    pub no_route: bool,
    /// The onboard occupancy map's RAM per companion, bytes.
    pub map_ram_bytes: usize,
    /// The load's horizontal path, m.
    pub load_path_m: f64,
    /// What the load would fly on the known map's plan: its generator from the load's start
    /// to the arrival point (`start_s_m` and `end_tolerance_m` off its length), m.
    pub known_plan_path_m: f64,
    /// `load_path_m / known_plan_path_m` (issue 28's target: <= 1.3).
    pub path_ratio: f64,
}

fn flown() -> String {
    "flown".into()
}

fn air() -> String {
    "air".into()
}

/// The start of one phase of a ground-start mission.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PhaseMark {
    /// The phase (`takeoff`, `tension`, `lift`, `climb`, `transport`, `descent`, `slack`,
    /// `released`).
    pub name: String,
    /// When the first UAV entered it, s.
    pub start_s: f64,
    /// The load's swing then: the angle from the vertical of the line from the attached UAVs'
    /// centroid to the load, deg.
    pub swing_deg: f64,
}

/// One cable that broke in flight.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct CableBreak {
    /// Index of the cable (= its UAV).
    pub uav: usize,
    /// Simulated time of the break, s.
    #[serde(deserialize_with = "f64_or_nan")]
    pub time_s: f64,
    /// Tension that broke it, N.
    #[serde(deserialize_with = "f64_or_nan")]
    pub tension_n: f64,
    /// Its breaking strength, N.
    #[serde(deserialize_with = "f64_or_nan")]
    pub breaking_n: f64,
}

impl Summary {
    /// The summary of a run refused before take-off for `reason`: not a success, nothing flown
    /// (distances and tensions NaN, which the sweep statistics skip).
    #[must_use]
    pub fn refused(s: &crate::scenario::Scenario, controller: &str, seed: u64, reason: String) -> Self {
        let nan = f64::NAN;
        Self {
            scenario: s.name.clone(),
            controller: controller.into(),
            seed,
            success: false,
            failures: vec![format!("refused before take-off: {reason}")],
            reached_end: false,
            completion_time_s: None,
            min_uav_boundary_m: nan,
            min_load_boundary_m: nan,
            min_uav_uav_m: nan,
            min_uav_uav_clearance_m: nan,
            min_uav_boundary_clearance_m: nan,
            min_obstacle_clearance_m: nan,
            uav_body_radius_m: s.uavs.envelope_radius_m(s.uavs.model),
            load_radius_m: s.load.envelope_radius_m(),
            max_tension_n: nan,
            mean_tension_n: nan,
            tension_cv_mean: nan,
            time_at_cap_fraction: nan,
            max_load_altitude_error_m: nan,
            max_thrust_fraction: nan,
            formation_error_end_m: nan,
            capacity_margin: nan,
            sim_time_s: 0.0,
            wall_time_s: 0.0,
            realtime_factor: nan,
            n_uavs: s.cables.lengths_m.len(),
            f_max_n: s.cables.rated_n,
            load_mass_kg: s.load.mass_kg,
            true_load_mass_kg: s.load.plant_mass_kg(),
            nonfinite: false,
            invalid_commands: 0,
            plant: "host".into(),
            uav_model: s.uavs.model.name().into(),
            cable_model: s.cables.model.name().into(),
            rated_n: s.cables.rated_n,
            time_above_rated_fraction: nan,
            cables_broken: 0,
            cable_breaks: Vec::new(),
            cables_cut_by_fault: 0,
            outcome: "refused".into(),
            start: s.mission.start.name().into(),
            phases: Vec::new(),
            lift_peak_tension_n: None,
            lift_share_spread: None,
            touchdown_speed_mps: None,
            perception: None,
        }
    }

    /// The team refused its start: before take-off (nothing flew, `sim_time_s` 0) or on the
    /// ground before the lift (it took off and landed).
    pub fn was_refused(&self) -> bool {
        self.outcome == "refused"
    }

    /// Rows for the terminal table: (label, value).
    pub fn table_rows(&self) -> Vec<(&'static str, String)> {
        let opt = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |v| format!("{v:.1} s"));
        vec![
            ("scenario", self.scenario.clone()),
            ("controller", self.controller.clone()),
            ("success", if self.success { "yes".into() } else { format!("NO ({})", self.failures.join("; ")) }),
            ("completion time", opt(self.completion_time_s)),
            ("min UAV-boundary", format!("{:.3} m", self.min_uav_boundary_m)),
            ("min load-boundary", format!("{:.3} m", self.min_load_boundary_m)),
            ("min UAV-UAV", format!("{:.3} m", self.min_uav_uav_m)),
            ("clearances", {
                // A world without obstacles has no obstacle clearance (NaN, `null` in the JSON).
                let obstacles = if self.min_obstacle_clearance_m.is_nan() { "no obstacles".to_string() } else { format!("{:.3} to obstacles", self.min_obstacle_clearance_m) };
                format!(
                    "{:.3} UAV-UAV, {:.3} UAV-boundary, {obstacles} (m; bodies {:.3} m, load {:.3} m)",
                    self.min_uav_uav_clearance_m, self.min_uav_boundary_clearance_m, self.uav_body_radius_m, self.load_radius_m
                )
            }),
            ("plant", format!("{}: {} UAVs, {} cables", self.plant, self.uav_model, self.cable_model)),
            ("max / mean tension", format!("{:.1} / {:.1} N (rated {:.0} N)", self.max_tension_n, self.mean_tension_n, self.rated_n)),
            ("time above rated", format!("{:.1} %  (cables broken: {})", 100.0 * self.time_above_rated_fraction, self.cables_broken)),
            ("tension std/mean", format!("{:.3}", self.tension_cv_mean)),
            ("time at cap", format!("{:.1} %", 100.0 * self.time_at_cap_fraction)),
            ("max load alt. error", format!("{:.3} m", self.max_load_altitude_error_m)),
            ("max thrust fraction", format!("{:.2}", self.max_thrust_fraction)),
            ("formation error end", format!("{:.3} m", self.formation_error_end_m)),
            ("capacity margin", format!("{:+.1} %", 100.0 * (self.capacity_margin - 1.0))),
            ("sim / wall time", {
                // Enough digits for slow (PIL, below 1x) and fast (SIL, 1000x) runs alike.
                let rt = self.realtime_factor;
                let digits = if rt >= 10.0 { 0 } else if rt >= 1.0 { 1 } else { 2 };
                format!("{:.1} s / {:.2} s ({rt:.digits$}x real time)", self.sim_time_s, self.wall_time_s)
            }),
        ]
    }

    /// The table as text.
    pub fn table(&self) -> String {
        let w = self.table_rows().iter().map(|r| r.0.len()).max().unwrap_or(0);
        self.table_rows().iter().map(|(k, v)| format!("  {k:<w$}  {v}\n")).collect()
    }
}

/// NaN: the value of a key a summary written before it existed lacks.
fn nan() -> f64 {
    f64::NAN
}

/// A number of `summary.json`: JSON has no NaN or infinity, so serde_json writes them as
/// `null`; `null` reads back as NaN (the sweep statistics skip non-finite values either way).
///
/// # Errors
/// The value is neither a number nor `null`.
pub fn f64_or_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

impl Summary {
    /// Issue 28: adds what the team's perception did; a flight that ended without a route is
    /// a failure with that reason (outcome `no_route`).
    pub fn perception(&mut self, ls: &crate::scenario::LoadedScenario, r: &crate::mission::replan::ReplanStats, load_path_m: f64) {
        let s = &ls.scenario;
        let known = s.tube.plan.as_ref().and_then(|spec| {
            let m = ls.plan.as_ref().map(|p| p.map.clone())?;
            m.plan(spec.start, spec.goal, &crate::plan::params_of(s, spec)).ok().map(|t| crate::scenario::SimTube::from_waypoints(&t.waypoints).map(|t| f64::from(t.length_m())))
        });
        let known_plan_path_m = match known {
            Some(Ok(len)) => len - s.load.start_s_m - s.mission.end_tolerance_m,
            _ => f64::NAN,
        };
        // The tube is the only guard a team has against what it has not seen: in a flight that
        // generates its tube, a body or cable touching an obstacle is a failure whatever the
        // clearance floor.
        if self.min_obstacle_clearance_m < 0.0 {
            self.success = false;
            self.failures.push(format!("touched an obstacle (clearance {:.2} m)", self.min_obstacle_clearance_m));
        }
        // A team that held for want of a route and then probed a way through cells it had not
        // seen yet, but never got to the goal, failed for want of a route all the same.
        let no_route = r.no_route || (r.no_route_seen && !self.reached_end);
        if no_route {
            self.success = false;
            self.outcome = "no_route".into();
            self.failures.insert(0, "no route to the goal on the map as seen: the team held in place".into());
        }
        self.perception = Some(PerceptionSummary {
            replans: r.replans,
            planned: r.planned,
            tube_switches: r.switches,
            tubes_kept: r.kept,
            no_route,
            map_ram_bytes: r.map_ram_bytes,
            load_path_m,
            known_plan_path_m,
            path_ratio: load_path_m / known_plan_path_m,
        });
    }
}
