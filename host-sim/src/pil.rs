//! Processor-in-the-loop (PIL): the f64 plant on the host, each UAV's controller inside its own
//! QEMU (`mps2-an386`) running the `qemu` firmware ELF, MAVLink 2 frames over each instance's
//! emulated UART (a Unix socket per instance), in lockstep with simulated time.
//!
//! # Lockstep
//! The firmware runs with `VT_LOCKSTEP = 1`: each own `LOCAL_POSITION_NED` it receives is one
//! low-level period. Per low-level period the host sends every UAV, in this order, the load's
//! state and the neighbours' positions (only when the high level is due) and then its own state;
//! the firmware answers with telemetry and, last, `SET_ATTITUDE_TARGET`, which the host waits
//! for before stepping the plant. Simulated time is carried in `time_boot_ms`; the emulator's
//! own clock plays no part, so results do not depend on host speed.
//!
//! The host plays the autopilot (own state in, attitude setpoint out: thrust vector
//! `collective * T_max * R(q) (0, 0, -1)_FRD`, converted to ENU), the load tracker, the team
//! network (the neighbour link model of `sim::run`) and the ground station (parameters, the
//! tube as a mission, `MAV_CMD_MISSION_START`).
//!
//! # SIL twin and bit-exactness
//! The same mission is flown again with every UAV's firmware replaced by
//! [`vt_companion::Companion`] compiled for the host (the crate the firmware wraps), fed the
//! identical byte stream. Both runs record every command the controllers produced (attitude
//! quaternion and collective at each low-level step; velocity command and cable-force
//! estimate at each high-level step) and [`PilReport`] compares them bit for bit. The controller
//! crates are `f32` code without fused multiply-add and use the `libm` crate on both sides
//! (`nalgebra/libm-force` on the host), so any difference is a finding, reported with its
//! first occurrence.
//!
//! The sensing mirrors `sim::run` without disturbances (noise, latency, wind, parameter draws
//! and faults are not modelled here; the report says so when the scenario has any): the high
//! level reads the last low-level sample, the low level the fresh velocity, neighbours pass
//! through the same link model.

use crate::cable::CableParams;
use crate::link::Link;
use crate::plant::{LoadParams, Plant, UavParams};
use crate::scenario::{LoadedScenario, Scenario};
use crate::sim::{self, Takeoff};
use crate::summary::Summary;
use mavlink::dialects::common::{
    MavCmd, MavFrame, MavParamType, COMMAND_ACK_DATA, COMMAND_LONG_DATA, DEBUG_VECT_DATA, HEARTBEAT_DATA,
    LOCAL_POSITION_NED_DATA, MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA,
    NAMED_VALUE_INT_DATA, PARAM_SET_DATA, PARAM_VALUE_DATA, POSITION_TARGET_LOCAL_NED_DATA, SET_ATTITUDE_TARGET_DATA,
    SYS_STATUS_DATA,
};
use mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, MessageData};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::Serialize;
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use vt_companion::companion::{NAME_CABLE_FORCE, NAME_CYCLES};
use vt_companion::{Companion, CompanionTube, Framer, Io, Param, AUTOPILOT_COMPONENT_ID, COMPANION_COMPONENT_ID};
use vt_dissipative::{Formation, MAX_UAVS};

type V3 = Vector3<f64>;
type V3f = Vector3<f32>;

/// System id the host uses as ground station.
pub const GCS_SYSTEM_ID: u8 = 255;
/// Component id the host uses as ground station (`MAV_COMP_ID_MISSIONPLANNER`).
pub const GCS_COMPONENT_ID: u8 = 190;
/// Component id of the load tracker on every UAV (`VT_LOAD_COMP`, `MAV_COMP_ID_CAMERA`).
pub const LOAD_COMPONENT_ID: u8 = 100;
/// System id of UAV 0 (`VT_SYSID_BASE`).
pub const SYSID_BASE: u8 = 1;
/// How long the host waits for one answer from an emulator before giving up.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(30);
/// Own-state timeout sent to the firmware (`FS_OWN_TMO`), s: ten low-level periods at 500 Hz.
pub const OWN_TIMEOUT_S: f32 = 0.02;
/// Load-state timeout (`FS_LOAD_TMO`), s.
pub const LOAD_TIMEOUT_S: f32 = 0.5;

/// A PIL run that could not be carried out.
#[derive(Debug, Clone, PartialEq)]
pub struct PilError(pub String);

impl std::fmt::Display for PilError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PilError {}

fn err<T>(msg: impl Into<String>) -> Result<T, PilError> {
    Err(PilError(msg.into()))
}

// ---------------------------------------------------------------------------------------------
// Messages

/// Frames sent by the host, with one sequence counter per sending component.
#[derive(Debug, Default)]
pub struct Encoder {
    seq: u8,
}

impl Encoder {
    /// One MAVLink 2 frame from (`system`, `component`).
    pub fn frame<D: MessageData>(&mut self, system: u8, component: u8, data: &D) -> Vec<u8> {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_data(MavHeader { system_id: u32::from(system), component_id: component, sequence: self.seq }, data);
        self.seq = self.seq.wrapping_add(1);
        raw.raw_bytes().to_vec()
    }
}

/// `LOCAL_POSITION_NED` for an ENU position and velocity.
pub fn local_position(time_ms: u32, pos_enu: &V3f, vel_enu: &V3f) -> LOCAL_POSITION_NED_DATA {
    LOCAL_POSITION_NED_DATA { time_boot_ms: time_ms, x: pos_enu.y, y: pos_enu.x, z: -pos_enu.z, vx: vel_enu.y, vy: vel_enu.x, vz: -vel_enu.z }
}

/// What the companion sent, decoded.
#[derive(Debug, Clone, PartialEq)]
pub enum Rx {
    /// `SET_ATTITUDE_TARGET`.
    Setpoint {
        /// `time_boot_ms`.
        time_ms: u32,
        /// Quaternion FRD -> NED, `[w, x, y, z]`.
        q: [f32; 4],
        /// Collective, `[0, 1]`.
        thrust: f32,
    },
    /// `POSITION_TARGET_LOCAL_NED`: the high-level velocity command (NED, m/s).
    VelocityTarget {
        /// `time_boot_ms`.
        time_ms: u32,
        /// Velocity, NED.
        v_ned: [f32; 3],
    },
    /// `DEBUG_VECT` `FHAT_NED`: the CFO's cable-force estimate (NED, N).
    CableForce([f32; 3]),
    /// `DEBUG_VECT` `CYCLES`: last high-level, last low-level, worst low-level step (cycles).
    Cycles([f32; 3]),
    /// `HEARTBEAT`: `custom_mode` (mode | hold reasons << 8).
    Heartbeat(u32),
    /// `SYS_STATUS` error counters: comm (checksum + framing), unknown ids, bad values,
    /// overruns, discarded bytes.
    Status([u16; 5]),
    /// `PARAM_VALUE`.
    ParamValue(String, f32),
    /// `MISSION_REQUEST_INT`.
    MissionRequest(u16),
    /// `MISSION_ACK` (`MAV_MISSION_RESULT` value).
    MissionAck(u32),
    /// `COMMAND_ACK` (command, `MAV_RESULT` value).
    CommandAck(u32, u32),
    /// `NAMED_VALUE_INT`.
    NamedInt(String, i32),
    /// Anything else (message id).
    Other(u32),
}

fn decode(id: u32, payload: &[u8]) -> Option<Rx> {
    let v2 = MavlinkVersion::V2;
    Some(match id {
        SET_ATTITUDE_TARGET_DATA::ID => {
            let d = SET_ATTITUDE_TARGET_DATA::deser(v2, payload).ok()?;
            Rx::Setpoint { time_ms: d.time_boot_ms, q: d.q, thrust: d.thrust }
        }
        POSITION_TARGET_LOCAL_NED_DATA::ID => {
            let d = POSITION_TARGET_LOCAL_NED_DATA::deser(v2, payload).ok()?;
            Rx::VelocityTarget { time_ms: d.time_boot_ms, v_ned: [d.vx, d.vy, d.vz] }
        }
        DEBUG_VECT_DATA::ID => {
            let d = DEBUG_VECT_DATA::deser(v2, payload).ok()?;
            match d.name.to_str().unwrap_or("") {
                n if n == NAME_CABLE_FORCE => Rx::CableForce([d.x, d.y, d.z]),
                n if n == NAME_CYCLES => Rx::Cycles([d.x, d.y, d.z]),
                _ => Rx::Other(id),
            }
        }
        HEARTBEAT_DATA::ID => Rx::Heartbeat(HEARTBEAT_DATA::deser(v2, payload).ok()?.custom_mode),
        SYS_STATUS_DATA::ID => {
            let d = SYS_STATUS_DATA::deser(v2, payload).ok()?;
            Rx::Status([d.errors_comm, d.errors_count1, d.errors_count2, d.errors_count3, d.errors_count4])
        }
        PARAM_VALUE_DATA::ID => {
            let d = PARAM_VALUE_DATA::deser(v2, payload).ok()?;
            Rx::ParamValue(d.param_id.to_str().unwrap_or("").to_string(), d.param_value)
        }
        MISSION_REQUEST_INT_DATA::ID => Rx::MissionRequest(MISSION_REQUEST_INT_DATA::deser(v2, payload).ok()?.seq),
        MISSION_ACK_DATA::ID => Rx::MissionAck(MISSION_ACK_DATA::deser(v2, payload).ok()?.mavtype as u32),
        COMMAND_ACK_DATA::ID => {
            let d = COMMAND_ACK_DATA::deser(v2, payload).ok()?;
            Rx::CommandAck(d.command as u32, d.result as u32)
        }
        NAMED_VALUE_INT_DATA::ID => {
            let d = NAMED_VALUE_INT_DATA::deser(v2, payload).ok()?;
            Rx::NamedInt(d.name.to_str().unwrap_or("").to_string(), d.value)
        }
        other => Rx::Other(other),
    })
}

// ---------------------------------------------------------------------------------------------
// Ports

/// One UAV's link to its companion: the firmware in QEMU, or its host twin.
pub trait Port {
    /// Sends bytes (frames or anything else).
    ///
    /// # Errors
    /// The link is closed.
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError>;
    /// The next message from the companion.
    ///
    /// # Errors
    /// Nothing arrives within the timeout (QEMU), or nothing is pending (host twin).
    fn recv(&mut self) -> Result<Rx, PilError>;
    /// Waits for the companion to stop (after a shutdown request) and returns its exit code
    /// and raw log; a host twin has neither.
    ///
    /// # Errors
    /// It does not stop in time.
    fn finish(self: Box<Self>) -> Result<(Option<i32>, Vec<u8>), PilError> {
        Ok((Some(0), Vec::new()))
    }
}

impl Port for Box<dyn Port> {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        self.as_mut().send(bytes)
    }
    fn recv(&mut self) -> Result<Rx, PilError> {
        self.as_mut().recv()
    }
    fn finish(self: Box<Self>) -> Result<(Option<i32>, Vec<u8>), PilError> {
        (*self).finish()
    }
}

/// The board side of the host twin: frames into a byte queue, no clock (lockstep needs none).
struct TwinIo<'a> {
    out: &'a mut Vec<u8>,
}

impl Io for TwinIo<'_> {
    fn now_ms(&self) -> u32 {
        0
    }
    fn cycles(&self) -> u32 {
        0
    }
    fn send(&mut self, frame: &[u8]) {
        self.out.extend_from_slice(frame);
    }
}

/// Tube storage of dropped twins, reused by new ones: a companion borrows its tube for its
/// lifetime (`'static` on the MCU), so the twins take theirs from this pool (leaked once,
/// about 9 KiB each); memory is bounded by the most twins alive at once.
static TUBE_POOL: std::sync::Mutex<Vec<&'static mut CompanionTube>> = std::sync::Mutex::new(Vec::new());

/// The firmware's companion compiled for the host (software in the loop).
pub struct SilPort {
    /// Always `Some` until dropped (then its tube goes back to the pool).
    companion: Option<Box<Companion<'static>>>,
    framer: Framer,
    pending: VecDeque<Rx>,
}

impl Default for SilPort {
    fn default() -> Self {
        Self::new()
    }
}

impl SilPort {
    /// A fresh companion.
    pub fn new() -> Self {
        let pooled = TUBE_POOL.lock().ok().and_then(|mut pool| pool.pop());
        let tube: &'static mut CompanionTube = pooled.unwrap_or_else(|| Box::leak(Box::new(CompanionTube::placeholder())));
        Self { companion: Some(Box::new(Companion::new(tube))), framer: Framer::new(), pending: VecDeque::new() }
    }

    /// The companion (for inspection in tests); `None` only while the twin is being dropped.
    pub fn companion(&self) -> Option<&Companion<'static>> {
        self.companion.as_deref()
    }
}

impl Drop for SilPort {
    fn drop(&mut self) {
        if let Some(c) = self.companion.take() {
            let tube = c.into_tube();
            if let Ok(mut pool) = TUBE_POOL.lock() {
                pool.push(tube);
            }
        }
    }
}

impl Port for SilPort {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        let mut out = Vec::new();
        let Some(companion) = self.companion.as_deref_mut() else {
            return Err(PilError("host twin: dropped".into()));
        };
        let _request = companion.on_bytes(bytes, &mut TwinIo { out: &mut out });
        for b in out {
            self.framer.push(b);
            while let Some(f) = self.framer.next_frame() {
                if let Some(rx) = decode(f.message_id, f.payload) {
                    self.pending.push_back(rx);
                }
            }
        }
        Ok(())
    }

    fn recv(&mut self) -> Result<Rx, PilError> {
        self.pending.pop_front().ok_or_else(|| PilError("host twin: no reply pending".into()))
    }
}

/// How to start QEMU.
#[derive(Debug, Clone)]
pub struct QemuOptions {
    /// The emulator binary.
    pub qemu: String,
    /// `-icount shift=0`: one instruction per virtual nanosecond (for instruction counts).
    pub icount: bool,
    /// Directory for the sockets.
    pub socket_dir: PathBuf,
    /// Instance name (socket file name).
    pub name: String,
}

/// The firmware in one QEMU instance.
pub struct QemuPort {
    child: Child,
    stream: UnixStream,
    framer: Framer,
    pending: VecDeque<Rx>,
    defmt: Arc<Mutex<Vec<u8>>>,
    reader: Option<std::thread::JoinHandle<()>>,
    socket: PathBuf,
}

impl QemuPort {
    /// Starts QEMU on `elf` with UART0 connected to a fresh Unix socket.
    ///
    /// # Errors
    /// The emulator cannot start or does not connect.
    pub fn spawn(elf: &Path, o: &QemuOptions) -> Result<Self, PilError> {
        if !elf.is_file() {
            return err(format!("firmware ELF {} not found (build it: cd firmware && cargo build --release --features qemu)", elf.display()));
        }
        std::fs::create_dir_all(&o.socket_dir).map_err(|e| PilError(format!("{}: {e}", o.socket_dir.display())))?;
        let socket = o.socket_dir.join(format!("{}.sock", o.name));
        let _ = std::fs::remove_file(&socket);
        let listener = UnixListener::bind(&socket).map_err(|e| PilError(format!("{}: {e}", socket.display())))?;
        let mut cmd = Command::new(&o.qemu);
        cmd.args(["-machine", "mps2-an386", "-cpu", "cortex-m4", "-display", "none", "-monitor", "none", "-nodefaults", "-nic", "none"])
            .args(["-chardev", &format!("socket,id=link,path={}", socket.display()), "-serial", "chardev:link"])
            .args(["-semihosting-config", "enable=on,target=native"]);
        if o.icount {
            cmd.args(["-icount", "shift=0"]);
        }
        cmd.arg("-kernel").arg(elf).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
        let mut child = cmd.spawn().map_err(|e| PilError(format!("cannot start {}: {e}", o.qemu)))?;
        // Forward the emulator's messages, less the one about the board's unused Ethernet.
        if let Some(err_pipe) = child.stderr.take() {
            std::thread::spawn(move || {
                use std::io::BufRead;
                for line in std::io::BufReader::new(err_pipe).lines().map_while(Result::ok) {
                    if !line.contains("has no peer") {
                        eprintln!("{line}");
                    }
                }
            });
        }
        listener.set_nonblocking(true).map_err(|e| PilError(e.to_string()))?;
        let t0 = Instant::now();
        let stream = loop {
            match listener.accept() {
                Ok((s, _)) => break s,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    if let Ok(Some(status)) = child.try_wait() {
                        return err(format!("{} exited before connecting ({status})", o.qemu));
                    }
                    if t0.elapsed() > REPLY_TIMEOUT {
                        let _ = child.kill();
                        return err(format!("{} did not connect to {}", o.qemu, socket.display()));
                    }
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(e) => return err(e.to_string()),
            }
        };
        stream.set_nonblocking(false).map_err(|e| PilError(e.to_string()))?;
        stream.set_read_timeout(Some(REPLY_TIMEOUT)).map_err(|e| PilError(e.to_string()))?;
        let defmt = Arc::new(Mutex::new(Vec::new()));
        let reader = child.stdout.take().map(|mut out| {
            let sink = Arc::clone(&defmt);
            std::thread::spawn(move || {
                let mut buf = [0u8; 4096];
                while let Ok(n) = out.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    if let (Ok(mut v), Some(chunk)) = (sink.lock(), buf.get(..n)) {
                        v.extend_from_slice(chunk);
                    }
                }
            })
        });
        Ok(Self { child, stream, framer: Framer::new(), pending: VecDeque::new(), defmt, reader, socket })
    }

    /// Link counters of the host's receiver (frames from the firmware).
    pub fn host_rx_counters(&self) -> vt_companion::LinkCounters {
        *self.framer.counters()
    }

    /// Asks the firmware to shut down (`MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN`, param1 = 2) and
    /// waits for the emulator to exit. Returns its exit code and the raw defmt bytes.
    ///
    /// # Errors
    /// The emulator does not exit in time (it is then killed).
    pub fn shutdown(mut self, enc: &mut Encoder, system_id: u8) -> Result<(Option<i32>, Vec<u8>), PilError> {
        let cmd = COMMAND_LONG_DATA {
            param1: 2.0,
            command: MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
            target_system: system_id,
            target_component: COMPANION_COMPONENT_ID,
            ..COMMAND_LONG_DATA::default()
        };
        let _ = self.send(&enc.frame(GCS_SYSTEM_ID, GCS_COMPONENT_ID, &cmd));
        self.wait_exit()
    }

    /// Waits for the emulator to exit by itself (e.g. after a shutdown request or a failure).
    ///
    /// # Errors
    /// It does not exit within the timeout (it is then killed).
    pub fn wait_exit(mut self) -> Result<(Option<i32>, Vec<u8>), PilError> {
        let t0 = Instant::now();
        // Keep draining the link: a firmware blocked on a full socket could not act on the
        // shutdown request.
        let _ = self.stream.set_nonblocking(true);
        let mut sink = [0u8; 4096];
        let status = loop {
            while matches!(self.stream.read(&mut sink), Ok(n) if n > 0) {}
            match self.child.try_wait() {
                Ok(Some(s)) => break Some(s),
                Ok(None) if t0.elapsed() < REPLY_TIMEOUT => std::thread::sleep(Duration::from_millis(5)),
                _ => break None,
            }
        };
        let timed_out = status.is_none();
        if timed_out {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
        let _ = std::fs::remove_file(&self.socket);
        let bytes = self.defmt.lock().map(|v| v.clone()).unwrap_or_default();
        if timed_out {
            return err("emulator did not exit in time (killed)");
        }
        Ok((status.and_then(|s| s.code()), bytes))
    }

    /// The defmt bytes received so far.
    pub fn defmt_bytes(&self) -> Vec<u8> {
        self.defmt.lock().map(|v| v.clone()).unwrap_or_default()
    }
}

impl Drop for QemuPort {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        let _ = std::fs::remove_file(&self.socket);
    }
}

impl Port for QemuPort {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        self.stream.write_all(bytes).map_err(|e| PilError(format!("link write: {e}")))
    }

    fn finish(self: Box<Self>) -> Result<(Option<i32>, Vec<u8>), PilError> {
        (*self).wait_exit()
    }

    fn recv(&mut self) -> Result<Rx, PilError> {
        let mut buf = [0u8; 1024];
        loop {
            if let Some(rx) = self.pending.pop_front() {
                return Ok(rx);
            }
            let n = self.stream.read(&mut buf).map_err(|e| PilError(format!("link read: {e}")))?;
            if n == 0 {
                return err("link closed by the emulator");
            }
            for &b in buf.get(..n).unwrap_or(&[]) {
                self.framer.push(b);
                while let Some(f) = self.framer.next_frame() {
                    if let Some(rx) = decode(f.message_id, f.payload) {
                        self.pending.push_back(rx);
                    }
                }
            }
        }
    }
}

/// Decodes defmt bytes (the firmware's semihosting output) with the ELF's table.
///
/// # Errors
/// The ELF has no defmt table or cannot be read.
pub fn decode_defmt(elf: &Path, bytes: &[u8]) -> Result<Vec<String>, PilError> {
    let data = std::fs::read(elf).map_err(|e| PilError(format!("{}: {e}", elf.display())))?;
    let table = defmt_decoder::Table::parse(&data)
        .map_err(|e| PilError(format!("defmt table: {e}")))?
        .ok_or_else(|| PilError("the ELF has no defmt table".into()))?;
    let mut dec = table.new_stream_decoder();
    dec.received(bytes);
    let mut lines = Vec::new();
    loop {
        match dec.decode() {
            Ok(frame) => lines.push(format!("{}", frame.display_message())),
            Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
            Err(defmt_decoder::DecodeError::Malformed) => lines.push("<malformed defmt frame>".into()),
        }
    }
    Ok(lines)
}

/// True when the emulator can be started.
pub fn qemu_available(qemu: &str) -> bool {
    Command::new(qemu).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
}

/// Where the firmware workspace is.
pub fn firmware_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("firmware")
}

/// The `qemu` firmware ELF: `$VT_FIRMWARE_ELF` if set, else the release build in the firmware
/// workspace.
pub fn default_firmware_path() -> PathBuf {
    std::env::var_os("VT_FIRMWARE_ELF")
        .map(PathBuf::from)
        .unwrap_or_else(|| firmware_dir().join("target/thumbv7em-none-eabihf/release/vt-firmware-qemu"))
}

/// Builds the `qemu` firmware (release) in its own workspace and target directory; cargo's
/// own caching makes this cheap when nothing changed.
///
/// # Errors
/// cargo fails.
pub fn build_firmware() -> Result<PathBuf, PilError> {
    let dir = firmware_dir();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(&dir).args(["build", "--release", "--features", "qemu"]);
    // Do not inherit the outer build's settings (target dir, flags, target, profile); keep the
    // rest (CARGO_HOME, registries, proxies).
    for (k, _) in std::env::vars_os() {
        if let Some(k) = k.to_str() {
            let outer = ["CARGO_BUILD_", "CARGO_PROFILE_", "CARGO_TARGET_"].iter().any(|p| k.starts_with(p))
                || ["CARGO_ENCODED_RUSTFLAGS", "RUSTFLAGS", "RUSTDOCFLAGS", "CARGO_INCREMENTAL", "CARGO_MAKEFLAGS", "CARGO_PRIMARY_PACKAGE"].contains(&k);
            if outer {
                cmd.env_remove(k);
            }
        }
    }
    cmd.env("CARGO_TARGET_DIR", dir.join("target"));
    let status = cmd.status().map_err(|e| PilError(format!("cannot run cargo: {e}")))?;
    if !status.success() {
        return err(format!("firmware build failed ({status})"));
    }
    Ok(dir.join("target/thumbv7em-none-eabihf/release/vt-firmware-qemu"))
}

// ---------------------------------------------------------------------------------------------
// Configuration

/// A waypoint as sent in `MISSION_ITEM_INT`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireWaypoint {
    /// North, 1e-4 m.
    pub x: i32,
    /// East, 1e-4 m.
    pub y: i32,
    /// Left half-width, m.
    pub w_left_m: f32,
    /// Right half-width, m.
    pub w_right_m: f32,
}

/// Everything one UAV's companion is told before the mission.
#[derive(Debug, Clone, PartialEq)]
pub struct UavConfig {
    /// Its MAVLink system id.
    pub system_id: u8,
    /// Parameter values (every parameter of the table that the scenario determines).
    pub params: Vec<(Param, f32)>,
    /// The tube.
    pub waypoints: Vec<WireWaypoint>,
}

/// The team's configuration and take-off state for a scenario, computed as `sim::run` computes
/// its controllers (nominal case: no disturbances).
#[derive(Debug, Clone)]
pub struct TeamSetup {
    /// One per UAV.
    pub configs: Vec<UavConfig>,
    /// Take-off geometry.
    pub takeoff: Takeoff,
    /// Cable lengths the controllers use (`sim::run`'s take-off calibration), m.
    pub calibrated_len_m: Vec<f64>,
}

/// Configuration of every UAV of `ls` (`lockstep`: `VT_LOCKSTEP = 1`).
///
/// # Errors
/// A waypoint is not representable at 0.1 mm, or the scenario's velocity loop is invalid.
pub fn team_setup(ls: &LoadedScenario, lockstep: bool) -> Result<TeamSetup, PilError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    if n > MAX_UAVS {
        return err(format!("{n} UAVs > capacity {MAX_UAVS}"));
    }
    let to = sim::takeoff(s, &ls.tube, s.cables.f_max_n);
    // sim::run's take-off calibration without sensor noise: |p_i - p_l| - stretch.
    let calibrated_len_m: Vec<f64> = to.uav_pos_m.iter().map(|p| (p - to.load_pos_m).norm() - to.stretch_m).collect();
    let mut waypoints = Vec::new();
    for (k, w) in s.tube.waypoints.iter().enumerate() {
        let (east, north, wl, wr) = (w[0], w[1], w[2], w[3]);
        let q = |v: f64| (v * 1e4).round();
        let (x, y) = (q(north), q(east));
        // The firmware computes `x as f32 / 1e4`; it must equal the scenario's value as f32.
        if (x as f32 / 1e4) != north as f32 || (y as f32 / 1e4) != east as f32 || x.abs() > f64::from(i32::MAX) || y.abs() > f64::from(i32::MAX) {
            return err(format!("tube waypoint {k}: not representable in 0.1 mm units without changing its f32 value"));
        }
        waypoints.push(WireWaypoint { x: x as i32, y: y as i32, w_left_m: wl as f32, w_right_m: wr as f32 });
    }
    let vl = sim::velocity_loop(s).map_err(|e| PilError(e.to_string()))?;
    let p = vl.params();
    let tray = sim::tray(s);
    let c = &s.controller;
    let r = &s.rates;
    let configs = (0..n)
        .map(|i| {
            let cable_m = calibrated_len_m.get(i).copied().unwrap_or(0.0);
            let v = sim::vertical_params(s, cable_m, &to);
            let g = p.gains();
            let lim = p.integral_limit_mps2();
            let params = vec![
                (Param::NUavs, n as f32),
                (Param::Id, i as f32),
                (Param::SysidBase, f32::from(SYSID_BASE)),
                (Param::LoadComp, f32::from(LOAD_COMPONENT_ID)),
                (Param::Lockstep, if lockstep { 1.0 } else { 0.0 }),
                (Param::HlHz, r.high_level_hz as f32),
                (Param::LlHz, r.low_level_hz as f32),
                (Param::FsOwnTmo, OWN_TIMEOUT_S),
                (Param::FsLoadTmo, LOAD_TIMEOUT_S),
                (Param::FsNbrTmo, s.link.stale_timeout_s as f32),
                (Param::K1, c.k1 as f32),
                (Param::K2, c.k2 as f32),
                (Param::K3, c.k3 as f32),
                (Param::VMax, c.v_max_mps as f32),
                (Param::RSafe, c.r_safe_m as f32),
                (Param::RActive, c.r_active_m as f32),
                (Param::TrayH, tray.height_above_load_m),
                (Param::TrayHMin, tray.min_height_above_load_m),
                (Param::LoadZRef, v.load_altitude_ref_m),
                (Param::CableL, v.cable_length_m),
                (Param::CableStretch, v.cable_stretch_m),
                (Param::Kz, v.kz_per_s),
                (Param::VzMax, v.vz_max_mps),
                (Param::ZMin, v.min_height_m),
                (Param::TShare, v.tension_share_n),
                (Param::KShare, v.share_gain_mps_per_n),
                (Param::KLoadAlt, v.load_altitude_gain_per_s),
                (Param::DzMax, v.share_offset_max_m),
                (Param::KpX, g.kp.x),
                (Param::KpY, g.kp.y),
                (Param::KpZ, g.kp.z),
                (Param::KiX, g.ki.x),
                (Param::KiY, g.ki.y),
                (Param::KiZ, g.ki.z),
                (Param::KdX, g.kd.x),
                (Param::KdY, g.kd.y),
                (Param::KdZ, g.kd.z),
                (Param::ILimX, lim.x),
                (Param::ILimY, lim.y),
                (Param::ILimZ, lim.z),
                (Param::ThrustMin, p.limits().thrust_min_n()),
                (Param::ThrustMax, p.limits().thrust_max_n()),
                (Param::TiltMax, s.uavs.tilt_max_deg.to_radians() as f32),
                (Param::CfoMu, p.cfo().bandwidth_rad_s()),
                (Param::Mass, p.mass_kg()),
                (Param::Yaw, 0.0),
            ];
            UavConfig { system_id: SYSID_BASE + i as u8, params, waypoints: waypoints.clone() }
        })
        .collect();
    Ok(TeamSetup { configs, takeoff: to, calibrated_len_m })
}

fn gcs<D: MessageData>(enc: &mut Encoder, d: &D) -> Vec<u8> {
    enc.frame(GCS_SYSTEM_ID, GCS_COMPONENT_ID, d)
}

/// Reads messages until `want` returns `Some`, skipping the others.
///
/// # Errors
/// The port's errors, or more than `limit` other messages in between.
pub fn recv_until<T, P: Port + ?Sized>(port: &mut P, limit: usize, mut want: impl FnMut(&Rx) -> Option<T>) -> Result<T, PilError> {
    for _ in 0..limit {
        let rx = port.recv()?;
        if let Some(t) = want(&rx) {
            return Ok(t);
        }
    }
    err("expected reply not received")
}

/// Sets every parameter (each echoed bit for bit) and uploads the tube.
///
/// # Errors
/// A parameter is refused or echoed differently, or the tube is not accepted.
pub fn configure<P: Port + ?Sized>(port: &mut P, cfg: &UavConfig, enc: &mut Encoder) -> Result<(), PilError> {
    for &(p, value) in &cfg.params {
        let name = p.info().name;
        let msg = PARAM_SET_DATA {
            param_value: value,
            target_system: 0,
            target_component: COMPANION_COMPONENT_ID,
            param_id: name.into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        };
        port.send(&gcs(enc, &msg))?;
        let echoed = recv_until(port, 64, |rx| match rx {
            Rx::ParamValue(n, v) if n == name => Some(*v),
            _ => None,
        })?;
        if echoed.to_bits() != value.to_bits() {
            return err(format!("parameter {name}: sent {value}, companion holds {echoed}"));
        }
    }
    let count = MISSION_COUNT_DATA { count: cfg.waypoints.len() as u16, target_system: cfg.system_id, target_component: COMPANION_COMPONENT_ID };
    port.send(&gcs(enc, &count))?;
    loop {
        let rx = recv_until(port, 64, |rx| match rx {
            Rx::MissionRequest(_) | Rx::MissionAck(_) => Some(rx.clone()),
            _ => None,
        })?;
        match rx {
            Rx::MissionRequest(seq) => {
                let Some(w) = cfg.waypoints.get(usize::from(seq)) else {
                    return err(format!("companion asked for waypoint {seq}"));
                };
                let item = MISSION_ITEM_INT_DATA {
                    param1: w.w_left_m,
                    param2: w.w_right_m,
                    x: w.x,
                    y: w.y,
                    seq,
                    command: MavCmd::MAV_CMD_NAV_WAYPOINT,
                    target_system: cfg.system_id,
                    target_component: COMPANION_COMPONENT_ID,
                    frame: MavFrame::MAV_FRAME_LOCAL_NED,
                    autocontinue: 1,
                    ..MISSION_ITEM_INT_DATA::default()
                };
                port.send(&gcs(enc, &item))?;
            }
            Rx::MissionAck(0) => return Ok(()),
            Rx::MissionAck(code) => return err(format!("tube refused (MAV_MISSION_RESULT {code})")),
            _ => {}
        }
    }
}

/// `MAV_CMD_MISSION_START`; returns the `MAV_RESULT` value.
///
/// # Errors
/// No acknowledgement.
pub fn start_mission<P: Port + ?Sized>(port: &mut P, system_id: u8, enc: &mut Encoder) -> Result<u32, PilError> {
    let cmd = COMMAND_LONG_DATA {
        command: MavCmd::MAV_CMD_MISSION_START,
        target_system: system_id,
        target_component: COMPANION_COMPONENT_ID,
        ..COMMAND_LONG_DATA::default()
    };
    port.send(&gcs(enc, &cmd))?;
    recv_until(port, 64, |rx| match rx {
        Rx::CommandAck(c, r) if *c == MavCmd::MAV_CMD_MISSION_START as u32 => Some(*r),
        _ => None,
    })
}

/// The frames of one lockstep tick for one UAV: load and neighbours (when the high level is
/// due), then the own state that triggers the steps.
pub struct TickFrames<'a> {
    /// Simulated time, ms.
    pub time_ms: u32,
    /// Own system id.
    pub system_id: u8,
    /// Load state (position, velocity), ENU, when the high level is due.
    pub load: Option<(V3f, V3f)>,
    /// Neighbours' positions by UAV index (`None`: not delivered), when the high level is due.
    pub neighbours: &'a [Option<V3f>],
    /// Own position and velocity, ENU.
    pub own: (V3f, V3f),
    /// This UAV's index (skipped among the neighbours).
    pub id: usize,
}

impl TickFrames<'_> {
    /// Encodes the tick.
    pub fn encode(&self, autopilot: &mut Encoder, tracker: &mut Encoder, network: &mut Encoder) -> Vec<u8> {
        let mut out = Vec::with_capacity(64 * (2 + self.neighbours.len()));
        if let Some((p, v)) = &self.load {
            out.extend(tracker.frame(self.system_id, LOAD_COMPONENT_ID, &local_position(self.time_ms, p, v)));
            for (j, nb) in self.neighbours.iter().enumerate() {
                if let (Some(p), true) = (nb, j != self.id) {
                    let sys = SYSID_BASE + j as u8;
                    out.extend(network.frame(sys, AUTOPILOT_COMPONENT_ID, &local_position(self.time_ms, p, &V3f::zeros())));
                }
            }
        }
        out.extend(autopilot.frame(self.system_id, AUTOPILOT_COMPONENT_ID, &local_position(self.time_ms, &self.own.0, &self.own.1)));
        out
    }
}

/// Per-UAV encoders (autopilot, load tracker, network relay) and the ground station's.
#[derive(Debug, Default)]
pub struct Encoders {
    /// The UAV's autopilot.
    pub autopilot: Encoder,
    /// Its load tracker.
    pub tracker: Encoder,
    /// The team network relay.
    pub network: Encoder,
    /// The ground station.
    pub gcs: Encoder,
}

// ---------------------------------------------------------------------------------------------
// Flight

/// Plant thrust (N, ENU) from an attitude setpoint (FRD -> NED quaternion, collective of `t_max_n`).
pub fn thrust_from_setpoint(q: &[f32; 4], collective: f32, t_max_n: f64) -> V3 {
    let [w, x, y, z] = q.map(f64::from);
    let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
    let up_ned = q * V3::new(0.0, 0.0, -1.0); // thrust along -z of FRD
    let up_enu = V3::new(up_ned.y, up_ned.x, -up_ned.z);
    up_enu * (f64::from(collective) * t_max_n)
}

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
fn field_name(kind: CommandKind, k: usize) -> &'static str {
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
}

/// Limits of a flight.
#[derive(Debug, Clone, Copy, Default)]
pub struct FlightLimits {
    /// Stop after this much simulated time, s (default: the scenario's limits).
    pub duration_s: Option<f64>,
}

/// Flies the mission with one port per UAV (lockstep). Ports must be fresh companions.
///
/// # Errors
/// Configuration refused, a link failure, or a missing reply.
pub fn fly<P: Port>(ls: &LoadedScenario, ports: &mut [P], limits: FlightLimits, label: &str) -> Result<FlightOutput, PilError> {
    let s = &ls.scenario;
    let tube = &ls.tube;
    let n = s.cables.lengths_m.len();
    if ports.len() != n {
        return err(format!("{} ports for {n} UAVs", ports.len()));
    }
    let setup = team_setup(ls, true)?;
    let to = &setup.takeoff;
    let f_max = s.cables.f_max_n;
    let uav_params = vec![UavParams { mass_kg: s.uavs.mass_kg, thrust_max_n: s.uavs.thrust_max_n, thrust_lag_s: s.uavs.thrust_lag_s }; n];
    let cables: Vec<CableParams> = s
        .cables
        .lengths_m
        .iter()
        .map(|&l| CableParams { rest_length_m: l, stiffness_n_per_m: s.cables.stiffness_n_per_m, damping_ns_per_m: s.cables.damping_ns_per_m, f_max_n: f_max })
        .collect();
    let mut plant = Plant::new(uav_params, cables, LoadParams { mass_kg: s.load.mass_kg }, &to.uav_pos_m, to.load_pos_m, s.rates.plant_substeps as usize)
        .map_err(|e| PilError(format!("plant: {e}")))?;
    let hover = plant.hover_thrust();
    for (u, t) in plant.uavs.iter_mut().zip(hover.iter()) {
        u.thrust_n = *t;
    }
    let mut thrust_cmd: Vec<V3> = hover.clone();

    // Configure every companion and start the mission from the take-off state.
    let mut enc: Vec<Encoders> = (0..n).map(|_| Encoders::default()).collect();
    let v3f = |v: &V3| V3f::new(v.x as f32, v.y as f32, v.z as f32);
    let zero = V3f::zeros();
    let own0: Vec<V3f> = to.uav_pos_m.iter().map(v3f).collect();
    let load0 = (v3f(&to.load_pos_m), zero);
    let all0: Vec<Option<V3f>> = own0.iter().copied().map(Some).collect();
    for (i, (port, cfg)) in ports.iter_mut().zip(&setup.configs).enumerate() {
        let e = &mut enc[i];
        configure(port, cfg, &mut e.gcs).map_err(|x| PilError(format!("{label} UAV {i}: {x}")))?;
        let tick = TickFrames { time_ms: 0, system_id: cfg.system_id, load: Some(load0), neighbours: &all0, own: (own0[i], zero), id: i };
        port.send(&tick.encode(&mut e.autopilot, &mut e.tracker, &mut e.network))?;
        let r = start_mission(port, cfg.system_id, &mut e.gcs)?;
        if r != 0 {
            return err(format!("{label} UAV {i}: mission start refused (MAV_RESULT {r})"));
        }
    }

    let r = &s.rates;
    let dt = 1.0 / f64::from(r.plant_hz);
    let ll_every = u64::from(r.plant_hz / r.low_level_hz);
    let hl_every = u64::from(r.plant_hz / r.high_level_hz);
    let rec_every = u64::from(r.plant_hz / r.record_hz);
    let time_limit = limits.duration_s.map_or(s.mission.time_limit_s, |d| d.min(s.mission.time_limit_s));
    let max_steps = (time_limit * f64::from(r.plant_hz)).ceil() as u64;
    let hl_hz = f64::from(r.high_level_hz);
    let mut link: Link<V3f> =
        Link::new(n, (s.link.delay_s * hl_hz).round() as u64, s.link.drop_probability, (s.link.stale_timeout_s * hl_hz).round().max(1.0) as u64, s.seed);
    let mut metrics = sim::Metrics::new(n, f_max, s, tube.length_m());
    let no_thrust_loss = vec![false; n];
    let mut commands = Vec::new();
    let mut hl_cycles = vec![Vec::new(); n];
    let mut ll_cycles = vec![Vec::new(); n];
    let mut status = vec![[0u16; 5]; n];
    let mut custom_mode = vec![0u32; n];
    // The last low-level sample (what the high level reads, as in sim::run).
    let mut sample_pos: Vec<V3f> = own0.clone();
    let mut sample_load = load0;
    let mut view: Vec<Option<V3f>> = Vec::with_capacity(n);
    let mut uav_hints = vec![0usize; n];
    let mut load_hint = 0usize;
    let wall = Instant::now();
    let mut step: u64 = 0;
    let mut arrival_step: Option<u64> = None;
    while step < max_steps {
        let t = step as f64 * dt;
        let time_ms = (t * 1000.0).round() as u32;
        let hl_due = step.is_multiple_of(hl_every);
        if hl_due {
            link.exchange(step / hl_every, &sample_pos);
            metrics.geometry(t, &plant, tube, &mut uav_hints, &mut load_hint, &no_thrust_loss);
            if metrics.arrived && arrival_step.is_none() {
                arrival_step = Some(step);
            }
        }
        if step.is_multiple_of(ll_every) {
            // Send every UAV its tick first (the emulators compute in parallel), then collect.
            for (i, port) in ports.iter_mut().enumerate() {
                let u = &plant.uavs[i];
                let own = (v3f(&u.pos_m), v3f(&u.vel_mps));
                if hl_due {
                    link.view(i, step / hl_every, sample_pos[i], &mut view);
                }
                let tick = TickFrames {
                    time_ms,
                    system_id: setup.configs[i].system_id,
                    load: hl_due.then_some(sample_load),
                    neighbours: if hl_due { &view } else { &[] },
                    own,
                    id: i,
                };
                let e = &mut enc[i];
                port.send(&tick.encode(&mut e.autopilot, &mut e.tracker, &mut e.network))?;
            }
            for (i, port) in ports.iter_mut().enumerate() {
                let mut hl_values: Vec<f32> = Vec::new();
                let sp = loop {
                    match port.recv().map_err(|e| PilError(format!("{label} UAV {i} at t = {t:.3} s: {e}")))? {
                        Rx::Setpoint { time_ms: tm, q, thrust } if tm == time_ms => break (q, thrust),
                        Rx::VelocityTarget { v_ned, .. } => hl_values.extend_from_slice(&v_ned),
                        Rx::CableForce(f) => hl_values.extend_from_slice(&f),
                        Rx::Cycles([h, l, _]) => {
                            hl_cycles[i].push(h);
                            ll_cycles[i].push(l);
                        }
                        Rx::Status(c) => status[i] = c,
                        Rx::Heartbeat(m) => custom_mode[i] = m,
                        _ => {}
                    }
                };
                if hl_due {
                    if hl_values.len() != 6 {
                        return err(format!("{label} UAV {i} at t = {t:.3} s: incomplete high-level telemetry"));
                    }
                    commands.push(CommandRecord { step, uav: i, kind: CommandKind::Velocity, values: hl_values });
                }
                let (q, thrust) = sp;
                commands.push(CommandRecord { step, uav: i, kind: CommandKind::Attitude, values: vec![q[0], q[1], q[2], q[3], thrust] });
                thrust_cmd[i] = thrust_from_setpoint(&q, thrust, s.uavs.thrust_max_n);
                metrics.max_thrust_fraction = metrics.max_thrust_fraction.max(f64::from(thrust));
            }
            // This sample is what the next high-level step reads.
            sample_pos = plant.uavs.iter().map(|u| v3f(&u.pos_m)).collect();
            sample_load = (v3f(&plant.load.pos_m), v3f(&plant.load.vel_mps));
        }
        plant.step(&thrust_cmd, &[], V3::zeros(), dt);
        metrics.tensions(plant.tensions_n());
        if step.is_multiple_of(rec_every) {
            if !sim::plant_finite(&plant) {
                metrics.nonfinite = true;
                break;
            }
            metrics.tension_sample(plant.tensions_n());
        }
        step += 1;
        if let Some(a) = arrival_step {
            if (step - a) as f64 * dt >= s.mission.post_arrival_s {
                break;
            }
        }
    }
    let wall_s = wall.elapsed().as_secs_f64();
    let tray = sim::tray(s);
    let uav_f: Vec<V3f> = to.uav_pos_m.iter().map(v3f).collect();
    let formation = Formation::<MAX_UAVS>::from_takeoff(&uav_f, &v3f(&to.load_pos_m), &tray).map_err(|e| PilError(format!("formation: {e}")))?;
    let formation_error = sim::formation_error(&plant, &formation, &tray);
    let limited = limits.duration_s.is_some_and(|d| d < s.mission.time_limit_s);
    let summary = metrics.finish(
        s,
        sim::ControllerKind::Dissipative,
        s.seed,
        step as f64 * dt,
        wall_s,
        formation_error,
        to.capacity_margin,
        arrival_step.map(|a| a as f64 * dt),
        limited,
    );
    Ok(FlightOutput { summary, commands, hl_cycles, ll_cycles, status, custom_mode })
}

// ---------------------------------------------------------------------------------------------
// The PIL command

/// Options of `host-sim pil`.
#[derive(Debug, Clone)]
pub struct PilOptions {
    /// The `qemu` firmware ELF.
    pub firmware: PathBuf,
    /// The emulator.
    pub qemu: String,
    /// Output directory (also holds the sockets).
    pub out_dir: PathBuf,
    /// Shorten the flight (s).
    pub duration_s: Option<f64>,
}

/// The first command that differs between SIL and PIL.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    /// Plant step.
    pub step: u64,
    /// Simulated time, s.
    pub time_s: f64,
    /// UAV index.
    pub uav: usize,
    /// Field.
    pub field: String,
    /// SIL value.
    pub sil: f32,
    /// PIL value.
    pub pil: f32,
}

/// Cycle statistics of one companion (board cycles: SysTick ticks under QEMU).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CycleStats {
    /// UAV index.
    pub uav: usize,
    /// Samples.
    pub samples: usize,
    /// Mean high-level step.
    pub high_level_mean: f64,
    /// Worst high-level step.
    pub high_level_max: f64,
    /// Mean low-level step.
    pub low_level_mean: f64,
    /// Worst low-level step.
    pub low_level_max: f64,
}

/// `pil_report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct PilReport {
    /// Scenario name.
    pub scenario: String,
    /// Team size.
    pub n_uavs: usize,
    /// Commands compared (attitude setpoints + velocity commands, all UAVs).
    pub commands_compared: usize,
    /// Largest absolute difference over every compared value.
    pub max_abs_diff: f64,
    /// Every compared value identical bit for bit, and the same number of commands.
    pub bit_exact: bool,
    /// The first difference, if any.
    pub first_difference: Option<Difference>,
    /// The PIL run's summary.
    pub summary: Summary,
    /// The host twin's (SIL) summary.
    pub sil_summary: Summary,
    /// `sim::run` on the same scenario (thrust applied as a vector, not through the attitude
    /// setpoint: close to, not identical with, the two runs above).
    pub host_sim_summary: Option<Summary>,
    /// How the runs were synchronised.
    pub lockstep: String,
    /// Scenario features not modelled in PIL.
    pub not_modelled: Vec<String>,
    /// The firmware ELF.
    pub firmware: String,
    /// `qemu-system-arm --version`, first line.
    pub qemu: String,
    /// Error counters last reported by each firmware (`SYS_STATUS`: checksum+framing, unknown
    /// ids, bad values, overruns, discarded bytes).
    pub firmware_errors: Vec<[u16; 5]>,
    /// Loop timing reported by each firmware (SysTick ticks at 25 MHz; host speed dependent
    /// without `-icount`).
    pub cycles: Vec<CycleStats>,
    /// Exit codes of the emulators after the shutdown command.
    pub qemu_exit_codes: Vec<Option<i32>>,
    /// Decoded defmt log of UAV 0's firmware.
    pub defmt_log_uav0: Vec<String>,
    /// Wall-clock seconds: SIL flight, PIL flight.
    pub wall_time_s: [f64; 2],
}

/// Compares two command streams.
pub fn compare(sil: &[CommandRecord], pil: &[CommandRecord], dt_s: f64) -> (usize, f64, bool, Option<Difference>) {
    let mut max_abs = 0.0f64;
    let mut first = None;
    let mut exact = sil.len() == pil.len();
    for (a, b) in sil.iter().zip(pil.iter()) {
        if a.step != b.step || a.uav != b.uav || a.kind != b.kind || a.values.len() != b.values.len() {
            exact = false;
            if first.is_none() {
                first = Some(Difference { step: a.step, time_s: a.step as f64 * dt_s, uav: a.uav, field: "sequence".into(), sil: f32::NAN, pil: f32::NAN });
            }
            break;
        }
        for (k, (x, y)) in a.values.iter().zip(b.values.iter()).enumerate() {
            if x.to_bits() != y.to_bits() {
                exact = false;
                let d = f64::from(*x) - f64::from(*y);
                max_abs = max_abs.max(if d.is_nan() { f64::INFINITY } else { d.abs() });
                if first.is_none() {
                    first = Some(Difference { step: a.step, time_s: a.step as f64 * dt_s, uav: a.uav, field: field_name(a.kind, k).into(), sil: *x, pil: *y });
                }
            }
        }
    }
    (sil.len().min(pil.len()), max_abs, exact, first)
}

fn cycle_stats(out: &FlightOutput) -> Vec<CycleStats> {
    let stat = |v: &[f32]| {
        let m = v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64;
        let mx = v.iter().fold(0.0f64, |a, &x| a.max(f64::from(x)));
        (m, mx)
    };
    out.hl_cycles
        .iter()
        .zip(out.ll_cycles.iter())
        .enumerate()
        .map(|(uav, (h, l))| {
            // Skip the first sample: the first high-level step warms the tube lookup.
            let h = h.get(1..).unwrap_or(&[]);
            let l = l.get(1..).unwrap_or(&[]);
            let (hm, hx) = stat(h);
            let (lm, lx) = stat(l);
            CycleStats { uav, samples: h.len(), high_level_mean: hm, high_level_max: hx, low_level_mean: lm, low_level_max: lx }
        })
        .collect()
}

fn qemu_version(qemu: &str) -> String {
    Command::new(qemu)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.lines().next().map(str::to_string))
        .unwrap_or_default()
}

fn not_modelled(s: &Scenario) -> Vec<String> {
    let d = &s.disturbances;
    let mut v = Vec::new();
    let any = [d.position_noise_m, d.velocity_noise_mps, d.latency_s, d.link_jitter_s, d.gust_std_mps, d.cable_length_error, d.cable_stiffness_error, d.uav_mass_error, d.load_mass_error]
        .iter()
        .any(|&x| x != 0.0)
        || d.wind_mean_mps.iter().any(|&x| x != 0.0);
    if any && d.intensity != 0.0 {
        v.push("disturbances (noise, latency, wind, parameter errors) are not applied in PIL".into());
    }
    if !s.faults.is_empty() {
        v.push("faults are not applied in PIL".into());
    }
    v
}

/// Flies `ls` SIL (host twins) and PIL (one QEMU per UAV), compares the commands, and writes
/// `pil_report.json` and the PIL run's `summary.json` into `opts.out_dir`.
///
/// # Errors
/// Any flight failure, or the report cannot be written.
pub fn run(ls: &LoadedScenario, opts: &PilOptions) -> Result<PilReport, PilError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    let limits = FlightLimits { duration_s: opts.duration_s };
    let dt = 1.0 / f64::from(s.rates.plant_hz);

    let t0 = Instant::now();
    let mut sil_ports: Vec<SilPort> = (0..n).map(|_| SilPort::new()).collect();
    let sil = fly(ls, &mut sil_ports, limits, "SIL")?;
    let sil_wall = t0.elapsed().as_secs_f64();

    let t0 = Instant::now();
    let sock_dir = opts.out_dir.join("sockets");
    let mut qemus = Vec::with_capacity(n);
    for i in 0..n {
        let o = QemuOptions { qemu: opts.qemu.clone(), icount: false, socket_dir: sock_dir.clone(), name: format!("uav{i}") };
        qemus.push(QemuPort::spawn(&opts.firmware, &o)?);
    }
    let pil = match fly(ls, &mut qemus, limits, "PIL") {
        Ok(p) => p,
        Err(e) => {
            // Attach what the firmware logged: the first thing to read when a run fails.
            let mut msg = e.0;
            for (i, q) in qemus.iter().enumerate() {
                let lines = decode_defmt(&opts.firmware, &q.defmt_bytes()).unwrap_or_default();
                let tail = lines.len().saturating_sub(8);
                for l in lines.get(tail..).unwrap_or(&[]) {
                    msg.push_str(&format!("\n  UAV {i} firmware: {l}"));
                }
            }
            return err(msg);
        }
    };
    let pil_wall = t0.elapsed().as_secs_f64();
    // Shut the emulators down cleanly and collect their logs.
    let mut exit_codes = Vec::new();
    let mut defmt0 = Vec::new();
    for (i, q) in qemus.into_iter().enumerate() {
        let mut enc = Encoder::default();
        let (code, bytes) = q.shutdown(&mut enc, SYSID_BASE + i as u8)?;
        exit_codes.push(code);
        if i == 0 {
            defmt0 = decode_defmt(&opts.firmware, &bytes).unwrap_or_else(|e| vec![format!("<{e}>")]);
        }
    }
    let _ = std::fs::remove_dir(&sock_dir);

    let (commands_compared, max_abs_diff, bit_exact, first_difference) = compare(&sil.commands, &pil.commands, dt);
    let host_sim_summary = sim::run(ls, &sim::RunOptions { record: false, ..sim::RunOptions::default() }).ok().map(|o| o.summary);
    let report = PilReport {
        scenario: s.name.clone(),
        n_uavs: n,
        commands_compared,
        max_abs_diff,
        bit_exact,
        first_difference,
        summary: pil.summary.clone(),
        sil_summary: sil.summary.clone(),
        host_sim_summary,
        lockstep: "event-driven: VT_LOCKSTEP=1, each own LOCAL_POSITION_NED is one low-level period; the host waits for \
                   SET_ATTITUDE_TARGET before stepping the plant; simulated time travels in time_boot_ms"
            .into(),
        not_modelled: not_modelled(s),
        firmware: opts.firmware.display().to_string(),
        qemu: qemu_version(&opts.qemu),
        firmware_errors: pil.status.clone(),
        cycles: cycle_stats(&pil),
        qemu_exit_codes: exit_codes,
        defmt_log_uav0: defmt0,
        wall_time_s: [sil_wall, pil_wall],
    };
    write_report(&opts.out_dir, &report)?;
    Ok(report)
}

/// Writes `pil_report.json` and `summary.json` (the PIL run's) into `dir`.
///
/// # Errors
/// I/O.
pub fn write_report(dir: &Path, report: &PilReport) -> Result<(), PilError> {
    std::fs::create_dir_all(dir).map_err(|e| PilError(format!("{}: {e}", dir.display())))?;
    let w = |name: &str, text: String| std::fs::write(dir.join(name), text + "\n").map_err(|e| PilError(format!("{name}: {e}")));
    w("pil_report.json", serde_json::to_string_pretty(report).map_err(|e| PilError(e.to_string()))?)?;
    w("summary.json", serde_json::to_string_pretty(&report.summary).map_err(|e| PilError(e.to_string()))?)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Instruction counts (Cortex-M4 under QEMU)

/// Team sizes the instruction counts are measured for.
pub const BENCH_TEAM_SIZES: [usize; 3] = [3, 10, 30];

/// The scenario flown for a team of `n`: the experiment (3), the paper's mission (10), or the
/// paper's mission with its ten cables repeated (any other size up to the capacity).
///
/// # Errors
/// The scenario files cannot be read, or `n` exceeds the capacity.
pub fn bench_scenario(n: usize) -> Result<LoadedScenario, PilError> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios");
    let load = |f: &str| crate::scenario::load(Some(&dir.join(f))).map_err(|e| PilError(e.to_string()));
    match n {
        3 => load("experiment-3uav.toml"),
        10 => load("paper-10uav.toml"),
        _ if n == 0 || n > MAX_UAVS => err(format!("team of {n} outside 1..={MAX_UAVS}")),
        _ => {
            let mut ls = load("paper-10uav.toml")?;
            let base = ls.scenario.cables.lengths_m.clone();
            ls.scenario.cables.lengths_m = base.iter().copied().cycle().take(n).collect();
            ls.scenario.name = format!("paper-{n}uav (bench)");
            Ok(ls)
        }
    }
}

/// Instruction counts of one team size (UAV 0's firmware under `-icount shift=0`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepCounts {
    /// Team size.
    pub n_uavs: usize,
    /// Scenario flown.
    pub scenario: String,
    /// High-level steps measured.
    pub high_level_steps: usize,
    /// Mean instructions of a high-level step (tube + springs + vertical law).
    pub high_level_mean: f64,
    /// Worst high-level step.
    pub high_level_max: f64,
    /// Low-level steps measured (one per high-level step: the one before it).
    pub low_level_steps: usize,
    /// Mean instructions of a low-level step (velocity loop + CFO + attitude).
    pub low_level_mean: f64,
    /// Worst low-level step.
    pub low_level_max: f64,
    /// Stack high-water mark of the firmware at the end, bytes.
    pub stack_peak_bytes: Option<u64>,
    /// Instructions of the one-off tube build (`Tube::rebuild`, on the mission upload).
    pub tube_build_instructions: Option<f64>,
}

/// `pil-bench` output.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// Instructions per 25 MHz SysTick tick, measured by the firmware's calibration loop.
    pub instructions_per_tick: f64,
    /// The calibration as logged: (instructions, ticks).
    pub calibration: (u64, u64),
    /// Per team size.
    pub steps: Vec<StepCounts>,
    /// Simulated seconds flown per team size.
    pub duration_s: f64,
    /// The firmware ELF.
    pub firmware: String,
}

fn parse_after(line: &str, prefix: &str) -> Option<u64> {
    line.split(prefix).nth(1)?.split_whitespace().next()?.parse().ok()
}

/// Measures instructions per high-level and low-level step for each team size in `teams`
/// (`pil-bench` uses [`BENCH_TEAM_SIZES`]), flying `duration_s` each: UAV 0 runs in QEMU with `-icount shift=0` (one instruction per virtual ns, so one 25 MHz SysTick
/// tick is 40 instructions; the firmware's calibration loop checks that), the rest of the team
/// as host twins. The counts cover the control steps only (`Flight::high_level`,
/// `Flight::low_level`), not MAVLink decoding or encoding, and include the few SysTick
/// interrupts that fall inside a step.
///
/// # Errors
/// A flight fails, or the firmware's log lacks the calibration.
pub fn bench(firmware: &Path, qemu: &str, socket_dir: &Path, teams: &[usize], duration_s: f64) -> Result<BenchReport, PilError> {
    let mut steps = Vec::new();
    let mut calibration = None;
    for &n in teams {
        let ls = bench_scenario(n)?;
        let o = QemuOptions { qemu: qemu.into(), icount: true, socket_dir: socket_dir.into(), name: format!("bench{n}") };
        let q = QemuPort::spawn(firmware, &o)?;
        let mut ports: Vec<Box<dyn Port>> = vec![Box::new(q)];
        ports.extend((1..n).map(|_| Box::new(SilPort::new()) as Box<dyn Port>));
        let out = fly(&ls, &mut ports, FlightLimits { duration_s: Some(duration_s) }, "bench")?;
        let Some(first) = ports.into_iter().next() else { return err("no port") };
        // Shut UAV 0's emulator down through its link and read its log.
        let (code, bytes) = shutdown_boxed(first, &mut Encoder::default())?;
        if code != Some(0) {
            return err(format!("bench emulator exited with {code:?}"));
        }
        let log = decode_defmt(firmware, &bytes)?;
        let mut stack = None;
        let mut tube_ticks = None;
        for l in &log {
            if let Some(c) = parse_after(l, "built in ") {
                tube_ticks = Some(c);
            }
            if l.starts_with("calibration:") {
                if let (Some(i), Some(t)) = (parse_after(l, "calibration: "), parse_after(l, "instructions in ")) {
                    calibration = Some((i, t));
                }
            }
            if let Some(s) = parse_after(l, "stack high-water mark ") {
                stack = Some(s);
            }
        }
        let (i, t) = calibration.ok_or_else(|| PilError("no calibration in the firmware log".into()))?;
        if t == 0 {
            return err("calibration measured 0 ticks (is -icount active?)");
        }
        let k = i as f64 / t as f64;
        let stat = |v: &[f32]| {
            let v = v.get(1..).unwrap_or(&[]); // the first step warms the tube lookup up
            let mean = v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64;
            let max = v.iter().fold(0.0f64, |a, &x| a.max(f64::from(x)));
            (v.len(), mean * k, max * k)
        };
        let (hn, hm, hx) = stat(&out.hl_cycles[0]);
        let (ln, lm, lx) = stat(&out.ll_cycles[0]);
        steps.push(StepCounts {
            n_uavs: n,
            scenario: ls.scenario.name.clone(),
            high_level_steps: hn,
            high_level_mean: hm,
            high_level_max: hx,
            low_level_steps: ln,
            low_level_mean: lm,
            low_level_max: lx,
            stack_peak_bytes: stack,
            tube_build_instructions: tube_ticks.map(|c| c as f64 * k),
        });
    }
    let (i, t) = calibration.unwrap_or((0, 1));
    Ok(BenchReport {
        instructions_per_tick: i as f64 / t.max(1) as f64,
        calibration: (i, t),
        steps,
        duration_s,
        firmware: firmware.display().to_string(),
    })
}

impl BenchReport {
    /// The object `cargo xtask bench` reads from `firmware/bench.sh` (issue 5's hook).
    pub fn hook_json(&self) -> serde_json::Value {
        let per = |f: &dyn Fn(&StepCounts) -> f64| {
            serde_json::Value::Object(self.steps.iter().map(|s| (s.n_uavs.to_string(), serde_json::json!(f(s).round() as u64))).collect())
        };
        let ll = self.steps.iter().map(|s| s.low_level_mean).fold(0.0f64, f64::max);
        let stack = self.steps.iter().filter_map(|s| s.stack_peak_bytes).max();
        serde_json::json!({
            "mcu_instructions_per_uav_step": per(&|s| s.high_level_mean + s.low_level_mean),
            "mcu_instructions_high_level": per(&|s| s.high_level_mean),
            "mcu_instructions_low_level": ll.round() as u64,
            "firmware_stack_peak_bytes": { "qemu": stack },
            "instructions_per_tick": self.instructions_per_tick,
            "steps": self.steps,
        })
    }
}

/// Shuts down a boxed port that holds a [`QemuPort`] (sends the command, drains, waits).
fn shutdown_boxed(mut port: Box<dyn Port>, enc: &mut Encoder) -> Result<(Option<i32>, Vec<u8>), PilError> {
    let cmd = COMMAND_LONG_DATA {
        param1: 2.0,
        command: MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
        target_system: SYSID_BASE,
        target_component: COMPANION_COMPONENT_ID,
        ..COMMAND_LONG_DATA::default()
    };
    port.send(&enc.frame(GCS_SYSTEM_ID, GCS_COMPONENT_ID, &cmd))?;
    port.finish()
}

// ---------------------------------------------------------------------------------------------
// Command-line entry points (wired by main.rs)

/// `host-sim pil [SCENARIO] [--out DIR] [--firmware ELF] [--duration S]`: flies the scenario
/// (default: the 3-UAV experiment) SIL and PIL, writes `DIR/pil_report.json` and
/// `DIR/summary.json`, prints the comparison. Builds the firmware when no ELF is given and the
/// default one is missing. Exit 0 when bit-exact and the PIL mission succeeded, 1 otherwise,
/// 2 on bad input.
pub fn cli(scenario: Option<&Path>, out: &Path, firmware: Option<PathBuf>, duration_s: Option<f64>) -> std::process::ExitCode {
    use std::process::ExitCode;
    let default_scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let ls = match crate::scenario::load(Some(scenario.unwrap_or(&default_scenario))) {
        Ok(ls) => ls,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let qemu = "qemu-system-arm";
    if !qemu_available(qemu) {
        eprintln!("error: {qemu} not found (apt-get install -y qemu-system-arm)");
        return ExitCode::from(2);
    }
    // An explicit ELF (flag or $VT_FIRMWARE_ELF) is flown as given; otherwise the firmware is
    // (re)built, so a stale image is never flown by accident.
    let elf = match firmware.or_else(|| std::env::var_os("VT_FIRMWARE_ELF").map(PathBuf::from)) {
        Some(p) if p.is_file() => p,
        Some(p) => {
            eprintln!("error: firmware ELF {} does not exist", p.display());
            return ExitCode::from(2);
        }
        None => match build_firmware() {
            Ok(p) => p,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        },
    };
    eprintln!("flying {} SIL (host twins) and PIL ({} x QEMU, {}) ...", ls.source_name, ls.scenario.cables.lengths_m.len(), elf.display());
    let opts = PilOptions { firmware: elf, qemu: qemu.into(), out_dir: out.to_path_buf(), duration_s };
    match run(&ls, &opts) {
        Ok(r) => {
            println!("{}", r.summary.table());
            println!(
                "  commands compared {}  bit_exact {}  max |diff| {}  (wall SIL {:.1} s, PIL {:.1} s)",
                r.commands_compared, r.bit_exact, r.max_abs_diff, r.wall_time_s[0], r.wall_time_s[1]
            );
            if let Some(d) = &r.first_difference {
                println!("  first difference: {d:?}");
            }
            println!("  wrote {}", out.join("pil_report.json").display());
            if r.bit_exact && r.summary.success { ExitCode::SUCCESS } else { ExitCode::from(1) }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// `host-sim pil-bench [--out DIR]`: instruction counts per step (see [`bench`]); writes
/// `DIR/bench.json` and prints the hook object (`firmware/bench.sh`) on the last line.
pub fn cli_bench(out: &Path, firmware: Option<PathBuf>) -> std::process::ExitCode {
    use std::process::ExitCode;
    let elf = match firmware.map_or_else(build_firmware, Ok) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    match bench(&elf, "qemu-system-arm", &out.join("sockets"), &BENCH_TEAM_SIZES, 2.0) {
        Ok(r) => {
            let _ = std::fs::create_dir_all(out);
            let _ = std::fs::write(out.join("bench.json"), serde_json::to_string_pretty(&r).unwrap_or_default());
            println!("{}", r.hook_json());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
