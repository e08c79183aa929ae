//! Team failsafe (issue 15, docs/design.md "Team failsafe") in SIL on the default plant
//! (rigid-body quadrotors, elastic cables): one UAV's own position feed stalls for 2 s mid-tube,
//! and one UAV's team link dies for good. The same flights through the companion twin are
//! bit-identical to the crates' (the QEMU side is in tests/pil.rs).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

mod common;

use common::Recording;
use host_sim::mission;
use host_sim::pil::{self, CommandKind, SilPort};
use host_sim::record::{EventKind, RunRecord};
use host_sim::scenario::{self, FaultKind, FaultSpec, LoadedScenario, StaleNeighbour};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;
use std::path::Path;
use vt_dissipative::TeamMode;

fn load(file: &str) -> LoadedScenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios").join(file);
    scenario::load(Some(&path)).expect("valid scenario")
}

/// `file` with one fault on `uav` at `time_s` (`duration_s` for a stall) and the stale-neighbour
/// policy `stale`.
fn with_fault(file: &str, kind: FaultKind, uav: usize, time_s: f64, duration_s: Option<f64>, stale: StaleNeighbour) -> LoadedScenario {
    let mut ls = load(file);
    ls.scenario.faults.push(FaultSpec { kind, uav, time_s, duration_s });
    ls.scenario.failsafe.stale_neighbour = stale;
    ls
}

/// Hold intervals `[start, end)` per UAV from the record's events (end: `f64::INFINITY` if
/// still holding at the end).
fn hold_intervals(rec: &RunRecord, n: usize) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new(); n];
    let mut open: Vec<Option<f64>> = vec![None; n];
    for e in &rec.events {
        match e.kind {
            EventKind::Hold => open[e.uav] = Some(e.time_s),
            EventKind::Resume => {
                if let Some(t0) = open[e.uav].take() {
                    out[e.uav].push((t0, e.time_s));
                }
            }
            _ => {}
        }
    }
    for (o, v) in open.iter().zip(out.iter_mut()) {
        if let Some(t0) = o {
            v.push((*t0, f64::INFINITY));
        }
    }
    out
}

/// The load's arc position along the tube at the record sample nearest `t`, m.
fn load_s_at(ls: &LoadedScenario, rec: &RunRecord, t: f64) -> f64 {
    let k = rec.time_s.iter().position(|&x| x >= t).unwrap_or(rec.time_s.len() - 1);
    let p = rec.load_pos_m[k];
    f64::from(ls.tube.locate(nalgebra::Vector2::new(p[0] as f32, p[1] as f32), 0).unwrap().s_m)
}

fn print(label: &str, s: &Summary) {
    println!(
        "{label}: success {} {:?}, completion {:?} s, UAV-UAV {:.3} m, UAV-boundary {:.3} m, load-boundary {:.3} m, load alt err {:.3} m, max tension {:.1} N ({} / {})",
        s.success, s.failures, s.completion_time_s, s.min_uav_uav_m, s.min_uav_boundary_m, s.min_load_boundary_m, s.max_load_altitude_error_m, s.max_tension_n, s.uav_model, s.cable_model
    );
}

const STALL_UAV: usize = 3;
const STALL_AT_S: f64 = 18.0;
const STALL_S: f64 = 2.0;

/// The paper mission's own-position feed of UAV 3 stalls for 2 s at 18 s (mid-tube; the
/// mission takes 37.5 s without faults): the team holds with it and resumes together; no
/// collision, tube kept, the load arrives.
#[test]
fn own_feed_stall_mid_tube_the_team_holds_resumes_and_completes() {
    let ls = with_fault("paper-10uav.toml", FaultKind::OwnFeedStall, STALL_UAV, STALL_AT_S, Some(STALL_S), StaleNeighbour::Drop);
    let n = ls.scenario.cables.lengths_m.len();
    let out = sim::run(&ls, &RunOptions::default()).unwrap();
    let s = &out.summary;
    print("own feed stall", s);
    assert_eq!((s.uav_model.as_str(), s.cable_model.as_str()), ("rigid_body", "elastic"), "the default plant");
    assert!(s.success, "{:?}", s.failures);
    assert!(s.reached_end && s.completion_time_s.is_some(), "the load arrives");
    assert!(s.min_uav_uav_m >= 0.4, "UAVs came within {:.3} m", s.min_uav_uav_m);
    assert!(s.min_uav_boundary_m > 0.0 && s.min_load_boundary_m > 0.0, "tube boundary crossed");
    assert!(!s.nonfinite);
    // Every UAV held, once: the stalled one from its own detection (FS_OWN_TMO after the
    // stall began), the others with it within two high-level periods.
    let holds = hold_intervals(&out.record, n);
    let resume_s = ls.scenario.failsafe.resume_s;
    let hl = 1.0 / f64::from(ls.scenario.rates.high_level_hz);
    for (i, h) in holds.iter().enumerate() {
        println!("  UAV {i}: hold {h:?}");
        assert_eq!(h.len(), 1, "UAV {i} held once: {h:?}");
        let (t0, t1) = h[0];
        assert!(t0 > STALL_AT_S && t0 < STALL_AT_S + pil::OWN_TIMEOUT_S as f64 + 3.0 * hl, "UAV {i} held at {t0} s");
        // Resumed together, FS_RESUME after the stall ended.
        let end = STALL_AT_S + STALL_S + resume_s;
        assert!(t1 >= end - 1e-9 && t1 < end + 4.0 * hl, "UAV {i} resumed at {t1} s (stall end + resume {end} s)");
    }
    let (first, last) = holds.iter().map(|h| h[0].1).fold((f64::MAX, 0.0f64), |(a, b), t| (a.min(t), b.max(t)));
    assert!(last - first <= 2.0 * hl + 1e-9, "the team resumed within {} s", last - first);
    // The team stopped: after 1 s of hold, the load moves less than 0.3 m more (at 1.5 m/s it
    // would cover 3 m in those 2 s).
    let held = load_s_at(&ls, &out.record, STALL_AT_S + STALL_S + resume_s) - load_s_at(&ls, &out.record, STALL_AT_S + 1.0);
    let before = load_s_at(&ls, &out.record, STALL_AT_S) - load_s_at(&ls, &out.record, STALL_AT_S - 2.0);
    println!("  load progress: {before:.2} m in the 2 s before the stall, {held:.2} m over the last {:.1} s of the hold", STALL_S - 1.0 + resume_s);
    assert!(before > 1.0, "the team was moving before the stall ({before:.2} m in 2 s)");
    assert!(held.abs() < 0.3, "the load moved {held:.2} m while the team held");
}

/// UAV 3's team link dies at 18 s. The team holds (docs/design.md says why) with the
/// stale-neighbour policy `hold`, and stays in the tube, apart and at altitude to the end.
#[test]
fn link_dead_the_team_holds_in_the_tube_to_the_end() {
    let mut ls = with_fault("paper-10uav.toml", FaultKind::LinkDead, STALL_UAV, STALL_AT_S, None, StaleNeighbour::Hold);
    ls.scenario.mission.time_limit_s = 60.0; // 42 s of hold after the fault
    let n = ls.scenario.cables.lengths_m.len();
    let out = sim::run(&ls, &RunOptions::default()).unwrap();
    let s = &out.summary;
    print("link dead, hold", s);
    assert_eq!((s.uav_model.as_str(), s.cable_model.as_str()), ("rigid_body", "elastic"), "the default plant");
    assert!(!s.reached_end, "the team holds: no arrival");
    assert_eq!(s.failures.len(), 1, "only the arrival criterion fails: {:?}", s.failures);
    assert!(s.min_uav_uav_m >= 0.4, "UAVs came within {:.3} m", s.min_uav_uav_m);
    assert!(s.min_uav_boundary_m > 0.0 && s.min_load_boundary_m > 0.0, "tube boundary crossed");
    assert!(s.max_load_altitude_error_m < ls.scenario.mission.altitude_tolerance_m);
    assert!(!s.nonfinite && s.cables_broken == 0);
    // Every UAV holds from within the stale timeout (+ a high-level period) to the end.
    let stale = ls.scenario.link.stale_timeout_s;
    let hl = 1.0 / f64::from(ls.scenario.rates.high_level_hz);
    for (i, h) in hold_intervals(&out.record, n).iter().enumerate() {
        println!("  UAV {i}: hold {h:?}");
        assert_eq!(h.len(), 1, "UAV {i}: {h:?}");
        assert!(h[0].0 > STALL_AT_S && h[0].0 <= STALL_AT_S + stale + 3.0 * hl, "UAV {i} held at {} s", h[0].0);
        assert_eq!(h[0].1, f64::INFINITY, "UAV {i} resumed");
    }
    // The held team stops within 2 m of where the hold began (momentum: it was moving at
    // about 1.4 m/s) and comes to rest there: the frozen tray centre anchors it.
    let t_hold = STALL_AT_S + stale;
    let s_hold = load_s_at(&ls, &out.record, t_hold);
    let excursion = out.record.time_s.iter().filter(|&&t| t >= t_hold).map(|&t| (load_s_at(&ls, &out.record, t) - s_hold).abs()).fold(0.0, f64::max);
    let creep = load_s_at(&ls, &out.record, 60.0) - load_s_at(&ls, &out.record, 50.0);
    println!("  load: s {s_hold:.2} m at the hold, largest excursion {excursion:.2} m, {creep:+.3} m over the last 10 s");
    assert!(excursion < 2.0, "the held load moved {excursion:.2} m from where the hold began");
    assert!(creep.abs() < 0.1, "the held load still moves: {creep:+.3} m in 10 s");
}

/// The alternative to holding (docs/design.md, "Team failsafe"): flying on without the dead
/// UAV (`stale_neighbour = "drop"`) delivers the load, but nobody keeps clear of the UAV that no
/// longer hears the team and that the team no longer sees; the hold keeps every pair farther
/// apart. Same fault, same plant.
#[test]
fn link_dead_flying_on_arrives_but_keeps_the_team_closer_than_holding() {
    let drop = with_fault("paper-10uav.toml", FaultKind::LinkDead, STALL_UAV, STALL_AT_S, None, StaleNeighbour::Drop);
    let d = sim::run(&drop, &RunOptions::default()).unwrap().summary;
    print("link dead, drop (fly on)", &d);
    let mut hold = with_fault("paper-10uav.toml", FaultKind::LinkDead, STALL_UAV, STALL_AT_S, None, StaleNeighbour::Hold);
    hold.scenario.mission.time_limit_s = drop.scenario.mission.time_limit_s;
    let h = sim::run(&hold, &RunOptions::default()).unwrap().summary;
    assert!(!d.nonfinite && d.reached_end, "flying on delivers the load");
    assert!(!h.reached_end, "holding does not");
    assert!(h.min_uav_uav_m >= 0.4 && h.min_uav_uav_m > d.min_uav_uav_m, "hold {:.3} m, fly on {:.3} m", h.min_uav_uav_m, d.min_uav_uav_m);
}

/// Crates and companion twin fly `ls` command for command, bit for bit; returns the crates'
/// summary and whether anyone held.
fn assert_crates_equal_twin(label: &str, ls: &LoadedScenario) -> Summary {
    let opts = RunOptions { record: true, ..RunOptions::default() };
    let mut crates = Recording::new();
    let a = mission::fly(ls, &opts, &mut crates).unwrap();
    let mut ports: Vec<SilPort> = (0..ls.scenario.cables.lengths_m.len()).map(|_| SilPort::new()).collect();
    let twin = pil::fly(ls, &mut ports, &opts, "twin").unwrap();
    print(label, &a.summary);
    let twin_cmds: Vec<(u64, usize, Vec<f32>)> =
        twin.commands.iter().filter(|c| c.kind == CommandKind::Attitude).map(|c| (c.step, c.uav, c.values.clone())).collect();
    assert_eq!(crates.commands.len(), twin_cmds.len(), "{label}: number of setpoints");
    if let Some((x, y)) = crates.commands.iter().zip(&twin_cmds).find(|(x, y)| x != y) {
        panic!("{label}: first differing setpoint: crates {x:?}, twin {y:?}");
    }
    assert!(crates.modes.contains(&TeamMode::Hold), "{label}: someone held");
    assert_eq!(a.record.events, twin.record.events, "{label}: same faults, holds and resumes");
    a.summary
}

#[test]
fn crates_and_twin_fly_the_own_feed_stall_identically() {
    let ls = with_fault("experiment-3uav.toml", FaultKind::OwnFeedStall, 1, 15.0, Some(STALL_S), StaleNeighbour::Hold);
    let s = assert_crates_equal_twin("experiment, own feed stall", &ls);
    assert!(s.success, "{:?}", s.failures);
    let ls = with_fault("paper-10uav.toml", FaultKind::OwnFeedStall, STALL_UAV, STALL_AT_S, Some(STALL_S), StaleNeighbour::Drop);
    assert!(assert_crates_equal_twin("paper, own feed stall", &ls).success);
}

#[test]
fn crates_and_twin_fly_the_dead_link_identically() {
    let mut ls = with_fault("experiment-3uav.toml", FaultKind::LinkDead, 2, 15.0, None, StaleNeighbour::Hold);
    ls.scenario.mission.time_limit_s = 30.0;
    let s = assert_crates_equal_twin("experiment, link dead", &ls);
    assert!(!s.reached_end && s.min_uav_uav_m >= 0.4 && s.min_uav_boundary_m > 0.0);
}
