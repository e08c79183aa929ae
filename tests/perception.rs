//! Issue 28, first part: tubes generated in flight in the SIL backend. Every UAV carries the
//! simulated LiDAR (`vt-sim/src/lidar.rs`); every companion fuses scans into its onboard map
//! and the lowest healthy id re-plans (`vt_companion::perception`). Plant: the default
//! rigid-body quadrotors behind the PX4-style autopilot, elastic cables.
//!
//! What is asserted is what holds today. The paper's world with the map unknown is flown to
//! the goal clear of every obstacle, but not yet within its floors in every seed (a UAV joining
//! a new tube is measured against it before it is inside; docs/design.md, "Tubes generated in
//! flight"): no test here claims a success the flights do not have.

use host_sim::scenario::{self, LoadedScenario};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;
use std::path::Path;

fn load(file: &str) -> LoadedScenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios").join(file);
    scenario::load(Some(&path)).unwrap_or_else(|e| panic!("{e}"))
}

fn fly(ls: &LoadedScenario) -> Summary {
    sim::run(ls, &RunOptions { record: false, ..RunOptions::default() }).expect("flies").summary
}

/// The paper's world, map unknown: the team starts on the straight tube planned on the bounds
/// alone (which crosses obstacles), maps with its LiDARs, re-plans around what it sees and
/// brings the load to the goal on a path within 1.3x of the known-map plan's. Same seed, same
/// bits.
#[test]
fn the_paper_world_unknown_is_mapped_and_flown_to_the_goal_on_replanned_tubes() {
    let ls = load("paper-10uav-unknown.toml");
    let s = fly(&ls);
    let p = s.perception.clone().expect("a perception summary");
    eprintln!("paper unknown: {p:?}, completion {:?} s, clearances {} / {} / {} m", s.completion_time_s, s.min_uav_uav_clearance_m, s.min_uav_boundary_clearance_m, s.min_obstacle_clearance_m);
    assert!(s.completion_time_s.is_some(), "the load reached the goal: {:?}", s.failures);
    assert!(p.replans >= 10 && p.planned >= 10, "{p:?}");
    assert!(p.tube_switches >= 10, "the team flew re-planned tubes: {p:?}");
    assert!(!p.no_route);
    assert!(p.path_ratio > 0.9 && p.path_ratio <= 1.3, "path over the known-map plan's: {p:?}");
    // No body, load or cable comes near an obstacle (it came 0.8-1.9 m into them before UAVs
    // outside a new tube joined it widened: docs/design.md, "Joining a re-planned tube").
    assert!(s.min_obstacle_clearance_m > 0.5, "obstacle clearance {} m", s.min_obstacle_clearance_m);
    // 33,600 four-bit cells (70 x 30 m at 0.25 m), the store's two 256-byte tables and the
    // grid's header.
    assert!(p.map_ram_bytes >= 16_800 + 512 && p.map_ram_bytes < 16_800 + 600, "{}", p.map_ram_bytes);
    let again = fly(&ls);
    assert_eq!(serde_json::to_string(&again.perception).unwrap(), serde_json::to_string(&s.perception).unwrap());
    assert_eq!(again.min_uav_uav_m.to_bits(), s.min_uav_uav_m.to_bits(), "deterministic");
}

/// The paper's world unknown, flown by the paper team with its 0.445 m bodies declared, the
/// formation shaped to the tube and a 0.2 m floor. The onboard map sees the passages narrower
/// than the known map's plan through the LiDAR's 5 deg sectors, often under the 2.1-2.2 m in
/// which the separated stadium keeps the floor; the re-planner asks for that width
/// (`DissipativeController::shaped_need_half_width_m`), so the team holds with no route instead
/// of flying a passage its formation cannot keep apart in (it flew through before, and pairs
/// came to 0.05 m; docs/design.md, "The width the shaped formation needs"). Which passage the
/// map as seen still opens depends on where the UAVs looked from: with the shape narrowing as a
/// passage comes (docs/design.md, "The shape narrows as the passage comes", session 46), this
/// seed's map opens the first passage and the team holds short of the second, 1.7 m before
/// x = 30 m (load path 31.7 m; before, it held before the first, 19.1 m). What must hold on any
/// map: a hold with no route, no body touching another, every surface a metre from the trunks.
#[test]
fn the_paper_team_with_bodies_holds_before_a_passage_its_shaped_formation_cannot_fly_apart() {
    let mut ls = load("paper-10uav-unknown.toml");
    ls.scenario.uavs.body_radius_m = Some(0.445);
    ls.scenario.mission.clearance_floor_m = Some(0.2);
    ls.scenario.controller.shape.enabled = true;
    let s = fly(&ls);
    let p = s.perception.clone().expect("a perception summary");
    eprintln!("paper unknown, bodies: {p:?}, outcome {}, clearances {} / {} / {} m", s.outcome, s.min_uav_uav_clearance_m, s.min_uav_boundary_clearance_m, s.min_obstacle_clearance_m);
    assert!(p.no_route && s.outcome == "no_route", "{p:?} {}", s.outcome);
    assert!(s.completion_time_s.is_none());
    assert!(p.load_path_m < p.known_plan_path_m, "held short of the goal: {p:?}");
    assert!(s.min_uav_uav_clearance_m > 0.0, "bodies never touch: {}", s.min_uav_uav_clearance_m);
    assert!(s.min_obstacle_clearance_m > 1.0, "{}", s.min_obstacle_clearance_m);
}

/// A wall appears across the whole yard at 10 s: the team sees it, finds no route and holds in
/// place with the reason; it never touches the wall.
#[test]
fn with_no_route_the_team_holds_and_never_touches_the_wall() {
    let s = fly(&load("closed-3uav-unknown.toml"));
    let p = s.perception.clone().expect("a perception summary");
    eprintln!("closed: {p:?}, obstacle clearance {} m", s.min_obstacle_clearance_m);
    assert!(p.no_route, "{p:?}");
    assert_eq!(s.outcome, "no_route");
    assert!(!s.success);
    assert!(s.failures.first().is_some_and(|f| f.contains("no route")), "{:?}", s.failures);
    // Bodies, load and cables at least a metre from every obstacle (the wall included).
    assert!(s.min_obstacle_clearance_m > 1.0, "{}", s.min_obstacle_clearance_m);
    assert!(s.completion_time_s.is_none());
    // The "holds with 0 violations": no centre floor breached. A UAV came to 0.19 m
    // of the boundary while tubes that left a member outside were handed over near a block.
    let floor = 0.4;
    assert!(s.min_uav_boundary_m >= floor && s.min_load_boundary_m >= floor && s.min_uav_uav_m >= floor, "{s:?}");
    // The airframes carry their envelope: surfaces keep the scenario's 0.2 m floor too.
    let clearance = 0.2;
    assert!(s.min_uav_uav_clearance_m >= clearance && s.min_uav_boundary_clearance_m >= clearance, "{s:?}");
    assert!(s.failures.iter().all(|f| f.contains("no route") || f.contains("did not reach")), "{:?}", s.failures);
}

/// The MAVLink backends carry the scans as `OBSTACLE_DISTANCE` (tests/backends.rs, tests/pil.rs,
/// tests/sitl.rs fly them bit for bit): each companion gets its map's configuration as `PR_*`
/// parameters. A LiDAR whose scans the message cannot carry is refused by name, file and
/// field, rather than flown blind.
#[test]
fn the_mavlink_backends_carry_the_map_and_refuse_a_lidar_the_wire_cannot_carry() {
    let ls = load("paper-10uav-unknown.toml");
    let setup = host_sim::lockstep::team_setup(&ls, true).expect("an unknown map flies on the wire");
    let pr_map = setup.configs[0].params.iter().find(|p| p.0 == vt_companion::Param::PrMap).map(|p| p.1);
    assert_eq!(pr_map, Some(1.0), "PR_MAP 1: the companion maps and re-plans");
    let mut odd = ls.clone();
    if let Some(l) = odd.scenario.sensors.lidar.as_mut() {
        l.beams = 50; // 7.2 deg sectors: not whole degrees dividing 90
    }
    let mut ports: Vec<host_sim::pil::SilPort> = (0..odd.scenario.cables.lengths_m.len()).map(|_| host_sim::pil::SilPort::new()).collect();
    let Err(e) = host_sim::pil::fly(&odd, &mut ports, &host_sim::sim::RunOptions { duration_s: Some(1.0), ..Default::default() }, "twin") else {
        panic!("a LiDAR the wire cannot carry was flown")
    };
    assert!(e.0.contains("paper-10uav-unknown.toml") && e.0.contains("[sensors.lidar]") && e.0.contains("OBSTACLE_DISTANCE"), "{e}");
}

/// The perception campaign (`scenarios/campaigns/perception-forest.toml`), 40 unknown forests
/// at its middle level (5 cm range noise, 10 % of the beams dropped): the flood-fill oracle on
/// the true field sorts them, no field without a route is ever flown to the goal (a check of
/// the oracle and of the team), no body, load or cable touches a trunk (a companion whose tube
/// is blocked close ahead stops: `Perception::must_stop`), no run leaves the team's tube (5-6
/// of 40 did while tubes that left a member outside were handed over), and the solvable
/// fields succeed with
/// their floors at least as often as they do on the direct path, less one field (measured 20 of
/// 25, 0.80, through the companion's re-planning on 2026-11-28; 18 of 25 on the direct path; 16
/// before the re-plan from the load; docs/robustness.md, "Perception campaign").
#[test]
fn unknown_forests_are_flown_where_a_route_exists_and_never_where_none_does() {
    use host_sim::campaign::{self, forest::Verdict};
    let dir = std::env::temp_dir().join(format!("vt-forest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/perception-forest.toml");
    let text = std::fs::read_to_string(&shipped).unwrap_or_else(|e| panic!("{e}"));
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/forest-3uav-unknown.toml");
    // The shipped campaign at one level: its base path made absolute, its levels dropped.
    let text = text.replace("base = \"../forest-3uav-unknown.toml\"", &format!("base = {:?}", base.display().to_string()));
    let text = text.split("[levels]").next().unwrap_or_default().to_string();
    let file = dir.join("forest.toml");
    std::fs::write(&file, text).unwrap_or_else(|e| panic!("{e}"));
    let c = campaign::load_in(Some(&file), Some(campaign::World::Scenario)).unwrap_or_else(|e| panic!("{e}"));
    assert!(c.forest.is_some() && c.name.starts_with("unknown forests over"));
    let rows = campaign::fly(&c, 40, 100, 2, false).unwrap_or_else(|e| panic!("{e}"));
    let rep = campaign::report(&c, 100, &rows);
    let st = rep.forest.first().cloned().unwrap_or_default();
    println!("{st:?}");
    assert_eq!(st.solvable + st.no_route + st.marginal, 40, "every run has the oracle's verdict");
    for r in &rows {
        let f = r.field.as_ref().unwrap_or_else(|| panic!("seed {}: no field", r.summary.seed));
        if f.verdict == Verdict::NoRoute {
            assert!(!r.summary.success && r.summary.completion_time_s.is_none(), "seed {}: flown to the goal through a field without a route", r.summary.seed);
        }
    }
    assert!(st.solvable >= 15 && st.no_route >= 2, "a campaign that tests both sides: {st:?}");
    assert_eq!(st.contacts, 0, "a body, the load or a cable touched a trunk (closest {} m)", st.min_obstacle_clearance_m);
    // No tube that leaves a member outside is handed over (`perception::hand_over_now`).
    assert_eq!(st.out_of_tube, 0, "runs where a UAV centre or the load crossed the team's tube");
    assert!(st.solvable_success_rate >= 0.68, "solvable fields: {} of {}", st.solvable_successes, st.solvable);
    let _ = std::fs::remove_dir_all(&dir);
}
