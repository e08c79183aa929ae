//! True clearances (issue 27): surface to surface at the plant rate, bodies, load and cables
//! against the real obstacles; judged when a scenario gives `mission.clearance_floor_m`; the
//! separation barrier that keeps surfaces apart when the UAVs declare `body_radius_m`.

mod common;

use host_sim::scenario::{parse, PAPER_10UAV};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;

fn fly(text: &str) -> (Summary, host_sim::record::RunRecord) {
    let ls = parse(text, "clearance.toml").expect("valid scenario");
    let out = sim::run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("flies");
    (out.summary, out.record)
}

/// The paper scenario on the point-mass plant, optionally with bodies and a clearance floor.
fn paper_point_mass(body_m: Option<f64>, floor_m: Option<f64>) -> String {
    let mut t = PAPER_10UAV.replacen("[uavs]\n", "[uavs]\nmodel = \"point_mass\"\n", 1);
    if let Some(b) = body_m {
        t = t.replacen("[uavs]\n", &format!("[uavs]\nbody_radius_m = {b}\n"), 1);
    }
    if let Some(f) = floor_m {
        t = t.replacen("[mission]\n", &format!("[mission]\nclearance_floor_m = {f}\n"), 1);
    }
    t
}

/// On the default plant the clearances use the sized airframe's envelope (2 kg: 0.445 m) and
/// the 18 kg load's (0.286 m); the plant-rate UAV-UAV clearance is at most every recorded
/// sample's centre distance less the two bodies, and the obstacle clearance is at most the one
/// of the UAV centres the record holds. Without `clearance_floor_m` they are reported, not
/// judged.
#[test]
fn the_paper_mission_reports_clearances_from_its_airframe() {
    let (s, rec) = fly(PAPER_10UAV);
    assert!((s.uav_body_radius_m - 0.445).abs() < 0.005, "{}", s.uav_body_radius_m);
    assert!((s.load_radius_m - 0.286).abs() < 0.005, "{}", s.load_radius_m);
    assert!(s.min_uav_uav_clearance_m <= s.min_uav_uav_m - 2.0 * s.uav_body_radius_m + 1e-9);
    assert!(s.min_uav_boundary_clearance_m <= s.min_uav_boundary_m - s.uav_body_radius_m + 1e-6);
    let ls = parse(PAPER_10UAV, "p.toml").expect("paper");
    let obstacles = host_sim::clearance::Obstacles::of(&ls);
    let recorded = rec
        .uav_pos_m
        .iter()
        .flatten()
        .map(|p| obstacles.point_m(nalgebra::Vector2::new(p[0], p[1])) - s.uav_body_radius_m)
        .fold(f64::INFINITY, f64::min);
    assert!(s.min_obstacle_clearance_m <= recorded + 1e-9, "{} vs {recorded}", s.min_obstacle_clearance_m);
    assert!(s.min_obstacle_clearance_m > 0.2, "the paper's tube keeps the team off the obstacles: {}", s.min_obstacle_clearance_m);
    assert!(s.success, "{:?}", s.failures);
}

/// With a floor the clearances are success criteria: a floor the team cannot keep fails the
/// run, naming the clearance. (0.5 m: its bodies take off 0.62 m apart, within a floor of 1 m,
/// which is refused before the flight since session 52, tests/scenario_errors.rs.)
#[test]
fn a_clearance_floor_is_judged() {
    let t = PAPER_10UAV.replacen("[mission]\n", "[mission]\nclearance_floor_m = 0.5\n", 1);
    let (s, _) = fly(&t);
    assert!(!s.success);
    assert!(s.failures.iter().any(|f| f.starts_with("UAV-UAV clearance")), "{:?}", s.failures);
    assert!(s.failures.iter().any(|f| f.starts_with("UAV-boundary clearance")), "{:?}", s.failures);
}

/// The separation barrier (extension, `vt_dissipative::separation`): the paper's team of
/// 0.445 m bodies on the point-mass plant comes within 0.06 m of each other with the paper's
/// controller (0.948 m between centres), and keeps more than the 0.2 m floor with the barrier.
/// The paper's own judgement (no floor, points) still passes without it.
#[test]
fn declared_bodies_keep_their_clearance_with_the_separation_barrier() {
    let (points, _) = fly(&paper_point_mass(None, None));
    assert!(points.success, "{:?}", points.failures);
    assert!(points.min_uav_uav_m - 2.0 * 0.445 < 0.2, "the paper's controller alone: {} m between centres", points.min_uav_uav_m);
    let (bodies, _) = fly(&paper_point_mass(Some(0.445), Some(0.2)));
    assert!(bodies.success, "{:?}", bodies.failures);
    assert!(bodies.min_uav_uav_clearance_m >= 0.2, "{}", bodies.min_uav_uav_clearance_m);
    assert!(bodies.min_uav_boundary_clearance_m >= 0.2, "{}", bodies.min_uav_boundary_clearance_m);
    assert!(bodies.min_obstacle_clearance_m >= 0.2, "{}", bodies.min_obstacle_clearance_m);
}

/// The paper's team of 0.445 m bodies on the default plant (rigid-body quadrotors behind the
/// PX4-style autopilot, elastic cables), calm: with the formation shaped to the tube and the
/// stadium lengthened to the separation floor where the UAVs fly (`vt_dissipative::shape`),
/// every surface keeps the 0.2 m floor and the mission succeeds (scenarios/campaigns/
/// nominal-bodies.toml flies it under the nominal disturbances). Measured on 2026-11-29:
/// 0.327 / 0.898 / 0.977 m, arrival 36.3 s; with the stadium as long as the ring, 0.035 m
/// between two bodies (docs/design.md, "A formation shaped to the tube"). Since 2026-12-01 the
/// passages are flown at 2/3 of `v_max` (docs/design.md, "The passage speed"): 0.358 m between
/// bodies, arrival 47.5 s. Since session 46 the shape narrows as a passage comes and widens only
/// once the passage has left the stadium's length (docs/design.md, "The shape narrows as the
/// passage comes"): this calm flight 0.292 m, while over 200 paired seeds of `nominal-bodies` and
/// of `nominal-bodies-ground` the closest pairs came 2.0 +- 2.0 and 11.1 +- 2.5 mm farther apart
/// (worst 0.228 -> 0.252 and 0.203 -> 0.237 m): one flight's closest pair moves by centimetres
/// with any change, so the bound is the floor plus 5 cm.
#[test]
fn the_paper_team_with_bodies_keeps_the_floor_on_the_default_plant() {
    let mut t = PAPER_10UAV.replacen("[uavs]\n", "[uavs]\nbody_radius_m = 0.445\n", 1);
    t = t.replacen("[mission]\n", "[mission]\nclearance_floor_m = 0.2\n", 1);
    t.push_str("\n[controller.shape]\nenabled = true\n");
    let (s, _) = fly(&t);
    assert!(s.success, "{:?}", s.failures);
    assert!(s.min_uav_uav_clearance_m >= 0.25, "{}", s.min_uav_uav_clearance_m);
    assert!(s.min_uav_boundary_clearance_m >= 0.2, "{}", s.min_uav_boundary_clearance_m);
    assert!(s.min_obstacle_clearance_m >= 0.2, "{}", s.min_obstacle_clearance_m);
    // The passage speed costs the two passages about 11 s; it must not crawl.
    assert!(s.completion_time_s.is_some_and(|t| t < 55.0), "{:?}", s.completion_time_s);
}

fn expect_error(text: &str, name: &str, must_contain: &[&str]) {
    common::expect_exit_2("clearance", text, name, must_contain);
}

#[test]
fn bad_envelopes_exit_2_naming_file_line_and_field() {
    let line_of = |t: &str, key: &str| t.lines().position(|l| l.starts_with(key)).expect("key") + 1;
    let t = PAPER_10UAV.replacen("[uavs]\n", "[uavs]\nbody_radius_m = -0.1\n", 1);
    expect_error(&t, "neg.toml", &["neg.toml:", &format!(":{}:", line_of(&t, "body_radius_m")), "`uavs.body_radius_m`"]);
    // A body whose safety radius reaches the barrier's activation radius (1.5 m).
    let t = PAPER_10UAV.replacen("[uavs]\n", "[uavs]\nbody_radius_m = 1.4\n", 1);
    expect_error(&t, "big.toml", &["`uavs.body_radius_m`", "r_active_m"]);
    let t = PAPER_10UAV.replacen("[mission]\n", "[mission]\nclearance_floor_m = nan\n", 1);
    expect_error(&t, "floor.toml", &["`mission.clearance_floor_m`"]);
    let t = PAPER_10UAV.replacen("[load]\n", "[load]\nradius_m = -1\n", 1);
    expect_error(&t, "load.toml", &["`load.radius_m`"]);
}

/// Issue 27, docs/design.md "The tube keeps the team, not one node": in the real-aircraft
/// world's nominal campaign, the tube barrier pressed one UAV into its neighbour at the second
/// passage (seed 1017: the front pair 1-9 entering it, 0.13 m; seed 1164: the rear pair leaving
/// it, 0.14 m; the paper's tube barrier on one node of the pair alone). Seed 1030 was the first
/// example until session 56's softer springs while the load heaves changed its flight: it now
/// keeps 0.29 m without the team keeping. Seed 1164 kept 0.208 m without it once session 59's
/// contact barrier acted inside the floor; seed 1050 (0.302 m with the team keeping, 0.163 m
/// without) took its place, one of the 15 seeds of 1000-1199 the team keeping alone wins
/// (198 against 183 of 200, measured that session). With the team keeping (the default with
/// the shape) both keep the 0.2 m floor; with each node keeping the tube on its own, as the
/// paper, both lose it.
#[test]
fn the_team_keeping_keeps_apart_the_pair_the_tube_pressed_together() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/nominal.toml");
    let on = host_sim::campaign::load_in(Some(&p), Some(host_sim::campaign::World::RealAircraft)).expect("campaign is valid");
    let mut off = on.clone();
    for (_, ls) in &mut off.levels {
        assert!(ls.scenario.controller.shape.enabled && ls.scenario.controller.shape.team_keeping, "on by default with the shape");
        ls.scenario.controller.shape.team_keeping = false;
    }
    let clearance = |c: &host_sim::campaign::Campaign, seed: u64| {
        let rows = host_sim::campaign::fly(c, 1, seed, 1, false).expect("run starts");
        let s = &rows[0].summary;
        println!("seed {seed}, team keeping {}: UAV-UAV clearance {:.3} m, {:?}", c.levels[0].1.scenario.controller.shape.team_keeping, s.min_uav_uav_clearance_m, s.failures);
        (s.success, s.min_uav_uav_clearance_m)
    };
    for seed in [1017, 1050] {
        let (ok, kept) = clearance(&on, seed);
        assert!(ok && kept >= 0.2, "seed {seed}: {kept:.3} m with the team keeping");
        let (_, lost) = clearance(&off, seed);
        assert!(lost < 0.2, "seed {seed}: {lost:.3} m without it");
    }
}

/// The contact barrier (extension, `vt_dissipative::separation::separation_pole_band`; docs/
/// design.md, "The contact barrier"): generated seed 5190 (twenty-one 2 kg UAVs, a light load on
/// a straight tube, the real-aircraft world at 1x) lost two bodies into each other in the
/// descent's last metre (-0.27 m between surfaces) with the separation barrier off beside the
/// shaped formation. With the barrier's pole at contact and its band the 0.2 m floor, on the 3-D
/// distance, the pair comes to 0.17 m and no closer: still under the floor (the run fails it),
/// but no contact.
#[test]
fn a_shaped_team_s_bodies_do_not_touch() {
    let (s, _) = fly(&common::generated(5190, 21, "paper-2kg-50N"));
    println!("seed 5190: UAV-UAV clearance {:.3} m, {:?}", s.min_uav_uav_clearance_m, s.failures);
    assert!(s.min_uav_uav_clearance_m > 0.05, "bodies within {:.3} m of each other", s.min_uav_uav_clearance_m);
}
