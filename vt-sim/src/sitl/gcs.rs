//! The ground station (`host-sim gcs`): uploads a scenario's parameters and tube to every
//! companion of a team given as UDP endpoints, starts, holds, resumes and aborts the mission,
//! and shows each UAV's status. One UDP socket (bind it where the companions send:
//! `vt-companion --remote`), the replies told apart by their sender.

use crate::lockstep::{configure, recv_until, start_mission_with_reason, Encoder, PilError, Port, Rx, UavConfig};
use crate::lockstep::{GCS_COMPONENT_ID, GCS_SYSTEM_ID};
use mavlink::dialects::common::{MavCmd, COMMAND_LONG_DATA};
use std::collections::VecDeque;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};
use vt_companion::{Framer, Mode, COMPANION_COMPONENT_ID};

/// How long the ground station waits for one answer.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(10);

/// What the ground station last heard from one companion.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UavStatus {
    /// Anything heard at all.
    pub heard: bool,
    /// `HEARTBEAT.custom_mode` (mode, hold reasons `<< 8`, refusal code `<< 16`).
    pub custom_mode: u32,
    /// Own, load and oldest team data age, ms (-1: never received).
    pub ages_ms: [f32; 3],
    /// `|f_hat|`, the CFO's cable-force estimate, N (the tension the UAV feels).
    pub tension_n: Option<f32>,
    /// Own centre to tube boundary, m.
    pub clearance_m: Option<f32>,
    /// The last `STATUSTEXT`, verbatim.
    pub text: Option<String>,
    /// The last `COMMAND_ACK`: command and `MAV_RESULT`.
    pub ack: Option<(u32, u32)>,
}

/// The ground station's socket and one receive queue per companion.
pub struct Gcs {
    socket: UdpSocket,
    endpoints: Vec<SocketAddr>,
    framers: Vec<Framer>,
    queues: Vec<VecDeque<Rx>>,
    encoders: Vec<Encoder>,
    status: Vec<UavStatus>,
}

impl Gcs {
    /// A ground station on `bind` for the companions at `endpoints` (UAV `i` at `endpoints[i]`).
    ///
    /// # Errors
    /// The address cannot be bound.
    pub fn bind(bind: SocketAddr, endpoints: Vec<SocketAddr>) -> Result<Self, PilError> {
        let socket = UdpSocket::bind(bind).map_err(|e| PilError(format!("ground station udp {bind}: {e}")))?;
        let n = endpoints.len();
        Ok(Self {
            socket,
            endpoints,
            framers: (0..n).map(|_| Framer::new()).collect(),
            queues: vec![VecDeque::new(); n],
            encoders: (0..n).map(|_| Encoder::default()).collect(),
            status: vec![UavStatus::default(); n],
        })
    }

    /// Sets the team (UAV `i` at `endpoints[i]`; statuses and queues start over).
    pub fn set_endpoints(&mut self, endpoints: Vec<SocketAddr>) {
        let n = endpoints.len();
        self.endpoints = endpoints;
        self.framers = (0..n).map(|_| Framer::new()).collect();
        self.queues = vec![VecDeque::new(); n];
        self.encoders = (0..n).map(|_| Encoder::default()).collect();
        self.status = vec![UavStatus::default(); n];
    }

    /// The bound address (give it to the companions as `--remote`).
    ///
    /// # Errors
    /// The socket has none.
    pub fn local_addr(&self) -> Result<SocketAddr, PilError> {
        self.socket.local_addr().map_err(|e| PilError(e.to_string()))
    }

    /// Companions in the team.
    pub fn len(&self) -> usize {
        self.endpoints.len()
    }

    /// True for an empty team.
    pub fn is_empty(&self) -> bool {
        self.endpoints.is_empty()
    }

    /// Receives for at most `wait`: every datagram goes to its sender's queue and status.
    fn pump(&mut self, wait: Duration) -> Result<(), PilError> {
        self.socket.set_read_timeout(Some(wait.max(Duration::from_micros(1)))).map_err(|e| PilError(e.to_string()))?;
        let mut buf = [0u8; 4096];
        match self.socket.recv_from(&mut buf) {
            Ok((n, from)) => {
                let Some(i) = self.endpoints.iter().position(|e| *e == from) else {
                    return Ok(()); // not a team member
                };
                for &b in buf.get(..n).unwrap_or(&[]) {
                    self.framers[i].push(b);
                    while let Some(f) = self.framers[i].next_frame() {
                        if let Some(rx) = crate::lockstep::wire::decode(f.message_id, f.payload) {
                            note(&mut self.status[i], &rx);
                            // The queue feeds request/reply exchanges; the streams are status only.
                            if !matches!(rx, Rx::Setpoint { .. } | Rx::VelocityTarget { .. } | Rx::CableForce(_) | Rx::Cycles(_)) {
                                self.queues[i].push_back(rx);
                            }
                        }
                    }
                }
                Ok(())
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut | std::io::ErrorKind::ConnectionRefused) => Ok(()),
            Err(e) => Err(PilError(format!("ground station receive: {e}"))),
        }
    }

    /// Uploads every companion's parameters (each echo checked bit for bit) and the tube.
    ///
    /// # Errors
    /// A parameter refused, the tube refused, or a companion silent.
    pub fn upload(&mut self, configs: &[UavConfig]) -> Result<(), PilError> {
        if configs.len() != self.len() {
            return Err(PilError(format!("{} configurations for a team of {}", configs.len(), self.len())));
        }
        for (i, cfg) in configs.iter().enumerate() {
            let mut enc = std::mem::take(&mut self.encoders[i]);
            let r = configure(&mut self.port(i), cfg, &mut enc);
            self.encoders[i] = enc;
            r.map_err(|e| PilError(format!("UAV {i} ({}): {e}", self.endpoints[i])))?;
        }
        Ok(())
    }

    /// `MAV_CMD_MISSION_START` to every companion: each `MAV_RESULT` with the `STATUSTEXT`
    /// lines that came before it (a refusal's reason, verbatim).
    ///
    /// # Errors
    /// A companion did not answer.
    pub fn start(&mut self, system_ids: &[u8]) -> Result<Vec<(u32, Vec<String>)>, PilError> {
        let mut out = Vec::with_capacity(self.len());
        for i in 0..self.len() {
            let id = system_ids.get(i).copied().unwrap_or(0);
            let mut enc = std::mem::take(&mut self.encoders[i]);
            let r = start_mission_with_reason(&mut self.port(i), id, &mut enc);
            self.encoders[i] = enc;
            out.push(r.map_err(|e| PilError(format!("UAV {i} ({}): {e}", self.endpoints[i])))?);
        }
        Ok(out)
    }

    /// A command to every companion (`param1`), each `MAV_RESULT`.
    ///
    /// # Errors
    /// A companion did not answer.
    pub fn command(&mut self, command: GcsCommand) -> Result<Vec<u32>, PilError> {
        let (cmd, param1) = command.mavlink();
        let mut out = Vec::with_capacity(self.len());
        for i in 0..self.len() {
            let d = COMMAND_LONG_DATA { command: cmd, param1, target_system: 0, target_component: COMPANION_COMPONENT_ID, ..COMMAND_LONG_DATA::default() };
            let bytes = self.encoders[i].frame(GCS_SYSTEM_ID, GCS_COMPONENT_ID, &d);
            let mut port = self.port(i);
            port.send(&bytes)?;
            let r = recv_until(&mut port, 100_000, |rx| match rx {
                Rx::CommandAck(c, r) if *c == cmd as u32 => Some(*r),
                _ => None,
            })
            .map_err(|e| PilError(format!("UAV {i}: {e}")))?;
            out.push(r);
        }
        Ok(out)
    }

    /// Listens for `wait` and returns what each companion last said.
    ///
    /// # Errors
    /// The socket failed.
    pub fn poll_status(&mut self, wait: Duration) -> Result<&[UavStatus], PilError> {
        let t0 = Instant::now();
        while t0.elapsed() < wait {
            self.pump(wait.saturating_sub(t0.elapsed()).min(Duration::from_millis(50)))?;
        }
        for q in &mut self.queues {
            q.clear();
        }
        Ok(&self.status)
    }

    /// UAV `i`'s side of the socket as a [`Port`], with nothing old queued: an exchange reads
    /// only the replies that follow its request.
    fn port(&mut self, i: usize) -> GcsPort<'_> {
        while let Ok(true) = self.pump_once() {}
        for q in &mut self.queues {
            q.clear();
        }
        GcsPort { gcs: self, i }
    }

    /// One datagram if one is waiting (true), without blocking.
    fn pump_once(&mut self) -> Result<bool, PilError> {
        self.socket.set_nonblocking(true).map_err(|e| PilError(e.to_string()))?;
        let mut peek = [0u8; 1];
        let waiting = self.socket.peek_from(&mut peek).is_ok();
        self.socket.set_nonblocking(false).map_err(|e| PilError(e.to_string()))?;
        if waiting {
            self.pump(Duration::from_millis(1))?;
        }
        Ok(waiting)
    }
}

/// A ground-station command for the whole team.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GcsCommand {
    /// The operator's hold: `MAV_CMD_DO_PAUSE_CONTINUE`, `param1 = 0` (the team holds in the tube).
    Hold,
    /// Lift the hold: `MAV_CMD_DO_PAUSE_CONTINUE`, `param1 = 1` (the team resumes `FS_RESUME` later).
    Resume,
    /// Stop commanding: `MAV_CMD_COMPONENT_ARM_DISARM`, `param1 = 0` to the companion (it tells
    /// the team to hold, then stops; the autopilot's setpoint-loss action takes over,
    /// docs/deploy.md).
    Abort,
}

impl GcsCommand {
    fn mavlink(self) -> (MavCmd, f32) {
        match self {
            Self::Hold => (MavCmd::MAV_CMD_DO_PAUSE_CONTINUE, 0.0),
            Self::Resume => (MavCmd::MAV_CMD_DO_PAUSE_CONTINUE, 1.0),
            Self::Abort => (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 0.0),
        }
    }
}

/// One companion's side of the ground station's socket.
struct GcsPort<'a> {
    gcs: &'a mut Gcs,
    i: usize,
}

impl Port for GcsPort<'_> {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        let to = self.gcs.endpoints[self.i];
        self.gcs.socket.send_to(bytes, to).map(|_| ()).map_err(|e| PilError(format!("send to {to}: {e}")))
    }

    fn recv(&mut self) -> Result<Rx, PilError> {
        let t0 = Instant::now();
        loop {
            if let Some(rx) = self.gcs.queues[self.i].pop_front() {
                return Ok(rx);
            }
            if t0.elapsed() > REPLY_TIMEOUT {
                return Err(PilError(format!("no reply from {} within {} s", self.gcs.endpoints[self.i], REPLY_TIMEOUT.as_secs())));
            }
            self.gcs.pump(Duration::from_millis(50))?;
        }
    }
}

/// Updates a status from one message.
fn note(s: &mut UavStatus, rx: &Rx) {
    s.heard = true;
    match rx {
        Rx::Heartbeat(m) => s.custom_mode = *m,
        Rx::Ages(a) => s.ages_ms = *a,
        Rx::Clearance(c) => s.clearance_m = Some(*c),
        Rx::CableForce(f) => s.tension_n = Some((f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt()),
        Rx::StatusText(_, t) => s.text = Some(t.clone()),
        Rx::CommandAck(c, r) => s.ack = Some((*c, *r)),
        _ => {}
    }
}

/// The mode's name from `HEARTBEAT.custom_mode`.
pub fn mode_name(custom_mode: u32) -> &'static str {
    match custom_mode & 0xFF {
        m if m == Mode::Unconfigured as u32 => "unconfigured",
        m if m == Mode::Ready as u32 => "ready",
        m if m == Mode::Transport as u32 => "transport",
        m if m == Mode::Hold as u32 => "HOLD",
        m if m == Mode::TeamHold as u32 => "team hold",
        _ => "?",
    }
}

/// The hold reasons' names (`HoldReasons` bits in `custom_mode` bits 8..15).
pub fn reason_names(custom_mode: u32) -> String {
    const NAMES: [&str; 6] = ["own stale", "load stale", "neighbour stale", "invalid input", "non-finite", "operator"];
    let bits = (custom_mode >> 8) & 0xFF;
    let v: Vec<&str> = NAMES.iter().enumerate().filter(|(k, _)| bits & (1 << k) != 0).map(|(_, n)| *n).collect();
    if v.is_empty() { "-".into() } else { v.join(", ") }
}

/// The status table the ground station prints (one line per UAV).
pub fn status_table(status: &[UavStatus]) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let _ = writeln!(t, "{:>3}  {:<12} {:<22} {:>8} {:>8} {:>8} {:>9} {:>10}  last message", "UAV", "mode", "hold reasons", "own ms", "load ms", "team ms", "tension N", "clearance m");
    for (i, s) in status.iter().enumerate() {
        if !s.heard {
            let _ = writeln!(t, "{i:>3}  {:<12}", "silent");
            continue;
        }
        let age = |a: f32| if a < 0.0 { "never".to_string() } else { format!("{a:.0}") };
        let opt = |x: Option<f32>, d: usize| x.map_or("-".to_string(), |v| format!("{v:.d$}"));
        let _ = writeln!(
            t,
            "{i:>3}  {:<12} {:<22} {:>8} {:>8} {:>8} {:>9} {:>10}  {}",
            mode_name(s.custom_mode),
            reason_names(s.custom_mode),
            age(s.ages_ms[0]),
            age(s.ages_ms[1]),
            age(s.ages_ms[2]),
            opt(s.tension_n, 1),
            opt(s.clearance_m, 2),
            s.text.as_deref().unwrap_or("")
        );
    }
    t
}
