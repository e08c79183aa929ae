//! Issue 28's onboard figures on the flight MCU's core: instructions per map update and per
//! re-plan, from `vt-bench-perception` under `qemu -icount shift=0`
//! (`firmware/src/perception_bench.rs` fixes the world and the path).

use serde::Serialize;
use std::path::Path;

use super::bench::{calibration, parse_after};
use super::qemu::{build_firmware_bin, decode_defmt, QemuOptions, QemuPort};
use super::{err, PilError};

/// The firmware binary of the bench and its cargo feature.
pub const PERCEPTION_BENCH_BIN: (&str, &str) = ("perception-bench", "vt-bench-perception");

/// What one run of the perception bench measured.
#[derive(Debug, Clone, Serialize)]
pub struct PerceptionBench {
    /// Scans integrated.
    pub scans: u64,
    /// Instructions per map update (one 72-sector scan), mean over the scans.
    pub map_update_mean: f64,
    /// The same, worst scan.
    pub map_update_max: f64,
    /// Instructions per scan of the map's fold alone (`OccupancyGrid::integrate_sectors`, no
    /// tube test of the newly occupied cells), mean and worst.
    pub fold_alone_mean: f64,
    /// The same, worst scan.
    pub fold_alone_max: f64,
    /// Cells the fold updates per scan, mean.
    pub cells_per_scan: u64,
    /// Instructions of the fold alone on synthetic scans at the map's middle: every sector
    /// clear, every sector hit at 9.9 m (just short of the free range), every sector hit at
    /// 5.9 m (arcs of three cells).
    pub fold_synthetic: [f64; 3],
    /// Instructions of the re-plan on the empty map.
    pub replan_empty_map: f64,
    /// Instructions of the re-plan after the last scan (the map seen most).
    pub replan_seen_map: f64,
    /// Both re-plans gave a tube.
    pub replans_ok: bool,
    /// A pillar was seen in the tube ahead (the trigger a re-plan answers).
    pub blocked: bool,
    /// `size_of::<Perception>()`, bytes (map, planner grid, work space).
    pub state_bytes: u64,
    /// Deepest stack use, bytes.
    pub stack_bytes: u64,
    /// Instructions per SysTick tick (the boot calibration; 40 under `-icount shift=0`).
    pub instructions_per_tick: f64,
}

/// Builds the bench firmware.
///
/// # Errors
/// cargo fails.
pub fn build_perception_bench() -> Result<std::path::PathBuf, PilError> {
    build_firmware_bin(PERCEPTION_BENCH_BIN.0, PERCEPTION_BENCH_BIN.1)
}

/// Runs `elf` (the bench firmware) in `qemu` with `-icount shift=0` and reads its log.
///
/// # Errors
/// The emulator fails or exits non-zero, or a figure is missing from the log.
pub fn perception_bench(elf: &Path, qemu: &str, socket_dir: &Path) -> Result<PerceptionBench, PilError> {
    let o = QemuOptions { qemu: qemu.into(), icount: true, socket_dir: socket_dir.into(), name: "perception-bench".into() };
    let (code, bytes) = QemuPort::spawn(elf, &o)?.wait_exit()?;
    let log = decode_defmt(elf, &bytes)?;
    if code != Some(0) {
        return err(format!("perception bench exited with {code:?}: {}", log.join(" | ")));
    }
    parse(&log)
}

/// The figures of a bench log.
///
/// # Errors
/// A line is missing.
pub fn parse(log: &[String]) -> Result<PerceptionBench, PilError> {
    let find = |key: &str, field: &str| log.iter().filter(|l| l.contains(key)).find_map(|l| parse_after(l, field));
    let missing = |what: &str| PilError(format!("perception bench log has no {what}: {}", log.join(" | ")));
    let (_, _, k) = calibration(log)?;
    let ticks = |key: &str, field: &str| find(key, field).map(|x| x as f64 * k).ok_or_else(|| missing(key));
    let replan_ok = |n: &str| log.iter().any(|l| l.contains(&format!("replan {n}:")) && l.contains("ok true"));
    Ok(PerceptionBench {
        scans: find("map update:", "map update: ").ok_or_else(|| missing("map update"))?,
        map_update_mean: ticks("map update:", "mean ")?,
        map_update_max: ticks("map update:", "max ")?,
        fold_alone_mean: ticks("fold alone:", "mean ")?,
        fold_alone_max: ticks("fold alone:", "max ")?,
        cells_per_scan: find("fold alone:", "ticks, ").ok_or_else(|| missing("cells per scan"))?,
        fold_synthetic: [ticks("synthetic folds:", "clear ")?, ticks("synthetic folds:", "far hits ")?, ticks("synthetic folds:", "near hits ")?],
        replan_empty_map: ticks("replan 0:", "replan 0: ")?,
        replan_seen_map: ticks("replan 1:", "replan 1: ")?,
        replans_ok: replan_ok("0") && replan_ok("1"),
        blocked: log.iter().any(|l| l.contains("map update:") && l.contains("blocked true")),
        state_bytes: find("state ", "state ").ok_or_else(|| missing("state size"))?,
        stack_bytes: find("done;", "stack used ").ok_or_else(|| missing("stack"))?,
        instructions_per_tick: k,
    })
}

impl PerceptionBench {
    /// The keys `cargo xtask bench` reads (instructions, rounded).
    pub fn hook_json(&self) -> serde_json::Value {
        serde_json::json!({
            "mcu_map_update_instructions": self.map_update_max.round() as u64,
            "mcu_map_update_instructions_mean": self.map_update_mean.round() as u64,
            "mcu_map_fold_synthetic_worst_instructions": self.fold_synthetic.iter().copied().fold(0.0, f64::max).round() as u64,
            "mcu_replan_instructions": self.replan_empty_map.max(self.replan_seen_map).round() as u64,
            "perception_state_bytes": self.state_bytes,
            "perception_stack_bytes": self.stack_bytes,
        })
    }
}
