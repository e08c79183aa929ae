//! Software-in-the-loop runner: the no_std controllers (one instance per UAV) flying the
//! f64 plant at three rates (plant, low level, high level), with a link model for
//! neighbours' positions. This file composes; the control laws live in the crates.

use crate::scenario::SIM_MAX_UAVS;
use crate::cable::CableParams;
use crate::disturbance::{drag_n, ParameterDraw, Sensors, Wind};
use crate::link::Link;
use crate::plant::{LoadParams, Plant, UavParams, GRAVITY_MPS2};
use crate::record::{EventKind, Obstacle, RecordEvent, RunRecord, SceneGeometry, MODE_HOLD, MODE_TRANSPORT};
use crate::scenario::{FaultKind, LoadedScenario, Scenario, SimTube};
use crate::summary::Summary;
use nalgebra::Vector3;
use std::time::Instant;
use vt_cfo::{CfoParams, PidGains, ThrustLimits, VelocityLoop, VelocityLoopParams};
use vt_dissipative::{
    BaselineController, BaselineParams, Command, DissipativeController, DissipativeParams, Formation, Measurements,
    TrayParams, VerticalParams,
};

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
}

impl Default for RunOptions {
    fn default() -> Self {
        Self { controller: ControllerKind::Dissipative, f_max_n: None, seed: None, progress: false, record: true }
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

fn v3f(v: &V3) -> V3f {
    V3f::new(v.x as f32, v.y as f32, v.z as f32)
}

fn v3d(v: &V3f) -> V3 {
    V3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

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
/// `stretch_m` and `share_n` stay the nominal values the controllers assume.
pub fn takeoff_with(s: &Scenario, tube: &SimTube, f_max_n: f64, lengths_m: &[f64], stiffness_n_per_m: &[f64]) -> Takeoff {
    let n = lengths_m.len();
    let h_tray = s.controller.tray_height_m;
    let r = s.uavs.formation_radius_m;
    let cos_lean = h_tray / (h_tray * h_tray + r * r).sqrt();
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

/// The altitude law's parameters for a UAV whose cable is `cable_m` long (calibrated at
/// take-off), from the scenario and the take-off state.
pub fn vertical_params(s: &Scenario, cable_m: f64, to: &Takeoff) -> VerticalParams {
    let c = &s.controller;
    VerticalParams {
        tension_share_n: to.share_n as f32,
        share_gain_mps_per_n: c.share_gain_mps_per_n as f32,
        load_altitude_gain_per_s: c.load_altitude_gain_per_s as f32,
        share_offset_max_m: c.share_offset_max_m as f32,
        load_altitude_ref_m: s.load.altitude_m as f32,
        cable_length_m: cable_m as f32,
        cable_stretch_m: to.stretch_m as f32,
        kz_per_s: c.kz_per_s as f32,
        vz_max_mps: c.vz_max_mps as f32,
        min_height_m: 1.0f32.min(0.5 * cable_m as f32),
    }
}

/// The dissipative controller's parameters (scenario gains, [`tray`], [`vertical_params`]).
pub fn dissipative_params(s: &Scenario, cable_m: f64, to: &Takeoff) -> DissipativeParams {
    let c = &s.controller;
    DissipativeParams {
        k1: c.k1 as f32,
        k2: c.k2 as f32,
        k3: c.k3 as f32,
        v_max_mps: c.v_max_mps as f32,
        r_safe_m: c.r_safe_m as f32,
        r_active_m: c.r_active_m as f32,
        tray: tray(s),
        vertical: vertical_params(s, cable_m, to),
    }
}

/// The tray used by the dissipative controller and by the formation metric.
pub fn tray(s: &Scenario) -> TrayParams {
    TrayParams { height_above_load_m: s.controller.tray_height_m as f32, ..TrayParams::default() }
}

enum HighLevel {
    Dissipative(Vec<DissipativeController<SIM_MAX_UAVS>>),
    Baseline(Vec<BaselineController>),
}

/// Builds the velocity loop of one UAV from the scenario.
pub fn velocity_loop(s: &Scenario) -> Result<VelocityLoop, SimError> {
    let f = |a: [f64; 3]| V3f::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let vl = &s.velocity_loop;
    let gains = PidGains { kp: f(vl.kp), ki: f(vl.ki), kd: f(vl.kd) };
    let thrust_max = s.uavs.thrust_max_n as f32;
    let limits = ThrustLimits::new(0.05 * thrust_max, thrust_max, s.uavs.tilt_max_deg.to_radians() as f32)
        .map_err(|e| SimError(format!("uavs: {e}")))?;
    let cfo = CfoParams::new(vl.cfo_bandwidth_rad_s as f32, s.uavs.mass_kg as f32, 1.0 / s.rates.low_level_hz as f32)
        .map_err(|e| SimError(format!("velocity_loop: {e}")))?;
    let params = VelocityLoopParams::new(gains, limits, V3f::repeat(2.0), cfo).map_err(|e| SimError(format!("velocity_loop: {e}")))?;
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
    }
}

/// Flies one mission.
///
/// # Errors
/// [`SimError`] when a crate rejects the scenario's parameters.
pub fn run(ls: &LoadedScenario, opts: &RunOptions) -> Result<RunOutput, SimError> {
    let s = &ls.scenario;
    let tube = &ls.tube;
    let n = s.cables.lengths_m.len();
    let f_max = opts.f_max_n.unwrap_or(s.cables.f_max_n);
    let seed = opts.seed.unwrap_or(s.seed);
    let dist = &s.disturbances;
    let draw = ParameterDraw::draw(dist, n, seed);
    let true_len: Vec<f64> = s.cables.lengths_m.iter().zip(&draw.cable_length).map(|(l, k)| l * k).collect();
    let true_k: Vec<f64> = draw.cable_stiffness.iter().map(|k| s.cables.stiffness_n_per_m * k).collect();
    let to = takeoff_with(s, tube, f_max, &true_len, &true_k);

    // Plant, with its true parameters drawn around the nominal ones (disturbances).
    let uav_params: Vec<UavParams> = draw
        .uav_mass
        .iter()
        .map(|k| UavParams { mass_kg: s.uavs.mass_kg * k, thrust_max_n: s.uavs.thrust_max_n, thrust_lag_s: s.uavs.thrust_lag_s })
        .collect();
    let cables: Vec<CableParams> = s
        .cables
        .lengths_m
        .iter()
        .zip(true_len.iter().zip(true_k.iter()))
        .map(|(_, (&l, &k))| CableParams {
            rest_length_m: l,
            stiffness_n_per_m: k,
            damping_ns_per_m: s.cables.damping_ns_per_m,
            f_max_n: f_max,
        })
        .collect();
    let load_params = LoadParams { mass_kg: s.load.mass_kg * draw.load_mass };
    let mut plant = Plant::new(uav_params, cables, load_params, &to.uav_pos_m, to.load_pos_m, s.rates.plant_substeps as usize)
        .map_err(|e| SimError(format!("plant: {e}")))?;
    let hover = plant.hover_thrust();
    for (u, t) in plant.uavs.iter_mut().zip(hover.iter()) {
        u.thrust_n = *t;
    }

    // Sensors first: the controllers calibrate from what they measure at take-off.
    let r = &s.rates;
    let latency_steps = (dist.latency_s * dist.intensity * f64::from(r.low_level_hz)).round() as usize;
    let mut sensors = Sensors::new(dist, latency_steps, seed);
    sensors.sample(&plant);
    let measured_load = sensors.position(&plant.load.pos_m);
    let measured_uav: Vec<V3> = to.uav_pos_m.iter().map(|p| sensors.position(p)).collect();
    // Cable length calibrated at take-off from the taut geometry (see docs/design.md):
    // measured UAV-load distance less the nominal stretch.
    let calibrated_len: Vec<f64> = measured_uav.iter().map(|p| (p - measured_load).norm() - to.stretch_m).collect();

    // Controllers, one per UAV.
    let tray = tray(s);
    let uav_f: Vec<V3f> = measured_uav.iter().map(v3f).collect();
    let formation = Formation::<SIM_MAX_UAVS>::from_takeoff(&uav_f, &v3f(&measured_load), &tray).map_err(|e| SimError(format!("formation: {e}")))?;
    let mut high = match opts.controller {
        ControllerKind::Dissipative => HighLevel::Dissipative(
            (0..n)
                .map(|i| {
                    let p = dissipative_params(s, calibrated_len[i], &to);
                    DissipativeController::new(i, p, &formation).map_err(|e| SimError(format!("controller: {e}")))
                })
                .collect::<Result<_, _>>()?,
        ),
        ControllerKind::Baseline => HighLevel::Baseline(
            (0..n)
                .map(|i| {
                    let b = &s.baseline;
                    let p = BaselineParams {
                        k1: b.k1 as f32,
                        k2: b.k2 as f32,
                        k3: b.k3 as f32,
                        v_max_mps: b.v_max_mps as f32,
                        r_safe_m: b.r_safe_m as f32,
                        r_active_m: b.r_active_m as f32,
                        vertical: vertical_params(s, calibrated_len[i], &to),
                    };
                    BaselineController::new(i, n, p).map_err(|e| SimError(format!("baseline: {e}")))
                })
                .collect::<Result<_, _>>()?,
        ),
    };
    let mut vloops: Vec<VelocityLoop> = (0..n).map(|_| velocity_loop(s)).collect::<Result<_, _>>()?;

    // Rates.
    let dt = 1.0 / f64::from(r.plant_hz);
    let ll_every = u64::from(r.plant_hz / r.low_level_hz);
    let hl_every = u64::from(r.plant_hz / r.high_level_hz);
    let rec_every = u64::from(r.plant_hz / r.record_hz);
    let hl_dt = 1.0 / r.high_level_hz as f32;
    let ll_dt = 1.0 / r.low_level_hz as f32;
    let max_steps = (s.mission.time_limit_s * f64::from(r.plant_hz)).ceil() as u64;
    let hl_hz = f64::from(r.high_level_hz);
    let mut link: Link<V3f> = Link::new(
        n,
        (s.link.delay_s * hl_hz).round() as u64,
        s.link.drop_probability,
        (s.link.stale_timeout_s * hl_hz).round().max(1.0) as u64,
        seed,
    )
    .with_jitter((dist.link_jitter_s * dist.intensity * hl_hz).round() as u64);
    let mut wind = Wind::new(dist, seed);
    let mut ext_uav = vec![V3::zeros(); n];
    let mut faults: Vec<(u64, FaultKind, usize)> =
        s.faults.iter().map(|f| ((f.time_s * f64::from(r.plant_hz)).round() as u64, f.kind, f.uav)).collect();
    faults.sort_by_key(|f| f.0);
    let mut next_fault = 0usize;
    let mut thrust_lost = vec![false; n];

    let mut metrics = Metrics::new(n, f_max, s, tube.length_m());
    let mut record = RunRecord {
        scenario: s.name.clone(),
        controller: opts.controller.name().into(),
        f_max_n: f_max,
        load_altitude_ref_m: s.load.altitude_m,
        tray_height_m: s.controller.tray_height_m, // issue 17 (replay)
        ..RunRecord::default()
    };
    let mut mode = vec![MODE_TRANSPORT; n]; // issue 17 (replay): controller mode per UAV
    let mut vel_cmd = vec![V3f::zeros(); n];
    let mut thrust_cmd = vec![V3::zeros(); n];
    let mut f_hat = vec![V3f::zeros(); n];
    let mut view: Vec<Option<V3f>> = Vec::with_capacity(n);
    let mut uav_hints = vec![0usize; n];
    let mut load_hint = 0usize;

    let bar = progress_bar(opts.progress, max_steps, "{spinner} simulating [{bar:40}] {percent:>3}% (time limit) {elapsed}");
    let wall = Instant::now();
    let mut step: u64 = 0;
    let mut arrival_step: Option<u64> = None;
    while step < max_steps {
        let t = step as f64 * dt;
        if step.is_multiple_of(hl_every) {
            let hl_step = step / hl_every;
            let snap = sensors.delayed().clone();
            let own: Vec<V3f> = snap.uav_pos_m.iter().map(|p| v3f(&sensors.position(p))).collect();
            link.exchange(hl_step, &own);
            let load_pos = v3f(&sensors.position(&snap.load_pos_m));
            let load_vel = v3f(&sensors.velocity(&snap.load_vel_mps));
            for i in 0..n {
                link.view(i, hl_step, own[i], &mut view);
                let m = Measurements {
                    own_pos_m: own[i],
                    load_pos_m: load_pos,
                    load_vel_mps: load_vel,
                    neighbours_m: &view,
                    own_cable_force_n: Some(f_hat[i]),
                };
                let cmd: Command = match &mut high {
                    HighLevel::Dissipative(c) => c[i].update(tube, &m, hl_dt),
                    HighLevel::Baseline(c) => c[i].update(tube, &m, hl_dt),
                };
                metrics.invalid_commands += u64::from(cmd.status.invalid_input || cmd.status.nonfinite_command);
                vel_cmd[i] = cmd.vel_mps;
                // issue 17 (replay): hold entered / left.
                let now = if cmd.status.invalid_input || cmd.status.nonfinite_command { MODE_HOLD } else { MODE_TRANSPORT };
                if opts.record && now != mode[i] {
                    let kind = if now == MODE_HOLD { EventKind::Hold } else { EventKind::Resume };
                    record.events.push(RecordEvent { time_s: t, kind, uav: i });
                }
                mode[i] = now;
            }
            // Safety metrics at the high-level rate.
            metrics.geometry(t, &plant, tube, &mut uav_hints, &mut load_hint, &thrust_lost);
            if metrics.arrived && arrival_step.is_none() {
                arrival_step = Some(step);
            }
        }
        // Faults due at this step.
        while let Some(&(due, kind, i)) = faults.get(next_fault) {
            if due > step {
                break;
            }
            match kind {
                FaultKind::CableSnap => plant.cut_cable(i),
                FaultKind::UavSilent => link.silence(i),
                FaultKind::ThrustLoss => {
                    if let Some(l) = thrust_lost.get_mut(i) {
                        *l = true;
                    }
                }
            }
            next_fault += 1;
            if opts.record {
                record.events.push(RecordEvent { time_s: t, kind: kind.into(), uav: i }); // issue 17 (replay)
            }
        }
        if step.is_multiple_of(ll_every) {
            sensors.sample(&plant);
            for i in 0..n {
                let v_meas = sensors.velocity(&sensors.delayed().uav_vel_mps[i].clone());
                let out = vloops[i].update(vel_cmd[i], v3f(&v_meas), ll_dt);
                thrust_cmd[i] = if thrust_lost[i] { V3::zeros() } else { v3d(&out.thrust_n) };
                f_hat[i] = out.f_hat_n;
                metrics.max_thrust_fraction = metrics.max_thrust_fraction.max(out.thrust_n.norm() as f64 / s.uavs.thrust_max_n);
            }
        }
        let w = if wind.is_calm() { V3::zeros() } else { wind.step(dt) };
        let ext_load = if wind.is_calm() {
            V3::zeros()
        } else {
            for (e, u) in ext_uav.iter_mut().zip(plant.uavs.iter()) {
                *e = drag_n(&w, &u.vel_mps, dist.uav_drag_area_m2);
            }
            drag_n(&w, &plant.load.vel_mps, dist.load_drag_area_m2)
        };
        plant.step(&thrust_cmd, &ext_uav, ext_load, dt);
        ground_contact(&mut plant);
        metrics.tensions(plant.tensions_n());
        if step.is_multiple_of(rec_every) {
            if !plant_finite(&plant) {
                metrics.nonfinite = true;
                break;
            }
            metrics.tension_sample(plant.tensions_n());
            if opts.record {
                push_record(&mut record, t, &plant, &metrics);
                push_record_controller(&mut record, &mode, &vel_cmd, &f_hat); // issue 17 (replay, MCAP)
            }
        }
        step += 1;
        if let Some(a) = arrival_step {
            if (step - a) as f64 * dt >= s.mission.post_arrival_s {
                break;
            }
        }
        if step.is_multiple_of(2000) {
            if let Some(b) = &bar {
                b.set_position(step);
            }
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let wall_s = wall.elapsed().as_secs_f64();
    let sim_s = step as f64 * dt;
    let formation_error = formation_error(&plant, &formation, &tray);
    let summary = metrics.finish(s, opts.controller, seed, sim_s, wall_s, formation_error, to.capacity_margin, arrival_step.map(|a| a as f64 * dt), false);
    Ok(RunOutput { summary, record, scene: scene(ls) })
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

/// The ground (z = 0) stops a falling UAV or load: position clamped, velocity zeroed.
fn ground_contact(p: &mut Plant) {
    for u in &mut p.uavs {
        if u.pos_m.z < 0.0 {
            u.pos_m.z = 0.0;
            u.vel_mps = V3::zeros();
        }
    }
    if p.load.pos_m.z < 0.0 {
        p.load.pos_m.z = 0.0;
        p.load.vel_mps = V3::zeros();
    }
}

/// Every plant state finite (the `nonfinite` criterion of `success`).
pub(crate) fn plant_finite(p: &Plant) -> bool {
    let ok = |v: &V3| v.iter().all(|x| x.is_finite());
    ok(&p.load.pos_m) && ok(&p.load.vel_mps) && p.uavs.iter().all(|u| ok(&u.pos_m) && ok(&u.vel_mps) && ok(&u.thrust_n))
}

fn push_record(rec: &mut RunRecord, t: f64, plant: &Plant, m: &Metrics) {
    let a = |v: &V3| [v.x, v.y, v.z];
    rec.time_s.push(t);
    rec.uav_pos_m.push(plant.uavs.iter().map(|u| a(&u.pos_m)).collect());
    rec.uav_vel_mps.push(plant.uavs.iter().map(|u| a(&u.vel_mps)).collect());
    rec.thrust_n.push(plant.uavs.iter().map(|u| u.thrust_n.norm()).collect());
    rec.tension_n.push(plant.tensions_n().to_vec());
    rec.load_pos_m.push(a(&plant.load.pos_m));
    rec.load_vel_mps.push(a(&plant.load.vel_mps));
    rec.min_uav_boundary_m.push(m.now_uav_boundary);
    rec.min_load_boundary_m.push(m.now_load_boundary);
    rec.min_uav_uav_m.push(m.now_uav_uav);
}

/// issue 17 (replay, MCAP): the controller side of one record sample: mode, velocity
/// command and CFO force estimate of every UAV.
fn push_record_controller(rec: &mut RunRecord, mode: &[u8], vel_cmd: &[V3f], f_hat: &[V3f]) {
    let a = |v: &V3f| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    rec.uav_mode.push(mode.to_vec());
    rec.vel_cmd_mps.push(vel_cmd.iter().map(a).collect());
    rec.f_hat_n.push(f_hat.iter().map(a).collect());
}

/// RMS over UAV node pairs of |current - rest length|, nodes by the tray projection.
pub fn formation_error<const N: usize>(plant: &Plant, formation: &Formation<N>, tray: &TrayParams) -> f64 {
    use vt_dissipative::springs::NodeId;
    let load = v3f(&plant.load.pos_m);
    let nodes: Vec<_> = plant.uavs.iter().map(|u| tray.project(&v3f(&u.pos_m), &load).0).collect();
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

/// Running metrics of a mission.
pub(crate) struct Metrics {
    n: usize,
    f_max: f64,
    settle_s: f64,
    alt_ref: f64,
    end_s: f32,
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
    pub(crate) nonfinite: bool,
    pub(crate) invalid_commands: u64,
}

impl Metrics {
    pub(crate) fn new(n: usize, f_max: f64, s: &Scenario, tube_len: f32) -> Self {
        Self {
            n,
            f_max,
            settle_s: s.mission.settle_time_s,
            alt_ref: s.load.altitude_m,
            end_s: tube_len - s.mission.end_tolerance_m as f32,
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
            nonfinite: false,
            invalid_commands: 0,
        }
    }

    /// Safety distances at one instant; UAVs that lost thrust (fallen) are left out.
    pub(crate) fn geometry(&mut self, t: f64, plant: &Plant, tube: &SimTube, uav_hints: &mut [usize], load_hint: &mut usize, lost: &[bool]) {
        let xy = |v: &V3| vt_tube::Vec2::new(v.x as f32, v.y as f32);
        let mut ub = f64::INFINITY;
        for ((u, h), _) in plant.uavs.iter().zip(uav_hints.iter_mut()).zip(lost.iter()).filter(|(_, l)| !**l) {
            let q = xy(&u.pos_m);
            match tube.locate(q, *h) {
                Some(sec) => {
                    *h = sec.segment;
                    ub = ub.min(f64::from(sec.boundary_distance_m(q)));
                }
                None => ub = f64::NEG_INFINITY,
            }
        }
        let ql = xy(&plant.load.pos_m);
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
                    uu = uu.min((plant.uavs[i].pos_m - plant.uavs[j].pos_m).norm());
                }
            }
        }
        self.now_uav_boundary = ub;
        self.now_load_boundary = lb;
        self.now_uav_uav = uu;
        self.min_uav_boundary = self.min_uav_boundary.min(ub);
        self.min_load_boundary = self.min_load_boundary.min(lb);
        self.min_uav_uav = self.min_uav_uav.min(uu);
        if t >= self.settle_s {
            self.max_alt_err = self.max_alt_err.max((plant.load.pos_m.z - self.alt_ref).abs());
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

    /// The summary; `shortened`: the flight was cut before the scenario's time limit (PIL
    /// `--duration`), which the arrival failure says.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn finish(
        self,
        s: &Scenario,
        kind: ControllerKind,
        seed: u64,
        sim_s: f64,
        wall_s: f64,
        formation_error: f64,
        capacity_margin: f64,
        completion: Option<f64>,
        shortened: bool,
    ) -> Summary {
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
        if self.max_alt_err > s.mission.altitude_tolerance_m {
            failures.push(format!("load altitude error {:.2} m > {} m", self.max_alt_err, s.mission.altitude_tolerance_m));
        }
        if self.nonfinite {
            failures.push("non-finite state".to_string());
        }
        let fin = |x: f64| if x.is_finite() { x } else { -1.0 };
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
            nonfinite: self.nonfinite,
            invalid_commands: self.invalid_commands,
        }
    }
}
