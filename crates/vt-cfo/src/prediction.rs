//! Measurement-delay compensation: the observer runs on the measurement's own timeline, and the
//! state is predicted forward to "now" with the thrust the vehicle applied since
//! (docs/design.md, "Latency compensation").
//!
//! A measurement stamped `k` control steps ago (`LOCAL_POSITION_NED.time_boot_ms`) is paired
//! with the thrust that was applied over the step that ended at its sample time, so the
//! compensation function observer sees a consistent input/output pair whatever the delay (its
//! estimate is then `k` steps old, the disturbance it tracks changes slowly). The velocity the
//! PID acts on is the measurement carried forward with the model of eq:1-1 and the estimate:
//!
//! ```text
//! v(t) = v(t - k h) + (h / m) (sum_{j<k} T_a(t - j h) + k (G - f_hat))     (eq:1-1 integrated)
//! p(t) = p(t - k h) + k h (v(t - k h) + v(t)) / 2                          (trapezoid)
//! ```
//!
//! This is a Smith-type predictor (O. J. M. Smith, "Closer control of loops with dead time",
//! Chem. Eng. Prog. 53, 1957) built on the observer's model. The sum over the window is kept
//! incrementally (one add and one subtract per step), so a step costs the same whatever the
//! delay.

use nalgebra::Vector3;

/// Longest delay the prediction covers, in control steps (254 ms at 500 Hz); a measurement
/// older than that is carried forward over this many steps only.
pub const DELAY_CAPACITY_STEPS: usize = HISTORY_LEN - 1;

/// Ring length of the thrust history (a power of two).
const HISTORY_LEN: usize = 128;

/// Index mask of the ring.
const HISTORY_MASK: usize = HISTORY_LEN - 1;

/// The measurement delay in whole control steps: `round(age / h)`, 0 for a non-finite, negative
/// or sub-half-step age, at most [`DELAY_CAPACITY_STEPS`].
#[must_use]
pub fn delay_steps(age_s: f32, period_s: f32) -> usize {
    let steps = age_s / period_s;
    if !(vt_fpu::is_finite(steps) && steps >= 0.5) {
        return 0;
    }
    // `as` saturates; the cap keeps the index inside the ring.
    (libm::roundf(steps) as usize).min(DELAY_CAPACITY_STEPS)
}

/// Largest product of the observer bandwidth and the measurement delay, rad
/// (docs/design.md, "Latency compensation"): a cable force varying faster than `1 / tau` cannot
/// be cancelled by an estimate `tau` old, it is only fed back with a phase error.
pub const DELAY_BANDWIDTH_PRODUCT: f32 = 0.5;

/// The observer bandwidth for a delay of `k` steps of `period_s`: `min(mu, c / (k h))`,
/// `c =` [`DELAY_BANDWIDTH_PRODUCT`]; `mu` itself without delay.
#[must_use]
pub fn scheduled_bandwidth_rad_s(mu_rad_s: f32, k: usize, period_s: f32) -> f32 {
    let delay_s = k as f32 * period_s;
    if delay_s > 0.0 {
        mu_rad_s.min(DELAY_BANDWIDTH_PRODUCT / delay_s)
    } else {
        mu_rad_s
    }
}

/// Age of a sample stamped `sample_ms` at `now_ms` (both on one clock, ms, wrapping), s; a
/// stamp in the future (more than half the `u32` range ahead) is taken as age 0.
#[must_use]
pub fn age_s(now_ms: u32, sample_ms: u32) -> f32 {
    let age_ms = now_ms.wrapping_sub(sample_ms);
    if age_ms > i32::MAX as u32 {
        0.0
    } else {
        age_ms as f32 / 1000.0
    }
}

/// A state measured `age_s` ago carried forward at constant velocity: `p + v age`, m. An age of
/// zero (or not finite and > 0) returns `pos_m` unchanged; a non-finite result returns `pos_m`.
#[must_use]
pub fn extrapolate_constant_velocity(pos_m: Vector3<f32>, vel_mps: Vector3<f32>, age_s: f32) -> Vector3<f32> {
    if !vt_fpu::positive_finite(age_s) {
        return pos_m;
    }
    let p = pos_m + vel_mps * age_s;
    if vt_fpu::all_finite(&p) {
        p
    } else {
        pos_m
    }
}

/// What the velocity loop predicted at its last step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Delay of the measurement, control steps.
    pub delay_steps: usize,
    /// Velocity now, m/s, ENU (the measurement when the delay is zero).
    pub velocity_mps: Vector3<f32>,
    /// Displacement since the measurement's sample time, m, ENU (zero when the delay is zero).
    pub displacement_m: Vector3<f32>,
}

impl Prediction {
    /// No delay: the measurement as is.
    #[must_use]
    pub fn undelayed(velocity_mps: Vector3<f32>) -> Self {
        Self { delay_steps: 0, velocity_mps, displacement_m: Vector3::zeros() }
    }
}

/// The thrust the vehicle applied over each of the last control steps, N, ENU, newest first,
/// with the running sum over a window of the newest entries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustHistory {
    ring: [Vector3<f32>; HISTORY_LEN],
    /// Index of the newest entry (age 0).
    head: usize,
    /// Length of the summed window, entries.
    window: usize,
    /// Sum of the newest `window` entries, N.
    window_sum_n: Vector3<f32>,
}

impl ThrustHistory {
    /// A history in which `thrust_n` was applied at every past step.
    #[must_use]
    pub fn new(thrust_n: Vector3<f32>) -> Self {
        Self { ring: [thrust_n; HISTORY_LEN], head: 0, window: 0, window_sum_n: Vector3::zeros() }
    }

    /// Makes this [`new`](Self::new)`(thrust_n)` in place (the ring is 1.5 KiB: building a new
    /// one and moving it costs that much stack twice on the MCU).
    pub fn fill(&mut self, thrust_n: Vector3<f32>) {
        self.ring = [thrust_n; HISTORY_LEN];
        self.head = 0;
        self.window = 0;
        self.window_sum_n = Vector3::zeros();
    }

    /// The thrust applied over the step that ended `age` steps ago (age 0: the last step), N;
    /// ages beyond the ring wrap onto older entries, so callers cap them at
    /// [`DELAY_CAPACITY_STEPS`].
    #[must_use]
    pub fn at(&self, age: usize) -> Vector3<f32> {
        let i = self.head.wrapping_sub(age) & HISTORY_MASK;
        self.ring.get(i).copied().unwrap_or_else(Vector3::zeros)
    }

    /// Sum of the newest `k` entries (`k <= DELAY_CAPACITY_STEPS`), N; O(1) while `k` does not
    /// change, O(k) when it does.
    pub fn sum_newest(&mut self, k: usize) -> Vector3<f32> {
        let k = k.min(DELAY_CAPACITY_STEPS);
        if k != self.window {
            self.window = k;
            self.resum();
        }
        self.window_sum_n
    }

    /// Appends the thrust applied over the coming step; the window slides with it. The sum is
    /// recomputed once per turn of the ring so rounding cannot accumulate.
    pub fn push(&mut self, thrust_n: Vector3<f32>) {
        // The entry at age `window - 1` now reaches age `window` and leaves the window.
        let leaving = if self.window > 0 { self.at(self.window - 1) } else { Vector3::zeros() };
        self.head = (self.head + 1) & HISTORY_MASK;
        if let Some(slot) = self.ring.get_mut(self.head) {
            *slot = thrust_n;
        }
        if self.window > 0 {
            if self.head == 0 {
                self.resum();
            } else {
                self.window_sum_n += thrust_n - leaving;
            }
        }
    }

    fn resum(&mut self) {
        let mut s = Vector3::zeros();
        for age in 0..self.window {
            s += self.at(age);
        }
        self.window_sum_n = s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn delay_rounds_to_steps_and_is_capped() {
        assert_eq!(delay_steps(0.0, 0.002), 0);
        assert_eq!(delay_steps(0.0009, 0.002), 0);
        assert_eq!(delay_steps(0.001, 0.002), 1);
        assert_eq!(delay_steps(0.15, 0.002), 75);
        assert_eq!(delay_steps(10.0, 0.002), DELAY_CAPACITY_STEPS);
        assert_eq!(delay_steps(f32::NAN, 0.002), 0);
        assert_eq!(delay_steps(-0.1, 0.002), 0);
        assert_eq!(delay_steps(0.1, 0.0), 0);
    }

    #[test]
    fn age_wraps_and_refuses_the_future() {
        assert_eq!(age_s(1150, 1000), 0.15);
        assert_eq!(age_s(5, u32::MAX - 4), 0.01);
        assert_eq!(age_s(1000, 1150), 0.0);
    }

    #[test]
    fn constant_velocity_extrapolation() {
        let p = Vector3::new(1.0, 2.0, 3.0);
        let v = Vector3::new(1.0, 0.0, -2.0);
        assert_eq!(extrapolate_constant_velocity(p, v, 0.5), Vector3::new(1.5, 2.0, 2.0));
        assert_eq!(extrapolate_constant_velocity(p, v, 0.0), p);
        assert_eq!(extrapolate_constant_velocity(p, Vector3::repeat(f32::NAN), 0.1), p);
    }

    /// Flies the point mass of eq:1-1 (2 kg, a constant 4/-2/12 N cable term) for `secs` with
    /// the velocity measured `delay` steps late; returns the worst speed error over the last
    /// second and the final observer error, N.
    fn fly_delayed(delay: usize, compensate: bool, lag_s: f32, secs: f32) -> (f32, f32) {
        use crate::{gravity_mps2, VelocityLoop, VelocityLoopParams};
        let params = VelocityLoopParams::default().with_actuator_lag(lag_s).unwrap();
        let (m, h) = (params.mass_kg(), params.cfo().period_s());
        let mut ctl = VelocityLoop::new(params);
        let cable_n = Vector3::new(4.0, -2.0, 12.0);
        let v_cmd = Vector3::new(1.0, 0.0, 0.0);
        let mut past = std::collections::VecDeque::from(std::vec![Vector3::<f32>::zeros(); delay + 1]);
        let (mut v, mut applied) = (Vector3::<f32>::zeros(), Vector3::new(0.0, 0.0, m * 9.81));
        let steps = (secs / h) as usize;
        let mut worst = 0.0f32;
        for step in 0..steps {
            past.push_back(v);
            let v_old = past.pop_front().unwrap();
            let age = if compensate { delay as f32 * h } else { 0.0 };
            let out = ctl.update_delayed(v_cmd, v_old, age, h);
            let alpha = if lag_s > 0.0 { 1.0 - (-h / lag_s).exp() } else { 1.0 };
            applied += (out.thrust_n - applied) * alpha;
            v += (applied + gravity_mps2() * m - cable_n) / m * h; // eq:1-1
            if step + (1.0 / h) as usize >= steps {
                worst = worst.max((v - v_cmd).norm());
            }
        }
        (worst, (ctl.observer().estimate_n() - cable_n).norm())
    }

    /// 150 ms of measurement delay with the paper's observer (mu = 15 rad/s) and a 50 ms
    /// actuator lag: the predicted loop settles on the command with the exact cable estimate;
    /// the same loop fed the late measurement as if it were fresh oscillates (measured: 3 m/s
    /// of speed error after a minute).
    #[test]
    fn prediction_keeps_the_loop_stable_at_150_ms() {
        let (err, f_err) = fly_delayed(75, true, 0.05, 60.0);
        assert!(err < 0.01 && f_err < 0.05, "compensated: speed error {err} m/s, f error {f_err} N");
        let (err_plain, _) = fly_delayed(75, false, 0.05, 60.0);
        assert!(err_plain > 1.0, "uncompensated loop unexpectedly settled: {err_plain} m/s");
        // And no delay at all is the plain loop, bit for bit.
        assert_eq!(fly_delayed(0, true, 0.05, 5.0), fly_delayed(0, false, 0.05, 5.0));
    }

    #[test]
    fn fill_in_place_is_a_new_history() {
        let mut h = ThrustHistory::new(Vector3::new(0.0, 0.0, 19.62));
        for i in 0..300 {
            h.push(Vector3::new(i as f32, 1.0, 2.0));
            let _ = h.sum_newest(i % 40);
        }
        let t = Vector3::new(0.5, -0.5, 21.0);
        h.fill(t);
        assert_eq!(h, ThrustHistory::new(t));
    }

    proptest! {
        /// The incremental window sum equals the direct sum whatever the pushes and window
        /// changes (rounding aside).
        #[test]
        fn window_sum_matches_direct_sum(
            pushes in proptest::collection::vec((-30.0f32..30.0, 0usize..200), 1..600),
        ) {
            let mut h = ThrustHistory::new(Vector3::new(0.0, 0.0, 19.62));
            let mut all: std::vec::Vec<Vector3<f32>> = std::vec![Vector3::new(0.0, 0.0, 19.62); HISTORY_LEN];
            for (x, k) in pushes {
                let k = k.min(DELAY_CAPACITY_STEPS);
                let s = h.sum_newest(k);
                let direct: Vector3<f32> = all.iter().rev().take(k).sum();
                prop_assert!((s - direct).norm() <= 1e-3 * (1.0 + direct.norm()), "k {k}: {s} vs {direct}");
                prop_assert_eq!(h.at(k), all[all.len() - 1 - k]);
                let t = Vector3::new(x, -x, 19.0 + x);
                h.push(t);
                all.push(t);
            }
        }
    }
}
