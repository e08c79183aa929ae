//! The 100-UAV scaled mission (issue 5's scalability scenario, `docs/benchmarks.md`): the same
//! controller and code path as the paper's 10 UAVs, flown to the end.

use host_sim::scenario;
use host_sim::sim::{self, RunOptions};
use std::path::Path;

#[test]
fn dissipative_controller_flies_the_100_uav_scaled_mission() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/scale-100uav.toml");
    let ls = scenario::load(Some(&path)).expect("valid scenario");
    let o = sim::run(&ls, &RunOptions { record: false, ..RunOptions::default() }).expect("run starts");
    let s = &o.summary;
    println!(
        "scale-100uav: success {} t_end {:?} min UAV-bnd {:.3} m min UAV-UAV {:.3} m max tension {:.1} N load alt err {:.3} m formation err end {:.3} m, {:.0}x real time",
        s.success,
        s.completion_time_s,
        s.min_uav_boundary_m,
        s.min_uav_uav_m,
        s.max_tension_n,
        s.max_load_altitude_error_m,
        s.formation_error_end_m,
        s.realtime_factor
    );
    assert_eq!(s.n_uavs, 100);
    assert!(s.success, "failures: {:?}", s.failures);
    assert_eq!(s.cables_broken, 0, "breaks: {:?}", s.cable_breaks);
}
