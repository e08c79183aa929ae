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

/// `host-sim generate SEED --base CAMPAIGN` writes the scenario the campaign flies for that seed
/// (its world, disturbances and draw, with the seed), so `host-sim run` of the file repeats the
/// campaign's flight bit for bit (docs/robustness.md, "Generated scenarios"). Seed 5126 of the
/// generated campaign at its first level (1x, the real-aircraft world).
#[test]
fn a_generated_file_flies_the_campaign_s_run_bit_for_bit() {
    let campaign = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/generated.toml");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["generate", "5126", "--base"])
        .arg(&campaign)
        .output()
        .expect("host-sim runs");
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).expect("utf-8");
    let written = scenario::parse(&text, "gen-5126.toml").expect("a valid scenario");
    let by_file = sim::run(&written, &RunOptions { record: false, ..RunOptions::default() }).expect("flies").summary;
    let c = host_sim::campaign::load(Some(&campaign)).expect("valid campaign");
    let rows = host_sim::campaign::fly(&c, 1, 5126, 1, false).expect("runs start");
    let by_campaign = &rows.first().expect("a row at the first level").summary;
    assert_eq!(rows.first().and_then(|r| r.level), Some(1.0));
    assert_eq!(by_file.min_uav_uav_clearance_m.to_bits(), by_campaign.min_uav_uav_clearance_m.to_bits());
    assert_eq!(by_file.completion_time_s.map(f64::to_bits), by_campaign.completion_time_s.map(f64::to_bits));
    assert_eq!(by_file.max_tension_n.to_bits(), by_campaign.max_tension_n.to_bits());
    assert_eq!((by_file.success, &by_file.failures), (by_campaign.success, &by_campaign.failures));
}
