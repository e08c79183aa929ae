//! The autopilot flies on an attitude estimate (issue 27 §3, `[sensing] attitude = "px4"`): a
//! gyro with the ADIS16448's noise and a residual bias behind PX4's 40 Hz `IMU_GYRO_CUTOFF`
//! low-pass, and an attitude estimate that lags the truth and carries a tilt misalignment.
//! Plant: rigid-body quadrotors behind the PX4-style autopilot, elastic cables; the paper mission.

mod common;

use host_sim::scenario::{parse, PAPER_10UAV};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;

const NOMINAL: &str =
    "[disturbances]\nposition_noise_m = 0.05\nvelocity_noise_mps = 0.05\nlatency_s = 0.02\nlink_jitter_s = 0.02\nwind_mean_mps = [3.0, 0.0, 0.0]\ngust_std_mps = 1.0\n\n";

/// The paper mission with the attitude estimate (errors times `scale`), on stock PX4 rate gains
/// with the observer's lag matched to them (tests/stock_autopilot.rs) when `stock`, under the
/// nominal campaign's sensing, latency and wind when `disturbed`.
fn scenario(scale: f64, stock: bool, disturbed: bool) -> String {
    let mut pre = format!("[sensing]\nattitude = \"px4\"\nattitude_error_scale = {scale}\n\n");
    if disturbed {
        pre.push_str(NOMINAL);
    }
    let mut t = PAPER_10UAV.replacen("[mission]\n", &format!("{pre}[mission]\n"), 1);
    if stock {
        t = t.replacen("[uavs]\n", "[uavs]\nautopilot = \"px4_default\"\n", 1).replacen("actuator_lag_s = 0.05", "actuator_lag_s = 0.08", 1);
    }
    t
}

fn fly(text: &str, seed: u64) -> Summary {
    let ls = parse(text, "attitude.toml").expect("valid scenario");
    sim::run(&ls, &RunOptions { seed: Some(seed), record: false, ..RunOptions::default() }).expect("flies").summary
}

/// With the estimate, calm, on the tuned and on the stock gains; and on the stock gains under
/// the nominal disturbances with ten times the sensor errors (0.5 deg/s of residual bias, 2 deg
/// of misalignment). The estimate is real: the flight differs from one on the true state.
#[test]
fn the_paper_mission_flies_on_an_attitude_estimate_and_stock_gains() {
    let truth = fly(PAPER_10UAV, 1);
    let tuned = fly(&scenario(1.0, false, false), 1);
    assert!(tuned.success, "{:?}", tuned.failures);
    assert_ne!(tuned.min_uav_boundary_m, truth.min_uav_boundary_m, "the estimate changed nothing");
    let stock = fly(&scenario(1.0, true, false), 1);
    assert!(stock.success, "{:?}", stock.failures);
    for seed in 100..103 {
        let s = fly(&scenario(10.0, true, true), seed);
        println!("seed {seed}: UAV-UAV {:.3} m, UAV-boundary {:.3} m", s.min_uav_uav_m, s.min_uav_boundary_m);
        assert!(s.success, "seed {seed}: {:?}", s.failures);
    }
}

/// A point mass has no attitude: the estimate is refused with the file, line and field.
#[test]
fn the_attitude_estimate_needs_the_rigid_body() {
    let text = scenario(1.0, false, false).replacen("[uavs]\n", "[uavs]\nmodel = \"point_mass\"\n", 1);
    common::expect_exit_2("attitude", &text, "point.toml", &["point.toml", "sensing.attitude", "rigid-body"]);
    let bad = scenario(-1.0, false, false);
    common::expect_exit_2("attitude-scale", &bad, "scale.toml", &["sensing.attitude_error_scale"]);
}
