//! One mission loop, three backends (issue 14): the companions called directly without framing
//! (`CompanionTeam`, what `sim::run` flies; issue 26) and the companion twin (`pil::fly` over
//! in-process `SilPort`s, MAVLink v2 on the wire) fly the same scenario on the same plant. Both hand the plant the attitude +
//! normalised thrust the firmware sends, the companion runs the same crates with the same
//! parameters, and the high level of both reads the last own sample (the firmware's lockstep
//! order), so the two must agree command for command, bit for bit. (The third backend, the
//! firmware in QEMU, is held to the twin in tests/pil.rs.)

mod common;

use common::Recording;
use host_sim::mission;
use host_sim::models::{CableModel, UavModel};
use host_sim::pil::{self, CommandKind, SilPort};
use host_sim::scenario::{self, LoadedScenario};
use host_sim::sim::RunOptions;
use host_sim::summary::Summary;
use std::path::Path;

fn load(file: &str) -> LoadedScenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios").join(file);
    scenario::load(Some(&path)).expect("valid scenario")
}

/// The summary without the fields that measure the host (wall time, realtime factor).
fn comparable(s: &Summary) -> serde_json::Value {
    let mut v = serde_json::to_value(s).expect("serialises");
    if let Some(o) = v.as_object_mut() {
        o.remove("wall_time_s");
        o.remove("realtime_factor");
    }
    v
}

fn assert_same(file: &str, uav: UavModel, cable: CableModel) {
    assert_same_scenario(&load(file), file, uav, cable);
}

fn assert_same_scenario(ls: &LoadedScenario, file: &str, uav: UavModel, cable: CableModel) {
    assert_same_flight(ls, file, uav, cable, true);
}

/// The two backends fly `ls` command for command (`must_succeed`: and the mission succeeds).
fn assert_same_flight(ls: &LoadedScenario, file: &str, uav: UavModel, cable: CableModel, must_succeed: bool) -> Summary {
    let ls = ls.clone();
    let opts = RunOptions { record: false, uav_model: Some(uav), cable_model: Some(cable), ..RunOptions::default() };
    let mut crates = Recording::new();
    let a = mission::fly(&ls, &opts, &mut crates).expect("crates backend flies").summary;
    let mut ports: Vec<SilPort> = (0..ls.scenario.cables.lengths_m.len()).map(|_| SilPort::new()).collect();
    let twin = pil::fly(&ls, &mut ports, &opts, "twin").expect("twin backend flies");
    let b = twin.summary;
    let label = format!("{file} {}/{}", uav.name(), cable.name());
    println!(
        "{label}: success {} / {}, completion {:?} s, UAV-bnd {:.4} m, UAV-UAV {:.4} m, {} setpoints each",
        a.success,
        b.success,
        a.completion_time_s,
        a.min_uav_boundary_m,
        a.min_uav_uav_m,
        crates.commands.len()
    );
    assert!(a.success || !must_succeed, "{label}: {:?}", a.failures);
    let twin_cmds: Vec<(u64, usize, Vec<f32>)> =
        twin.commands.iter().filter(|c| c.kind == CommandKind::Attitude).map(|c| (c.step, c.uav, c.values.clone())).collect();
    assert_eq!(crates.commands.len(), twin_cmds.len(), "{label}: number of setpoints");
    if let Some((x, y)) = crates.commands.iter().zip(&twin_cmds).find(|(x, y)| x != y) {
        panic!("{label}: first differing setpoint: crates {x:?}, twin {y:?}");
    }
    assert_eq!(comparable(&a), comparable(&b), "{label}: summaries");
    a
}

#[test]
fn crates_and_twin_fly_the_experiment_identically_on_the_point_mass_plant() {
    assert_same("experiment-3uav.toml", UavModel::PointMass, CableModel::PaperClamp);
}

#[test]
fn crates_and_twin_fly_the_paper_mission_identically_on_the_point_mass_plant() {
    assert_same("paper-10uav.toml", UavModel::PointMass, CableModel::PaperClamp);
}

#[test]
fn crates_and_twin_fly_the_experiment_identically_on_the_rigid_body_plant() {
    assert_same("experiment-3uav.toml", UavModel::RigidBody, CableModel::Elastic);
}

/// Issue 27: the ground start (lift-off, transport, set-down) is the companion's, so the twin
/// flies it bit for bit too.
#[test]
fn crates_and_twin_fly_the_experiment_from_the_ground_identically() {
    let mut ls = load("experiment-3uav.toml");
    ls.scenario.mission.start = host_sim::scenario::MissionStart::Ground;
    assert_same_scenario(&ls, "experiment-3uav.toml (ground)", UavModel::RigidBody, CableModel::Elastic);
}

#[test]
fn crates_and_twin_fly_the_paper_mission_identically_on_the_rigid_body_plant() {
    assert_same("paper-10uav.toml", UavModel::RigidBody, CableModel::Elastic);
}

/// With 100 ms of sensor latency the own and load states carry their sample times
/// (`time_boot_ms`) and the host sends `SYSTEM_TIME` (docs/protocol.md): the twin's clock, its
/// delay compensation and the crates' must still agree bit for bit.
#[test]
fn crates_and_twin_compensate_latency_identically_on_the_rigid_body_plant() {
    let mut ls = load("paper-10uav.toml");
    ls.scenario.disturbances.latency_s = 0.1;
    ls.scenario.disturbances.velocity_noise_mps = 0.02;
    assert_same_scenario(&ls, "paper-10uav.toml + 100 ms latency", UavModel::RigidBody, CableModel::Elastic);
}

/// Issue 28 on the wire: the twin's companions get their LiDAR scans as `OBSTACLE_DISTANCE`,
/// their map's configuration as `PR_*` parameters, and the planner's tube offers as pushed
/// missions relayed by the team network; SIL calls the same companion code without the bytes.
/// The two fly the same commands, re-plans and switches, a re-route included.
#[test]
fn crates_and_twin_fly_unknown_maps_identically() {
    for file in ["yard-3uav-unknown.toml", "reroute-3uav-unknown.toml"] {
        let a = assert_same_flight(&load(file), file, UavModel::RigidBody, CableModel::Elastic, false);
        let p = a.perception.as_ref().expect("perception figures");
        println!("{file}: {p:?}");
        assert!(p.replans > 0 && p.tube_switches > 0, "{file}: the team re-planned and switched ({p:?})");
    }
}

/// A refusal on the ground reads the same on both backends, in the companion's own words: the
/// experiment's team from the ground with a declared 30 m/s wind is refused at its arming
/// (code 8), lands at once, and the failure quotes its `STATUSTEXT` with the numbers (SIL reads
/// them from the companion, the twin from the wire).
#[test]
fn crates_and_twin_report_a_refusal_on_the_ground_in_the_same_words() {
    let mut ls = load("experiment-3uav.toml");
    ls.scenario.mission.start = scenario::MissionStart::Ground;
    ls.scenario.mission.max_wind_mps = Some(30.0);
    let s = assert_same_flight(&ls, "experiment-3uav.toml (ground, 30 m/s declared)", UavModel::RigidBody, CableModel::Elastic, false);
    println!("{:?}", s.failures);
    assert_eq!(s.outcome, "refused");
    let first = &s.failures[0];
    assert!(first.starts_with("refused on the ground: UAV 0: ") && first.contains("(refusal code 8): \"start refused: "), "{first}");
    // The declared 30 m/s plus the scenario's gust margin, against the team's capacity.
    assert!(first.contains("wind 30.") && first.contains("m/s > cap ") && first.contains("(tilt)"), "the numbers: {first}");
}

/// A team near its capacity flies dashpots beside its springs on its neighbours' velocities
/// (docs/design.md, "A dashpot beside the springs of a team near its capacity"): SIL hands the
/// companions the velocities the link delivered, the twin sends them in the members'
/// `LOCAL_POSITION_NED` (`vx`, `vy`, `vz`). `payload-packed` at 19.8 kg on the 20 N clamp, in the
/// real-aircraft world (its capacity margin 0.4 %: the dashpots on), seed 7105, flies command
/// for command on both. Before the dashpots this seed lost a pair at 0.19 m.
#[test]
fn crates_and_twin_fly_the_dashpots_of_a_team_near_its_capacity_identically() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/payload-packed.toml");
    let c = host_sim::campaign::load_in(Some(&p), Some(host_sim::campaign::World::RealAircraft)).expect("campaign is valid");
    let l = c.levels.iter().position(|(l, _)| *l == Some(19.8)).expect("19.8 kg is a level");
    let (ls, _, _) = host_sim::campaign::scenario_of(&c, l, 7105).expect("the level's scenario");
    let mut ls = ls.into_owned();
    ls.scenario.seed = 7105;
    let s = assert_same_flight(&ls, "payload-packed.toml (19.8 kg, seed 7105)", UavModel::RigidBody, CableModel::PaperClamp, true);
    assert!(s.min_uav_uav_clearance_m >= 0.2, "pairs apart: {} m", s.min_uav_uav_clearance_m);
}
