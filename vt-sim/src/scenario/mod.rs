//! Scenario files: TOML, parsed with serde, validated with errors that name the field and
//! its line. The paper's 10-UAV mission is compiled in as the default.

use serde::Deserialize;
use std::fmt;
use std::path::Path;
use crate::models::{check_cable_integration, CableModel, StiffnessError, UavModel, DEFAULT_BREAKING_FACTOR, MAX_DAMPING_H, MAX_OMEGA_H};
use vt_tube::{Tube, Waypoint};

/// Team capacity of the simulator, UAVs: the controllers' fixed-size arrays are instantiated
/// with it in host-sim (`DissipativeController<SIM_MAX_UAVS>`). The firmware keeps the crates'
/// default `vt_dissipative::MAX_UAVS` (32): an MCU sizes its team at build time.
pub const SIM_MAX_UAVS: usize = 128;

/// The paper's simulation scenario, compiled in (also at `scenarios/paper-10uav.toml`).
pub const PAPER_10UAV: &str = include_str!("../../../scenarios/paper-10uav.toml");

/// The paper experiment's scenario (three 1.47 kg UAVs), as shipped.
pub const EXPERIMENT_3UAV: &str = include_str!("../../../scenarios/experiment-3uav.toml");

/// Name shown for the compiled-in default.
pub const DEFAULT_SCENARIO_NAME: &str = "scenarios/paper-10uav.toml (built in)";

/// Arc-length table size of the simulated tube (the firmware uses the same).
pub const TUBE_SAMPLES: usize = vt_tube::DEFAULT_SAMPLES;
/// The tube type every controller in the simulator uses.
pub type SimTube = Tube<TUBE_SAMPLES>;

/// A scenario error: what is wrong, where, and (when known) the line.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioError {
    /// File name or description of the source.
    pub source_name: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// Dotted field path (`load.mass_kg`), when known.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.source_name)?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        write!(f, ": ")?;
        if let Some(field) = &self.field {
            write!(f, "`{field}`: ")?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for ScenarioError {}

/// A whole scenario.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name.
    pub name: String,
    /// One-paragraph description.
    #[serde(default)]
    pub description: String,
    /// Default random seed (link drops and, later, disturbances).
    #[serde(default)]
    pub seed: u64,
    /// Space and obstacles.
    pub world: World,
    /// The virtual tube.
    pub tube: TubeSpec,
    /// The load.
    pub load: LoadSpec,
    /// The UAVs.
    pub uavs: UavSpec,
    /// The cables.
    pub cables: CableSpec,
    /// High-level dissipative controller.
    pub controller: ControllerSpec,
    /// Baseline (traditional virtual tube) controller; published parameters by default.
    #[serde(default)]
    pub baseline: BaselineSpec,
    /// Low-level velocity loop and CFO.
    pub velocity_loop: VelocityLoopSpec,
    /// Loop rates.
    pub rates: Rates,
    /// Link between UAVs.
    #[serde(default)]
    pub link: LinkSpec,
    /// Mission limits and success criteria.
    pub mission: MissionSpec,
    /// Disturbances and uncertainty (all off by default; seeded).
    #[serde(default)]
    pub disturbances: DisturbanceSpec,
    /// How the receivers see positions (issue 27; white noise by default).
    #[serde(default)]
    pub sensing: crate::sensing::SensingSpec,
    /// Faults injected at given times.
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// Team failsafe (docs/design.md, "Team failsafe").
    #[serde(default)]
    pub failsafe: FailsafeSpec,
    /// The pre-flight feasibility check (docs/design.md, "Pre-flight feasibility check").
    #[serde(default)]
    pub preflight: PreflightSpec,
    /// What the team knows of the map and how it re-plans (issue 28).
    #[serde(default)]
    pub perception: PerceptionSpec,
    /// Sensors beyond the autopilot's: the LiDAR (issue 28).
    #[serde(default)]
    pub sensors: SensorsSpec,
}

/// What a UAV does when a neighbour's data go stale (`link.stale_timeout_s`).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StaleNeighbour {
    /// Drop its springs and fly on (the paper's Remark 2 reading; the firmware's `FS_NBR_ACT = 0`).
    #[default]
    Drop,
    /// The team holds (the firmware's default `FS_NBR_ACT = 1`).
    Hold,
}

/// Team failsafe settings (docs/design.md, "Team failsafe"; the firmware's `FS_NBR_ACT`,
/// `FS_RESUME`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailsafeSpec {
    /// Stale neighbour: `drop` (default) or `hold`.
    #[serde(default)]
    pub stale_neighbour: StaleNeighbour,
    /// The team resumes this long after the last alarm, s (rounded to high-level periods).
    #[serde(default = "default_resume_s")]
    pub resume_s: f64,
}

impl Default for FailsafeSpec {
    fn default() -> Self {
        Self { stale_neighbour: StaleNeighbour::Drop, resume_s: default_resume_s() }
    }
}

fn default_resume_s() -> f64 {
    1.0
}

/// The pre-flight feasibility check's requirement.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PreflightSpec {
    /// Required vertical-force margin `F_avail / F_need - 1`, fraction (default 0.01 = 1 %;
    /// in (-1, 10]). A negative margin flies a load past the team's capacity on purpose.
    #[serde(default = "default_min_margin")]
    pub min_margin: f64,
    /// Fraction of each UAV's largest thrust the check keeps for control (default 0.1; in
    /// [0, 0.5]): the rotors are rated at `(1 - thrust_reserve) thrust_max_n`.
    #[serde(default = "default_thrust_reserve")]
    pub thrust_reserve: f64,
}

impl Default for PreflightSpec {
    fn default() -> Self {
        Self { min_margin: default_min_margin(), thrust_reserve: default_thrust_reserve() }
    }
}

fn default_thrust_reserve() -> f64 {
    f64::from(vt_dissipative::feasibility::DEFAULT_THRUST_RESERVE)
}

fn default_min_margin() -> f64 {
    f64::from(vt_dissipative::feasibility::DEFAULT_MIN_MARGIN)
}

/// What goes wrong.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// The UAV's cable snaps.
    CableSnap,
    /// The UAV stops transmitting its position.
    UavSilent,
    /// The UAV loses all thrust and falls with its cable attached.
    ThrustLoss,
    /// The UAV's own `LOCAL_POSITION_NED` stops reaching its companion for `duration_s`
    /// (the team network still carries its position).
    OwnFeedStall,
    /// The UAV's team link dies for good: it neither sends nor receives team data.
    LinkDead,
}

/// One fault.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    /// Kind of fault.
    pub kind: FaultKind,
    /// Affected UAV (0-based).
    pub uav: usize,
    /// Time of the fault, s.
    pub time_s: f64,
    /// How long the fault lasts, s (`own_feed_stall` only, where it is required).
    #[serde(default)]
    pub duration_s: Option<f64>,
}

/// The flight space.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// `[x_min, x_max, y_min, y_max]`, m.
    pub bounds_m: [f64; 4],
    /// Ceiling, m.
    #[serde(default = "default_ceiling")]
    pub ceiling_m: f64,
    /// Vertical cylindrical obstacles.
    #[serde(default)]
    pub obstacles: Vec<ObstacleSpec>,
    /// Obstacles that appear in flight (issue 28).
    #[serde(default)]
    pub appear: Vec<AppearSpec>,
}

fn default_ceiling() -> f64 {
    20.0
}

/// One obstacle.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// Centre `[x, y]`, m.
    pub center_m: [f64; 2],
    /// Radius, m.
    pub radius_m: f64,
}

/// The tube: waypoints `[x, y, w_left, w_right]` in metres.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TubeSpec {
    /// Waypoints `[x_m, y_m, w_left_m, w_right_m]` (filled by the planner when `plan` is given).
    #[serde(default)]
    pub waypoints: Vec<[f64; 4]>,
    /// Issue 16: plan the tube on a map instead of giving `waypoints` (exactly one of them).
    #[serde(default)]
    pub plan: Option<crate::plan::PlanSpec>,
}

impl TubeSpec {
    /// The waypoints as the controller crates take them (f32, m).
    pub fn waypoints_f32(&self) -> Vec<Waypoint> {
        self.waypoints.iter().map(|w| Waypoint::new(w[0] as f32, w[1] as f32, w[2] as f32, w[3] as f32)).collect()
    }
}

/// The load.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Altitude reference (and start altitude), m.
    pub altitude_m: f64,
    /// Start: arc length along the tube where the load starts, m.
    #[serde(default = "default_start_s")]
    pub start_s_m: f64,
    /// Mass the plant's load really has, kg, when it differs from the declared `mass_kg`
    /// (overload in flight, issue 15). Controllers, the take-off geometry and the checks use
    /// `mass_kg`; only the plant flies `true_mass_kg` (times `disturbances.load_mass_error`).
    #[serde(default)]
    pub true_mass_kg: Option<f64>,
    /// Radius of the sphere that bounds the load, m (issue 27; default
    /// [`LoadSpec::envelope_radius_m`]'s rule).
    #[serde(default)]
    pub radius_m: Option<f64>,
}

/// Mean density the default load envelope assumes: a crate of mixed cargo, kg/m^3 (project
/// choice; docs/plant.md, "Body envelope").
pub const LOAD_DENSITY_KG_M3: f64 = 500.0;

impl LoadSpec {
    /// Radius of the load's envelope, m: `radius_m`, else the sphere around a cube of
    /// [`LOAD_DENSITY_KG_M3`] holding the declared mass (`sqrt 3 / 2` times its side; 18 kg:
    /// 0.29 m).
    pub fn envelope_radius_m(&self) -> f64 {
        self.radius_m.unwrap_or_else(|| 0.5 * 3f64.sqrt() * (self.mass_kg / LOAD_DENSITY_KG_M3).cbrt())
    }

    /// The plant's load mass before disturbance draws, kg: `true_mass_kg`, else `mass_kg`.
    pub fn plant_mass_kg(&self) -> f64 {
        self.true_mass_kg.unwrap_or(self.mass_kg)
    }
}

fn default_start_s() -> f64 {
    4.0
}

/// The UAVs (all alike except for their cables).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UavSpec {
    /// Mass of each UAV, kg.
    pub mass_kg: f64,
    /// Maximum thrust of each UAV, N.
    pub thrust_max_n: f64,
    /// First-order thrust lag, s (0 = none).
    #[serde(default)]
    pub thrust_lag_s: f64,
    /// Maximum tilt, degrees.
    #[serde(default = "default_tilt")]
    pub tilt_max_deg: f64,
    /// Radius of the take-off node circle on the tray, m: the paper's ring, node `i` at angle
    /// `2 pi i / n` from the tube's direction. Give this or `formation_offsets_m`.
    #[serde(default)]
    pub formation_radius_m: Option<f64>,
    /// Take-off node offsets on the tray about the load, m, one `[x, y]` per cable in the
    /// cables' order, x along the tube's direction at the start and y to its left: any layout
    /// (two rings for a large team, docs/design.md "Take-off layouts other than the ring").
    /// Give this or `formation_radius_m`.
    #[serde(default)]
    pub formation_offsets_m: Option<Vec<[f64; 2]>>,
    /// UAV model of the plant: `rigid_body` (default) or `point_mass` (the paper's).
    #[serde(default)]
    pub model: UavModel,
    /// Radius of the sphere that bounds each UAV (rotors and guards), m (issue 27). Given, the
    /// companions keep it (`VT_BODY_R`: the separation barrier, a tube safety radius of at least
    /// `body_radius_m + clearance floor`); absent, the controller flies the paper's points and
    /// the clearances are measured with [`UavSpec::envelope_radius_m`]'s default.
    #[serde(default)]
    pub body_radius_m: Option<f64>,
    /// The rigid-body UAVs' autopilot: `tuned` (default, the project's rate gains, docs/plant.md)
    /// or `px4_default` (PX4's stock rate gains; issue 27).
    #[serde(default)]
    pub autopilot: AutopilotPreset,
    /// Battery sag: the fraction of the maximum thrust lost per minute of flight, from the
    /// start of the flight (issue 27; the firmware keeps believing `thrust_max_n`).
    #[serde(default)]
    pub battery_sag_per_min: f64,
}

/// Rate gains of the rigid-body UAVs' autopilot (`[uavs] autopilot`).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum AutopilotPreset {
    /// The project's tuned rate loop (rate P 25 1/s on the paper's airframe).
    #[default]
    Tuned,
    /// PX4's stock rate gains (`QuadParams::with_px4_default_rate_gains`).
    Px4Default,
}

impl UavSpec {
    /// The airframe of a rigid-body UAV of mass `mass_kg`: sized from it and `thrust_max_n`,
    /// behind the autopilot the scenario names.
    pub fn airframe(&self, mass_kg: f64) -> crate::quadrotor::QuadParams {
        let q = crate::quadrotor::QuadParams::sized(mass_kg, self.thrust_max_n);
        match self.autopilot {
            AutopilotPreset::Tuned => q,
            AutopilotPreset::Px4Default => q.with_px4_default_rate_gains(),
        }
    }

    /// The tube barrier's safety radius the companions fly, m: `r_safe_m`, raised to
    /// `body_radius_m + clearance floor` when the UAVs have a body (`vt_companion::Params::r_safe_m`).
    pub fn flown_r_safe_m(&self, r_safe_m: f64, clearance_floor_m: f64) -> f64 {
        match self.body_radius_m {
            Some(b) if b > 0.0 => r_safe_m.max(b + clearance_floor_m),
            _ => r_safe_m,
        }
    }

    /// Radius of a UAV's envelope flown as `model`, m: `body_radius_m`; else, for
    /// `rigid_body`, the sized airframe's rotor-tip radius plus its guard
    /// (`QuadParams::envelope_radius_m`, docs/plant.md "Body envelope"); for `point_mass`, 0:
    /// the paper's UAVs are points, judged on its centre distances.
    pub fn envelope_radius_m(&self, model: UavModel) -> f64 {
        self.body_radius_m.unwrap_or_else(|| match model {
            UavModel::RigidBody => crate::quadrotor::QuadParams::sized(self.mass_kg, self.thrust_max_n).envelope_radius_m(),
            UavModel::PointMass => 0.0,
        })
    }
}

fn default_tilt() -> f64 {
    35.0
}

/// The cables, one per UAV.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CableSpec {
    /// Unstretched length of each cable, m (one entry per UAV: defines the team size).
    pub lengths_m: Vec<f64>,
    /// Stiffness, N/m.
    pub stiffness_n_per_m: f64,
    /// Damping, N s/m.
    pub damping_ns_per_m: f64,
    /// Rated capacity per cable, N: the paper's `f_max` (20 N). The `paper_clamp` cable caps the
    /// tension here; the `elastic` cable reports the time above it. (`f_max_n` is accepted too.)
    #[serde(alias = "f_max_n")]
    pub rated_n: f64,
    /// Cable model of the plant: `elastic` (default) or `paper_clamp` (the paper's).
    #[serde(default)]
    pub model: CableModel,
    /// Breaking strength of the `elastic` cable, N (default `3 x rated_n`).
    #[serde(default)]
    pub breaking_n: Option<f64>,
}

impl CableSpec {
    /// Breaking strength, N: `breaking_n`, or [`DEFAULT_BREAKING_FACTOR`]` x rated_n`.
    pub fn breaking_strength_n(&self) -> f64 {
        self.breaking_n.unwrap_or(DEFAULT_BREAKING_FACTOR * self.rated_n)
    }
}

/// High-level controller parameters (paper Table II, REFERENCE §5).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// Passing gain.
    pub k1: f64,
    /// Spring gain.
    pub k2: f64,
    /// Tube barrier gain.
    pub k3: f64,
    /// Velocity limit, m/s.
    pub v_max_mps: f64,
    /// Tube barrier safety radius, m.
    pub r_safe_m: f64,
    /// Tube barrier activation radius, m.
    pub r_active_m: f64,
    /// Tray height above the load, m.
    pub tray_height_m: f64,
    /// Altitude gain, 1/s.
    #[serde(default = "one")]
    pub kz_per_s: f64,
    /// Vertical speed limit, m/s.
    #[serde(default = "one")]
    pub vz_max_mps: f64,
    /// Load-sharing gain k_T, (m/s)/N (0 disables load sharing).
    #[serde(default)]
    pub share_gain_mps_per_n: f64,
    /// Load-altitude gain k_L of the sharing integrator, 1/s.
    #[serde(default)]
    pub load_altitude_gain_per_s: f64,
    /// Bound on the sharing altitude offset, m.
    #[serde(default)]
    pub share_offset_max_m: f64,
    /// Take-off survey window: the take-off positions are averaged over this many samples per
    /// source before `MISSION_START` (`VT_CAL_N`; 1: the last sample; docs/design.md).
    #[serde(default = "default_survey_samples")]
    pub survey_samples: u32,
    /// Capacity-aware formation (issue 15).
    #[serde(default)]
    pub capacity: CapacitySpec,
    /// The formation shaped to the tube ahead (extension, issues 27 and 29).
    #[serde(default)]
    pub shape: ShapeSpec,
}

fn one() -> f64 {
    1.0
}

/// Baseline controller parameters (REFERENCE §2; published values by default, field by field:
/// a table that sets one field keeps the others' defaults).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BaselineSpec {
    /// Passing gain, m/s.
    pub k1: f64,
    /// Robot barrier gain.
    pub k2: f64,
    /// Tube barrier gain.
    pub k3: f64,
    /// Velocity limit, m/s.
    pub v_max_mps: f64,
    /// Safety radius, m.
    pub r_safe_m: f64,
    /// Activation radius, m.
    pub r_active_m: f64,
}

impl Default for BaselineSpec {
    fn default() -> Self {
        Self { k1: 2.0, k2: 1.0, k3: 1.0, v_max_mps: 3.0, r_safe_m: 0.5, r_active_m: 0.7 }
    }
}

/// Velocity loop (eq:2-3) and CFO (REFERENCE §4).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocityLoopSpec {
    /// Proportional gains per axis, 1/s.
    pub kp: [f64; 3],
    /// Integral gains per axis, 1/s^2.
    pub ki: [f64; 3],
    /// Derivative gains per axis.
    pub kd: [f64; 3],
    /// CFO bandwidth `mu`, rad/s.
    pub cfo_bandwidth_rad_s: f64,
    /// Time constant of the thrust the vehicle realises behind its autopilot, as the CFO
    /// models it, s (default 0: the paper's thrust = command).
    #[serde(default)]
    pub actuator_lag_s: f64,
    /// Time constant of the low-pass on the thrust demand, s (default 0: the paper's demand as
    /// it is; docs/design.md, "Thrust command filter").
    #[serde(default)]
    pub command_filter_s: f64,
    /// Fraction of the thrust limit kept for the horizontal part: the vertical component is
    /// capped at `thrust_max sqrt(1 - r^2)` (issue 15, "Overload in flight"; default 0, the
    /// paper's vertical priority; the rigid-body tuning has its own default).
    #[serde(default)]
    pub horizontal_reserve: f64,
    /// Tuning used instead when the UAVs are `rigid_body` (flying behind an attitude
    /// autopilot); fields left out take the project's rigid-body tuning
    /// ([`crate::models::RIGID_BODY_CFO_BANDWIDTH_RAD_S`], [`crate::models::RIGID_BODY_ACTUATOR_LAG_S`]).
    #[serde(default)]
    pub rigid_body: Option<VelocityLoopTuning>,
}

/// Observer tuning of the velocity loop for one UAV model (`[velocity_loop.rigid_body]`).
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocityLoopTuning {
    /// CFO bandwidth `mu`, rad/s.
    pub cfo_bandwidth_rad_s: Option<f64>,
    /// Actuator lag the CFO models, s.
    pub actuator_lag_s: Option<f64>,
    /// Time constant of the thrust command filter, s.
    pub command_filter_s: Option<f64>,
    /// Horizontal thrust reserve (issue 15).
    pub horizontal_reserve: Option<f64>,
}

impl VelocityLoopSpec {
    /// `(cfo_bandwidth_rad_s, actuator_lag_s, command_filter_s)` flown on UAV model `model`: the table's values
    /// for `point_mass`; `[velocity_loop.rigid_body]`, else the project's rigid-body tuning, for
    /// `rigid_body` (docs/design.md, "Velocity loop behind an attitude autopilot").
    #[must_use]
    pub fn tuning(&self, model: UavModel) -> (f64, f64, f64) {
        match model {
            UavModel::RigidBody => {
                let t = self.rigid_body.unwrap_or_default();
                (
                    t.cfo_bandwidth_rad_s.unwrap_or(crate::models::RIGID_BODY_CFO_BANDWIDTH_RAD_S),
                    t.actuator_lag_s.unwrap_or(crate::models::RIGID_BODY_ACTUATOR_LAG_S),
                    t.command_filter_s.unwrap_or(crate::models::RIGID_BODY_COMMAND_FILTER_S),
                )
            }
            UavModel::PointMass => (self.cfo_bandwidth_rad_s, self.actuator_lag_s, self.command_filter_s),
        }
    }

    /// Horizontal thrust reserve the scenario sets for UAV model `model`:
    /// `horizontal_reserve` for `point_mass`; `[velocity_loop.rigid_body] horizontal_reserve`
    /// for `rigid_body`, `None` when left to the airframe's default (sent as `VL_H_RES = -1`,
    /// derived aboard: `vt_companion::Params::horizontal_reserve`; docs/design.md, "Overload in
    /// flight").
    #[must_use]
    pub fn horizontal_reserve(&self, model: UavModel) -> Option<f64> {
        match model {
            UavModel::RigidBody => self.rigid_body.and_then(|t| t.horizontal_reserve),
            UavModel::PointMass => Some(self.horizontal_reserve),
        }
    }
}

/// Loop rates, Hz. The plant rate must be a multiple of the others.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rates {
    /// Plant integration rate.
    pub plant_hz: u32,
    /// Plant sub-steps per plant step (stiff cables).
    #[serde(default = "one_u32")]
    pub plant_substeps: u32,
    /// Velocity loop + CFO rate.
    pub low_level_hz: u32,
    /// Tube + springs rate.
    pub high_level_hz: u32,
    /// Trajectory record rate.
    pub record_hz: u32,
}

fn one_u32() -> u32 {
    1
}

/// Link model for neighbour positions (every field has its default: a table that sets one
/// field keeps the others', issue 29).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinkSpec {
    /// Delivery delay, s (rounded to high-level periods).
    pub delay_s: f64,
    /// Probability that one message is lost.
    pub drop_probability: f64,
    /// Age after which a neighbour is dropped from the spring set, s.
    pub stale_timeout_s: f64,
}

impl Default for LinkSpec {
    fn default() -> Self {
        Self { delay_s: 0.0, drop_probability: 0.0, stale_timeout_s: 0.5 }
    }
}

/// Mission limits and success criteria.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionSpec {
    /// Time limit, s.
    pub time_limit_s: f64,
    /// Where the mission starts (issue 27): in the air at the take-off formation with taut
    /// cables (the paper), or from the ground: the load resting on the ground, the UAVs hovering
    /// low with slack cables, the mission ending with the load set down (companion `VT_START`;
    /// docs/design.md, "Lift-off and set-down").
    #[serde(default)]
    pub start: MissionStart,
    /// The load has arrived when its section is within this of the end, m.
    #[serde(default = "one")]
    pub end_tolerance_m: f64,
    /// Time flown on after arrival (formation recovery is judged at the end), s.
    #[serde(default = "default_post")]
    pub post_arrival_s: f64,
    /// Take-off settling excluded from the load-altitude criterion, s.
    #[serde(default = "default_settle")]
    pub settle_time_s: f64,
    /// Safety floor for UAV-boundary and UAV-UAV distances, m.
    #[serde(default = "default_floor")]
    pub safety_distance_m: f64,
    /// Floor of every surface-to-surface clearance (UAV-UAV, UAV-boundary, bodies, load and
    /// cables against the obstacles), m. Given, success requires it (issue 27, docs/design.md
    /// "Envelopes and clearances"); absent, the clearances are reported and the companions keep
    /// [`DEFAULT_CLEARANCE_FLOOR_M`].
    #[serde(default)]
    pub clearance_floor_m: Option<f64>,
    /// Allowed load altitude error after settling, m.
    #[serde(default = "one")]
    pub altitude_tolerance_m: f64,
    /// Pre-flight: how long the team hovers at take-off, its autopilots holding position and
    /// streaming their measurements, before `MISSION_START`, s (rounded to high-level periods;
    /// the plant is held at its take-off state; docs/design.md, "Take-off survey").
    #[serde(default = "default_preflight")]
    pub preflight_s: f64,
    /// Declared steady wind at the site, m/s (a forecast or a measurement; companion
    /// `VT_WIND_DECL`). With it, a team that cannot hold this wind plus `gust_margin_mps` in the
    /// tube is refused before take-off (docs/design.md, "Wind capacity"). Absent: no wind check.
    #[serde(default)]
    pub max_wind_mps: Option<f64>,
    /// Gust margin added to `max_wind_mps` in the start check, m/s (`VT_WIND_GUST`).
    #[serde(default)]
    pub gust_margin_mps: f64,
}

/// Where a mission starts (`[mission] start`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissionStart {
    /// In the air at the take-off formation, cables taut, load at its altitude (the paper).
    #[default]
    Air,
    /// From the ground: lift-off, transport, set-down.
    Ground,
}

impl MissionStart {
    /// The scenario-file name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Air => "air",
            Self::Ground => "ground",
        }
    }
}

fn default_survey_samples() -> u32 {
    100
}

fn default_preflight() -> f64 {
    2.0
}

fn default_post() -> f64 {
    5.0
}
fn default_settle() -> f64 {
    3.0
}
fn default_floor() -> f64 {
    0.4
}
/// Clearance floor the companions keep when the scenario gives none (`VT_CLR_MIN`), m.
pub const DEFAULT_CLEARANCE_FLOOR_M: f64 = 0.2;

impl MissionSpec {
    /// The clearance floor, m: `clearance_floor_m` or [`DEFAULT_CLEARANCE_FLOOR_M`].
    pub fn clearance_floor(&self) -> f64 {
        self.clearance_floor_m.unwrap_or(DEFAULT_CLEARANCE_FLOOR_M)
    }
}

/// A scenario with its source (for error locations).
#[derive(Debug, Clone)]
pub struct LoadedScenario {
    /// The parsed scenario.
    pub scenario: Scenario,
    /// Where it came from.
    pub source_name: String,
    /// The validated tube.
    pub tube: SimTube,
    /// For a planned `[tube]`: the map and the planner's result (corridor, bottleneck).
    pub plan: Option<std::sync::Arc<crate::record::PlanScene>>,
}

/// Loads a scenario file, or the built-in paper scenario when `path` is `None`.
///
/// # Errors
/// Unreadable file, TOML syntax/type errors (with line), or a failed validation naming the field.
pub fn load(path: Option<&Path>) -> Result<LoadedScenario, ScenarioError> {
    match path {
        None => parse(PAPER_10UAV, DEFAULT_SCENARIO_NAME),
        Some(p) => {
            let name = p.display().to_string();
            let text = std::fs::read_to_string(p).map_err(|e| ScenarioError {
                source_name: name.clone(),
                line: None,
                field: None,
                message: format!("cannot read: {e}"),
            })?;
            parse(&text, &name)
        }
    }
}

/// Parses and validates scenario text.
///
/// # Errors
/// As [`load`].
pub fn parse(text: &str, source_name: &str) -> Result<LoadedScenario, ScenarioError> {
    let mut scenario: Scenario = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of_offset(text, s.start));
        let field = line.and_then(|l| field_at_line(text, l));
        ScenarioError { source_name: source_name.into(), line, field, message: e.message().trim().to_string() }
    })?;
    let plan = crate::plan::fill_planned_tube(&mut scenario, text, source_name)?.map(std::sync::Arc::new); // issue 16
    let v = Validator { text, source_name };
    let tube = v.check(&scenario)?;
    Ok(LoadedScenario { scenario, source_name: source_name.into(), tube, plan })
}

mod capacity;
mod disturbances;
mod formation;
pub mod generate;
mod perception;
mod shape;
mod validate;

pub use capacity::CapacitySpec;
pub use disturbances::{DisturbanceSpec, WIND_ONSET_RAMP_S};
pub use formation::MIN_NODE_SPACING_M;
pub use perception::{AppearSpec, MapKnowledge, PerceptionSpec, SensorsSpec};
pub use shape::ShapeSpec;

use validate::{field_at_line, line_of_offset, Validator};
