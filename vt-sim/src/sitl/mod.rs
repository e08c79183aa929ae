//! host-sim as a MAVLink simulator (issue 26): every UAV of the world on its own UDP port, as
//! PX4 SITL instances are (`serve`), flown by `vt-companion` processes that a ground station
//! configured and started (`sitl`, [`gcs`]).
//!
//! # Lockstep (default)
//! The companions run with `VT_LOCKSTEP = 1`: each UAV's port sends, per low-level period, the
//! autopilot's `SYSTEM_TIME` when needed, the load tracker's and the team's states (high level
//! due) and the own `LOCAL_POSITION_NED` (lockstep::TickFrames, docs/protocol.md), and waits for the
//! `SET_ATTITUDE_TARGET` of that period before the plant steps: simulated time never depends on
//! the wall clock, so the commands equal the SIL twin's bit for bit ([`SitlReport`]).
//!
//! # The physics seam
//! The mission loop ([`crate::mission::fly`]) sees a [`crate::mission::Team`]; the plant sees
//! setpoints. What a companion is, in process or behind a socket, is the team's business: a
//! fourth plant or a fourth transport needs no change to `mission::fly` (docs/design.md, "One
//! flight logic").

pub mod gcs;
pub mod realtime;
pub mod rotorpy;
pub mod udp;

use crate::lockstep::{self, compare, CommandRecord, Difference, PilError, PortTeam, SilPort, UavConfig};
use crate::scenario::LoadedScenario;
use crate::sim::{self, RunOptions, RunOutput};
use crate::summary::Summary;
use gcs::Gcs;
use serde::Serialize;
use std::io::{BufRead, BufReader, Write};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use udp::UdpPort;

/// How long the simulator waits for a companion's reply in lockstep.
pub const LOCKSTEP_TIMEOUT: Duration = Duration::from_secs(30);

/// The `vt-companion` binary: `$VT_COMPANION_BIN`, else built with cargo in the profile and
/// target directory of this executable (`target/<profile>/`, or one level up from `deps/` for
/// tests: `cargo test --profile ci` gets a `ci` companion), else whatever lies beside it.
///
/// # Errors
/// Not found and the build failed.
pub fn companion_binary() -> Result<PathBuf, PilError> {
    if let Some(p) = std::env::var_os("VT_COMPANION_BIN").map(PathBuf::from) {
        return if p.is_file() { Ok(p) } else { Err(PilError(format!("VT_COMPANION_BIN={} does not exist", p.display()))) };
    }
    let exe = std::env::current_exe().map_err(|e| PilError(e.to_string()))?;
    let dirs: Vec<PathBuf> = exe.parent().into_iter().flat_map(|d| [d.to_path_buf(), d.join("..")]).collect();
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let (profile, profile_dir) = own_profile(&exe).unwrap_or_else(|| ("release".into(), workspace.join("target/release")));
    let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.args(["build", "--profile", &profile, "-q", "-p", "vt-companion-linux"]).current_dir(&workspace);
    if let Some(target_dir) = profile_dir.parent() {
        cmd.arg("--target-dir").arg(target_dir);
    }
    if !matches!(cmd.status(), Ok(s) if s.success()) {
        // No cargo (an installed host-sim): whatever is beside it.
        if let Some(p) = dirs.iter().map(|d| d.join("vt-companion")).find(|p| p.is_file()) {
            return Ok(p);
        }
        return Err(PilError("vt-companion not found and `cargo build -p vt-companion-linux` failed".into()));
    }
    let built = profile_dir.join("vt-companion");
    if built.is_file() {
        Ok(built)
    } else {
        Err(PilError(format!("{} missing after the build", built.display())))
    }
}

/// The cargo profile this executable was built in, and its directory: `exe` lies in
/// `<target>/<dir>/` or `<target>/<dir>/deps/`, with `<target>` holding cargo's `CACHEDIR.TAG`;
/// the `dev` profile's directory is `debug`. `None` outside a host build's target directory.
fn own_profile(exe: &Path) -> Option<(String, PathBuf)> {
    let mut dir = exe.parent()?;
    if dir.file_name()? == "deps" {
        dir = dir.parent()?;
    }
    if !dir.parent()?.join("CACHEDIR.TAG").is_file() {
        return None;
    }
    let name = dir.file_name()?.to_str()?;
    let profile = if name == "debug" { "dev" } else { name };
    Some((profile.to_string(), dir.to_path_buf()))
}

/// A `vt-companion` process.
pub struct CompanionProcess {
    child: Child,
    /// Where it listens.
    pub addr: SocketAddr,
    log: Option<std::thread::JoinHandle<Vec<String>>>,
}

impl CompanionProcess {
    /// Starts `bin` on a free loopback port, sending to every address of `remotes`.
    ///
    /// # Errors
    /// It does not start or does not say where it listens.
    pub fn spawn(bin: &Path, remotes: &[SocketAddr]) -> Result<Self, PilError> {
        let mut cmd = Command::new(bin);
        cmd.args(["--udp", "127.0.0.1:0"]);
        for r in remotes {
            cmd.args(["--remote", &r.to_string()]);
        }
        let mut child = cmd.stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().map_err(|e| PilError(format!("{}: {e}", bin.display())))?;
        let Some(stderr) = child.stderr.take() else {
            return Err(PilError("vt-companion: no stderr".into()));
        };
        let mut lines = BufReader::new(stderr).lines();
        let first = lines.next().and_then(Result::ok).unwrap_or_default();
        let addr = first.rsplit(' ').next().and_then(|a| a.parse().ok());
        let Some(addr) = addr else {
            let _ = child.kill();
            return Err(PilError(format!("vt-companion did not say where it listens: {first:?}")));
        };
        let log = std::thread::spawn(move || lines.map_while(Result::ok).collect());
        Ok(Self { child, addr, log: Some(log) })
    }

    /// Asks it to stop (SIGINT, as Ctrl-C) and waits: its exit code and what it printed.
    pub fn stop(mut self) -> (Option<i32>, Vec<String>) {
        let _ = Command::new("kill").args(["-INT", &self.child.id().to_string()]).status();
        let t0 = Instant::now();
        let code = loop {
            match self.child.try_wait() {
                Ok(Some(s)) => break s.code(),
                Ok(None) if t0.elapsed() < Duration::from_secs(5) => std::thread::sleep(Duration::from_millis(10)),
                _ => {
                    let _ = self.child.kill();
                    break None;
                }
            }
        };
        let log = self.log.take().and_then(|h| h.join().ok()).unwrap_or_default();
        (code, log)
    }
}

impl Drop for CompanionProcess {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// What `host-sim sitl` measured (`sitl_report.json`).
#[derive(Debug, Clone, Serialize)]
pub struct SitlReport {
    /// Scenario name.
    pub scenario: String,
    /// UAVs (one `vt-companion` process each).
    pub n_uavs: usize,
    /// `lockstep` or `realtime`.
    pub mode: String,
    /// Commands compared with the SIL twin (lockstep; 0 in real time).
    pub commands_compared: usize,
    /// Every compared command equal bit for bit (`None` in real time: two clocks).
    pub bit_exact: Option<bool>,
    /// Largest difference, if any.
    pub max_abs_diff: f64,
    /// The first difference.
    pub first_difference: Option<Difference>,
    /// The SITL flight's metrics.
    pub summary: Summary,
    /// Wall time of the SITL flight and of the SIL twin's, s.
    pub wall_time_s: [f64; 2],
    /// SITL wall time over SIL's (`bench.json` `sitl_lockstep_overhead`).
    pub lockstep_overhead: f64,
    /// Each companion's exit code after Ctrl-C (0: it told the team to hold and exited).
    pub companion_exit_codes: Vec<Option<i32>>,
}

/// The processes and sockets of one SITL flight, the companions configured by the ground
/// station: the simulator's UAV ports and the ground station's socket first (the companions
/// send to both, as a MAVLink router would fan out), then one `vt-companion` per UAV, then the
/// upload.
struct Launch {
    ports: Vec<UdpPort>,
    gcs: Gcs,
    procs: Vec<CompanionProcess>,
    configs: Vec<UavConfig>,
}

impl Launch {
    fn new(ls: &LoadedScenario, opts: &RunOptions, bin: &Path, lockstep: bool) -> Result<Self, PilError> {
        let s = &ls.scenario;
        let n = s.cables.lengths_m.len();
        let loopback: SocketAddr = ([127, 0, 0, 1], 0).into();
        let mut ports: Vec<UdpPort> = (0..n).map(|_| UdpPort::bind(loopback, None, LOCKSTEP_TIMEOUT)).collect::<Result<_, _>>()?;
        let mut gcs = Gcs::bind(loopback, Vec::new())?;
        let gcs_addr = gcs.local_addr()?;
        let mut procs = Vec::with_capacity(n);
        for port in &ports {
            procs.push(CompanionProcess::spawn(bin, &[port.local_addr()?, gcs_addr])?);
        }
        for (port, p) in ports.iter_mut().zip(&procs) {
            port.set_peer(p.addr);
        }
        gcs.set_endpoints(procs.iter().map(|p| p.addr).collect());
        // The ground station uploads the scenario's parameters and the tube.
        let rated = opts.f_max_n.unwrap_or(s.cables.rated_n);
        let setup = lockstep::team_setup_for(ls, opts.controller, sim::takeoff(s, &ls.tube, rated), rated, lockstep)?;
        gcs.upload(&setup.configs)?;
        Ok(Self { ports, gcs, procs, configs: setup.configs })
    }

    /// The team over the simulator's ports, started by the ground station after the pre-flight.
    fn team<'a>(&'a mut self, opts: &RunOptions) -> PortTeam<'a, UdpPort> {
        let ids: Vec<u8> = self.configs.iter().map(|c| c.system_id).collect();
        let gcs = &mut self.gcs;
        PortTeam::new(&mut self.ports, "SITL").with_controller(opts.controller).configured(self.configs.clone()).started_by(move || {
            let results = gcs.start(&ids).map_err(|e| e.0)?;
            match results.iter().enumerate().find(|(_, (r, _))| *r != 0) {
                Some((i, (r, texts))) => Err(format!("UAV {i} refused the start (MAV_RESULT {r}): {}", texts.join("; "))),
                None => Ok(()),
            }
        })
    }

    /// Ctrl-C to every companion: their exit codes.
    fn stop(self) -> Vec<Option<i32>> {
        self.procs.into_iter().map(|p| p.stop().0).collect()
    }
}

/// Flies `ls` with one `vt-companion` process per UAV behind `host-sim`'s UDP ports, in
/// lockstep, configured and started by the ground station; flies the SIL twin too and compares
/// every command.
///
/// # Errors
/// A process or socket failed, a companion refused, or a reply was missing.
pub fn sitl_lockstep(ls: &LoadedScenario, opts: &RunOptions, bin: &Path) -> Result<(RunOutput, SitlReport, Vec<CommandRecord>), PilError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    let mut launch = Launch::new(ls, opts, bin, true)?;
    let wall = Instant::now();
    let flown = lockstep::fly_team(ls, launch.team(opts), opts)?;
    let sitl_wall = wall.elapsed().as_secs_f64();
    let codes = launch.stop();
    // The SIL twin: the same companions in process, the same bytes.
    let wall = Instant::now();
    let mut twins: Vec<SilPort> = (0..n).map(|_| SilPort::new()).collect();
    let twin = lockstep::fly(ls, &mut twins, opts, "twin")?;
    let sil_wall = wall.elapsed().as_secs_f64();
    let dt = 1.0 / f64::from(s.rates.plant_hz);
    let (compared, max_abs, exact, first) = compare(&twin.commands, &flown.commands, dt);
    let report = SitlReport {
        scenario: s.name.clone(),
        n_uavs: n,
        mode: "lockstep".into(),
        commands_compared: compared,
        bit_exact: Some(exact),
        max_abs_diff: max_abs,
        first_difference: first,
        summary: flown.summary.clone(),
        wall_time_s: [sitl_wall, sil_wall],
        lockstep_overhead: sitl_wall / sil_wall.max(1e-9),
        companion_exit_codes: codes,
    };
    let out = RunOutput { summary: flown.summary, record: flown.record, scene: sim::scene(ls) };
    Ok((out, report, flown.commands))
}

/// Flies `ls` with one `vt-companion` process per UAV on the wall clock (`VT_LOCKSTEP = 0`:
/// the companions' own Tickers), configured and started by the ground station.
///
/// # Errors
/// A process or socket failed, a companion refused, or the start timed out.
pub fn sitl_realtime(ls: &LoadedScenario, opts: &RunOptions, bin: &Path) -> Result<(RunOutput, SitlReport), PilError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    let mut launch = Launch::new(ls, opts, bin, false)?;
    let wall = Instant::now();
    let mut team = realtime::RealtimeTeam::new(launch.team(opts), n);
    let flown = crate::mission::fly(ls, opts, &mut team).map_err(|e| PilError(e.0))?;
    let wall_s = wall.elapsed().as_secs_f64();
    eprintln!(
        "real time: worst lag of the simulator behind the wall clock {:.1} ms; {} UAV-periods without a new setpoint",
        1e3 * team.worst_lag_s,
        team.stale_periods
    );
    drop(team);
    let codes = launch.stop();
    let report = SitlReport {
        scenario: s.name.clone(),
        n_uavs: n,
        mode: "realtime".into(),
        commands_compared: 0,
        bit_exact: None,
        max_abs_diff: 0.0,
        first_difference: None,
        summary: flown.summary.clone(),
        wall_time_s: [wall_s, 0.0],
        lockstep_overhead: 0.0,
        companion_exit_codes: codes,
    };
    Ok((RunOutput { summary: flown.summary, record: flown.record, scene: sim::scene(ls) }, report))
}

/// `sitl_report.json` into `dir`.
///
/// # Errors
/// The file cannot be written.
pub fn write_report(dir: &Path, r: &SitlReport) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join("sitl_report.json");
    let text = serde_json::to_string_pretty(r).map_err(|e| e.to_string())?;
    std::fs::File::create(&path).and_then(|mut f| f.write_all(text.as_bytes())).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::own_profile;

    #[test]
    fn the_companion_is_built_in_the_asking_executables_profile() {
        let target = std::env::temp_dir().join(format!("vt-own-profile-{}", std::process::id()));
        for d in ["ci/deps", "debug/deps", "release"] {
            std::fs::create_dir_all(target.join(d)).unwrap();
        }
        // Not a cargo target directory yet (no CACHEDIR.TAG): nothing is assumed.
        assert_eq!(own_profile(&target.join("ci/deps/sitl-0123")), None);
        std::fs::write(target.join("CACHEDIR.TAG"), "Signature: 8a477f597d28d172789f06886806bc55").unwrap();
        // A test binary in deps/, a binary beside its profile's artefacts; `dev` lives in `debug`.
        assert_eq!(own_profile(&target.join("ci/deps/sitl-0123")), Some(("ci".into(), target.join("ci"))));
        assert_eq!(own_profile(&target.join("debug/deps/sitl-0123")), Some(("dev".into(), target.join("debug"))));
        assert_eq!(own_profile(&target.join("release/host-sim")), Some(("release".into(), target.join("release"))));
        std::fs::remove_dir_all(&target).unwrap();
    }
}
