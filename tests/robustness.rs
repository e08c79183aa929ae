//! Robustness campaigns of issue 6 (scenarios/campaigns/), flown in full: each asserts the
//! success rate the campaign is held to and prints its worst metrics.

use host_sim::campaign::{self, Campaign};
use std::path::Path;

/// Campaign `name` flown in its base scenario's own world: these are the claims about the
/// scenarios as written (the real-aircraft world's figures are docs/robustness.md's,
/// "Every campaign in the real-aircraft world").
fn load(name: &str) -> Campaign {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns").join(name);
    campaign::load_in(Some(&p), Some(campaign::World::Scenario)).expect("campaign is valid")
}

/// Keeps only `level` of campaign `c` (its scenario and the table the generator draws over).
fn only_level(c: &mut Campaign, level: f64) {
    let k = c.levels.iter().position(|l| l.0 == Some(level)).expect("the campaign has the level");
    c.levels = vec![c.levels.swap_remove(k)];
    c.tables = vec![c.tables.swap_remove(k)];
}

fn jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Loads campaign `name`, checks it holds `runs` runs, flies it and asserts its success rate.
fn succeeds_at_least(name: &str, runs: usize, rate: f64) -> campaign::SweepReport {
    let c = load(name);
    assert_eq!(c.runs, runs);
    let rep = fly(&c);
    assert!(rep.success_rate >= rate, "success rate {:.3}", rep.success_rate);
    rep
}

/// Flies the campaign at its own run count and seed; returns the report.
fn fly(c: &Campaign) -> campaign::SweepReport {
    let rows = campaign::fly(c, c.runs, c.seed, jobs(), false).expect("runs start");
    let rep = campaign::report(c, c.seed, &rows);
    for l in &rep.levels {
        let p = |k: &str| l.percentiles.get(k).cloned();
        println!(
            "{} level {:?}: {}/{} ({:.1} %), worst UAV-bnd {:?} m, worst UAV-UAV {:?} m, worst load alt err {:?} m, failures {:?}",
            rep.scenario,
            l.level,
            l.successes,
            l.runs,
            100.0 * l.success_rate,
            p("min_uav_boundary_m").map(|p| p.min),
            p("min_uav_uav_m").map(|p| p.min),
            p("max_load_altitude_error_m").map(|p| p.max),
            l.failure_reasons
        );
    }
    rep
}

#[test]
fn nominal_disturbances_succeed_in_at_least_99_percent_of_200_runs_on_the_paper_plant() {
    succeeds_at_least("nominal-point-mass.toml", 200, 0.99);
}

/// Issue 14's target on the default plant (rigid-body UAVs, elastic cables): met since the
/// velocity loop compensates the measurement delay (docs/design.md, "Latency compensation");
/// before, 188/200.
#[test]
fn nominal_disturbances_succeed_in_at_least_99_percent_of_200_runs_on_the_rigid_body_plant() {
    succeeds_at_least("nominal.toml", 200, 0.99);
}

/// Issue 27's first target, in the real-aircraft world (ground start, PX4's stock gains on the
/// attitude estimate, RTK errors, light turbulence, thrust errors, 0.445 m bodies declared and a
/// 0.2 m floor between surfaces; rigid-body quadrotors behind the PX4-style autopilot, elastic
/// cables): at least 99 % of the nominal campaign's 200 runs keep every clearance and set their
/// load down. 198 / 200 since session 49 (docs/design.md, "The stadium flown keeps a wider
/// floor"), 195 before.
#[test]
fn nominal_disturbances_succeed_in_at_least_99_percent_of_200_runs_in_the_real_aircraft_world() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/nominal.toml");
    let c = campaign::load_in(Some(&p), Some(campaign::World::RealAircraft)).expect("campaign is valid");
    assert_eq!(c.runs, 200);
    let rep = fly(&c);
    assert!(rep.success_rate >= 0.99, "success rate {:.3}", rep.success_rate);
}

/// Issue 15: three times every nominal disturbance (15 cm / 15 cm/s noise, 60 ms latency and
/// jitter, 30 % drops, 9 m/s wind + 3 m/s gusts) on the default plant, 100 runs: at least 95 %
/// succeed. 97/100 since the tilt limit went to 45 deg; 85/100 at 35 deg (docs/design.md,
/// "Tilt limit").
#[test]
fn three_times_the_nominal_disturbances_succeed_in_at_least_95_percent_of_100_runs() {
    succeeds_at_least("intensity-3x.toml", 100, 0.95);
}

/// Issue 15: 150 ms of measurement latency with the paper's observer bandwidth (mu = 15 rad/s)
/// on the default plant: every run succeeds and keeps both floors.
#[test]
fn every_run_succeeds_at_150_ms_of_measurement_latency() {
    let rep = succeeds_at_least("latency-150ms.toml", 10, 1.0);
    let uu = rep.percentiles.get("min_uav_uav_m").expect("metric").min;
    let bnd = rep.percentiles.get("min_uav_boundary_m").expect("metric").min;
    assert!(uu >= 0.4 && bnd > 0.0, "UAV-UAV {uu} m, UAV-boundary {bnd} m");
}

#[test]
fn cable_length_and_stiffness_errors_are_tolerated() {
    let rep = fly(&load("cable-uncertainty.toml"));
    for l in &rep.levels {
        assert!(l.success_rate >= 0.95, "level {:?}: {:.2}", l.level, l.success_rate);
    }
}

#[test]
fn a_snapped_cable_keeps_the_load_in_the_tube_and_at_altitude() {
    let rep = fly(&load("cable-snap.toml"));
    assert!(rep.success_rate >= 0.95, "success rate {:.3}", rep.success_rate);
    let alt = rep.percentiles.get("max_load_altitude_error_m").expect("metric").max;
    let bnd = rep.percentiles.get("min_load_boundary_m").expect("metric").min;
    assert!(alt < 1.0 && bnd > 0.0, "load altitude error {alt} m, load-boundary {bnd} m");
}

#[test]
fn a_silent_uav_causes_no_collision() {
    let rep = fly(&load("uav-silent.toml"));
    let uu = rep.percentiles.get("min_uav_uav_m").expect("metric").min;
    assert!(uu >= 0.4, "UAVs came within {uu} m");
    assert!(rep.success_rate >= 0.95, "success rate {:.3}", rep.success_rate);
}

#[test]
fn same_seed_list_gives_the_same_sweep_whatever_the_thread_count() {
    let mut c = load("nominal.toml");
    c.runs = 6;
    let a = campaign::fly(&c, 6, 77, 1, false).expect("runs");
    let b = campaign::fly(&c, 6, 77, 2, false).expect("runs");
    assert_eq!(campaign::csv(&a), campaign::csv(&b));
    let r1 = serde_json::to_string(&campaign::report(&c, 77, &a)).expect("json");
    let r2 = serde_json::to_string(&campaign::report(&c, 77, &b)).expect("json");
    assert_eq!(r1, r2);
}

/// Issue 29: generated missions (`generated.toml`: its first 40 seeds at 1x and 3x, wind
/// declared, the formation shaped to the tube). No UAV or load ever leaves its tube; among
/// accepted runs at least 95 % succeed at 1x (39/40 measured with the shaped formation; 37/40
/// with the ring, 35/39 before the control thrust reserve, the declared-share horizontal
/// reserve and the long-cable take-off check) and the 3x refusals are those the wind law makes
/// (34 of 40). The full 200-seed tables: docs/robustness.md.
#[test]
fn generated_missions_never_leave_the_tube() {
    let mut c = load("generated.toml");
    c.runs = 40;
    let rep = fly(&c);
    for l in &rep.levels {
        assert_eq!(l.out_of_tube, 0, "level {:?}: {l:?}", l.level);
        assert_eq!(l.runs, 40);
    }
    let at = |x: f64| rep.levels.iter().find(|l| l.level == Some(x)).expect("level");
    let (one, three) = (at(1.0), at(3.0));
    assert_eq!(one.refused, 0, "3 + 2 m/s is within every generated team's capacity here");
    assert!(one.accepted_success_rate >= 0.95, "1x: {:.3}", one.accepted_success_rate);
    assert!(three.refused >= 30 && three.refused < 40, "3x refusals: {}", three.refused);
}

/// Issue 29: generated missions that failed at 1x before two changes (docs/design.md, "The
/// spring gain of large teams" and "Vertical margin of the thrust cap"), flown again:
/// - seeds 5092 (25 heavy UAVs, S-bend) and 5150 (22 light UAVs, straight) crawled past their
///   time limits in a limit cycle of their stiff formations; with the spring gain scaled to the
///   team they arrive;
/// - seeds 5091 (21 light UAVs, 94 % of capacity) and 5195 (6 light UAVs, 93 %) lost their load
///   1.21 and 1.05 m below its reference, their vertical thrust capped 5 % above the share;
///   with 15 % they hold it within the 1 m tolerance.
#[test]
fn large_and_heavily_loaded_generated_teams_arrive_with_the_load_at_altitude() {
    let mut c = load("generated.toml");
    only_level(&mut c, 1.0);
    let mut rows = Vec::new();
    for (seed, runs) in [(5091, 2), (5150, 1), (5195, 1)] {
        rows.extend(campaign::fly(&c, runs, seed, jobs(), false).expect("runs start"));
    }
    for r in &rows {
        let (s, class) = (&r.summary, r.class.as_ref().expect("generated"));
        println!(
            "seed {}: {} UAVs ({}), load {:.0} %: success {} {:?}, arrival {:?} s of {:.0}, load altitude error {:.3} m",
            s.seed, class.n_uavs, class.airframe, 100.0 * class.load_fraction, s.success, s.failures, s.completion_time_s, s.sim_time_s, s.max_load_altitude_error_m
        );
        assert!(s.success, "seed {}: {:?}", s.seed, s.failures);
        assert!(s.max_load_altitude_error_m < 1.0, "seed {}", s.seed);
    }
    for r in rows.iter().filter(|r| r.class.as_ref().is_some_and(|c| c.n_uavs > 20)) {
        let t = r.summary.completion_time_s.expect("arrived");
        assert!(t < 110.0, "seed {}: {} UAVs arrive without crawling ({t:.1} s)", r.summary.seed, r.class.as_ref().map_or(0, |c| c.n_uavs));
    }
}

/// Issue 29, the end is a stop: generated seed 5324 at 3x (6 paper UAVs, straight tube, 9 m/s
/// tailwind with 3 m/s gusts, accepted) arrived, and a gust then carried its load 0.25 m out past
/// the tube's end while it hovered there. The phases now watch the load after arrival too
/// (`HoldWatch::cannot_hold_end`): carried more than `SET_DOWN_PAST_END_M` past the end, the team
/// sets it down there, inside.
#[test]
fn a_team_carried_past_the_tubes_end_after_arrival_sets_the_load_down_inside() {
    let mut c = load("generated.toml");
    only_level(&mut c, 3.0);
    let rows = campaign::fly(&c, 1, 5324, 1, false).expect("runs start");
    let s = &rows.first().expect("one run").summary;
    println!("seed 5324 at 3x: {} {:?}, load-boundary {:.3} m, UAV-boundary {:.3} m, phases {:?}", s.outcome, s.failures, s.min_load_boundary_m, s.min_uav_boundary_m, s.phases);
    assert_eq!(s.outcome, "flown");
    assert!(s.success, "{:?}", s.failures);
    let arrival = s.completion_time_s.expect("arrived");
    let descent = s.phases.iter().find(|p| p.name == "descent").expect("set down");
    assert!(descent.start_s > arrival, "set down after arrival ({arrival} s), at {} s", descent.start_s);
    assert!(s.min_load_boundary_m > 0.0 && s.min_uav_boundary_m > 0.0);
}
