//! `vt-companion`: the cooperative-transport companion as a Linux program (Raspberry Pi,
//! Jetson) beside PX4 or ArduPilot. The same flight logic as the firmware (`vt_companion`), in
//! real time on the wall clock, MAVLink v2 over UDP or a serial port (docs/deploy.md).
//!
//! Exit codes: 0 stopped (Ctrl-C / SIGTERM, after telling the team to hold) or shut down by
//! command; 1 the link failed; 2 bad arguments.

mod link;
mod runner;

use clap::Parser;
use link::{Link, Serial, Udp};
use runner::Exit;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use vt_companion::perception::{Perception, PlannerSpace};
use vt_companion::replanning::Replanning;
use vt_companion::{Companion, CompanionTube, Param};

#[derive(Parser)]
#[command(name = "vt-companion", version, about = "Cooperative-transport companion: the flight logic beside PX4/ArduPilot over MAVLink (docs/deploy.md)")]
struct Args {
    /// Listen for MAVLink on this UDP address, e.g. 0.0.0.0:14540.
    #[arg(long, value_name = "BIND:PORT", conflicts_with = "serial")]
    udp: Option<SocketAddr>,
    /// Send every frame to this UDP address (repeatable: the autopilot or simulator, the ground
    /// station); default: whoever sent last.
    #[arg(long = "remote", value_name = "HOST:PORT", requires = "udp")]
    remotes: Vec<SocketAddr>,
    /// Serial device wired to the autopilot, e.g. /dev/ttyAMA0.
    #[arg(long, value_name = "DEV")]
    serial: Option<String>,
    /// Serial baud rate (PX4 TELEM2 / ArduPilot SERIAL2 as set up in docs/deploy.md).
    #[arg(long, default_value_t = 921_600, requires = "serial")]
    baud: u32,
    /// Set a parameter before anything arrives (repeatable), e.g. --param VT_ID=2; the ground
    /// station may change it later with PARAM_SET.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// Print nothing but errors.
    #[arg(long)]
    quiet: bool,
}

/// Bad input: exit 2 with the message.
fn bad(msg: &str) -> ExitCode {
    eprintln!("vt-companion: error: {msg}");
    ExitCode::from(2)
}

/// The `--param` presets, checked against the companion's own table.
fn presets(list: &[String]) -> Result<Vec<(Param, f32)>, String> {
    list.iter()
        .map(|s| {
            let (name, value) = s.split_once('=').ok_or_else(|| format!("--param {s}: expected NAME=VALUE"))?;
            let p = Param::from_name(name.trim()).ok_or_else(|| format!("--param {s}: no parameter called {name}"))?;
            let v: f32 = value.trim().parse().map_err(|_| format!("--param {s}: {value} is not a number"))?;
            vt_companion::Params::new().set(p, v).map_err(|e| format!("--param {s}: refused ({e:?}; range {} .. {})", p.info().min, p.info().max))?;
            Ok((p, v))
        })
        .collect()
}

fn main() -> ExitCode {
    let args = Args::parse();
    let presets = match presets(&args.params) {
        Ok(p) => p,
        Err(e) => return bad(&e),
    };
    let mut link: Box<dyn Link> = match (&args.udp, &args.serial) {
        (Some(bind), None) => match Udp::open(*bind, args.remotes.clone()) {
            Ok(u) => {
                if !args.quiet {
                    eprintln!("vt-companion: MAVLink on udp {}", u.local_addr().map_or_else(|_| bind.to_string(), |a| a.to_string()));
                }
                Box::new(u)
            }
            Err(e) => return bad(&format!("--udp {bind}: {e}")),
        },
        (None, Some(dev)) => match Serial::open(dev, args.baud) {
            Ok(s) => Box::new(s),
            Err(e) => return bad(&format!("--serial {dev}: {e}")),
        },
        _ => return bad("give a link: --udp BIND:PORT [--remote HOST:PORT], or --serial DEV [--baud N]"),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)) {
        return bad(&format!("cannot install the Ctrl-C handler: {e}"));
    }
    // The tube's tables (about 9 KiB) live beside the companion, as in the firmware's static.
    let mut tube = Box::new(CompanionTube::placeholder());
    // Issue 28: the onboard map and the re-planning's two tubes (about 290 KiB), configured by
    // the companion from its `PR_*` parameters when `PR_MAP` is 1.
    let (mut map, mut space) = (Box::new(Perception::placeholder()), Box::new(PlannerSpace::zeroed()));
    let (mut spare, mut check) = (Box::new(CompanionTube::placeholder()), Box::new(CompanionTube::placeholder()));
    loop {
        // The re-planning's state (about 6 KiB), kept in place as the firmware's static is.
        let mut slot = Box::new(vt_companion::ReplanSlot::new());
        let mut companion = Companion::new(&mut tube);
        let _none = companion.attach_replanning(&mut slot, Replanning::new(&mut map, &mut space, &mut spare, &mut check));
        for &(p, v) in &presets {
            if companion.set_param(p, v).is_err() {
                return bad(&format!("parameter {} = {v} refused", p.info().name));
            }
        }
        let quiet = args.quiet;
        let exit = runner::run(&mut companion, link.as_mut(), &stop, |mode, reasons| {
            if !quiet {
                eprintln!("vt-companion: mode {mode:?} (hold reasons {reasons:#04x})");
            }
        });
        match exit {
            Ok(Exit::Stopped) => {
                if !args.quiet {
                    eprintln!("vt-companion: stopped; the team was told to hold");
                }
                return ExitCode::SUCCESS;
            }
            Ok(Exit::Shutdown) => return ExitCode::SUCCESS,
            Ok(Exit::Reboot) => {
                if !args.quiet {
                    eprintln!("vt-companion: reboot requested: starting over");
                }
            }
            Err(e) => {
                eprintln!("vt-companion: link failed: {e}");
                return ExitCode::from(1);
            }
        }
    }
}
