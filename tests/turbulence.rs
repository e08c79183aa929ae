//! Dryden turbulence (`[disturbances] turbulence`, issue 27) on the paper mission. Plant: the
//! default rigid-body quadrotors behind the PX4-style autopilot, elastic cables.

use host_sim::scenario::{parse, PAPER_10UAV};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;

fn turbulent(level: f64) -> String {
    PAPER_10UAV.replacen("[mission]\n", &format!("[disturbances]\nturbulence = {level}\nwind_mean_mps = [3.0, 0.0, 0.0]\n\n[mission]\n"), 1)
}

fn fly(text: &str, seed: u64) -> Summary {
    let ls = parse(text, "turbulence.toml").expect("valid scenario");
    sim::run(&ls, &RunOptions { seed: Some(seed), record: false, ..RunOptions::default() }).expect("flies").summary
}

/// Moderate turbulence (30 kt at 20 ft: sigma_u about 2.8 m/s at the UAVs' altitude) over a
/// 3 m/s wind: the team arrives with the floors; the gusts reach the plant (the flight differs
/// from the same wind without them, and from seed to seed).
#[test]
fn the_paper_mission_flies_in_moderate_turbulence() {
    let steady = fly(&turbulent(0.0), 1);
    let mut seen = Vec::new();
    for seed in 1..4 {
        let s = fly(&turbulent(2.0), seed);
        assert!(s.success, "seed {seed}: {:?}", s.failures);
        assert_ne!(s.min_uav_uav_m, steady.min_uav_uav_m);
        seen.push(s.min_uav_uav_m);
    }
    assert!(seen.windows(2).all(|w| w[0] != w[1]), "{seen:?}");
}

#[test]
fn bad_turbulence_is_refused_naming_the_field() {
    let e = parse(&turbulent(-1.0), "bad.toml").unwrap_err();
    assert_eq!(e.field.as_deref(), Some("disturbances.turbulence"), "{e}");
    assert!(e.line.is_some());
}
