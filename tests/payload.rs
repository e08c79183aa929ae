//! Issue 15, "Payload" and "Overload in flight": the capacity-aware formation carries a load
//! near the physical limit, and a load heavier than declared never costs a floor.
//! The full campaigns (`scenarios/campaigns/{payload,payload-elastic,overload,overload-clamp}.toml`)
//! are flown by `scripts/robustness-report.sh`; these tests fly reduced versions.

mod common;

use host_sim::campaign::{self, Campaign, Row};
use host_sim::models::{CableModel, UavModel};
use host_sim::scenario::{self, LoadedScenario};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;
use std::path::Path;

/// The paper's physical limit with the 20 N cap: 10 x 20 N / g, kg.
const PHYSICAL_LIMIT_KG: f64 = 10.0 * 20.0 / 9.81;

fn paper(mass_kg: f64) -> LoadedScenario {
    let mut ls = scenario::load(None).expect("built-in scenario is valid");
    ls.scenario.load.mass_kg = mass_kg;
    ls
}

/// The 20 N capacity as a hard cap: `paper_clamp` cables on the default rigid-body UAVs.
fn hard_cap() -> RunOptions {
    RunOptions { record: false, uav_model: Some(UavModel::RigidBody), cable_model: Some(CableModel::PaperClamp), ..RunOptions::default() }
}

fn describe(s: &Summary) -> String {
    format!(
        "success {} ({}), t_end {:?} s, min UAV-bnd {:.3} m, min UAV-UAV {:.3} m, load alt err {:.3} m, take-off capacity margin {:+.1} %",
        s.success,
        s.failures.join("; "),
        s.completion_time_s,
        s.min_uav_boundary_m,
        s.min_uav_uav_m,
        s.max_load_altitude_error_m,
        100.0 * (s.capacity_margin - 1.0)
    )
}

/// The goal: at least 19.8 kg (97 % of the 20.4 kg limit) through the paper tube on ten 20 N
/// UAVs with the cap as a hard limit, both floors held. Without the capacity-aware formation the
/// same flight fails (the 3 m formation's cables lean 16.7 deg: 191.6 N of lift for 194.2 N).
#[test]
fn carries_19_8_kg_with_the_20_n_cap_as_a_hard_limit() {
    let mass = 19.8;
    assert!(mass / PHYSICAL_LIMIT_KG > 0.97);
    let on = sim::run(&paper(mass), &hard_cap()).expect("run starts").summary;
    println!("{mass} kg, rigid_body + paper_clamp, capacity-aware: {}", describe(&on));
    assert_eq!((on.uav_model.as_str(), on.cable_model.as_str()), ("rigid_body", "paper_clamp"));
    let floor = paper(mass).scenario.mission.safety_distance_m;
    assert!(on.success, "{}", describe(&on));
    assert!(on.min_uav_boundary_m >= floor && on.min_uav_uav_m >= floor, "{}", describe(&on));
    assert!(on.capacity_margin > 1.0, "the adapted take-off formation must lift the load: {}", describe(&on));

    // Without the law the paper's formation is refused before take-off, and flown anyway (the
    // pre-flight requirement lowered on purpose) it drops the load.
    let mut off = paper(mass);
    off.scenario.controller.capacity.enabled = false;
    let refused = sim::run(&off, &hard_cap()).expect("a refusal is an outcome").summary;
    let why = refused.failures.join("; ");
    assert!(refused.was_refused(), "the pre-flight check refuses the 3 m formation: {why}");
    assert!(why.contains("pre-flight") && why.contains("available 191.6 N"), "{why}");
    off.scenario.preflight.min_margin = -0.5;
    let off = sim::run(&off, &hard_cap()).expect("run starts").summary;
    println!("{mass} kg, rigid_body + paper_clamp, law off: {}", describe(&off));
    assert!(!off.success && off.capacity_margin < 1.0, "without the law the paper formation cannot lift {mass} kg: {}", describe(&off));
}

/// Campaign `name` in its base scenario's own world (tests/robustness.rs's `load`).
fn load(name: &str) -> Campaign {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns").join(name);
    campaign::load_in(Some(&p), Some(campaign::World::Scenario)).expect("campaign is valid")
}

fn jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Flies `levels` of campaign `name` with `runs` seeds each; prints each level's success rate
/// and failure modes; returns the rows.
fn fly_levels(name: &str, levels: &[f64], runs: usize) -> Vec<Row> {
    let mut c = load(name);
    c.levels.retain(|(l, _)| l.is_some_and(|v| levels.contains(&v)));
    assert_eq!(c.levels.len(), levels.len(), "{name}: levels {levels:?} not all in the campaign");
    let rows = campaign::fly(&c, runs, c.seed, jobs(), false).expect("runs start");
    for l in &campaign::report(&c, c.seed, &rows).levels {
        let worst = |k: &str| l.percentiles.get(k).map_or(f64::NAN, |p| p.min);
        println!(
            "{name} true load {:?} kg: {}/{} succeed, worst UAV-bnd {:.3} m, worst UAV-UAV {:.3} m, failure modes {:?}",
            l.level,
            l.successes,
            l.runs,
            worst("min_uav_boundary_m"),
            worst("min_uav_uav_m"),
            l.failure_reasons
        );
    }
    rows
}

/// "What must not happen": a UAV across (or within 0.4 m of) the boundary, two UAVs within
/// 0.4 m, anything non-finite, at any true load.
fn assert_floors(rows: &[Row]) {
    for r in rows {
        let s = &r.summary;
        let ctx = format!("true load {:?} kg, seed {}: {}", r.level, s.seed, describe(s));
        assert!(!s.nonfinite, "{ctx}");
        assert!(s.min_uav_boundary_m >= 0.4, "{ctx}");
        assert!(s.min_uav_uav_m >= 0.4, "{ctx}");
    }
}

/// Overload on the default plant (rigid body + elastic): told 18 kg, carrying 15, 20 or 25 kg,
/// with sensor noise; both floors hold at every level.
#[test]
fn overload_keeps_both_floors_on_the_default_plant() {
    let rows = fly_levels("overload.toml", &[15.0, 20.0, 25.0], 2);
    assert!(rows.iter().all(|r| r.summary.uav_model == "rigid_body" && r.summary.cable_model == "elastic"));
    assert!(rows.iter().any(|r| r.summary.true_load_mass_kg == 25.0 && r.summary.load_mass_kg == 18.0));
    assert_floors(&rows);
}

/// Overload with the 20 N cap as a hard limit: above 20.4 kg the load cannot be held and sinks
/// (progress and altitude give way), yet no floor is crossed.
#[test]
fn overload_beyond_the_hard_cap_keeps_both_floors() {
    let rows = fly_levels("overload-clamp.toml", &[18.0, 21.0, 25.0], 1);
    assert!(rows.iter().all(|r| r.summary.cable_model == "paper_clamp"));
    let beyond: Vec<&Row> = rows.iter().filter(|r| r.level.is_some_and(|l| l > PHYSICAL_LIMIT_KG)).collect();
    assert!(!beyond.is_empty() && beyond.iter().all(|r| !r.summary.success), "a load beyond the physical limit cannot arrive");
    assert_floors(&rows);
}

/// The campaign `scenarios/campaigns/{file}` in the real-aircraft world at each of `loads` (kg,
/// levels it has), one run each at its own seed: the summaries in the order of `loads`.
fn fly_loads(file: &str, loads: &[f64]) -> Vec<Summary> {
    fly_loads_from(file, loads, None)
}

/// [`fly_loads`] from `seed` instead of the campaign's.
fn fly_loads_from(file: &str, loads: &[f64], seed: Option<u64>) -> Vec<Summary> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns").join(file);
    let mut c = campaign::load_in(Some(&p), Some(campaign::World::RealAircraft)).expect("campaign is valid");
    c.levels.retain(|(l, _)| l.is_some_and(|v| loads.contains(&v)));
    assert_eq!(c.levels.len(), loads.len(), "{file} flies every load asked");
    let rows = campaign::fly(&c, 1, seed.unwrap_or(c.seed), jobs(), false).expect("runs start");
    loads.iter().map(|&kg| rows.iter().find(|r| r.level == Some(kg)).map(|r| r.summary.clone()).expect("level flown")).collect()
}

/// Issue 27 §5 in the real-aircraft world (ground start, stock PX4 gains on an attitude
/// estimate, RTK, light turbulence, thrust errors, 0.445 m bodies, 0.2 m floor), the `payload`
/// campaign's seed: 19.4 kg at the 20 N clamp is lifted, carried and set down with every pair of
/// bodies 0.2 m apart, and 19.8 kg, which the team cannot carry with its pairs apart, is refused
/// on the ground instead of flown with rotors overlapping. The first needs both halves of
/// docs/design.md's "Heavy loads keep their pairs apart": without the guard above the floor, or
/// with the stadium held to the capacity margin in the passages, 19.4 kg overlapped (-0.09 and
/// -0.06 m of clearance); 19.0-19.8 kg all did before (to -0.21 m).
#[test]
fn the_real_aircraft_world_carries_19_4_kg_at_the_clamp_with_its_pairs_apart() {
    let flown = fly_loads("payload.toml", &[19.4, 19.8]);
    let (carried, heavy) = (&flown[0], &flown[1]);
    for s in [carried, heavy] {
        println!("{} kg: outcome {}, UAV-UAV clearance {:.3} m, {}", s.true_load_mass_kg, s.outcome, s.min_uav_uav_clearance_m, describe(s));
        assert_eq!(s.cable_model, "paper_clamp");
    }
    assert!(carried.success && carried.outcome == "flown", "{}", describe(carried));
    assert!(carried.min_uav_uav_clearance_m >= 0.2, "{}", carried.min_uav_uav_clearance_m);
    assert_eq!(heavy.outcome, "refused", "{}", describe(heavy));
    assert!(heavy.min_uav_uav_clearance_m > 0.0, "a refused team's bodies never touch: {}", heavy.min_uav_uav_clearance_m);
}

/// A team packed around the load (`payload-packed`: a hexagonal patch, not a ring) flies the
/// paper's two passages at the 20 N clamp with 19.4 and 19.6 kg, where the ring was refused on
/// the ground from 19.6 kg until session 58 (from 19.8 kg since): the formation shaped to the tube squeezes the patch across and
/// stretches it along, its inner nodes kept inside, and keeps a reserve of lift (docs/design.md,
/// "The shaped formation of a packed team"). Before, the stadium would have put the inner nodes
/// on its perimeter (the mutation `RING_SPREAD = 0`: 19.4 kg never reaches the end), and such a
/// layout was refused in a tube narrower than its reach; without the reserve 19.6 kg sank in
/// the passages (0 of 20 seeds).
#[test]
fn a_packed_team_carries_19_6_kg_through_the_passages_with_its_pairs_apart() {
    for s in &fly_loads("payload-packed.toml", &[19.4, 19.6]) {
        println!("{} kg packed: outcome {}, UAV-UAV clearance {:.3} m, {}", s.true_load_mass_kg, s.outcome, s.min_uav_uav_clearance_m, describe(s));
        assert!(s.success && s.outcome == "flown", "{}", describe(s));
        assert!(s.min_uav_uav_clearance_m >= 0.2 && s.min_uav_boundary_clearance_m >= 0.2, "{}", describe(s));
    }
}

/// At 19.8 kg on the 20 N clamp the packed team lifts with a few newtons to spare, and its load
/// climbs seconds behind the climb's ramp. The transport starts once the load is up, not the
/// ramp (docs/design.md, "The climb ends with the load up"): on seed 7100 the load's largest
/// altitude error in the transport is 0.52 m; when the transport started with the ramp, the
/// load was 2.4 m below its altitude (2.37 m of error, against the 1 m tolerance).
#[test]
fn a_load_lifted_at_the_team_s_last_newtons_starts_the_transport_up() {
    let s = &fly_loads_from("payload-packed.toml", &[19.8], Some(7100))[0];
    println!("19.8 kg packed, seed 7100: outcome {}, load altitude error {:.3} m, {}", s.outcome, s.max_load_altitude_error_m, describe(s));
    assert_eq!(s.outcome, "flown", "{}", describe(s));
    assert!(s.phases.iter().any(|p| p.name == "transport"), "{:?}", s.phases);
    assert!(s.max_load_altitude_error_m < 0.7, "the transport starts with the load up: {:.3} m", s.max_load_altitude_error_m);
}

/// At 19.8 kg on the 20 N clamp the load leaves the ground slower than the lift's ramp rises
/// (docs/design.md, "The lift ends with the load off the ground"): on seed 7119 it was 1 cm
/// short of the 0.2 m that counts as lifted when the ramp passed its top, rising at 0.06 m/s,
/// and the start was refused (`load did not leave the ground`). The ramp now waits at its top
/// while the load rises, and the team lifts it and carries it to the end.
#[test]
fn a_load_leaving_the_ground_at_the_team_s_last_newtons_is_lifted() {
    let s = &fly_loads_from("payload-packed.toml", &[19.8], Some(7119))[0];
    println!("19.8 kg packed, seed 7119: outcome {}, phases {:?}, {}", s.outcome, s.phases, describe(s));
    assert_eq!(s.outcome, "flown", "{}", describe(s));
    let start = |name: &str| s.phases.iter().find(|p| p.name == name).map(|p| p.start_s);
    let (lift, climb) = (start("lift").expect("a lift"), start("climb").expect("lifted"));
    // The ramp reaches its top 0.7 m / 0.1 m/s = 7 s into the lift; the load cleared later.
    assert!(climb - lift > 7.0, "the lift waited at its top: {:.2} s", climb - lift);
    assert!(s.success, "{}", describe(s));
}

/// At 19.8 kg the cables' 20 N rating leaves the load's drag 4.3 m/s of wind; the hover on seed
/// 7111 saw a wind that with its gust margin came to 4.7 m/s, and the start was refused on the
/// cable (`wind 4.7m/s > cap 4.3m/s (cable)`).
/// The gust margin is now held against the rotors, which hold far more, and the steady wind
/// against the cables (docs/design.md, "The gust margin is the rotors'"): the team takes off and
/// carries the load to the end with its floors. No flight this let take off failed on the wind.
#[test]
fn a_gust_margin_is_held_by_the_rotors_not_the_cables_rating() {
    let s = &fly_loads_from("payload-packed.toml", &[19.8], Some(7111))[0];
    println!("19.8 kg packed, seed 7111: outcome {}, {}", s.outcome, describe(s));
    assert_eq!(s.outcome, "flown", "{}", describe(s));
    assert!(s.success, "{}", describe(s));
}

/// A team near its capacity flies slower (docs/design.md, "A team near its capacity flies
/// slower"): at 19.7 and 19.8 kg on the 20 N clamp the packed team's capacity margin is 0.9 and
/// 0.4 %, and it flies half its `v_max`. On seed 7100 both loads are carried with every pair of
/// bodies 0.2 m apart (0.34 and 0.27 m with session 60's dashpots, 0.27 and 0.23 m before); at
/// full speed the patch's tip and its neighbour came to 0.12 and 0.07 m in the passages, and the
/// loads arrived in 83-84 s instead of 132-136 s (125 s with the dashpots).
#[test]
fn a_packed_team_near_its_capacity_flies_slower_and_keeps_its_pairs_apart() {
    for s in &fly_loads_from("payload-packed.toml", &[19.7, 19.8], Some(7100)) {
        println!("{} kg packed, seed 7100: outcome {}, {}", s.true_load_mass_kg, s.outcome, describe(s));
        assert!(s.success && s.outcome == "flown", "{}", describe(s));
        assert!(s.min_uav_uav_clearance_m >= 0.2 && s.min_uav_boundary_clearance_m >= 0.2, "{}", describe(s));
        assert!(s.completion_time_s.is_some_and(|t| t > 110.0), "flown at half speed: {:?}", s.completion_time_s);
    }
}

/// A team near its capacity flies dashpots beside its springs (docs/design.md, "A dashpot
/// beside the springs of a team near its capacity"): the packed patch's spring mode, which
/// surged it fore and aft at about 0.7 Hz behind the velocity loop, is damped, and at 19.8 kg
/// the seeds that lost the rear tip's pair at 0.18-0.19 m (7106, 7112, 7200, 7218) keep every
/// pair of bodies 0.2 m apart and set the load down.
#[test]
fn the_dashpots_keep_the_packed_patch_s_tip_apart_at_19_8_kg() {
    for seed in [7106, 7112, 7200, 7218] {
        let s = &fly_loads_from("payload-packed.toml", &[19.8], Some(seed))[0];
        println!("19.8 kg packed, seed {seed}: outcome {}, UAV-UAV clearance {:.3} m, {}", s.outcome, s.min_uav_uav_clearance_m, describe(s));
        assert!(s.success && s.outcome == "flown", "seed {seed}: {}", describe(s));
        assert!(s.min_uav_uav_clearance_m >= 0.2, "seed {seed}: {}", describe(s));
    }
}

/// A team near its capacity descends as fast as it can brake (docs/design.md, "A team near its
/// capacity descends as fast as it can brake"): at 19.8 kg its spare capacity (0.4 %) brakes the
/// load at about 0.04 m/s^2, so it descends at 0.30 m/s instead of 0.5 m/s. The seeds whose load
/// touched down at 0.47 and 0.50 m/s (7108, 7216: the descent never slowed) touch down under
/// 0.3 m/s.
#[test]
fn a_team_at_its_last_newtons_sets_its_load_down_gently() {
    for seed in [7108, 7216] {
        let s = &fly_loads_from("payload-packed.toml", &[19.8], Some(seed))[0];
        println!("19.8 kg packed, seed {seed}: outcome {}, touchdown {:?} m/s, {}", s.outcome, s.touchdown_speed_mps, describe(s));
        assert!(s.success && s.outcome == "flown", "seed {seed}: {}", describe(s));
        assert!(s.touchdown_speed_mps.is_some_and(|v| v < 0.3), "seed {seed}: touchdown {:?} m/s", s.touchdown_speed_mps);
    }
}

/// The new scenario fields are validated like the others: file, line and field, exit code 2.
#[test]
fn bad_payload_fields_name_the_file_line_and_field() {
    let paper = scenario::PAPER_10UAV;
    let line_of = |needle: &str| paper.lines().position(|l| l.contains(needle)).expect("needle") + 1;
    let cases = [
        ("true_mass.toml", paper.replacen("start_s_m = 4.0", "start_s_m = 4.0\ntrue_mass_kg = -3.0", 1), "load.true_mass_kg", line_of("start_s_m = 4.0") + 1),
        (
            "sag.toml",
            paper.replacen("[baseline]", "[controller.capacity]\nsag_start_m = 0.5\nsag_full_m = 0.2\n\n[baseline]", 1),
            "controller.capacity.sag_full_m",
            line_of("[baseline]") + 2,
        ),
        (
            "reserve.toml",
            paper.replacen("cfo_bandwidth_rad_s = 15.0", "cfo_bandwidth_rad_s = 15.0\nhorizontal_reserve = 1.5", 1),
            "velocity_loop.horizontal_reserve",
            line_of("cfo_bandwidth_rad_s = 15.0") + 1,
        ),
    ];
    for (name, text, field, line) in cases {
        common::expect_exit_2("payload-errors", &text, name, &[&format!("{name}:{line}:"), field]);
    }
}
