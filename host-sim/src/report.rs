//! Writers for a run's outputs: `summary.json`, `trajectory.csv`, the plots.

use crate::sim::RunOutput;
use std::path::{Path, PathBuf};

/// Writes `summary.json`, `trajectory.csv`, the PNG plots and `replay.html` of one run into `dir`.
///
/// # Errors
/// I/O and plotting errors, as text naming the file.
pub fn write_run(dir: &Path, out: &RunOutput) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut files = Vec::new();
    let summary = dir.join("summary.json");
    let json = serde_json::to_string_pretty(&out.summary).map_err(|e| e.to_string())?;
    std::fs::write(&summary, json + "\n").map_err(|e| format!("{}: {e}", summary.display()))?;
    files.push(summary);
    let csv = dir.join("trajectory.csv");
    std::fs::write(&csv, crate::record::trajectory_csv(&out.record)).map_err(|e| format!("{}: {e}", csv.display()))?;
    files.push(csv);
    files.extend(crate::plots::write_run_plots(dir, &out.scene, &out.record).map_err(|e| e.to_string())?);
    files.push(crate::replay::write(dir, &out.scene, &[&out.record])?);
    Ok(files)
}

/// [`write_run`], listing each file written on stdout (`  wrote PATH`), as the commands do.
///
/// # Errors
/// As [`write_run`].
pub fn write_run_listed(dir: &Path, out: &RunOutput) -> Result<(), String> {
    for f in write_run(dir, out)? {
        println!("  wrote {}", f.display());
    }
    Ok(())
}
