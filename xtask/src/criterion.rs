//! The host benches: runs `cargo bench -p host-sim --bench control --bench plan` (criterion) and reads the
//! medians it wrote under `CRITERION_HOME`.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::Paths;

/// Medians of every benchmark of `host-sim/benches/control.rs`, ns.
#[derive(Debug, Clone, Default)]
pub struct HostBench {
    /// `control_step/<n>`: one UAV's high-level + low-level step.
    pub control_step_ns: Vec<(usize, f64)>,
    /// `high_level/<n>`.
    pub high_level_ns: Vec<(usize, f64)>,
    /// `low_level/step`.
    pub low_level_ns: Option<f64>,
    /// `allocation_qp/<n>`.
    pub allocation_ns: Vec<(usize, f64)>,
    /// `tube_locate/warm` and `tube_locate/cold`.
    pub locate_warm_ns: Option<f64>,
    /// See `locate_warm_ns`.
    pub locate_cold_ns: Option<f64>,
    /// `plant_step/<n>`.
    pub plant_step_ns: Vec<(usize, f64)>,
    /// `plan/paper_map` (issue 16, `host-sim/benches/plan.rs`).
    pub plan_paper_map_ns: Option<f64>,
    /// `plan/obstacles_500`.
    pub plan_500_obstacles_ns: Option<f64>,
    /// `plan/grid_1000`.
    pub plan_grid_1000_ns: Option<f64>,
}

/// Team sizes of the control and allocation groups.
pub const TEAM_SIZES: [usize; 4] = [3, 10, 30, 100];
/// Team sizes of the plant group.
pub const PLANT_SIZES: [usize; 2] = [10, 100];

/// Runs the criterion benches (cargo's and criterion's output go to `criterion.log` in the
/// output directory)
/// and reads the medians.
///
/// # Errors
/// The bench could not be built or run, or wrote no estimates.
pub fn run(paths: &Paths, extra_args: &[String]) -> Result<HostBench, String> {
    let home = paths.out.join("criterion");
    // Stale estimates of a previous run must not be read as this run's.
    if home.exists() {
        fs::remove_dir_all(&home).map_err(|e| format!("cannot clear {}: {e}", home.display()))?;
    }
    fs::create_dir_all(&home).map_err(|e| format!("cannot create {}: {e}", home.display()))?;
    let log_path = paths.out.join("criterion.log");
    let log = fs::File::create(&log_path).map_err(|e| format!("cannot create {}: {e}", log_path.display()))?;
    let log_err = log.try_clone().map_err(|e| format!("cannot open {}: {e}", log_path.display()))?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(&paths.root)
        .args(["bench", "-p", "host-sim", "--bench", "control", "--bench", "plan", "--"])
        .args(extra_args)
        .env("CRITERION_HOME", &home)
        .stdout(Stdio::from(log))
        .stderr(Stdio::from(log_err))
        .status()
        .map_err(|e| format!("cannot start cargo bench: {e}"))?;
    if !status.success() {
        return Err(format!("cargo bench failed ({status}); see {}", log_path.display()));
    }
    let read_n = |group: &str, sizes: &[usize]| -> Vec<(usize, f64)> {
        sizes
            .iter()
            .filter_map(|&n| median_ns(&home.join(group).join(n.to_string())).map(|v| (n, v)))
            .collect()
    };
    let bench = HostBench {
        control_step_ns: read_n("control_step", &TEAM_SIZES),
        high_level_ns: read_n("high_level", &TEAM_SIZES),
        low_level_ns: median_ns(&home.join("low_level").join("step")),
        allocation_ns: read_n("allocation_qp", &TEAM_SIZES),
        locate_warm_ns: median_ns(&home.join("tube_locate").join("warm")),
        locate_cold_ns: median_ns(&home.join("tube_locate").join("cold")),
        plant_step_ns: read_n("plant_step", &PLANT_SIZES),
        plan_paper_map_ns: median_ns(&home.join("plan").join("paper_map")),
        plan_500_obstacles_ns: median_ns(&home.join("plan").join("obstacles_500")),
        plan_grid_1000_ns: median_ns(&home.join("plan").join("grid_1000")),
    };
    if bench.control_step_ns.is_empty() {
        return Err(format!("criterion wrote no estimates under {}", home.display()));
    }
    Ok(bench)
}

/// Median point estimate (ns) of one benchmark directory (`.../new/estimates.json`).
fn median_ns(dir: &Path) -> Option<f64> {
    let path: PathBuf = dir.join("new").join("estimates.json");
    let text = fs::read_to_string(path).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v.get("median")?.get("point_estimate")?.as_f64()
}
