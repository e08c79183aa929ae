//! Command-line entry points of `host-sim sitl`, `host-sim serve` and `host-sim gcs` (wired by
//! main.rs). Exit codes: 0 success, 1 mission failed or a process/link failure, 2 bad input.

use super::gcs::{status_table, Gcs, GcsCommand};
use super::udp::UdpPort;
use super::{companion_binary, sitl_lockstep, sitl_realtime, write_report};
use crate::pil::{self, PilError, PortTeam};
use crate::scenario::{self, LoadedScenario};
use crate::sim::{self, RunOptions, RunOutput};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

fn load(path: Option<&Path>) -> Result<LoadedScenario, ExitCode> {
    scenario::load(path).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(2)
    })
}

fn write_outputs(out: &Path, run: &RunOutput) -> Result<(), ExitCode> {
    crate::report::write_run_listed(out, run).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(1)
    })
}

/// Whose physics a SITL flight flies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SitlPlant {
    /// host-sim's own plant behind its UDP ports.
    Host,
    /// RotorPy (`vt-sim/rotorpy/vt_rotorpy.py`), scored by host-sim.
    RotorPy,
}

/// `host-sim sitl [SCENARIO] [--out DIR] [--companion BIN] [--plant host|rotorpy]`: the
/// scenario flown by one `vt-companion` process per UAV over UDP, uploaded and started by the
/// ground station, in lockstep; on host-sim's plant the SIL twin is flown beside it and every
/// command compared (`sitl_report.json`).
pub fn sitl(scenario: Option<&Path>, out: &Path, companion: Option<PathBuf>, realtime: bool, plant: SitlPlant, opts: &RunOptions) -> ExitCode {
    let ls = match load(scenario) {
        Ok(ls) => ls,
        Err(c) => return c,
    };
    if plant == SitlPlant::RotorPy {
        if realtime {
            eprintln!("error: --plant rotorpy flies in lockstep only (RotorPy runs slower than real time)");
            return ExitCode::from(2);
        }
        if let Some(why) = super::rotorpy::unsupported(&ls) {
            eprintln!("error: {why}");
            return ExitCode::from(2);
        }
    }
    let bin = match companion.map_or_else(companion_binary, Ok) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let mode = match (plant, realtime) {
        (SitlPlant::RotorPy, _) => "lockstep on RotorPy",
        (SitlPlant::Host, true) => "real time",
        (SitlPlant::Host, false) => "lockstep",
    };
    eprintln!("flying {} with {} vt-companion processes ({}) in {mode} ...", ls.source_name, ls.scenario.cables.lengths_m.len(), bin.display());
    let flown = match (plant, realtime) {
        (SitlPlant::RotorPy, _) => super::rotorpy::sitl_rotorpy(&ls, opts, &bin, out),
        (SitlPlant::Host, true) => sitl_realtime(&ls, opts, &bin),
        (SitlPlant::Host, false) => sitl_lockstep(&ls, opts, &bin).map(|(r, rep, _)| (r, rep)),
    };
    let (run, report) = match flown {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    println!("{}", run.summary.table());
    if let Some(exact) = report.bit_exact {
        println!(
            "  commands compared {}  bit_exact {exact}  max |diff| {}  (wall SITL {:.2} s, SIL twin {:.2} s: overhead {:.1}x)",
            report.commands_compared, report.max_abs_diff, report.wall_time_s[0], report.wall_time_s[1], report.lockstep_overhead
        );
    }
    if let Err(c) = write_outputs(out, &run) {
        return c;
    }
    match write_report(out, &report) {
        Ok(p) => println!("  wrote {}", p.display()),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    }
    if report.bit_exact != Some(false) && run.summary.success && report.companion_exit_codes.iter().all(|c| *c == Some(0)) {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// `host-sim serve SCENARIO [--port BASE] [--out DIR]`: every UAV of the world on UDP port
/// `BASE + i` (as PX4 SITL instances), in lockstep. Companions connect by sending to their port
/// (their heartbeat); the simulator waits until every one is configured (`Ready`, from a ground
/// station), flies the pre-flight, waits for the ground station's `MISSION_START`, then flies and
/// writes the usual outputs.
pub fn serve(scenario: Option<&Path>, base_port: u16, realtime: bool, out: &Path, opts: &RunOptions) -> ExitCode {
    let ls = match load(scenario) {
        Ok(ls) => ls,
        Err(c) => return c,
    };
    let n = ls.scenario.cables.lengths_m.len();
    // Waiting for a person: long time-outs.
    let patience = Duration::from_secs(600);
    let mut ports = Vec::with_capacity(n);
    for i in 0..n {
        let addr: SocketAddr = ([127, 0, 0, 1], base_port.saturating_add(i as u16)).into();
        match UdpPort::bind(addr, None, patience) {
            Ok(p) => ports.push(p),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        }
    }
    for (i, p) in ports.iter().enumerate() {
        eprintln!("UAV {i}: udp {}  (vt-companion --udp 127.0.0.1:0 --remote {} --remote GCS)", p.local_addr().map_or("?".into(), |a| a.to_string()), p.local_addr().map_or("?".into(), |a| a.to_string()));
    }
    eprintln!("waiting for every companion to be configured (mode Ready) by a ground station (host-sim gcs ... upload) ...");
    let t0 = Instant::now();
    let mut ready = vec![false; n];
    while !ready.iter().all(|r| *r) {
        if t0.elapsed() > patience {
            eprintln!("error: companions {:?} not ready after {} s", ready.iter().enumerate().filter(|(_, r)| !**r).map(|(i, _)| i).collect::<Vec<_>>(), patience.as_secs());
            return ExitCode::from(1);
        }
        for (p, r) in ports.iter_mut().zip(ready.iter_mut()) {
            if let Ok(Some(pil::Rx::Heartbeat(m))) = p.poll(Duration::from_millis(5)) {
                *r = m & 0xFF == vt_companion::Mode::Ready as u32;
            }
        }
    }
    let rated = opts.f_max_n.unwrap_or(ls.scenario.cables.rated_n);
    let setup = match pil::team_setup_for(&ls, opts.controller, sim::takeoff(&ls.scenario, &ls.tube, rated), rated, !realtime) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let team = PortTeam::new(&mut ports, "serve").with_controller(opts.controller).configured(setup.configs).started_by(|| {
        eprintln!("pre-flight flown: waiting for MAV_CMD_MISSION_START from the ground station (host-sim gcs ... start) ...");
        Ok(())
    });
    let flown = if realtime {
        let mut rt = super::realtime::RealtimeTeam::new(team, n).with_start_timeout(patience);
        crate::mission::fly(&ls, opts, &mut rt).map(|f| (f.summary, f.record)).map_err(|e| PilError(e.0))
    } else {
        pil::fly_team(&ls, team, opts).map(|f| (f.summary, f.record))
    };
    let (summary, record) = match flown {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let run = RunOutput { summary, record, scene: sim::scene(&ls) };
    println!("{}", run.summary.table());
    if let Err(c) = write_outputs(out, &run) {
        return c;
    }
    if run.summary.success { ExitCode::SUCCESS } else { ExitCode::from(1) }
}

/// What `host-sim gcs` does.
#[derive(Debug, Clone)]
pub enum GcsAction {
    /// Upload a scenario's parameters and tube (`true`: for a flight on the wall clock,
    /// `VT_LOCKSTEP = 0`; else lockstep with a simulator).
    Upload(PathBuf, bool),
    /// `MAV_CMD_MISSION_START`.
    Start,
    /// A team command.
    Command(GcsCommand),
    /// The live status table for this many seconds (refreshed in place on a terminal).
    Status(f64),
}

/// `host-sim gcs --team ADDR,... [--bind ADDR] ACTION`.
pub fn gcs(team: &[SocketAddr], bind: SocketAddr, action: &GcsAction, opts: &RunOptions) -> ExitCode {
    if team.is_empty() {
        eprintln!("error: --team: give the companions' UDP addresses, UAV 0 first");
        return ExitCode::from(2);
    }
    let mut g = match Gcs::bind(bind, team.to_vec()) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let result = match action {
        GcsAction::Upload(path, realtime) => {
            let ls = match load(Some(path)) {
                Ok(ls) => ls,
                Err(c) => return c,
            };
            if ls.scenario.cables.lengths_m.len() != team.len() {
                eprintln!("error: {}: {} UAVs, --team has {}", ls.source_name, ls.scenario.cables.lengths_m.len(), team.len());
                return ExitCode::from(2);
            }
            let rated = opts.f_max_n.unwrap_or(ls.scenario.cables.rated_n);
            pil::team_setup_for(&ls, opts.controller, sim::takeoff(&ls.scenario, &ls.tube, rated), rated, !*realtime)
                .and_then(|s| g.upload(&s.configs))
                .map(|()| println!("uploaded {} to {} companions: parameters echoed, tube accepted", ls.source_name, team.len()))
        }
        GcsAction::Start => {
            let ids: Vec<u8> = (0..team.len()).map(|i| crate::companion::SYSID_BASE.saturating_add(i as u8)).collect();
            g.start(&ids).map(|results| {
                for (i, (r, texts)) in results.iter().enumerate() {
                    let verdict = if *r == 0 { "accepted".to_string() } else { format!("REFUSED (MAV_RESULT {r})") };
                    println!("UAV {i}: MISSION_START {verdict}");
                    for t in texts {
                        println!("UAV {i}:   {t}");
                    }
                }
            })
        }
        GcsAction::Command(c) => g.command(*c).map(|rs| {
            for (i, r) in rs.iter().enumerate() {
                println!("UAV {i}: {c:?} {}", if *r == 0 { "accepted".to_string() } else { format!("refused (MAV_RESULT {r})") });
            }
        }),
        GcsAction::Status(seconds) => {
            use std::io::IsTerminal;
            let t0 = Instant::now();
            let live = std::io::stdout().is_terminal();
            let mut r = Ok(());
            while r.is_ok() && t0.elapsed().as_secs_f64() < *seconds {
                r = g.poll_status(Duration::from_millis(500)).map(|st| {
                    let table = status_table(st);
                    if live {
                        // Refreshed in place: cursor home, clear the screen below.
                        print!("\x1b[H\x1b[J{table}");
                    }
                });
            }
            if !live {
                if let Ok(st) = g.poll_status(Duration::ZERO) {
                    print!("{}", status_table(st));
                }
            }
            r
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
