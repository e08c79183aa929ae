//! Project automation. `cargo xtask bench` (alias in `.cargo/config.toml`) measures what issue 5
//! asks for and checks it against the budgets (method and figures: `docs/benchmarks.md`):
//!
//! 1. host benches (criterion, `host-sim/benches/control.rs`): one UAV's control step for
//!    n = 3, 10, 30, 100, the QP allocation for the same n in the same run, the section lookup
//!    and the plant step;
//! 2. the whole-mission realtime factor of `scenarios/paper-10uav.toml` and
//!    `scenarios/scale-100uav.toml` (host-sim's runner, one thread);
//! 3. firmware flash and static RAM of each board (built here, ELF section headers), and the
//!    MCU instruction counts and stack peak from the firmware tooling's hook
//!    ([`firmware`]); what cannot be measured is `null` with a "not measured: why" note.
//!
//! Writes `out/bench/bench.json`, `out/bench/scaling.png` and `out/bench/criterion.log`, and
//! prints a table. Exit code 0 when everything measured ran (budgets missed are reported, not
//! failed: they are goals), 1 when a step could not run, 2 for bad arguments.

mod criterion;
mod firmware;
mod mission;
mod plot;
mod report;

use std::path::PathBuf;
use std::process::ExitCode;

/// Where things are.
#[derive(Debug, Clone)]
pub struct Paths {
    /// Repository root.
    pub root: PathBuf,
    /// Output directory (`out/bench`).
    pub out: PathBuf,
}

/// Command-line options of `bench`.
#[derive(Debug, Clone)]
struct Options {
    skip_host: bool,
    skip_missions: bool,
    skip_firmware: bool,
    runs_10: usize,
    runs_100: usize,
    mcu_cmd: Option<String>,
    boards: Vec<String>,
    docs: bool,
    criterion_args: Vec<String>,
}

const USAGE: &str = "usage: cargo xtask bench [--skip host,missions,firmware] [--runs-10 N] [--runs-100 N]
                        [--boards qemu,stm32f405] [--mcu-cmd CMD] [--docs] [-- CRITERION_ARGS...]
  --skip       leave parts out (their keys are null, noted as skipped)
  --runs-10    runs of the 10-UAV mission, median realtime factor (default 5)
  --runs-100   runs of the 100-UAV mission (default 1)
  --boards     firmware boards to build and measure (default: qemu,stm32f405)
  --mcu-cmd    command printing the MCU figures as JSON (default: firmware/bench.sh)
  --docs       also copy the scaling plot to docs/img/bench-scaling.png
       cargo xtask firmware-size
  builds both firmware boards and fails when flash > 128 KiB or static RAM > 32 KiB";

fn parse(args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        skip_host: false,
        skip_missions: false,
        skip_firmware: false,
        runs_10: 5,
        runs_100: 1,
        mcu_cmd: None,
        boards: firmware::BOARDS.iter().map(|b| b.to_string()).collect(),
        docs: false,
        criterion_args: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("{name} needs a value"));
        match a.as_str() {
            "--skip" => {
                for part in value("--skip")?.split(',') {
                    match part.trim() {
                        "host" => o.skip_host = true,
                        "missions" => o.skip_missions = true,
                        "firmware" => o.skip_firmware = true,
                        other => return Err(format!("--skip: unknown part `{other}`")),
                    }
                }
            }
            "--runs-10" => o.runs_10 = value("--runs-10")?.parse().map_err(|_| "--runs-10 needs a count")?,
            "--runs-100" => o.runs_100 = value("--runs-100")?.parse().map_err(|_| "--runs-100 needs a count")?,
            "--mcu-cmd" => o.mcu_cmd = Some(value("--mcu-cmd")?),
            "--boards" => {
                o.boards = value("--boards")?.split(',').map(|b| b.trim().to_string()).collect();
                if let Some(b) = o.boards.iter().find(|b| !firmware::BOARDS.contains(&b.as_str())) {
                    return Err(format!("--boards: unknown board `{b}`"));
                }
            }
            "--docs" => o.docs = true,
            "--" => {
                o.criterion_args = it.by_ref().cloned().collect();
            }
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    Ok(o)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("bench") => {}
        Some("firmware-size") => {
            let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().map(PathBuf::from).unwrap_or_default();
            let paths = Paths { out: root.join("out").join("bench"), root };
            return match firmware::size_check(&paths) {
                Ok(true) => ExitCode::SUCCESS,
                Ok(false) => ExitCode::FAILURE,
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            };
        }
        Some("-h" | "--help") | None => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Some(other) => {
            eprintln!("unknown task `{other}`\n{USAGE}");
            return ExitCode::from(2);
        }
    }
    let opts = match parse(args.get(1..).unwrap_or(&[])) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().map(PathBuf::from).unwrap_or_default();
    let paths = Paths { out: root.join("out").join("bench"), root };
    if let Err(e) = std::fs::create_dir_all(&paths.out) {
        eprintln!("cannot create {}: {e}", paths.out.display());
        return ExitCode::FAILURE;
    }
    match report::bench(&paths, &opts_to_plan(&opts)) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn opts_to_plan(o: &Options) -> report::Plan {
    report::Plan {
        host: !o.skip_host,
        missions: !o.skip_missions,
        firmware: !o.skip_firmware,
        runs_10: o.runs_10.max(1),
        runs_100: o.runs_100.max(1),
        mcu_cmd: o.mcu_cmd.clone(),
        boards: o.boards.clone(),
        docs: o.docs,
        criterion_args: o.criterion_args.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn options_parse() {
        let o = parse(&strings(&["--skip", "host,firmware", "--runs-10", "3", "--docs", "--", "--measurement-time", "1"]));
        let o = o.unwrap_or_else(|e| unreachable!("{e}"));
        assert!(o.skip_host && o.skip_firmware && !o.skip_missions && o.docs);
        assert_eq!(o.runs_10, 3);
        assert_eq!(o.criterion_args, strings(&["--measurement-time", "1"]));
        assert!(parse(&strings(&["--skip", "gpu"])).is_err());
        assert!(parse(&strings(&["--runs-10"])).is_err());
    }
}
