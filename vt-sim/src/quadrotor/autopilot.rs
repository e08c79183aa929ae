//! The autopilot's inner loops as PX4 runs them: a quaternion attitude controller feeding a
//! body-rate PID, taking exactly what the firmware sends in `SET_ATTITUDE_TARGET`.
//!
//! # Attitude loop (PX4 `src/modules/mc_att_control/AttitudeControl/AttitudeControl.cpp`)
//!
//! With `q` the attitude and `q_d` the target (body FLU to world ENU, Hamilton):
//! 1. reduced attitude: `q_red = rot(e_z, e_z,d) * q`, the smallest rotation that aligns the
//!    thrust axes (`e_z = q * z`), applied to `q` (tilt first);
//! 2. yaw with reduced weight `w`: `q_mix = q_red^-1 q_d` (canonical), and
//!    `q_d' = q_red * (cos(w acos q_mix,w), 0, 0, sin(w asin q_mix,z))`;
//! 3. `q_e = q^-1 q_d'` (canonical), rate setpoint `omega_sp = 2 Im(q_e) .* K`, with the yaw
//!    gain divided by `w` (PX4 `setProportionalGain` compensates the weight), each axis clamped
//!    to its rate limit.
//!
//! # Rate loop (PX4 `src/lib/rate_control/rate_control.cpp`)
//!
//! `alpha_cmd = K_P e + i - K_D alpha_meas`, `e = omega_sp - omega`, `alpha_meas` the measured
//! angular acceleration (difference of successive rates). The integral grows by
//! `f K_I e dt`, `f = max(0, 1 - (e / 400 deg/s)^2)` (PX4's reduction for large errors) and is
//! clamped to `+-rate_int_lim` (anti-windup). The gains are in angular-acceleration units, so
//! the body torque is `tau = I alpha_cmd` (PX4's gains act on normalised torque, i.e. the same
//! thing divided by the airframe's full-differential authority; docs/plant.md).
//!
//! # Collective
//!
//! `F = thrust_norm * 4 * T_max,rotor`, linear: what PX4 delivers when `THR_MDL_FAC` matches
//! the motors (thrust proportional to the normalised command), and the inverse of the
//! firmware's `thrust_norm = |T| / thrust_max_total` (docs/plant.md, docs/protocol.md).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::params::AutopilotParams;

/// PX4 `RateControl::updateIntegral`: rate error at which integration stops, rad/s (400 deg/s).
const I_REDUCTION_RATE_RPS: f64 = 6.981_317_007_977_318;
/// Relative slack when comparing accumulated time with a loop period (rounding of `sum h`).
const PERIOD_SLACK: f64 = 1e-9;
/// Below this `1 + e_z . e_z,d` the thrust axes are opposite and the reduced attitude is
/// undefined (PX4 uses the full target then; its threshold is `|q_red,x or y| > 1 - 1e-5`).
const OPPOSITE_AXES_EPS: f64 = 1e-10;

/// What the firmware commands: `SET_ATTITUDE_TARGET` after the NED/FRD to ENU/FLU conversion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeTarget {
    /// Target attitude, body FLU to world ENU, Hamilton (yaw included: the firmware holds it).
    pub attitude: UnitQuaternion<f64>,
    /// Normalised collective thrust in `[0, 1]` of the total rotor thrust.
    pub thrust_norm: f64,
}

impl AttitudeTarget {
    /// A target from the crates' / firmware's f32 setpoint (`vt_cfo::thrust_to_attitude`).
    #[must_use]
    pub fn from_setpoint(sp: &vt_cfo::AttitudeSetpoint) -> Self {
        Self { attitude: sp.attitude.cast::<f64>(), thrust_norm: f64::from(sp.collective) }
    }

    /// `self` with a renormalised quaternion and the thrust clamped to `[0, 1]`, or `None` when
    /// a component is non-finite or the quaternion is near zero.
    fn sanitised(&self) -> Option<Self> {
        let q = self.attitude.as_ref();
        let norm = q.norm();
        let usable = norm > 1e-6 && norm.is_finite() && self.thrust_norm.is_finite();
        if !usable {
            return None;
        }
        Some(Self {
            attitude: UnitQuaternion::new_unchecked(q / norm),
            thrust_norm: self.thrust_norm.clamp(0.0, 1.0),
        })
    }
}

/// Output of the inner loops: the demand handed to the mixer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutopilotOutput {
    /// Collective thrust demand, N.
    pub force_n: f64,
    /// Body torque demand, FLU, N m.
    pub torque_nm: Vector3<f64>,
}

/// State of the inner loops, updated on the plant's step (see [`Autopilot::update`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Autopilot {
    /// Gains and rates.
    params: AutopilotParams,
    /// Diagonal inertia, kg m^2 (angular acceleration to torque).
    inertia_kgm2: Vector3<f64>,
    /// Collective at `thrust_norm = 1`, N.
    thrust_max_total_n: f64,
    /// Last valid target (held when a non-finite one arrives).
    target: AttitudeTarget,
    /// The target as last received, before sanitising (the plant steps faster than setpoints
    /// change: an unchanged one is not sanitised again).
    received: Option<AttitudeTarget>,
    /// Body-rate setpoint from the attitude loop, rad/s.
    rate_sp_rps: Vector3<f64>,
    /// Rate integral, rad/s^2.
    rate_int_radps2: Vector3<f64>,
    /// Body rates at the previous rate-loop run, rad/s.
    rate_prev_rps: Vector3<f64>,
    /// Time since the attitude loop last ran, s (starts due).
    att_elapsed_s: f64,
    /// Time since the rate loop last ran, s (starts due).
    rate_elapsed_s: f64,
    /// `1 / attitude_rate_hz` and `1 / rate_loop_hz`, s.
    periods_s: (f64, f64),
    /// Whether the rate loop has run once (no derivative before).
    primed: bool,
    /// Demand held between rate-loop runs.
    output: AutopilotOutput,
}

impl Autopilot {
    /// Inner loops at rest, holding `target`, for a vehicle of diagonal inertia `inertia_kgm2`
    /// (kg m^2) and total thrust `thrust_max_total_n` (N). Parameters are assumed validated.
    #[must_use]
    pub fn new(params: AutopilotParams, inertia_kgm2: Vector3<f64>, thrust_max_total_n: f64, target: AttitudeTarget) -> Self {
        let mut a = Self {
            params,
            inertia_kgm2,
            thrust_max_total_n,
            target,
            received: None,
            rate_sp_rps: Vector3::zeros(),
            rate_int_radps2: Vector3::zeros(),
            rate_prev_rps: Vector3::zeros(),
            att_elapsed_s: 0.0,
            rate_elapsed_s: 0.0,
            periods_s: (1.0 / params.attitude_rate_hz, 1.0 / params.rate_loop_hz),
            primed: false,
            output: AutopilotOutput { force_n: 0.0, torque_nm: Vector3::zeros() },
        };
        a.reset(target, Vector3::zeros());
        a
    }

    /// Restarts the loops holding `target`, with the rate integral set to hold the body
    /// torque `torque_nm` (N m, FLU; clamped to the integral limit) at zero rate error.
    pub fn reset(&mut self, target: AttitudeTarget, torque_nm: Vector3<f64>) {
        self.target = target.sanitised().unwrap_or(self.target);
        self.received = None;
        let lim = self.params.rate_int_lim_radps2;
        let int = torque_nm.component_div(&self.inertia_kgm2);
        self.rate_int_radps2 = int.zip_map(&lim, |x, l| if x.is_finite() { x.clamp(-l, l) } else { 0.0 });
        self.rate_sp_rps = Vector3::zeros();
        self.rate_prev_rps = Vector3::zeros();
        self.att_elapsed_s = 1.0 / self.params.attitude_rate_hz;
        self.rate_elapsed_s = 1.0 / self.params.rate_loop_hz;
        self.primed = false;
        self.output = AutopilotOutput {
            force_n: self.target.thrust_norm * self.thrust_max_total_n,
            torque_nm: self.inertia_kgm2.component_mul(&self.rate_int_radps2),
        };
    }

    /// Advances the loops by `h_s` (s) with the vehicle at attitude `q` and body rates
    /// `omega_rps` (rad/s, FLU), under `target` (a non-finite target keeps the last valid
    /// one). Each loop runs when its period has elapsed (at most once per call; a period
    /// shorter than `h_s` runs every call). Returns the demand and whether the rate loop ran
    /// (the mixer need only run then).
    pub fn update(&mut self, target: &AttitudeTarget, q: &UnitQuaternion<f64>, omega_rps: &Vector3<f64>, h_s: f64) -> (AutopilotOutput, bool) {
        if self.received != Some(*target) {
            self.received = Some(*target);
            if let Some(t) = target.sanitised() {
                self.target = t;
            }
        }
        let p = &self.params;
        let (att_period, rate_period) = self.periods_s;
        self.att_elapsed_s += h_s;
        self.rate_elapsed_s += h_s;
        if self.att_elapsed_s * (1.0 + PERIOD_SLACK) >= att_period {
            self.rate_sp_rps = attitude_rate_setpoint(q, &self.target.attitude, p);
            self.att_elapsed_s = (self.att_elapsed_s - att_period).clamp(0.0, att_period);
            if self.att_elapsed_s * (1.0 + PERIOD_SLACK) >= att_period {
                self.att_elapsed_s = 0.0;
            }
        }
        if self.rate_elapsed_s * (1.0 + PERIOD_SLACK) < rate_period {
            return (self.output, false);
        }
        let dt = self.rate_elapsed_s;
        self.rate_elapsed_s = 0.0;
        let err = self.rate_sp_rps - omega_rps;
        let accel = if self.primed { (omega_rps - self.rate_prev_rps) / dt } else { Vector3::zeros() };
        self.rate_prev_rps = *omega_rps;
        self.primed = true;
        let p = &self.params;
        let alpha = p.rate_p_per_s.component_mul(&err) + self.rate_int_radps2 - p.rate_d.component_mul(&accel);
        // Integral after the output, as PX4 (`RateControl::update`).
        for i in 0..3 {
            let (Some(int), Some(&e), Some(&ki), Some(&lim)) = (
                self.rate_int_radps2.get_mut(i),
                err.get(i),
                p.rate_i_per_s2.get(i),
                p.rate_int_lim_radps2.get(i),
            ) else {
                continue;
            };
            let f = e / I_REDUCTION_RATE_RPS;
            let f = (1.0 - f * f).max(0.0);
            let next = *int + f * ki * e * dt;
            if next.is_finite() {
                *int = next.clamp(-lim, lim);
            }
        }
        self.output = AutopilotOutput {
            force_n: self.target.thrust_norm * self.thrust_max_total_n,
            torque_nm: self.inertia_kgm2.component_mul(&alpha),
        };
        (self.output, true)
    }

    /// Sets the collective at `thrust_norm = 1`, N: what the motors give at full throttle now
    /// (a weak battery or worn motors give less for the same normalised command).
    pub fn set_thrust_max_total(&mut self, thrust_max_total_n: f64) {
        self.thrust_max_total_n = thrust_max_total_n;
    }

    /// The target being tracked (the last valid one received).
    #[must_use]
    pub fn target(&self) -> &AttitudeTarget {
        &self.target
    }

    /// Current body-rate setpoint of the attitude loop, rad/s (FLU).
    #[must_use]
    pub fn rate_setpoint_rps(&self) -> Vector3<f64> {
        self.rate_sp_rps
    }
}

/// PX4 `AttitudeControl::update`: body-rate setpoint (rad/s, FLU) that turns `q` towards
/// `q_d` (both body FLU to world ENU), tilt first, yaw weighted (module doc, steps 1-3).
#[must_use]
pub fn attitude_rate_setpoint(q: &UnitQuaternion<f64>, q_d: &UnitQuaternion<f64>, p: &AutopilotParams) -> Vector3<f64> {
    let e_z = q * Vector3::z();
    let e_z_d = q_d * Vector3::z();
    // Shortest rotation e_z -> e_z_d: (1 + a.b, a x b) normalised (half-angle form).
    let w = 1.0 + e_z.dot(&e_z_d);
    let q_red = if w > OPPOSITE_AXES_EPS {
        let v = e_z.cross(&e_z_d);
        super::unit(Quaternion::new(w, v.x, v.y, v.z)) * q
    } else {
        *q_d
    };
    let mut q_mix = (q_red.inverse() * q_d).into_inner();
    if q_mix.w < 0.0 {
        q_mix = -q_mix;
    }
    let (yaw_cos, yaw_sin) = weighted_yaw(q_mix.w, q_mix.k, p.yaw_weight);
    let q_yaw = Quaternion::new(yaw_cos, 0.0, 0.0, yaw_sin);
    let q_d_mixed = super::unit(q_red.into_inner() * q_yaw);
    let mut q_e = (q.inverse() * q_d_mixed).into_inner();
    if q_e.w < 0.0 {
        q_e = -q_e;
    }
    let mut gain = p.attitude_gain_per_s;
    gain.z /= p.yaw_weight; // PX4 setProportionalGain: compensates the yaw weight (w > 0 validated)
    let sp = (2.0 * q_e.imag()).component_mul(&gain);
    sp.zip_map(&p.rate_limit_rps, |x, l| x.clamp(-l, l))
}

/// Below this `|q_mix,z|` [`weighted_yaw`] uses its series (a yaw error under 2.3 deg, where the
/// vehicle flies nearly all the time: the firmware holds its heading).
const YAW_SERIES_MAX: f64 = 0.02;

/// PX4's weighted yaw `(cos(w acos(c)), sin(w asin(s)))` for the yaw part `(c, s)` of `q_mix`
/// (`c >= 0`, clamped to [-1, 1] as PX4 does). For small angles by series instead of four
/// trigonometric calls: `acos(1 - e)^2 = 2e + e^2/3 + 4e^3/45 + O(e^4)` and
/// `asin(s) = s + s^3/6 + 3s^5/40 + 5s^7/112 + O(s^9)`, then `cos` and `sin` of `w` times them to the next
/// term; for `|s| < YAW_SERIES_MAX` (and `e < YAW_SERIES_MAX^2`) every neglected term is below
/// 2e-14, within the rounding of PX4's own f32 arithmetic by six orders of magnitude (tested
/// against the trigonometric form).
fn weighted_yaw(c: f64, s: f64, w: f64) -> (f64, f64) {
    let c = c.clamp(-1.0, 1.0);
    let s = s.clamp(-1.0, 1.0);
    let e = 1.0 - c;
    if s.abs() < YAW_SERIES_MAX && e < YAW_SERIES_MAX * YAW_SERIES_MAX {
        let theta2 = e * (2.0 + e * (1.0 / 3.0 + e * (4.0 / 45.0)));
        let x2 = w * w * theta2;
        let cos = 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0)));
        let s2 = s * s;
        let a = w * s * (1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0))));
        let a2 = a * a;
        let sin = a * (1.0 - a2 * (1.0 / 6.0 - a2 * (1.0 / 120.0)));
        return (cos, sin);
    }
    ((w * c.acos()).cos(), (w * s.asin()).sin())
}

#[cfg(test)]
mod yaw_tests {
    use super::*;

    /// The series equals the trigonometric form to 2e-14 over its whole domain, for the
    /// weights PX4 allows; outside it the trigonometric form is used as it is.
    #[test]
    fn weighted_yaw_series_matches_the_trigonometric_form() {
        let trig = |c: f64, s: f64, w: f64| ((w * c.clamp(-1.0, 1.0).acos()).cos(), (w * s.clamp(-1.0, 1.0).asin()).sin());
        let mut worst: f64 = 0.0;
        for w in [0.05, 0.4, 0.7, 1.0] {
            for k in -2000..=2000 {
                let s = YAW_SERIES_MAX * f64::from(k) / 2000.0 * 0.999_999;
                // A pure yaw (c^2 + s^2 = 1) and one with a little tilt left in the quaternion.
                for c in [(1.0 - s * s).sqrt(), (1.0 - s * s - 1e-9).max(0.0).sqrt()] {
                    let (a, b) = weighted_yaw(c, s, w);
                    let (ta, tb) = trig(c, s, w);
                    worst = worst.max((a - ta).abs()).max((b - tb).abs());
                }
            }
        }
        assert!(worst < 2e-14, "series off the trigonometric form by {worst:e}");
        // Outside the series' domain the two are the same function.
        assert_eq!(weighted_yaw(0.9, 0.3, 0.4), trig(0.9, 0.3, 0.4));
        assert_eq!(weighted_yaw(2.0, -3.0, 0.4), trig(2.0, -3.0, 0.4));
    }
}

