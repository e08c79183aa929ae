//! Writers for a run's outputs: `summary.json`, `trajectory.csv`, the plots.

use crate::record::RunRecord;
use crate::sim::RunOutput;
use std::fmt::Write as _;
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
    std::fs::write(&csv, trajectory_csv(&out.record)).map_err(|e| format!("{}: {e}", csv.display()))?;
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

/// The trajectory as CSV: one row per record sample.
pub fn trajectory_csv(r: &RunRecord) -> String {
    let n = r.uav_pos_m.first().map_or(0, Vec::len);
    let mut s = String::from("time_s");
    for i in 0..n {
        for c in ["x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "thrust_n", "tension_n"] {
            let _ = write!(s, ",uav{i}_{c}");
        }
    }
    s.push_str(",load_x_m,load_y_m,load_z_m,load_vx_mps,load_vy_mps,load_vz_mps,min_uav_boundary_m,min_load_boundary_m,min_uav_uav_m\n");
    for k in 0..r.time_s.len() {
        let _ = write!(s, "{}", r.time_s[k]);
        for i in 0..n {
            let p = r.uav_pos_m[k][i];
            let v = r.uav_vel_mps[k][i];
            let _ = write!(s, ",{},{},{},{},{},{},{},{}", p[0], p[1], p[2], v[0], v[1], v[2], r.thrust_n[k][i], r.tension_n[k][i]);
        }
        let p = r.load_pos_m[k];
        let v = r.load_vel_mps[k];
        let _ = writeln!(
            s,
            ",{},{},{},{},{},{},{},{},{}",
            p[0], p[1], p[2], v[0], v[1], v[2], r.min_uav_boundary_m[k], r.min_load_boundary_m[k], r.min_uav_uav_m[k]
        );
    }
    s
}
