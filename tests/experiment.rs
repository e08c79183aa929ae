//! The paper's outdoor experiment scenario (3 UAVs), dissipative controller.

use host_sim::scenario;
use host_sim::sim::{self, RunOptions};
use std::path::Path;

#[test]
fn dissipative_controller_flies_the_experiment_scenario() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let ls = scenario::load(Some(&path)).expect("valid scenario");
    let o = sim::run(&ls, &RunOptions::default()).expect("run starts");
    let s = &o.summary;
    println!(
        "experiment-3uav: success {} t_end {:?} min UAV-bnd {:.3} m min UAV-UAV {:.3} m max thrust fraction {:.2} load alt err {:.3} m",
        s.success, s.completion_time_s, s.min_uav_boundary_m, s.min_uav_uav_m, s.max_thrust_fraction, s.max_load_altitude_error_m
    );
    assert!(s.success, "failures: {:?}", s.failures);
    assert_eq!(s.n_uavs, 3);
}
