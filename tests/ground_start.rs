//! The whole mission from the ground (issue 27 §2): `[mission] start = "ground"`. The load rests
//! on the ground, the UAVs hover low with slack cables; the companions fly take-off, tension
//! build-up, lift, climb, transport, descent, set-down and slack (`vt_dissipative::phases`).
//! Plant: the default rigid-body quadrotors behind the PX4-style autopilot on elastic cables,
//! the load on the ground with Coulomb friction (docs/plant.md, "Ground contact").

mod common;

use common::generated;
use host_sim::scenario::{parse, PAPER_10UAV};
use host_sim::sim::{self, RunOptions};
use host_sim::summary::Summary;

const PHASES: [&str; 8] = ["takeoff", "tension", "lift", "climb", "transport", "descent", "slack", "released"];

/// The nominal campaign's disturbances at three times their intensity (issue 29's strong-wind
/// cases: 9 m/s at 20 ft, 3 m/s gusts, 15 cm / 15 cm/s noise, 60 ms latency and jitter).
const THREE_X_NOMINAL: &str = "[link]\ndrop_probability = 0.1\n[disturbances]\nposition_noise_m = 0.05\nvelocity_noise_mps = 0.05\nlatency_s = 0.02\nlink_jitter_s = 0.02\nwind_mean_mps = [3.0, 0.0, 0.0]\ngust_std_mps = 1.0\ngust_tau_s = 2.0\nintensity = 3.0\n";

fn ground(text: &str) -> String {
    text.replacen("[mission]\n", "[mission]\nstart = \"ground\"\n", 1)
}

fn fly(text: &str) -> (Summary, host_sim::record::RunRecord) {
    let ls = parse(text, "ground.toml").expect("valid scenario");
    let out = sim::run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("flies");
    (out.summary, out.record)
}

fn names(s: &Summary) -> Vec<&str> {
    s.phases.iter().map(|m| m.name.as_str()).collect()
}

/// The paper mission from the ground: every phase in order, no snatch above 1.5 x rated, the
/// tensions even when the load leaves the ground, a touchdown below 0.5 m/s, the load back on
/// the ground at the end, inside the tube throughout.
#[test]
fn the_paper_mission_lifts_off_transports_and_sets_down() {
    let (s, rec) = fly(&ground(PAPER_10UAV));
    println!(
        "ground start: success {} {:?}, phases {:?}, lift peak {:?} N, spread {:?}, touchdown {:?} m/s, arrival {:?} s, clearances {:.3}/{:.3}/{:.3} m",
        s.success,
        s.failures,
        s.phases,
        s.lift_peak_tension_n,
        s.lift_share_spread,
        s.touchdown_speed_mps,
        s.completion_time_s,
        s.min_uav_uav_clearance_m,
        s.min_uav_boundary_clearance_m,
        s.min_obstacle_clearance_m
    );
    assert!(s.success, "{:?}", s.failures);
    assert_eq!((s.uav_model.as_str(), s.cable_model.as_str(), s.start.as_str()), ("rigid_body", "elastic", "ground"));
    assert_eq!(names(&s), PHASES, "every phase, in order");
    assert!(s.phases.windows(2).all(|w| w[0].start_s < w[1].start_s), "phases in time order: {:?}", s.phases);
    let peak = s.lift_peak_tension_n.expect("lift peak");
    assert!(peak > 0.5 * s.load_mass_kg * 9.81 / s.n_uavs as f64, "the cables carried the load at lift: peak {peak:.1} N");
    assert!(peak <= 1.5 * s.rated_n, "snatch {peak:.1} N > 1.5 x rated {} N", s.rated_n);
    let spread = s.lift_share_spread.expect("share spread at lift-off");
    assert!(spread < 0.2, "uneven sharing at lift-off: {spread:.3}");
    let touchdown = s.touchdown_speed_mps.expect("touchdown");
    assert!(touchdown <= 0.5, "touchdown at {touchdown:.2} m/s");
    for m in &s.phases {
        assert!(m.swing_deg < 10.0, "swing {:.1} deg at {}", m.swing_deg, m.name);
    }
    assert!(s.min_load_boundary_m > 0.0 && s.min_uav_boundary_m > 0.0, "inside the tube");
    // The load started and ended on the ground (its envelope's radius up), and flew at its
    // altitude in between.
    let z: Vec<f64> = rec.load_pos_m.iter().map(|p| p[2]).collect();
    let rest = s.load_radius_m;
    assert!((z[0] - rest).abs() < 0.02 && (z[z.len() - 1] - rest).abs() < 0.02, "on the ground at both ends: {} / {}", z[0], z[z.len() - 1]);
    let top = z.iter().copied().fold(f64::MIN, f64::max);
    assert!(top > 5.0, "transport altitude reached: {top:.2} m");
    assert!(z.iter().all(|&h| h >= rest - 1e-9), "the load never went into the ground");
    // The replay timeline carries the phases.
    let marks = rec.events.iter().filter(|e| format!("{:?}", e.kind).starts_with("Phase")).count();
    assert_eq!(marks, PHASES.len());
}

/// The time limit judges the arrival (docs/design.md, "The time limit judges the arrival"): the
/// paper mission from the ground with its limit 3 s after its arrival flies on for its set-down
/// and succeeds, where the flight used to end in the descent with "the load was not set down";
/// with its limit 3 s before the arrival it fails on the arrival alone.
#[test]
fn a_load_that_arrives_in_time_is_set_down_after_the_time_limit() {
    let text = ground(PAPER_10UAV);
    let (full, _) = fly(&text);
    let arrival = full.completion_time_s.expect("the paper mission arrives");
    let limited = |limit: f64| fly(&text.replacen("time_limit_s = 150.0", &format!("time_limit_s = {limit:.2}"), 1)).0;
    let late = limited(arrival + 3.0);
    println!("arrival {arrival:.2} s; limit + 3 s: {} {:?}, flown {:.1} s, phases {:?}", late.success, late.failures, late.sim_time_s, names(&late));
    assert!(late.success, "{:?}", late.failures);
    assert_eq!(names(&late), PHASES, "set down and released after the limit");
    assert!(late.sim_time_s > arrival + 3.0 + 10.0, "flown on past the limit: {:.1} s", late.sim_time_s);
    assert_eq!(late.completion_time_s, Some(arrival), "the same flight up to the limit");
    let early = limited(arrival - 3.0);
    assert!(!early.success && early.failures.iter().any(|f| f.contains("did not reach the end")), "{:?}", early.failures);
    assert!(early.sim_time_s <= arrival - 3.0 + 0.01, "no allowance without an arrival: {:.2} s", early.sim_time_s);
}

/// A load heavier than declared (26 kg against 18 kg: the pre-flight check passes on the
/// declaration) does not leave the ground: the team abandons the lift when a cable passes
/// 1.25 x rated, slackens its cables and releases. Refused, no cable broken, the load never up.
#[test]
fn an_undeclared_overload_is_abandoned_on_the_ground() {
    let text = ground(PAPER_10UAV).replacen("[load]\n", "[load]\ntrue_mass_kg = 26.0\n", 1);
    let (s, rec) = fly(&text);
    println!("overload: outcome {}, {:?}, phases {:?}, peak {:?} N", s.outcome, s.failures, names(&s), s.lift_peak_tension_n);
    assert_eq!(s.outcome, "refused");
    assert!(s.failures[0].contains("did not leave the ground"), "{:?}", s.failures);
    assert_eq!(names(&s), ["takeoff", "tension", "lift", "slack", "released"]);
    assert_eq!(s.cables_broken, 0);
    let peak = s.lift_peak_tension_n.expect("peak");
    assert!(peak <= 1.5 * s.rated_n, "snatch {peak:.1} N");
    let top = rec.load_pos_m.iter().map(|p| p[2]).fold(f64::MIN, f64::max);
    assert!(top < s.load_radius_m + 0.2, "the load stayed down: {top:.2} m");
    assert_eq!(s.touchdown_speed_mps, None);
}

/// The start checks run with the cables taut and the load still down: a declared wind above the
/// team's capacity is refused there (code 8), and the team lands at once. (Scenario
/// validation refuses such a file before any flight; a campaign's drawn wind reaches the
/// companions as this one does.)
#[test]
fn a_refused_start_check_leaves_the_load_on_the_ground() {
    let mut ls = parse(&ground(PAPER_10UAV), "ground.toml").expect("valid scenario");
    ls.scenario.mission.max_wind_mps = Some(30.0);
    let out = sim::run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("flies");
    let (s, rec) = (out.summary, out.record);
    println!("wind refusal: outcome {}, {:?}, phases {:?}", s.outcome, s.failures, names(&s));
    assert_eq!(s.outcome, "refused");
    assert!(s.failures[0].contains("refusal code 8"), "{:?}", s.failures);
    assert_eq!(names(&s), ["takeoff", "tension", "released"]);
    let top = rec.load_pos_m.iter().map(|p| p[2]).fold(f64::MIN, f64::max);
    assert!(top < s.load_radius_m + 0.05, "the load stayed down: {top:.2} m");
}

/// An air start is in transport from its start (the phases exist for a set-down, tests/wind.rs)
/// and has no lift or touchdown figures; `start` is `air`.
#[test]
fn an_air_start_has_no_ground_figures() {
    let ls = parse(PAPER_10UAV, "paper.toml").unwrap();
    let s = sim::run(&ls, &RunOptions { duration_s: Some(5.0), record: false, ..RunOptions::default() }).unwrap().summary;
    assert_eq!(s.start, "air");
    assert_eq!(names(&s), ["transport"]);
    assert_eq!(s.phases[0].start_s, 0.0);
    assert!(s.lift_peak_tension_n.is_none() && s.lift_share_spread.is_none() && s.touchdown_speed_mps.is_none());
}

/// Issue 29 with the ground start: the experiment team (capacity 7.63 m/s, tilt-bound,
/// docs/design.md "Wind capacity") from the ground in a headwind along its first legs.
/// - At 0.9 x the capacity it flies.
/// - A steady 1.11 x, 1.18 x or 1.57 x is seen by the hover's observers before the lift and
///   refused on the ground (code 8), no declaration needed. (Before the wind was sheared near
///   the ground, 1.18 x blew the UAVs off their places in the take-off, code 10; in the gusts of
///   the next test some still are.)
/// - 9 and 10 m/s arriving as a gust front after the lift (onset 22 s, 5 s build-up; 8.5 m/s is
///   now flown, the load 3 m up meeting 86 % of it and the capacity law counting all): the team
///   cannot hold the tube and the companions set the load down where it is (the load carried
///   back 2 m, or within 0.5 m of the boundary): outcome `set_down`, the load and every UAV
///   inside the tube, a gentle touchdown. (The air start sets down too: tests/wind.rs.)
#[test]
fn a_wind_the_team_cannot_hold_is_refused_on_the_ground_or_sets_the_load_down_inside_the_tube() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let exp = ground(&std::fs::read_to_string(path).expect("experiment scenario"));
    for (wind, onset, outcome, code) in
        [(6.87, None, "flown", 0), (8.5, None, "refused", 8), (9.0, None, "refused", 8), (12.0, None, "refused", 8), (9.0, Some(22.0), "set_down", 0), (10.0, Some(22.0), "set_down", 0)]
    {
        let front = onset.map_or(String::new(), |t| format!("wind_onset_s = {t}\n"));
        let text = format!("{exp}\n[disturbances]\nwind_mean_mps = [-{wind}, 0.0, 0.0]\n{front}");
        let (s, _) = fly(&text);
        println!(
            "headwind {wind} m/s from {onset:?} s: outcome {}, {:?}, load-boundary {:.3} m, UAV-boundary {:.3} m, UAV-UAV {:.3} m, touchdown {:?}",
            s.outcome, s.failures, s.min_load_boundary_m, s.min_uav_boundary_m, s.min_uav_uav_m, s.touchdown_speed_mps
        );
        assert_eq!(s.outcome, outcome, "{wind} m/s from {onset:?}: {:?}", s.failures);
        assert!(s.min_load_boundary_m > 0.0 && s.min_uav_boundary_m > 0.0, "{wind} m/s: inside the tube");
        assert_eq!(s.cables_broken, 0);
        match outcome {
            "flown" => assert!(s.success, "{:?}", s.failures),
            "refused" => {
                assert!(s.failures[0].contains(&format!("refusal code {code})")), "{:?}", s.failures);
                assert!(!names(&s).contains(&"climb"), "refused before the load left the ground: {:?}", names(&s));
                if code == 10 {
                    // The drifting UAV lands at once; its team, held by its refusal, abandons
                    // after `LIFT_HOLD_ABORT_S` and lands after the slack.
                    assert_eq!(names(&s).get(..2), Some(&["takeoff", "tension"][..]));
                    assert!(names(&s).contains(&"released"), "{:?}", names(&s));
                }
            }
            _ => {
                assert!(!s.reached_end);
                assert_eq!(names(&s), PHASES, "every phase, the transport cut short");
                assert!(s.touchdown_speed_mps.is_some_and(|v| v <= 0.5), "touchdown {:?}", s.touchdown_speed_mps);
            }
        }
    }
}

/// Issue 29, a wind the team cannot fight (the experiment's 1.47 kg / 30 N airframes at three
/// times the nominal campaign's disturbances: 9 m/s mean, 3 m/s gusts at 20 ft), undeclared:
/// every start is refused on the ground before any lift, by the hover's wind check (code 8) or
/// by a UAV blown more than `STATION_DRIFT_ABORT_M` off its place (code 10), and the whole team
/// lands: at the end every UAV rests on the ground inside the tube, no cable is broken, and the
/// load was never lifted and never moved (it rests in the weak wind near the ground: before the
/// wind was sheared, it slid up to 7 m out of the tube; docs/design.md, "Wind near the ground").
#[test]
fn a_wind_the_team_cannot_fight_is_refused_on_the_ground_and_the_team_lands() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let exp = ground(&std::fs::read_to_string(path).expect("experiment scenario"));
    let text = format!(
        "{exp}\n{THREE_X_NOMINAL}"
    );
    let ls = parse(&text, "experiment-3x.toml").expect("scenario");
    for seed in 7000..7005 {
        let out = sim::run(&ls, &RunOptions { seed: Some(seed), record: true, ..RunOptions::default() }).expect("flies");
        let (s, rec) = (out.summary, out.record);
        println!("seed {seed}: {} {:?} phases {:?} at {:.1} s", s.outcome, s.failures.first(), names(&s), s.sim_time_s);
        assert_eq!(s.outcome, "refused", "seed {seed}: {:?}", s.failures);
        assert!(s.failures[0].contains("(refusal code 10)") || s.failures[0].contains("(refusal code 8)"), "seed {seed}: {:?}", s.failures);
        // The drifting UAV goes straight from the take-off or the tension to the landing (its
        // held team follows through the slack after `LIFT_HOLD_ABORT_S`); a refused arming
        // slackens first.
        let first_release = names(&s).iter().position(|n| *n == "released");
        assert!(first_release.is_some_and(|k| k <= 3), "seed {seed}: landing at once, {:?}", names(&s));
        assert!(!names(&s).contains(&"lift"), "seed {seed}: never lifted");
        assert!(s.min_load_boundary_m > 0.0 && s.min_uav_boundary_m > 0.0, "seed {seed}: inside the tube");
        let (first, end) = (rec.load_pos_m.first().expect("a record"), rec.load_pos_m.last().expect("a record"));
        let moved = ((end[0] - first[0]).powi(2) + (end[1] - first[1]).powi(2)).sqrt();
        assert!(moved < 0.05, "seed {seed}: the load stays where it rests ({moved:.3} m)");
        assert_eq!(s.cables_broken, 0, "seed {seed}");
        let last = rec.uav_pos_m.last().expect("a record");
        // The record's last frame is up to one record period (50 ms, 3.5 cm at 0.7 m/s) before
        // the end, which waits for every UAV to rest on the ground.
        assert!(last.iter().all(|p| p[2] <= 0.05), "seed {seed}: every UAV down at the end: {last:?}");
        assert!(s.sim_time_s < 60.0, "seed {seed}: the mission ends once all are down ({:.1} s)", s.sim_time_s);
    }
}

/// Issue 29's 25-UAV team (45 kg) from the ground in calm air: its formation runs a limit cycle
/// through the transport (docs/robustness.md, "The 25-UAV team's oscillation, analysed"), which
/// touched the load down at 0.61 m/s. A delivery's descent and slack fly at the descent speed
/// limit (`vt_dissipative::phases::DESCENT_V_MAX_MPS`), and the touchdown is gentle.
#[test]
fn the_25_uav_team_touches_its_45_kg_load_down_gently() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/heavy-25uav.toml")).expect("shipped scenario");
    let (s, _) = fly(&ground(&text));
    let touchdown = s.touchdown_speed_mps.expect("touchdown");
    println!("25 UAVs, 45 kg, calm, ground start: success {} {:?}, touchdown {touchdown:.3} m/s", s.success, s.failures);
    assert!(s.success, "{:?}", s.failures);
    assert_eq!(names(&s), PHASES, "every phase, in order");
    assert!(touchdown <= 0.4, "touchdown at {touchdown:.2} m/s");
}

/// A free UAV holds still (docs/design.md, "The observer of a free UAV"). With its cable slack
/// (take-off, and after the release), the velocity loop's observer at the rigid-body default
/// `mu = 15 rad/s` limit-cycled on any position noise: 0.5-0.8 m/s at about 2 Hz with 1-5 cm of
/// noise, pairs 0.53 m apart centre to centre. Capped at `vt_cfo::UNLOADED_BANDWIDTH_RAD_S`
/// while unloaded, the UAVs hover within centimetres per second. The paper mission from the
/// ground with 5 cm of white position noise and nothing else.
#[test]
fn free_uavs_hold_still_on_noisy_positions() {
    let text = ground(PAPER_10UAV).replacen("[mission]\n", "[disturbances]\nposition_noise_m = 0.05\n\n[mission]\n", 1);
    let (s, rec) = fly(&text);
    let start = |name: &str| s.phases.iter().find(|m| m.name == name).map(|m| m.start_s).expect("phase flown");
    // Horizontal speed, RMS over the UAVs and the samples of [t0, t1), m/s.
    let rms = |t0: f64, t1: f64| {
        let (mut sum, mut k) = (0.0, 0usize);
        for (t, v) in rec.time_s.iter().zip(&rec.uav_vel_mps) {
            if (t0..t1).contains(t) {
                sum += v.iter().map(|u| u[0] * u[0] + u[1] * u[1]).sum::<f64>();
                k += v.len();
            }
        }
        assert!(k > 0, "samples in [{t0}, {t1})");
        (sum / k as f64).sqrt()
    };
    // The closest pair, m, over the samples of [t0, t1).
    let closest = |t0: f64, t1: f64| rec.time_s.iter().zip(&rec.min_uav_uav_m).filter(|(t, _)| (t0..t1).contains(*t)).map(|(_, d)| *d).fold(f64::INFINITY, f64::min);
    let (tension, released) = (start("tension"), start("released"));
    let (takeoff, landing) = (rms(2.0, tension), rms(released, released + 5.0));
    let (near_takeoff, near_landing) = (closest(0.0, tension), closest(released, f64::INFINITY));
    println!("free UAVs on 5 cm noise: horizontal speed rms {takeoff:.3} m/s at take-off, {landing:.3} m/s landing; closest pair {near_takeoff:.3} / {near_landing:.3} m");
    assert!(takeoff < 0.05, "take-off: the free UAVs shake at {takeoff:.3} m/s rms");
    assert!(landing < 0.1, "landing: the free UAVs shake at {landing:.3} m/s rms");
    assert!(near_takeoff > 1.2 && near_landing > 1.2, "closest pair {near_takeoff:.3} m at take-off, {near_landing:.3} m landing");
}

/// Issue 29: the hover sees the gusts too (docs/design.md, "The gusts the hover sees"). The
/// experiment team holds a 6 m/s mean headwind (capacity 7.63 m/s: 6.87 m/s flies, above), but
/// not gusts of 2 m/s sigma on top of it. Undeclared, the tension phase's survey measures
/// both the mean wind and two standard deviations of the airspeed its observer saw, and the
/// arming refuses (code 8) with the load on the ground. In steady wind the same mean flies.
#[test]
fn the_hover_sees_the_gusts_and_refuses_a_gusty_wind_on_the_ground() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let exp = ground(&std::fs::read_to_string(path).expect("experiment scenario"));
    for (gust, outcome) in [(0.0, "flown"), (2.0, "refused")] {
        let text = format!("{exp}\n[disturbances]\nwind_mean_mps = [-6.0, 0.0, 0.0]\ngust_std_mps = {gust}\ngust_tau_s = 2.0\n");
        let (s, _) = fly(&text);
        println!("6 m/s headwind, gusts {gust} m/s sigma: outcome {}, {:?}", s.outcome, s.failures);
        assert_eq!(s.outcome, outcome, "gusts {gust}: {:?}", s.failures);
        assert!(s.min_load_boundary_m > 0.0 && s.min_uav_boundary_m > 0.0, "inside the tube");
        if outcome == "refused" {
            assert!(s.failures[0].contains("refusal code 8)"), "{:?}", s.failures);
            assert!(!names(&s).contains(&"climb"), "refused before the load left the ground: {:?}", names(&s));
        } else {
            assert!(s.success, "{:?}", s.failures);
        }
    }
}

/// Issue 29, the hover's wind survey spans the whole take-off and tension, not the tension's
/// last 2 s (docs/design.md, "Wind near the ground"): the narrowing team at three times the
/// nominal disturbances (9 m/s at 20 ft, 3 m/s gusts with a 2 s correlation time), seed 7028,
/// whose last 2 s of tension fall in a lull (its UAVs saw 4.0-4.6 m/s there). Surveyed over
/// 15.5 s it sees about 6.3 m/s with about 5.6 m/s of gust margin and is refused on the ground
/// (code 8); surveyed over the last 2 s it armed, could not hold the tube and set its load down
/// 1.1 m outside the 2.5 m-wide narrowing.
#[test]
fn a_lull_at_the_end_of_the_hover_does_not_arm_the_team() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/narrowing-3uav.toml")).expect("shipped scenario");
    let text = format!(
        "{}\n{THREE_X_NOMINAL}",
        ground(&text)
    );
    let ls = parse(&text, "narrowing-3x.toml").expect("scenario");
    let s = sim::run(&ls, &RunOptions { seed: Some(7028), ..RunOptions::default() }).expect("flies").summary;
    println!("seed 7028: {} {:?} phases {:?}", s.outcome, s.failures.first(), names(&s));
    assert_eq!(s.outcome, "refused", "{:?}", s.failures);
    assert!(s.failures[0].contains("(refusal code 8)"), "{:?}", s.failures);
    assert!(!names(&s).contains(&"lift"), "never lifted: {:?}", names(&s));
    assert!(s.min_load_boundary_m > 0.0 && s.min_uav_boundary_m > 0.0, "inside the tube");
}

/// The spring gain of a slow airframe (docs/design.md, "The spring gain of large teams", "...
/// and of slow airframes"): the generated campaign's seed 5044, sixteen 4 kg UAVs behind PX4's
/// stock gains (observer lag 0.142 s) on 9-10 m cables, flown with every disturbance off. At the
/// full spring gain its formation breathed radially at 1.3 Hz through the transport, the mean
/// radius +-0.097 m (1 sigma) about its trend (pairs within 0.14 m of each other's surfaces in
/// the nominal world); at the lag-scaled gain +-0.004 m.
#[test]
fn a_team_of_slow_airframes_does_not_breathe_in_calm_air() {
    let text = generated(5044, 16, "heavy-4kg-100N");
    let mut t: toml::Table = text.parse().expect("the generated TOML");
    let d = t.get_mut("disturbances").and_then(toml::Value::as_table_mut).expect("[disturbances]");
    d.insert("intensity".into(), toml::Value::Float(0.0));
    let (s, rec) = fly(&t.to_string());
    assert!(s.success, "{:?}", s.failures);
    let start = s.phases.iter().find(|p| p.name == "transport").expect("a transport").start_s;
    // The mean horizontal UAV-load distance over 28 s of the transport, less its 2 s moving mean.
    let radius: Vec<f64> = rec
        .time_s
        .iter()
        .zip(&rec.uav_pos_m)
        .zip(&rec.load_pos_m)
        .filter(|((&t, _), _)| t >= start + 2.0 && t <= start + 30.0)
        .map(|((_, uavs), l)| uavs.iter().map(|p| (p[0] - l[0]).hypot(p[1] - l[1])).sum::<f64>() / uavs.len() as f64)
        .collect();
    let k = 50; // 1 s either side at the 50 Hz record
    assert!(radius.len() > 10 * k, "{} samples", radius.len());
    let detrended: Vec<f64> = (k..radius.len() - k).map(|i| radius[i] - radius[i - k..i + k].iter().sum::<f64>() / (2 * k) as f64).collect();
    let sd = (detrended.iter().map(|x| x * x).sum::<f64>() / detrended.len() as f64).sqrt();
    println!("slow airframes in calm air: breathing {sd:.3} m (1 sigma), closest surfaces {:.3} m", s.min_uav_uav_clearance_m);
    assert!(sd < 0.04, "the formation breathes: mean radius +-{sd:.3} m about its trend");
}

/// The descent keeps the load shared (docs/design.md, "The descent shares the load"): generated
/// seed 5084, twenty-three 2 kg UAVs in a straight tube, as drawn (the real-aircraft world's
/// errors). With the sharing integrator held from the end of the transport, the tensions
/// drifted apart in the descent and a pair closed to 0.04 m between surfaces in its slow last
/// metre, under the 0.2 m floor; with the tensions evened in the descent (the load's altitude
/// term left out), 0.39 m (0.33 m with the softer springs of the heaving load).
#[test]
fn a_descending_team_keeps_its_cables_shared_and_its_pairs_apart() {
    let text = generated(5084, 23, "paper-2kg-50N");
    let (s, _) = fly(&text);
    assert_eq!(names(&s), PHASES);
    println!("descent: closest surfaces {:.3} m, touchdown {:.2} m/s", s.min_uav_uav_clearance_m, s.touchdown_speed_mps.unwrap_or(f64::NAN));
    assert!(s.success, "{:?}", s.failures);
    assert!(s.min_uav_uav_clearance_m >= 0.2, "pairs {:.3} m apart", s.min_uav_uav_clearance_m);
    assert!(s.touchdown_speed_mps.is_some_and(|v| v <= 0.5), "touchdown {:?}", s.touchdown_speed_mps);
}

/// The springs while the load heaves (docs/design.md, "The springs while the load heaves"):
/// generated seed 5114, nine 2 kg UAVs, as drawn (the real-aircraft world's errors). At the
/// full spring gain the formation breathed radially once the load left the ground, the load
/// bounced on its cables (its vertical speed 0.44 +- 0.29 m/s through the climb) and a cable the
/// tension build-up had left slack snapped taut at 35.2 N, beyond 1.5 x its 20 N rating; at 0.7
/// of the gain through lift, climb and descent, 0.16 m/s and 15.6 N.
#[test]
fn a_lifting_team_does_not_bounce_its_load_into_a_snatch() {
    let text = generated(5114, 9, "paper-2kg-50N");
    let (s, rec) = fly(&text);
    assert_eq!(names(&s), PHASES);
    let at = |name: &str| s.phases.iter().find(|p| p.name == name).expect("the phase").start_s;
    let (climb, transport) = (at("climb"), at("transport"));
    let vz: Vec<f64> = rec.time_s.iter().zip(&rec.load_vel_mps).filter(|(&t, _)| t >= climb && t < transport).map(|(_, v)| v[2]).collect();
    assert!(vz.len() > 50, "{} samples of the climb", vz.len());
    let mean = vz.iter().sum::<f64>() / vz.len() as f64;
    let sd = (vz.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / vz.len() as f64).sqrt();
    println!("climb: load vertical speed {mean:.2} +- {sd:.2} m/s, lift peak {:.1} N", s.lift_peak_tension_n.unwrap_or(f64::NAN));
    assert!(sd < 0.22, "the load bounces through the climb: +-{sd:.2} m/s");
    assert!(s.lift_peak_tension_n.is_some_and(|t| t <= 30.0), "lift peak {:?} N", s.lift_peak_tension_n);
    assert!(s.success, "{:?}", s.failures);
}
