//! The armed controllers of one UAV and their two steps, with the freshness failsafe.
//!
//! - High level (tube + springs, `vt-dissipative`), every `1/VT_HL_HZ`: own position, load
//!   position and velocity, neighbours' positions, the CFO's last cable-force estimate -> a
//!   velocity command (world ENU).
//! - Low level (velocity loop + CFO, `vt-cfo`), every `1/VT_LL_HZ`: velocity command and own
//!   velocity -> thrust vector -> attitude + collective thrust ([`vt_cfo::thrust_to_attitude`];
//!   no trigonometry: the heading is a unit vector computed at start).
//!
//! These are exactly the calls host-sim's software-in-the-loop runner makes (`sim::run`): the
//! same parameters, `dt = 1/rate`, `own_cable_force_n = Some(f_hat)` from the previous
//! low-level step, high level before low level when both are due.
//!
//! # Failsafe (hold) and team failsafe (team hold)
//! Own state older than `FS_OWN_TMO`, load state older than `FS_LOAD_TMO`, or a controller
//! output that is non-finite or flagged invalid: the velocity command becomes zero (no
//! horizontal motion, no climb), which the velocity loop turns into the hover thrust corrected
//! by the CFO's force estimate. With no fresh own velocity the velocity loop gets NaN and flies
//! its own failsafe: the compensated hover thrust `f_hat - G` without feedback.
//!
//! The team holds with it (`docs/design.md`, "Team failsafe"): every such detection, and with
//! `FS_NBR_ACT = 1` a neighbour older than `FS_NBR_TMO` (or never heard), makes this UAV
//! broadcast [`TeamMode::Hold`]; a fresh neighbour broadcasting `Hold` makes it follow. While
//! holding with usable own and load data, it flies the controller's team hold (passing off;
//! springs to the fresh neighbours, tube keeping and altitude law on). The hold ends
//! `FS_RESUME` seconds after the last alarm ([`TeamHoldSupervisor`]), for every UAV within a
//! high-level period or two of the others. The reasons are reported in
//! `HEARTBEAT.custom_mode` ([`HoldReasons`]).

use nalgebra::{Unit, UnitQuaternion, Vector2};
use vt_cfo::{age_s, extrapolate_constant_velocity, thrust_to_attitude, VelocityLoop, UNLOADED_BANDWIDTH_RAD_S};
use vt_dissipative::{
    capacity, Command, Measurements,
    phases::{HoldWatch, OverloadWatch}, Phase, PhaseProfile, TakeoffSurvey, TeamHoldSupervisor, TeamMode,
};
use vt_dissipative::wind::GustSurvey;

use crate::frames::{finite3, ned_frd_quaternion};
use crate::params::{Param, Params};
use crate::{CompanionTube, Vec3, MAX_UAVS};

mod arming;
mod hold_reasons;
mod landing;
mod phases;
use arming::{arm, HighLevel};
#[cfg(feature = "std")]
pub use arming::shaped_need_at_arming_m;
pub use hold_reasons::HoldReasons;
pub use phases::TRANSPORT_WATCH_S;
use landing::Landing;
use phases::{watch_every, Pending};

/// A measurement with the time it was received (companion clock, ms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stamped<T> {
    /// The value.
    pub value: T,
    /// Receive time, ms.
    pub stamp_ms: u32,
}

impl<T: Copy> Stamped<T> {
    /// The value if it is at most `timeout_ms` old at `now_ms` (a stamp in the future is stale).
    #[inline]
    pub fn fresh(&self, now_ms: u32, timeout_ms: u32) -> Option<T> {
        (now_ms.wrapping_sub(self.stamp_ms) <= timeout_ms).then_some(self.value)
    }
}

/// Position and velocity, world ENU.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Position, m.
    pub pos_m: Vec3,
    /// Velocity, m/s.
    pub vel_mps: Vec3,
    /// When it was sampled, on the companion's clock, ms (the autopilot's `time_boot_ms`
    /// mapped by the `SYSTEM_TIME` offset; the receipt time when unknown).
    pub sample_ms: u32,
}

/// The latest data from every source.
#[derive(Debug, Clone)]
pub struct Sources {
    /// Own state from the autopilot.
    pub own: Option<Stamped<State>>,
    /// Load state from the load tracker.
    pub load: Option<Stamped<State>>,
    /// Neighbours' positions by UAV index (own slot unused).
    pub neighbours: [Option<Stamped<Vec3>>; MAX_UAVS],
    /// Neighbours' horizontal velocities by UAV index, m/s, from the same reports as
    /// `neighbours` (own slot unused; zero until the first): the dashpots beside the springs
    /// read them where the position is fresh (`vt_dissipative::springs::dashpot_velocity`).
    pub neighbour_vel_mps: [Vector2<f32>; MAX_UAVS],
    /// Bit `j` set: neighbour `j`'s last broadcast mode was [`TeamMode::Hold`] (own bit never
    /// set); it counts while the neighbour's position is fresh.
    pub neighbour_hold: MemberBits,
    /// Bit `j` set: neighbour `j`'s last broadcast phase was [`Phase::Released`] (own bit
    /// never set): it lands, and the armed law flies on without it.
    pub neighbour_released: MemberBits,
    /// Before the mission starts: the take-off positions averaged over `VT_CAL_N` samples per
    /// source (`vt_dissipative::survey`); [`Flight::start`] calibrates from them.
    pub survey: TakeoffSurvey<MAX_UAVS>,
}

/// Words of [`MemberBits`].
const MEMBER_WORDS: usize = MAX_UAVS.div_ceil(32);
/// `Flight::no_route` bit: the team's planner found no route (issue 28).
const NO_ROUTE_TEAM: u8 = 1;
/// `Flight::no_route` bit: this UAV's own tube is blocked close ahead (issue 28).
const NO_ROUTE_BLOCKED: u8 = 2;

/// One bit per team member (`MAX_UAVS` bits).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MemberBits([u32; MEMBER_WORDS]);

impl MemberBits {
    /// No bit set.
    pub const EMPTY: Self = Self([0; MEMBER_WORDS]);

    /// Sets bit `j` to `on` (nothing for `j >= MAX_UAVS`).
    #[inline]
    pub fn set(&mut self, j: usize, on: bool) {
        if let Some(w) = self.0.get_mut(j / 32) {
            let bit = 1u32 << (j % 32);
            if on {
                *w |= bit;
            } else {
                *w &= !bit;
            }
        }
    }

    /// Bit `j` (false for `j >= MAX_UAVS`).
    #[inline]
    pub fn get(&self, j: usize) -> bool {
        self.0.get(j / 32).is_some_and(|w| (w >> (j % 32)) & 1 == 1)
    }

    /// True when any bit is set.
    #[inline]
    pub fn any(&self) -> bool {
        self.0.iter().any(|&w| w != 0)
    }
}

impl Default for Sources {
    fn default() -> Self {
        Self::new()
    }
}

impl Sources {
    /// How old the own, the load's and the oldest team member's data are at `now_ms`, ms, for
    /// telemetry (`-1`: never received); members `0..n` but `id`.
    pub fn ages_ms(&self, now_ms: u32, n: usize, id: usize) -> [i32; 3] {
        let age = |stamp: u32| i32::try_from(now_ms.wrapping_sub(stamp)).unwrap_or(i32::MAX);
        let own = self.own.map_or(-1, |s| age(s.stamp_ms));
        let load = self.load.map_or(-1, |s| age(s.stamp_ms));
        let mut team = 0;
        for (j, slot) in self.neighbours.iter().enumerate().take(n) {
            if j != id {
                team = match slot {
                    Some(s) if team >= 0 => team.max(age(s.stamp_ms)),
                    _ => -1,
                };
            }
        }
        [own, load, team]
    }

    /// Nothing received yet.
    pub const fn new() -> Self {
        Self { own: None, load: None, neighbours: [None; MAX_UAVS], neighbour_vel_mps: [Vector2::new(0.0, 0.0); MAX_UAVS], neighbour_hold: MemberBits::EMPTY, neighbour_released: MemberBits::EMPTY, survey: TakeoffSurvey::new(1) }
    }
}

/// Why the mission could not start.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StartError {
    /// No valid tube uploaded.
    NoTube,
    /// `VT_ID >= VT_N_UAVS`, or `VT_LL_HZ` not a multiple of `VT_HL_HZ`.
    BadTeam,
    /// Own, load or a neighbour's state is missing or stale.
    StaleData,
    /// The high-level controller rejected its parameters or the take-off formation.
    Controller(vt_dissipative::ControlError),
    /// The velocity loop rejected its parameters.
    VelocityLoop(vt_cfo::CfoError),
    /// The take-off calibration refused the measured geometry (`vt_dissipative::calibrate`).
    Calibration(vt_dissipative::CalibrationError),
    /// The pre-flight check: the team cannot carry the declared load with the required margin.
    Infeasible(vt_dissipative::FeasibilityError),
    /// The pre-flight wind check: the declared wind plus its gust margin is above what the
    /// team can hold in the tube (`vt_dissipative::wind`).
    Wind(vt_dissipative::wind::WindError),
    /// Ground start: the load did not leave the ground before the lift's allowance (an
    /// overload or a snagged load; the team slackens its cables with the load down).
    LiftFailed,
    /// Ground start: before its arming the UAV drifted `drift_m` (m) from the place it holds,
    /// beyond `vt_dissipative::landing::STATION_DRIFT_ABORT_M`: a wind it cannot hold on its own.
    /// The team lands at once, the load still on the ground.
    Station {
        /// How far the UAV had drifted, m.
        drift_m: f32,
    },
    /// `PR_MAP` 1 (the map is unknown), but this build has no onboard map (feature
    /// `perception`), or the world `PR_X0`..`PR_Y1` does not fit it at `PR_CELL`.
    NoMap,
}

/// What one low-level step produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setpoint {
    /// Attitude, `[w, x, y, z]`, FRD body to local NED (MAVLink `SET_ATTITUDE_TARGET.q`).
    pub q_ned: [f32; 4],
    /// Collective thrust, `[0, 1]` of `VL_T_MAX` (`SET_ATTITUDE_TARGET.thrust`).
    pub thrust: f32,
}

/// The armed controllers and their inputs.
#[derive(Debug, Clone)]
pub struct Flight {
    /// The landing after the release.
    landing: Landing,
    id: usize,
    n: usize,
    /// The high-level law (`None` until a ground start is armed, or after it was refused).
    high: Option<HighLevel>,
    low: VelocityLoop,
    heading: Unit<Vector2<f32>>,
    thrust_max_n: f32,
    hover_n: f32,
    /// The observer's bandwidth cap while the cable is loaded, rad/s (`vt_cfo::loaded_bandwidth_cap`).
    loaded_cap_rad_s: f32,
    hl_dt_s: f32,
    ll_dt_s: f32,
    low_per_high: u32,
    own_tmo_ms: u32,
    load_tmo_ms: u32,
    nbr_tmo_ms: u32,
    hold_on_stale_neighbour: bool,
    ll_ticks: u32,
    vel_cmd_mps: Vec3,
    f_hat_n: Vec3,
    hl_reasons: HoldReasons,
    ll_reasons: HoldReasons,
    last_command: Option<Command>,
    supervisor: TeamHoldSupervisor,
    team_mode: TeamMode,
    invalid_commands: u32,
    operator_hold: bool,
    /// Issue 28, why this UAV has no route ([`HoldReasons::NO_ROUTE`] while not 0): bit
    /// [`NO_ROUTE_TEAM`], the team's planner found none; bit [`NO_ROUTE_BLOCKED`], its own tube
    /// is blocked close ahead by an obstacle its map has seen and it has no tube it may take.
    no_route: u8,
    /// The phases: a ground start's whole sequence; an air start's in transport from its start,
    /// for a set-down (`PhaseProfile::air`).
    profile: Option<PhaseProfile>,
    /// Ground start: what the arming reads (`None` once armed or refused, and in an air start).
    pending: Option<Pending>,
    /// Ground start: why the arming refused.
    refusal: Option<StartError>,
    /// The refusal is yet to be reported ([`Flight::take_refusal`]).
    refusal_unreported: bool,
    /// Arrival: the load within this arc length of the tube's end, m (`VT_END_TOL`).
    end_tol_m: f32,
    /// Warm start of the load's tube lookup.
    load_hint: usize,
    /// Rated cable tension `VT_CABLE_RATED`, N (the lift's overload abort).
    rated_n: f32,
    /// The set-down's watch over the current tube (the load's furthest progress, the edge).
    hold_watch: HoldWatch,
    /// This UAV declined the team's newer tube and flies its old one (issue 28): where the load
    /// lies in the old tube says nothing about the team holding the new one, so the set-down's
    /// watch waits for the next switch.
    on_declined_tube: bool,
    /// High-level steps between two looks at the load in transport ([`TRANSPORT_WATCH_S`]).
    watch_every: u32,
    /// High-level steps since the last look.
    watch_ticks: u32,
    /// The lift's overload watch (the own cable's tension estimate).
    overload: OverloadWatch,
    /// Horizontal speed limit of the own position holds, m/s (`VT_V_MAX`).
    v_max_mps: f32,
    /// The velocity loop's tilt cone as configured (`VL_TILT_MAX`), its tangent.
    tilt_max_tan: f32,
}

impl Flight {
    /// Arms: the cable calibration from the current positions of every UAV and the load
    /// (`vt_dissipative::calibrate`), the pre-flight check at the measured lean
    /// (`vt_dissipative::feasibility::check`), the take-off formation (eq:2-7), then the
    /// controllers from the parameters and the calibration (`VT_CTRL` picks the high-level law;
    /// the baseline takes the gains `VT_K1`..`VT_R_ACT`, no formation). Every backend of host-sim
    /// flies this (docs/design.md, "One flight logic").
    ///
    /// # Errors
    /// [`StartError`].
    pub fn start(params: &Params, tube: Option<&CompanionTube>, src: &Sources, now_ms: u32) -> Result<Self, StartError> {
        if tube.is_none() {
            return Err(StartError::NoTube);
        }
        let n = params.get_u32(Param::NUavs) as usize;
        let id = params.get_u32(Param::Id) as usize;
        let low_per_high = params.low_per_high().ok_or(StartError::BadTeam)?;
        if id >= n || n > MAX_UAVS {
            return Err(StartError::BadTeam);
        }
        let (own_tmo_ms, load_tmo_ms, nbr_tmo_ms) =
            (params.timeout_ms(Param::FsOwnTmo), params.timeout_ms(Param::FsLoadTmo), params.timeout_ms(Param::FsNbrTmo));
        let own = src.own.and_then(|s| s.fresh(now_ms, own_tmo_ms)).ok_or(StartError::StaleData)?;
        let load = src.load.and_then(|s| s.fresh(now_ms, load_tmo_ms)).ok_or(StartError::StaleData)?;
        // Every source must be fresh; the positions used are the survey's averages (the last
        // sample when the survey has none: it is fed whatever the start reads).
        let mut takeoff = [Vec3::zeros(); MAX_UAVS];
        for (j, slot) in takeoff.iter_mut().enumerate().take(n) {
            *slot = if j == id {
                src.survey.own().unwrap_or(own.pos_m)
            } else {
                let last = src.neighbours.get(j).copied().flatten().and_then(|s| s.fresh(now_ms, nbr_tmo_ms)).ok_or(StartError::StaleData)?;
                src.survey.member(j).unwrap_or(last)
            };
        }
        let takeoff = takeoff.get(..n).unwrap_or(&[]);
        let own_pos_m = takeoff.get(id).copied().unwrap_or(own.pos_m);
        let load_pos_m = src.survey.load().unwrap_or(load.pos_m);
        let vl = params.velocity_loop().map_err(StartError::VelocityLoop)?;
        let supervisor = TeamHoldSupervisor::new(params.get(Param::FsResume), params.high_level_dt_s()).map_err(StartError::Controller)?;
        let mut low = VelocityLoop::new(vl);
        let (high, profile, pending) = if params.ground_start() {
            // Ground start (docs/design.md, "Lift-off and set-down"): the arming waits for taut
            // cables, at the end of the tension build-up.
            let profile = PhaseProfile::ground(params.phases(load_pos_m.z).map_err(StartError::Controller)?).map_err(StartError::Controller)?;
            let pending = Pending { params: params.clone(), hold_xy_m: own_pos_m.xy(), vertical: params.nominal_vertical(), survey: TakeoffSurvey::new(u32::MAX), gusts: GustSurvey::default() };
            (None, Some(profile), Some(pending))
        } else {
            let (high, margin) = arm(params, id, n, takeoff, &load_pos_m, None)?;
            // Warm start with the declared load's share (bumpless transfer; capacity.rs).
            if let Some(f) = params.capacity().ok().and_then(|cap| capacity::takeoff_cable_force_n(&own_pos_m, &load_pos_m, cap.load_mass_kg, n)) {
                low.preload(f);
            }
            // In transport from the start; the phases only for a set-down (issue 29).
            let mut profile = PhaseProfile::air(params.phases(params.get(Param::LoadGz)).map_err(StartError::Controller)?).map_err(StartError::Controller)?;
            profile.brake_descent(margin);
            (Some(high), Some(profile), None)
        };
        Ok(Self {
            id,
            n,
            high,
            low,
            heading: params.heading(),
            thrust_max_n: vl.limits().thrust_max_n(),
            hover_n: vl.hover_thrust_n(),
            // The observer of a lightly loaded UAV: the declared load's share of each UAV's
            // weight, against the loop's own (validated) mass, lag and `mu`.
            loaded_cap_rad_s: vt_cfo::loaded_bandwidth_cap(params.get(Param::LoadKg) / (n as f32 * vl.mass_kg()), vl.actuator_lag_s(), vl.cfo().bandwidth_rad_s()),
            hl_dt_s: params.high_level_dt_s(),
            ll_dt_s: params.low_level_dt_s(),
            low_per_high,
            own_tmo_ms,
            load_tmo_ms,
            nbr_tmo_ms,
            hold_on_stale_neighbour: params.get_u32(Param::FsNbrAct) == 1,
            ll_ticks: 0,
            vel_cmd_mps: Vec3::zeros(),
            f_hat_n: Vec3::zeros(),
            hl_reasons: HoldReasons::default(),
            ll_reasons: HoldReasons::default(),
            last_command: None,
            supervisor,
            team_mode: TeamMode::Transport,
            invalid_commands: 0,
            operator_hold: false,
            no_route: 0,
            profile,
            pending,
            refusal: None,
            refusal_unreported: false,
            end_tol_m: params.get(Param::EndTol),
            load_hint: 0,
            rated_n: params.get(Param::CableRated),
            hold_watch: HoldWatch::new(),
            on_declined_tube: false,
            watch_every: watch_every(params.high_level_dt_s()),
            watch_ticks: 0,
            landing: Landing::new(params),
            overload: OverloadWatch::default(),
            v_max_mps: params.get(Param::VMax),
            tilt_max_tan: vl.limits().tilt_max_tan(),
        })
    }

    /// True when the high-level step is due at this lockstep tick (tick 0, then every
    /// `VT_LL_HZ / VT_HL_HZ` ticks).
    pub fn high_level_due(&self) -> bool {
        self.ll_ticks.is_multiple_of(self.low_per_high.max(1))
    }

    /// One high-level step at `now_ms`: the velocity command (zero in hold without usable own
    /// or load data; the controller's team hold while the team holds).
    pub fn high_level(&mut self, tube: &CompanionTube, src: &Sources, now_ms: u32) -> Vec3 {
        let mut reasons = if self.operator_hold { HoldReasons::OPERATOR } else { 0 };
        if self.no_route != 0 {
            reasons |= HoldReasons::NO_ROUTE;
        }
        if self.refusal.is_some() {
            reasons |= HoldReasons::REFUSED;
        }
        let own = src.own.and_then(|s| s.fresh(now_ms, self.own_tmo_ms));
        let load = src.load.and_then(|s| s.fresh(now_ms, self.load_tmo_ms));
        if own.is_none() {
            reasons |= HoldReasons::OWN_STALE;
        }
        if load.is_none() {
            reasons |= HoldReasons::LOAD_STALE;
        }
        let mut view: [Option<Vec3>; MAX_UAVS] = [None; MAX_UAVS];
        // Beside the team's slots (both arrays hold `MAX_UAVS`): no index to check.
        for (j, (slot, received)) in view.iter_mut().zip(src.neighbours.iter()).enumerate().take(self.n) {
            if j == self.id {
                *slot = own.map(|o| o.pos_m);
            } else {
                *slot = received.and_then(|s| s.fresh(now_ms, self.nbr_tmo_ms));
                // Hold, or leave the slot empty: the controller drops that neighbour's springs.
                if slot.is_none() && self.hold_on_stale_neighbour {
                    reasons |= HoldReasons::NEIGHBOUR_STALE;
                }
            }
        }
        // A fresh neighbour in hold: the team holds (docs/design.md, "Team failsafe"). No
        // neighbour holds in nominal flight: one test then.
        let holds = src.neighbour_hold;
        let follow = holds.any() && view.iter().enumerate().take(self.n).any(|(j, v)| v.is_some() && holds.get(j));
        self.vel_cmd_mps = Vec3::zeros();
        self.team_mode = self.supervisor.step(reasons != 0, follow);
        if let (Some(own), Some(load)) = (own, load) {
            let holding = self.team_mode.is_holding();
            self.advance_phases(tube, &own.pos_m, &load.pos_m, &view, holding, src.neighbour_released.any());
            let phase = self.phase();
            // The observer of a free UAV (vt_cfo::UNLOADED_BANDWIDTH_RAD_S) and of a lightly
            // loaded one (`loaded_cap_rad_s`): one comparison while the phase keeps its cable
            // loaded or unloaded.
            self.low.set_bandwidth_cap(if phase.unloaded() { UNLOADED_BANDWIDTH_RAD_S } else { self.loaded_cap_rad_s });
            if phase == Phase::Released {
                // The release (a delivery, a set-down, a refusal on the ground): land in place.
                self.vel_cmd_mps = self.landing_command(tube, own.pos_m, view.get(..self.n).unwrap_or(&[]));
                self.hl_reasons = HoldReasons(reasons);
                return self.vel_cmd_mps;
            }
            let z_ref = self.profile.as_ref().map(PhaseProfile::load_altitude_ref_m);
            let Some(high) = self.high.as_mut() else {
                // A ground start before its arming (or refused): the hold, with the tube kept.
                self.vel_cmd_mps = self.unarmed_command(tube, &own.pos_m, &load.pos_m, view.get(..self.n).unwrap_or(&[]));
                self.hl_reasons = HoldReasons(reasons);
                return self.vel_cmd_mps;
            };
            // Own and load usable: transport, or the team hold while the team holds (and in
            // every phase of a ground start but the transport).
            high.set_team_hold(holding || phase.passing_off());
            // A hold for want of a route holds every UAV where it is (docs/design.md, "The
            // no-route hold holds in place").
            if holding && self.no_route != 0 {
                high.anchor_team_hold();
            }
            if let Some(z) = z_ref {
                high.set_load_altitude_ref(z, phase.sharing());
            }
            high.set_heaving(phase.heaving());
            // A released neighbour lands: its springs and clearance leave the armed law, which
            // would otherwise pull the UAVs still flying over its spot on the ground
            // (docs/design.md, "A refused start lands at once"). No neighbour is released in
            // transport: one test then.
            if src.neighbour_released.any() {
                for (j, slot) in view.iter_mut().enumerate().take(self.n) {
                    if src.neighbour_released.get(j) {
                        *slot = None;
                    }
                }
            }
            // Measurements carried forward to now (vt_cfo::prediction): own position by the
            // velocity loop's last prediction (made from this same sample), the load at constant
            // velocity.
            let pred = self.low.prediction();
            let own_pos_m = if pred.delay_steps > 0 { own.pos_m + pred.displacement_m } else { own.pos_m };
            let load_age_s = age_s(now_ms, load.sample_ms);
            let m = Measurements {
                own_pos_m,
                own_vel_mps: own.vel_mps,
                load_pos_m: extrapolate_constant_velocity(load.pos_m, load.vel_mps, load_age_s),
                load_vel_mps: load.vel_mps,
                neighbours_m: view.get(..self.n).unwrap_or(&[]),
                neighbours_vel_mps: src.neighbour_vel_mps.get(..self.n).unwrap_or(&[]),
                own_cable_force_n: Some(self.f_hat_n),
            };
            let cmd = high.update(tube, &m, self.hl_dt_s);
            self.last_command = Some(cmd);
            if cmd.status.nonfinite_command || !finite3(&cmd.vel_mps) {
                reasons |= HoldReasons::NONFINITE;
            } else if cmd.status.invalid_input {
                reasons |= HoldReasons::INVALID_INPUT;
            } else {
                self.vel_cmd_mps = cmd.vel_mps;
                if matches!(phase, Phase::Descent | Phase::Slack) {
                    self.limit_descent_speed(phase);
                }
            }
            if reasons & (HoldReasons::NONFINITE | HoldReasons::INVALID_INPUT) != 0 {
                self.invalid_commands = self.invalid_commands.wrapping_add(1);
                // The controller flagged its output: an own detection after all (the hold
                // restarts whatever the neighbours say).
                self.team_mode = self.supervisor.step(true, false);
            }
        }
        self.hl_reasons = HoldReasons(reasons);
        self.vel_cmd_mps
    }

    /// Why a ground start was refused at its arming or abandoned its lift (the load on the
    /// ground); `None` while it flies.
    pub fn refusal(&self) -> Option<&StartError> {
        self.refusal.as_ref()
    }

    /// The refusal once, to report (`STATUSTEXT`, heartbeat): `None` afterwards.
    pub fn take_refusal(&mut self) -> Option<StartError> {
        if self.refusal_unreported {
            self.refusal_unreported = false;
            self.refusal
        } else {
            None
        }
    }

    /// One low-level step at `now_ms`: the attitude setpoint.
    pub fn low_level(&mut self, src: &Sources, now_ms: u32) -> Setpoint {
        let mut reasons = 0u8;
        let (v_meas, own_age_s) = match src.own.and_then(|s| s.fresh(now_ms, self.own_tmo_ms)) {
            Some(own) => (own.vel_mps, age_s(now_ms, own.sample_ms)),
            None => {
                reasons |= HoldReasons::OWN_STALE;
                (Vec3::repeat(f32::NAN), 0.0) // the velocity loop's no-measurement failsafe
            }
        };
        // Zero unless the high level had usable own and load data (then also in team hold).
        let out = self.low.update_delayed(self.vel_cmd_mps, v_meas, own_age_s, self.ll_dt_s);
        self.f_hat_n = out.f_hat_n;
        let att = thrust_to_attitude(out.thrust_n, self.heading, self.thrust_max_n);
        let mut sp = Setpoint { q_ned: ned_frd_quaternion(&att.attitude), thrust: att.collective };
        // Every component finite: one sum (vt_fpu::zero_or_nan).
        let finite_probe = sp.q_ned.iter().fold(vt_fpu::zero_or_nan(sp.thrust), |acc, &c| acc + vt_fpu::zero_or_nan(c));
        if finite_probe != 0.0 {
            reasons |= HoldReasons::NONFINITE;
            sp = self.level_hover();
        }
        if self.landing.landed() {
            sp = self.idle();
        }
        self.ll_reasons = HoldReasons(reasons);
        self.ll_ticks = self.ll_ticks.wrapping_add(1);
        sp
    }

    /// Down after the release: level, rotors at idle (PX4 disarms on its land detector).
    #[cold]
    #[inline(never)]
    fn idle(&self) -> Setpoint {
        Setpoint { thrust: 0.0, ..self.level_hover() }
    }

    /// Level attitude along the heading at the hover collective (the last-resort output):
    /// the attitude of a vertical hover thrust, trig-free like the nominal path.
    fn level_hover(&self) -> Setpoint {
        let att = thrust_to_attitude(Vec3::new(0.0, 0.0, self.hover_n.max(0.0)), self.heading, self.thrust_max_n);
        let q_ned = ned_frd_quaternion(&att.attitude);
        if q_ned.iter().all(|c| c.is_finite()) && att.collective.is_finite() {
            Setpoint { q_ned, thrust: att.collective }
        } else {
            // Unreachable for a unit heading; a defined output all the same.
            Setpoint { q_ned: ned_frd_quaternion(&UnitQuaternion::identity()), thrust: 0.0 }
        }
    }

    /// Current hold reasons (high and low level).
    pub fn hold_reasons(&self) -> HoldReasons {
        let operator = if self.operator_hold { HoldReasons::OPERATOR } else { 0 };
        let no_route = if self.no_route != 0 { HoldReasons::NO_ROUTE } else { 0 };
        HoldReasons(self.hl_reasons.0 | self.ll_reasons.0 | operator | no_route)
    }

    /// The team mode decided at the last high-level step (what this UAV broadcasts).
    pub fn team_mode(&self) -> TeamMode {
        self.team_mode
    }

    /// The last velocity command, m/s, world ENU.
    pub fn velocity_command_mps(&self) -> Vec3 {
        self.vel_cmd_mps
    }

    /// The CFO's cable-force estimate `f_hat`, N, world ENU.
    pub fn cable_force_n(&self) -> Vec3 {
        self.f_hat_n
    }

    /// The last high-level command with its status (None before the first nominal step).
    pub fn last_command(&self) -> Option<&Command> {
        self.last_command.as_ref()
    }

    /// The operator's hold on or off: while on, this UAV holds as after its own detection (it
    /// broadcasts `Hold`, the team follows); after it is lifted the team resumes `FS_RESUME`
    /// later, as after any alarm.
    pub fn set_operator_hold(&mut self, on: bool) {
        self.operator_hold = on;
    }

    /// Issue 28: the team's planner found no route (on: hold in place, as the operator's hold
    /// does; off: a later plan found one).
    pub fn set_no_route(&mut self, on: bool) {
        self.no_route = if on { self.no_route | NO_ROUTE_TEAM } else { self.no_route & !NO_ROUTE_TEAM };
    }

    /// Issue 28: the team holds for want of a route ([`Flight::set_no_route`]).
    pub fn team_no_route(&self) -> bool {
        self.no_route & NO_ROUTE_TEAM != 0
    }

    /// Issue 28: this UAV's own tube is blocked close ahead and it has no tube it may switch to
    /// (`perception::Perception::must_stop`; on: hold in place with
    /// [`HoldReasons::NO_ROUTE`], as the team's no-route hold; off: it switched, or the block
    /// cleared).
    pub fn set_blocked(&mut self, on: bool) {
        self.no_route = if on { self.no_route | NO_ROUTE_BLOCKED } else { self.no_route & !NO_ROUTE_BLOCKED };
    }

    /// The tube was switched (issue 28): the set-down's watch restarts on the new tube (its
    /// drift trigger compares arc lengths of one tube; its edge trigger waits until the load has
    /// been well inside the new one), the load's lookup from anywhere.
    pub fn tube_switched(&mut self) {
        self.hold_watch = HoldWatch::new();
        self.on_declined_tube = false;
        self.load_hint = 0;
    }

    /// This UAV switched to a re-planned tube it is not yet inside (issue 28,
    /// `perception::accept_joining`): as [`Flight::tube_switched`], and the dissipative
    /// controller's barriers see the tube widened until its node is inside
    /// (`DissipativeController::join_tube`). False (nothing changed) when the baseline flies:
    /// it keeps the old tube.
    pub fn tube_joined(&mut self) -> bool {
        let Some(HighLevel::Dissipative(c)) = self.high.as_mut() else {
            return false;
        };
        c.join_tube();
        self.tube_switched();
        true
    }

    /// Issue 28: the narrowest tube half-width the formation shaped to the tube keeps its
    /// separation floor in, m (`DissipativeController::shaped_need_half_width_m`, the stadium
    /// framed by `tube`'s direction at `load_xy_m` before the first look); `None` when no
    /// shape with a floor is flown. A re-plan asks the planner for at least this much.
    pub fn shaped_need_half_width_m(&self, tube: &CompanionTube, load_xy_m: vt_tube::Vec2) -> Option<f32> {
        let Some(HighLevel::Dissipative(c)) = self.high.as_ref() else {
            return None;
        };
        let tangent = tube.locate(load_xy_m, 0).map_or(vt_tube::Vec2::new(1.0, 0.0), |sec| sec.tangent);
        c.shaped_need_half_width_m(&tangent)
    }

    /// This UAV declined a newer tube and keeps flying its own (issue 28): the set-down's watch
    /// waits until it switches.
    pub fn tube_declined(&mut self) {
        self.on_declined_tube = true;
    }

    /// True while the operator's hold is on.
    pub fn operator_hold(&self) -> bool {
        self.operator_hold
    }

    /// High-level commands so far that fell back to hold (invalid input or non-finite output).
    pub fn invalid_commands(&self) -> u32 {
        self.invalid_commands
    }

    /// Low-level steps so far.
    pub fn low_level_ticks(&self) -> u32 {
        self.ll_ticks
    }
}

#[cfg(test)]
#[path = "flight_tests.rs"]
pub(crate) mod tests;
