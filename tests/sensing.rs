//! GNSS-like sensing (issue 27): `[sensing] position = "rtk" | "gnss"`, each receiver's error a
//! Gauss-Markov process plus a team-common one (`vt_sim::sensing`). Plant: the default
//! rigid-body quadrotors behind the PX4-style autopilot, elastic cables; the paper mission.

use host_sim::scenario::{parse, PAPER_10UAV};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;

fn with_sensing(model: &str, scale: f64) -> String {
    PAPER_10UAV.replacen("[mission]\n", &format!("[sensing]\nposition = \"{model}\"\nerror_scale = {scale}\n\n[mission]\n"), 1)
}

fn fly(text: &str, seed: u64) -> Summary {
    let ls = parse(text, "sensing.toml").expect("valid scenario");
    sim::run(&ls, &RunOptions { seed: Some(seed), record: false, ..RunOptions::default() }).expect("flies").summary
}

/// RTK-class errors (1-2 cm, correlated over a minute, shared by the team) cost the paper
/// mission nothing: every seed arrives with the floors.
#[test]
fn the_paper_mission_flies_on_rtk() {
    for seed in 100..105 {
        let s = fly(&with_sensing("rtk", 1.0), seed);
        assert!(s.success, "seed {seed}: {:?}", s.failures);
    }
}

/// A standalone receiver (1.1 m per horizontal axis) is far beyond what the paper's tube and
/// formation allow: the team leaves the tube and collides. Scaled to 5 % of it, it flies.
#[test]
fn standalone_gnss_is_survived_only_when_scaled_down_to_rtk_class() {
    let s = fly(&with_sensing("gnss", 1.0), 101);
    assert!(!s.success && s.min_uav_boundary_m < 0.0, "{s:?}");
    for seed in 100..104 {
        let s = fly(&with_sensing("gnss", 0.05), seed);
        assert!(s.success, "seed {seed}: {:?}", s.failures);
    }
}

/// A companion that refuses the start on what it measured is an outcome, not an error: the
/// run ends refused with the companion's reason (here its take-off calibration, which reads a
/// 10.9 m cable out of metre-level position errors), and nothing flies.
#[test]
fn a_start_refused_aboard_is_a_refused_run() {
    let s = fly(&with_sensing("gnss", 1.0), 114);
    assert!(s.was_refused(), "{s:?}");
    assert_eq!(s.outcome, "refused");
    assert!(s.failures.iter().any(|f| f.contains("take-off calibration")), "{:?}", s.failures);
    assert_eq!(s.sim_time_s, 0.0);
}

#[test]
fn a_bad_error_scale_is_refused_naming_the_field() {
    let e = parse(&with_sensing("gnss", -1.0), "bad.toml").unwrap_err();
    assert_eq!(e.field.as_deref(), Some("sensing.error_scale"), "{e}");
    let e = parse(&PAPER_10UAV.replacen("[mission]\n", "[sensing]\nposition = \"lidar\"\n\n[mission]\n", 1), "bad.toml").unwrap_err();
    assert!(e.line.is_some() && e.message.contains("unknown variant"), "{e}");
}
