//! The whole mission from the ground (issue 27 §2; the paper starts in the air): take-off,
//! tension build-up, lift, climb, transport, descent with set-down, slack, release.
//!
//! The sequence is one scalar the team shares: the load altitude reference `z_l,ref(t)` of the
//! altitude law ([`crate::vertical`]), ramped from below the ground to the transport altitude
//! and back. Every UAV computes the same ramp from the same inputs (the load's altitude
//! measured at the start, the shared parameters, the high-level clock since the common start
//! command), so the team changes phase together without a message; a team hold freezes the
//! ramp and the timers, so no phase advances while anybody holds.
//!
//! | phase | `z_l,ref` | the UAV flies (docs/design.md, "Lift-off and set-down") |
//! |---|---|---|
//! | take-off | `z_g - slack` | own horizontal position held; climb to `slack` below taut |
//! | tension | (not used) | climb at `v_t` until the own cable carries [`PhaseParams::pretension_n`] (tension loop on the observer's estimate); the survey in its last `settle_s` |
//! | lift | `z_g + v_lift t` up to `lift_clear_m + lift_extra_m` | the armed controller, passing off; ends when the load is `lift_clear_m` up, refused when it has not risen [`LIFT_PROGRESS_M`] for [`LIFT_PROGRESS_TIMEOUT_S`] with the ramp at its top |
//! | climb | `+ v_climb t` up to `z_t` | as lift; ends when the load is within [`CLIMB_ARRIVE_M`] of `z_t`, set down from where it hangs when it stops rising short of it ([`CLIMB_ARRIVE_TIMEOUT_S`]) |
//! | transport | `z_t` | the paper's controller; arrival latched, `settle_s` later: descent (a ground start; an air start hovers at the end); a set-down ([`HoldWatch`]) descends at once |
//! | descent | down at `v_climb`, `v_lift` in the last `touchdown_band_m` | passing off, load sharing on the tensions alone ([`crate::vertical::Sharing::Tension`]) |
//! | slack | down to `z_g - slack` at `v_lift` | passing off, load sharing off |
//! | released | `z_g - slack` | land in place at [`crate::landing::LAND_SPEED_MPS`], motors idle once down ([`crate::landing::LandDetector`]); a start refused before the lift comes here at once: a UAV that cannot hold its place before the arming ([`PhaseProfile::land_now`]), the start checks' refusal at the arming and a start held too long before it ([`PhaseProfile::refuse`]) |

use crate::ControlError;

/// The team cannot hold the tube when the load has been carried this far back along it from the
/// furthest it reached, m (a wind against the passing direction beyond the team's capacity).
pub const SET_DOWN_BLOWN_BACK_M: f32 = 2.0;
/// ... or when the load stays this close to the tube's boundary, m, for
/// [`SET_DOWN_EDGE_CONFIRM_S`] ...
pub const SET_DOWN_LOAD_EDGE_M: f32 = 0.5;
/// ... net, s: a load swinging on its cables in a narrow tube grazes the edge band for a few
/// tenths of a second at the end of each swing, and its measured position carries the tracker's
/// noise; a team that is losing the tube stays there (issue 29: the 2.5 m narrowing set 3 of 40
/// nominal ground starts down on such swings, two of them never nearer than 0.56 m) ...
pub const SET_DOWN_EDGE_CONFIRM_S: f32 = 0.4;
/// ... or at once when the load comes this close, m (a load driven at the wall does not wait).
pub const SET_DOWN_LOAD_EDGE_HARD_M: f32 = 0.25;
/// After arrival the tube's end is a stop (issue 29): the team cannot hold it when the load has
/// been carried this far past the end terminal along the end's tangent, m. The end stop's
/// barrier pushes a node back only near the end disk's rim; a load this far past has been carried
/// by a wind the stop does not hold.
pub const SET_DOWN_PAST_END_M: f32 = 1.0;

/// The climb ends once its ramp is at the transport altitude and the load within this of it, m
/// (issue 27: at 19.8 kg on the 20 N clamp the load climbs at the team's last newtons and was
/// 2.4 m below when the ramp ended; the transport is judged on the load's altitude).
pub const CLIMB_ARRIVE_M: f32 = 0.5;
/// ... and a load short of it that has not risen [`CLIMB_PROGRESS_M`] for this long, the ramp
/// up, is set down, s ...
pub const CLIMB_ARRIVE_TIMEOUT_S: f32 = 10.0;
/// ... m.
pub const CLIMB_PROGRESS_M: f32 = 0.1;

/// The lift is refused once its ramp is at its top (`lift_clear_m + lift_extra_m` above the
/// ground, where it stops) and the load has not risen [`LIFT_PROGRESS_M`] for this long, s
/// (issue 27: at 19.8 kg on the 20 N clamp the load leaves the ground at the team's last newtons,
/// 0.06 m/s, and was 1 cm short of `lift_clear_m` when the ramp passed its top; docs/design.md,
/// "The lift ends with the load off the ground") ...
pub const LIFT_PROGRESS_TIMEOUT_S: f32 = 5.0;
/// ... m (above the RTK load tracker's centimetres).
pub const LIFT_PROGRESS_M: f32 = 0.05;

/// Horizontal speed limit of the formation while a delivered load descends and the cables
/// slacken, m/s (phases `Descent` and `Slack` after arrival; not a set-down, which must keep the
/// tube against a wind it could not hold). The team only holds its place there, and a formation
/// limit cycle swings with an amplitude proportional to the speed limit (the 25-UAV team: about
/// 0.3 s x `v_max`, docs/robustness.md), which the touchdown then meets: 20 of 40 nominal
/// ground starts touched down above 0.5 m/s at `v_max` = 1.5 m/s, none at this limit.
pub const DESCENT_V_MAX_MPS: f32 = 0.5;

/// The horizontal speed limit of `phase`, m/s: [`DESCENT_V_MAX_MPS`] in a delivery's descent and
/// slack (`set_down` false), `v_max_mps` otherwise.
pub fn horizontal_speed_limit_mps(phase: Phase, set_down: bool, v_max_mps: f32) -> f32 {
    if matches!(phase, Phase::Descent | Phase::Slack) && !set_down {
        v_max_mps.min(DESCENT_V_MAX_MPS)
    } else {
        v_max_mps
    }
}

/// The load must have been this far inside its tube before the edge triggers of [`HoldWatch`]
/// count, m: a tube re-planned in flight (issue 28) may start with the load near its edge, and
/// that is the planner's fit around an obstacle, not the team losing the tube.
pub const SET_DOWN_EDGE_ARM_M: f32 = 2.0 * SET_DOWN_LOAD_EDGE_M;

/// The set-down's watch over one tube: the furthest the load got along it, and whether the load
/// has been [`SET_DOWN_EDGE_ARM_M`] inside it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HoldWatch {
    /// Furthest arc length of the load along the tube so far, m.
    s_max_m: f32,
    /// The load has been [`SET_DOWN_EDGE_ARM_M`] inside the tube.
    edge_armed: bool,
    /// Time the load has spent in the edge band, net.
    near_edge: crate::dwell::Dwell,
}

impl Default for HoldWatch {
    fn default() -> Self {
        Self::new()
    }
}

impl HoldWatch {
    /// A watch over a tube the load has not been seen in yet.
    pub const fn new() -> Self {
        Self {
            s_max_m: f32::MIN,
            edge_armed: false,
            near_edge: crate::dwell::Dwell::new(),
        }
    }

    /// One look at the load, `dt_s` (s) after the last: its arc length `s_m` along the tube and
    /// its distance to the boundary `load_boundary_m`, m. True when the team cannot hold the
    /// tube: carried back ([`SET_DOWN_BLOWN_BACK_M`]), or, once armed, in the edge band
    /// ([`SET_DOWN_LOAD_EDGE_M`]) for [`SET_DOWN_EDGE_CONFIRM_S`] net, or nearer than
    /// [`SET_DOWN_LOAD_EDGE_HARD_M`]. NaN figures never trigger.
    pub fn cannot_hold(&mut self, s_m: f32, load_boundary_m: f32, dt_s: f32) -> bool {
        self.s_max_m = self.s_max_m.max(s_m);
        self.s_max_m - s_m > SET_DOWN_BLOWN_BACK_M || self.at_edge(load_boundary_m, dt_s)
    }

    /// One look at the load after arrival, `dt_s` (s) after the last: how far it is past the end
    /// terminal along the end's tangent `past_end_m` (negative before it) and its distance to
    /// the boundary (the end disk's rim past the end), m. True when the team cannot hold the end:
    /// carried past it by more than [`SET_DOWN_PAST_END_M`], or at the edge as in
    /// [`Self::cannot_hold`]. NaN figures never trigger.
    pub fn cannot_hold_end(&mut self, past_end_m: f32, load_boundary_m: f32, dt_s: f32) -> bool {
        past_end_m > SET_DOWN_PAST_END_M || self.at_edge(load_boundary_m, dt_s)
    }

    /// The edge triggers: once armed, in the edge band for the confirmation time net, or nearer
    /// than the hard edge.
    fn at_edge(&mut self, load_boundary_m: f32, dt_s: f32) -> bool {
        self.edge_armed |= load_boundary_m >= SET_DOWN_EDGE_ARM_M;
        let in_band = self.edge_armed && load_boundary_m < SET_DOWN_LOAD_EDGE_M;
        // Within rounding of the confirmation time (a sum of watch periods).
        let confirmed = self.near_edge.step(in_band, dt_s) >= SET_DOWN_EDGE_CONFIRM_S - 1e-4;
        let hard = self.edge_armed && load_boundary_m < SET_DOWN_LOAD_EDGE_HARD_M;
        hard || confirmed
    }
}

/// A team hold during the lift longer than this abandons it, s (the load is still down; a UAV
/// that refused its arming holds its team).
pub const LIFT_HOLD_ABORT_S: f32 = 3.0;

/// A set-down's slow final band above the ground, m (a normal descent's is
/// [`PhaseParams::touchdown_band_m`]).
pub const SET_DOWN_TOUCHDOWN_BAND_M: f32 = 0.3;

/// A UAV abandons the lift when its own cable's tension estimate passes this many times the
/// rated tension while the load is still on the ground (an overload shows in every cable at
/// once, so the team abandons together; below the 1.5 x rated snatch the issue allows).
pub const LIFT_ABORT_FACTOR: f32 = 1.25;

/// ... for this long, net, s: a cable that bounces on the lift (the 7-UAV S-bend's true tensions
/// swing by 10-20 N at 2.5 Hz while they build up, and touched 24 N of a 25 N abort level)
/// passes the level for a few hundredths of a second; an overload stays above it as the ramp
/// rises (docs/design.md, "Lift-off and set-down").
pub const LIFT_ABORT_CONFIRM_S: f32 = 0.1;

/// The lift's overload watch: an up-down timer on the own cable's tension estimate above
/// [`LIFT_ABORT_FACTOR`] times the rating ([`LIFT_ABORT_CONFIRM_S`] net above it abandons).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OverloadWatch {
    above: crate::dwell::Dwell,
}

impl OverloadWatch {
    /// One look at the own cable's tension estimate `tension_n` (N) against `rated_n` (N) after
    /// `dt_s`; true when the lift must be abandoned. NaN never counts as above.
    pub fn overloaded(&mut self, tension_n: f32, rated_n: f32, dt_s: f32) -> bool {
        // Within rounding of the confirmation time (a sum of high-level periods).
        self.above.step(tension_n > LIFT_ABORT_FACTOR * rated_n, dt_s) >= LIFT_ABORT_CONFIRM_S - 1e-4
    }
}

/// A phase of the mission (numbering: the MAVLink `custom_mode` byte and the record).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// UAVs climb to just below taut cables (the load rests on the ground).
    Takeoff = 1,
    /// Cables go taut; the tension builds up to the pretension; the team surveys.
    Tension = 2,
    /// The load's reference rises slowly until the load leaves the ground.
    Lift = 3,
    /// Climb to the transport altitude.
    Climb = 4,
    /// The paper's mission (an air start is in this phase from its start).
    Transport = 5,
    /// Descent at the goal until the load touches the ground.
    Descent = 6,
    /// The UAVs sink until the cables are slack.
    Slack = 7,
    /// Done: hovering with slack cables, the load on the ground (released).
    Released = 8,
}

impl Phase {
    /// Every phase in order.
    pub const ALL: [Phase; 8] =
        [Phase::Takeoff, Phase::Tension, Phase::Lift, Phase::Climb, Phase::Transport, Phase::Descent, Phase::Slack, Phase::Released];

    /// Lower-case name (record, summary, telemetry).
    pub fn name(self) -> &'static str {
        match self {
            Self::Takeoff => "takeoff",
            Self::Tension => "tension",
            Self::Lift => "lift",
            Self::Climb => "climb",
            Self::Transport => "transport",
            Self::Descent => "descent",
            Self::Slack => "slack",
            Self::Released => "released",
        }
    }

    /// The phase of a code (`None` for anything else).
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|p| *p as u8 == code)
    }

    /// True while the armed controller flies with passing off (every phase but transport).
    pub fn passing_off(self) -> bool {
        self != Self::Transport
    }

    /// What the load-sharing integrator integrates: the tensions and the load's altitude in
    /// climb and transport, the tensions alone in the descent (the load hangs in all three).
    pub fn sharing(self) -> crate::vertical::Sharing {
        match self {
            Self::Climb | Self::Transport => crate::vertical::Sharing::Full,
            Self::Descent => crate::vertical::Sharing::Tension,
            _ => crate::vertical::Sharing::Off,
        }
    }

    /// True while the load's altitude is being changed with the load hanging (lift, climb,
    /// descent): the springs fly softer then (`DissipativeController::set_heaving`).
    pub fn heaving(self) -> bool {
        matches!(self, Self::Lift | Self::Climb | Self::Descent)
    }

    /// True while the cable carries none of the load's weight (it rests on the ground): the
    /// velocity loop's observer then runs at `vt_cfo::UNLOADED_BANDWIDTH_RAD_S` (docs/design.md,
    /// "The observer of a free UAV").
    pub fn unloaded(self) -> bool {
        matches!(self, Self::Takeoff | Self::Tension | Self::Slack | Self::Released)
    }
}

/// Why the lift was abandoned (the team slackens its cables with the load on the ground).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Abort {
    /// The start checks refused at the end of the tension build-up (calibration, capacity, wind).
    Refused,
    /// The load did not leave the ground before the ramp passed its allowance (overload, a
    /// snagged load).
    LiftFailed,
}

/// Parameters of the ground sequence (every length ENU up, m; speeds m/s; times s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseParams {
    /// The load's altitude resting on the ground `z_g` (measured at the start), m.
    pub ground_z_m: f32,
    /// Transport altitude of the load `z_t` (`VT_LOAD_ZREF`), m.
    pub transport_z_m: f32,
    /// How far below taut the UAVs fly with slack cables (take-off, slack), m.
    pub slack_m: f32,
    /// Length of the take-off phase, s.
    pub takeoff_s: f32,
    /// Climb speed while the cables go taut `v_t`, m/s.
    pub tension_vz_mps: f32,
    /// Tension each cable is brought to before the survey, N.
    pub pretension_n: f32,
    /// Lift and touchdown speed `v_lift`, m/s.
    pub lift_vz_mps: f32,
    /// Climb and descent speed `v_climb`, m/s.
    pub climb_vz_mps: f32,
    /// Height above `z_g` at which the load counts as lifted, m.
    pub lift_clear_m: f32,
    /// How much further the ramp may rise before the lift is abandoned, m.
    pub lift_extra_m: f32,
    /// Height above `z_g` below which the descent slows to `v_lift`, m.
    pub touchdown_band_m: f32,
    /// Settling hold (survey at tension, after arrival, after slack), s.
    pub settle_s: f32,
}

impl PhaseParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let nonneg = |x: f32| x.is_finite() && x >= 0.0;
        let checks: [(bool, &'static str); 12] = [
            (self.ground_z_m.is_finite(), "phases.ground_z_m"),
            (self.transport_z_m.is_finite() && self.transport_z_m > self.ground_z_m, "phases.transport_z_m"),
            (pos(self.slack_m), "phases.slack_m"),
            (nonneg(self.takeoff_s), "phases.takeoff_s"),
            (pos(self.tension_vz_mps), "phases.tension_vz_mps"),
            (nonneg(self.pretension_n), "phases.pretension_n"),
            (pos(self.lift_vz_mps), "phases.lift_vz_mps"),
            (pos(self.climb_vz_mps), "phases.climb_vz_mps"),
            (pos(self.lift_clear_m), "phases.lift_clear_m"),
            (pos(self.lift_extra_m), "phases.lift_extra_m"),
            (nonneg(self.touchdown_band_m), "phases.touchdown_band_m"),
            (nonneg(self.settle_s), "phases.settle_s"),
        ];
        for (ok, name) in checks {
            if !ok {
                return Err(ControlError::InvalidParameter(name));
            }
        }
        Ok(())
    }

    /// Length of the tension phase: the climb through the slack at `v_t` (twice over, for the
    /// tension to build), then the settling survey, s.
    pub fn tension_s(&self) -> f32 {
        2.0 * self.slack_m / self.tension_vz_mps + self.settle_s
    }
}

/// How long the take-off flies before its wind survey starts, s: five time constants of the
/// free UAV's observer (`UNLOADED_BANDWIDTH_RAD_S` = 5 rad/s), which starts from nothing.
pub const WIND_SURVEY_SETTLE_S: f32 = 1.0;

/// The ground sequence of one UAV: the phase, the load altitude reference and the timers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseProfile {
    p: PhaseParams,
    phase: Phase,
    z_ref_m: f32,
    timer_s: f32,
    arrived: bool,
    abort: Option<Abort>,
    /// The transport was cut short by [`Self::set_down_now`].
    set_down_early: bool,
    /// Arrival ends the transport with the descent (a ground start); an air start hovers at the
    /// end and descends only in a set-down.
    descend_at_end: bool,
    /// How long the team has held, before its arming or in the lift, s.
    held_s: f32,
    /// The highest load altitude the lift or the climb has seen since its last progress
    /// ([`LIFT_PROGRESS_M`], [`CLIMB_PROGRESS_M`]), m.
    best_load_m: f32,
    /// The descent's speed above the touchdown band, m/s: `v_climb` unless the team's capacity
    /// brakes less ([`Self::limit_descent`]).
    descent_vz_mps: f32,
}

impl PhaseProfile {
    /// A ground start: take-off, the load reference `slack_m` below the ground.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`].
    pub fn ground(p: PhaseParams) -> Result<Self, ControlError> {
        p.validate()?;
        Ok(Self { p, phase: Phase::Takeoff, z_ref_m: p.ground_z_m - p.slack_m, timer_s: 0.0, arrived: false, abort: None, set_down_early: false, descend_at_end: true, held_s: 0.0, best_load_m: p.ground_z_m, descent_vz_mps: p.climb_vz_mps })
    }

    /// An air start (the paper's): in transport from the start at `z_t`, hovering at the end
    /// after arrival; a set-down ([`Self::set_down_now`]) descends to `z_g` (the load's resting
    /// altitude, a parameter here: nothing was measured on the ground), slackens and releases
    /// as from a ground start.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`].
    pub fn air(p: PhaseParams) -> Result<Self, ControlError> {
        p.validate()?;
        Ok(Self { p, phase: Phase::Transport, z_ref_m: p.transport_z_m, timer_s: 0.0, arrived: false, abort: None, set_down_early: false, descend_at_end: false, held_s: 0.0, best_load_m: p.ground_z_m, descent_vz_mps: p.climb_vz_mps })
    }

    /// Limits the descent's speed above the touchdown band to `v_mps` (m/s; the team's braking
    /// descent, `crate::capacity::braking_descent_mps`), never below `v_lift` nor above
    /// `v_climb`; a value that is not a positive number changes nothing.
    pub fn limit_descent(&mut self, v_mps: f32) {
        if v_mps > 0.0 && vt_fpu::is_finite(v_mps) {
            self.descent_vz_mps = vt_fpu::min(self.p.climb_vz_mps, vt_fpu::max(v_mps, self.p.lift_vz_mps));
        }
    }

    /// Limits the descent to what a team with capacity margin `margin` (`rho`) can brake to
    /// `v_lift` within the touchdown band ([`crate::capacity::braking_descent_mps`] of this
    /// profile's own `v_lift` and band; docs/design.md, "A team near its capacity descends as
    /// fast as it can brake"), through [`Self::limit_descent`].
    pub fn brake_descent(&mut self, margin: f32) {
        self.limit_descent(crate::capacity::braking_descent_mps(margin, self.p.lift_vz_mps, self.p.touchdown_band_m));
    }

    /// The descent's speed above the touchdown band, m/s.
    pub fn descent_vz_mps(&self) -> f32 {
        self.descent_vz_mps
    }

    /// The parameters.
    pub fn params(&self) -> &PhaseParams {
        &self.p
    }

    /// The current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The load altitude reference `z_l,ref`, m.
    pub fn load_altitude_ref_m(&self) -> f32 {
        self.z_ref_m
    }

    /// Why the lift was abandoned, if it was.
    pub fn abort(&self) -> Option<Abort> {
        self.abort
    }

    /// True in the last `settle_s` of the tension phase (the survey the arming calibrates from).
    pub fn surveying(&self) -> bool {
        self.phase == Phase::Tension && self.timer_s >= self.p.tension_s() - self.p.settle_s
    }

    /// True while the UAV surveys the wind (`wind::GustSurvey`): the whole take-off but its
    /// first [`WIND_SURVEY_SETTLE_S`] (the observer converging from nothing) and the whole
    /// tension phase, many gust correlation times rather than one.
    pub fn wind_surveying(&self) -> bool {
        (self.phase == Phase::Takeoff && self.timer_s >= WIND_SURVEY_SETTLE_S) || self.phase == Phase::Tension
    }

    /// True when the tension phase is over: the caller arms ([`Self::armed`]) or refuses
    /// ([`Self::refuse`]).
    pub fn ready_to_arm(&self) -> bool {
        self.phase == Phase::Tension && self.timer_s >= self.p.tension_s()
    }

    /// Armed: the lift starts from the load's measured ground altitude `load_z_m` (the armed
    /// altitude law then commands the altitude the UAV flies at: a bumpless start).
    pub fn armed(&mut self, load_z_m: f32) {
        if self.phase == Phase::Tension {
            self.phase = Phase::Lift;
            self.timer_s = 0.0;
            self.z_ref_m = if load_z_m.is_finite() { load_z_m } else { self.p.ground_z_m };
            self.best_load_m = self.z_ref_m;
        }
    }

    /// The team cannot hold the tube (the caller's detection on the load's state, which every
    /// UAV shares): the transport ends here, the descent and the set-down start at once.
    pub fn set_down_now(&mut self) {
        if self.phase == Phase::Transport {
            self.enter_set_down();
        }
    }

    /// The descent at once, as a set-down ([`Self::set_down_now`], a climb that stops short).
    fn enter_set_down(&mut self) {
        self.phase = Phase::Descent;
        self.timer_s = 0.0;
        self.set_down_early = true;
    }

    /// One step of `dt_s` of the watch on a load that must keep rising (the lift's and the
    /// climb's, the ramp at its top): a load `step_m` above the best seen becomes the best and
    /// restarts the timer, else the timer runs (an unknown altitude counts as no progress). True
    /// once it has run `timeout_s`.
    fn stalled(&mut self, load_z_m: Option<f32>, step_m: f32, timeout_s: f32, dt_s: f32) -> bool {
        self.timer_s += dt_s;
        if let Some(z) = load_z_m.filter(|&z| z >= self.best_load_m + step_m) {
            self.best_load_m = z;
            self.timer_s = 0.0;
        }
        self.timer_s >= timeout_s
    }

    /// True when the transport was cut short by a set-down ([`Self::set_down_now`]).
    pub fn set_down_early(&self) -> bool {
        self.set_down_early
    }

    /// The own cable is overloaded while the load is still on the ground (the caller's
    /// detection, [`LIFT_ABORT_FACTOR`]): the lift is abandoned, the cables slacken.
    pub fn abort_lift(&mut self) {
        if self.phase == Phase::Lift {
            self.abort = Some(Abort::LiftFailed);
            self.enter_slack(self.z_ref_m);
        }
    }

    /// The start checks refused at the arming: the UAV lands at once, as [`Self::land_now`].
    /// The load never left the ground and its cable carries at most the pretension, which the
    /// landing's first centimetres take off; the set-down's slow slack (`slack_m` at `v_lift`,
    /// then `settle_s`: 7 s by default) would keep it up in a wind that may be the reason for
    /// the refusal (docs/design.md, "A refused start lands at once"). Members that armed drop
    /// it from their law once it broadcasts `released`.
    pub fn refuse(&mut self) {
        self.land_now();
    }

    /// The UAV cannot hold its place before the arming ([`crate::landing::STATION_DRIFT_ABORT_M`]): the start is
    /// refused and the team lands at once, the cables slack and the load still on the ground.
    pub fn land_now(&mut self) {
        if matches!(self.phase, Phase::Takeoff | Phase::Tension) {
            self.abort = Some(Abort::Refused);
            self.phase = Phase::Released;
            self.timer_s = 0.0;
            self.z_ref_m = self.p.ground_z_m - self.p.slack_m;
        }
    }

    fn enter_slack(&mut self, from_m: f32) {
        self.phase = Phase::Slack;
        self.timer_s = 0.0;
        self.z_ref_m = from_m.min(self.p.ground_z_m);
    }

    /// One high-level step of `dt_s`: `load_z_m` the measured load altitude (`None`: unknown,
    /// the ramp waits), `arrived` the load reached the tube's end, `hold` the team holds (ramp
    /// and timers frozen). Returns the load altitude reference, m.
    pub fn step(&mut self, dt_s: f32, load_z_m: Option<f32>, arrived: bool, hold: bool) -> f32 {
        let dt = if dt_s.is_finite() && dt_s > 0.0 { dt_s } else { 0.0 };
        self.arrived |= arrived && self.phase == Phase::Transport;
        if dt == 0.0 {
            return self.z_ref_m;
        }
        // A hold freezes every phase but the slackening with the load down. A lift held longer
        // than `LIFT_HOLD_ABORT_S` is abandoned: a UAV that refused its arming holds its team.
        if hold && !matches!(self.phase, Phase::Slack | Phase::Released) {
            if self.phase == Phase::Lift {
                self.held_s += dt;
                if self.held_s > LIFT_HOLD_ABORT_S {
                    self.abort = Some(Abort::LiftFailed);
                    self.enter_slack(self.z_ref_m);
                }
            } else if matches!(self.phase, Phase::Takeoff | Phase::Tension) {
                // Before the arming, a hold as long abandons the start too (a member that
                // refused, or cannot hold its place, holds its team): the team lands at once
                // ([`Self::refuse`]).
                self.held_s += dt;
                if self.held_s > LIFT_HOLD_ABORT_S {
                    self.refuse();
                }
            }
            return self.z_ref_m;
        }
        self.held_s = 0.0;
        let p = self.p;
        let load_z = load_z_m.filter(|z| z.is_finite());
        match self.phase {
            Phase::Takeoff => {
                self.timer_s += dt;
                if self.timer_s >= p.takeoff_s {
                    self.phase = Phase::Tension;
                    self.timer_s = 0.0;
                }
            }
            Phase::Tension => self.timer_s += dt,
            Phase::Lift => {
                if let Some(z) = load_z {
                    // The ramp stops at its top; a load still rising there is being lifted at
                    // the team's last newtons, one that has stopped is refused.
                    let top = p.ground_z_m + p.lift_clear_m + p.lift_extra_m;
                    self.z_ref_m = (self.z_ref_m + p.lift_vz_mps * dt).min(top);
                    if z >= p.ground_z_m + p.lift_clear_m {
                        self.phase = Phase::Climb;
                        self.timer_s = 0.0;
                    } else if self.z_ref_m >= top && self.stalled(load_z, LIFT_PROGRESS_M, LIFT_PROGRESS_TIMEOUT_S, dt) {
                        self.abort = Some(Abort::LiftFailed);
                        self.enter_slack(self.z_ref_m);
                    }
                }
            }
            Phase::Climb => {
                self.z_ref_m = (self.z_ref_m + p.climb_vz_mps * dt).min(p.transport_z_m);
                // The transport starts with the load at its altitude, not the ramp: a load
                // the team lifts with little to spare climbs behind its reference
                // (docs/design.md, "The climb ends with the load up").
                // A load that stops rising short of it (no [`CLIMB_PROGRESS_M`] in
                // [`CLIMB_ARRIVE_TIMEOUT_S`] once the ramp is up) is set down from where it
                // hangs, as by a team that cannot hold the tube.
                if self.z_ref_m >= p.transport_z_m {
                    if load_z.is_some_and(|z| z >= p.transport_z_m - CLIMB_ARRIVE_M) {
                        self.phase = Phase::Transport;
                        self.timer_s = 0.0;
                    } else if self.stalled(load_z, CLIMB_PROGRESS_M, CLIMB_ARRIVE_TIMEOUT_S, dt) {
                        self.enter_set_down();
                        self.z_ref_m = self.best_load_m.min(self.z_ref_m);
                    }
                }
            }
            Phase::Transport => {
                if self.arrived && self.descend_at_end {
                    self.timer_s += dt;
                    if self.timer_s >= p.settle_s {
                        self.phase = Phase::Descent;
                        self.timer_s = 0.0;
                    }
                }
            }
            Phase::Descent => {
                // A set-down in a wind the team cannot hold slows down only in the last
                // [`SET_DOWN_TOUCHDOWN_BAND_M`]: on the ground, friction holds the load.
                // A ground start's delivery set down after its arrival (carried past the end in
                // the seconds before its descent) only descends early: it keeps the delivery's
                // band, and touches down as gently.
                let delivery = self.descend_at_end && self.arrived;
                let band = if self.set_down_early && !delivery { SET_DOWN_TOUCHDOWN_BAND_M.min(p.touchdown_band_m) } else { p.touchdown_band_m };
                let v = if self.z_ref_m > p.ground_z_m + band { self.descent_vz_mps } else { p.lift_vz_mps };
                self.z_ref_m = (self.z_ref_m - v * dt).max(p.ground_z_m);
                if self.z_ref_m <= p.ground_z_m {
                    self.enter_slack(p.ground_z_m);
                }
            }
            Phase::Slack => {
                let bottom = p.ground_z_m - p.slack_m;
                self.z_ref_m = (self.z_ref_m - p.lift_vz_mps * dt).max(bottom);
                if self.z_ref_m <= bottom {
                    self.timer_s += dt;
                    if self.timer_s >= p.settle_s {
                        self.phase = Phase::Released;
                    }
                }
            }
            Phase::Released => {}
        }
        self.z_ref_m
    }
}

/// Vertical speed of the tension build-up, m/s: climb at `v_t` while the own cable's tension
/// estimate `tension_n` is below the pretension, proportionally less near it, down when above
/// (a P law on the observer's tension estimate, gain `v_t / pretension`); a non-finite estimate
/// holds the altitude.
pub fn tension_climb_mps(tension_n: f32, p: &PhaseParams) -> f32 {
    if !tension_n.is_finite() {
        return 0.0;
    }
    let scale = p.pretension_n.max(1.0);
    vt_tube::limit(p.tension_vz_mps * (p.pretension_n - tension_n) / scale, -p.tension_vz_mps, p.tension_vz_mps)
}

#[cfg(test)]
#[path = "phases_tests.rs"]
mod tests;
