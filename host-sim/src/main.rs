//! `host-sim`: fly the cooperative-transport mission software-in-the-loop.

use clap::{Parser, Subcommand, ValueEnum};
use host_sim::scenario;
use host_sim::sim::{self, ControllerKind, RunOptions};
use std::path::PathBuf;
use std::process::ExitCode;

/// Exit code for invalid input (scenario or arguments).
const EXIT_BAD_INPUT: u8 = 2;
/// Exit code for a run that could not be written or failed internally.
const EXIT_FAILURE: u8 = 1;

#[derive(Parser)]
#[command(name = "host-sim", version, about = "Software-in-the-loop simulator for virtual-tube cooperative transport")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Clone, Copy, ValueEnum)]
enum Controller {
    Dissipative,
    Baseline,
}

#[derive(Subcommand)]
enum Cmd {
    /// Fly one mission and write summary.json, trajectory.csv and plots.
    Run {
        /// Scenario TOML file (default: the paper's 10-UAV mission, built in).
        scenario: Option<PathBuf>,
        /// High-level controller.
        #[arg(long, value_enum, default_value = "dissipative")]
        controller: Controller,
        /// Override the cable capacity f_max, N.
        #[arg(long)]
        f_max: Option<f64>,
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Random seed (overrides the scenario's).
        #[arg(long)]
        seed: Option<u64>,
    },
    /// Fly both controllers on the same scenario and write paired plots and summaries.
    Compare {
        /// Scenario TOML file (default: the built-in paper scenario).
        scenario: Option<PathBuf>,
        /// Override the cable capacity f_max, N.
        #[arg(long)]
        f_max: Option<f64>,
        /// Output directory.
        #[arg(long, default_value = "out/compare")]
        out: PathBuf,
        /// Random seed.
        #[arg(long)]
        seed: Option<u64>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Cmd::Run { scenario, controller, f_max, out, seed } => {
            let kind = match controller {
                Controller::Dissipative => ControllerKind::Dissipative,
                Controller::Baseline => ControllerKind::Baseline,
            };
            run(scenario, kind, f_max, &out, seed)
        }
        Cmd::Compare { scenario, f_max, out, seed } => compare(scenario, f_max, &out, seed),
    }
}

fn load(path: Option<PathBuf>) -> Result<scenario::LoadedScenario, ExitCode> {
    scenario::load(path.as_deref()).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_BAD_INPUT)
    })
}

fn fly(ls: &scenario::LoadedScenario, kind: ControllerKind, f_max: Option<f64>, seed: Option<u64>) -> Result<sim::RunOutput, ExitCode> {
    if let Some(f) = f_max {
        if !(f.is_finite() && f > 0.0) {
            eprintln!("error: --f-max must be a finite number > 0 (got {f})");
            return Err(ExitCode::from(EXIT_BAD_INPUT));
        }
    }
    eprintln!("flying {} with the {} controller ...", ls.source_name, kind.name());
    sim::run(ls, &RunOptions { controller: kind, f_max_n: f_max, seed, progress: true }).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_BAD_INPUT)
    })
}

fn write(dir: &std::path::Path, out: &sim::RunOutput) -> Result<(), ExitCode> {
    match host_sim::report::write_run(dir, out) {
        Ok(files) => {
            for f in files {
                println!("  wrote {}", f.display());
            }
            Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}");
            Err(ExitCode::from(EXIT_FAILURE))
        }
    }
}

fn run(path: Option<PathBuf>, kind: ControllerKind, f_max: Option<f64>, out: &std::path::Path, seed: Option<u64>) -> ExitCode {
    let result = (|| {
        let ls = load(path)?;
        let o = fly(&ls, kind, f_max, seed)?;
        println!("{}", o.summary.table());
        write(out, &o)?;
        Ok::<_, ExitCode>(if o.summary.success { ExitCode::SUCCESS } else { ExitCode::from(EXIT_FAILURE) })
    })();
    result.unwrap_or_else(|c| c)
}

fn compare(path: Option<PathBuf>, f_max: Option<f64>, out: &std::path::Path, seed: Option<u64>) -> ExitCode {
    let result = (|| {
        let ls = load(path)?;
        let a = fly(&ls, ControllerKind::Dissipative, f_max, seed)?;
        let b = fly(&ls, ControllerKind::Baseline, f_max, seed)?;
        println!("dissipative:\n{}\nbaseline:\n{}", a.summary.table(), b.summary.table());
        write(&out.join("dissipative"), &a)?;
        write(&out.join("baseline"), &b)?;
        match host_sim::plots::write_comparison_plots(out, &a.scene, &a.record, &b.record) {
            Ok(files) => files.iter().for_each(|f| println!("  wrote {}", f.display())),
            Err(e) => {
                eprintln!("error: {e}");
                return Err(ExitCode::from(EXIT_FAILURE));
            }
        }
        Ok(ExitCode::SUCCESS)
    })();
    result.unwrap_or_else(|c| c)
}
