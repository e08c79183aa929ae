//! The world the team flies in: the plant (UAVs, cables, load), the sensors (noise, latency),
//! the wind, the team link, the faults, the metrics and the recorder. It steps under the
//! setpoints a [`super::Team`] sends and produces the [`Tick`]s the team reads.

use super::team::{Beacon, Meas, Report, Setpoint, TeamStart, Tick};
use crate::disturbance::{ParameterDraw, Sensors, Wind};
use crate::link::Link;
use crate::metrics::{formation_error, FlightEnd, Metrics, TubeHints};
use crate::models::{CableModel, UavModel};
use crate::plant::Plant;
use crate::record::{EventKind, RecordEvent, RunRecord, MODE_HOLD, MODE_TRANSPORT};
use crate::scenario::{FaultKind, LoadedScenario, SimTube, SIM_MAX_UAVS};
use crate::sim::{self, ControllerKind, RunOptions, SimError, Takeoff};
use crate::sensing::Receiver;
use crate::summary::{CableBreak, Summary};
use nalgebra::Vector3;
use vt_dissipative::{Formation, TeamMode};

type V3 = Vector3<f64>;
type V3f = Vector3<f32>;

fn v3f(v: &V3) -> V3f {
    V3f::new(v.x as f32, v.y as f32, v.z as f32)
}

/// What each UAV sends its team every high-level period: its position (from its autopilot)
/// and its companion's team mode (docs/design.md, "Team failsafe").
#[derive(Debug, Clone, Copy)]
struct TeamMsg {
    pos_m: V3f,
    /// The sender's own velocity as its autopilot reports it (its last own sample), m/s.
    vel_mps: V3f,
    mode: Beacon,
}

impl TeamMsg {
    /// Before the first high-level step: nothing measured, the start's beacon.
    const START: Self = Self { pos_m: V3f::new(0.0, 0.0, 0.0), vel_mps: V3f::new(0.0, 0.0, 0.0), mode: Beacon::START };
}

/// The simulated world of one mission.
pub struct World<'a> {
    ls: &'a LoadedScenario,
    /// The plant.
    pub plant: Plant,
    sensors: Sensors,
    wind: Wind,
    link: Link<TeamMsg>,
    faults: Vec<(u64, FaultKind, usize, u64)>,
    next_fault: usize,
    motors_off: Vec<bool>,
    /// Running metrics.
    pub(crate) metrics: Metrics,
    /// Recorded histories (when `record`).
    pub record: RunRecord,
    record_on: bool,
    takeoff: Takeoff,
    rated_n: f64,
    /// The take-off formation as measured (`None` until the take-off measurement).
    formation: Option<Formation<SIM_MAX_UAVS>>,
    start_own: Vec<Meas>,
    start_load: Meas,
    start_views: Vec<Vec<Option<Report>>>,
    start_modes: Vec<Vec<Option<Beacon>>>,
    own: Vec<Meas>,
    load: Meas,
    views: Vec<Vec<Option<Report>>>,
    /// Per receiver, per sender: the team mode that came with the position in `views`.
    modes: Vec<Vec<Option<Beacon>>>,
    link_msg: Vec<TeamMsg>,
    view_buf: Vec<Option<TeamMsg>>,
    /// Per UAV, the team mode its companion broadcasts (reported by the team).
    team_mode: Vec<TeamMode>,
    /// Per UAV, the plant step until which its own position feed stalls (fault).
    stall_until: Vec<Option<u64>>,
    /// Per UAV, its own state did not reach its companion this period.
    own_stalled: Vec<bool>,
    no_stall: Vec<bool>,
    /// Where each body was last found along the tube.
    hints: TubeHints,
    /// Scratch: the UAV positions the safety metrics read, m.
    uav_pos_scratch: Vec<V3>,
    /// Scratch: the delayed snapshot the sensors measure from (copied into, not allocated,
    /// at every low-level tick).
    snap_scratch: crate::disturbance::Snapshot,
    /// Dryden turbulence per body (`None`: off).
    turbulence: Option<crate::turbulence::Turbulence>,
    /// Which cables are attached (not cut or broken), per plant step.
    attached: Vec<bool>,
    dt: f64,
    ll_every: u64,
    hl_every: u64,
    rec_every: u64,
    max_steps: u64,
    /// The flight's length was given (`RunOptions::duration_s`): no set-down allowance.
    fixed_length: bool,
    shortened: bool,
    step: u64,
    arrival_step: Option<u64>,
    seed: u64,
    uav_model: UavModel,
    cable_model: CableModel,
    uav_drag_area_m2: f64,
    load_drag_area_m2: f64,
    holding: Vec<bool>,
    /// Per UAV, the team's last velocity command, ENU, m/s (for the record).
    vel_cmd: Vec<V3f>,
    /// Per UAV, the team's last cable-force estimate `f_hat`, ENU, N (for the record).
    f_hat: Vec<V3f>,
    /// Pre-flight length, plant steps (whole high-level periods).
    boot_steps: u64,
    /// The pre-flight's clock, plant steps (`None`: the mission runs).
    pre_step: Option<u64>,
    /// The team's phases, lift and touchdown (an air start: transport, and a set-down's).
    phases: crate::phases::PhaseRecord,
    /// `[mission] start = "ground"`.
    ground_start: bool,
    /// Per UAV, the phase its companion reports (`vt_dissipative::Phase` code; 0 none).
    phase_codes: Vec<u8>,
    /// Per UAV, the refusal code its companion reports (0 none).
    refusal_codes: Vec<u8>,
    /// Ground start: the plant step at which the whole team was released.
    released_step: Option<u64>,
    /// Issue 28: the LiDAR scans and the obstacles that appear (`None`: neither).
    scans: Option<super::scans::Scans>,
    /// Issue 28: the tube the team flies when its planner replaced the scenario's.
    team_tube: Option<Box<SimTube>>,
}

/// Flown on after the whole team is released (ground start), s.
const AFTER_RELEASE_S: f64 = 1.0;
/// A released UAV whose centre is this low rests on the ground, m (the ground contact puts it
/// at z = 0; docs/plant.md, "Ground contact").
const ON_GROUND_Z_M: f64 = 1e-3;
/// Longest landing after the release before the mission ends anyway, s (from 20 m at
/// `LAND_SPEED_MPS`, 29 s).
const LANDING_MAX_S: f64 = 40.0;
/// A ground start whose load arrives within the time limit flies on for its set-down, slack,
/// release and landing up to this long after the arrival, s: the time limit judges the arrival
/// (docs/design.md, "The time limit judges the arrival"). The paper team needs about 50 s (2 s
/// settle, a 13 s descent, 7 s of slack, a landing from 10 m of at most `LANDING_MAX_S`).
const SET_DOWN_ALLOWANCE_S: f64 = 90.0;

impl<'a> World<'a> {
    /// Builds the world of `ls` at take-off (plant at rest with taut cables, sensors sampled:
    /// the take-off measurement the team calibrates from).
    ///
    /// # Errors
    /// The plant rejects its parameters, or the take-off formation is degenerate.
    pub fn new(ls: &'a LoadedScenario, opts: &RunOptions) -> Result<Self, SimError> {
        let s = &ls.scenario;
        let n = s.cables.lengths_m.len();
        let uav_model = opts.uav_model.unwrap_or(s.uavs.model);
        let cable_model = opts.cable_model.unwrap_or(s.cables.model);
        let f_max = opts.f_max_n.unwrap_or(s.cables.rated_n);
        let seed = opts.seed.unwrap_or(s.seed);
        let dist = &s.disturbances;
        let draw = ParameterDraw::draw(dist, n, seed);
        let true_len: Vec<f64> = s.cables.lengths_m.iter().zip(&draw.cable_length).map(|(l, k)| l * k).collect();
        let true_k: Vec<f64> = draw.cable_stiffness.iter().map(|k| s.cables.stiffness_n_per_m * k).collect();
        let takeoff = sim::takeoff_with(s, &ls.tube, f_max, &true_len, &true_k);
        let mut plant = crate::plant::build(s, &draw, &true_len, &true_k, &takeoff, uav_model, cable_model, f_max)
            .map_err(|e| SimError(format!("plant: {e}")))?;
        if s.sensing.attitude == crate::sensing::AttitudeModel::Px4 {
            plant.fit_imus(seed, s.sensing.attitude_error_scale.unwrap_or(1.0));
        }
        // The load rests on its envelope (docs/plant.md, "Ground contact").
        let rest_z = s.load.envelope_radius_m();
        plant.set_load_rest_z(rest_z);
        plant.set_surface_roughness(dist.surface_roughness_m);
        let ground_start = s.mission.start == crate::scenario::MissionStart::Ground;
        let phases = crate::phases::PhaseRecord::new(rest_z, !ground_start);

        // Sensors first: the controllers calibrate from what they measure at take-off.
        let r = &s.rates;
        let latency_steps = (dist.latency_s * dist.intensity * f64::from(r.low_level_hz)).round() as usize;
        let sensors = Sensors::new(dist, &s.sensing, n, 1.0 / f64::from(r.low_level_hz), latency_steps, seed);
        let hl_every = u64::from(r.plant_hz / r.high_level_hz);
        // Pre-flight: whole high-level periods of hover before the start (docs/design.md,
        // "Take-off survey"); the take-off measurement is sampled at its end.
        let boot_steps = preflight_steps(s);
        let start_load = Meas::default();
        let start_own = vec![Meas::default(); n];
        let start_views = vec![vec![None; n]; n];

        let hl_hz = f64::from(r.high_level_hz);
        let link = Link::new(
            n,
            (s.link.delay_s * hl_hz).round() as u64,
            s.link.drop_probability,
            (s.link.stale_timeout_s * hl_hz).round().max(1.0) as u64,
            seed,
        )
        .with_jitter((dist.link_jitter_s * dist.intensity * hl_hz).round() as u64);
        let plant_steps = |t: f64| (t * f64::from(r.plant_hz)).round() as u64;
        let mut faults: Vec<(u64, FaultKind, usize, u64)> =
            s.faults.iter().map(|f| (plant_steps(f.time_s), f.kind, f.uav, plant_steps(f.duration_s.unwrap_or(0.0)))).collect();
        faults.sort_by_key(|f| f.0);
        let time_limit = opts.duration_s.map_or(s.mission.time_limit_s, |d| d.min(s.mission.time_limit_s));
        let (clearances, judge) = crate::clearance::Clearances::for_flight(ls, uav_model);
        let mut metrics = Metrics::new(n, f_max, s, ls.tube.length_m(), clearances, judge);
        metrics.set_rated(f_max);
        let record = RunRecord {
            scenario: s.name.clone(),
            controller: opts.controller.name().into(),
            f_max_n: f_max,
            load_altitude_ref_m: s.load.altitude_m,
            rated_n: f_max,
            tray_height_m: s.controller.tray_height_m,
            ..RunRecord::default()
        };
        let mut world = Self {
            ls,
            sensors,
            wind: Wind::new(dist, seed),
            turbulence: {
                let altitude = takeoff.uav_pos_m.iter().map(|p| p.z).sum::<f64>() / n.max(1) as f64;
                crate::turbulence::Turbulence::of_scenario(s, altitude, n, seed)
            },
            link,
            faults,
            next_fault: 0,
            motors_off: vec![false; n],
            metrics,
            record,
            record_on: opts.record,
            takeoff,
            rated_n: f_max,
            formation: None,
            own: start_own.clone(),
            load: start_load,
            views: start_views.clone(),
            modes: vec![vec![Some(Beacon::START); n]; n],
            start_modes: vec![vec![Some(Beacon::START); n]; n],
            start_own,
            start_load,
            start_views,
            link_msg: vec![TeamMsg::START; n],
            view_buf: Vec::with_capacity(n),
            team_mode: vec![TeamMode::Transport; n],
            stall_until: vec![None; n],
            own_stalled: vec![false; n],
            no_stall: vec![false; n],
            hints: TubeHints::new(n),
            uav_pos_scratch: Vec::with_capacity(n),
            snap_scratch: crate::disturbance::Snapshot::default(),
            attached: Vec::with_capacity(n),
            dt: 1.0 / f64::from(r.plant_hz),
            ll_every: u64::from(r.plant_hz / r.low_level_hz),
            hl_every,
            rec_every: u64::from(r.plant_hz / r.record_hz),
            max_steps: (time_limit * f64::from(r.plant_hz)).ceil() as u64,
            fixed_length: opts.duration_s.is_some(),
            shortened: opts.duration_s.is_some_and(|d| d < s.mission.time_limit_s),
            step: 0,
            arrival_step: None,
            seed,
            uav_model,
            cable_model,
            uav_drag_area_m2: dist.uav_drag_area_m2,
            load_drag_area_m2: dist.load_drag_area_m2,
            holding: vec![false; n],
            vel_cmd: vec![V3f::zeros(); n],
            f_hat: vec![V3f::zeros(); n],
            plant,
            boot_steps,
            pre_step: (boot_steps > 0).then_some(0),
            phases,
            ground_start,
            phase_codes: vec![0; n],
            refusal_codes: vec![0; n],
            released_step: None,
            scans: super::scans::Scans::new(ls, n, seed, f64::from(r.plant_hz), hl_hz),
            team_tube: None,
        };
        if boot_steps == 0 {
            world.sample_start()?;
        } else {
            // The sensors hold the take-off state before the first pre-flight period reads its
            // "last sample" (no noise is drawn here).
            world.sensors.sample(&world.plant, 0);
        }
        Ok(world)
    }

    /// The take-off measurement (what [`Self::start`] gives the team), sampled now, at the end
    /// of the pre-flight: the plant's true state with sensor noise, every view complete.
    fn sample_start(&mut self) -> Result<(), SimError> {
        let time_ms = self.clock_ms();
        let (sensors, plant) = (&mut self.sensors, &self.plant);
        sensors.sample(plant, time_ms);
        let start_load = Meas {
            pos_m: v3f(&sensors.position(Receiver::Load, &plant.load.pos_m)),
            vel_mps: v3f(&sensors.velocity(&plant.load.vel_mps)),
            sample_ms: time_ms,
        };
        let start_own: Vec<Meas> = plant
            .uavs
            .iter()
            .enumerate()
            .map(|(i, u)| Meas { pos_m: v3f(&sensors.position(Receiver::Uav(i), &u.pos_m)), vel_mps: v3f(&sensors.velocity(&u.vel_mps)), sample_ms: time_ms })
            .collect();
        let own_pos: Vec<V3f> = start_own.iter().map(|m| m.pos_m).collect();
        // A ground start's formation is the one its cables will hold taut: each UAV at its
        // cable's taut height above the measured load (the companions arm from that geometry).
        let taut_pos: Vec<V3f> = if self.ground_start {
            own_pos
                .iter()
                .zip(&self.ls.scenario.cables.lengths_m)
                .map(|(p, &len)| {
                    let r = (p.xy() - start_load.pos_m.xy()).norm();
                    V3f::new(p.x, p.y, start_load.pos_m.z + (len as f32 * len as f32 - r * r).max(0.0).sqrt())
                })
                .collect()
        } else {
            own_pos.clone()
        };
        self.formation = Some(
            Formation::<SIM_MAX_UAVS>::from_takeoff(&taut_pos, &start_load.pos_m, &sim::tray(&self.ls.scenario))
                .map_err(|e| SimError(format!("formation: {e}")))?,
        );
        let n = own_pos.len();
        self.start_views = vec![own_pos.iter().map(|p| Some((*p, V3f::zeros()))).collect::<Vec<_>>(); n];
        self.views = self.start_views.clone();
        self.modes = vec![vec![Some(Beacon::START); n]; n];
        self.own = start_own.clone();
        self.load = start_load;
        self.start_own = start_own;
        self.start_load = start_load;
        Ok(())
    }

    /// True while the pre-flight runs: [`Self::measure`] gives its ticks (for the team's
    /// survey), [`Self::advance_preflight`] moves its clock; the plant is held.
    pub fn preflight_due(&self) -> bool {
        self.pre_step.is_some()
    }

    /// One low-level period of pre-flight: the clock advances, the plant stays at its take-off
    /// state (the autopilots hold it); after the last one the take-off measurement is sampled.
    ///
    /// # Errors
    /// The take-off formation is degenerate.
    pub fn advance_preflight(&mut self) -> Result<(), SimError> {
        if let Some(k) = self.pre_step {
            let next = k + self.ll_every;
            if next >= self.boot_steps {
                self.pre_step = None;
                self.sample_start()?;
            } else {
                self.pre_step = Some(next);
            }
        }
        Ok(())
    }

    /// The wire clock, plant steps since the autopilots booted (the pre-flight, then the
    /// mission): `time_boot_ms` is this times the plant step.
    fn clock_step(&self) -> u64 {
        self.pre_step.unwrap_or(self.boot_steps + self.step)
    }

    /// The wire clock, ms.
    fn clock_ms(&self) -> u32 {
        (self.clock_step() as f64 * self.dt * 1000.0).round() as u32
    }

    /// What the team knows at take-off.
    pub fn start(&self) -> TeamStart<'_> {
        TeamStart {
            tick: Tick {
                step: 0,
                time_ms: self.clock_ms(),
                high_level: true,
                own: &self.start_own,
                own_stalled: &self.no_stall,
                load: self.start_load,
                views: &self.start_views,
                modes: &self.start_modes,
                scans: &[],
            },
            takeoff: &self.takeoff,
            cable_rated_n: self.rated_n,
        }
    }

    /// The nominal take-off geometry the plant starts in.
    pub fn takeoff(&self) -> &Takeoff {
        &self.takeoff
    }

    /// Rated tension of each cable (the scenario's, or the run's `--f-max`), N.
    pub fn cable_rated_n(&self) -> f64 {
        self.rated_n
    }

    /// Plant steps so far.
    pub fn step_count(&self) -> u64 {
        self.step
    }

    /// Plant step, s.
    pub fn dt_s(&self) -> f64 {
        self.dt
    }

    /// Step limit of the flight.
    pub fn max_steps(&self) -> u64 {
        self.max_steps
    }

    /// True when the team's low level is due at this step.
    pub fn low_level_due(&self) -> bool {
        self.step.is_multiple_of(self.ll_every)
    }

    /// True when the mission is over: time limit, non-finite plant, or the post-arrival time
    /// has passed.
    pub fn done(&self) -> bool {
        if self.step >= self.max_steps || self.metrics.nonfinite {
            return true;
        }
        // A team released (a ground start's end, a refusal on the ground, a set-down) is done.
        if let Some(r) = self.released_step {
            // Released UAVs land in place (vt_dissipative::landing::LAND_SPEED_MPS): done once
            // every UAV is down, or after `LANDING_MAX_S` (one that cannot land: its link lost).
            let since = (self.step - r) as f64 * self.dt;
            let down = self.plant.uavs.iter().all(|u| u.pos_m.z <= ON_GROUND_Z_M);
            return (since >= AFTER_RELEASE_S && down) || since >= LANDING_MAX_S;
        }
        if self.ground_start {
            return false;
        }
        self.arrival_step.is_some_and(|a| (self.step - a) as f64 * self.dt >= self.ls.scenario.mission.post_arrival_s)
    }

    /// The measurements of this low-level period. When the high level is due, the load's state
    /// and the team's positions come from the last sample (what the high level reads, as the
    /// firmware receives it before its own state) and pass through the link; then the sensors
    /// sample the plant and every UAV reads its own state.
    pub fn measure(&mut self) -> Tick<'_> {
        let clock = self.clock_step();
        let high_level = clock.is_multiple_of(self.hl_every);
        if high_level {
            let hl_step = clock / self.hl_every;
            self.snap_scratch.copy_from(self.sensors.delayed());
            let snap = &self.snap_scratch;
            // The mode as the team set it for this tick, the phase as its last step reported
            // it: both what the companion's last HEARTBEAT said.
            for (i, ((((msg, x), own), mode), phase)) in self.link_msg.iter_mut().zip(&snap.uav_pos_m).zip(&self.own).zip(&self.team_mode).zip(&self.phase_codes).enumerate() {
                *msg = TeamMsg { pos_m: v3f(&self.sensors.position(Receiver::Uav(i), x)), vel_mps: own.vel_mps, mode: Beacon { mode: *mode, phase: *phase } };
            }
            self.load = Meas {
                pos_m: v3f(&self.sensors.position(Receiver::Load, &snap.load_pos_m)),
                vel_mps: v3f(&self.sensors.velocity(&snap.load_vel_mps)),
                sample_ms: snap.time_ms,
            };
            self.link.exchange(hl_step, &self.link_msg);
            if let Some(sc) = self.scans.as_mut() {
                self.uav_pos_scratch.clear();
                self.uav_pos_scratch.extend(self.plant.uavs.iter().map(|u| u.pos_m));
                let measured: Vec<V3f> = self.link_msg.iter().map(|m| m.pos_m).collect();
                sc.measure(hl_step, &self.uav_pos_scratch, &measured);
            }
            for (i, (view, modes)) in self.views.iter_mut().zip(self.modes.iter_mut()).enumerate() {
                let own = self.link_msg.get(i).copied().unwrap_or(TeamMsg::START);
                self.link.view(i, hl_step, own, &mut self.view_buf);
                view.clear();
                view.extend(self.view_buf.iter().map(|m| m.map(|m| (m.pos_m, m.vel_mps))));
                modes.clear();
                modes.extend(self.view_buf.iter().map(|m| m.map(|m| m.mode)));
            }
        }
        for (stalled, until) in self.own_stalled.iter_mut().zip(&self.stall_until) {
            *stalled = until.is_some_and(|e| self.step < e);
        }
        let time_ms = self.clock_ms();
        self.sensors.sample(&self.plant, time_ms);
        self.snap_scratch.copy_from(self.sensors.delayed());
        let snap = &self.snap_scratch;
        for (i, (m, (p, v))) in self.own.iter_mut().zip(snap.uav_pos_m.iter().zip(&snap.uav_vel_mps)).enumerate() {
            *m = Meas { pos_m: v3f(&self.sensors.position(Receiver::Uav(i), p)), vel_mps: v3f(&self.sensors.velocity(v)), sample_ms: snap.time_ms };
        }
        Tick {
            step: self.step,
            time_ms,
            high_level,
            own: &self.own,
            own_stalled: &self.own_stalled,
            load: self.load,
            views: &self.views,
            modes: &self.modes,
            scans: if high_level { self.scans.as_ref().map_or(&[], |s| s.last()) } else { &[] },
        }
    }

    /// The load's horizontal path so far, m (sampled at the high-level rate).
    pub fn load_path_m(&self) -> f64 {
        self.metrics.load_path_m
    }

    /// Issue 28: the team's planner replaced the tube: the metrics measure against `tube` from
    /// now on (its boundary, and arrival at its end).
    pub fn set_team_tube(&mut self, tube: &SimTube) {
        self.metrics.set_tube_length(tube.length_m());
        self.hints = TubeHints::new(self.ls.scenario.cables.lengths_m.len());
        self.team_tube = Some(Box::new(tube.clone()));
    }

    /// Per UAV, the team mode its companion broadcasts (docs/design.md, "Team failsafe"), for
    /// the team to fill in before [`Self::measure`]; it travels with the UAV's position.
    pub fn team_mode_slots(&mut self) -> &mut [TeamMode] {
        &mut self.team_mode
    }

    /// Per UAV, whether its controller holds (reported by the team, for the record): a change
    /// puts a hold / resume event on the record's timeline.
    pub fn set_holding(&mut self, holding: &[bool]) {
        if holding.len() != self.holding.len() {
            return;
        }
        let t = self.step as f64 * self.dt;
        for (i, (was, now)) in self.holding.iter_mut().zip(holding).enumerate() {
            if *was != *now && self.record_on {
                let kind = if *now { EventKind::Hold } else { EventKind::Resume };
                self.record.events.push(RecordEvent { time_s: t, kind, uav: i });
            }
            *was = *now;
        }
    }

    /// Per UAV, the phase (`vt_dissipative::Phase` code) and the refusal code its companion
    /// reports (`HEARTBEAT.custom_mode` bits 24..31 and 16..23), for the team to fill in before
    /// [`Self::advance`].
    pub fn phase_slots(&mut self) -> (&mut [u8], &mut [u8]) {
        (&mut self.phase_codes, &mut self.refusal_codes)
    }

    /// Mutable views of the per-UAV velocity command and cable-force estimate (ENU, m/s and N)
    /// the team reports for the record.
    pub fn controller_slots(&mut self) -> (&mut [V3f], &mut [V3f]) {
        (&mut self.vel_cmd, &mut self.f_hat)
    }

    /// One plant step under `setpoints` (one per UAV, held since the last low-level period):
    /// safety metrics at the high-level rate, faults due now, wind, the plant, ground contact,
    /// tensions, the record.
    pub fn advance(&mut self, setpoints: &[Setpoint]) {
        let t = self.step as f64 * self.dt;
        // Battery sag (issue 27): the maximum thrust declines over the flight, once per
        // low-level period; the firmware keeps believing `thrust_max_n`.
        let sag = self.ls.scenario.uavs.battery_sag_per_min;
        if sag > 0.0 && self.step.is_multiple_of(self.ll_every) {
            let scale = (1.0 - sag * t / 60.0).max(0.0);
            for i in 0..self.plant.n_uavs() {
                self.plant.set_thrust_scale(i, scale);
            }
        }
        if self.step.is_multiple_of(self.ll_every) {
            let g = &mut self.phases;
            self.uav_pos_scratch.clear();
            self.uav_pos_scratch.extend(self.plant.uavs.iter().map(|u| u.pos_m));
            // The cables attached after the last step (all of them before the first).
            if self.attached.is_empty() {
                self.attached.extend(self.plant.cable_params().iter().map(|c| c.stiffness_n_per_m > 0.0));
            }
            let marked = g.marks().len();
            g.report(t, &self.phase_codes, &self.refusal_codes, &self.uav_pos_scratch, &self.plant.load.pos_m, &self.attached);
            if self.record_on {
                for m in g.marks().iter().skip(marked) {
                    if let Some(p) = vt_dissipative::Phase::ALL.iter().find(|p| p.name() == m.name) {
                        let uav = self.phase_codes.iter().position(|&c| c == *p as u8).unwrap_or(0);
                        self.record.events.push(RecordEvent { time_s: t, kind: EventKind::of_phase(*p), uav });
                    }
                }
            }
            // Nothing reported yet: an air start is in transport.
            self.metrics.judge_altitude = g.team_phase().map_or(!self.ground_start, |p| p == vt_dissipative::Phase::Transport);
            if g.team_phase() == Some(vt_dissipative::Phase::Released) && self.released_step.is_none() {
                self.released_step = Some(self.step);
            }
        }
        if self.step.is_multiple_of(self.hl_every) {
            self.uav_pos_scratch.clear();
            self.uav_pos_scratch.extend(self.plant.uavs.iter().map(|u| u.pos_m));
            let tube = self.team_tube.as_deref().unwrap_or(&self.ls.tube);
            self.metrics.geometry(t, &self.uav_pos_scratch, &self.plant.load.pos_m, tube, &mut self.hints, &self.motors_off);
            if self.metrics.arrived && self.arrival_step.is_none() {
                self.arrival_step = Some(self.step);
                if self.ground_start && !self.fixed_length {
                    let allowance = (SET_DOWN_ALLOWANCE_S / self.dt).ceil() as u64;
                    self.max_steps = self.max_steps.max(self.step + allowance);
                }
            }
        }
        while let Some(&(due, kind, i, duration)) = self.faults.get(self.next_fault) {
            if due > self.step {
                break;
            }
            match kind {
                FaultKind::CableSnap => {
                    self.plant.cut_cable(i);
                    self.metrics.snapped_by_fault += 1;
                }
                FaultKind::UavSilent => self.link.silence(i),
                FaultKind::LinkDead => self.link.kill(i),
                FaultKind::OwnFeedStall => {
                    if let Some(u) = self.stall_until.get_mut(i) {
                        *u = Some(due + duration);
                    }
                }
                FaultKind::ThrustLoss => {
                    if let Some(l) = self.motors_off.get_mut(i) {
                        *l = true;
                    }
                }
            }
            if self.record_on {
                self.record.events.push(RecordEvent { time_s: t, kind: kind.into(), uav: i });
            }
            self.next_fault += 1;
        }
        let mut wind = if self.wind.is_calm() { V3::zeros() } else { self.wind.step(self.dt) };
        if let Some(onset) = self.ls.scenario.disturbances.wind_onset_s {
            wind *= ((t - onset) / crate::scenario::WIND_ONSET_RAMP_S).clamp(0.0, 1.0);
        }
        if let Some(t) = &mut self.turbulence {
            t.step(self.dt);
            self.plant.set_gusts(t.gusts());
        }
        self.plant.step_setpoints(setpoints, &self.motors_off, &wind, self.uav_drag_area_m2, self.load_drag_area_m2, self.dt);
        for (i, tension_n, breaking_n) in self.plant.take_breaks() {
            self.metrics.breaks.push(CableBreak { uav: i, time_s: t, tension_n, breaking_n });
            if self.record_on {
                // On the timeline a break shows as the cable parting, like a snap fault.
                self.record.events.push(RecordEvent { time_s: t, kind: EventKind::Snap, uav: i });
            }
        }
        let contact = self.plant.ground_contact();
        self.phases.step(self.plant.tensions_n(), &self.plant.load.pos_m, contact);
        self.attached.clear();
        self.attached.extend(self.plant.cable_params().iter().map(|c| c.stiffness_n_per_m > 0.0));
        let uav_pos = &mut self.uav_pos_scratch;
        uav_pos.clear();
        uav_pos.extend(self.plant.uavs.iter().map(|u| u.pos_m));
        if let Some(sc) = self.scans.as_mut() {
            let clearances = &mut self.metrics.clearances;
            sc.appear(self.step, |shape| clearances.add_obstacle(shape));
        }
        let tube = self.team_tube.as_deref().unwrap_or(&self.ls.tube);
        self.metrics.clearances.sample(uav_pos, &self.plant.load.pos_m, &self.motors_off, &self.attached, tube);
        self.metrics.tensions(self.plant.tensions_n());
        self.metrics.max_thrust_fraction =
            setpoints.iter().fold(self.metrics.max_thrust_fraction, |a, sp| a.max(f64::from(sp.thrust)));
        if self.step.is_multiple_of(self.rec_every) {
            if !self.plant.is_finite() {
                self.metrics.nonfinite = true;
            } else {
                self.metrics.tension_sample(self.plant.tensions_n());
                if self.record_on {
                    self.push_record(t);
                }
            }
        }
        self.step += 1;
    }

    fn push_record(&mut self, t: f64) {
        let a = |v: &V3| [v.x, v.y, v.z];
        let (rec, plant, m) = (&mut self.record, &self.plant, &self.metrics);
        rec.time_s.push(t);
        rec.uav_pos_m.push(plant.uavs.iter().map(|u| a(&u.pos_m)).collect());
        rec.uav_vel_mps.push(plant.uavs.iter().map(|u| a(&u.vel_mps)).collect());
        rec.thrust_n.push(plant.uavs.iter().map(|u| u.thrust_n.norm()).collect());
        rec.tension_n.push(plant.tensions_n().to_vec());
        rec.load_pos_m.push(a(&plant.load.pos_m));
        rec.load_vel_mps.push(a(&plant.load.vel_mps));
        rec.min_uav_boundary_m.push(m.now_uav_boundary());
        rec.min_load_boundary_m.push(m.now_load_boundary());
        rec.min_uav_uav_m.push(m.now_uav_uav());
        let f = |v: &V3f| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
        rec.uav_mode.push(self.holding.iter().map(|&h| if h { MODE_HOLD } else { MODE_TRANSPORT }).collect());
        rec.vel_cmd_mps.push(self.vel_cmd.iter().map(f).collect());
        rec.f_hat_n.push(self.f_hat.iter().map(f).collect());
    }

    /// Ends the flight: the summary (`wall_s`: wall time of the loop, s; `invalid_commands`:
    /// the team's hold fallbacks; `refusal_text`: a UAV's refusal in its own words, from the
    /// team, for the failure of a refusal on the ground).
    pub fn finish(mut self, kind: ControllerKind, wall_s: f64, invalid_commands: u64, refusal_text: impl Fn(usize) -> Option<String>) -> (Summary, RunRecord) {
        let s = &self.ls.scenario;
        self.metrics.invalid_commands = invalid_commands;
        let end = FlightEnd {
            kind,
            seed: self.seed,
            sim_s: self.step as f64 * self.dt,
            wall_s,
            formation_error: self.formation.as_ref().map_or(f64::NAN, |f| {
                let pos: Vec<V3> = self.plant.uavs.iter().map(|u| u.pos_m).collect();
                formation_error(&pos, &self.plant.load.pos_m, f, &sim::tray(s))
            }),
            capacity_margin: self.takeoff.capacity_margin,
            completion: self.arrival_step.map(|a| a as f64 * self.dt),
            shortened: self.shortened,
            uav_model: self.uav_model.name(),
            cable_model: self.cable_model.name(),
        };
        let mut summary = self.metrics.finish(s, &end);
        summary.start = s.mission.start.name().into();
        let text = self.phases.refusal().and_then(|(uav, _)| refusal_text(uav));
        phase_verdict(&mut summary, &self.phases, self.rated_n, self.ground_start, text.as_deref());
        (summary, self.record)
    }
}

/// Largest lift snatch a ground start may show, times the rated tension (issue 27).
pub const LIFT_PEAK_FACTOR: f64 = 1.5;
/// Fastest touchdown of the load a ground start may show, m/s (issue 27).
pub const TOUCHDOWN_MAX_MPS: f64 = 0.5;

/// The phases' figures and verdict. A ground start: set down (the whole team released after
/// arrival), no snatch above [`LIFT_PEAK_FACTOR`] times the rated tension, a touchdown at most
/// [`TOUCHDOWN_MAX_MPS`]; a refusal on the ground is the outcome `refused`. Either start: a
/// descent before the end is the outcome `set_down`, its touchdown judged as a ground start's.
fn phase_verdict(summary: &mut Summary, g: &crate::phases::PhaseRecord, rated_n: f64, ground_start: bool, refusal_text: Option<&str>) {
    let (phases, peak, spread, touchdown) = g.figures();
    let released = g.team_phase() == Some(vt_dissipative::Phase::Released);
    summary.phases = phases;
    summary.lift_peak_tension_n = peak;
    summary.lift_share_spread = spread;
    summary.touchdown_speed_mps = touchdown;
    if let Some((uav, code)) = g.refusal() {
        summary.outcome = "refused".into();
        summary.success = false;
        let what = if code == vt_companion::flight::StartError::LiftFailed.code() { "the load did not leave the ground" } else { "the start checks refused with the load on the ground" };
        // The companion's own words after the code (its STATUSTEXT), when the team heard them.
        let said = refusal_text.map_or_else(String::new, |t| format!(": \"{t}\""));
        summary.failures.insert(0, format!("refused on the ground: UAV {uav}: {what} (refusal code {code}){said}"));
        return;
    }
    let mut fail = |m: String| {
        summary.failures.push(m);
        summary.success = false;
    };
    if ground_start && !released {
        let at = g.team_phase().map_or("none", vt_dissipative::Phase::name);
        fail(format!("the load was not set down and released (team in phase {at} at the end)"));
    }
    if let Some(p) = peak.filter(|p| *p > LIFT_PEAK_FACTOR * rated_n) {
        fail(format!("lift snatch {p:.1} N > {LIFT_PEAK_FACTOR} x rated {rated_n} N"));
    }
    match touchdown {
        Some(v) if v > TOUCHDOWN_MAX_MPS => fail(format!("touchdown at {v:.2} m/s > {TOUCHDOWN_MAX_MPS} m/s")),
        None if released => fail("no touchdown recorded".into()),
        _ => {}
    }
    // Descent before arrival: the companions set the load down because the team could not hold
    // the tube (issue 29) — a safe outcome, not a success.
    if !summary.reached_end && summary.phases.iter().any(|m| m.name == vt_dissipative::Phase::Descent.name()) {
        summary.outcome = "set_down".into();
        summary.success = false;
        summary.failures.insert(0, "set the load down before the end: the team could not hold the tube".into());
    }
}

/// Plant steps of the pre-flight: whole high-level periods of hover before the start
/// (docs/design.md, "Take-off survey"). Every plant that flies the lockstep protocol uses it.
pub fn preflight_steps(s: &crate::scenario::Scenario) -> u64 {
    let r = &s.rates;
    (s.mission.preflight_s * f64::from(r.high_level_hz)).round() as u64 * u64::from(r.plant_hz / r.high_level_hz)
}
