//! Command-line entry points of `host-sim pil` and `host-sim pil-bench` (wired by main.rs).

use std::path::{Path, PathBuf};
use super::bench::*;
use super::qemu::*;
use super::report::*;

/// `host-sim pil [SCENARIO] [--out DIR] [--firmware ELF] [--duration S]`: flies the scenario
/// (default: the 3-UAV experiment) SIL and PIL, writes `DIR/pil_report.json` and
/// `DIR/summary.json` and the PIL flight's `DIR/replay.html`, prints the comparison. Builds the firmware when no ELF is given and the
/// default one is missing. Exit 0 when bit-exact and the PIL mission succeeded, 1 otherwise,
/// 2 on bad input.
pub fn cli(
    scenario: Option<&Path>,
    out: &Path,
    firmware: Option<PathBuf>,
    duration_s: Option<f64>,
    uav_model: Option<crate::models::UavModel>,
    cable_model: Option<crate::models::CableModel>,
    mcap: Option<&Path>,
) -> std::process::ExitCode {
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
        None => match build_firmware_for(&ls) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        },
    };
    eprintln!("flying {} SIL (host twins) and PIL ({} x QEMU, {}) ...", ls.source_name, ls.scenario.cables.lengths_m.len(), elf.display());
    let opts = PilOptions { firmware: elf, qemu: qemu.into(), out_dir: out.to_path_buf(), duration_s, uav_model, cable_model, mcap: mcap.map(Path::to_path_buf) };
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
