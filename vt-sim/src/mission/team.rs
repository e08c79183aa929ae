//! The team-controller interface of the mission loop, and its first backend: every UAV's
//! companion (`vt_companion`, the firmware's flight logic) called directly, without MAVLink
//! framing (SIL).
//!
//! Every backend receives the same [`Tick`] (what the UAVs' computers measure at one low-level
//! period) and answers with what the firmware sends its autopilot: one [`Setpoint`]
//! (`SET_ATTITUDE_TARGET`: FRD-to-NED quaternion and normalised collective) per UAV. The other
//! backends, the same companion fed MAVLink bytes (SIL twin) and the firmware in QEMU (PIL), live
//! in [`crate::lockstep`]; all three run one flight logic (docs/design.md, "One flight logic").

use crate::companion::{params_for, tube_waypoints, HostCompanion};
use crate::scenario::LoadedScenario;
use crate::sim::{ControllerKind, SimError, Takeoff};
use nalgebra::Vector3;
use vt_companion::{Io, Mode, Source};
use vt_dissipative::TeamMode;

pub use vt_companion::flight::Setpoint;

type V3f = Vector3<f32>;

/// A team member's state as the team link delivers it: position, m, and velocity, m/s (ENU;
/// the member's own autopilot's, as its `LOCAL_POSITION_NED` carries them).
pub type Report = (V3f, V3f);

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
    /// Per UAV, the team's positions and velocities as its link delivered them (`None`: not
    /// delivered; own slot: its own; valid when `high_level`).
    pub views: &'a [Vec<Option<Report>>],
    /// Per UAV, the team mode and phase each other UAV broadcast with the position in `views`
    /// (`None` with it; docs/design.md, "Team failsafe"; valid when `high_level`).
    pub modes: &'a [Vec<Option<Beacon>>],
    /// Issue 28: per UAV, the LiDAR scan taken this high-level period (empty or `None`: none;
    /// origin at the UAV's measured position, as its companion knows it).
    pub scans: &'a [Option<vt_map::Scan>],
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
    /// Configures and arms every UAV (`MAV_CMD_MISSION_START`): `Some(reason)` when a UAV
    /// refused the start (its pre-flight checks: the flight is not flown, an outcome, not an
    /// error).
    ///
    /// # Errors
    /// A configuration is refused, or a backend failed.
    fn start(&mut self, ls: &LoadedScenario, start: &TeamStart<'_>) -> Result<Option<String>, SimError>;

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

    /// Why UAV `uav` refused its start on the ground, as its `STATUSTEXT` lines said it
    /// ("; " between them; `None`: no refusal, or a team that does not report one).
    fn refusal_text(&self, _uav: usize) -> Option<String> {
        None
    }

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

    /// Writes each UAV's phase (`vt_dissipative::Phase` code) and refusal code, as its last
    /// `HEARTBEAT.custom_mode` carries them (bits 24..31 and 16..23; docs/protocol.md); a team
    /// that does not report leaves them 0.
    fn phases(&self, _phases: &mut [u8], _refusals: &mut [u8]) {}

    /// Issue 28: the tube the team re-planned and switched to last, with a version that
    /// changes at each new one (`None`: the scenario's tube; a team that does not re-plan).
    fn published_tube(&self) -> Option<(u32, &crate::scenario::SimTube)> {
        None
    }

    /// Issue 28: what the team's perception did (`None`: it does not re-plan).
    fn replan_stats(&self) -> Option<super::replan::ReplanStats> {
        None
    }
}

/// The phase code in a companion's `HEARTBEAT.custom_mode` (bits 24..31; 0: not flying).
pub fn phase_of(custom_mode: u32) -> u8 {
    (custom_mode >> 24) as u8
}

/// The refusal code in a companion's `HEARTBEAT.custom_mode` (bits 16..23; 0: none).
pub fn refusal_of(custom_mode: u32) -> u8 {
    (custom_mode >> 16) as u8
}

/// The board side of a companion whose frames nobody reads: the SIL team takes its results
/// from the companion itself, so nothing is encoded (`Io::wants_frames`). Lockstep needs no
/// clock.
struct Unlinked;

impl Io for Unlinked {
    fn now_ms(&self) -> u32 {
        0
    }
    fn cycles(&self) -> u32 {
        0
    }
    fn send(&mut self, _frame: &[u8]) {}
    fn wants_frames(&self) -> bool {
        false
    }
}

/// What a UAV's team message carries besides its position: its companion's team mode and
/// mission phase, as its last `HEARTBEAT.custom_mode` says them (docs/protocol.md, "Team
/// failsafe"; a neighbour in `released` leaves the armed law, docs/design.md "A refused start
/// lands at once").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Beacon {
    /// The team mode (`custom_mode` low byte).
    pub mode: TeamMode,
    /// The phase code (`vt_dissipative::Phase`, `custom_mode` bits 24..31; 0 before one).
    pub phase: u8,
}

impl Beacon {
    /// Before any heartbeat: transport, no phase.
    pub const START: Self = Self { mode: TeamMode::Transport, phase: 0 };

    /// The `HEARTBEAT.custom_mode` the team network relays: the mode and the phase.
    pub fn custom_mode(self) -> u32 {
        Mode::of_team(self.mode) as u32 | (u32::from(self.phase) << 24)
    }
}

/// A refusal's `STATUSTEXT` lines as one text, as [`Team::refusal_text`] gives it ("; "
/// between them): every backend joins them here, so SIL's text and the wire's agree.
pub fn refusal_text_of<'a>(lines: impl IntoIterator<Item = &'a str>) -> String {
    lines.into_iter().collect::<Vec<_>>().join("; ")
}

/// The team mode in a companion's `HEARTBEAT.custom_mode` (low byte, docs/protocol.md).
pub fn team_mode_of(custom_mode: u32) -> TeamMode {
    match custom_mode & 0xFF {
        m if m == Mode::Hold as u32 => TeamMode::Hold,
        m if m == Mode::TeamHold as u32 => TeamMode::TeamHold,
        _ => TeamMode::Transport,
    }
}

/// Whether a companion's `HEARTBEAT.custom_mode` says it holds: a hold reason set (bits 8..15),
/// or a holding team mode.
pub fn holding_of(custom_mode: u32) -> bool {
    (custom_mode >> 8) & 0xff != 0 || team_mode_of(custom_mode).is_holding()
}

/// Every UAV's companion (`vt_companion::Companion`, the flight logic the firmware runs)
/// called directly: configured with [`params_for`] and the scenario's tube, fed each tick's
/// measurements in the order the lockstep link delivers them (docs/protocol.md), in lockstep
/// (`VT_LOCKSTEP = 1`). Its commands equal the twin's and the firmware's bit for bit
/// (tests/backends.rs, tests/pil.rs): the same code, without the bytes.
pub struct CompanionTeam {
    kind: ControllerKind,
    uavs: Vec<HostCompanion>,
    /// Issue 28: the onboard maps and re-planning (`None`: the map is known).
    perception: Option<super::replan::TeamPerception>,
    /// Each companion's low-level step count before the tick (reused buffer).
    before: Vec<Option<u32>>,
}

impl CompanionTeam {
    /// A team flying `kind`, configured at the first [`Team::preflight`] or [`Team::start`].
    pub fn new(kind: ControllerKind) -> Self {
        Self { kind, uavs: Vec::new(), perception: None, before: Vec::new() }
    }

    /// UAV `i`'s companion (for inspection).
    pub fn companion(&self, i: usize) -> Option<&vt_companion::Companion<'static>> {
        self.uavs.get(i).and_then(HostCompanion::get)
    }

    /// Configures every companion (parameters, tube), once.
    fn configure(&mut self, ls: &LoadedScenario, cable_rated_n: f64) -> Result<(), SimError> {
        if !self.uavs.is_empty() {
            return Ok(());
        }
        let s = &ls.scenario;
        let n = s.cables.lengths_m.len();
        let items: Vec<_> = tube_waypoints(s)?.iter().enumerate().map(|(k, w)| w.item(k as u16)).collect();
        for i in 0..n {
            let params = params_for(s, i, self.kind, cable_rated_n, true)?;
            let mut uav = HostCompanion::new();
            let c = uav.get_mut().ok_or_else(|| SimError("companion dropped".into()))?;
            for &p in vt_companion::params::ALL {
                c.set_param(p, params.get(p)).map_err(|e| SimError(format!("UAV {i}: parameter {}: {e:?}", p.info().name)))?;
            }
            c.upload_tube(&items, &mut Unlinked).map_err(|e| SimError(format!("UAV {i}: tube refused ({e:?})")))?;
            self.uavs.push(uav);
        }
        self.perception = super::replan::TeamPerception::attach(ls, &mut self.uavs);
        Ok(())
    }

    /// UAV `i`'s share of `tick`, as the lockstep link delivers it (`pil::TickFrames`): the
    /// neighbours' mode changes, `SYSTEM_TIME` when the own sample is older than now, the load's
    /// and the neighbours' states when the high level is due, then the own state, which closes
    /// the period (a second `SYSTEM_TIME` when the own feed stalls).
    fn deliver(c: &mut vt_companion::Companion<'static>, i: usize, tick: &Tick<'_>, perception: Option<&super::replan::TeamPerception>) {
        let io = &mut Unlinked;
        let own = tick.own.get(i).copied().unwrap_or_default();
        let stalled = tick.own_stalled.get(i).copied().unwrap_or(false);
        if tick.high_level {
            for (j, m) in tick.modes.get(i).into_iter().flatten().enumerate() {
                if let (Some(m), true) = (m, j != i) {
                    c.member_heartbeat(j, m.custom_mode());
                }
            }
        }
        if stalled || own.sample_ms != tick.time_ms {
            c.system_time(tick.time_ms, io);
        }
        if tick.high_level {
            c.position(Source::Load, tick.load.pos_m, tick.load.vel_mps, tick.load.sample_ms, io);
            for (j, p) in tick.views.get(i).into_iter().flatten().enumerate() {
                if let (Some((p, v)), true) = (p, j != i) {
                    c.position(Source::Member(j), *p, *v, tick.time_ms, io);
                }
            }
        }
        // Issue 28: the scans and the offer due, as the team network relays them.
        if let Some(p) = perception {
            p.deliver(c, i, tick);
        }
        if stalled {
            c.system_time(tick.time_ms, io);
        } else {
            c.position(Source::Own, own.pos_m, own.vel_mps, own.sample_ms, io);
        }
    }

    fn each(&mut self, tick: &Tick<'_>) -> Result<(), SimError> {
        if tick.own.len() != self.uavs.len() {
            return Err(SimError(format!("tick for {} UAVs, team of {}", tick.own.len(), self.uavs.len())));
        }
        if let Some(p) = self.perception.as_mut() {
            p.open(tick);
        }
        for (i, uav) in self.uavs.iter_mut().enumerate() {
            let c = uav.get_mut().ok_or_else(|| SimError("companion dropped".into()))?;
            Self::deliver(c, i, tick, self.perception.as_ref());
        }
        Ok(())
    }

    fn companions(&self) -> impl Iterator<Item = &vt_companion::Companion<'static>> {
        self.uavs.iter().filter_map(HostCompanion::get)
    }
}

impl Team for CompanionTeam {
    fn preflight(&mut self, ls: &LoadedScenario, at: &TeamStart<'_>) -> Result<(), SimError> {
        self.configure(ls, at.cable_rated_n)?;
        self.each(&at.tick)?;
        if let Some(p) = self.perception.as_mut() {
            p.close(&at.tick, &mut self.uavs, true);
        }
        Ok(())
    }

    fn start(&mut self, ls: &LoadedScenario, start: &TeamStart<'_>) -> Result<Option<String>, SimError> {
        self.configure(ls, start.cable_rated_n)?;
        self.each(&start.tick)?;
        if let Some(p) = self.perception.as_mut() {
            p.close(&start.tick, &mut self.uavs, true);
        }
        for (i, uav) in self.uavs.iter_mut().enumerate() {
            let c = uav.get_mut().ok_or_else(|| SimError("companion dropped".into()))?;
            if let Err(e) = c.start_mission(&mut Unlinked) {
                return Ok(Some(format!("UAV {i}: mission start refused: {e}")));
            }
        }
        Ok(None)
    }

    fn step(&mut self, tick: &Tick<'_>, out: &mut [Setpoint]) -> Result<(), SimError> {
        if out.len() != self.uavs.len() {
            return Err(SimError(format!("{} companions, {} setpoints", self.uavs.len(), out.len())));
        }
        let ticks = |c: &vt_companion::Companion<'static>| c.flight().map(vt_companion::Flight::low_level_ticks);
        self.before.clear();
        self.before.extend(self.uavs.iter().filter_map(HostCompanion::get).map(ticks));
        // Issue 28: each companion's perception step runs before its high level (a tube taken
        // now is flown now); the team network relays what came out of it.
        self.each(tick)?;
        if let Some(p) = self.perception.as_mut() {
            p.close(tick, &mut self.uavs, false);
        }
        let companions = self.uavs.iter().filter_map(HostCompanion::get);
        for (i, ((slot, c), before)) in out.iter_mut().zip(companions).zip(&self.before).enumerate() {
            // Exactly one low-level step ran for this tick, and it produced the setpoint.
            let stepped = matches!((before, ticks(c)), (Some(b), Some(a)) if a == b.wrapping_add(1));
            *slot = c.setpoint().filter(|_| stepped).ok_or_else(|| SimError(format!("UAV {i}: no setpoint for t = {} ms (not armed)", tick.time_ms)))?;
        }
        Ok(())
    }

    fn refusal_text(&self, uav: usize) -> Option<String> {
        // The lines its STATUSTEXT carries (`Core::refused`), without the bytes.
        let e = self.companions().nth(uav)?.flight()?.refusal()?;
        let (head, detail) = e.lines();
        Some(refusal_text_of(core::iter::once(&head).chain(detail.as_ref()).map(vt_companion::refusal::Line::as_str)))
    }

    fn invalid_commands(&self) -> u64 {
        self.companions().filter_map(|c| c.flight()).map(|f| u64::from(f.invalid_commands())).sum()
    }

    fn holding(&self) -> Vec<bool> {
        self.companions().map(|c| holding_of(c.heartbeat_custom_mode())).collect()
    }

    fn controller_outputs(&self, vel_cmd_mps: &mut [V3f], f_hat_n: &mut [V3f]) {
        for ((v, f), c) in vel_cmd_mps.iter_mut().zip(f_hat_n.iter_mut()).zip(self.companions()) {
            if let Some(fl) = c.flight() {
                *v = fl.velocity_command_mps();
                *f = fl.cable_force_n();
            }
        }
    }

    fn team_modes(&self, out: &mut [TeamMode]) {
        // What each companion's last HEARTBEAT said (the team network relays it).
        out.iter_mut().zip(self.companions()).for_each(|(o, c)| *o = team_mode_of(c.heartbeat_custom_mode()));
    }

    fn phases(&self, phases: &mut [u8], refusals: &mut [u8]) {
        for ((p, r), c) in phases.iter_mut().zip(refusals.iter_mut()).zip(self.companions()) {
            (*p, *r) = (phase_of(c.heartbeat_custom_mode()), refusal_of(c.heartbeat_custom_mode()));
        }
    }

    fn published_tube(&self) -> Option<(u32, &crate::scenario::SimTube)> {
        self.perception.as_ref().and_then(super::replan::TeamPerception::published)
    }

    fn replan_stats(&self) -> Option<super::replan::ReplanStats> {
        self.perception.as_ref().map(|p| p.stats().clone())
    }
}
