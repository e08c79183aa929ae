//! `vt-companion` as a process, over a real UDP socket and a real pseudo-terminal: parameters,
//! the tube upload, a mission start on the wall clock, the real-time own-data failsafe, bytes
//! from a fuzzer, and Ctrl-C (the team told to hold, then a clean exit).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use mavlink::dialects::common::{
    MavCmd, MavFrame, MavParamType, COMMAND_ACK_DATA, COMMAND_LONG_DATA, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA, MISSION_ACK_DATA,
    MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA, PARAM_VALUE_DATA,
    SET_ATTITUDE_TARGET_DATA,
};
use mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, MessageData};
use serialport::SerialPort;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::UdpSocket;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use vt_companion::{Framer, HoldReasons, Mode};

const GCS: (u8, u8) = (255, 190);

/// One test at a time: the real-time test measures a 500 Hz loop on the wall clock, and the
/// fuzz test floods a socket; on a 2-core machine they would measure each other.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn exclusive() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}
const AUTOPILOT: u8 = 1;
const LOAD: u8 = 100;

fn frame<D: MessageData>(sys: u8, comp: u8, d: &D) -> Vec<u8> {
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.serialize_message_data(MavHeader { system_id: u32::from(sys), component_id: comp, sequence: 0 }, d);
    raw.raw_bytes().to_vec()
}

/// What came back, decoded.
#[derive(Debug)]
enum Rx {
    Param(String, f32),
    MissionRequest(u16),
    MissionAck(u8),
    Ack(u32, u8),
    Heartbeat(u32),
    /// `SET_ATTITUDE_TARGET`, with its `time_boot_ms` (the companion's wall clock).
    Setpoint(u32),
    Other,
}

fn decode(id: u32, payload: &[u8]) -> Rx {
    let v2 = MavlinkVersion::V2;
    match id {
        PARAM_VALUE_DATA::ID => PARAM_VALUE_DATA::deser(v2, payload).map_or(Rx::Other, |d| Rx::Param(d.param_id.to_str().unwrap_or("").to_string(), d.param_value)),
        MISSION_REQUEST_INT_DATA::ID => MISSION_REQUEST_INT_DATA::deser(v2, payload).map_or(Rx::Other, |d| Rx::MissionRequest(d.seq)),
        MISSION_ACK_DATA::ID => MISSION_ACK_DATA::deser(v2, payload).map_or(Rx::Other, |d| Rx::MissionAck(d.mavtype as u8)),
        COMMAND_ACK_DATA::ID => COMMAND_ACK_DATA::deser(v2, payload).map_or(Rx::Other, |d| Rx::Ack(d.command as u32, d.result as u8)),
        HEARTBEAT_DATA::ID => HEARTBEAT_DATA::deser(v2, payload).map_or(Rx::Other, |d| Rx::Heartbeat(d.custom_mode)),
        SET_ATTITUDE_TARGET_DATA::ID => SET_ATTITUDE_TARGET_DATA::deser(v2, payload).map_or(Rx::Other, |d| Rx::Setpoint(d.time_boot_ms)),
        _ => Rx::Other,
    }
}

/// The test's end of a link.
trait End {
    fn send(&mut self, bytes: &[u8]);
    fn recv_bytes(&mut self, buf: &mut [u8]) -> usize;
}

struct UdpEnd {
    socket: UdpSocket,
    to: std::net::SocketAddr,
}

impl End for UdpEnd {
    fn send(&mut self, bytes: &[u8]) {
        self.socket.send_to(bytes, self.to).unwrap();
    }
    fn recv_bytes(&mut self, buf: &mut [u8]) -> usize {
        self.socket.recv(buf).unwrap_or(0)
    }
}

struct PtyEnd {
    master: serialport::TTYPort,
}

impl End for PtyEnd {
    fn send(&mut self, bytes: &[u8]) {
        self.master.write_all(bytes).unwrap();
    }
    fn recv_bytes(&mut self, buf: &mut [u8]) -> usize {
        self.master.read(buf).unwrap_or(0)
    }
}

/// Reads until `want` says yes, for at most `secs`.
fn until<T>(end: &mut dyn End, framer: &mut Framer, secs: f64, mut want: impl FnMut(&Rx) -> Option<T>) -> Option<T> {
    let t0 = Instant::now();
    let mut buf = [0u8; 2048];
    while t0.elapsed().as_secs_f64() < secs {
        let n = end.recv_bytes(&mut buf);
        for &b in &buf[..n] {
            framer.push(b);
            while let Some(f) = framer.next_frame() {
                if let Some(t) = want(&decode(f.message_id, f.payload)) {
                    return Some(t);
                }
            }
        }
    }
    None
}

fn set_param(end: &mut dyn End, framer: &mut Framer, name: &str, value: f32) -> f32 {
    let d = PARAM_SET_DATA { param_value: value, target_system: 0, target_component: 0, param_id: name.into(), param_type: MavParamType::MAV_PARAM_TYPE_REAL32 };
    end.send(&frame(GCS.0, GCS.1, &d));
    until(end, framer, 5.0, |rx| match rx {
        Rx::Param(n, v) if n == name => Some(*v),
        _ => None,
    })
    .unwrap_or_else(|| panic!("no echo of {name}"))
}

/// One `PARAM_REQUEST_READ`, and the answer if it comes within `secs`.
fn read_param_once(end: &mut dyn End, framer: &mut Framer, name: &str, secs: f64) -> Option<f32> {
    let d = PARAM_REQUEST_READ_DATA { param_index: -1, target_system: 0, target_component: 0, param_id: name.into() };
    end.send(&frame(GCS.0, GCS.1, &d));
    until(end, framer, secs, |rx| match rx {
        Rx::Param(n, v) if n == name => Some(*v),
        _ => None,
    })
}

/// A parameter read as a ground station does it: the request is repeated (every second, five
/// times, as QGroundControl retries) because a datagram may be lost on a flooded link.
fn read_param(end: &mut dyn End, framer: &mut Framer, name: &str) -> Option<f32> {
    (0..5).find_map(|_| read_param_once(end, framer, name, 1.0))
}

/// A companion process, killed if the test ends before it exits (a failed assertion must not
/// leave it running and holding the harness's output open).
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            self.0.kill().ok();
            self.0.wait().ok();
        }
    }
}

impl std::ops::Deref for Proc {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Proc {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

fn spawn(args: &[&str]) -> (Proc, BufReader<std::process::ChildStderr>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_vt-companion")).args(args).stderr(Stdio::piped()).spawn().expect("vt-companion starts");
    let err = BufReader::new(child.stderr.take().unwrap());
    (Proc(child), err)
}

fn interrupt(child: &mut Child) -> Option<i32> {
    let ok = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success();
    assert!(ok);
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(10) {
        if let Some(s) = child.try_wait().unwrap() {
            return s.code();
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().ok();
    panic!("vt-companion did not exit after SIGINT");
}

fn udp_companion() -> (Proc, UdpEnd) {
    let (child, mut err) = spawn(&["--udp", "127.0.0.1:0"]);
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    let addr = line.trim().rsplit(' ').next().unwrap().parse().unwrap_or_else(|_| panic!("address in {line:?}"));
    std::thread::spawn(move || for _ in err.lines() {});
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    (child, UdpEnd { socket, to: addr })
}

/// A straight tube along north, 3 UAVs on the experiment's defaults around a load at 3 m.
fn fly_until_setpoints(end: &mut dyn End, framer: &mut Framer) {
    // Time-outs long enough for a loaded machine: this test is about the link, not the clock.
    for (name, v) in [("FS_OWN_TMO", 0.5), ("FS_LOAD_TMO", 1.0), ("FS_NBR_TMO", 1.0), ("VT_CAL_N", 1.0)] {
        assert_eq!(set_param(end, framer, name, v), v);
    }
    let wps = [(0, 0), (200_000, 0), (400_000, 0)];
    end.send(&frame(GCS.0, GCS.1, &MISSION_COUNT_DATA { count: 3, target_system: 1, target_component: 191 }));
    loop {
        let rx = until(end, framer, 5.0, |rx| match rx {
            Rx::MissionRequest(seq) => Some(Ok(*seq)),
            Rx::MissionAck(r) => Some(Err(*r)),
            _ => None,
        });
        match rx.expect("upload answered") {
            Ok(seq) => {
                let (x, y) = wps[usize::from(seq)];
                let item = MISSION_ITEM_INT_DATA {
                    param1: 3.5,
                    param2: 3.5,
                    x,
                    y,
                    seq,
                    command: MavCmd::MAV_CMD_NAV_WAYPOINT,
                    target_system: 1,
                    target_component: 191,
                    frame: MavFrame::MAV_FRAME_LOCAL_NED,
                    autocontinue: 1,
                    ..Default::default()
                };
                end.send(&frame(GCS.0, GCS.1, &item));
            }
            Err(result) => {
                assert_eq!(result, 0, "tube accepted (MAV_MISSION_ACCEPTED)");
                break;
            }
        }
    }
    // Own, load and both neighbours (NED: x north, z down), then the start.
    let load = [5.0f32, 0.0, -3.0];
    let pos = |j: usize| {
        let a = j as f32 * std::f32::consts::TAU / 3.0;
        [load[0] + 1.5 * a.cos(), load[1] + 1.5 * a.sin(), load[2] - 2.6]
    };
    let state = |p: [f32; 3]| LOCAL_POSITION_NED_DATA { time_boot_ms: 0, x: p[0], y: p[1], z: p[2], vx: 0.0, vy: 0.0, vz: 0.0 };
    end.send(&frame(1, AUTOPILOT, &state(pos(0))));
    end.send(&frame(1, LOAD, &state(load)));
    end.send(&frame(2, AUTOPILOT, &state(pos(1))));
    end.send(&frame(3, AUTOPILOT, &state(pos(2))));
    end.send(&frame(GCS.0, GCS.1, &COMMAND_LONG_DATA { command: MavCmd::MAV_CMD_MISSION_START, target_system: 1, target_component: 191, ..Default::default() }));
    let ack = until(end, framer, 5.0, |rx| match rx {
        Rx::Ack(c, r) if *c == MavCmd::MAV_CMD_MISSION_START as u32 => Some(*r),
        _ => None,
    });
    assert_eq!(ack, Some(0), "mission start accepted");
}

/// On the wall clock (Tickers at 50 / 500 Hz): setpoints stream, the own-data time-out trips the
/// hold when the feeds stop, and Ctrl-C announces the operator's hold to the team, then exits 0.
#[test]
fn udp_mission_runs_in_real_time_holds_on_stale_data_and_ctrl_c_tells_the_team() {
    let _one = exclusive();
    let (mut child, mut end) = udp_companion();
    let mut framer = Framer::new();
    fly_until_setpoints(&mut end, &mut framer);
    // The loop's rate on the companion's own clock (the setpoints' time stamps), so that a
    // receiver descheduled for a moment does not count as a slow loop.
    let mut stamps = Vec::new();
    until(&mut end, &mut framer, 0.5, |rx| {
        if let Rx::Setpoint(t) = rx {
            stamps.push(*t);
        }
        None::<()>
    });
    let span_s = f64::from(stamps.last().unwrap_or(&0) - stamps.first().unwrap_or(&0)) / 1000.0;
    let rate = (stamps.len().max(1) - 1) as f64 / span_s.max(1e-3);
    assert!(stamps.len() > 20 && (450.0..550.0).contains(&rate), "SET_ATTITUDE_TARGET at {rate:.0} Hz over {span_s:.3} s, {} received (VT_LL_HZ 500)", stamps.len());
    // Nothing has arrived since the start: the own state went stale after FS_OWN_TMO.
    let hold = until(&mut end, &mut framer, 3.0, |rx| match rx {
        Rx::Heartbeat(m) if m & 0xFF == Mode::Hold as u32 => Some(*m),
        _ => None,
    })
    .expect("a HEARTBEAT in Hold");
    assert_ne!((hold >> 8) & u32::from(HoldReasons::OWN_STALE | HoldReasons::LOAD_STALE), 0, "stale data: {hold:#x}");
    // Ctrl-C: the operator's hold goes out, then the process ends cleanly.
    let code = interrupt(&mut child);
    let told = until(&mut end, &mut framer, 1.0, |rx| match rx {
        Rx::Heartbeat(m) if (m >> 8) & u32::from(HoldReasons::OPERATOR) != 0 => Some(*m),
        _ => None,
    });
    assert_eq!(code, Some(0));
    assert_eq!(told.map(|m| m & 0xFF), Some(Mode::Hold as u32), "the team was told to hold");
}

/// Random bytes, random frames with good checksums and valid messages with absurd values: no
/// panic, and the companion still answers afterwards.
#[test]
fn udp_link_survives_fuzzed_bytes() {
    let _one = exclusive();
    let (mut child, mut end) = udp_companion();
    let mut framer = Framer::new();
    assert_eq!(set_param(&mut end, &mut framer, "VT_K1", 0.7), 0.7);
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    for k in 0..3000 {
        let len = (next() % 300) as usize;
        let mut bytes: Vec<u8> = (0..len).map(|_| next() as u8).collect();
        match k % 3 {
            0 => {}
            // A valid frame with its payload mangled after the header (checksum then fails).
            1 => {
                let mut f = frame(1, AUTOPILOT, &LOCAL_POSITION_NED_DATA { x: f32::from_bits(next() as u32), ..Default::default() });
                let i = 10 + (next() as usize % (f.len() - 10));
                f[i] ^= 0x5A;
                bytes = f;
            }
            // A valid frame with non-finite or huge values.
            _ => {
                let v = [f32::NAN, f32::INFINITY, 1e30, -1e30][k % 4];
                bytes = frame(1, AUTOPILOT, &LOCAL_POSITION_NED_DATA { time_boot_ms: next() as u32, x: v, y: v, z: v, vx: v, vy: v, vz: v });
            }
        }
        end.send(&bytes);
    }
    assert_eq!(read_param(&mut end, &mut framer, "VT_K1"), Some(0.7), "alive and unchanged after the fuzz");
    assert!(child.try_wait().unwrap().is_none(), "still running");
    assert_eq!(interrupt(&mut child), Some(0));
}

/// One datagram ending in a truncated frame (a marker claiming a 255-byte payload), then a
/// request in the next datagram: over UDP every datagram carries whole frames (PX4,
/// mavlink-router), so the stub is dropped at the datagram's end and the request is answered at
/// once, not held back until enough later bytes complete the bogus frame.
#[test]
fn udp_truncated_frame_does_not_hold_back_the_next_datagram() {
    let _one = exclusive();
    let (mut child, mut end) = udp_companion();
    let mut framer = Framer::new();
    for stub in [vec![0xFD, 255, 0, 0, 0, 1, 1], vec![0xFD], vec![0xFD, 40, 1]] {
        end.send(&stub);
        assert_eq!(read_param_once(&mut end, &mut framer, "VT_K1", 2.0).map(|v| v > 0.0), Some(true), "answered after {stub:?}");
    }
    assert_eq!(interrupt(&mut child), Some(0));
}

/// The same companion on a serial line (a pseudo-terminal pair standing in for a UART):
/// parameters round-trip, and Ctrl-C exits cleanly.
#[test]
fn serial_link_round_trips_parameters() {
    let _one = exclusive();
    let (master, slave) = serialport::TTYPort::pair().expect("a pty pair");
    let path = slave.name().expect("pty name");
    let (mut child, err) = spawn(&["--serial", &path, "--baud", "115200", "--param", "VT_ID=2"]);
    std::thread::spawn(move || for _ in err.lines() {});
    let mut master = master;
    master.set_timeout(Duration::from_millis(50)).unwrap();
    let mut end = PtyEnd { master };
    let mut framer = Framer::new();
    assert_eq!(read_param(&mut end, &mut framer, "VT_ID"), Some(2.0), "the --param preset");
    assert_eq!(set_param(&mut end, &mut framer, "VT_K2", 0.25), 0.25);
    drop(slave);
    assert_eq!(interrupt(&mut child), Some(0));
}

#[test]
fn bad_arguments_exit_2_with_the_reason() {
    let _one = exclusive();
    for (args, needle) in [
        (vec!["--param", "VT_K1"], "NAME=VALUE"),
        (vec!["--udp", "127.0.0.1:0", "--param", "NOPE=1"], "no parameter called NOPE"),
        (vec!["--udp", "127.0.0.1:0", "--param", "VT_N_UAVS=2.5"], "refused"),
        (vec![], "give a link"),
        (vec!["--serial", "/dev/does-not-exist"], "/dev/does-not-exist"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_vt-companion")).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}
