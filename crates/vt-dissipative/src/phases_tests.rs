//! Tests of the mission phases (`phases.rs`).

use super::*;

fn params() -> PhaseParams {
    PhaseParams {
        ground_z_m: 0.3,
        transport_z_m: 3.0,
        slack_m: 0.5,
        takeoff_s: 4.0,
        tension_vz_mps: 0.2,
        pretension_n: 5.0,
        lift_vz_mps: 0.1,
        climb_vz_mps: 0.5,
        lift_clear_m: 0.2,
        lift_extra_m: 0.5,
        touchdown_band_m: 1.0,
        settle_s: 2.0,
    }
}

/// Steps until `phase` changes (at most `limit` steps), returning the steps taken.
fn run(pr: &mut PhaseProfile, load_z: impl Fn(f32) -> f32, arrived: bool, limit: usize) -> usize {
    let start = pr.phase();
    for k in 0..limit {
        let z = load_z(pr.load_altitude_ref_m());
        pr.step(0.02, Some(z), arrived, false);
        if pr.phase() != start {
            return k + 1;
        }
    }
    limit
}

#[test]
fn the_whole_sequence_in_order_with_a_continuous_reference() {
    let p = params();
    let mut pr = PhaseProfile::ground(p).unwrap();
    assert_eq!(pr.phase(), Phase::Takeoff);
    assert!((pr.load_altitude_ref_m() - (0.3 - 0.5)).abs() < 1e-6);
    let k = run(&mut pr, |_| 0.3, false, 10_000);
    assert_eq!(pr.phase(), Phase::Tension);
    assert!((k as f32 * 0.02 - 4.0).abs() < 0.03, "take-off lasts takeoff_s: {k}");
    let mut surveyed = 0;
    while !pr.ready_to_arm() {
        surveyed += usize::from(pr.surveying());
        pr.step(0.02, Some(0.3), false, false);
    }
    assert!((surveyed as f32 * 0.02 - p.settle_s).abs() < 0.05, "survey lasts settle_s: {surveyed}");
    pr.armed(0.31);
    assert_eq!(pr.phase(), Phase::Lift);
    assert!((pr.load_altitude_ref_m() - 0.31).abs() < 1e-6, "lift starts at the measured load");
    // The load follows the ramp once it is 1 cm above the ground reference.
    let follow = |z: f32| z.max(0.3);
    let mut last = pr.load_altitude_ref_m();
    let mut order = vec![pr.phase()];
    for _ in 0..100_000 {
        let arrived = pr.phase() == Phase::Transport;
        let z_load = if pr.phase() == Phase::Descent || pr.phase() == Phase::Slack { follow(pr.load_altitude_ref_m()) } else { follow(last) };
        let z = pr.step(0.02, Some(z_load), arrived, false);
        assert!((z - last).abs() <= 0.5 * 0.02 + 1e-5, "the reference moves at most v_climb: {last} -> {z}");
        last = z;
        if order.last() != Some(&pr.phase()) {
            order.push(pr.phase());
        }
        if pr.phase() == Phase::Released {
            break;
        }
    }
    assert_eq!(order, vec![Phase::Lift, Phase::Climb, Phase::Transport, Phase::Descent, Phase::Slack, Phase::Released]);
    assert!((pr.load_altitude_ref_m() - (0.3 - 0.5)).abs() < 1e-5);
    assert_eq!(pr.abort(), None);
}

#[test]
fn a_hold_freezes_the_ramp_and_the_timers() {
    let mut pr = PhaseProfile::ground(params()).unwrap();
    // Held for just under `LIFT_HOLD_ABORT_S`, twice: frozen, and the hold time restarts.
    for _ in 0..2 {
        for _ in 0..145 {
            pr.step(0.02, Some(0.3), false, true);
        }
        assert_eq!((pr.phase(), pr.load_altitude_ref_m()), (Phase::Takeoff, 0.3 - 0.5));
        pr.step(0.02, Some(0.3), false, false);
    }
    run(&mut pr, |_| 0.3, false, 10_000);
    while !pr.ready_to_arm() {
        pr.step(0.02, Some(0.3), false, false);
    }
    pr.armed(0.3);
    let z = pr.load_altitude_ref_m();
    for _ in 0..100 {
        assert_eq!(pr.step(0.02, Some(0.3), false, true), z);
    }
    // An unknown load altitude also waits.
    assert_eq!(pr.step(0.02, None, false, false), z);
}

#[test]
fn a_start_held_too_long_or_off_station_is_abandoned_with_the_load_down() {
    // A hold longer than `LIFT_HOLD_ABORT_S` before the arming: refused, the team lands at once.
    let mut pr = PhaseProfile::ground(params()).unwrap();
    for _ in 0..149 {
        pr.step(0.02, Some(0.3), false, true);
    }
    assert_eq!((pr.phase(), pr.abort()), (Phase::Takeoff, None), "not before LIFT_HOLD_ABORT_S");
    for _ in 0..2 {
        pr.step(0.02, Some(0.3), false, true);
    }
    assert_eq!((pr.phase(), pr.abort()), (Phase::Released, Some(Abort::Refused)));
    assert!(pr.load_altitude_ref_m() <= 0.3);
    // Off station (the caller's watch): released at once, in take-off and in tension.
    for tension in [false, true] {
        let mut pr = PhaseProfile::ground(params()).unwrap();
        if tension {
            run(&mut pr, |_| 0.3, false, 10_000);
            assert_eq!(pr.phase(), Phase::Tension);
        }
        pr.land_now();
        assert_eq!((pr.phase(), pr.abort()), (Phase::Released, Some(Abort::Refused)));
    }
    // Not once armed: a_refusal_before_the_lift_lands_at_once.
}

#[test]
fn the_overload_watch_ignores_a_bounce_and_confirms_an_overload() {
    let dt = 0.02;
    // A bouncing cable: above the 25 N level for one step in three, never for long.
    let mut w = OverloadWatch::default();
    for k in 0..1000 {
        let t = if k % 3 == 0 { 26.0 } else { 18.0 };
        assert!(!w.overloaded(t, 20.0, dt), "bounce at step {k}");
    }
    // An overload: abandoned after the confirmation time, not before.
    let mut w = OverloadWatch::default();
    let steps = (0..100).position(|_| w.overloaded(25.5, 20.0, dt)).unwrap();
    assert_eq!(steps + 1, (LIFT_ABORT_CONFIRM_S / dt).round() as usize);
    let mut nan = OverloadWatch::default();
    assert!(!(0..100).any(|_| nan.overloaded(f32::NAN, 20.0, dt)));
}

#[test]
fn a_lift_held_too_long_is_abandoned_and_the_slack_goes_on_in_a_hold() {
    let mut pr = PhaseProfile::ground(params()).unwrap();
    run(&mut pr, |_| 0.3, false, 10_000);
    while !pr.ready_to_arm() {
        pr.step(0.02, Some(0.3), false, false);
    }
    pr.armed(0.3);
    let steps = (LIFT_HOLD_ABORT_S / 0.02) as usize;
    for _ in 0..steps - 5 {
        pr.step(0.02, Some(0.3), false, true);
    }
    pr.step(0.02, Some(0.3), false, false);
    for _ in 0..steps - 5 {
        pr.step(0.02, Some(0.3), false, true);
    }
    assert_eq!(pr.phase(), Phase::Lift, "a released hold restarts the count");
    for _ in 0..10 {
        pr.step(0.02, Some(0.3), false, true);
    }
    assert_eq!((pr.phase(), pr.abort()), (Phase::Slack, Some(Abort::LiftFailed)));
    let z = pr.load_altitude_ref_m();
    pr.step(0.02, Some(0.3), false, true);
    assert!(pr.load_altitude_ref_m() < z, "the slack goes on in a hold");
}

#[test]
fn a_load_that_stays_on_the_ground_abandons_the_lift() {
    let p = params();
    let mut pr = PhaseProfile::ground(p).unwrap();
    run(&mut pr, |_| 0.3, false, 10_000);
    while !pr.ready_to_arm() {
        pr.step(0.02, Some(0.3), false, false);
    }
    pr.armed(0.3);
    let top = p.ground_z_m + p.lift_clear_m + p.lift_extra_m;
    let mut k = 0;
    while pr.phase() == Phase::Lift && k < 100_000 {
        // The ramp stops at its top; a load that does not rise is refused there.
        assert!(pr.step(0.02, Some(0.3), false, false) <= top + 1e-6 || pr.phase() != Phase::Lift);
        k += 1;
    }
    assert_eq!(pr.phase(), Phase::Slack);
    assert_eq!(pr.abort(), Some(Abort::LiftFailed));
    let expected = (p.lift_clear_m + p.lift_extra_m) / p.lift_vz_mps + LIFT_PROGRESS_TIMEOUT_S;
    assert!((k as f32 * 0.02 - expected).abs() < 0.05, "abandoned after {k} steps, {expected} s expected");
    assert!(pr.load_altitude_ref_m() <= p.ground_z_m);
    run(&mut pr, |_| 0.3, false, 100_000);
    assert_eq!(pr.phase(), Phase::Released);
}

/// Issue 27 at 19.8 kg on the 20 N clamp (seed 7119): the load leaves the ground at the team's
/// last newtons, slower than the ramp. The ramp waits at its top while the load still rises
/// ([`LIFT_PROGRESS_M`] within [`LIFT_PROGRESS_TIMEOUT_S`]) and the lift ends as any other; a
/// load that rises and then stops short is refused one timeout after its last progress; a hold
/// at the top freezes the wait.
#[test]
fn a_load_that_leaves_the_ground_slowly_is_lifted() {
    let p = params();
    let start = |pr: &mut PhaseProfile| {
        run(pr, |_| 0.3, false, 10_000);
        while !pr.ready_to_arm() {
            pr.step(0.02, Some(0.3), false, false);
        }
        pr.armed(0.3);
    };
    let top = p.ground_z_m + p.lift_clear_m + p.lift_extra_m;
    let ramp_s = (p.lift_clear_m + p.lift_extra_m) / p.lift_vz_mps;
    // Rising at 0.02 m/s from when the ramp is at its top: 10 s to clear, twice the timeout.
    let mut pr = PhaseProfile::ground(p).unwrap();
    start(&mut pr);
    let mut t = 0.0f32;
    while pr.phase() == Phase::Lift && t < 100.0 {
        let z = 0.3 + 0.02 * (t - ramp_s).max(0.0);
        assert!(pr.step(0.02, Some(z), false, false) <= top + 1e-6);
        t += 0.02;
    }
    assert_eq!(pr.phase(), Phase::Climb, "lifted after {t} s");
    assert_eq!(pr.abort(), None);
    assert!((t - (ramp_s + p.lift_clear_m / 0.02)).abs() < 0.1, "lifted after {t} s");
    // Rising 0.12 m at the top, then stuck: refused one timeout after its last 5 cm (its
    // second, at 0.1 m).
    let mut pr = PhaseProfile::ground(p).unwrap();
    start(&mut pr);
    let mut t = 0.0f32;
    while pr.phase() == Phase::Lift && t < 100.0 {
        let z = 0.3 + (0.02 * (t - ramp_s).max(0.0)).min(0.12);
        pr.step(0.02, Some(z), false, false);
        t += 0.02;
    }
    assert_eq!(pr.abort(), Some(Abort::LiftFailed));
    let last_progress_s = ramp_s + 0.1 / 0.02;
    assert!((t - (last_progress_s + LIFT_PROGRESS_TIMEOUT_S)).abs() < 0.2, "refused after {t} s");
    // A hold at the top freezes the wait (and is itself bounded by LIFT_HOLD_ABORT_S).
    let mut pr = PhaseProfile::ground(p).unwrap();
    start(&mut pr);
    for _ in 0..((ramp_s + LIFT_PROGRESS_TIMEOUT_S - 1.0) / 0.02) as usize {
        pr.step(0.02, Some(0.3), false, false);
    }
    for _ in 0..((LIFT_HOLD_ABORT_S - 0.5) / 0.02) as usize {
        pr.step(0.02, Some(0.3), false, true);
    }
    assert_eq!(pr.phase(), Phase::Lift, "a short hold neither refuses nor advances the wait");
    for _ in 0..(0.9 / 0.02) as usize {
        pr.step(0.02, Some(0.3), false, false);
    }
    assert_eq!(pr.phase(), Phase::Lift);
    for _ in 0..(0.2 / 0.02) as usize {
        pr.step(0.02, Some(0.3), false, false);
    }
    assert_eq!(pr.abort(), Some(Abort::LiftFailed));
}

/// A profile in climb, the load just off the ground.
fn climbing(p: PhaseParams) -> PhaseProfile {
    let mut pr = PhaseProfile::ground(p).unwrap();
    run(&mut pr, |_| 0.3, false, 10_000);
    while !pr.ready_to_arm() {
        pr.step(0.02, Some(0.3), false, false);
    }
    pr.armed(0.3);
    run(&mut pr, |z| z, false, 10_000);
    assert_eq!(pr.phase(), Phase::Climb);
    pr
}

#[test]
fn the_climb_ends_with_the_load_up_not_the_ramp() {
    let p = params();
    // A load that climbs behind its ramp: the transport waits for it, the ramp at `z_t`.
    let mut pr = climbing(p);
    let mut lagging = p.ground_z_m;
    let mut steps = 0;
    while pr.phase() == Phase::Climb && steps < 100_000 {
        lagging = (lagging + 0.3 * 0.02).min(p.transport_z_m);
        let z = pr.step(0.02, Some(lagging), false, false);
        assert!(z <= p.transport_z_m);
        steps += 1;
    }
    assert_eq!(pr.phase(), Phase::Transport);
    assert!((lagging - (p.transport_z_m - CLIMB_ARRIVE_M)).abs() < 0.01, "left the climb with the load at {lagging}");
    assert_eq!(pr.load_altitude_ref_m(), p.transport_z_m);
    // The transport's settle timer starts from zero, whatever the climb waited.
    let k = run(&mut pr, |_| p.transport_z_m, true, 10_000);
    assert_eq!(pr.phase(), Phase::Descent);
    assert!((k as f32 * 0.02 - p.settle_s).abs() < 0.03, "settled for {k} steps");
    assert!(!pr.set_down_early());
    // An unknown load altitude waits as a low one; a hold freezes the wait.
    let mut pr = climbing(p);
    run(&mut pr, |_| 1.0, false, (p.transport_z_m / p.climb_vz_mps / 0.02) as usize + 10);
    assert_eq!(pr.phase(), Phase::Climb);
    for _ in 0..2_000 {
        pr.step(0.02, None, false, true);
    }
    assert_eq!(pr.phase(), Phase::Climb);
}

#[test]
fn a_load_that_cannot_climb_to_the_transport_altitude_is_set_down() {
    let p = params();
    let mut pr = climbing(p);
    let ramp_s = (p.transport_z_m - pr.load_altitude_ref_m()) / p.climb_vz_mps;
    let low = p.transport_z_m - CLIMB_ARRIVE_M - 0.05;
    let k = run(&mut pr, |_| low, false, 100_000);
    assert_eq!(pr.phase(), Phase::Descent);
    assert!(pr.set_down_early(), "a set-down, not a delivery");
    assert!((k as f32 * 0.02 - (ramp_s + CLIMB_ARRIVE_TIMEOUT_S)).abs() < 0.1, "set down after {k} steps");
    assert!((pr.load_altitude_ref_m() - low).abs() < 0.05, "set down from where the load hangs: {}", pr.load_altitude_ref_m());
    run(&mut pr, |z| z.max(0.3), false, 100_000);
    assert_eq!(pr.phase(), Phase::Slack);
    // A load still rising, if slowly (0.1 m every 5 s), is waited for.
    let mut pr = climbing(p);
    let mut z = 1.0;
    while pr.phase() == Phase::Climb {
        z += 0.02 * 0.02;
        pr.step(0.02, Some(z), false, false);
    }
    assert_eq!(pr.phase(), Phase::Transport, "the slow load arrived at {z}");
}

#[test]
fn a_set_down_in_transport_descends_at_once_and_only_from_transport() {
    let mut pr = PhaseProfile::ground(params()).unwrap();
    pr.set_down_now();
    assert_eq!(pr.phase(), Phase::Takeoff, "nothing before the transport");
    run(&mut pr, |_| 0.3, false, 10_000);
    while !pr.ready_to_arm() {
        pr.step(0.02, Some(0.3), false, false);
    }
    pr.armed(0.3);
    while pr.phase() != Phase::Transport {
        let z = pr.load_altitude_ref_m();
        pr.step(0.02, Some(z), false, false);
    }
    pr.set_down_now();
    assert_eq!(pr.phase(), Phase::Descent);
    assert!(pr.set_down_early());
    run(&mut pr, |z| z.max(0.3), false, 100_000);
    assert_eq!(pr.phase(), Phase::Slack);
}

/// The set-down's trigger: carried back beyond 2 m, or within the edge of the boundary.
#[test]
fn the_watch_arms_the_edge_once_the_load_was_well_inside() {
    let dt = 0.2;
    let mut w = HoldWatch::new();
    // A re-planned tube with the load near its edge: not the team losing it.
    assert!(!w.cannot_hold(4.0, 0.2, dt) && !w.cannot_hold(4.0, 0.2, dt));
    assert!(!w.cannot_hold(4.5, SET_DOWN_EDGE_ARM_M, dt));
    // Armed: the edge band counts once confirmed, the hard edge at once.
    assert!(!w.cannot_hold(5.0, 0.45, dt), "one look in the band is a swing");
    assert!(w.cannot_hold(5.0, 0.45, dt), "confirmed after 0.4 s");
    let mut w = HoldWatch::new();
    assert!(!w.cannot_hold(4.5, SET_DOWN_EDGE_ARM_M, dt));
    assert!(w.cannot_hold(5.0, 0.2, dt), "nearer than the hard edge: at once");
    // A swing that grazes the band for one look in every three never triggers.
    let mut w = HoldWatch::new();
    for k in 0..300 {
        let d = if k % 3 == 0 { 0.45 } else { 0.9 };
        assert!(!w.cannot_hold(5.0 + k as f32 * 0.01, d, dt), "swing at look {k}");
    }
    let mut w = HoldWatch::new();
    assert!(!w.cannot_hold(10.0, 0.3, dt) && !w.cannot_hold(8.5, 0.3, dt));
    assert!(w.cannot_hold(7.9, 0.3, dt), "carried back more than 2 m counts unarmed");
    assert!(!HoldWatch::new().cannot_hold(f32::NAN, f32::NAN, dt));
}

/// After arrival the end is a stop (issue 29): carried past it by more than
/// `SET_DOWN_PAST_END_M`, or at the end disk's rim, the team cannot hold it.
#[test]
fn the_watch_after_arrival_stops_a_load_carried_past_the_end() {
    let dt = 0.2;
    let mut w = HoldWatch::new();
    assert!(!w.cannot_hold(40.0, 3.0, dt), "armed well inside");
    // Short of the end, at it and up to the limit past it: holding.
    for past in [-1.0, 0.0, 0.5, SET_DOWN_PAST_END_M] {
        assert!(!w.cannot_hold_end(past, 3.0, dt), "{past} m past the end");
    }
    assert!(w.cannot_hold_end(SET_DOWN_PAST_END_M + 0.01, 3.0, dt), "carried past the end");
    // The rim of the end disk counts as the tube's boundary does.
    let mut w = HoldWatch::new();
    assert!(!w.cannot_hold(40.0, 3.0, dt));
    assert!(w.cannot_hold_end(0.0, SET_DOWN_LOAD_EDGE_HARD_M - 0.01, dt), "at the rim");
    // Carried back by a wind against the passing direction counts only before arrival (the
    // load is then no longer within the end's tolerance): the end look measures along the
    // end's tangent instead.
    let mut w = HoldWatch::new();
    assert!(!w.cannot_hold(40.0, 3.0, dt));
    assert!(!w.cannot_hold_end(-3.0, 3.0, dt));
    assert!(!HoldWatch::new().cannot_hold_end(f32::NAN, f32::NAN, dt));
}

#[test]
fn a_delivery_descends_at_the_descent_speed_limit_and_a_set_down_keeps_its_authority() {
    for phase in Phase::ALL {
        let lim = horizontal_speed_limit_mps(phase, false, 1.5);
        let expected = if matches!(phase, Phase::Descent | Phase::Slack) { DESCENT_V_MAX_MPS } else { 1.5 };
        assert_eq!(lim, expected, "{phase:?}");
        assert_eq!(horizontal_speed_limit_mps(phase, true, 1.5), 1.5, "a set-down keeps v_max in {phase:?}");
    }
    // Never above the airframe's own limit.
    assert_eq!(horizontal_speed_limit_mps(Phase::Descent, false, 0.3), 0.3);
}

/// An air start flies the transport at `z_t` from its first step and hovers at the end
/// after arrival; only a set-down descends, to `z_g`, and then slackens and releases.
#[test]
fn an_air_start_hovers_at_the_end_and_sets_down_only_when_it_cannot_hold() {
    let p = params();
    let mut pr = PhaseProfile::air(p).unwrap();
    assert_eq!((pr.phase(), pr.load_altitude_ref_m()), (Phase::Transport, p.transport_z_m));
    assert_eq!(run(&mut pr, |z| z, true, 10_000), 10_000, "arrival does not end an air start's transport");
    assert_eq!(pr.load_altitude_ref_m(), p.transport_z_m);
    let mut pr = PhaseProfile::air(p).unwrap();
    pr.set_down_now();
    assert_eq!(pr.phase(), Phase::Descent);
    let mut last = pr.load_altitude_ref_m();
    for _ in 0..100_000 {
        let z = pr.step(0.02, Some(pr.load_altitude_ref_m().max(p.ground_z_m)), false, false);
        assert!(z <= last, "the reference only goes down: {z} after {last}");
        last = z;
        if pr.phase() == Phase::Released {
            break;
        }
    }
    assert_eq!(pr.phase(), Phase::Released);
    assert_eq!(pr.load_altitude_ref_m(), p.ground_z_m - p.slack_m);
    assert!(PhaseProfile::air(PhaseParams { ground_z_m: 3.5, ..p }).is_err(), "the ground above the transport altitude");
}

#[test]
fn a_refusal_before_the_lift_lands_at_once() {
    // In take-off and at the end of the tension build-up alike: no slow slack with the load
    // down (a set-down's), the landing straight away.
    for tension in [false, true] {
        let mut pr = PhaseProfile::ground(params()).unwrap();
        if tension {
            run(&mut pr, |_| 0.3, false, 10_000);
            while !pr.ready_to_arm() {
                pr.step(0.02, Some(0.3), false, false);
            }
        }
        pr.refuse();
        assert_eq!((pr.phase(), pr.abort()), (Phase::Released, Some(Abort::Refused)));
        assert_eq!(pr.load_altitude_ref_m(), params().ground_z_m - params().slack_m);
        pr.step(0.02, Some(0.3), false, false);
        assert_eq!(pr.phase(), Phase::Released, "released stays released");
    }
    // Too late to refuse once lifted: nothing changes.
    let mut lifted = PhaseProfile::ground(params()).unwrap();
    run(&mut lifted, |_| 0.3, false, 10_000);
    while !lifted.ready_to_arm() {
        lifted.step(0.02, Some(0.3), false, false);
    }
    lifted.armed(0.3);
    lifted.refuse();
    assert_eq!((lifted.phase(), lifted.abort()), (Phase::Lift, None));
    // Nor to land off station: a lift is abandoned by its own rules.
    lifted.land_now();
    assert_eq!((lifted.phase(), lifted.abort()), (Phase::Lift, None));
}

#[test]
fn tension_law_climbs_holds_and_backs_off() {
    let p = params();
    assert!((tension_climb_mps(0.0, &p) - p.tension_vz_mps).abs() < 1e-6);
    assert!(tension_climb_mps(p.pretension_n, &p).abs() < 1e-6);
    assert!(tension_climb_mps(50.0, &p) < 0.0);
    assert_eq!(tension_climb_mps(f32::NAN, &p), 0.0);
    for code in 0..=255u8 {
        if let Some(ph) = Phase::from_code(code) {
            assert_eq!(ph as u8, code);
        }
    }
    assert_eq!(Phase::ALL.iter().filter(|p| p.passing_off()).count(), 7);
    // The cable carries the load from the lift to the touchdown; never while it is shared.
    let unloaded: Vec<Phase> = Phase::ALL.iter().copied().filter(|p| p.unloaded()).collect();
    assert_eq!(unloaded, [Phase::Takeoff, Phase::Tension, Phase::Slack, Phase::Released]);
    assert!(Phase::ALL.iter().all(|p| !(p.unloaded() && p.sharing() != crate::vertical::Sharing::Off)));
}

#[test]
fn bad_parameters_are_named() {
    let mut p = params();
    p.transport_z_m = 0.1;
    assert_eq!(PhaseProfile::ground(p).err(), Some(ControlError::InvalidParameter("phases.transport_z_m")));
    let mut p = params();
    p.lift_vz_mps = f32::NAN;
    assert_eq!(PhaseProfile::ground(p).err(), Some(ControlError::InvalidParameter("phases.lift_vz_mps")));
}

/// Where the descent's reference first slows to the lift speed: a set-down before arrival (either
/// start) and an air start's after arrival slow in the short set-down band, a ground start's
/// delivery set down after its arrival (carried past the end before its descent) in the
/// delivery's own band.
#[test]
fn a_delivery_set_down_after_arrival_keeps_the_delivery_band() {
    let p = params();
    let band_entry = |mut pr: PhaseProfile| {
        assert_eq!(pr.phase(), Phase::Descent);
        loop {
            let before = pr.load_altitude_ref_m();
            let z = pr.step(0.02, Some(before.max(p.ground_z_m)), false, false);
            if before - z < 0.5 * p.climb_vz_mps * 0.02 {
                return before - p.ground_z_m;
            }
        }
    };
    let in_transport = |ground: bool| {
        let mut pr = if ground { PhaseProfile::ground(p).unwrap() } else { PhaseProfile::air(p).unwrap() };
        for _ in 0..100_000 {
            if pr.phase() == Phase::Transport {
                break;
            }
            if pr.ready_to_arm() {
                pr.armed(p.ground_z_m);
            }
            let z = pr.load_altitude_ref_m();
            pr.step(0.02, Some(z.max(p.ground_z_m)), false, false);
        }
        pr
    };
    let short = SET_DOWN_TOUCHDOWN_BAND_M.min(p.touchdown_band_m);
    for ground in [false, true] {
        let mut pr = in_transport(ground);
        pr.set_down_now();
        assert!((band_entry(pr) - short).abs() < 0.011, "ground {ground}: set down before arrival");
        let mut pr = in_transport(ground);
        pr.step(0.02, Some(p.transport_z_m), true, false);
        pr.set_down_now();
        let band = if ground { p.touchdown_band_m } else { short };
        assert!((band_entry(pr) - band).abs() < 0.011, "ground {ground}: set down after arrival");
    }
}

/// A team near its capacity descends as fast as it can brake (`limit_descent`): the descent's
/// reference falls at the limited speed above the touchdown band and at `v_lift` inside it; the
/// limit stays within `[v_lift, v_climb]`, and a value that is not a positive number changes
/// nothing.
#[test]
fn a_limited_descent_falls_at_its_limit_above_the_band() {
    let p = params();
    let descending = |limit: Option<f32>| {
        let mut pr = PhaseProfile::air(p).unwrap();
        if let Some(v) = limit {
            pr.limit_descent(v);
        }
        pr.set_down_now();
        assert_eq!(pr.phase(), Phase::Descent);
        pr
    };
    // The fall of the reference in one step of 0.02 s, at 2 m above the ground and inside the band.
    let fall = |mut pr: PhaseProfile, above_m: f32| {
        while pr.load_altitude_ref_m() > p.ground_z_m + above_m {
            let z = pr.load_altitude_ref_m();
            pr.step(0.02, Some(z), false, false);
        }
        let before = pr.load_altitude_ref_m();
        (before - pr.step(0.02, Some(before), false, false)) / 0.02
    };
    assert!((fall(descending(None), 2.0) - p.climb_vz_mps).abs() < 1e-4);
    assert!((fall(descending(Some(0.3)), 2.0) - 0.3).abs() < 1e-4);
    assert!((fall(descending(Some(0.3)), 0.2) - p.lift_vz_mps).abs() < 1e-4, "the band keeps v_lift");
    assert_eq!(descending(Some(0.01)).descent_vz_mps(), p.lift_vz_mps);
    assert_eq!(descending(Some(2.0)).descent_vz_mps(), p.climb_vz_mps);
    for bad in [0.0, -0.3, f32::NAN, f32::INFINITY] {
        assert_eq!(descending(Some(bad)).descent_vz_mps(), p.climb_vz_mps, "{bad}");
    }
    // From a capacity margin, with the profile's own `v_lift` and band: 0.4 % brakes from
    // 0.297 m/s; no declared load (an infinite margin) keeps `v_climb`.
    let mut pr = PhaseProfile::air(p).unwrap();
    pr.brake_descent(0.004);
    assert_eq!(pr.descent_vz_mps(), crate::capacity::braking_descent_mps(0.004, p.lift_vz_mps, p.touchdown_band_m));
    assert!((pr.descent_vz_mps() - 0.297).abs() < 0.001);
    let mut pr = PhaseProfile::air(p).unwrap();
    pr.brake_descent(f32::INFINITY);
    assert_eq!(pr.descent_vz_mps(), p.climb_vz_mps);
}
