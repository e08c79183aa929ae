//! Tests of `velocity_loop` (kept apart to keep the law's file short).

use super::*;
use crate::gravity_mps2;
use approx::assert_relative_eq;
use proptest::prelude::*;

const DT_S: f32 = 0.002;

fn plant_step(
    v_mps: Vector3<f32>,
    thrust_n: Vector3<f32>,
    f_n: Vector3<f32>,
    m: f32,
) -> Vector3<f32> {
    v_mps + (thrust_n + gravity_mps2() * m - f_n) / m * DT_S // eq:1-1
}

fn within_limits(t: &Vector3<f32>, l: &ThrustLimits) -> bool {
    let n = t.norm();
    let slack = 4.0 * f32::EPSILON;
    t.iter().all(|c| c.is_finite())
        && n <= l.thrust_max_n() * (1.0 + slack)
        && t.z >= l.thrust_min_n()
        && t.z >= l.tilt_max_cos() * n * (1.0 - slack)
}

#[test]
fn paper_gains_are_the_default() {
    let g = PidGains::default();
    assert_eq!(g.kp, Vector3::repeat(2.0));
    assert_eq!(g.ki, Vector3::repeat(0.1));
    assert_eq!(g.kd, Vector3::repeat(0.1));
    let d = VelocityLoopParams::default();
    assert_eq!(
        VelocityLoopParams::new(d.gains, d.limits, d.integral_limit_mps2, d.cfo),
        Ok(d)
    );
}

#[test]
fn params_reject_bad_gains_naming_the_axis() {
    let d = VelocityLoopParams::default();
    let with = |f: &dyn Fn(&mut PidGains)| {
        let mut g = PidGains::default();
        f(&mut g);
        VelocityLoopParams::new(g, d.limits, d.integral_limit_mps2, d.cfo)
    };
    assert_eq!(
        with(&|g| g.kp.y = -1.0),
        Err(CfoError::InvalidKp { axis: 1 })
    );
    assert_eq!(
        with(&|g| g.ki.z = f32::NAN),
        Err(CfoError::InvalidKi { axis: 2 })
    );
    assert_eq!(
        with(&|g| g.kd.x = 1.0),
        Err(CfoError::InvalidKd { axis: 0 })
    );
    assert_eq!(
        VelocityLoopParams::new(d.gains, d.limits, Vector3::new(1.0, -1.0, 1.0), d.cfo),
        Err(CfoError::InvalidIntegralLimit { axis: 1 })
    );
}

#[test]
fn params_reject_hover_above_thrust_max() {
    let d = VelocityLoopParams::default();
    let heavy = CfoParams::new(15.0, 6.0, DT_S).unwrap(); // 58.9 N > 50 N
    assert!(matches!(
        VelocityLoopParams::new(d.gains, d.limits, d.integral_limit_mps2, heavy),
        Err(CfoError::HoverOutsideThrustLimits { .. })
    ));
}

#[test]
fn hover_at_rest_outputs_weight_compensation() {
    let mut ctl = VelocityLoop::new(VelocityLoopParams::default());
    let out = ctl.update(Vector3::zeros(), Vector3::zeros(), DT_S);
    assert_eq!(out.status, Status::Ok);
    assert_relative_eq!(
        out.thrust_n,
        Vector3::new(0.0, 0.0, 2.0 * GRAVITY_MPS2),
        epsilon = 1e-5
    );
}

/// Warm start (`preload`): hovering on a cable that pulls with `f`, the preloaded loop holds
/// the hover from the first step; a cold one first drops to `-G` and sinks while the observer
/// converges. Same plant, same `f`, with and without the actuator lag.
#[test]
fn preloaded_loop_holds_the_hover_it_starts_in() {
    for lag in [0.0, 0.05] {
        let p = VelocityLoopParams::default().with_actuator_lag(lag).unwrap();
        let m = p.mass_kg();
        let f = Vector3::new(3.0, -1.0, 18.0); // cable term (the cable pulls with -f)
        let sink = |preload: bool| {
            let mut ctl = VelocityLoop::new(p);
            if preload {
                ctl.preload(f);
            }
            let mut v = Vector3::zeros();
            let mut applied = f - gravity_mps2() * m; // the vehicle trimmed in hover
            let mut worst = 0.0f32;
            for _ in 0..500 {
                let out = ctl.update(Vector3::zeros(), v, DT_S);
                applied = if lag > 0.0 { applied + (out.thrust_n - applied) * (DT_S / lag) } else { out.thrust_n };
                v = plant_step(v, applied, f, m);
                worst = worst.max(v.norm());
            }
            worst
        };
        let (warm, cold) = (sink(true), sink(false));
        assert!(warm < 1e-3, "lag {lag}: preloaded loop moved at {warm} m/s");
        assert!(cold > 0.1, "lag {lag}: cold start moved only at {cold} m/s");
    }
    // A non-finite preload changes nothing.
    let mut a = VelocityLoop::new(VelocityLoopParams::default());
    a.preload(Vector3::new(f32::NAN, 0.0, 1.0));
    assert_eq!(a, VelocityLoop::new(VelocityLoopParams::default()));
}

#[test]
fn nan_measurement_outputs_compensated_hover_and_holds_state() {
    // At rest under a constant force for 10 BLIND_HOLD_TAU_S: the mean thrust is the
    // compensated hover `f - G`, the velocity (hence the brake) zero.
    let p = VelocityLoopParams::default();
    let m = p.mass_kg();
    let mut ctl = VelocityLoop::new(p);
    let f = Vector3::new(2.0, 0.0, 6.0);
    let mut v = Vector3::zeros();
    for _ in 0..(10.0 * BLIND_HOLD_TAU_S / DT_S) as usize {
        let out = ctl.update(Vector3::zeros(), v, DT_S);
        v = plant_step(v, out.thrust_n, f, m);
    }
    let integral = ctl.integral_mps2();
    let f_hat = ctl.observer().estimate_n();
    let out = ctl.update(Vector3::zeros(), Vector3::new(f32::NAN, 0.0, 0.0), DT_S);
    assert_eq!(out.status, Status::InvalidInput);
    assert_eq!(out.f_hat_n, f_hat);
    // The f32 mean stops moving once `|T - mean| dt / tau` is below half an ulp of the
    // mean: within about 1.5 mN of 25 N here.
    assert_relative_eq!(out.thrust_n, f - gravity_mps2() * m, epsilon = 3e-3);
    assert_eq!(ctl.integral_mps2(), integral);
}

#[test]
fn without_measurements_the_loop_brakes_and_the_observer_resumes_without_a_jump() {
    // Cruising at 1 m/s east under a constant cable force, then 2 s without measurements:
    // the dead-reckoned brake stops the UAV (the old compensated hover coasted on at
    // 1 m/s), and the first measurement after the gap re-seeds the observer.
    let p = VelocityLoopParams::default();
    let m = p.mass_kg();
    let mut ctl = VelocityLoop::new(p);
    let f = Vector3::new(-3.0, 1.0, 8.0);
    let v_cmd = Vector3::new(1.0, 0.0, 0.0);
    let mut v = Vector3::zeros();
    for _ in 0..(10.0 * BLIND_HOLD_TAU_S / DT_S) as usize {
        let out = ctl.update(v_cmd, v, DT_S);
        v = plant_step(v, out.thrust_n, f, m);
    }
    assert_relative_eq!(v, v_cmd, epsilon = 0.01);
    let f_hat = ctl.observer().estimate_n();
    for _ in 0..(2.0 / DT_S) as usize {
        let out = ctl.update(Vector3::zeros(), Vector3::repeat(f32::NAN), DT_S);
        assert_eq!(out.status, Status::InvalidInput);
        assert!(within_limits(&out.thrust_n, p.limits()));
        v = plant_step(v, out.thrust_n, f, m);
    }
    assert!(v.norm() < 0.05, "braked to {v:?} after 2 s");
    // The gap is over: no spike in the estimate (the old loop predicted over the gap).
    let out = ctl.update(Vector3::zeros(), v, DT_S);
    assert_eq!(out.status, Status::ObserverReset);
    assert!((out.f_hat_n - f_hat).norm() < 0.5, "f_hat {:?} after the gap, {f_hat:?} before", out.f_hat_n);
}

#[test]
fn non_positive_or_non_finite_dt_outputs_compensated_hover() {
    let p = VelocityLoopParams::default();
    for dt in [0.0, -DT_S, f32::NAN, f32::INFINITY] {
        let mut ctl = VelocityLoop::new(p);
        let out = ctl.update(Vector3::new(5.0, 0.0, 0.0), Vector3::zeros(), dt);
        assert_eq!(out.status, Status::InvalidInput);
        assert_eq!(out.thrust_n, Vector3::new(0.0, 0.0, p.hover_thrust_n()));
    }
}

#[test]
fn nan_command_brakes_to_zero_velocity_and_flags_invalid_input() {
    let p = VelocityLoopParams::default();
    let m = p.mass_kg();
    let mut ctl = VelocityLoop::new(p);
    let mut v = Vector3::new(1.0, -1.0, 0.5);
    for _ in 0..5000 {
        let out = ctl.update(Vector3::new(f32::NAN, 0.0, 0.0), v, DT_S);
        assert_eq!(out.status.max(Status::InvalidInput), Status::InvalidInput);
        assert_eq!(out.status, Status::InvalidInput);
        v = plant_step(v, out.thrust_n, Vector3::zeros(), m);
    }
    assert!(v.norm() < 0.01, "{v:?}");
    assert_eq!(ctl.integral_mps2(), Vector3::zeros());
}

#[test]
fn integrator_does_not_wind_up_when_saturated() {
    let p = VelocityLoopParams::default();
    let mut ctl = VelocityLoop::new(p);
    // Demand far beyond the tilt limit, velocity never reached (plant not simulated).
    for _ in 0..5000 {
        let out = ctl.update(Vector3::new(100.0, 0.0, 0.0), Vector3::zeros(), DT_S);
        assert_eq!(out.status, Status::Saturated);
    }
    assert_eq!(ctl.integral_mps2().x, 0.0);
}

#[test]
fn integral_is_clamped_to_limit() {
    let d = VelocityLoopParams::default();
    let gains = PidGains {
        ki: Vector3::repeat(5.0),
        ..PidGains::default()
    };
    let p = VelocityLoopParams::new(gains, d.limits, Vector3::repeat(0.5), d.cfo).unwrap();
    let m = p.mass_kg();
    let mut ctl = VelocityLoop::new(p);
    let mut v = Vector3::zeros();
    let mut peak = 0.0f32;
    // A 1 m/s step: Ki int e_v would reach about 5 * 0.5 m = 2.5 m/s² without the clamp.
    for _ in 0..5000 {
        let out = ctl.update(Vector3::new(1.0, 0.0, 0.0), v, DT_S);
        v = plant_step(v, out.thrust_n, Vector3::zeros(), m);
        peak = peak.max(ctl.integral_mps2().x.abs());
    }
    assert_eq!(peak, 0.5);
}

#[test]
fn reset_clears_integral_and_observer() {
    let p = VelocityLoopParams::default();
    let mut ctl = VelocityLoop::new(p);
    for _ in 0..100 {
        ctl.update(Vector3::new(0.5, 0.0, 0.0), Vector3::zeros(), DT_S);
    }
    ctl.reset();
    assert_eq!(ctl, VelocityLoop::new(p));
}

/// The bandwidth cap (a free UAV's observer): it lowers the observer's bandwidth at once, under
/// the delay's schedule too, lifting it restores the schedule, and a loop whose cap was never
/// set or was lifted flies the same bits as one without.
#[test]
fn bandwidth_cap_lowers_the_observer_and_lifting_it_restores_the_schedule() {
    let p = VelocityLoopParams::default(); // mu = 15 rad/s
    let mut capped = VelocityLoop::new(p);
    let mut plain = VelocityLoop::new(p);
    assert_eq!(capped.bandwidth_cap_rad_s(), f32::INFINITY);
    capped.set_bandwidth_cap(f32::INFINITY); // unchanged: no effect at all
    assert_eq!(capped, plain);
    capped.set_bandwidth_cap(UNLOADED_BANDWIDTH_RAD_S);
    assert_eq!(capped.observer().bandwidth_rad_s(), UNLOADED_BANDWIDTH_RAD_S);
    // A delay whose schedule is above the cap keeps the cap: 4 steps of 2 ms, 0.5 / 0.008 = 62.5.
    capped.update_delayed(Vector3::zeros(), Vector3::zeros(), 4.0 * DT_S, DT_S);
    assert_eq!(capped.observer().bandwidth_rad_s(), UNLOADED_BANDWIDTH_RAD_S);
    // A cap above the configured mu changes nothing; NaN and 0 lift it.
    capped.set_bandwidth_cap(100.0);
    assert_eq!(capped.observer().bandwidth_rad_s(), 15.0);
    for lift in [f32::NAN, 0.0, -1.0] {
        capped.set_bandwidth_cap(UNLOADED_BANDWIDTH_RAD_S);
        capped.set_bandwidth_cap(lift);
        assert_eq!(capped.bandwidth_cap_rad_s(), f32::INFINITY);
        assert_eq!(capped.observer().bandwidth_rad_s(), 15.0);
    }
    // Lifted, the loop flies what one never capped flies (same state, same outputs).
    let mut again = VelocityLoop::new(p);
    again.set_bandwidth_cap(UNLOADED_BANDWIDTH_RAD_S);
    again.set_bandwidth_cap(f32::INFINITY);
    for k in 0..200 {
        let v = Vector3::new(0.01 * k as f32, -0.02, 0.0);
        assert_eq!(again.update(Vector3::new(0.5, 0.0, 0.0), v, DT_S), plain.update(Vector3::new(0.5, 0.0, 0.0), v, DT_S));
    }
}

/// The observer of a lightly loaded UAV: a share up to `LIGHT_SHARE_RATIO` caps the loop as a
/// slack cable does, the cap rises linearly to `mu` at `FULL_SHARE_RATIO` and is lifted from
/// there (the paper team's 0.9 flies as before), never for the tuned loop's lag, and every
/// input that is not a number lifts it.
#[test]
fn a_light_share_caps_the_observer_between_the_free_and_the_full_bandwidth() {
    let (lag, mu) = (0.08, 15.0);
    assert_eq!(loaded_bandwidth_cap(0.0, lag, mu), UNLOADED_BANDWIDTH_RAD_S);
    assert_eq!(loaded_bandwidth_cap(0.38, lag, mu), UNLOADED_BANDWIDTH_RAD_S, "sixteen 2 kg UAVs carrying 12.2 kg");
    assert_eq!(loaded_bandwidth_cap(LIGHT_SHARE_RATIO, lag, mu), UNLOADED_BANDWIDTH_RAD_S);
    let mid = 0.5 * (LIGHT_SHARE_RATIO + FULL_SHARE_RATIO);
    assert_relative_eq!(loaded_bandwidth_cap(mid, lag, mu), 10.0, epsilon = 1e-5);
    assert_relative_eq!(loaded_bandwidth_cap(0.69, 0.101, mu), 5.0 + 10.0 * 0.29 / 0.45, epsilon = 1e-5);
    for full in [FULL_SHARE_RATIO, 0.9, 0.99, 5.0, f32::INFINITY] {
        assert_eq!(loaded_bandwidth_cap(full, lag, mu), f32::INFINITY, "share {full}");
    }
    // Monotone in the share, and never above mu below the full share.
    let mut last = 0.0;
    for k in 0..=100 {
        let c = loaded_bandwidth_cap(k as f32 * 0.0084, lag, mu);
        assert!(c >= last && (c <= mu || c == f32::INFINITY), "{k}: {c}");
        last = c;
    }
    // The tuned loop, a mu already at the free cap, and degenerate inputs: no cap.
    assert_eq!(loaded_bandwidth_cap(0.38, 0.05, mu), f32::INFINITY);
    assert_eq!(loaded_bandwidth_cap(0.38, lag, UNLOADED_BANDWIDTH_RAD_S), f32::INFINITY);
    assert_eq!(loaded_bandwidth_cap(f32::NAN, lag, mu), f32::INFINITY);
    assert_eq!(loaded_bandwidth_cap(0.38, f32::NAN, mu), f32::INFINITY);
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(loaded_bandwidth_cap(0.38, lag, bad), f32::INFINITY, "mu {bad}");
    }
    assert_eq!(loaded_bandwidth_cap(-1.0, lag, mu), UNLOADED_BANDWIDTH_RAD_S, "a negative share is no share");
}

/// The capped observer converges more slowly to a constant force, at the rate its bandwidth
/// says: after 0.3 s (1.5 / mu at 5 rad/s, 4.5 / mu at 15 rad/s) the capped estimate is about
/// three times further off (0.34 against 0.12 N of 3 N).
#[test]
fn capped_observer_tracks_a_force_at_its_lower_bandwidth() {
    let p = VelocityLoopParams::default();
    let (m, f) = (p.mass_kg(), Vector3::new(3.0, 0.0, 0.0));
    let mut err = [0.0f32; 2];
    for (slot, cap) in err.iter_mut().zip([f32::INFINITY, UNLOADED_BANDWIDTH_RAD_S]) {
        let mut ctl = VelocityLoop::new(p);
        ctl.set_bandwidth_cap(cap);
        let mut v = Vector3::zeros();
        for _ in 0..150 {
            let out = ctl.update(Vector3::zeros(), v, DT_S);
            v = plant_step(v, out.thrust_n, f, m);
        }
        *slot = (ctl.observer().estimate_n() - f).norm();
        // Converged in the end, either way.
        for _ in 0..5_000 {
            let out = ctl.update(Vector3::zeros(), v, DT_S);
            v = plant_step(v, out.thrust_n, f, m);
        }
        assert_relative_eq!(ctl.observer().estimate_n(), f, epsilon = 0.01);
    }
    assert!(err[1] > 2.0 * err[0], "capped {} N against {} N after 0.3 s", err[1], err[0]);
}

/// Any f32 including NaN, infinities and huge values.
#[test]
fn command_filter_rejects_a_bad_time_constant() {
    let d = VelocityLoopParams::default();
    for tau in [-0.01, f32::NAN, f32::INFINITY] {
        assert_eq!(d.with_command_filter(tau), Err(CfoError::InvalidCommandFilter));
    }
    assert_eq!(d.with_command_filter(0.0).map(|p| p.command_filter_s()), Ok(0.0));
    assert_eq!(d.command_filter_s(), 0.0);
}

/// Deterministic zero-mean noise in [-sqrt 3, sqrt 3] (unit variance), per axis.
fn noise(state: &mut u32) -> Vector3<f32> {
    let mut draw = || {
        *state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223); // Numerical Recipes LCG
        ((*state >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 2.0 * 1.732_050_8
    };
    Vector3::new(draw(), draw(), draw())
}

/// Flies the loop around a point mass with a constant cable force for 20 s, measuring its
/// velocity with white noise of `sigma` m/s; returns (mean thrust, rms thrust deviation) over
/// the last 10 s, N.
fn fly_with_velocity_noise(p: VelocityLoopParams, sigma: f32) -> (Vector3<f32>, f32) {
    let m = p.mass_kg();
    let f = Vector3::new(3.0, -2.0, 19.6);
    let mut ctl = VelocityLoop::new(p);
    ctl.preload(f);
    let (mut v, mut seed) = (Vector3::zeros(), 7u32);
    let (mut sum, mut sum_sq, mut count) = (Vector3::zeros(), 0.0f32, 0.0f32);
    let expected = f - gravity_mps2() * m;
    for k in 0..10_000 {
        let out = ctl.update(Vector3::zeros(), v + noise(&mut seed) * sigma, DT_S);
        v = plant_step(v, out.thrust_n, f, m);
        if k >= 5_000 {
            sum += out.thrust_n;
            sum_sq += (out.thrust_n - expected).norm_squared();
            count += 1.0;
        }
    }
    (sum / count, (sum_sq / count).sqrt())
}

/// The command filter removes most of the thrust noise that velocity noise causes through the
/// observer's `l1 e` (docs/design.md, "Thrust command filter") and keeps the mean thrust.
#[test]
fn command_filter_attenuates_thrust_noise_and_keeps_the_mean() {
    let p = VelocityLoopParams::default();
    let expected = Vector3::new(3.0, -2.0, 19.6) - gravity_mps2() * p.mass_kg();
    let (mean_raw, rms_raw) = fly_with_velocity_noise(p, 0.15);
    let (mean_f, rms_f) = fly_with_velocity_noise(p.with_command_filter(0.02).unwrap(), 0.15);
    // Unfiltered: about 2 mu sigma m = 9 N rms per axis (white noise through l1 e).
    assert!(rms_raw > 8.0, "unfiltered rms {rms_raw} N");
    assert!(rms_f < 0.3 * rms_raw, "filtered rms {rms_f} N vs {rms_raw} N");
    assert!((mean_f - expected).norm() < 0.5, "filtered mean {mean_f} vs {expected}");
    assert!((mean_raw - expected).norm() < 1.0, "unfiltered mean {mean_raw} vs {expected}");
}

/// With the filter the loop still converges to the command and the observer to the cable
/// force (the observer is told the thrust actually sent).
#[test]
fn filtered_loop_converges_to_the_command_and_the_cable_force() {
    let p = VelocityLoopParams::default().with_command_filter(0.05).unwrap();
    let m = p.mass_kg();
    let (f, v_cmd) = (Vector3::new(4.0, -2.0, 12.0), Vector3::new(1.0, 0.0, -0.3));
    let mut ctl = VelocityLoop::new(p);
    let mut v = Vector3::zeros();
    for _ in 0..30_000 {
        let out = ctl.update(v_cmd, v, DT_S);
        v = plant_step(v, out.thrust_n, f, m);
    }
    assert_relative_eq!(v, v_cmd, epsilon = 0.01);
    assert_relative_eq!(ctl.observer().estimate_n(), f, epsilon = 0.05);
}

/// The filter is a first-order lag on the observer's compensation only: with the PID gains at
/// zero the thrust is `f_f - G`, and `f_f` follows `f_hat` step by step with the exact gain
/// `1 - exp(-h / tau)`, settling on the cable force.
#[test]
fn command_filter_is_a_first_order_lag_on_f_hat() {
    let tau = 0.05;
    let d = VelocityLoopParams::default();
    let gains = PidGains { kp: Vector3::zeros(), ki: Vector3::zeros(), kd: Vector3::zeros() };
    let p = VelocityLoopParams::new(gains, d.limits, d.integral_limit_mps2, d.cfo)
        .and_then(|p| p.with_command_filter(tau))
        .unwrap();
    let (m, weight) = (p.mass_kg(), gravity_mps2() * p.mass_kg());
    let f = Vector3::new(2.0, -1.0, 10.0);
    let gain = 1.0 - (-DT_S / tau).exp();
    let mut ctl = VelocityLoop::new(p);
    let (mut v, mut f_f) = (Vector3::zeros(), Vector3::zeros());
    for _ in 0..5_000 {
        let out = ctl.update(Vector3::zeros(), v, DT_S);
        f_f += (out.f_hat_n - f_f) * gain;
        assert_relative_eq!(out.thrust_n + weight, f_f, epsilon = 1e-3);
        v = plant_step(v, out.thrust_n, f, m);
    }
    assert_relative_eq!(f_f, f, epsilon = 0.05);
}

fn any_component() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -20.0f32..20.0,
        1 => any::<f32>(),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(-f32::MAX),
    ]
}

fn any_vector() -> impl Strategy<Value = Vector3<f32>> {
    (any_component(), any_component(), any_component())
        .prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Closed around a point mass with an unknown constant cable force, the velocity error
    /// settles below 1 cm/s: the observer's `f_hat` carries the force.
    #[test]
    fn closed_loop_rejects_unknown_constant_cable_force(
        fx in -8.0f32..8.0, fy in -8.0f32..8.0, fz in -5.0f32..15.0,
        vx in -1.5f32..1.5, vy in -1.5f32..1.5, vz in -0.5f32..0.5,
        mu in 5.0f32..40.0,
    ) {
        let d = VelocityLoopParams::default();
        let cfo = CfoParams::new(mu, d.mass_kg(), DT_S).unwrap();
        let p = VelocityLoopParams::new(d.gains, d.limits, d.integral_limit_mps2, cfo).unwrap();
        let m = p.mass_kg();
        let f = Vector3::new(fx, fy, fz);
        let v_cmd = Vector3::new(vx, vy, vz);
        let mut ctl = VelocityLoop::new(p);
        let mut v = Vector3::zeros();
        // The paper's Ki = 0.1 against Kp = 2 leaves a slow mode (time constant about 20 s)
        // that bleeds off what the integral gathered in the transient: settle for 60 s.
        for _ in 0..30_000 {
            let out = ctl.update(v_cmd, v, DT_S);
            v = plant_step(v, out.thrust_n, f, m);
        }
        // Then report the worst error over the last 2 s.
        let mut worst = 0.0f32;
        for _ in 0..1000 {
            let out = ctl.update(v_cmd, v, DT_S);
            prop_assert_eq!(out.status, Status::Ok);
            v = plant_step(v, out.thrust_n, f, m);
            worst = worst.max((v_cmd - v).norm());
        }
        prop_assert!(worst < 0.01, "steady-state |e_v| = {worst} m/s");
        prop_assert!((ctl.observer().estimate_n() - f).norm() < 0.05);
    }

    /// Random inputs, including NaN, infinities and huge values, never give a non-finite or
    /// out-of-limit thrust.
    #[test]
    fn output_is_finite_and_within_limits_for_any_input(
        steps in proptest::collection::vec(
            (any_vector(), any_vector(), prop_oneof![
                4 => Just(DT_S), 1 => any::<f32>(), 1 => Just(f32::NAN), 1 => Just(0.0f32)
            ]),
            1..60,
        ),
    ) {
        let p = VelocityLoopParams::default();
        let filtered = p.with_command_filter(0.02).unwrap();
        let (mut ctl, mut ctl_f) = (VelocityLoop::new(p), VelocityLoop::new(filtered));
        for (v_cmd, v_meas, dt) in steps {
            let out_f = ctl_f.update(v_cmd, v_meas, dt);
            prop_assert!(within_limits(&out_f.thrust_n, p.limits()), "filtered: {out_f:?}");
            let out = ctl.update(v_cmd, v_meas, dt);
            prop_assert!(within_limits(&out.thrust_n, p.limits()), "{out:?}");
            prop_assert!(ctl.integral_mps2().iter().zip(p.integral_limit_mps2().iter())
                .all(|(i, l)| i.abs() <= *l));
        }
    }
}

/// A cone set by its tangent: 60 deg (tan = sqrt 3) has cos 1/2; a non-finite or non-positive
/// tangent keeps the limits; the rest of the limits are untouched, and the sphere still binds.
#[test]
fn the_tilt_cone_is_set_by_its_tangent_and_nothing_else() {
    let l = ThrustLimits::default();
    let w = l.with_tilt_max_tan(3f32.sqrt());
    assert_relative_eq!(w.tilt_max_tan(), 3f32.sqrt(), epsilon = 1e-6);
    assert_relative_eq!(w.tilt_max_cos(), 0.5, epsilon = 1e-6);
    assert_eq!((w.thrust_min_n(), w.thrust_max_n(), w.vertical_max_n()), (l.thrust_min_n(), l.thrust_max_n(), l.vertical_max_n()));
    for keep in [f32::NAN, 0.0, -1.0, f32::INFINITY] {
        assert_eq!(l.with_tilt_max_tan(keep), l, "{keep}");
    }
    assert_eq!(w.with_tilt_max_tan(l.tilt_max_tan()).tilt_max_tan(), l.tilt_max_tan());
    // At a 19.6 N vertical part the 45 deg cone passes 19.6 N sideways, the 60 deg one 33.9 N.
    let demand = Vector3::new(-40.0, 0.0, 19.6);
    assert_relative_eq!(l.clamp(demand, 19.6).x, -19.6, epsilon = 1e-4);
    assert_relative_eq!(w.clamp(demand, 19.6).x, -19.6 * 3f32.sqrt(), epsilon = 1e-3);
    assert!(within_limits(&w.clamp(demand, 19.6), &w));
    // The sphere: 50 N at most, whatever the cone.
    let steep = l.with_tilt_max_tan(100.0).clamp(Vector3::new(-100.0, 0.0, 19.6), 19.6);
    assert_relative_eq!(steep.norm(), l.thrust_max_n(), epsilon = 1e-3);
}

/// A loop whose cone is widened passes the horizontal demand the configured cone cuts (a UAV
/// landing in a wind it must lean into), the vertical part unchanged; until then it flies bit
/// for bit what a loop never changed flies, and set back it flies the configured cone again.
#[test]
fn a_wider_cone_leans_further_and_only_from_the_call() {
    let p = VelocityLoopParams::default();
    let (mut wide, mut plain) = (VelocityLoop::new(p), VelocityLoop::new(p));
    // Commanded 3 m/s upwind while blown 8 m/s downwind: a demand outside either cone.
    let (cmd, v) = (Vector3::new(-3.0, 0.0, 0.0), Vector3::new(8.0, 0.0, 0.0));
    for _ in 0..20 {
        assert_eq!(wide.update(cmd, v, DT_S), plain.update(cmd, v, DT_S));
    }
    let tan60 = 3f32.sqrt();
    wide.set_tilt_max_tan(tan60);
    let (a, b) = (wide.update(cmd, v, DT_S).thrust_n, plain.update(cmd, v, DT_S).thrust_n);
    assert_eq!(a.z, b.z, "the vertical part first, unchanged");
    assert_relative_eq!(-b.x, b.z * p.limits.tilt_max_tan(), epsilon = 1e-3);
    assert_relative_eq!(-a.x, a.z * tan60, epsilon = 1e-3);
    wide.set_tilt_max_tan(f32::NAN);
    assert_relative_eq!(wide.params().limits.tilt_max_tan(), tan60);
    wide.set_tilt_max_tan(p.limits.tilt_max_tan());
    assert_eq!(wide.params().limits, p.limits);
}
