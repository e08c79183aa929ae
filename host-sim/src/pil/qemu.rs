//! The firmware in QEMU as one UAV's [`Port`] ([`QemuPort`], over a Unix socket); building
//! and finding the firmware.

use mavlink::dialects::common::{
    MavCmd, COMMAND_LONG_DATA,
};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use super::ethernet::{self, Deframer};
use vt_companion::{Framer, COMPANION_COMPONENT_ID};
use vt_sim::lockstep::wire::decode_into;
use vt_sim::lockstep::{err, Encoder, PilError, Port, Rx, GCS_COMPONENT_ID, GCS_SYSTEM_ID, REPLY_TIMEOUT};

/// Environment variable: a file prefix; emulators started with `-icount` then write QEMU's
/// instruction trace to `PREFIX.<name>` (`scripts/mcu-profile.py` reads it).
pub const TRACE_ENV: &str = "VT_QEMU_TRACE";

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
    deframer: Deframer,
    pending: VecDeque<Rx>,
    defmt: Arc<Mutex<Vec<u8>>>,
    reader: Option<std::thread::JoinHandle<()>>,
    socket: PathBuf,
}

impl QemuPort {
    /// Starts QEMU on `elf` with the board's Ethernet controller on a fresh Unix socket
    /// (QEMU's `stream` netdev, [`ethernet`] framing).
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
        cmd.args(["-machine", "mps2-an386", "-cpu", "cortex-m4", "-display", "none", "-monitor", "none", "-nodefaults"])
            .args(["-netdev", &format!("stream,id=link,server=off,addr.type=unix,addr.path={}", socket.display()), "-net", "nic,netdev=link"])
            .args(["-semihosting-config", "enable=on,target=native"]);
        if o.icount {
            cmd.args(["-icount", "shift=0"]);
            // An instruction trace for scripts/mcu-profile.py (docs/benchmarks.md, "Profiling
            // the MCU code"): every executed block, hundreds of MB a second of flight.
            if let Some(prefix) = std::env::var_os(TRACE_ENV) {
                let mut log = prefix;
                log.push(format!(".{}", o.name));
                cmd.args(["-d", "in_asm,exec,nochain", "-D"]).arg(log);
            }
        }
        cmd.arg("-kernel").arg(elf).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
        let mut child = cmd.spawn().map_err(|e| PilError(format!("cannot start {}: {e}", o.qemu)))?;
        // Forward the emulator's messages.
        if let Some(err_pipe) = child.stderr.take() {
            std::thread::spawn(move || {
                use std::io::BufRead;
                for line in std::io::BufReader::new(err_pipe).lines().map_while(Result::ok) {
                    eprintln!("{line}");
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
                loop {
                    let n = match out.read(&mut buf) {
                        Ok(0) => break,
                        Ok(n) => n,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        Err(_) => break,
                    };
                    if let (Ok(mut v), Some(chunk)) = (sink.lock(), buf.get(..n)) {
                        v.extend_from_slice(chunk);
                    }
                }
            })
        });
        // The firmware's first frame says its receiver is on: frames sent before would be
        // dropped by the emulated controller. (Waited for with the log reader running, so a
        // firmware blocked on a full stdout cannot stall it.) Whatever came with it is kept.
        let mut deframer = Deframer::default();
        let mut early = Vec::new();
        let mut buf = [0u8; 256];
        while deframer.frames == 0 {
            match (&stream).read(&mut buf) {
                Ok(n) if n > 0 => deframer.push(buf.get(..n).unwrap_or(&[]), |p| early.extend_from_slice(p)),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                other => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return err(match other {
                        Ok(_) => "the emulator closed the link before it came up".to_string(),
                        Err(e) => format!("the firmware's link did not come up: {e}"),
                    });
                }
            }
        }
        let (mut framer, mut pending) = (Framer::new(), VecDeque::new());
        decode_into(&mut framer, &early, &mut pending);
        Ok(Self { child, stream, framer, deframer, pending, defmt, reader, socket })
    }

    /// Writes `records` to the emulator's network socket as they are: whole stream records
    /// ([`ethernet::encode`]'s format), which need not be the link's frames (tests of the
    /// firmware's receiver).
    ///
    /// # Errors
    /// The socket write fails.
    pub fn send_records(&mut self, records: &[u8]) -> Result<(), PilError> {
        self.stream.write_all(records).map_err(|e| PilError(format!("link write: {e}")))
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
        if bytes.is_empty() {
            return Ok(());
        }
        self.send_records(&ethernet::encode(bytes))
    }

    fn finish(self: Box<Self>) -> Result<(Option<i32>, Vec<u8>), PilError> {
        (*self).wait_exit()
    }

    fn recv(&mut self) -> Result<Rx, PilError> {
        let mut buf = [0u8; 4096];
        loop {
            if let Some(rx) = self.pending.pop_front() {
                return Ok(rx);
            }
            let n = match self.stream.read(&mut buf) {
                Ok(n) => n,
                // A signal (a debugger's stop and continue): read again.
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                    return err(format!("no reply from the emulator in {} s (link read: {e})", REPLY_TIMEOUT.as_secs()));
                }
                Err(e) => return err(format!("link read: {e}")),
            };
            if n == 0 {
                return err("link closed by the emulator");
            }
            let mut payload = Vec::new();
            self.deframer.push(buf.get(..n).unwrap_or(&[]), |p| payload.extend_from_slice(p));
            decode_into(&mut self.framer, &payload, &mut self.pending);
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
    build_firmware_bin("qemu", "vt-firmware-qemu")
}

/// The firmware `ls` needs: the `qemu` build, or for an unknown map (issue 28) the `qemu`
/// build with in-flight re-planning (`--features qemu,perception`, the board's full 4 MiB of
/// RAM: not a flight layout), built as [`build_firmware`] does.
///
/// # Errors
/// cargo fails.
pub fn build_firmware_for(ls: &crate::scenario::LoadedScenario) -> Result<PathBuf, PilError> {
    if crate::mission::replan::perception_config(&ls.scenario).is_some() {
        build_firmware_bin("qemu,perception", "vt-firmware-qemu-perception")
    } else {
        build_firmware()
    }
}

/// Builds binary `bin` of the firmware workspace with `features` (release, `--bin bin` only:
/// a bench build never re-links the flight image) and returns the ELF's path.
///
/// # Errors
/// cargo fails.
pub fn build_firmware_bin(features: &str, bin: &str) -> Result<PathBuf, PilError> {
    let dir = firmware_dir();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(&dir).args(["build", "--release", "--features", features, "--bin", bin]);
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
    Ok(dir.join("target/thumbv7em-none-eabihf/release").join(bin))
}
