//! Whole-mission realtime factor: flies a scenario with host-sim's runner (in this process,
//! one thread) and reads `realtime_factor` (simulated seconds per wall second of the loop).

use std::path::Path;

use host_sim::models::{CableModel, UavModel};
use host_sim::scenario;
use host_sim::sim::{self, RunOptions};
use serde_json::{json, Value};

/// The result of flying one scenario `runs` times.
#[derive(Debug, Clone)]
pub struct MissionBench {
    /// Median realtime factor over the runs.
    pub realtime_factor: f64,
    /// Every run's realtime factor.
    pub runs: Vec<f64>,
    /// Team size.
    pub n_uavs: usize,
    /// Summary of the first run (success, distances, times) as JSON.
    pub summary: Value,
}

/// Flies `path` `runs` times (at least once) with the scenario's defaults on UAV model
/// `uav_model` (with the paper's clamped cable for `point_mass`, whose figures continue the
/// project's history; `None`: the scenario's plant).
///
/// # Errors
/// The scenario does not load (the message is host-sim's), or the run cannot start.
pub fn run(path: &Path, runs: usize, uav_model: Option<UavModel>) -> Result<MissionBench, String> {
    let ls = scenario::load(Some(path)).map_err(|e| e.to_string())?;
    let cable_model = (uav_model == Some(UavModel::PointMass)).then_some(CableModel::PaperClamp);
    let opts = RunOptions { progress: false, uav_model, cable_model, ..RunOptions::default() };
    let mut factors = Vec::with_capacity(runs.max(1));
    let mut summary = Value::Null;
    let n_uavs = ls.scenario.cables.lengths_m.len();
    for k in 0..runs.max(1) {
        let out = sim::run(&ls, &opts).map_err(|e| e.to_string())?;
        let s = &out.summary;
        factors.push(s.realtime_factor);
        if k == 0 {
            summary = json!({
                "scenario": s.scenario,
                "n_uavs": s.n_uavs,
                "uav_model": s.uav_model,
                "cable_model": s.cable_model,
                "success": s.success,
                "failures": s.failures,
                "completion_time_s": s.completion_time_s,
                "sim_time_s": s.sim_time_s,
                "wall_time_s": s.wall_time_s,
                "min_uav_boundary_m": s.min_uav_boundary_m,
                "min_uav_uav_m": s.min_uav_uav_m,
                "max_tension_n": s.max_tension_n,
                "max_load_altitude_error_m": s.max_load_altitude_error_m,
                "formation_error_end_m": s.formation_error_end_m,
                "capacity_margin": s.capacity_margin,
            });
        }
    }
    Ok(MissionBench { realtime_factor: median(&factors), runs: factors, n_uavs, summary })
}

/// `host-sim sitl`'s lockstep wall time over the SIL twin's on `path` (issue 26).
///
/// # Errors
/// The scenario does not load, the companion cannot be built, or the flight failed or was not
/// bit-exact.
pub fn sitl_overhead(path: &Path) -> Result<f64, String> {
    let ls = scenario::load(Some(path)).map_err(|e| e.to_string())?;
    let bin = host_sim::sitl::companion_binary().map_err(|e| e.0)?;
    let opts = RunOptions { progress: false, record: false, ..RunOptions::default() };
    let (_, report, _) = host_sim::sitl::sitl_lockstep(&ls, &opts, &bin).map_err(|e| e.0)?;
    if report.bit_exact != Some(true) {
        return Err(format!("not bit-exact: {:?}", report.first_difference));
    }
    Ok(report.lockstep_overhead)
}

/// Median of a non-empty list (mean of the middle two for an even length); NaN when empty.
pub fn median(xs: &[f64]) -> f64 {
    let mut v: Vec<f64> = xs.iter().copied().filter(|x| !x.is_nan()).collect();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    match (v.get(m.wrapping_sub(1)), v.get(m)) {
        (_, None) => f64::NAN,
        (Some(a), Some(b)) if v.len().is_multiple_of(2) => 0.5 * (a + b),
        (_, Some(b)) => *b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_lists() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }
}
