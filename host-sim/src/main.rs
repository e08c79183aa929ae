//! `host-sim`: fly the cooperative-transport mission software-in-the-loop.

use clap::{Parser, Subcommand, ValueEnum};
use host_sim::models::{CableModel, UavModel};
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

/// The plant to fly on, overriding the scenario's `[uavs] model` and `[cables] model`.
#[derive(clap::Args, Clone, Copy)]
struct PlantArgs {
    /// UAV model (default: the scenario's, `rigid_body` unless it says otherwise).
    #[arg(long, value_enum)]
    uav_model: Option<UavModel>,
    /// Cable model (default: the scenario's, `elastic` unless it says otherwise).
    #[arg(long = "cable", value_enum)]
    cable_model: Option<CableModel>,
}

/// `host-sim sweep merge`.
#[derive(Subcommand)]
enum SweepCmd {
    /// Combine the shard directories of one campaign (each written by `sweep --shard K/N`) into
    /// the sweep.csv, sweep.json and plots one unsharded run writes.
    Merge {
        /// The shards' output directories (each holds shard.json), in any order.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "out/sweep")]
        out: PathBuf,
    },
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
        #[command(flatten)]
        plant: PlantArgs,
        /// Also write an MCAP log for Foxglove (docs/replay.md).
        #[arg(long, value_name = "FILE")]
        mcap: Option<PathBuf>,
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
        #[command(flatten)]
        plant: PlantArgs,
        /// Also write an MCAP log of both runs for Foxglove (docs/replay.md).
        #[arg(long, value_name = "FILE")]
        mcap: Option<PathBuf>,
    },
    /// Fly many seeded runs (a scenario or a campaign under scenarios/campaigns/) in parallel
    /// and write sweep.csv, sweep.json (success rate, percentiles) and, for campaigns with
    /// levels, success_rate_vs_level.png. `--shard K/N` flies one slice (shard.json);
    /// `sweep merge DIR...` combines the slices into what one run writes (docs/robustness.md).
    #[command(args_conflicts_with_subcommands = true)]
    Sweep {
        #[command(subcommand)]
        merge: Option<SweepCmd>,
        /// Scenario or campaign TOML file (default: the built-in paper scenario).
        scenario: Option<PathBuf>,
        /// Runs per level (default: the campaign's `runs`, else 20).
        #[arg(long)]
        runs: Option<usize>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// First seed; runs use seed, seed+1, ... (default: the campaign's `seed`).
        #[arg(long)]
        seed: Option<u64>,
        /// Output directory.
        #[arg(long, default_value = "out/sweep")]
        out: PathBuf,
        /// Fly the worst run again (first failure, else smallest UAV-boundary distance) with
        /// recording on and write its summary, plots and replay.html into OUT/worst.
        #[arg(long)]
        replay_worst: bool,
        /// Fly only the K-th of N disjoint slices of the runs (1 <= K <= N) and write
        /// OUT/shard.json for `sweep merge`.
        #[arg(long, value_name = "K/N")]
        shard: Option<host_sim::campaign::ShardSpec>,
        /// The world a campaign's base is flown in: `real_aircraft` (ground start, PX4's stock
        /// gains, RTK errors, attitude estimate, turbulence, thrust errors, declared bodies and
        /// a 0.2 m clearance floor) or `scenario` (as written). Default: the campaign's `world`
        /// key, else `real_aircraft`; a plain scenario file always flies as written.
        #[arg(long, value_parser = host_sim::campaign::World::parse)]
        world: Option<host_sim::campaign::World>,
    },
    /// Processor-in-the-loop: fly the mission with each UAV's controller in its own QEMU
    /// (the `qemu` firmware over MAVLink) and SIL with host twins; compare every command and
    /// write pil_report.json and summary.json.
    Pil {
        /// Scenario TOML file (default: scenarios/experiment-3uav.toml).
        scenario: Option<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "out/pil")]
        out: PathBuf,
        /// Firmware ELF to fly (default: build the `qemu` board, or $VT_FIRMWARE_ELF).
        #[arg(long)]
        firmware: Option<PathBuf>,
        /// Stop the flight after this many simulated seconds.
        #[arg(long)]
        duration: Option<f64>,
        #[command(flatten)]
        plant: PlantArgs,
        /// Also write an MCAP log of the PIL flight for Foxglove (docs/replay.md).
        #[arg(long, value_name = "FILE")]
        mcap: Option<PathBuf>,
    },
    /// Plan a tube on a map (TOML obstacle list or ROS map_server YAML) and write it in the
    /// scenario's `[tube]` format; prints the bottleneck (issue 16, docs/planning.md).
    Plan {
        /// Map file: `.toml` obstacle list or ROS `map_server` `.yaml`.
        map: PathBuf,
        /// Start `X,Y`, m.
        #[arg(long, value_parser = host_sim::plan::parse_point, allow_hyphen_values = true)]
        start: [f64; 2],
        /// Goal `X,Y`, m.
        #[arg(long, value_parser = host_sim::plan::parse_point, allow_hyphen_values = true)]
        goal: [f64; 2],
        /// Scenario whose team sets the width needed (default: the built-in paper scenario).
        #[arg(long)]
        team: Option<PathBuf>,
        /// Write the `[tube]` table here (default: print it).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also draw the map, corridor and tube into this PNG.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Write the scenario a generated campaign flies for SEED (issue 29; docs/robustness.md,
    /// "Generated scenarios"): a TOML file to read, edit and fly with `run`.
    Generate {
        /// The run's seed.
        seed: u64,
        /// Scenario or campaign whose gains, rates, link and disturbances are kept (default:
        /// the built-in paper scenario as written); over a campaign, its first level in its
        /// world, so `run` of the file repeats the campaign's flight of SEED.
        #[arg(long)]
        base: Option<PathBuf>,
        /// Write it here (default: print it).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Fly the scenario with one `vt-companion` process per UAV over UDP (host-sim as the MAVLink
    /// simulator, the ground station uploading and starting), in lockstep; fly the SIL twin
    /// beside it and compare every command; write sitl_report.json, summary.json, plots.
    Sitl {
        /// Scenario TOML file (default: the paper's 10-UAV mission, built in).
        scenario: Option<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "out/sitl")]
        out: PathBuf,
        /// The `vt-companion` binary (default: $VT_COMPANION_BIN, else built with cargo).
        #[arg(long)]
        companion: Option<PathBuf>,
        /// Physics: `host` (host-sim's plant) or `rotorpy` (RotorPy, a Python simulator; needs a
        /// Python with `rotorpy` and `pymavlink`, see docs/plant.md; lockstep only).
        #[arg(long, default_value = "host", value_parser = ["host", "rotorpy"])]
        plant: String,
        /// On the wall clock: the companions' own Tickers (VT_LOCKSTEP = 0), the simulator
        /// streaming states in real time; nothing bit-comparable, the mission must succeed.
        #[arg(long)]
        realtime: bool,
        /// High-level controller.
        #[arg(long, value_enum, default_value = "dissipative")]
        controller: Controller,
    },
    /// Score a trajectory flown elsewhere (a `trajectory.csv` in host-sim's format, e.g. from
    /// RotorPy) against a scenario: the same metrics, floors and summary.json as a host-sim
    /// flight, plus plots and replay; exit 1 when the mission failed.
    Score {
        /// The trajectory CSV (host-sim's `trajectory.csv` columns; extra columns are ignored).
        trajectory: PathBuf,
        /// Scenario TOML file it flew (default: the paper's 10-UAV mission, built in).
        scenario: Option<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "out/score")]
        out: PathBuf,
        /// What flew it, for summary.json `plant`.
        #[arg(long, default_value = "external", value_parser = ["external", "rotorpy", "host"])]
        plant: String,
    },
    /// Be the MAVLink simulator: UAV `i` of the scenario on UDP port `PORT + i` (as PX4 SITL
    /// instances), lockstep or on the wall clock; companions connect to it, a ground station configures and starts
    /// them (`host-sim gcs`); writes summary.json and plots at the end.
    Serve {
        /// Scenario TOML file (default: the paper's 10-UAV mission, built in).
        scenario: Option<PathBuf>,
        /// UDP port of UAV 0.
        #[arg(long, default_value_t = 14560)]
        port: u16,
        /// On the wall clock (companions uploaded with `gcs upload --realtime`).
        #[arg(long)]
        realtime: bool,
        /// Output directory.
        #[arg(long, default_value = "out/serve")]
        out: PathBuf,
    },
    /// Ground station: talk to a team of companions given as UDP endpoints.
    Gcs {
        /// The companions' addresses, UAV 0 first: HOST:PORT,HOST:PORT,...
        #[arg(long, value_delimiter = ',', required = true)]
        team: Vec<std::net::SocketAddr>,
        /// Where the ground station listens (start the companions with `--remote` this).
        #[arg(long, default_value = "127.0.0.1:14550")]
        bind: std::net::SocketAddr,
        #[command(subcommand)]
        action: GcsCmd,
    },
    /// Instruction counts of the firmware's control steps for 3, 10 and 30 UAVs under
    /// `qemu-system-arm -icount shift=0`; writes OUT/bench.json (docs/benchmarks.md).
    PilBench {
        /// Output directory.
        #[arg(long, default_value = "out/bench/mcu")]
        out: PathBuf,
        /// Firmware ELF (default: build the `qemu` board).
        #[arg(long)]
        firmware: Option<PathBuf>,
    },
}

/// What the ground station does.
#[derive(Subcommand)]
enum GcsCmd {
    /// Upload the scenario's parameters (each echoed) and its tube to every companion.
    Upload {
        /// Scenario TOML file.
        scenario: PathBuf,
        /// For a flight on the wall clock (VT_LOCKSTEP = 0), not lockstep with a simulator.
        #[arg(long)]
        realtime: bool,
    },
    /// MAV_CMD_MISSION_START to every companion; refusals printed verbatim.
    Start,
    /// The operator's hold (the team holds in the tube).
    Hold,
    /// Lift the hold (the team resumes FS_RESUME later).
    Resume,
    /// The companions stop commanding (the team is told to hold first); the autopilots' own
    /// setpoint-loss action takes over (docs/deploy.md).
    Abort,
    /// Each UAV's mode, data ages, tension estimate and clearance, refreshed in place.
    Status {
        /// How long to show it, s.
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Cmd::Run { scenario, controller, f_max, out, seed, plant, mcap } => run(scenario, controller_kind(controller), f_max, &out, seed, plant, mcap.as_deref()),
        Cmd::Compare { scenario, f_max, out, seed, plant, mcap } => compare(scenario, f_max, &out, seed, plant, mcap.as_deref()),
        Cmd::Sweep { merge: Some(SweepCmd::Merge { dirs, out }), .. } => sweep_merge(&dirs, &out),
        Cmd::Sweep { merge: None, scenario, runs, jobs, seed, out, replay_worst, shard, world } => sweep(scenario, runs, jobs, seed, &out, replay_worst, shard, world),
        Cmd::Pil { scenario, out, firmware, duration, plant, mcap } => {
            if let Some(d) = duration {
                if !(d.is_finite() && d > 0.0) {
                    eprintln!("error: --duration must be a finite number of seconds > 0 (got {d})");
                    return ExitCode::from(EXIT_BAD_INPUT);
                }
            }
            host_sim::pil::cli(scenario.as_deref(), &out, firmware, duration, plant.uav_model, plant.cable_model, mcap.as_deref())
        }
        Cmd::PilBench { out, firmware } => host_sim::pil::cli_bench(&out, firmware),
        Cmd::Sitl { scenario, out, companion, plant, controller, realtime } => {
            use host_sim::sitl::cli::SitlPlant;
            let plant = if plant == "rotorpy" { SitlPlant::RotorPy } else { SitlPlant::Host };
            let opts = RunOptions { controller: controller_kind(controller), record: true, ..RunOptions::default() };
            host_sim::sitl::cli::sitl(scenario.as_deref(), &out, companion, realtime, plant, &opts)
        }
        Cmd::Score { trajectory, scenario, out, plant } => score(&trajectory, scenario.as_deref(), &out, &plant),
        Cmd::Serve { scenario, port, realtime, out } => host_sim::sitl::cli::serve(scenario.as_deref(), port, realtime, &out, &RunOptions::default()),
        Cmd::Gcs { team, bind, action } => {
            use host_sim::sitl::cli::GcsAction;
            use host_sim::sitl::gcs::GcsCommand;
            let action = match action {
                GcsCmd::Upload { scenario, realtime } => GcsAction::Upload(scenario, realtime),
                GcsCmd::Start => GcsAction::Start,
                GcsCmd::Hold => GcsAction::Command(GcsCommand::Hold),
                GcsCmd::Resume => GcsAction::Command(GcsCommand::Resume),
                GcsCmd::Abort => GcsAction::Command(GcsCommand::Abort),
                GcsCmd::Status { seconds } => GcsAction::Status(seconds),
            };
            host_sim::sitl::cli::gcs(&team, bind, &action, &RunOptions::default())
        }
        Cmd::Plan { map, start, goal, team, out, plot } => plan(&map, start, goal, team.as_deref(), out.as_deref(), plot.as_deref()),
        Cmd::Generate { seed, base, out } => generate(seed, base.as_deref(), out.as_deref()),
    }
}

/// `host-sim generate SEED [--base FILE] [--out FILE]`.
fn generate(seed: u64, base: Option<&std::path::Path>, out: Option<&std::path::Path>) -> ExitCode {
    let c = match host_sim::campaign::load(base) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let Some(table) = c.tables.first() else {
        eprintln!("error: {}: no scenario", c.name);
        return ExitCode::from(EXIT_BAD_INPUT);
    };
    let g = match scenario::generate::generate(table, seed) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let d = &g.drawn;
    let text = format!(
        "# host-sim generate {seed} (over {}): {} tube, {} x {}, load {:.1} % of the team's capacity, {} cables, narrowest half-width {:.2} m, {} redraws\n{}",
        c.name,
        d.tube.name(),
        d.n_uavs,
        d.airframe.name,
        100.0 * d.load_fraction,
        if d.equal_cables { "equal" } else { "unequal" },
        d.min_half_width_m,
        d.redraws,
        g.text
    );
    match out {
        None => print!("{text}"),
        Some(p) => {
            if let Err(e) = std::fs::write(p, text) {
                eprintln!("error: {}: {e}", p.display());
                return ExitCode::from(EXIT_BAD_INPUT);
            }
            eprintln!("wrote {}", p.display());
        }
    }
    ExitCode::SUCCESS
}

fn controller_kind(c: Controller) -> ControllerKind {
    match c {
        Controller::Dissipative => ControllerKind::Dissipative,
        Controller::Baseline => ControllerKind::Baseline,
    }
}

fn load(path: Option<PathBuf>) -> Result<scenario::LoadedScenario, ExitCode> {
    scenario::load(path.as_deref()).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_BAD_INPUT)
    })
}

fn fly(ls: &scenario::LoadedScenario, kind: ControllerKind, f_max: Option<f64>, seed: Option<u64>, plant: PlantArgs) -> Result<sim::RunOutput, ExitCode> {
    if let Some(f) = f_max {
        if !(f.is_finite() && f > 0.0) {
            eprintln!("error: --f-max must be a finite number > 0 (got {f})");
            return Err(ExitCode::from(EXIT_BAD_INPUT));
        }
        // The scenario passed the pre-flight check at its own rating; this one is the run's.
        if let Err(e) = sim::preflight(&ls.scenario, f) {
            eprintln!("error: {}: with --f-max {f}: {e}", ls.source_name);
            return Err(ExitCode::from(EXIT_BAD_INPUT));
        }
    }
    eprintln!("flying {} with the {} controller ...", ls.source_name, kind.name());
    let opts = RunOptions { controller: kind, f_max_n: f_max, seed, progress: true, record: true, uav_model: plant.uav_model, cable_model: plant.cable_model, duration_s: None };
    sim::run(ls, &opts).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_BAD_INPUT)
    })
}

fn write(dir: &std::path::Path, out: &sim::RunOutput) -> Result<(), ExitCode> {
    host_sim::report::write_run_listed(dir, out).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_FAILURE)
    })
}

/// Writes the MCAP log of `runs` to `path` when asked (`--mcap`).
fn write_mcap(path: Option<&std::path::Path>, scene: &host_sim::record::SceneGeometry, runs: &[&host_sim::record::RunRecord]) -> Result<(), ExitCode> {
    let Some(path) = path else { return Ok(()) };
    match host_sim::mcap_log::write(path, scene, runs) {
        Ok(stats) => {
            println!("  wrote {} ({} messages)", path.display(), stats.messages.values().sum::<u64>());
            Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}");
            Err(ExitCode::from(EXIT_FAILURE))
        }
    }
}

fn run(path: Option<PathBuf>, kind: ControllerKind, f_max: Option<f64>, out: &std::path::Path, seed: Option<u64>, plant: PlantArgs, mcap: Option<&std::path::Path>) -> ExitCode {
    let result = (|| {
        let ls = load(path)?;
        let o = fly(&ls, kind, f_max, seed, plant)?;
        println!("{}", o.summary.table());
        write(out, &o)?;
        write_mcap(mcap, &o.scene, &[&o.record])?;
        write_plan_plot(&ls, out)?; // issue 16: map, corridor and tube of a planned scenario
        Ok::<_, ExitCode>(if o.summary.success { ExitCode::SUCCESS } else { ExitCode::from(EXIT_FAILURE) })
    })();
    result.unwrap_or_else(|c| c)
}

fn compare(path: Option<PathBuf>, f_max: Option<f64>, out: &std::path::Path, seed: Option<u64>, plant: PlantArgs, mcap: Option<&std::path::Path>) -> ExitCode {
    let result = (|| {
        let ls = load(path)?;
        let a = fly(&ls, ControllerKind::Dissipative, f_max, seed, plant)?;
        let b = fly(&ls, ControllerKind::Baseline, f_max, seed, plant)?;
        println!("dissipative:\n{}\nbaseline:\n{}", a.summary.table(), b.summary.table());
        write(&out.join("dissipative"), &a)?;
        write(&out.join("baseline"), &b)?;
        write_mcap(mcap, &a.scene, &[&a.record, &b.record])?;
        match host_sim::replay::write(out, &a.scene, &[&a.record, &b.record]) {
            Ok(f) => println!("  wrote {}", f.display()),
            Err(e) => {
                eprintln!("error: {e}");
                return Err(ExitCode::from(EXIT_FAILURE));
            }
        }
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

#[allow(clippy::too_many_arguments)]
fn sweep(path: Option<PathBuf>, runs: Option<usize>, jobs: Option<usize>, seed: Option<u64>, out: &std::path::Path, replay_worst: bool, shard: Option<host_sim::campaign::ShardSpec>, world: Option<host_sim::campaign::World>) -> ExitCode {
    use host_sim::campaign;
    let c = match campaign::load_in(path.as_deref(), world) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let runs = runs.unwrap_or(c.runs);
    if runs == 0 {
        eprintln!("error: --runs must be > 0");
        return ExitCode::from(EXIT_BAD_INPUT);
    }
    let seed = seed.unwrap_or(c.seed);
    let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    eprintln!("sweep {}: {} level(s) x {runs} runs from seed {seed} on {jobs} threads ...", c.name, c.levels.len());
    let wall = std::time::Instant::now();
    if let Some(spec) = shard {
        if replay_worst {
            eprintln!("error: --replay-worst needs every run: give it to `sweep merge`'s campaign instead, or fly unsharded");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
        let rows = match campaign::fly_shard(&c, runs, seed, jobs, true, Some(spec)) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(EXIT_BAD_INPUT);
            }
        };
        let n = rows.len();
        let file = campaign::ShardFile::new(&c, runs, seed, spec, rows);
        let path = out.join("shard.json");
        let written = std::fs::create_dir_all(out)
            .map_err(|e| e.to_string())
            .and_then(|()| serde_json::to_string(&file).map_err(|e| e.to_string()))
            .and_then(|t| std::fs::write(&path, t + "\n").map_err(|e| e.to_string()));
        if let Err(e) = written {
            eprintln!("error: {}: {e}", path.display());
            return ExitCode::from(EXIT_FAILURE);
        }
        println!("shard {}/{}: {n} runs in {:.1} s\n  wrote {}", spec.index, spec.count, wall.elapsed().as_secs_f64(), path.display());
        return ExitCode::SUCCESS;
    }
    let rows = match campaign::fly(&c, runs, seed, jobs, true) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let rep = campaign::report(&c, seed, &rows);
    if let Err(e) = write_sweep(out, &rows, &rep) {
        eprintln!("error: {e}");
        return ExitCode::from(EXIT_FAILURE);
    }
    print_sweep(&rep, wall.elapsed().as_secs_f64(), out);
    if replay_worst {
        if let Some(w) = campaign::worst(&rows) {
            let lv = w.level.map_or_else(String::new, |v| format!(" at level {v}"));
            eprintln!("re-flying the worst run (seed {}{lv}) with recording ...", w.summary.seed);
            let o = match campaign::refly(&c, w) {
                Ok(o) => o,
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(EXIT_FAILURE);
                }
            };
            if write(&out.join("worst"), &o).is_err() {
                return ExitCode::from(EXIT_FAILURE);
            }
        }
    }
    ExitCode::SUCCESS
}

fn write_sweep(out: &std::path::Path, rows: &[host_sim::campaign::Row], rep: &host_sim::campaign::SweepReport) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let csv = out.join("sweep.csv");
    std::fs::write(&csv, host_sim::campaign::csv(rows)).map_err(|e| format!("{}: {e}", csv.display()))?;
    let json = out.join("sweep.json");
    let text = serde_json::to_string_pretty(rep).map_err(|e| e.to_string())?;
    std::fs::write(&json, text + "\n").map_err(|e| format!("{}: {e}", json.display()))?;
    if rep.levels.len() > 1 {
        let pts: Vec<(f64, f64)> = rep.levels.iter().filter_map(|l| l.level.map(|v| (v, 100.0 * l.success_rate))).collect();
        let key = rep.level_key.clone().unwrap_or_default();
        host_sim::plots::write_xy_plot(
            &out.join("success_rate_vs_level.png"),
            &format!("Success rate - {} (level: {key})", rep.scenario),
            level_axis(&key),
            "success rate [%]",
            &[("success rate".to_string(), pts)],
            &[0.0, 100.0],
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// The x-axis label of a level sweep: what the levels set (issue 15 added the load sweeps).
fn level_axis(key: &str) -> &'static str {
    match key {
        "load.mass_kg" => "load mass [kg]",
        "load.true_mass_kg" => "true load mass [kg] (declared: load.mass_kg)",
        "disturbances.latency_s" => "sensor latency [s]",
        "disturbances.intensity" => "disturbance intensity (x nominal)",
        "sensors.lidar.dropout" => "LiDAR beam dropout probability",
        _ => "level",
    }
}

/// `host-sim plan` (issue 16).
fn plan(
    map: &std::path::Path,
    start: [f64; 2],
    goal: [f64; 2],
    team: Option<&std::path::Path>,
    out: Option<&std::path::Path>,
    plot: Option<&std::path::Path>,
) -> ExitCode {
    let o = match host_sim::plan::run_cli(map, start, goal, team) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let b = &o.tube.bottleneck;
    eprintln!(
        "planned {} waypoints ({} discs) in {:.2} ms; bottleneck: half-width {:.2} m (width {:.2} m) at ({:.2}, {:.2}), s = {:.2} m",
        o.tube.waypoints.len(), o.tube.discs.len(), o.plan_ms, b.half_width_m, 2.0 * b.half_width_m, b.pos_m.x, b.pos_m.y, b.s_m
    );
    match out {
        Some(p) => {
            if let Err(e) = std::fs::write(p, &o.toml) {
                eprintln!("error: {}: {e}", p.display());
                return ExitCode::from(EXIT_FAILURE);
            }
            println!("  wrote {}", p.display());
        }
        None => print!("{}", o.toml),
    }
    if let Some(p) = plot {
        if let Err(e) = host_sim::plan_plot::write(p, &o.map, &o.tube) {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_FAILURE);
        }
        println!("  wrote {}", p.display());
    }
    ExitCode::SUCCESS
}

/// For a scenario whose tube is planned, `plan.png` in `out`: the map, the corridor's discs and
/// the tube (host_sim::plan_plot), beside the run's top view.
fn write_plan_plot(ls: &scenario::LoadedScenario, out: &std::path::Path) -> Result<(), ExitCode> {
    let Some(plan) = &ls.plan else { return Ok(()) };
    let path = out.join("plan.png");
    host_sim::plan_plot::write(&path, &plan.map, &plan.tube).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_FAILURE)
    })?;
    println!("  wrote {}", path.display());
    Ok(())
}

/// `host-sim score`: exit 2 on bad input (file:line:column), 1 when the mission failed.
fn score(trajectory: &std::path::Path, scenario: Option<&std::path::Path>, out: &std::path::Path, plant: &str) -> ExitCode {
    let ls = match scenario::load(scenario) {
        Ok(ls) => ls,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let plant = match plant {
        "rotorpy" => "rotorpy",
        "host" => "host",
        _ => "external",
    };
    let from = host_sim::score::Provenance { plant, uav_model: "external", cable_model: "external", controller: ControllerKind::Dissipative, wall_s: 0.0 };
    let (summary, record) = match host_sim::score::score_file(trajectory, &ls, &from) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let run = sim::RunOutput { summary, record, scene: sim::scene(&ls) };
    println!("{}", run.summary.table());
    if let Err(e) = host_sim::report::write_run_listed(out, &run) {
        eprintln!("error: {e}");
        return ExitCode::from(EXIT_FAILURE);
    }
    if run.summary.success { ExitCode::SUCCESS } else { ExitCode::from(EXIT_FAILURE) }
}

/// The sweep's table on stdout (one line per level).
fn print_sweep(rep: &host_sim::campaign::SweepReport, wall_s: f64, out: &std::path::Path) {
    println!("{} runs, {} successes ({:.1} %) in {:.1} s", rep.runs, rep.successes, 100.0 * rep.success_rate, wall_s);
    for l in &rep.levels {
        let lv = l.level.map_or_else(|| "-".to_string(), |v| format!("{v}"));
        let worst = |k: &str, hi: bool| l.percentiles.get(k).map_or(f64::NAN, |p| if hi { p.max } else { p.min });
        println!(
            "  level {lv:>6}: {:>4}/{:<4} success {:>5.1} %  worst UAV-bnd {:.2} m  worst UAV-UAV {:.2} m  worst load alt err {:.2} m{}",
            l.successes,
            l.runs,
            100.0 * l.success_rate,
            worst("min_uav_boundary_m", false),
            worst("min_uav_uav_m", false),
            worst("max_load_altitude_error_m", true),
            if l.failure_reasons.is_empty() { String::new() } else { format!("  failures: {:?}", l.failure_reasons) }
        );
        if l.refused > 0 || l.out_of_tube > 0 || l.set_down > 0 {
            println!(
                "                  refused {}, accepted {}: success {:.1} %, set down before the end {}, out of the tube {}",
                l.refused,
                l.runs - l.refused,
                100.0 * l.accepted_success_rate,
                l.set_down,
                l.out_of_tube
            );
        }
    }
    if !rep.classes.is_empty() {
        println!("  generated scenarios ({} redraws): class, level, successes / runs, refused, out of the tube, failures", rep.redraws);
        for c in &rep.classes {
            let lv = c.level.map_or_else(|| "-".to_string(), |v| format!("{v}"));
            println!(
                "    {:>8} {:<18} level {lv:>4}: {:>4}/{:<4} refused {:>3} out {:>3}{}",
                c.dimension,
                c.class,
                c.successes,
                c.runs,
                c.refused,
                c.out_of_tube,
                if c.failure_reasons.is_empty() { String::new() } else { format!("  {:?}", c.failure_reasons) }
            );
        }
    }
    for f in &rep.forest {
        let lv = f.level.map_or_else(|| "-".to_string(), |v| format!("{v}"));
        println!(
            "  unknown forests, level {lv}: solvable {}/{} succeeded ({} held: false no_route), no route {}/{} held, marginal {}/{} succeeded; contacts with a trunk {} (closest {:.2} m), out of the tube {}",
            f.solvable_successes, f.solvable, f.solvable_held, f.no_route_held, f.no_route, f.marginal_successes, f.marginal, f.contacts, f.min_obstacle_clearance_m, f.out_of_tube
        );
    }
    println!("  wrote {}", out.display());
}

/// `host-sim sweep merge DIR... --out OUT`: exit 2 when the shards are not one whole campaign.
fn sweep_merge(dirs: &[PathBuf], out: &std::path::Path) -> ExitCode {
    use host_sim::campaign;
    let wall = std::time::Instant::now();
    let mut shards = Vec::with_capacity(dirs.len());
    for d in dirs {
        match campaign::ShardFile::read(d) {
            Ok(s) => shards.push((d.join("shard.json").display().to_string(), s)),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(EXIT_BAD_INPUT);
            }
        }
    }
    let m = match campaign::merge(&shards) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let rep = campaign::report_for(&m.campaign, m.level_key.as_deref(), &m.levels, m.first_seed, &m.rows);
    if let Err(e) = write_sweep(out, &m.rows, &rep) {
        eprintln!("error: {e}");
        return ExitCode::from(EXIT_FAILURE);
    }
    print_sweep(&rep, wall.elapsed().as_secs_f64(), out);
    ExitCode::SUCCESS
}
