//! The team-controller interface of the mission loop, and its first backend: the controller
//! crates called directly (SIL).
//!
//! Every backend receives the same [`Tick`] (what the UAVs' computers measure at one low-level
//! period) and answers with what the firmware sends its autopilot: one [`Setpoint`]
//! (`SET_ATTITUDE_TARGET`: FRD-to-NED quaternion and normalised collective) per UAV. The other
//! backends, the firmware's companion compiled for the host (SIL twin) and the firmware in QEMU
//! (PIL), speak MAVLink and live in [`crate::pil`].

use crate::scenario::{LoadedScenario, SimTube, StaleNeighbour, SIM_MAX_UAVS};
use crate::sim::{self, ControllerKind, SimError, Takeoff};
use nalgebra::{UnitVector2, Vector2, Vector3};
use vt_cfo::{age_s, extrapolate_constant_velocity, thrust_to_attitude, VelocityLoop};
use vt_companion::frames::ned_frd_quaternion;
use vt_dissipative::{
    capacity, BaselineController, BaselineParams, Command, DissipativeController, Formation, FormationScale, Measurements,
    TakeoffSurvey, TeamHoldSupervisor, TeamMode,
};

pub use vt_companion::flight::Setpoint;

type V3f = Vector3<f32>;

/// One measured state: position (m) and velocity (m/s), world ENU, `f32` as on the wire, and
/// when it was sampled.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Meas {
    /// Position, m.
    pub pos_m: V3f,
    /// Velocity, m/s.
    pub vel_mps: V3f,
    /// Simulated time of the sample, ms (`LOCAL_POSITION_NED.time_boot_ms`; older than the
    /// tick's `time_ms` by the sensor latency).
    pub sample_ms: u32,
}

/// What the team's computers receive at one low-level period.
#[derive(Debug, Clone, Copy)]
pub struct Tick<'a> {
    /// Plant step of this tick.
    pub step: u64,
    /// Simulated time, ms (`time_boot_ms` on the wire).
    pub time_ms: u32,
    /// The high level is due: `load` and `views` carry this period's data.
    pub high_level: bool,
    /// Each UAV's own measured state (from its autopilot).
    pub own: &'a [Meas],
    /// Per UAV, its own state did not reach its computer this period (`own_feed_stall`
    /// fault): it still has the last one it received.
    pub own_stalled: &'a [bool],
    /// The load's measured state (from the load tracker; valid when `high_level`).
    pub load: Meas,
    /// Per UAV, the team's positions as its link delivered them (`None`: not delivered; own
    /// slot: its own position; valid when `high_level`).
    pub views: &'a [Vec<Option<V3f>>],
    /// Per UAV, the team mode each other UAV broadcast with the position in `views` (`None`
    /// with it; docs/design.md, "Team failsafe"; valid when `high_level`).
    pub modes: &'a [Vec<Option<TeamMode>>],
}

/// What the team knows at take-off, before its first tick.
#[derive(Debug, Clone, Copy)]
pub struct TeamStart<'a> {
    /// The take-off measurement (every view complete), stamped at time 0.
    pub tick: Tick<'a>,
    /// The nominal take-off geometry the plant starts in (the team calibrates its cables from
    /// `tick`, not from this).
    pub takeoff: &'a Takeoff,
    /// Rated tension of each cable for the pre-flight check (the scenario's, or the run's
    /// `--f-max`), N.
    pub cable_rated_n: f64,
}

/// A team controller: one computer per UAV, however they are built.
pub trait Team {
    /// Configures and arms every UAV (`MAV_CMD_MISSION_START`).
    ///
    /// # Errors
    /// A configuration is refused.
    fn start(&mut self, ls: &LoadedScenario, start: &TeamStart<'_>) -> Result<(), SimError>;

    /// One low-level period of the pre-flight hover (`at.tick`), before [`Team::start`]: every
    /// UAV's computer takes the tick's measurements into its take-off survey (docs/design.md,
    /// "Take-off survey"); nothing is commanded. A backend configures its UAVs at the first.
    ///
    /// # Errors
    /// A configuration is refused, or a backend failed.
    fn preflight(&mut self, ls: &LoadedScenario, at: &TeamStart<'_>) -> Result<(), SimError>;

    /// One low-level period: every UAV's setpoint for `tick` into `out` (one per UAV).
    ///
    /// # Errors
    /// A backend failed (link closed, reply missing).
    fn step(&mut self, tick: &Tick<'_>, out: &mut [Setpoint]) -> Result<(), SimError>;

    /// High-level commands so far that fell back to hold (invalid input or non-finite output).
    fn invalid_commands(&self) -> u64 {
        0
    }

    /// Per UAV, whether it is in hold (failsafe) after the last step (empty: not reported).
    fn holding(&self) -> Vec<bool> {
        Vec::new()
    }

    /// Writes each UAV's last velocity command (m/s) and cable-force estimate `f_hat` (N),
    /// ENU, into the slices (for the record); a team that does not report leaves them.
    fn controller_outputs(&self, _vel_cmd_mps: &mut [V3f], _f_hat_n: &mut [V3f]) {}

    /// Writes the team mode each UAV broadcasts to its team (docs/design.md, "Team failsafe");
    /// a team without the team failsafe leaves them (transport).
    fn team_modes(&self, _out: &mut [TeamMode]) {}
}

enum HighLevel {
    Dissipative(Vec<DissipativeController<SIM_MAX_UAVS>>),
    Baseline(Vec<BaselineController>),
}

/// The controller crates called directly, one instance per UAV: exactly the calls of the
/// firmware's `Flight` (vt-companion), without MAVLink, including its failsafe: own state
/// older than the companion's `FS_OWN_TMO` ([`crate::pil::OWN_TIMEOUT_S`]) or a controller
/// output flagged invalid or non-finite gives a zero command (hold); the team failsafe
/// (`docs/design.md`, "Team failsafe") follows a neighbour's `Hold` and, with
/// `failsafe.stale_neighbour = "hold"`, holds on a stale neighbour. (The load state arrives
/// every high-level period here, so its timeout never trips.)
pub struct CrateTeam {
    kind: ControllerKind,
    high: Option<HighLevel>,
    tube: Option<SimTube>,
    low: Vec<VelocityLoop>,
    vel_cmd: Vec<V3f>,
    f_hat: Vec<V3f>,
    heading: UnitVector2<f32>,
    thrust_max_n: f32,
    hover_n: Vec<f32>,
    hl_dt: f32,
    ll_dt: f32,
    invalid: u64,
    holding: Vec<bool>,
    /// Each UAV's own state as last received and its time, ms: the high level reads it before
    /// the new one is taken (the firmware's `lockstep_tick`), the low level after.
    own_last: Vec<(Meas, u32)>,
    own_tmo_ms: u32,
    hold_on_stale: bool,
    supervisors: Vec<TeamHoldSupervisor>,
    team_mode: Vec<TeamMode>,
    /// Per UAV, its take-off survey (`vt_dissipative::survey`), fed before the start.
    surveys: Vec<TakeoffSurvey<SIM_MAX_UAVS>>,
}

impl CrateTeam {
    /// A team flying `kind`, configured at [`Team::start`].
    pub fn new(kind: ControllerKind) -> Self {
        Self {
            kind,
            high: None,
            tube: None,
            low: Vec::new(),
            vel_cmd: Vec::new(),
            f_hat: Vec::new(),
            // VL_YAW = 0 (NED yaw 0): nose north, the heading the PIL configuration sends and
            // the companion computes as (sin 0, cos 0) = (0, 1) in ENU.
            heading: UnitVector2::new_unchecked(Vector2::new(0.0, 1.0)),
            thrust_max_n: 0.0,
            hover_n: Vec::new(),
            hl_dt: 0.0,
            ll_dt: 0.0,
            invalid: 0,
            holding: Vec::new(),
            own_last: Vec::new(),
            own_tmo_ms: 0,
            hold_on_stale: false,
            supervisors: Vec::new(),
            team_mode: Vec::new(),
            surveys: Vec::new(),
        }
    }
}

impl Team for CrateTeam {
    fn preflight(&mut self, ls: &LoadedScenario, at: &TeamStart<'_>) -> Result<(), SimError> {
        let tick = &at.tick;
        let n = tick.own.len();
        if self.surveys.len() != n {
            self.surveys = vec![TakeoffSurvey::new(ls.scenario.controller.survey_samples); n];
        }
        // What each companion's receive path does before the start (vt-companion
        // `on_local_position`): its own state every period unless its feed stalls, the load's
        // and the delivered team positions every high-level period.
        for (i, survey) in self.surveys.iter_mut().enumerate() {
            if !tick.own_stalled.get(i).copied().unwrap_or(false) {
                survey.push_own(&tick.own[i].pos_m);
            }
            if tick.high_level {
                survey.push_load(&tick.load.pos_m);
                for (j, p) in tick.views.get(i).into_iter().flatten().enumerate() {
                    if let (Some(p), true) = (p, j != i) {
                        survey.push_member(j, p);
                    }
                }
            }
        }
        Ok(())
    }

    fn start(&mut self, ls: &LoadedScenario, start: &TeamStart<'_>) -> Result<(), SimError> {
        let s = &ls.scenario;
        let n = start.tick.own.len();
        let tray = sim::tray(s);
        // The take-off measurement reaches every companion before MISSION_START: into the
        // survey with the pre-flight's.
        self.preflight(ls, start)?;
        let cap = sim::capacity_params(s, start.cable_rated_n);
        // As the companion's Flight::start, per UAV: the take-off positions it surveyed (its
        // own, the load's, its view of the team), the cable calibration and the pre-flight check
        // at the measured lean, the take-off formation and the capacity plan from them.
        let mut takeoffs: Vec<(Vec<V3f>, V3f)> = Vec::with_capacity(n);
        let mut cals = Vec::with_capacity(n);
        let mut formations = Vec::with_capacity(n);
        let mut scales = Vec::with_capacity(n);
        for (i, survey) in self.surveys.iter().enumerate() {
            let seen: Vec<V3f> = (0..n)
                .map(|j| {
                    let last = if j == i { Some(start.tick.own[i].pos_m) } else { start.tick.views.get(i).and_then(|v| v.get(j).copied().flatten()) };
                    let mean = if j == i { survey.own() } else { survey.member(j) };
                    mean.or(last).unwrap_or(V3f::repeat(f32::NAN))
                })
                .collect();
            let load = survey.load().unwrap_or(start.tick.load.pos_m);
            let cal = vt_dissipative::calibrate(i, &seen, &load, &sim::calibration_params(s, i))
                .map_err(|e| SimError(format!("UAV {i}: take-off calibration: {e}")))?;
            vt_dissipative::feasibility::check(&sim::feasibility_params(s, start.cable_rated_n, cal.cos_lean))
                .map_err(|e| SimError(format!("UAV {i}: pre-flight check: {e}")))?;
            formations.push(Formation::<SIM_MAX_UAVS>::from_takeoff(&seen, &load, &tray).map_err(|e| SimError(format!("formation: {e}")))?);
            // Capacity-aware formation (issue 15), from the same take-off positions.
            let plan = capacity::plan_from_takeoff(&seen, &load, &tray, &cap).map_err(|e| SimError(format!("capacity: {e}")))?;
            scales.push(FormationScale::new(&plan, &cap));
            cals.push(cal);
            takeoffs.push((seen, load));
        }
        self.high = Some(match self.kind {
            ControllerKind::Dissipative => HighLevel::Dissipative(
                (0..n)
                    .map(|i| {
                        DissipativeController::new(i, sim::dissipative_params(s, i, &cals[i]), &formations[i])
                            .map(|c| c.with_capacity(scales[i]))
                            .map_err(|e| SimError(format!("controller: {e}")))
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
                            vertical: sim::vertical_params(s, i, &cals[i]),
                        };
                        BaselineController::new(i, n, p).map_err(|e| SimError(format!("baseline: {e}")))
                    })
                    .collect::<Result<_, _>>()?,
            ),
        });
        self.tube = Some(ls.tube.clone());
        self.low = (0..n).map(|_| sim::velocity_loop(s)).collect::<Result<_, _>>()?;
        // Warm start with the declared load's share (capacity.rs; the companion's Flight::start).
        for (i, (l, (seen, load))) in self.low.iter_mut().zip(&takeoffs).enumerate() {
            if let Some(f) = capacity::takeoff_cable_force_n(&seen[i], load, cap.load_mass_kg, n) {
                l.preload(f);
            }
        }
        self.thrust_max_n = self.low.first().map_or(0.0, |l| l.params().limits().thrust_max_n());
        self.hover_n = self.low.iter().map(|l| l.params().hover_thrust_n()).collect();
        self.vel_cmd = vec![V3f::zeros(); n];
        self.f_hat = vec![V3f::zeros(); n];
        self.holding = vec![false; n];
        self.own_last = start.tick.own.iter().map(|m| (*m, start.tick.time_ms)).collect();
        self.hl_dt = 1.0 / s.rates.high_level_hz as f32;
        self.ll_dt = 1.0 / s.rates.low_level_hz as f32;
        // As the companion converts FS_OWN_TMO (`Params::timeout_ms`).
        self.own_tmo_ms = (crate::pil::OWN_TIMEOUT_S * 1000.0) as u32;
        self.hold_on_stale = s.failsafe.stale_neighbour == StaleNeighbour::Hold;
        let sup = TeamHoldSupervisor::new(s.failsafe.resume_s as f32, self.hl_dt).map_err(|e| SimError(format!("failsafe: {e}")))?;
        self.supervisors = vec![sup; n];
        self.team_mode = vec![TeamMode::Transport; n];
        Ok(())
    }

    fn step(&mut self, tick: &Tick<'_>, out: &mut [Setpoint]) -> Result<(), SimError> {
        let (Some(high), Some(tube)) = (self.high.as_mut(), self.tube.as_ref()) else {
            return Err(SimError("team stepped before start".into()));
        };
        let n = self.low.len();
        let sizes_ok = tick.own.len() == n && tick.own_stalled.len() == n && out.len() == n;
        if !sizes_ok || (tick.high_level && (tick.views.len() != n || tick.modes.len() != n)) {
            return Err(SimError(format!("tick for {} UAVs, team of {n}", tick.own.len())));
        }
        let now = tick.time_ms;
        for i in 0..n {
            let (own, own_ms) = self.own_last[i];
            let own_fresh = now.wrapping_sub(own_ms) <= self.own_tmo_ms;
            if tick.high_level {
                // The companion's `Flight::high_level`, decision for decision.
                let mut detected = !own_fresh;
                let mut follow = false;
                for (j, (v, m)) in tick.views[i].iter().zip(&tick.modes[i]).enumerate() {
                    if j != i {
                        detected |= v.is_none() && self.hold_on_stale;
                        follow |= v.is_some() && *m == Some(TeamMode::Hold);
                    }
                }
                let mut mode = self.supervisors[i].step(detected, follow);
                self.vel_cmd[i] = V3f::zeros();
                if own_fresh {
                    // Measurements carried forward to now (vt_cfo::prediction): own position by
                    // the velocity loop's last prediction (made from this same sample), the load
                    // at constant velocity.
                    let pred = self.low[i].prediction();
                    let own_pos_m = if pred.delay_steps > 0 { own.pos_m + pred.displacement_m } else { own.pos_m };
                    let load_age_s = age_s(now, tick.load.sample_ms);
                    let m = Measurements {
                        own_pos_m,
                        load_pos_m: extrapolate_constant_velocity(tick.load.pos_m, tick.load.vel_mps, load_age_s),
                        load_vel_mps: tick.load.vel_mps,
                        neighbours_m: &tick.views[i],
                        own_cable_force_n: Some(self.f_hat[i]),
                    };
                    let cmd: Command = match high {
                        HighLevel::Dissipative(c) => {
                            c[i].set_team_hold(mode.is_holding());
                            c[i].update(tube, &m, self.hl_dt)
                        }
                        HighLevel::Baseline(c) => {
                            c[i].set_team_hold(mode.is_holding());
                            c[i].update(tube, &m, self.hl_dt)
                        }
                    };
                    let bad = cmd.status.invalid_input || cmd.status.nonfinite_command || !cmd.vel_mps.iter().all(|x| x.is_finite());
                    self.invalid += u64::from(bad);
                    if bad {
                        mode = self.supervisors[i].step(true, follow);
                    } else {
                        self.vel_cmd[i] = cmd.vel_mps;
                    }
                }
                self.team_mode[i] = mode;
                self.holding[i] = mode.is_holding();
            }
            // Take this period's own state (unless its feed stalls); the low level flies it,
            // or, once it is older than FS_OWN_TMO, the velocity loop's no-measurement failsafe.
            if !tick.own_stalled[i] {
                self.own_last[i] = (tick.own[i], now);
            }
            let (own, own_ms) = self.own_last[i];
            // As the companion's `Flight::low_level`: a stale own state is no measurement (age 0).
            let (v_meas, own_age_s) = if now.wrapping_sub(own_ms) <= self.own_tmo_ms {
                (own.vel_mps, age_s(now, own.sample_ms))
            } else {
                (V3f::repeat(f32::NAN), 0.0)
            };
            let o = self.low[i].update_delayed(self.vel_cmd[i], v_meas, own_age_s, self.ll_dt);
            self.f_hat[i] = o.f_hat_n;
            let att = thrust_to_attitude(o.thrust_n, self.heading, self.thrust_max_n);
            let mut sp = Setpoint { q_ned: ned_frd_quaternion(&att.attitude), thrust: att.collective };
            if !(sp.q_ned.iter().all(|c| c.is_finite()) && sp.thrust.is_finite()) {
                let hover = thrust_to_attitude(V3f::new(0.0, 0.0, self.hover_n[i].max(0.0)), self.heading, self.thrust_max_n);
                sp = Setpoint { q_ned: ned_frd_quaternion(&hover.attitude), thrust: hover.collective };
                self.holding[i] = true;
            }
            out[i] = sp;
        }
        Ok(())
    }

    fn invalid_commands(&self) -> u64 {
        self.invalid
    }

    fn holding(&self) -> Vec<bool> {
        self.holding.clone()
    }

    fn controller_outputs(&self, vel_cmd_mps: &mut [V3f], f_hat_n: &mut [V3f]) {
        vel_cmd_mps.iter_mut().zip(&self.vel_cmd).for_each(|(o, v)| *o = *v);
        f_hat_n.iter_mut().zip(&self.f_hat).for_each(|(o, f)| *o = *f);
    }

    fn team_modes(&self, out: &mut [TeamMode]) {
        out.iter_mut().zip(&self.team_mode).for_each(|(o, m)| *o = *m);
    }
}
