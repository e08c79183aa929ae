//! Software-in-the-loop entry point and the configuration shared by every backend: the
//! take-off geometry, the controllers' parameters from a scenario, the scene for plots.
//! The flight itself is [`crate::mission::fly`]; the control laws live in the crates.

use crate::mission::CrateTeam;
use crate::models::{CableModel, UavModel};
use crate::plant::GRAVITY_MPS2;
use crate::record::{Obstacle, RunRecord, SceneGeometry};
use crate::scenario::{LoadedScenario, Scenario, SimTube};
use crate::summary::Summary;
use nalgebra::Vector3;
use vt_cfo::{CfoParams, PidGains, ThrustLimits, VelocityLoop, VelocityLoopParams};
use vt_dissipative::{Calibration, CalibrationParams, CapacityParams, DissipativeParams, FeasibilityParams, TrayParams, VerticalParams};

type V3 = Vector3<f64>;
type V3f = Vector3<f32>;

/// Which high-level controller flies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerKind {
    /// The paper's dissipative controller.
    Dissipative,
    /// Traditional virtual-tube control (REFERENCE §2).
    Baseline,
}

impl ControllerKind {
    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Dissipative => "dissipative",
            Self::Baseline => "baseline",
        }
    }
}

/// Options of one run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Controller.
    pub controller: ControllerKind,
    /// Override of the cable capacity `f_max`, N.
    pub f_max_n: Option<f64>,
    /// Override of the scenario seed.
    pub seed: Option<u64>,
    /// Show a progress bar on a terminal.
    pub progress: bool,
    /// Keep the time histories (off for sweeps: summaries only).
    pub record: bool,
    /// Override of the scenario's UAV model.
    pub uav_model: Option<UavModel>,
    /// Override of the scenario's cable model.
    pub cable_model: Option<CableModel>,
    /// Stop the flight after this many simulated seconds (the summary says it was shortened).
    pub duration_s: Option<f64>,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self { controller: ControllerKind::Dissipative, f_max_n: None, seed: None, progress: false, record: true, uav_model: None, cable_model: None, duration_s: None }
    }
}

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct RunOutput {
    /// The metrics.
    pub summary: Summary,
    /// The sampled time histories.
    pub record: RunRecord,
    /// The scene, for plots.
    pub scene: SceneGeometry,
}

/// A run that could not start (the scenario's parameters were rejected by a crate).
#[derive(Debug, Clone, PartialEq)]
pub struct SimError(pub String);

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SimError {}


/// Take-off geometry shared by the plant set-up, the controllers and the metrics.
#[derive(Debug, Clone)]
pub struct Takeoff {
    /// Initial UAV positions, m.
    pub uav_pos_m: Vec<V3>,
    /// Initial load position, m.
    pub load_pos_m: V3,
    /// Static stretch of each cable under an equal share, m.
    pub stretch_m: f64,
    /// Equal share of the load's weight along each cable at the take-off lean, N.
    pub share_n: f64,
    /// Vertical capacity of the capped cables at the take-off lean / load weight.
    pub capacity_margin: f64,
}

/// Computes the take-off state: nodes on the formation circle around the load, cables taut
/// and stretched for an equal share of the load (REFERENCE §6).
pub fn takeoff(s: &Scenario, tube: &SimTube, f_max_n: f64) -> Takeoff {
    let n = s.cables.lengths_m.len();
    takeoff_with(s, tube, f_max_n, &s.cables.lengths_m, &vec![s.cables.stiffness_n_per_m; n])
}

/// [`takeoff`] for the plant's true cable lengths and stiffnesses: every cable taut at the
/// stretch its true stiffness gives under an equal share, so the true plant starts at rest.
/// `stretch_m` and `share_n` stay the nominal values (the controllers calibrate their own at
/// take-off, `vt_dissipative::calibrate`).
pub fn takeoff_with(s: &Scenario, tube: &SimTube, f_max_n: f64, lengths_m: &[f64], stiffness_n_per_m: &[f64]) -> Takeoff {
    let n = lengths_m.len();
    let h_tray = s.controller.tray_height_m;
    let r = s.uavs.formation_radius_m * takeoff_scale(s, f_max_n);
    let cos_lean = takeoff_cos_lean(s, f_max_n);
    let weight = s.load.mass_kg * GRAVITY_MPS2;
    let share = weight / (n as f64 * cos_lean);
    let stretch_m = share / s.cables.stiffness_n_per_m;
    let capacity_margin = n as f64 * f_max_n * cos_lean / weight;
    let k = ((s.load.start_s_m as f32 / tube.ds_m()) as usize).min(tube.samples().len() - 1);
    let smp = tube.samples().get(k).copied().unwrap_or(tube.samples()[0]);
    let heading = f64::from(smp.tangent.y).atan2(f64::from(smp.tangent.x));
    let load = V3::new(f64::from(smp.pos_m.x), f64::from(smp.pos_m.y), s.load.altitude_m);
    let uav_pos_m = lengths_m
        .iter()
        .zip(stiffness_n_per_m.iter())
        .enumerate()
        .map(|(i, (len, k))| {
            let a = heading + std::f64::consts::TAU * i as f64 / n as f64;
            let taut = len + share / k;
            let height = taut * cos_lean;
            let offset = r * height / h_tray;
            load + V3::new(offset * a.cos(), offset * a.sin(), height)
        })
        .collect();
    Takeoff { uav_pos_m, load_pos_m: load, stretch_m, share_n: share, capacity_margin }
}

/// Scale of the take-off formation: the capacity-aware formation's `lambda*` for the declared
/// load (issue 15; the team lifts the load in the formation the law chooses), 1 when the law is
/// off or rejects the scenario (validation reports the scenario's errors).
pub fn takeoff_scale(s: &Scenario, rated_n: f64) -> f64 {
    let cap = capacity_params(s, rated_n);
    if cap.load_mass_kg.is_nan() || cap.load_mass_kg <= 0.0 {
        return 1.0;
    }
    let lengths: Vec<f32> = s.cables.lengths_m.iter().map(|&l| l as f32).collect();
    vt_dissipative::capacity::plan_circle(s.uavs.formation_radius_m as f32, &lengths, s.controller.tray_height_m as f32, &cap)
        .map_or(1.0, |p| f64::from(p.scale))
}

/// Cos of the take-off cable lean from vertical: every cable points from the load at its node on
/// the formation circle of the tray `H` above, `H / sqrt(H^2 + R^2)` (REFERENCE §6), with `R` the
/// scenario's radius times the capacity-aware formation's scale ([`takeoff_scale`]: the lean the
/// adapted formation reaches for the declared load, `CapacityPlan::lean_cos_min` for a circle).
/// The pre-flight check's lean.
pub fn takeoff_cos_lean(s: &Scenario, rated_n: f64) -> f64 {
    let (h, r) = (s.controller.tray_height_m, s.uavs.formation_radius_m * takeoff_scale(s, rated_n));
    h / (h * h + r * r).sqrt()
}

/// The altitude law's height floor of UAV `i` (`VT_Z_MIN`), m: 1 m, or half its nominal cable
/// when that is shorter. Also the shortest cable the take-off calibration accepts.
pub fn min_height_m(s: &Scenario, i: usize) -> f32 {
    1.0f32.min(0.5 * s.cables.lengths_m.get(i).copied().unwrap_or(0.0) as f32)
}

/// Longest plausible cable (`VT_CABLE_LMAX`), m: 1.5 x the scenario's longest nominal cable
/// (room for any length error the disturbance model draws, far from a wrong measurement).
pub fn max_cable_m(s: &Scenario) -> f32 {
    (1.5 * s.cables.lengths_m.iter().copied().fold(0.0f64, f64::max)) as f32
}

/// What UAV `i`'s take-off calibration knows (`vt_dissipative::calibrate`; the firmware's
/// `VT_LOAD_KG`, `VT_CABLE_K`, `VT_Z_MIN`, `VT_CABLE_LMAX`).
pub fn calibration_params(s: &Scenario, i: usize) -> CalibrationParams {
    CalibrationParams {
        load_mass_kg: s.load.mass_kg as f32,
        stiffness_n_per_m: s.cables.stiffness_n_per_m as f32,
        min_length_m: min_height_m(s, i),
        max_length_m: max_cable_m(s),
        min_cos_lean: vt_dissipative::calibration::MIN_COS_LEAN,
    }
}

/// What the pre-flight check needs (`vt_dissipative::feasibility::check`) for cables rated
/// `rated_n` (N) leaning `cos_lean` from vertical (the firmware's `VT_N_UAVS`, `VT_LOAD_KG`,
/// `VL_MASS`, `VL_T_MAX`, `VL_TILT_MAX`, `VT_CABLE_RATED`, `VT_MARGIN_MIN`).
pub fn feasibility_params(s: &Scenario, rated_n: f64, cos_lean: f32) -> FeasibilityParams {
    FeasibilityParams {
        n_uavs: s.cables.lengths_m.len(),
        load_mass_kg: s.load.mass_kg as f32,
        uav_mass_kg: s.uavs.mass_kg as f32,
        thrust_max_n: s.uavs.thrust_max_n as f32,
        tilt_max_rad: s.uavs.tilt_max_deg.to_radians() as f32,
        cable_rated_n: rated_n as f32,
        cos_lean,
        min_margin: s.preflight.min_margin as f32,
    }
}

/// The pre-flight check of `s` before take-off (docs/design.md, "Pre-flight feasibility
/// check") for cables rated `rated_n` (N), at the take-off lean ([`takeoff_cos_lean`]).
///
/// # Errors
/// [`vt_dissipative::FeasibilityError`] with the needed and available force and the margin.
pub fn preflight(s: &Scenario, rated_n: f64) -> Result<vt_dissipative::Feasibility, vt_dissipative::FeasibilityError> {
    vt_dissipative::feasibility::check(&feasibility_params(s, rated_n, takeoff_cos_lean(s, rated_n) as f32))
}

/// The altitude law's parameters of UAV `i` with its take-off calibration `cal`.
pub fn vertical_params(s: &Scenario, i: usize, cal: &Calibration) -> VerticalParams {
    let c = &s.controller;
    VerticalParams {
        tension_share_n: cal.tension_share_n,
        share_gain_mps_per_n: c.share_gain_mps_per_n as f32,
        load_altitude_gain_per_s: c.load_altitude_gain_per_s as f32,
        share_offset_max_m: c.share_offset_max_m as f32,
        load_altitude_ref_m: s.load.altitude_m as f32,
        cable_length_m: cal.cable_length_m,
        cable_stretch_m: cal.stretch_m,
        kz_per_s: c.kz_per_s as f32,
        vz_max_mps: c.vz_max_mps as f32,
        min_height_m: min_height_m(s, i),
    }
}

/// The dissipative controller's parameters of UAV `i` (scenario gains, [`tray`],
/// [`vertical_params`]).
pub fn dissipative_params(s: &Scenario, i: usize, cal: &Calibration) -> DissipativeParams {
    let c = &s.controller;
    DissipativeParams {
        k1: c.k1 as f32,
        k2: c.k2 as f32,
        k3: c.k3 as f32,
        v_max_mps: c.v_max_mps as f32,
        r_safe_m: c.r_safe_m as f32,
        r_active_m: c.r_active_m as f32,
        tray: tray(s),
        vertical: vertical_params(s, i, cal),
    }
}

/// The tray used by the dissipative controller and by the formation metric.
pub fn tray(s: &Scenario) -> TrayParams {
    TrayParams { height_above_load_m: s.controller.tray_height_m as f32, ..TrayParams::default() }
}

/// The capacity-aware formation's parameters (issue 15): the declared load `load.mass_kg`
/// (0 when `[controller.capacity] enabled = false`: the law is off), the rated capacity per
/// UAV `rated_n` (N; the scenario's `cables.rated_n` or the `--f-max` override, as the
/// pre-flight check's), and `[controller.capacity]`.
pub fn capacity_params(s: &Scenario, rated_n: f64) -> CapacityParams {
    let c = &s.controller.capacity;
    CapacityParams {
        load_mass_kg: if c.enabled { s.load.mass_kg as f32 } else { 0.0 },
        uav_capacity_n: rated_n as f32,
        margin: c.margin as f32,
        separation_m: c.separation_m.unwrap_or(s.mission.safety_distance_m + s.controller.r_safe_m) as f32,
        rate_per_s: c.rate_per_s as f32,
        sag_start_m: c.sag_start_m as f32,
        sag_full_m: c.sag_full_m as f32,
    }
}

/// The horizontal thrust reserve flown (issue 15, docs/design.md "Overload in flight"): the
/// scenario's value for its UAV model, else, on the rigid body,
/// `min(RIGID_BODY_HORIZONTAL_RESERVE, sqrt(1 - ((m g + rated) / T_max)^2))`: as much as the
/// default allows while the vertical cap still holds the UAV's weight plus its rated cable pull
/// (0 for an airframe that cannot).
pub fn horizontal_reserve(s: &Scenario) -> f64 {
    s.velocity_loop.horizontal_reserve(s.uavs.model).unwrap_or_else(|| {
        let need = (s.uavs.mass_kg * GRAVITY_MPS2 + s.cables.rated_n) / s.uavs.thrust_max_n;
        let room = if need < 1.0 { (1.0 - need * need).sqrt() } else { 0.0 };
        crate::models::RIGID_BODY_HORIZONTAL_RESERVE.min(room)
    })
}

/// Builds the velocity loop of one UAV from the scenario, with the observer tuning of its UAV
/// model (`[velocity_loop.rigid_body]` for `rigid_body`).
pub fn velocity_loop(s: &Scenario) -> Result<VelocityLoop, SimError> {
    let f = |a: [f64; 3]| V3f::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let vl = &s.velocity_loop;
    let gains = PidGains { kp: f(vl.kp), ki: f(vl.ki), kd: f(vl.kd) };
    let thrust_max = s.uavs.thrust_max_n as f32;
    let limits = ThrustLimits::new(0.05 * thrust_max, thrust_max, s.uavs.tilt_max_deg.to_radians() as f32)
        .and_then(|l| l.with_horizontal_reserve(horizontal_reserve(s) as f32))
        .map_err(|e| SimError(format!("uavs: {e}")))?;
    let (bandwidth, lag, filter) = vl.tuning(s.uavs.model);
    let cfo = CfoParams::new(bandwidth as f32, s.uavs.mass_kg as f32, 1.0 / s.rates.low_level_hz as f32)
        .map_err(|e| SimError(format!("velocity_loop: {e}")))?;
    let params = VelocityLoopParams::new(gains, limits, V3f::repeat(2.0), cfo)
        .and_then(|p| p.with_actuator_lag(lag as f32))
        .and_then(|p| p.with_command_filter(filter as f32))
        .map_err(|e| SimError(format!("velocity_loop: {e}")))?;
    Ok(VelocityLoop::new(params))
}

/// Scene geometry for plots.
pub fn scene(ls: &LoadedScenario) -> SceneGeometry {
    let p = |v: vt_tube::Vec2| [f64::from(v.x), f64::from(v.y)];
    let t = &ls.tube;
    SceneGeometry {
        centerline: t.samples().iter().map(|s| p(s.pos_m)).collect(),
        left_boundary: t.samples().iter().map(|s| p(s.left_boundary_m())).collect(),
        right_boundary: t.samples().iter().map(|s| p(s.right_boundary_m())).collect(),
        obstacles: ls.scenario.world.obstacles.iter().map(|o| Obstacle { center_m: o.center_m, radius_m: o.radius_m }).collect(),
        bounds_m: ls.scenario.world.bounds_m,
        plan: ls.plan.clone(),
    }
}

/// Flies one mission with the controller crates called directly (SIL), through the one
/// mission loop ([`crate::mission::fly`]).
///
/// # Errors
/// [`SimError`] when a crate rejects the scenario's parameters.
pub fn run(ls: &LoadedScenario, opts: &RunOptions) -> Result<RunOutput, SimError> {
    let mut team = CrateTeam::new(opts.controller);
    let flown = crate::mission::fly(ls, opts, &mut team)?;
    Ok(RunOutput { summary: flown.summary, record: flown.record, scene: scene(ls) })
}

/// A progress bar on stderr when it is a terminal and `enabled`, with `template`.
pub(crate) fn progress_bar(enabled: bool, len: u64, template: &str) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if !enabled || !std::io::stderr().is_terminal() {
        return None;
    }
    let b = indicatif::ProgressBar::new(len);
    if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
        b.set_style(style.progress_chars("=> "));
    }
    Some(b)
}
