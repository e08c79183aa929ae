//! The wind capacity law (`vt_dissipative::wind`, issue 29) against the plant it is a claim
//! about, and the pre-flight refusal built on it. Plant: the default rigid-body quadrotors
//! behind the PX4-style autopilot, elastic cables.

mod common;

use host_sim::sim::{self, RunOptions};

fn experiment() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/experiment-3uav.toml")).expect("experiment scenario")
}

fn paper() -> String {
    host_sim::scenario::PAPER_10UAV.to_string()
}

fn declare(text: &str, wind: f64, gust: f64) -> String {
    text.replacen("[mission]\n", &format!("[mission]\nmax_wind_mps = {wind}\ngust_margin_mps = {gust}\n"), 1)
}

/// The team's steady-wind capacity as the companions compute it before take-off.
fn capacity(text: &str) -> Cap {
    let s = host_sim::scenario::parse(text, "calm.toml").expect("calm").scenario;
    let c = sim::wind_check(&s, s.cables.rated_n, 0.0, 0.0).expect("holds calm air");
    Cap { steady_mps: f64::from(c.steady_wind_max_mps), limit: format!("{:?}", c.limit) }
}

/// What the tests read of a `WindCapacity`: the steady wind held, m/s, and the binding limit.
#[derive(Debug)]
struct Cap {
    steady_mps: f64,
    limit: String,
}

fn expect_error(text: &str, name: &str, must_contain: &[&str]) {
    common::expect_exit_2("wind", text, name, must_contain);
}

/// The law's capacity is where the plant's team stops holding the tube: the experiment's team
/// flies its mission in a steady wind of 0.9 x the capacity against its first legs. At 1.3 x
/// (which the pre-flight check refuses when declared) it is blown back 2 m within 1.5 s and sets
/// the load down inside the tube, where it stays: 0.16 m up, the 3.06 kg, 0.3 m^2 load meets a
/// quarter of the wind (docs/plant.md, "Wind near the ground"). (With one wind down to the
/// ground, its 18 N of drag dragged it along against 15 N of friction, out of the tube.)
#[test]
fn the_wind_capacity_is_where_the_team_stops_holding_the_tube() {
    let exp = experiment();
    let cap = capacity(&exp);
    for (factor, holds) in [(0.9, true), (1.3, false)] {
        let w = factor * cap.steady_mps;
        // The first legs run east (+x): the wind blows west, against the passing direction.
        let text = format!("{exp}\n[disturbances]\nwind_mean_mps = [{:.3}, 0.0, 0.0]\n", -w);
        let ls = host_sim::scenario::parse(&text, "headwind.toml").expect("valid");
        let out = sim::run(&ls, &RunOptions { record: false, ..RunOptions::default() }).expect("flies");
        let s = &out.summary;
        let inside = s.min_uav_boundary_m > 0.0 && s.min_load_boundary_m > 0.0;
        println!("wind {w:.2} m/s ({factor} x {:.2}): success {}, UAV-boundary {:.2} m, load-boundary {:.2} m", cap.steady_mps, s.success, s.min_uav_boundary_m, s.min_load_boundary_m);
        if holds {
            assert!(s.success && inside, "{factor} x capacity: {s:?}");
        } else {
            assert!(!s.success && inside, "{factor} x capacity should be beyond the team, set down inside: {s:?}");
            assert_eq!(s.outcome, "set_down", "{:?}", s.failures);
            let declared = host_sim::scenario::parse(&declare(&exp, w, 0.0), "declared.toml");
            assert!(declared.is_err(), "{factor} x capacity declared must be refused");
        }
    }
}

/// Issue 29: a declared wind (`[mission] max_wind_mps` plus `gust_margin_mps`) that the team
/// cannot hold in the tube is refused before take-off, exit 2, naming file, line and field with
/// the numbers; the companions aboard refuse the same at `MISSION_START`
/// (firmware/companion/src/flight_tests.rs). No declared wind: no check.
#[test]
fn a_declared_wind_the_team_cannot_hold_is_refused_with_the_numbers() {
    let exp = experiment();
    // The experiment's 1.47 kg / 30 N airframes at 30 deg with 3.06 kg: tilt-bound.
    let cap = capacity(&exp);
    assert_eq!(cap.limit, "Tilt", "{cap:?}");
    assert!((4.0..10.0).contains(&cap.steady_mps), "{cap:?}");
    // The 3x case (9 m/s with 3 m/s gusts) is refused; the 1x case (3 + 1) flies.
    let line = exp.lines().position(|l| l == "[mission]").expect("[mission]") + 2;
    let text = declare(&exp, 9.0, 3.0);
    let need = format!("wind {:.1} m/s (with gust margin), capacity {:.1} m/s (tilt limit)", 12.0, cap.steady_mps);
    expect_error(&text, "windy.toml", &["windy.toml", &format!(":{line}:"), "mission.max_wind_mps", &need, "blown out of the tube"]);
    host_sim::scenario::parse(&declare(&exp, 3.0, 1.0), "breezy.toml").expect("3 + 1 m/s: within the capacity");
    // Just either side of the capacity.
    let c = cap.steady_mps;
    host_sim::scenario::parse(&declare(&exp, c - 1.05, 1.0), "inside.toml").expect("just inside");
    expect_error(&declare(&exp, c - 0.95, 1.0), "outside.toml", &["mission.max_wind_mps"]);
    // The paper's heavier team (2 kg / 50 N at 45 deg, 18 kg) holds more.
    assert!(capacity(&paper()).steady_mps > cap.steady_mps);
    // Out-of-range declarations name their field.
    expect_error(&declare(&exp, -1.0, 0.0), "neg-wind.toml", &["mission.max_wind_mps", "[0, 100]"]);
    expect_error(&declare(&exp, 3.0, f64::INFINITY), "inf-gust.toml", &["mission.gust_margin_mps"]);
}

/// The tube's end is a stop (docs/design.md, "Wind capacity"): with a tailwind of 0.9 x the
/// capacity along its last legs (north), the experiment's team arrives and holds at the end for
/// 15 s after arrival, every UAV and the load inside the end terminal's disk.
#[test]
fn a_tailwind_within_the_capacity_does_not_carry_the_team_past_the_end() {
    let exp = experiment();
    let w = 0.9 * capacity(&exp).steady_mps;
    let text = format!("{}\n[disturbances]\nwind_mean_mps = [0.0, {w:.3}, 0.0]\n", exp.replacen("post_arrival_s = 5.0", "post_arrival_s = 15.0", 1));
    let ls = host_sim::scenario::parse(&text, "tailwind.toml").expect("valid");
    assert_eq!(ls.scenario.mission.post_arrival_s, 15.0);
    let out = sim::run(&ls, &RunOptions { record: false, ..RunOptions::default() }).expect("flies");
    let s = &out.summary;
    println!("tailwind {w:.2} m/s: success {}, UAV-boundary {:.2} m, load-boundary {:.2} m", s.success, s.min_uav_boundary_m, s.min_load_boundary_m);
    assert!(s.success && s.reached_end && s.min_uav_boundary_m > 0.4 && s.min_load_boundary_m > 0.0, "{s:?}");
}

/// Issue 29 from an air start (the paper's): the companions set the load down inside the tube
/// when the team cannot hold it (the load carried back 2 m, or within 0.5 m of the boundary),
/// descend to the load's resting altitude `VT_LOAD_GZ`, slacken and release. The experiment
/// team (capacity 7.63 m/s) in a headwind of 1.11 x and 1.18 x its capacity from the start, and
/// of 1.18 x as a front at 10 s (5 s build-up): set down, the load and every UAV inside the tube,
/// a gentle touchdown, no cable broken. Before the air start could set down, the steady 1.18 x
/// case ended with the load 0.53 m outside. (A 1.11 x front is flown since the wind is sheared
/// near the ground: the load, 3 m up, meets 86 % of it.)
#[test]
fn a_wind_beyond_the_capacity_in_the_air_sets_the_load_down_inside_the_tube() {
    let exp = experiment();
    for (wind, onset) in [(8.5, None), (9.0, None), (9.0, Some(10.0))] {
        let front = onset.map_or(String::new(), |t: f64| format!("wind_onset_s = {t}\n"));
        let text = format!("{exp}\n[disturbances]\nwind_mean_mps = [-{wind}, 0.0, 0.0]\n{front}");
        let ls = host_sim::scenario::parse(&text, "air-front.toml").expect("valid");
        let s = sim::run(&ls, &RunOptions { record: false, ..RunOptions::default() }).expect("flies").summary;
        let names: Vec<&str> = s.phases.iter().map(|m| m.name.as_str()).collect();
        println!(
            "air start, headwind {wind} m/s from {onset:?} s: outcome {}, phases {names:?}, load-boundary {:.3} m, UAV-boundary {:.3} m, UAV-UAV {:.3} m, touchdown {:?}",
            s.outcome, s.min_load_boundary_m, s.min_uav_boundary_m, s.min_uav_uav_m, s.touchdown_speed_mps
        );
        assert_eq!((s.start.as_str(), s.outcome.as_str()), ("air", "set_down"), "{wind} m/s from {onset:?}: {:?}", s.failures);
        assert_eq!(names, ["transport", "descent", "slack", "released"]);
        assert!(s.min_load_boundary_m > 0.0 && s.min_uav_boundary_m > 0.0, "{wind} m/s from {onset:?}: inside the tube");
        assert!(s.touchdown_speed_mps.is_some_and(|v| v <= 0.5), "touchdown {:?}", s.touchdown_speed_mps);
        assert!(!s.reached_end && s.cables_broken == 0);
    }
}

/// Issue 27's safety finding (docs/design.md, "A refused start lands at once"): in the
/// real-aircraft world at three times the nominal campaign's disturbances, seed 7013 of
/// `strong-wind-experiment` has UAV 2 blown off its place 1 s after the take-off (refusal
/// code 10, it lands at once). Its neighbours hold 3 s, then land at once too: the phases go
/// from the take-off straight to `released`. Through the 7 s slack they used to fly at their
/// cables' taut height first, they were blown 6 m downwind and dragged the load 4.95 m out of
/// the tube; it now stays inside.
#[test]
fn a_start_held_in_a_wind_the_team_cannot_fight_lands_and_keeps_the_load_in_the_tube() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/strong-wind-experiment.toml");
    let c = host_sim::campaign::load_in(Some(&path), Some(host_sim::campaign::World::RealAircraft)).expect("campaign");
    let rows = host_sim::campaign::fly(&c, 1, 7013, 1, false).expect("flies");
    let s = &rows.iter().find(|r| r.level == Some(3.0)).expect("the 3x level").summary;
    let names: Vec<&str> = s.phases.iter().map(|m| m.name.as_str()).collect();
    println!("seed 7013 at 3x: outcome {}, phases {names:?}, load-boundary {:.2} m, {:?}", s.outcome, s.min_load_boundary_m, s.failures);
    assert_eq!(s.outcome, "refused");
    assert!(s.failures[0].contains("refusal code 10"), "{:?}", s.failures);
    assert_eq!(names, ["takeoff", "released"], "no slack before the landing");
    assert!(s.min_load_boundary_m > 1.0, "the load stays inside the tube: {:.2} m", s.min_load_boundary_m);
    assert_eq!(s.cables_broken, 0);
}

/// The same rule where part of the team had armed: generated seed 5058 at 1x (four 1.47 kg
/// UAVs, real-aircraft world). UAV 1's start checks refuse at its arming (the hover's wind
/// survey, code 8) and it lands at once, while the other three have armed. Its `released`
/// heartbeat takes it out of their law: kept in, its springs pull the three over its spot on
/// the ground, to 0.74 m between centres (measured with the rule taken out). Now no pair comes
/// closer than the landing's spacing. (Seed 5157 showed it, 0.49 m, until the generator
/// declared the drawn airframe's body and matched its observer's lag, session 52, and drew or
/// flew those seeds otherwise.)
#[test]
fn a_member_that_lands_after_its_refusal_leaves_the_armed_law() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/generated.toml");
    let c = host_sim::campaign::load_in(Some(&path), Some(host_sim::campaign::World::RealAircraft)).expect("campaign");
    let rows = host_sim::campaign::fly(&c, 1, 5058, 1, false).expect("flies");
    let s = &rows.iter().find(|r| r.level == Some(1.0)).expect("the 1x level").summary;
    println!("generated 5058 at 1x: outcome {}, UAV-UAV {:.3} m, {:?}", s.outcome, s.min_uav_uav_m, s.failures);
    assert_eq!(s.outcome, "refused");
    assert!(s.failures[0].contains("UAV 1") && s.failures[0].contains("refusal code 8"), "{:?}", s.failures);
    assert!(s.min_uav_uav_m >= vt_dissipative::landing::LAND_SPACING_M as f64, "UAV-UAV {:.3} m", s.min_uav_uav_m);
}

/// Issue 29's 25-UAV team in the real-aircraft world at the nominal disturbances
/// (`strong-wind-heavy` at 1x). On one 5 m ring its 0.445 m bodies took off 0.04 m apart and
/// every run failed the 0.2 m floor (40 of 40, pairs at 0.75-0.79 m between centres); the
/// scenario now lays it out on two rings (docs/design.md, "Take-off layouts other than the
/// ring"), and its first seeds fly with every pair of bodies at least the floor apart.
#[test]
fn the_25_uav_team_on_two_rings_keeps_its_bodies_apart() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/strong-wind-heavy.toml");
    let c = host_sim::campaign::load_in(Some(&path), Some(host_sim::campaign::World::RealAircraft)).expect("campaign");
    let rows = host_sim::campaign::fly(&c, 3, 7000, 2, false).expect("flies");
    for r in rows.iter().filter(|r| r.level == Some(1.0)) {
        let s = &r.summary;
        println!("25 UAVs, 1x, seed {}: {} UAV-UAV clearance {:.3} m, centres {:.3} m {:?}", s.seed, s.outcome, s.min_uav_uav_clearance_m, s.min_uav_uav_m, s.failures);
        assert!(s.success, "seed {}: {:?}", s.seed, s.failures);
        assert!(s.min_uav_uav_clearance_m >= 0.2, "seed {}: {:.3} m", s.seed, s.min_uav_uav_clearance_m);
    }
}

/// How many of `seeds` (of `s`'s wind) blow a team-mean wind beyond each of `limits_mps`
/// (m/s) within `window_s` of flight: the wind the plant blows (mean, gusts and, when `s` has
/// it, Dryden turbulence at `altitude_m`, as `World` draws them per seed), horizontal, averaged
/// over the team's `n` UAVs and low-passed over `average_s` (the team's and the load's inertia
/// ride out shorter gusts).
fn seeds_beyond(s: &host_sim::scenario::Scenario, seeds: std::ops::Range<u64>, altitude_m: f64, window_s: f64, average_s: f64, limits_mps: &[f64]) -> Vec<usize> {
    let n = s.cables.lengths_m.len();
    let dt = 0.01;
    let mut beyond = vec![0; limits_mps.len()];
    for seed in seeds {
        let mut wind = host_sim::disturbance::Wind::new(&s.disturbances, seed);
        let mut turb = vt_sim::turbulence::Turbulence::of_scenario(s, altitude_m, n, seed);
        let mut averaged: Option<f64> = None;
        let mut peak: f64 = 0.0;
        for _ in 0..(window_s / dt) as usize {
            let mut w = wind.step(dt);
            if let Some(t) = &mut turb {
                t.step(dt);
                w += t.gusts().iter().take(n).sum::<nalgebra::Vector3<f64>>() / n as f64;
            }
            let speed = w.xy().norm();
            let a = averaged.map_or(speed, |a| a + (speed - a) * dt / average_s);
            averaged = Some(a);
            peak = peak.max(a);
        }
        for (b, limit) in beyond.iter_mut().zip(limits_mps) {
            *b += usize::from(peak > *limit);
        }
    }
    beyond
}

/// Issue 27's 3x target (>= 95 % of 100 runs in the real-aircraft world) against the wind that
/// world blows. Its levels scale light Dryden turbulence with the rest, so 3x is severe
/// turbulence (`W20` 45 kt: `sigma_u` 4.3 m/s at the UAVs' 14 m) over a 9 m/s wind with 3 m/s
/// gusts. Over seeds 2000-2099 and 90 s of transport, the team-mean wind averaged over 5 s
/// passes the paper team's capacity (14.6 m/s, cable-bound, what its companions check) in about
/// three runs of four, and the airframes' own (16.3 m/s with the cables' rating lifted,
/// thrust-bound: no controller of these rotors holds it) in about half. Without the turbulence
/// (issue 15's 3x world, where 97 of 100 flew) it passes the capacity in 6. So the 95 % target
/// asks for success where the team cannot hold its station (docs/robustness.md, "3x in the
/// real-aircraft world: the wind beyond the team").
#[test]
fn the_3x_real_aircraft_wind_passes_the_paper_teams_capacity_in_most_flights() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/intensity-3x.toml");
    let c = host_sim::campaign::load_in(Some(&path), Some(host_sim::campaign::World::RealAircraft)).expect("campaign");
    let s = &c.levels[0].1.scenario;
    let cap = sim::wind_check(s, s.cables.rated_n, 0.0, 0.0).expect("holds calm air");
    let rotors = sim::wind_check(s, 20.0 * s.uavs.thrust_max_n, 0.0, 0.0).expect("holds calm air");
    assert_eq!(format!("{:?}", rotors.limit), "Thrust", "{rotors:?}");
    let (cap, rotors) = (f64::from(cap.steady_wind_max_mps), f64::from(rotors.steady_wind_max_mps));
    assert!(s.disturbances.intensity == 3.0 && s.disturbances.turbulence == 1.0, "{:?}", s.disturbances);
    let altitude = s.load.altitude_m + s.cables.lengths_m.iter().sum::<f64>() / s.cables.lengths_m.len() as f64;
    let severe = seeds_beyond(s, 2000..2100, altitude, 90.0, 5.0, &[cap, rotors]);
    let calm = host_sim::scenario::Scenario { disturbances: host_sim::scenario::DisturbanceSpec { turbulence: 0.0, ..s.disturbances.clone() }, ..s.clone() };
    let gusts = seeds_beyond(&calm, 2000..2100, altitude, 90.0, 5.0, &[cap, rotors]);
    println!("capacity {cap:.2} m/s, rotors {rotors:.2} m/s; of 100 seeds beyond them: with turbulence {severe:?}, without {gusts:?}");
    assert!(severe[0] >= 60 && severe[1] >= 30, "{severe:?}");
    assert!(gusts[0] <= 10 && gusts[1] <= 5, "{gusts:?}");
}

/// Refused in the 3x real-aircraft wind, the team lands and stays in the tube: a start refused
/// before the arming lands on each UAV's station, not where the wind carried it, and a UAV
/// carried off its landing place may lean to 60 deg (`vt_dissipative::landing::
/// landing_tilt_max_tan`) where the 45 deg of the transport cut its demand. The `intensity-3x`
/// seeds where a landing UAV was carried out before (its body's edge 4.33, 4.36, 1.34, 2.80, 1.00
/// and 0.25 m past the boundary; three of them into an obstacle of the paper's world): every
/// body keeps the 0.2 m floor to the boundary and to the obstacles now, and no cable breaks
/// (docs/design.md, "The landing after the release tilts to 60 deg").
#[test]
fn a_team_refused_in_the_3x_wind_lands_inside_the_tube() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/intensity-3x.toml");
    let c = host_sim::campaign::load_in(Some(&path), Some(host_sim::campaign::World::RealAircraft)).expect("campaign");
    for seed in [2010, 2015, 2026, 2031, 2059, 2065] {
        let rows = host_sim::campaign::fly(&c, 1, seed, 1, false).expect("flies");
        let s = &rows[0].summary;
        println!("seed {seed}: {}, UAV-boundary {:.2} m, obstacles {:.2} m, cables broken {}", s.outcome, s.min_uav_boundary_m, s.min_obstacle_clearance_m, s.cables_broken);
        assert_eq!(s.outcome, "refused", "seed {seed}");
        assert!(s.min_uav_boundary_m >= 0.2, "seed {seed}: UAV-boundary {:.2} m", s.min_uav_boundary_m);
        assert!(s.min_obstacle_clearance_m >= 0.2, "seed {seed}: obstacles {:.2} m", s.min_obstacle_clearance_m);
        assert_eq!(s.cables_broken, 0, "seed {seed}");
    }
}

/// Issue 27's safety finding, second pass (session 51): a team refused in the 3x wind lands
/// with a guard, the tube keeping (eq:2-14/eq:2-15) and a linear push from neighbours within
/// 0.7 m of the separation floor (`vt_dissipative::landing::guarded_landing_velocity`), instead
/// of its landing places' 1/s hold alone. Over the 100 `intensity-3x` seeds (2000-2099; every
/// run refused on the ground), the runs whose bodies came into contact (centres closer than two
/// 0.445 m bodies, 0.89 m) were 70, the closest pair 0.03 m between centres; with the guard
/// 36, 0.32 m. Asserted with a few runs' room: at most 40, no pair closer than 0.25 m, no UAV
/// out of the tube, no cable broken (docs/design.md, "The landing keeps the tube and its
/// neighbours").
#[test]
fn refused_teams_in_the_3x_wind_land_with_their_bodies_apart_in_most_runs() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/intensity-3x.toml");
    let c = host_sim::campaign::load_in(Some(&path), Some(host_sim::campaign::World::RealAircraft)).expect("campaign");
    let rows = host_sim::campaign::fly(&c, 100, 2000, 2, false).expect("flies");
    let touching = rows.iter().filter(|r| r.summary.min_uav_uav_m < 0.89).count();
    let closest = rows.iter().map(|r| r.summary.min_uav_uav_m).fold(f64::INFINITY, f64::min);
    let out = rows.iter().filter(|r| r.summary.min_uav_boundary_m < 0.0).count();
    println!("{} runs, {touching} with bodies in contact, closest pair {closest:.2} m, {out} with a UAV out", rows.len());
    assert_eq!(rows.len(), 100);
    assert!(rows.iter().all(|r| r.summary.outcome == "refused"), "every 3x run is refused on the ground");
    assert!(touching <= 40, "{touching} runs with bodies in contact (70 before the guard)");
    assert!(closest >= 0.25, "closest pair {closest:.2} m (0.03 m before the guard)");
    assert_eq!(out, 0);
    assert!(rows.iter().all(|r| r.summary.cables_broken == 0));
}
