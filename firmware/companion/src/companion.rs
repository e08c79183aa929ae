//! The companion: MAVLink dispatch, configuration, lockstep ticks and telemetry around one
//! [`Flight`]. The board supplies bytes, a millisecond clock, a cycle counter and a byte sink
//! ([`Io`]); the firmware's Tickers call [`Companion::high_level_step`] and
//! [`Companion::low_level_step`], or, with `VT_LOCKSTEP = 1`, each own `LOCAL_POSITION_NED`
//! runs one low-level period (and the high level when due) on receipt; an own `SYSTEM_TIME`
//! runs one without a new own state (the position feed stalled).
//!
//! The message mapping is documented in `docs/protocol.md`. Every frame with a bad checksum,
//! an unknown id or an impossible value is counted ([`LinkCounters`], [`ValueCounters`]) and
//! dropped; nothing on the wire reaches the controllers unchecked.

use mavlink::dialects::common::{
    AttitudeTargetTypemask, MavFrame, MavMissionResult, PositionTargetTypemask, COMMAND_LONG_DATA,
    DEBUG_VECT_DATA, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA, MISSION_ACK_DATA, MISSION_CLEAR_ALL_DATA, MISSION_COUNT_DATA,
    MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA, PARAM_REQUEST_LIST_DATA, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA,
    POSITION_TARGET_LOCAL_NED_DATA, SET_ATTITUDE_TARGET_DATA, SYSTEM_TIME_DATA,
};
use mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, MessageData};
use vt_dissipative::TeamMode;

use crate::flight::{Flight, HoldReasons, Setpoint, Sources, StartError};
use crate::framer::{Frame, Framer, LinkCounters};
use crate::frames::ned_from_enu;
use crate::mission::{Item, MissionResult, MissionUpload, UploadReply};
use crate::Vec3;
use crate::params::{Param, ParamError, Params};
use crate::{log, CompanionTube, AUTOPILOT_COMPONENT_ID, COMPANION_COMPONENT_ID};

#[cfg(feature = "perception")]
mod aboard;
mod commands;
mod inputs;
mod telemetry;
mod tubes;

#[cfg(feature = "perception")]
pub use aboard::{ReplanReport, ReplanSlot, ReplanTotals, NAME_REPLAN, NAME_TUBES, NO_ROUTE_TEXT};

/// Largest accepted position magnitude per axis, m (anything beyond is a corrupt value).
pub const POSITION_LIMIT_M: f32 = 1.0e5;
/// Largest accepted velocity magnitude per axis, m/s.
pub const VELOCITY_LIMIT_MPS: f32 = 200.0;
/// `POSITION_TARGET_LOCAL_NED.type_mask`: velocity only (ignore position, acceleration, yaw,
/// yaw rate).
const VELOCITY_ONLY_MASK: u16 = 0b1101_1100_0111;
/// `SET_ATTITUDE_TARGET.type_mask`: ignore the three body rates.
const IGNORE_BODY_RATES_MASK: u8 = 0b0000_0111;
/// `MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN.param1` values.
const REBOOT: f32 = 1.0;
/// See [`REBOOT`].
const SHUTDOWN: f32 = 2.0;
/// `DEBUG_VECT.name` of the cable-force estimate.
pub const NAME_CABLE_FORCE: &str = "FHAT_NED";
/// `DEBUG_VECT.name` of the loop timing (x: last high-level step, y: last low-level step,
/// z: worst low-level step, in board cycles).
pub const NAME_CYCLES: &str = "CYCLES";
/// `NAMED_VALUE_INT.name` of the stack high-water mark, bytes.
pub const NAME_STACK: &str = "STACK";
/// `DEBUG_VECT.name` of the data ages, ms (x: own state, y: load, z: oldest team member; -1:
/// never received), once per second.
pub const NAME_AGES: &str = "AGES";
/// `NAMED_VALUE_FLOAT.name` of the own centre's distance to the tube boundary, m (negative
/// outside), once per second while a tube is loaded.
pub const NAME_CLEARANCE: &str = "CLEAR";

/// What the board provides.
pub trait Io {
    /// Board clock, ms (used as receive stamps and "now" outside lockstep).
    fn now_ms(&self) -> u32;
    /// A free-running cycle counter for loop timing (board-defined unit, `docs/firmware.md`).
    fn cycles(&self) -> u32;
    /// Sends one complete frame.
    fn send(&mut self, frame: &[u8]);
    /// Bytes the link can take now without dropping a frame (unbounded: a host link or a
    /// socket). A parameter list goes out only while [`PARAM_LIST_HEADROOM`] is free; the rest
    /// follows at [`Companion::poll`].
    fn tx_room(&self) -> usize {
        usize::MAX
    }
    /// Issue 28: the board runs a re-plan's search in a task of lower priority
    /// ([`Companion::take_plan_job`]), outside lockstep; otherwise the perception step runs it
    /// in line.
    fn plans_aside(&self) -> bool {
        false
    }
    /// Stack high-water mark, bytes (0 if unknown).
    fn stack_used_bytes(&self) -> u32 {
        0
    }
    /// False when nobody reads the companion's frames (host-sim's software in the loop, which
    /// reads the results through [`Companion::setpoint`] and [`Companion::flight`]): the frames
    /// are then not even encoded. Every decision is taken as with a link.
    fn wants_frames(&self) -> bool {
        true
    }
}

/// Room a parameter list leaves on the link for the control frames (a period's telemetry and
/// the setpoint), bytes: the list's frames go out only while more than this is free.
pub const PARAM_LIST_HEADROOM: usize = 1024;

/// Where a position report comes from (the frame's system and component ids, mapped by
/// `VT_SYSID_BASE` and `VT_LOAD_COMP`; docs/protocol.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Source {
    /// The own autopilot (`LOCAL_POSITION_NED`, own system, `MAV_COMP_ID_AUTOPILOT1`).
    Own,
    /// The load tracker on the own system.
    Load,
    /// Team member `j`'s autopilot, relayed by the team network (position only).
    Member(usize),
}

/// What the board should do after a message (from `MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Request {
    /// Reset the MCU.
    Reboot,
    /// Stop (QEMU: exit the emulator).
    Shutdown,
}

/// Operating mode, reported in `HEARTBEAT.custom_mode` (low byte; hold reasons in the next).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Mode {
    /// No valid tube yet.
    Unconfigured = 0,
    /// Tube accepted; waiting for `MAV_CMD_MISSION_START`.
    Ready = 1,
    /// Flying the transport.
    Transport = 2,
    /// Failsafe hold ([`HoldReasons`]); the team follows (broadcast [`TeamMode::Hold`]).
    Hold = 3,
    /// Holding with the team (following a neighbour's hold, or waiting out `FS_RESUME`).
    TeamHold = 4,
}

impl Mode {
    /// The mode a team mode is broadcast as.
    pub fn of_team(m: TeamMode) -> Self {
        match m {
            TeamMode::Transport => Self::Transport,
            TeamMode::Hold => Self::Hold,
            TeamMode::TeamHold => Self::TeamHold,
        }
    }
}

/// Values rejected after decoding (counted, dropped).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ValueCounters {
    /// Non-finite or out-of-range states, refused parameters, malformed payloads.
    pub bad_values: u32,
    /// Valid frames the companion does not use, or from systems outside the team.
    pub ignored: u32,
}

/// The companion computer's state. The tube's tables (about 9 KiB) live outside, in storage
/// the owner provides (a zero-initialised `static` on the MCU), and are built in place.
pub struct Companion<'t> {
    framer: Framer,
    core: Core<'t>,
}

/// Everything but the framer (so frames borrowed from it can be handled).
struct Core<'t> {
    params: Params,
    mission: MissionUpload,
    /// The tube's storage, built in place (`Tube::rebuild`: the tables are ~9 KiB and must
    /// not be copied through the stack); valid only when `tube_ok`.
    tube: &'t mut CompanionTube,
    /// `tube` holds a validated tube.
    tube_ok: bool,
    sources: Sources,
    flight: Option<Flight>,
    mode: Mode,
    values: ValueCounters,
    tx_seq: u8,
    clock_ms: u32,
    /// Companion clock minus the own autopilot's `time_boot_ms`, ms (wrapping), from its last
    /// `SYSTEM_TIME`; 0 in lockstep (one simulated clock); `None`: unknown, measurements are
    /// taken as sampled on receipt (no delay compensation).
    autopilot_offset_ms: Option<u32>,
    /// Lockstep: the simulated time of the period a `SYSTEM_TIME` opened (until the own state
    /// closes it).
    lockstep_now_ms: Option<u32>,
    hl_steps: u32,
    /// Team mode in the last heartbeat decision (a change sends one at once).
    team_mode_sent: TeamMode,
    /// The phase the last `HEARTBEAT` carried (`custom_mode` bits 24..31).
    phase_sent: u8,
    hl_cycles: u32,
    ll_cycles: u32,
    ll_cycles_max: u32,
    request: Option<Request>,
    link: LinkCounters,
    /// Code of the last refused `MISSION_START` ([`StartError::code`]; 0 after a start).
    refusal: u8,
    /// `custom_mode` of the last `HEARTBEAT` (what the team sees of this UAV).
    beacon: u32,
    /// The last low-level setpoint.
    setpoint: Option<Setpoint>,
    /// The next parameter of a `PARAM_REQUEST_LIST` still to send (table index).
    param_list_next: Option<u8>,
    /// Issue 28: in-flight re-planning, when attached.
    #[cfg(feature = "perception")]
    aboard: Option<&'t mut aboard::ReplanSlot<'t>>,
}

impl<'t> Companion<'t> {
    /// A fresh companion: default parameters, no tube, not armed; `tube` is its tube storage
    /// (any content: it is rebuilt before use, e.g. [`CompanionTube::placeholder`]).
    pub const fn new(tube: &'t mut CompanionTube) -> Self {
        Self {
            framer: Framer::new(),
            core: Core {
                params: Params::new(),
                mission: MissionUpload::new(),
                tube,
                tube_ok: false,
                sources: Sources::new(),
                flight: None,
                mode: Mode::Unconfigured,
                values: ValueCounters { bad_values: 0, ignored: 0 },
                tx_seq: 0,
                clock_ms: 0,
                autopilot_offset_ms: None,
                lockstep_now_ms: None,
                hl_steps: 0,
                team_mode_sent: TeamMode::Transport,
                phase_sent: 0,
                hl_cycles: 0,
                ll_cycles: 0,
                ll_cycles_max: 0,
                request: None,
                link: LinkCounters::ZERO,
                refusal: 0,
                beacon: 0,
                setpoint: None,
                param_list_next: None,
                #[cfg(feature = "perception")]
                aboard: None,
            },
        }
    }

    /// Gives the tube storage back (for reuse by another companion; the host twins pool it).
    pub fn into_tube(self) -> &'t mut CompanionTube {
        self.core.tube
    }

    /// Feeds received bytes; handles every complete frame (and, in lockstep, runs the control
    /// steps they trigger). Returns a board request if one arrived.
    pub fn on_bytes(&mut self, bytes: &[u8], io: &mut impl Io) -> Option<Request> {
        self.feed(bytes, io, false)
    }

    /// [`Companion::on_bytes`] for one whole datagram (UDP): a frame left incomplete at its
    /// end is dropped rather than completed by the next datagram ([`Framer::end_datagram`]).
    pub fn on_datagram(&mut self, bytes: &[u8], io: &mut impl Io) -> Option<Request> {
        self.feed(bytes, io, true)
    }

    /// Frames and handles `bytes`; a `datagram` ends with them ([`Framer::end_datagram`]).
    fn feed(&mut self, bytes: &[u8], io: &mut impl Io, datagram: bool) -> Option<Request> {
        for &b in bytes {
            self.framer.push(b);
            self.handle_frames(io);
        }
        if datagram {
            self.framer.end_datagram();
            self.handle_frames(io);
        }
        self.core.link = *self.framer.counters();
        self.core.request.take()
    }

    /// Sends what waits for room on the link: the rest of a parameter list. The board calls it
    /// when its transmit queue drains (the firmware's transmit task).
    pub fn poll(&mut self, io: &mut impl Io) {
        self.core.send_param_list(io);
    }

    /// Handles every complete frame the framer holds.
    fn handle_frames(&mut self, io: &mut impl Io) {
        while let Some(frame) = self.framer.next_frame() {
            self.core.handle(&frame, io);
        }
    }

    /// Adds receive overruns counted by the board's link driver (reported in `SYS_STATUS`
    /// `errors_count3`). They go into the framer's counters, which every received chunk copies
    /// into the reported ones: added to the copy, they were lost at the next chunk.
    pub fn add_overruns(&mut self, n: u32) {
        self.framer.add_overruns(n);
        self.core.link = *self.framer.counters();
    }

    /// One high-level period (Ticker mode; does nothing in lockstep). Also sends telemetry.
    pub fn high_level_step(&mut self, io: &mut impl Io) {
        if self.lockstep() {
            return;
        }
        self.core.clock_ms = io.now_ms();
        #[cfg(feature = "perception")]
        if let Some(own) = self.core.sources.own {
            self.core.perception_step(&own.value.pos_m, io);
        }
        self.core.high_level(io);
    }

    /// One low-level period (Ticker mode; does nothing in lockstep, where own states drive
    /// the steps). Returns false only when the step produced a non-finite setpoint (replaced by
    /// the level hover): the caller feeds the watchdog on true.
    pub fn low_level_step(&mut self, io: &mut impl Io) -> bool {
        if self.lockstep() {
            return true;
        }
        self.core.clock_ms = io.now_ms();
        self.core.low_level(io)
    }

    /// True with `VT_LOCKSTEP = 1`.
    pub fn lockstep(&self) -> bool {
        self.core.params.get_u32(Param::Lockstep) == 1
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.core.mode
    }

    /// Current hold reasons (clear unless in [`Mode::Hold`]).
    pub fn hold_reasons(&self) -> HoldReasons {
        self.core.flight.as_ref().map(Flight::hold_reasons).unwrap_or_default()
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.core.params
    }

    /// Link-level counters.
    pub fn link_counters(&self) -> LinkCounters {
        self.core.link
    }

    /// Value-level counters.
    pub fn value_counters(&self) -> ValueCounters {
        self.core.values
    }

    /// The armed controllers, if any.
    pub fn flight(&self) -> Option<&Flight> {
        self.core.flight.as_ref()
    }

    /// A position report from `from` (world ENU, m and m/s), sampled at `time_boot_ms` on its
    /// sender's clock: what a `LOCAL_POSITION_NED` frame does once its ids are mapped. Out of
    /// range or non-finite values are counted and dropped; in lockstep the own state runs the
    /// period's control steps.
    pub fn position(&mut self, from: Source, pos_m: Vec3, vel_mps: Vec3, time_boot_ms: u32, io: &mut impl Io) {
        self.core.position(from, pos_m, vel_mps, time_boot_ms, io);
    }

    /// The own autopilot's `SYSTEM_TIME` (`time_boot_ms`): in lockstep it opens a period, and a
    /// second one at the same time closes it without an own state.
    pub fn system_time(&mut self, time_boot_ms: u32, io: &mut impl Io) {
        self.core.system_time(time_boot_ms, io);
    }

    /// Team member `j`'s companion `HEARTBEAT` with `custom_mode` (the team failsafe).
    pub fn member_heartbeat(&mut self, j: usize, custom_mode: u32) {
        self.core.member_heartbeat(j, custom_mode);
    }

    /// `PARAM_SET` without the echo.
    ///
    /// # Errors
    /// The value is refused, or the mission runs.
    pub fn set_param(&mut self, p: Param, value: f32) -> Result<(), ParamError> {
        if self.core.flight.is_some() {
            return Err(ParamError::Locked);
        }
        self.core.params.set(p, value)?;
        if p.is_map() {
            self.core.map_params_changed();
        }
        Ok(())
    }

    /// The tube upload without the handshake: `items` as the mission protocol carries them,
    /// checked and built as an upload over the link is.
    ///
    /// # Errors
    /// The `MAV_MISSION_RESULT` a ground station would get.
    pub fn upload_tube(&mut self, items: &[Item], io: &mut impl Io) -> Result<(), MissionResult> {
        if self.core.flight.is_some() {
            return Err(MissionResult::Denied);
        }
        let mut reply = self.core.mission.begin(u16::try_from(items.len()).unwrap_or(u16::MAX));
        for it in items {
            match reply {
                UploadReply::Refuse(r) => return Err(r),
                _ => reply = self.core.mission.item(it),
            }
        }
        match reply {
            UploadReply::Complete if self.core.finish_upload(io) => Ok(()),
            UploadReply::Complete => Err(MissionResult::Invalid),
            UploadReply::Refuse(r) => Err(r),
            _ => Err(MissionResult::InvalidSequence),
        }
    }

    /// `MAV_CMD_MISSION_START` without the acknowledgement (a refusal still sends its
    /// `STATUSTEXT` lines and heartbeat).
    ///
    /// # Errors
    /// Why the start was refused.
    pub fn start_mission(&mut self, io: &mut impl Io) -> Result<(), StartError> {
        let r = self.core.start(io);
        self.core.update_mode();
        r
    }

    /// The operator's hold (`MAV_CMD_DO_PAUSE_CONTINUE`) without the command: on, this UAV
    /// holds and tells the team at once (a `HEARTBEAT` in `Hold`, which every fresh neighbour
    /// follows); off, the team resumes `FS_RESUME` after the last alarm. Returns false when no
    /// mission runs.
    pub fn operator_hold(&mut self, on: bool, io: &mut impl Io) -> bool {
        let Some(fl) = self.core.flight.as_mut() else {
            return false;
        };
        fl.set_operator_hold(on);
        if on {
            // Announce now: the next high-level step may never come (the Linux companion's
            // Ctrl-C exits right after).
            self.core.mode = Mode::Hold;
            self.core.send_heartbeat_with(io, HoldReasons::OPERATOR);
        }
        true
    }

    /// A `HEARTBEAT` now (the 1 Hz heartbeat of a companion that is not flying: a simulator or
    /// router learns where it is from it).
    pub fn heartbeat(&mut self, io: &mut impl Io) {
        self.core.send_heartbeat(io);
    }

    /// The last low-level setpoint (`SET_ATTITUDE_TARGET`), if any.
    pub fn setpoint(&self) -> Option<Setpoint> {
        self.core.setpoint
    }

    /// `custom_mode` of the last `HEARTBEAT` sent: mode, hold reasons `<< 8`, refusal code
    /// `<< 16` (docs/protocol.md). What the team and the ground station see of this UAV.
    pub fn heartbeat_custom_mode(&self) -> u32 {
        self.core.beacon
    }

    /// High-level rate, Hz.
    pub fn high_level_hz(&self) -> u32 {
        self.core.params.get_u32(Param::HlHz)
    }

    /// Low-level rate, Hz.
    pub fn low_level_hz(&self) -> u32 {
        self.core.params.get_u32(Param::LlHz)
    }
}

impl Core<'_> {
    fn tube(&self) -> Option<&CompanionTube> {
        self.tube_ok.then_some(&*self.tube)
    }

    fn own_system_id(&self) -> u8 {
        self.params.own_system_id()
    }

    fn send<D: MessageData>(&mut self, io: &mut impl Io, data: &D) {
        if !io.wants_frames() {
            return;
        }
        let mut raw = MAVLinkV2MessageRaw::new();
        let header = MavHeader { system_id: u32::from(self.own_system_id()), component_id: COMPANION_COMPONENT_ID, sequence: self.tx_seq };
        raw.serialize_message_data(header, data);
        self.tx_seq = self.tx_seq.wrapping_add(1);
        io.send(raw.raw_bytes());
    }

    fn bad_value(&mut self) {
        self.values.bad_values = self.values.bad_values.wrapping_add(1);
    }

    fn ignored(&mut self) {
        self.values.ignored = self.values.ignored.wrapping_add(1);
    }

    /// True when a message addressed to (`system`, `component`) is for us.
    fn for_us(&self, system: u8, component: u8) -> bool {
        (system == 0 || system == self.own_system_id()) && (component == 0 || component == COMPANION_COMPONENT_ID)
    }

    fn handle(&mut self, f: &Frame<'_>, io: &mut impl Io) {
        macro_rules! decode {
            ($t:ty) => {
                match <$t>::deser(MavlinkVersion::V2, f.payload) {
                    Ok(d) => d,
                    Err(_) => return self.bad_value(),
                }
            };
        }
        match f.message_id {
            LOCAL_POSITION_NED_DATA::ID => {
                let d = decode!(LOCAL_POSITION_NED_DATA);
                self.on_local_position(f, &d, io);
            }
            SYSTEM_TIME_DATA::ID => {
                let d = decode!(SYSTEM_TIME_DATA);
                self.on_system_time(f, &d, io);
            }
            PARAM_SET_DATA::ID => {
                let d = decode!(PARAM_SET_DATA);
                self.on_param_set(f, &d, io);
            }
            PARAM_REQUEST_READ_DATA::ID => {
                let d = decode!(PARAM_REQUEST_READ_DATA);
                if !self.for_us(d.target_system, d.target_component) {
                    return self.ignored();
                }
                let p = match d.param_index {
                    -1 => d.param_id.to_str().ok().and_then(Param::from_name),
                    k => usize::try_from(k).ok().and_then(Param::from_index),
                };
                match p {
                    Some(p) => self.send_param(io, p),
                    None => self.bad_value(),
                }
            }
            PARAM_REQUEST_LIST_DATA::ID => {
                let d = decode!(PARAM_REQUEST_LIST_DATA);
                if !self.for_us(d.target_system, d.target_component) {
                    return self.ignored();
                }
                self.param_list_next = Some(0);
                self.send_param_list(io);
            }
            MISSION_COUNT_DATA::ID => {
                let d = decode!(MISSION_COUNT_DATA);
                #[cfg(feature = "perception")]
                if self.is_offer(f) {
                    return self.offer_count(f, &d);
                }
                if !self.for_us(d.target_system, d.target_component) {
                    return self.ignored();
                }
                let reply = if self.flight.is_some() { UploadReply::Refuse(MissionResult::Denied) } else { self.mission.begin(d.count) };
                self.mission_reply(f, reply, io);
            }
            MISSION_ITEM_INT_DATA::ID => {
                let d = decode!(MISSION_ITEM_INT_DATA);
                if !self.for_us(d.target_system, d.target_component) {
                    return self.ignored();
                }
                let item = Item {
                    seq: d.seq,
                    frame: d.frame as u8,
                    command: d.command as u16,
                    x: d.x,
                    y: d.y,
                    param1: d.param1,
                    param2: d.param2,
                };
                #[cfg(feature = "perception")]
                if self.is_offer(f) {
                    return self.offer_item(f, &item);
                }
                let reply = if self.flight.is_some() { UploadReply::Refuse(MissionResult::Denied) } else { self.mission.item(&item) };
                if matches!(reply, UploadReply::Refuse(_)) {
                    self.bad_value();
                }
                self.mission_reply(f, reply, io);
            }
            MISSION_CLEAR_ALL_DATA::ID => {
                let d = decode!(MISSION_CLEAR_ALL_DATA);
                if !self.for_us(d.target_system, d.target_component) {
                    return self.ignored();
                }
                let result = if self.flight.is_some() {
                    MavMissionResult::MAV_MISSION_DENIED
                } else {
                    self.mission.clear();
                    self.tube_ok = false;
                    self.mode = Mode::Unconfigured;
                    MavMissionResult::MAV_MISSION_ACCEPTED
                };
                self.send(io, &MISSION_ACK_DATA { target_system: f.system_id, target_component: f.component_id, mavtype: result });
            }
            COMMAND_LONG_DATA::ID => {
                let d = decode!(COMMAND_LONG_DATA);
                if !self.for_us(d.target_system, d.target_component) {
                    return self.ignored();
                }
                self.on_command(&d, io);
            }
            HEARTBEAT_DATA::ID => {
                let d = decode!(HEARTBEAT_DATA);
                self.on_heartbeat(f, &d);
            }
            #[cfg(feature = "perception")]
            mavlink::dialects::common::OBSTACLE_DISTANCE_DATA::ID => {
                let d = decode!(mavlink::dialects::common::OBSTACLE_DISTANCE_DATA);
                self.on_obstacle_distance(f, &d);
            }
            _ => self.ignored(),
        }
    }

    /// Without the `perception` feature there is no onboard map.
    #[cfg(not(feature = "perception"))]
    fn map_on(&mut self) -> bool {
        false
    }

    /// Without the `perception` feature there is no onboard map to configure.
    #[cfg(not(feature = "perception"))]
    fn map_params_changed(&mut self) {}

    fn high_level(&mut self, io: &mut impl Io) {
        let now = self.clock_ms;
        if let (Some(fl), Some(tube)) = (self.flight.as_mut(), self.tube_ok.then_some(&*self.tube)) {
            let t0 = io.cycles();
            let v = fl.high_level(tube, &self.sources, now);
            self.hl_cycles = io.cycles().wrapping_sub(t0);
            let refusal = fl.take_refusal();
            let ned = ned_from_enu(&v);
            let f_hat = ned_from_enu(&fl.cable_force_n());
            self.update_mode();
            let target = POSITION_TARGET_LOCAL_NED_DATA {
                time_boot_ms: now,
                x: 0.0,
                y: 0.0,
                z: 0.0,
                vx: ned[0],
                vy: ned[1],
                vz: ned[2],
                afx: 0.0,
                afy: 0.0,
                afz: 0.0,
                yaw: 0.0,
                yaw_rate: 0.0,
                type_mask: PositionTargetTypemask::from_bits_truncate(VELOCITY_ONLY_MASK),
                coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
            };
            self.send(io, &target);
            let time_usec = u64::from(now) * 1000;
            self.send(io, &DEBUG_VECT_DATA { time_usec, x: f_hat[0], y: f_hat[1], z: f_hat[2], name: NAME_CABLE_FORCE.into() });
            let (x, y, z) = (self.hl_cycles as f32, self.ll_cycles as f32, self.ll_cycles_max as f32);
            self.send(io, &DEBUG_VECT_DATA { time_usec, x, y, z, name: NAME_CYCLES.into() });
            // A ground start refused at its arming, or its lift abandoned: said once.
            if let Some(e) = refusal {
                log!(warn, "ground start refused: {}", e);
                self.refused(&e, io);
            }
        }
        // Slow telemetry once per second of high-level steps; the heartbeat also at every step
        // while holding and on every change of the team mode or the phase (docs/protocol.md, "Team
        // failsafe").
        let per_second = self.params.get_u32(Param::HlHz).max(1);
        let team = self.flight.as_ref().map_or(TeamMode::Transport, Flight::team_mode);
        let phase = self.flight.as_ref().map_or(0, |f| f.phase() as u8);
        let beat = team.is_holding() || team != self.team_mode_sent || phase != self.phase_sent;
        self.team_mode_sent = team;
        self.phase_sent = phase;
        if self.hl_steps.is_multiple_of(per_second) {
            self.send_status(io);
        } else if beat {
            self.send_heartbeat(io);
        }
        self.hl_steps = self.hl_steps.wrapping_add(1);
    }

    /// Returns false when the setpoint had to be replaced (non-finite); true otherwise,
    /// including when not armed (nothing to send).
    fn low_level(&mut self, io: &mut impl Io) -> bool {
        let now = self.clock_ms;
        let Some(fl) = self.flight.as_mut() else {
            return true;
        };
        let t0 = io.cycles();
        let sp: Setpoint = fl.low_level(&self.sources, now);
        self.setpoint = Some(sp);
        self.ll_cycles = io.cycles().wrapping_sub(t0);
        self.ll_cycles_max = self.ll_cycles_max.max(self.ll_cycles);
        // Hold on stale data is a designed state; only a non-finite output is unhealthy.
        let healthy = fl.hold_reasons().0 & HoldReasons::NONFINITE == 0;
        self.update_mode();
        let msg = SET_ATTITUDE_TARGET_DATA {
            time_boot_ms: now,
            q: sp.q_ned,
            body_roll_rate: 0.0,
            body_pitch_rate: 0.0,
            body_yaw_rate: 0.0,
            thrust: sp.thrust,
            target_system: self.own_system_id(),
            target_component: AUTOPILOT_COMPONENT_ID,
            type_mask: AttitudeTargetTypemask::from_bits_truncate(IGNORE_BODY_RATES_MASK),
        };
        self.send(io, &msg);
        healthy
    }

    fn update_mode(&mut self) {
        let new = match &self.flight {
            // The team mode of the last high-level step; a low-level hold in between is a hold.
            Some(fl) if fl.team_mode() == TeamMode::Transport && !fl.hold_reasons().is_clear() => Mode::Hold,
            Some(fl) => Mode::of_team(fl.team_mode()),
            None if self.tube_ok => Mode::Ready,
            None => Mode::Unconfigured,
        };
        if new != self.mode {
            log!(info, "mode {} -> {} (hold reasons {=u8:#x})", self.mode, new, self.flight.as_ref().map_or(0, |f| f.hold_reasons().0));
            self.mode = new;
        }
    }

    fn on_param_set(&mut self, _f: &Frame<'_>, d: &PARAM_SET_DATA, io: &mut impl Io) {
        if !self.for_us(d.target_system, d.target_component) {
            return self.ignored();
        }
        let Some(p) = d.param_id.to_str().ok().and_then(Param::from_name) else {
            log!(warn, "PARAM_SET: unknown name");
            return self.bad_value();
        };
        let result = if self.flight.is_some() { Err(ParamError::Locked) } else { self.params.set(p, d.param_value) };
        if result.is_ok() && p.is_map() {
            self.map_params_changed();
        }
        if let Err(_e) = result {
            log!(warn, "PARAM_SET {} refused: {}", p, _e);
            self.bad_value();
        }
        // Echo the value in force (the new one, or the unchanged one when refused).
        self.send_param(io, p);
    }

    fn mission_reply(&mut self, f: &Frame<'_>, reply: UploadReply, io: &mut impl Io) {
        let (ts, tc) = (f.system_id, f.component_id);
        let ack = |r| MISSION_ACK_DATA { target_system: ts, target_component: tc, mavtype: r };
        match reply {
            UploadReply::Request(seq) => self.send(io, &MISSION_REQUEST_INT_DATA { seq, target_system: ts, target_component: tc }),
            UploadReply::Nothing => self.ignored(),
            UploadReply::Refuse(r) => {
                let code = match r {
                    MissionResult::Error => MavMissionResult::MAV_MISSION_ERROR,
                    MissionResult::UnsupportedFrame => MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME,
                    MissionResult::Unsupported => MavMissionResult::MAV_MISSION_UNSUPPORTED,
                    MissionResult::NoSpace => MavMissionResult::MAV_MISSION_NO_SPACE,
                    MissionResult::Invalid => MavMissionResult::MAV_MISSION_INVALID,
                    MissionResult::InvalidParam1 => MavMissionResult::MAV_MISSION_INVALID_PARAM1,
                    MissionResult::InvalidSequence => MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                    MissionResult::Denied => MavMissionResult::MAV_MISSION_DENIED,
                };
                self.send(io, &ack(code));
            }
            UploadReply::Complete => {
                let result = if self.finish_upload(io) { MavMissionResult::MAV_MISSION_ACCEPTED } else { MavMissionResult::MAV_MISSION_INVALID };
                self.send(io, &ack(result));
            }
        }
    }

    /// A complete upload: builds and validates the tube now, once (the lookup tables are the
    /// expensive part). True when accepted.
    fn finish_upload(&mut self, io: &mut impl Io) -> bool {
        let t0 = io.cycles();
        let built = self.tube.rebuild(self.mission.waypoints());
        let _cycles = io.cycles().wrapping_sub(t0);
        self.tube_ok = built.is_ok();
        match built {
            Ok(()) => {
                log!(info, "tube accepted: {} waypoints, built in {} cycles", self.mission.waypoints().len(), _cycles);
            }
            Err(_e) => {
                log!(warn, "tube rejected: {}", _e);
                self.bad_value();
            }
        }
        self.update_mode();
        self.tube_ok
    }
}
