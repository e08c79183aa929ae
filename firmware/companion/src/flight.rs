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
//! # Failsafe (hold)
//! Own state older than `FS_OWN_TMO`, load state older than `FS_LOAD_TMO`, any neighbour older
//! than `FS_NBR_TMO` (or never heard; with `FS_NBR_ACT = 0` such a neighbour is only dropped
//! from the spring set, as host-sim's controllers do), or a controller output that is
//! non-finite or flagged invalid: the velocity command becomes zero (no horizontal motion, no climb), which the
//! velocity loop turns into the hover thrust corrected by the CFO's force estimate. With no
//! fresh own velocity the velocity loop gets NaN and flies its own failsafe: the compensated
//! hover thrust `f_hat - G` without feedback. Hold ends by itself when every input is fresh
//! again. The reasons are reported in `HEARTBEAT.custom_mode` ([`HoldReasons`]).

use nalgebra::{Unit, UnitQuaternion, Vector2};
use vt_cfo::{age_s, extrapolate_constant_velocity, thrust_to_attitude, VelocityLoop};
use vt_dissipative::{capacity, Command, DissipativeController, Formation, FormationScale, Measurements};

use crate::frames::{finite3, ned_frd_quaternion};
use crate::params::{Param, Params};
use crate::{CompanionTube, Vec3, MAX_UAVS};

/// Why the companion holds (bit set, reported in telemetry).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HoldReasons(pub u8);

impl HoldReasons {
    /// Own state stale or missing.
    pub const OWN_STALE: u8 = 1 << 0;
    /// Load state stale or missing.
    pub const LOAD_STALE: u8 = 1 << 1;
    /// A neighbour's position stale or missing.
    pub const NEIGHBOUR_STALE: u8 = 1 << 2;
    /// The high-level controller flagged invalid input.
    pub const INVALID_INPUT: u8 = 1 << 3;
    /// A command was non-finite.
    pub const NONFINITE: u8 = 1 << 4;

    /// True when no reason is set.
    pub fn is_clear(self) -> bool {
        self.0 == 0
    }
}

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
}

impl Default for Sources {
    fn default() -> Self {
        Self::new()
    }
}

impl Sources {
    /// Nothing received yet.
    pub const fn new() -> Self {
        Self { own: None, load: None, neighbours: [None; MAX_UAVS] }
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
    id: usize,
    n: usize,
    high: DissipativeController<MAX_UAVS>,
    low: VelocityLoop,
    heading: Unit<Vector2<f32>>,
    thrust_max_n: f32,
    hover_n: f32,
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
}

impl Flight {
    /// Arms: the cable calibration from the current positions of every UAV and the load
    /// (`vt_dissipative::calibrate`), the pre-flight check at the measured lean
    /// (`vt_dissipative::feasibility::check`), the take-off formation (eq:2-7), then the
    /// controllers from the parameters and the calibration. host-sim's `CrateTeam::start` makes
    /// the same calls with the same `f32` inputs.
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
        let mut takeoff = [Vec3::zeros(); MAX_UAVS];
        for (j, slot) in takeoff.iter_mut().enumerate().take(n) {
            *slot = if j == id {
                own.pos_m
            } else {
                src.neighbours.get(j).copied().flatten().and_then(|s| s.fresh(now_ms, nbr_tmo_ms)).ok_or(StartError::StaleData)?
            };
        }
        let takeoff = takeoff.get(..n).unwrap_or(&[]);
        let cal = vt_dissipative::calibrate(id, takeoff, &load.pos_m, &params.calibration()).map_err(StartError::Calibration)?;
        vt_dissipative::feasibility::check(&params.feasibility(cal.cos_lean)).map_err(StartError::Infeasible)?;
        let dissipative = params.dissipative(&cal).map_err(StartError::Controller)?;
        let tray = params.tray();
        let formation = Formation::<MAX_UAVS>::from_takeoff(takeoff, &load.pos_m, &tray)
            .map_err(StartError::Controller)?;
        // Capacity-aware formation (issue 15): every UAV plans from the same take-off measurement.
        let cap = params.capacity().map_err(StartError::Controller)?;
        let plan = capacity::plan_from_takeoff(takeoff.get(..n).unwrap_or(&[]), &load.pos_m, &tray, &cap)
            .map_err(StartError::Controller)?;
        let mut high = DissipativeController::new(id, dissipative, &formation).map_err(StartError::Controller)?;
        high.set_capacity(FormationScale::new(&plan, &cap));
        let vl = params.velocity_loop().map_err(StartError::VelocityLoop)?;
        let mut low = VelocityLoop::new(vl);
        // Warm start with the declared load's share (bumpless transfer; capacity.rs).
        if let Some(f) = capacity::takeoff_cable_force_n(&own.pos_m, &load.pos_m, cap.load_mass_kg, n) {
            low.preload(f);
        }
        Ok(Self {
            id,
            n,
            high,
            low,
            heading: params.heading(),
            thrust_max_n: vl.limits().thrust_max_n(),
            hover_n: vl.hover_thrust_n(),
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
        })
    }

    /// True when the high-level step is due at this lockstep tick (tick 0, then every
    /// `VT_LL_HZ / VT_HL_HZ` ticks).
    pub fn high_level_due(&self) -> bool {
        self.ll_ticks.is_multiple_of(self.low_per_high.max(1))
    }

    /// One high-level step at `now_ms`: the velocity command (zero in hold).
    pub fn high_level(&mut self, tube: &CompanionTube, src: &Sources, now_ms: u32) -> Vec3 {
        let mut reasons = 0u8;
        let own = src.own.and_then(|s| s.fresh(now_ms, self.own_tmo_ms));
        let load = src.load.and_then(|s| s.fresh(now_ms, self.load_tmo_ms));
        if own.is_none() {
            reasons |= HoldReasons::OWN_STALE;
        }
        if load.is_none() {
            reasons |= HoldReasons::LOAD_STALE;
        }
        let mut view: [Option<Vec3>; MAX_UAVS] = [None; MAX_UAVS];
        for (j, slot) in view.iter_mut().enumerate().take(self.n) {
            if j == self.id {
                *slot = own.map(|o| o.pos_m);
            } else {
                *slot = src.neighbours.get(j).copied().flatten().and_then(|s| s.fresh(now_ms, self.nbr_tmo_ms));
                // Hold, or leave the slot empty: the controller drops that neighbour's springs.
                if slot.is_none() && self.hold_on_stale_neighbour {
                    reasons |= HoldReasons::NEIGHBOUR_STALE;
                }
            }
        }
        self.vel_cmd_mps = Vec3::zeros();
        if let (0, Some(own), Some(load)) = (reasons, own, load) {
            // Measurements carried forward to now (vt_cfo::prediction): own position by the
            // velocity loop's last prediction (made from this same sample), the load at constant
            // velocity.
            let pred = self.low.prediction();
            let own_pos_m = if pred.delay_steps > 0 { own.pos_m + pred.displacement_m } else { own.pos_m };
            let load_age_s = age_s(now_ms, load.sample_ms);
            let m = Measurements {
                own_pos_m,
                load_pos_m: extrapolate_constant_velocity(load.pos_m, load.vel_mps, load_age_s),
                load_vel_mps: load.vel_mps,
                neighbours_m: view.get(..self.n).unwrap_or(&[]),
                own_cable_force_n: Some(self.f_hat_n),
            };
            let cmd = self.high.update(tube, &m, self.hl_dt_s);
            self.last_command = Some(cmd);
            if cmd.status.nonfinite_command || !finite3(&cmd.vel_mps) {
                reasons |= HoldReasons::NONFINITE;
            } else if cmd.status.invalid_input {
                reasons |= HoldReasons::INVALID_INPUT;
            } else {
                self.vel_cmd_mps = cmd.vel_mps;
            }
        }
        self.hl_reasons = HoldReasons(reasons);
        self.vel_cmd_mps
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
        let v_cmd = if self.hl_reasons.is_clear() { self.vel_cmd_mps } else { Vec3::zeros() };
        let out = self.low.update_delayed(v_cmd, v_meas, own_age_s, self.ll_dt_s);
        self.f_hat_n = out.f_hat_n;
        let att = thrust_to_attitude(out.thrust_n, self.heading, self.thrust_max_n);
        let mut sp = Setpoint { q_ned: ned_frd_quaternion(&att.attitude), thrust: att.collective };
        if !(sp.q_ned.iter().all(|c| c.is_finite()) && sp.thrust.is_finite()) {
            reasons |= HoldReasons::NONFINITE;
            sp = self.level_hover();
        }
        self.ll_reasons = HoldReasons(reasons);
        self.ll_ticks = self.ll_ticks.wrapping_add(1);
        sp
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
        HoldReasons(self.hl_reasons.0 | self.ll_reasons.0)
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

    /// Low-level steps so far.
    pub fn low_level_ticks(&self) -> u32 {
        self.ll_ticks
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vt_dissipative::{CalibrationError, FeasibilityError};

    /// The default parameters (the experiment: 3 UAVs, 3.06 kg) with every source fresh at
    /// t = 0: UAVs on a 1.125 m circle 3 m above the load (3.2 m cables, lean cos 0.936).
    fn setup(load_kg: f32, uav1_z: f32) -> (Params, Box<CompanionTube>, Sources) {
        let mut p = Params::new();
        p.set(Param::LoadKg, load_kg).unwrap();
        let mut tube = Box::new(CompanionTube::placeholder());
        tube.rebuild(&[vt_tube::Waypoint::new(0.0, 0.0, 3.5, 3.5), vt_tube::Waypoint::new(20.0, 0.0, 3.5, 3.5)]).unwrap();
        let load = Vec3::new(2.0, 0.0, 3.0);
        let at = |i: usize| {
            let a = i as f32 * 2.0944;
            load + Vec3::new(1.125 * libm::cosf(a), 1.125 * libm::sinf(a), if i == 1 { uav1_z } else { 3.0 })
        };
        let stamped = |pos_m| Stamped { value: State { pos_m, vel_mps: Vec3::zeros(), sample_ms: 0 }, stamp_ms: 0 };
        let mut src = Sources::new();
        src.own = Some(stamped(at(0)));
        src.load = Some(stamped(load));
        for j in 1..3 {
            src.neighbours[j] = Some(Stamped { value: at(j), stamp_ms: 0 });
        }
        (p, tube, src)
    }

    #[test]
    fn a_plausible_take_off_calibrates_and_starts() {
        let (p, tube, src) = setup(3.06, 3.0);
        let fl = Flight::start(&p, Some(&tube), &src, 0).unwrap();
        assert!(fl.hold_reasons().is_clear());
    }

    #[test]
    fn an_overweight_declared_load_is_refused_with_the_numbers() {
        // Three 1.47 kg / 30 N UAVs at 30 deg tilt hold about 16 N each along a cable leaning
        // 20.6 deg: 45 N of vertical force for 58.9 N (6 kg).
        let (p, tube, src) = setup(6.0, 3.0);
        match Flight::start(&p, Some(&tube), &src, 0) {
            Err(StartError::Infeasible(FeasibilityError::Infeasible { needed_n, available_n, margin, min_margin })) => {
                assert!((needed_n - 58.86).abs() < 1e-3, "{needed_n}");
                assert!((available_n - 45.1).abs() < 0.1, "{available_n}");
                assert!((margin - (available_n / needed_n - 1.0)).abs() < 1e-7);
                assert_eq!(min_margin, 0.01);
            }
            other => panic!("{other:?}"),
        }
        // 4.58 kg (44.9 N) is within the capacity, but not with 1 % to spare: still refused.
        let (p, tube, src) = setup(4.58, 3.0);
        assert!(matches!(Flight::start(&p, Some(&tube), &src, 0), Err(StartError::Infeasible(_))));
        // With the requirement lowered to 0 %, it starts.
        let (mut p, tube, src) = setup(4.58, 3.0);
        p.set(Param::MarginMin, 0.0).unwrap();
        assert!(Flight::start(&p, Some(&tube), &src, 0).is_ok());
    }

    #[test]
    fn an_implausible_take_off_is_refused_by_the_calibration() {
        // UAV 1 below the load.
        let (p, tube, src) = setup(3.06, -0.5);
        assert_eq!(Flight::start(&p, Some(&tube), &src, 0).err(), Some(StartError::Calibration(CalibrationError::NotAboveLoad { index: 1 })));
        // A cable longer than VT_CABLE_LMAX.
        let (mut p, tube, src) = setup(3.06, 3.0);
        p.set(Param::CableLMax, 2.0).unwrap();
        assert!(matches!(
            Flight::start(&p, Some(&tube), &src, 0),
            Err(StartError::Calibration(CalibrationError::LengthOutOfRange { max_m, .. })) if max_m == 2.0
        ));
        // A cable too soft for the load: the stretch exceeds the distance.
        let (mut p, tube, src) = setup(3.06, 3.0);
        p.set(Param::CableK, 1.0).unwrap();
        assert!(matches!(Flight::start(&p, Some(&tube), &src, 0), Err(StartError::Calibration(CalibrationError::StretchExceedsDistance { .. }))));
        // The refusal codes are distinct (HEARTBEAT.custom_mode bits 16..23).
        assert_eq!(StartError::Calibration(CalibrationError::NonFiniteLoad).code(), 6);
    }
}
