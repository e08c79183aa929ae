//! Software-in-the-loop entry point and what every backend shares: the take-off geometry the
//! plant starts in, the scene for plots. The flight itself is [`crate::mission::fly`]; the
//! companions' parameters come from [`crate::companion::params_for`]; the control laws live in
//! the crates.

use crate::mission::CompanionTeam;
use crate::models::{CableModel, UavModel};
use crate::plant::GRAVITY_MPS2;
use crate::record::{Obstacle, RunRecord, SceneGeometry};
use crate::scenario::{LoadedScenario, Scenario, SimTube};
use crate::summary::Summary;
use nalgebra::Vector3;
use vt_dissipative::{FeasibilityParams, TrayParams};

type V3 = Vector3<f64>;

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
    /// Each UAV's take-off node on the tray, m (horizontal, world frame): the scenario's layout
    /// about the load times the capacity-aware formation's scale ([`takeoff_scale`]).
    pub nodes_m: Vec<[f64; 2]>,
}

/// Computes the take-off state: nodes on the take-off layout around the load (the ring, or the
/// scenario's `formation_offsets_m`), cables taut and stretched for an equal share of the load's
/// weight (REFERENCE §6).
pub fn takeoff(s: &Scenario, tube: &SimTube, f_max_n: f64) -> Takeoff {
    let n = s.cables.lengths_m.len();
    takeoff_with(s, tube, f_max_n, &s.cables.lengths_m, &vec![s.cables.stiffness_n_per_m; n])
}

/// [`takeoff`] for the plant's true cable lengths and stiffnesses: every cable taut at the
/// stretch its true stiffness gives under its share, so the true plant starts at rest.
/// `stretch_m` and `share_n` stay the nominal values (the controllers calibrate their own at
/// take-off, `vt_dissipative::calibrate`). Each cable carries the same vertical share of the
/// load, `W / n`: at rest for a layout whose nodes balance about the load (the ring, concentric
/// rings); another layout starts with the load pulled sideways until the springs settle it.
pub fn takeoff_with(s: &Scenario, tube: &SimTube, f_max_n: f64, lengths_m: &[f64], stiffness_n_per_m: &[f64]) -> Takeoff {
    let n = lengths_m.len();
    let h_tray = s.controller.tray_height_m;
    let scale = takeoff_scale(s, f_max_n);
    let cos_lean = takeoff_cos_lean(s, f_max_n);
    let weight = s.load.mass_kg * GRAVITY_MPS2;
    let share = weight / (n as f64 * cos_lean);
    let stretch_m = share / s.cables.stiffness_n_per_m;
    let k = ((s.load.start_s_m as f32 / tube.ds_m()) as usize).min(tube.samples().len() - 1);
    let smp = tube.samples().get(k).copied().unwrap_or(tube.samples()[0]);
    let heading = f64::from(smp.tangent.y).atan2(f64::from(smp.tangent.x));
    let ground = s.mission.start == crate::scenario::MissionStart::Ground;
    let load_z = if ground { s.load.envelope_radius_m() } else { s.load.altitude_m };
    let load = V3::new(f64::from(smp.pos_m.x), f64::from(smp.pos_m.y), load_z);
    let (sin_h, cos_h) = heading.sin_cos();
    // Each node: its direction from the load (unit, world frame), its distance on the tray and
    // the cos of its cable's lean `H / sqrt(H^2 + d^2)`. The ring keeps its own arithmetic (the
    // flights before explicit layouts, bit for bit).
    let nodes: Vec<([f64; 2], f64, f64)> = match s.uavs.ring_radius_m() {
        Some(radius) => (0..n)
            .map(|i| {
                let a = heading + std::f64::consts::TAU * i as f64 / n as f64;
                ([a.cos(), a.sin()], radius * scale, cos_lean)
            })
            .collect(),
        None => s
            .uavs
            .formation_offsets(n)
            .iter()
            .map(|o| {
                let d = o[0].hypot(o[1]) * scale;
                let u = if d > 0.0 { [(o[0] * cos_h - o[1] * sin_h) * scale / d, (o[0] * sin_h + o[1] * cos_h) * scale / d] } else { [1.0, 0.0] };
                (u, d, h_tray / (h_tray * h_tray + d * d).sqrt())
            })
            .collect(),
    };
    let capacity_margin = match s.uavs.ring_radius_m() {
        Some(_) => n as f64 * f_max_n * cos_lean / weight,
        None => f_max_n * nodes.iter().map(|nd| nd.2).sum::<f64>() / weight,
    };
    let uav_pos_m = lengths_m
        .iter()
        .zip(stiffness_n_per_m.iter())
        .zip(&nodes)
        .map(|((len, k), &(u, r, cos))| {
            let taut = len + weight / (n as f64 * cos) / k;
            let height = taut * cos;
            let offset = r * height / h_tray;
            // A ground start: the same place, hovering low with a slack cable.
            let z = if ground { ground_hover_height_m(*len, offset) } else { height };
            load + V3::new(offset * u[0], offset * u[1], z)
        })
        .collect();
    let nodes_m = nodes.iter().map(|&(u, r, _)| [load.x + r * u[0], load.y + r * u[1]]).collect();
    Takeoff { uav_pos_m, load_pos_m: load, stretch_m, share_n: share, capacity_margin, nodes_m }
}

/// Height above the resting load at which a ground start's UAVs hover before take-off, m:
/// [`GROUND_HOVER_M`], or half the taut height when that leaves less than 0.5 m of slack.
pub fn ground_hover_height_m(cable_m: f64, offset_m: f64) -> f64 {
    let taut = (cable_m * cable_m - offset_m * offset_m).max(0.0).sqrt();
    if GROUND_HOVER_M <= taut - 0.5 { GROUND_HOVER_M } else { 0.5 * taut }
}

/// A ground start's hover height before take-off, above the resting load, m.
pub const GROUND_HOVER_M: f64 = 1.5;

/// Length of a ground start's take-off phase (`VT_TKO_S`), s: the climb from the hover height
/// to the longest cable's taut height at the vertical speed limit, plus 3 s to settle. A
/// mission-planning figure, as a waypoint's time is.
pub fn ground_takeoff_s(s: &Scenario) -> f64 {
    let longest = s.cables.lengths_m.iter().copied().fold(0.0, f64::max);
    (longest - GROUND_HOVER_M).max(0.0) / s.controller.vz_max_mps.max(0.1) + 3.0
}

/// Scale of the take-off formation: the capacity-aware formation's `lambda*` for the declared
/// load (issue 15; the team lifts the load in the formation the law chooses), 1 when the law is
/// off or rejects the scenario (validation reports the scenario's errors).
pub fn takeoff_scale(s: &Scenario, rated_n: f64) -> f64 {
    let Some(Ok(cap)) = lead_params(s, rated_n).map(|p| p.capacity()) else {
        return 1.0;
    };
    if cap.load_mass_kg.is_nan() || cap.load_mass_kg <= 0.0 {
        return 1.0;
    }
    let lengths: Vec<f32> = s.cables.lengths_m.iter().map(|&l| l as f32).collect();
    let h = s.controller.tray_height_m as f32;
    let plan = match s.uavs.ring_radius_m() {
        Some(r) => vt_dissipative::capacity::plan_circle(r as f32, &lengths, h, &cap),
        None => {
            let offsets: Vec<vt_dissipative::Vec2> = s.uavs.formation_offsets(lengths.len()).iter().map(|d| vt_dissipative::Vec2::new(d[0] as f32, d[1] as f32)).collect();
            vt_dissipative::capacity::plan(&offsets, &lengths, h, &cap)
        }
    };
    plan.map_or(1.0, |p| f64::from(p.scale))
}

/// Cos of the take-off cables' lean from vertical, as every companion measures it at its
/// arming: the mean over the cables (`vt_dissipative::calibrate`'s `cos_lean`, the lean its
/// pre-flight and wind checks use). A node on the tray `H` above the load and `R` from it leans
/// its cable `H / sqrt(H^2 + R^2)` (REFERENCE §6), with `R` the node's offset
/// ([`crate::scenario::UavSpec::formation_offsets`]) times the capacity-aware formation's scale
/// ([`takeoff_scale`]: the lean the adapted formation reaches for the declared load). On the
/// ring every cable leans alike, and the ring keeps its own arithmetic (its flights bit for
/// bit). Test `the_host_s_take_off_lean_is_the_companions_calibration_s`.
pub fn takeoff_cos_lean(s: &Scenario, rated_n: f64) -> f64 {
    let (h, scale) = (s.controller.tray_height_m, takeoff_scale(s, rated_n));
    let cos = |r: f64| h / (h * h + r * r).sqrt();
    if s.uavs.ring_radius_m().is_some() {
        return cos(s.uavs.formation_reach_m() * scale);
    }
    let offsets = s.uavs.formation_offsets(s.cables.lengths_m.len());
    if offsets.is_empty() {
        return cos(0.0);
    }
    offsets.iter().map(|o| cos(o[0].hypot(o[1]) * scale)).sum::<f64>() / offsets.len() as f64
}

/// The companion parameters of UAV 0 for the host's own uses of the laws before any companion
/// runs (take-off geometry, scenario validation): the one parameter map
/// ([`crate::companion::params_for`]), `None` when the scenario cannot be mapped (validation says
/// why).
fn lead_params(s: &Scenario, rated_n: f64) -> Option<vt_companion::Params> {
    crate::companion::params_for(s, 0, ControllerKind::Dissipative, rated_n, false).ok()
}

/// The tube half-width the formation shaped to `tube` keeps its separation floor in, m, as UAV
/// 0's companion arms it from the take-off on `tube` (`vt_companion::shaped_need_at_arming_m`,
/// the one law; docs/design.md, "The width the shaped formation needs"): what a planner must give
/// a team with bodies declared and `[controller.shape]` on. `None` otherwise, or when the arming
/// would refuse (its own error says why).
pub fn shaped_need_m(s: &Scenario, tube: &SimTube) -> Option<f64> {
    if s.uavs.body_radius_m.is_none() || !s.controller.shape.enabled {
        return None;
    }
    let rated = s.cables.rated_n;
    let to = takeoff(s, tube, rated);
    let params = lead_params(s, rated)?;
    let f32v = |p: &V3| vt_companion::Vec3::new(p.x as f32, p.y as f32, p.z as f32);
    let uavs: Vec<vt_companion::Vec3> = to.uav_pos_m.iter().map(f32v).collect();
    let load = f32v(&to.load_pos_m);
    let tangent = tube.locate(load.xy(), 0)?.tangent;
    vt_companion::shaped_need_at_arming_m(&params, &uavs, &load, tangent).map(f64::from)
}

/// What the pre-flight check sees of `s` with cables rated `rated_n` (N) at the take-off lean
/// ([`takeoff_cos_lean`]): the companion's own `Params::feasibility`.
pub fn feasibility_at_takeoff(s: &Scenario, rated_n: f64) -> Option<FeasibilityParams> {
    lead_params(s, rated_n).map(|p| p.feasibility(takeoff_cos_lean(s, rated_n) as f32))
}

/// The pre-flight check of `s` before take-off (docs/design.md, "Pre-flight feasibility
/// check") for cables rated `rated_n` (N), at the take-off lean ([`takeoff_cos_lean`]): what
/// every companion checks at `MISSION_START`, with the nominal geometry.
///
/// # Errors
/// [`vt_dissipative::FeasibilityError`] with the needed and available force and the margin
/// (`InvalidParameter` when the scenario cannot be mapped to the companion's parameters).
pub fn preflight(s: &Scenario, rated_n: f64) -> Result<vt_dissipative::Feasibility, vt_dissipative::FeasibilityError> {
    let p = feasibility_at_takeoff(s, rated_n).ok_or(vt_dissipative::FeasibilityError::InvalidParameter("companion parameters"))?;
    vt_dissipative::feasibility::check(&p)
}

/// The pre-flight wind check of `s` (docs/design.md, "Wind capacity") for cables rated
/// `rated_n` (N) at the take-off lean: what every companion checks at `MISSION_START` with its
/// `VT_WIND_DECL`. `Ok(None)` when no wind is declared.
///
/// # Errors
/// [`vt_dissipative::wind::WindError`] with the wind, the capacity and the binding limit
/// (`InvalidParameter` when the scenario cannot be mapped to the companion's parameters).
pub fn wind_preflight(s: &Scenario, rated_n: f64) -> Result<Option<vt_dissipative::wind::WindCapacity>, vt_dissipative::wind::WindError> {
    let p = lead_params(s, rated_n).ok_or(vt_dissipative::wind::WindError::InvalidParameter("companion parameters"))?;
    let Some((wind_mps, gust_mps)) = p.declared_wind_mps() else { return Ok(None) };
    vt_dissipative::wind::check(&p.wind(takeoff_cos_lean(s, rated_n) as f32), wind_mps, gust_mps).map(Some)
}

/// The companions' wind check of `s` at a steady wind `wind_mps` plus `gust_mps` (m/s),
/// whatever the scenario declares: the capacity (`steady_wind_max_mps`) when the team holds it.
///
/// # Errors
/// As [`wind_preflight`].
pub fn wind_check(s: &Scenario, rated_n: f64, wind_mps: f32, gust_mps: f32) -> Result<vt_dissipative::wind::WindCapacity, vt_dissipative::wind::WindError> {
    let p = lead_params(s, rated_n).ok_or(vt_dissipative::wind::WindError::InvalidParameter("companion parameters"))?;
    vt_dissipative::wind::check(&p.wind(takeoff_cos_lean(s, rated_n) as f32), wind_mps, gust_mps)
}

/// The tray of the formation metric (the companions fly `VT_TRAY_H`, the same height).
pub fn tray(s: &Scenario) -> TrayParams {
    TrayParams { height_above_load_m: s.controller.tray_height_m as f32, ..TrayParams::default() }
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
    let mut team = CompanionTeam::new(opts.controller);
    let flown = crate::mission::fly(ls, opts, &mut team)?;
    Ok(RunOutput { summary: flown.summary, record: flown.record, scene: scene(ls) })
}

/// A progress bar on stderr when it is a terminal and `enabled`, with `template`.
pub fn progress_bar(enabled: bool, len: u64, template: &str) -> Option<indicatif::ProgressBar> {
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
