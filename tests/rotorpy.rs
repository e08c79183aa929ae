//! Issue 26: a flight in a physics engine nobody here wrote. `host-sim sitl --plant rotorpy`
//! flies the experiment in RotorPy (Python, pymavlink) with unchanged `vt-companion` processes,
//! uploaded and started by host-sim's ground station, and scores the trajectory with the
//! project's own metrics; `host-sim score` gives the same verdict from the file alone.
//!
//! Needs a Python with `rotorpy` and `pymavlink` (`scripts/test-all.sh` makes
//! `target/rotorpy-venv`). Without one the flight is skipped, unless `VT_REQUIRE_ROTORPY=1`
//! (the test command sets it), where that is a failure.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn host_sim(args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_host-sim")).args(args).output().unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr))
}

fn summary(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

fn rotorpy_available() -> bool {
    match host_sim::sitl::rotorpy::check_python() {
        Ok(()) => true,
        Err(e) => {
            assert!(std::env::var("VT_REQUIRE_ROTORPY").as_deref() != Ok("1"), "VT_REQUIRE_ROTORPY=1: {e}");
            eprintln!("skipped: {e}");
            false
        }
    }
}

#[test]
fn the_experiment_flies_in_rotorpy_with_its_floors_and_scores_the_same_from_the_file() {
    if !rotorpy_available() {
        return;
    }
    let scenario = repo().join("scenarios/experiment-3uav.toml");
    let out = std::env::temp_dir().join(format!("vt-rotorpy-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let (code, text) = host_sim(&["sitl", scenario.to_str().unwrap(), "--plant", "rotorpy", "--out", out.to_str().unwrap()]);
    println!("{text}");
    assert_eq!(code, Some(0), "the mission succeeds in RotorPy: {text}");
    let s = summary(&out);
    assert_eq!(s["plant"], "rotorpy");
    assert_eq!(s["success"], true, "{}", s["failures"]);
    // The scenario's own floors (safety_distance_m 0.4 m), centre to centre as for the host.
    let floor = 0.4;
    for key in ["min_uav_uav_m", "min_uav_boundary_m"] {
        assert!(s[key].as_f64().unwrap() >= floor, "{key} = {} below the floor", s[key]);
    }
    assert_eq!(s["cables_broken"], 0);
    assert!(s["max_load_altitude_error_m"].as_f64().unwrap() < 1.0);
    // The plant's own file, at the low-level rate (500 Hz): well over the 20 Hz record.
    let raw = out.join("rotorpy_trajectory.csv");
    let rows = std::fs::read_to_string(&raw).unwrap().lines().count() - 1;
    let sim_s = s["sim_time_s"].as_f64().unwrap();
    assert!(rows as f64 >= 499.0 * sim_s, "{rows} rows for {sim_s} s");
    // Every companion was told to stop with Ctrl-C and exited 0.
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("sitl_report.json")).unwrap()).unwrap();
    assert_eq!(report["companion_exit_codes"], serde_json::json!([0, 0, 0]));
    // `host-sim score` on the file alone: the same verdict and distances.
    let rescored = out.join("rescored");
    let (code, text) = host_sim(&["score", raw.to_str().unwrap(), scenario.to_str().unwrap(), "--plant", "rotorpy", "--out", rescored.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{text}");
    let r = summary(&rescored);
    for key in ["success", "plant", "min_uav_uav_m", "min_uav_boundary_m", "min_load_boundary_m", "completion_time_s", "max_tension_n"] {
        assert_eq!(r[key], s[key], "{key}");
    }
    // A corrupted file is bad input: exit 2 naming the file, the line and the column.
    let text = std::fs::read_to_string(&raw).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<String> = lines[10].split(',').map(String::from).collect();
    fields[3] = "tall".into();
    lines[10] = fields.join(",");
    let bad = out.join("bad.csv");
    std::fs::write(&bad, lines.join("\n")).unwrap();
    let (code, text) = host_sim(&["score", bad.to_str().unwrap(), scenario.to_str().unwrap(), "--out", out.join("bad").to_str().unwrap()]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains(&format!("{}:11: column `uav0_z_m`: `tall` is not a number", bad.display())), "{text}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn rotorpy_refuses_what_its_plant_does_not_model_and_real_time() {
    let campaign_base = repo().join("scenarios/experiment-3uav.toml");
    let text = std::fs::read_to_string(&campaign_base).unwrap()
        + "\n[[faults]]\nkind = \"cable_snap\"\ntime_s = 5.0\nuav = 1\n";
    let dir = std::env::temp_dir().join(format!("vt-rotorpy-refuse-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let with_fault = dir.join("fault.toml");
    std::fs::write(&with_fault, text).unwrap();
    let (code, text) = host_sim(&["sitl", with_fault.to_str().unwrap(), "--plant", "rotorpy", "--out", dir.join("o").to_str().unwrap()]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("[[faults]]") && text.contains("--plant host"), "{text}");
    let (code, text) = host_sim(&["sitl", campaign_base.to_str().unwrap(), "--plant", "rotorpy", "--realtime"]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("lockstep only"), "{text}");
    let (code, text) = host_sim(&["sitl", campaign_base.to_str().unwrap(), "--plant", "gazebo"]);
    assert_eq!(code, Some(2), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
