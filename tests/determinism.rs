//! Same scenario and seed give the same bits; a different seed changes a seeded run.

use host_sim::record::trajectory_csv;
use host_sim::scenario;
use host_sim::sim::{self, RunOptions};

fn lossy_scenario() -> scenario::LoadedScenario {
    // The paper scenario with a lossy, delayed link so the seed matters.
    let text = scenario::PAPER_10UAV
        .replace("delay_s = 0.0", "delay_s = 0.04")
        .replace("drop_probability = 0.0", "drop_probability = 0.2");
    scenario::parse(&text, "paper-10uav (lossy link)").expect("valid")
}

#[test]
fn same_scenario_and_seed_give_identical_trajectories() {
    let ls = lossy_scenario();
    let a = sim::run(&ls, &RunOptions { seed: Some(7), ..RunOptions::default() }).expect("run");
    let b = sim::run(&ls, &RunOptions { seed: Some(7), ..RunOptions::default() }).expect("run");
    let (ca, cb) = (trajectory_csv(&a.record), trajectory_csv(&b.record));
    assert!(ca.len() > 100_000, "trajectory unexpectedly short");
    assert!(ca == cb, "trajectory.csv differs between identical runs");
    let c = sim::run(&ls, &RunOptions { seed: Some(8), ..RunOptions::default() }).expect("run");
    assert!(trajectory_csv(&c.record) != ca, "the seed has no effect on a lossy link");
}
