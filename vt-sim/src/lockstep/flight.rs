//! The companions as a team backend of the mission loop ([`PortTeam`]): each UAV's companion,
//! the firmware in QEMU or its host twin, fed the tick's frames over MAVLink, every command it
//! answers recorded for the bit-for-bit comparison.

use nalgebra::Vector3;
use vt_companion::frames::enu_from_ned;
use super::config::{configure, start_mission_with_reason, sync, team_setup_for, UavConfig};
use super::port::Port;
use super::wire::{relayed_heartbeat, Encoders, Rx, TickFrames};
use vt_dissipative::TeamMode;
use super::relay::PortPerception;
use super::{err, PilError};
use crate::mission::{self, holding_of, refusal_text_of, team_mode_of, Beacon, Setpoint, Team, TeamStart, Tick};
use vt_companion::refusal::REFUSAL_HEAD;
use crate::record::RunRecord;
use crate::scenario::LoadedScenario;
use crate::sim::{ControllerKind, RunOptions, SimError};
use crate::summary::Summary;
use serde::Serialize;

/// What one UAV's companion produced at one step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum CommandKind {
    /// Low level: `q[0..4]`, collective.
    Attitude,
    /// High level: velocity NED, cable force NED.
    Velocity,
}

/// One recorded command.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandRecord {
    /// Plant step.
    pub step: u64,
    /// UAV index.
    pub uav: usize,
    /// Which command.
    pub kind: CommandKind,
    /// Values (5 for attitude, 6 for velocity).
    pub values: Vec<f32>,
}

/// Field names of a record's values.
pub(crate) fn field_name(kind: CommandKind, k: usize) -> &'static str {
    const A: [&str; 5] = ["q_w", "q_x", "q_y", "q_z", "collective"];
    const V: [&str; 6] = ["vel_north", "vel_east", "vel_down", "f_hat_north", "f_hat_east", "f_hat_down"];
    match kind {
        CommandKind::Attitude => A.get(k).copied().unwrap_or("?"),
        CommandKind::Velocity => V.get(k).copied().unwrap_or("?"),
    }
}

/// One flight's outputs.
#[derive(Debug, Clone)]
pub struct FlightOutput {
    /// Metrics, as `summary.json`.
    pub summary: Summary,
    /// Time histories (when the options asked for them).
    pub record: RunRecord,
    /// Every command, in order.
    pub commands: Vec<CommandRecord>,
    /// High-level step cycles reported by each companion (`DEBUG_VECT CYCLES.x`).
    pub hl_cycles: Vec<Vec<f32>>,
    /// Low-level step cycles reported by each companion (`DEBUG_VECT CYCLES.y`).
    pub ll_cycles: Vec<Vec<f32>>,
    /// Last `SYS_STATUS` counters of each companion.
    pub status: Vec<[u16; 5]>,
    /// Last `HEARTBEAT.custom_mode` of each companion.
    pub custom_mode: Vec<u32>,
    /// Issue 28: each companion's longest re-plan, board cycles (empty: the map is known).
    pub replan_worst_cycles: Vec<f32>,
}

/// The companions behind `ports` (one per UAV, fresh) as a [`Team`].
pub struct PortTeam<'p, P: Port> {
    ports: &'p mut [P],
    kind: ControllerKind,
    label: String,
    configs: Vec<UavConfig>,
    enc: Vec<Encoders>,
    /// Every command, in order.
    pub commands: Vec<CommandRecord>,
    /// High-level step cycles per companion.
    pub hl_cycles: Vec<Vec<f32>>,
    /// Low-level step cycles per companion.
    pub ll_cycles: Vec<Vec<f32>>,
    /// Last `SYS_STATUS` counters per companion.
    pub status: Vec<[u16; 5]>,
    /// Last `HEARTBEAT.custom_mode` per companion.
    pub custom_mode: Vec<u32>,
    /// Per companion, the `STATUSTEXT` lines of its refusal on the ground (the head line,
    /// "start refused: ...", and the line right after it), as [`Team::refusal_text`] gives them.
    refusal: Vec<Vec<String>>,
    /// Per companion, true right after a refusal's head line: the next frame may be its detail.
    refusal_open: Vec<bool>,
    /// Last velocity command and cable-force estimate per companion, ENU (m/s, N).
    last_high_level: Vec<(Vector3<f32>, Vector3<f32>)>,
    /// Per receiver, per sender: the team mode last relayed (the network relays a member's
    /// `HEARTBEAT` when the mode that came with its position changes).
    relayed: Vec<Vec<Beacon>>,
    /// Someone else starts the mission (a ground station, `host-sim sitl`): called once the
    /// start tick has been delivered; the team then waits for every companion's `COMMAND_ACK`.
    start_hook: Option<StartHook<'p>>,
    /// Issue 28: the network's relay of scans and tube offers (`None`: the map is known).
    perception: Option<PortPerception>,
}

/// What starts the companions when the team does not (see [`PortTeam::started_by`]).
pub type StartHook<'p> = Box<dyn FnMut() -> Result<(), String> + 'p>;

impl<'p, P: Port> PortTeam<'p, P> {
    /// A team over `ports`; `label` names it in errors (`SIL`, `PIL`).
    pub fn new(ports: &'p mut [P], label: &str) -> Self {
        let n = ports.len();
        Self {
            ports,
            kind: ControllerKind::Dissipative,
            label: label.into(),
            configs: Vec::new(),
            enc: (0..n).map(|_| Encoders::default()).collect(),
            commands: Vec::new(),
            hl_cycles: vec![Vec::new(); n],
            ll_cycles: vec![Vec::new(); n],
            status: vec![[0u16; 5]; n],
            custom_mode: vec![0u32; n],
            refusal: vec![Vec::new(); n],
            refusal_open: vec![false; n],
            last_high_level: vec![(Vector3::zeros(), Vector3::zeros()); n],
            relayed: vec![vec![Beacon::START; n]; n],
            start_hook: None,
            perception: None,
        }
    }

    /// The companions were configured by someone else (a ground station) with `configs`: the
    /// team sends no parameters and no tube.
    #[must_use]
    pub fn configured(mut self, configs: Vec<UavConfig>) -> Self {
        self.configs = configs;
        self
    }

    /// Someone else sends `MAV_CMD_MISSION_START` (`hook`, called after the start tick): the
    /// team waits for each companion's acknowledgement (sent to every remote it has).
    #[must_use]
    pub fn started_by(mut self, hook: impl FnMut() -> Result<(), String> + 'p) -> Self {
        self.start_hook = Some(Box::new(hook));
        self
    }

    /// The same team flying the high-level law `kind` (`VT_CTRL`).
    #[must_use]
    pub fn with_controller(mut self, kind: ControllerKind) -> Self {
        self.kind = kind;
        self
    }

    /// The frames UAV `i`'s companion gets for `tick` (as [`Team::step`] sends them).
    pub fn frames_for(&mut self, i: usize, tick: &Tick<'_>) -> Vec<u8> {
        self.tick_frames(i, tick)
    }

    /// The ports.
    pub fn ports_mut(&mut self) -> &mut [P] {
        self.ports
    }

    /// Takes the start hook (a team that starts the companions its own way).
    pub fn take_start_hook(&mut self) -> Option<StartHook<'p>> {
        self.start_hook.take()
    }

    /// Every frame received from UAV `i`, first: one that is not a `STATUSTEXT` ends a
    /// refusal's lines (the companion sends its head and detail lines back to back).
    pub fn frame_seen(&mut self, i: usize, rx: &Rx) {
        if let (false, Some(open)) = (matches!(rx, Rx::StatusText(..)), self.refusal_open.get_mut(i)) {
            *open = false;
        }
    }

    /// What UAV `i` sent besides its setpoint and high-level telemetry (after
    /// [`Self::frame_seen`]): its `HEARTBEAT`, a refusal's `STATUSTEXT` lines, and the
    /// re-planning's frames ([`Self::absorb`]).
    pub fn note(&mut self, i: usize, rx: Rx) {
        match rx {
            Rx::Heartbeat(m) => self.note_heartbeat(i, m),
            Rx::StatusText(_, t) if t.starts_with(REFUSAL_HEAD) && self.refusal.get(i).is_some_and(Vec::is_empty) => {
                self.refusal[i].push(t);
                self.refusal_open[i] = true;
            }
            Rx::StatusText(_, t) if self.refusal_open.get(i).copied().unwrap_or(false) => {
                self.refusal[i].push(t);
                self.refusal_open[i] = false;
            }
            other => self.absorb(i, &other),
        }
    }

    /// Records the last `HEARTBEAT.custom_mode` heard from UAV `i`.
    pub fn note_heartbeat(&mut self, i: usize, custom_mode: u32) {
        if let Some(m) = self.custom_mode.get_mut(i) {
            *m = custom_mode;
        }
    }

    fn tick_frames(&mut self, i: usize, tick: &Tick<'_>) -> Vec<u8> {
        // Team failsafe: the neighbours' mode changes, as `HEARTBEAT`s of their companions.
        let mut beats = Vec::new();
        if let (true, Some(modes), Some(relayed)) = (tick.high_level, tick.modes.get(i), self.relayed.get_mut(i)) {
            for (j, (m, last)) in modes.iter().zip(relayed.iter_mut()).enumerate() {
                if let (Some(m), true) = (m, j != i) {
                    if m != last {
                        *last = *m;
                        beats.extend(relayed_heartbeat(&mut self.enc[i].network, j, m.custom_mode()));
                    }
                }
            }
        }
        let own = tick.own.get(i).copied().unwrap_or_default();
        let system_id = self.configs.get(i).map_or(0, |c| c.system_id);
        let e = &mut self.enc[i];
        let relayed = self.perception.as_ref().map_or_else(Vec::new, |p| p.frames_for(i, system_id, tick, &mut e.autopilot, &mut e.network));
        let frames = TickFrames {
            time_ms: tick.time_ms,
            system_id,
            load: tick.high_level.then_some((tick.load.pos_m, tick.load.vel_mps)),
            neighbours: if tick.high_level { tick.views.get(i).map_or(&[], Vec::as_slice) } else { &[] },
            own: (own.pos_m, own.vel_mps),
            sample_ms: (own.sample_ms, tick.load.sample_ms),
            id: i,
        };
        if tick.own_stalled.get(i).copied().unwrap_or(false) {
            beats.extend(frames.encode_stalled_with(&mut e.autopilot, &mut e.tracker, &mut e.network, &relayed));
        } else {
            beats.extend(frames.encode_with(&mut e.autopilot, &mut e.tracker, &mut e.network, &relayed));
        }
        beats
    }

    /// Issue 28: sets up the network's relay of scans and offers for `ls` (once; nothing for a
    /// known map), for a team that runs its own periods (`sitl::realtime`).
    ///
    /// # Errors
    /// The scenario's LiDAR takes scans `OBSTACLE_DISTANCE` cannot carry.
    pub fn relay_for(&mut self, ls: &LoadedScenario) -> Result<(), SimError> {
        if self.perception.is_none() {
            self.perception = PortPerception::new(ls, self.ports.len()).map_err(|e| SimError(e.0))?;
        }
        Ok(())
    }

    /// Issue 28: what companion `i` sent that the network relays or counts.
    pub fn absorb(&mut self, i: usize, rx: &Rx) {
        if let Some(p) = self.perception.as_mut() {
            p.absorb(i, rx);
        }
    }

    /// Issue 28: the start of a period.
    pub fn open(&mut self, tick: &Tick<'_>) {
        if let Some(p) = self.perception.as_mut() {
            p.open(tick);
        }
    }

    /// Issue 28: the end of a period (`immediate`: before the start).
    pub fn close(&mut self, tick: &Tick<'_>, immediate: bool) {
        if let Some(p) = self.perception.as_mut() {
            p.close(tick.time_ms, immediate);
        }
    }

    fn fail(&self, i: usize, what: impl std::fmt::Display) -> SimError {
        SimError(format!("{} UAV {i}: {what}", self.label))
    }
}

impl<P: Port> PortTeam<'_, P> {
    /// Configures every companion (parameters, tube), once.
    fn configure_all(&mut self, ls: &LoadedScenario, at: &TeamStart<'_>) -> Result<(), SimError> {
        let n = ls.scenario.cables.lengths_m.len();
        if self.ports.len() != n {
            return Err(SimError(format!("{} ports for {n} UAVs", self.ports.len())));
        }
        // The network relays scans and offers however the companions were configured (here,
        // or by a ground station: `configured`).
        self.relay_for(ls)?;
        if !self.configs.is_empty() {
            return Ok(());
        }
        let setup = team_setup_for(ls, self.kind, at.takeoff.clone(), at.cable_rated_n, true).map_err(|e| SimError(e.0))?;
        self.configs = setup.configs;
        for i in 0..n {
            let cfg = self.configs[i].clone();
            configure(&mut self.ports[i], &cfg, &mut self.enc[i].gcs).map_err(|e| self.fail(i, e))?;
        }
        Ok(())
    }
}

impl<P: Port> Team for PortTeam<'_, P> {
    fn preflight(&mut self, ls: &LoadedScenario, at: &TeamStart<'_>) -> Result<(), SimError> {
        self.configure_all(ls, at)?;
        // The period's frames to every companion (no flight: nothing is answered; they go into
        // its survey, and its re-planning), then one round trip each so no receive buffer
        // overflows.
        self.open(&at.tick);
        for i in 0..self.ports.len() {
            let bytes = self.tick_frames(i, &at.tick);
            self.ports[i].send(&bytes).map_err(|e| self.fail(i, e))?;
        }
        for i in 0..self.ports.len() {
            let id = self.configs[i].system_id;
            let mut seen = Vec::new();
            sync(&mut Tap { port: &mut self.ports[i], seen: &mut seen }, id, &mut self.enc[i].gcs).map_err(|e| self.fail(i, e))?;
            seen.iter().for_each(|rx| self.absorb(i, rx));
        }
        self.close(&at.tick, true);
        Ok(())
    }

    fn start(&mut self, ls: &LoadedScenario, start: &TeamStart<'_>) -> Result<Option<String>, SimError> {
        self.configure_all(ls, start)?;
        if let Some(mut hook) = self.start_hook.take() {
            self.open(&start.tick);
            for i in 0..self.ports.len() {
                let bytes = self.tick_frames(i, &start.tick);
                self.ports[i].send(&bytes).map_err(|e| self.fail(i, e))?;
            }
            hook().map_err(|e| SimError(format!("{}: the start failed: {e}", self.label)))?;
            for i in 0..self.ports.len() {
                let (mut texts, mut seen) = (Vec::new(), Vec::new());
                let r = super::config::recv_until(&mut self.ports[i], 4096, |rx| match rx {
                    Rx::CommandAck(c, r) if *c == mavlink::dialects::common::MavCmd::MAV_CMD_MISSION_START as u32 => Some(*r),
                    other => {
                        if let Rx::StatusText(_, t) = other {
                            texts.push(t.clone());
                        }
                        seen.push(other.clone());
                        None
                    }
                })
                .map_err(|e| self.fail(i, e))?;
                seen.iter().for_each(|rx| self.absorb(i, rx));
                if r != 0 {
                    return Ok(Some(format!("{}: UAV {i}: mission start refused (MAV_RESULT {r}): {}", self.label, refusal_text_of(texts.iter().map(String::as_str)))));
                }
            }
            self.close(&start.tick, true);
            return Ok(None);
        }
        // The start tick to every companion (its re-planning's first tube goes out at once, as
        // in SIL), then the start itself.
        self.open(&start.tick);
        for i in 0..self.ports.len() {
            let id = self.configs[i].system_id;
            let bytes = self.tick_frames(i, &start.tick);
            self.ports[i].send(&bytes).map_err(|e| self.fail(i, e))?;
            let mut seen = Vec::new();
            sync(&mut Tap { port: &mut self.ports[i], seen: &mut seen }, id, &mut self.enc[i].gcs).map_err(|e| self.fail(i, e))?;
            seen.iter().for_each(|rx| self.absorb(i, rx));
        }
        self.close(&start.tick, true);
        for i in 0..self.ports.len() {
            let id = self.configs[i].system_id;
            let (r, texts) = start_mission_with_reason(&mut self.ports[i], id, &mut self.enc[i].gcs).map_err(|e| self.fail(i, e))?;
            if r != 0 {
                return Ok(Some(format!("{}: UAV {i}: mission start refused (MAV_RESULT {r}): {}", self.label, refusal_text_of(texts.iter().map(String::as_str)))));
            }
        }
        Ok(None)
    }

    fn step(&mut self, tick: &Tick<'_>, out: &mut [Setpoint]) -> Result<(), SimError> {
        let n = self.ports.len();
        if out.len() != n {
            return Err(SimError(format!("{n} companions, {} setpoints", out.len())));
        }
        // Send every UAV its tick first (the emulators compute in parallel), then collect.
        self.open(tick);
        for i in 0..n {
            let bytes = self.tick_frames(i, tick);
            self.ports[i].send(&bytes).map_err(|e| self.fail(i, e))?;
        }
        let t = tick.step;
        for (i, slot) in out.iter_mut().enumerate() {
            let mut hl_values: Vec<f32> = Vec::new();
            let (q, thrust) = loop {
                let rx = self.ports[i].recv().map_err(|e| SimError(format!("{} UAV {i} at tick {}: {e}", self.label, tick.time_ms)))?;
                self.frame_seen(i, &rx);
                match rx {
                    Rx::Setpoint { time_ms, q, thrust } if time_ms == tick.time_ms => break (q, thrust),
                    Rx::VelocityTarget { v_ned, .. } => hl_values.extend_from_slice(&v_ned),
                    Rx::CableForce(f) => hl_values.extend_from_slice(&f),
                    Rx::Cycles([h, l, _]) => {
                        self.hl_cycles[i].push(h);
                        self.ll_cycles[i].push(l);
                    }
                    Rx::Status(c) => self.status[i] = c,
                    other => self.note(i, other),
                }
            };
            if tick.high_level {
                let [vn, ve, vd, fn_, fe, fd] = hl_values[..] else {
                    return Err(SimError(format!("{} UAV {i} at t = {} ms: incomplete high-level telemetry", self.label, tick.time_ms)));
                };
                if let Some(slot) = self.last_high_level.get_mut(i) {
                    *slot = (enu_from_ned(vn, ve, vd), enu_from_ned(fn_, fe, fd));
                }
                self.commands.push(CommandRecord { step: t, uav: i, kind: CommandKind::Velocity, values: hl_values });
            }
            self.commands.push(CommandRecord { step: t, uav: i, kind: CommandKind::Attitude, values: vec![q[0], q[1], q[2], q[3], thrust] });
            *slot = Setpoint { q_ned: q, thrust };
        }
        self.close(tick, false);
        Ok(())
    }

    fn controller_outputs(&self, vel_cmd_mps: &mut [Vector3<f32>], f_hat_n: &mut [Vector3<f32>]) {
        for ((v, f), (lv, lf)) in vel_cmd_mps.iter_mut().zip(f_hat_n.iter_mut()).zip(&self.last_high_level) {
            *v = *lv;
            *f = *lf;
        }
    }

    fn holding(&self) -> Vec<bool> {
        // HEARTBEAT.custom_mode = mode | hold reasons << 8 (docs/protocol.md).
        self.custom_mode.iter().map(|m| holding_of(*m)).collect()
    }

    fn refusal_text(&self, uav: usize) -> Option<String> {
        self.refusal.get(uav).filter(|l| !l.is_empty()).map(|l| refusal_text_of(l.iter().map(String::as_str)))
    }

    fn team_modes(&self, out: &mut [TeamMode]) {
        // The companion sends a HEARTBEAT at every change of its team mode.
        out.iter_mut().zip(&self.custom_mode).for_each(|(o, m)| *o = team_mode_of(*m));
    }

    fn phases(&self, phases: &mut [u8], refusals: &mut [u8]) {
        // ... and of its phase (docs/protocol.md).
        for ((p, r), m) in phases.iter_mut().zip(refusals.iter_mut()).zip(&self.custom_mode) {
            (*p, *r) = (crate::mission::phase_of(*m), crate::mission::refusal_of(*m));
        }
    }

    fn published_tube(&self) -> Option<(u32, &crate::scenario::SimTube)> {
        self.perception.as_ref().and_then(PortPerception::published)
    }

    fn replan_stats(&self) -> Option<crate::mission::replan::ReplanStats> {
        self.perception.as_ref().map(|p| p.stats().clone())
    }
}

/// A port whose every received message is also kept (what the team relays or counts, read off
/// a round trip's way).
struct Tap<'a, P: Port> {
    port: &'a mut P,
    seen: &'a mut Vec<Rx>,
}

impl<P: Port> Port for Tap<'_, P> {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        self.port.send(bytes)
    }
    fn recv(&mut self) -> Result<Rx, PilError> {
        let rx = self.port.recv()?;
        self.seen.push(rx.clone());
        Ok(rx)
    }
}

/// Flies the mission through the one mission loop with one port per UAV (lockstep). Ports
/// must be fresh companions.
///
/// # Errors
/// Configuration refused, a link failure, or a missing reply.
pub fn fly<P: Port>(ls: &LoadedScenario, ports: &mut [P], opts: &RunOptions, label: &str) -> Result<FlightOutput, PilError> {
    if ports.is_empty() {
        return err("no companions");
    }
    fly_team(ls, PortTeam::new(ports, label).with_controller(opts.controller), opts)
}

/// Flies the mission through the one mission loop with `team` (lockstep).
///
/// # Errors
/// Configuration refused, a link failure, or a missing reply.
pub fn fly_team<P: Port>(ls: &LoadedScenario, mut team: PortTeam<'_, P>, opts: &RunOptions) -> Result<FlightOutput, PilError> {
    let flown = mission::fly(ls, opts, &mut team).map_err(|e| PilError(e.0))?;
    Ok(FlightOutput {
        summary: flown.summary,
        record: flown.record,
        commands: team.commands,
        hl_cycles: team.hl_cycles,
        ll_cycles: team.ll_cycles,
        replan_worst_cycles: team.perception.as_ref().map_or_else(Vec::new, PortPerception::worst_replan_cycles),
        status: team.status,
        custom_mode: team.custom_mode,
    })
}
