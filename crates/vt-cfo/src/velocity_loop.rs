//! The low-level velocity loop: PID on the velocity error plus the observer's cable-force
//! feedforward and gravity compensation (eq:2-3, REFERENCE §4).

use nalgebra::Vector3;

use crate::prediction::{delay_steps, scheduled_bandwidth_rad_s, Prediction, ThrustHistory};
use crate::{Cfo, CfoError, CfoParams, Status, ThrustLimits, GRAVITY_MPS2};

/// Paper gain `Kp`, 1/s, every axis (REFERENCE §4).
const PAPER_KP_PER_S: f32 = 2.0;
/// Paper gain `Ki`, 1/s², every axis (REFERENCE §4).
const PAPER_KI_PER_S2: f32 = 0.1;
/// Paper gain `Kd`, dimensionless, every axis (REFERENCE §4).
const PAPER_KD: f32 = 0.1;
/// Exclusive upper bound on `Kd`: the derivative term feeds back `Kd` times the thrust applied in
/// the previous step (`e_v' ~ -v_hat'`, which contains `T/m`), a discrete loop stable only for
/// `Kd < 1`.
const KD_MAX: f32 = 1.0;
/// Default bound on the integral term `|Ki int e_v|`, m/s², per axis (project choice: about
/// 0.2 g; the observer carries the cable force, the integral only trims what is left).
const DEFAULT_INTEGRAL_LIMIT_MPS2: f32 = 2.0;
/// Time constant of the mean thrust the no-measurement failsafe flies, s (docs/design.md,
/// "Team failsafe": the mean over a few seconds carries the cable force, the wind and the
/// integral's trim without the observer's fast swings; 3 s measured best of 0.5-8 s).
pub const BLIND_HOLD_TAU_S: f32 = 3.0;
/// Observer bandwidth while the cable carries no load, rad/s ([`VelocityLoop::set_bandwidth_cap`];
/// docs/design.md, "The observer of a free UAV"). Behind an attitude autopilot the horizontal
/// thrust lags the command by the attitude loop, longer than the observer's first-order model:
/// with a taut, loaded cable the load's coupling damps what that mismatch feeds back, but a free
/// UAV at the rigid-body default `mu = 15 rad/s` limit-cycles at about 2 Hz and 0.5-0.8 m/s on
/// any position noise (measured: 1 cm suffices). With no cable force to cancel, the observer
/// only tracks wind and drag, which change over seconds: 5 rad/s holds the free UAV
/// (0.003 m/s), 10 rad/s leaves 0.05 m/s.
pub const UNLOADED_BANDWIDTH_RAD_S: f32 = 5.0;

/// Share ratio (the declared load's weight per UAV over the UAV's own, `m_L / (n m)`) up to
/// which a taut cable damps the loop behind a stock-gains autopilot no more than a slack one:
/// the observer flies [`UNLOADED_BANDWIDTH_RAD_S`] (docs/design.md, "The observer of a lightly
/// loaded UAV"; measured: sixteen 2 kg UAVs at 0.38 ring at 1.4 Hz at 15 rad/s, not at 7).
pub const LIGHT_SHARE_RATIO: f32 = 0.4;

/// Share ratio from which a taut cable damps the loop as the paper team's (0.9) does: the
/// observer flies its configured `mu` ([`loaded_bandwidth_cap`]).
pub const FULL_SHARE_RATIO: f32 = 0.85;

/// Actuation lag from which a light share caps the observer, s: the paper airframe's behind
/// PX4's stock rate gains. The tuned loop (0.05 s) was measured not to ring at a light share.
pub const LIGHT_SHARE_MIN_LAG_S: f32 = 0.08;

/// The observer's bandwidth cap while the cable carries a share `share_ratio` of the load
/// (`m_L / (n m)`), rad/s, for a loop of bandwidth `mu_rad_s` behind the actuation lag
/// `actuator_lag_s` (s): [`UNLOADED_BANDWIDTH_RAD_S`] up to [`LIGHT_SHARE_RATIO`], linear to
/// `mu_rad_s` at [`FULL_SHARE_RATIO`], no cap (`f32::INFINITY`) from there, below
/// [`LIGHT_SHARE_MIN_LAG_S`], for a `mu_rad_s` not above the unloaded cap, or for any input
/// that is not a number (extension; docs/design.md, "The observer of a lightly loaded UAV").
#[must_use]
pub fn loaded_bandwidth_cap(share_ratio: f32, actuator_lag_s: f32, mu_rad_s: f32) -> f32 {
    // Negated comparisons: a NaN fails each and leaves the loop uncapped, as before the rule.
    if !(actuator_lag_s >= LIGHT_SHARE_MIN_LAG_S) || !(share_ratio < FULL_SHARE_RATIO) || !(mu_rad_s > UNLOADED_BANDWIDTH_RAD_S) || !vt_fpu::is_finite(mu_rad_s) {
        return f32::INFINITY;
    }
    let x = vt_fpu::max((share_ratio - LIGHT_SHARE_RATIO) / (FULL_SHARE_RATIO - LIGHT_SHARE_RATIO), 0.0);
    UNLOADED_BANDWIDTH_RAD_S + (mu_rad_s - UNLOADED_BANDWIDTH_RAD_S) * x
}

/// Diagonal PID gains of eq:2-3, per axis (x east, y north, z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Proportional gain `Kp`, 1/s.
    pub kp: Vector3<f32>,
    /// Integral gain `Ki`, 1/s².
    pub ki: Vector3<f32>,
    /// Derivative gain `Kd`, dimensionless, in `[0, 1)`.
    pub kd: Vector3<f32>,
}

impl Default for PidGains {
    /// The paper's gains: `Kp = 2`, `Ki = 0.1`, `Kd = 0.1` on every axis (REFERENCE §4).
    fn default() -> Self {
        Self {
            kp: Vector3::repeat(PAPER_KP_PER_S),
            ki: Vector3::repeat(PAPER_KI_PER_S2),
            kd: Vector3::repeat(PAPER_KD),
        }
    }
}

/// Validated parameters of a [`VelocityLoop`].
///
/// The UAV mass is the observer's (`cfo.mass_kg()`): one number, so the feedforward and the
/// observer cannot disagree.
///
/// # Examples
///
/// ```
/// use nalgebra::Vector3;
/// use vt_cfo::{CfoError, CfoParams, PidGains, ThrustLimits, VelocityLoopParams};
///
/// // The paper's experiment: 1.47 kg quadrotors with 30 N of thrust (REFERENCE §5).
/// let params = VelocityLoopParams::new(
///     PidGains::default(),
///     ThrustLimits::new(1.5, 30.0, 0.6)?,
///     Vector3::repeat(2.0),
///     CfoParams::new(15.0, 1.47, 0.002)?,
/// )?;
/// assert!((params.hover_thrust_n() - 14.42).abs() < 0.01);
/// # Ok::<(), CfoError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityLoopParams {
    gains: PidGains,
    limits: ThrustLimits,
    integral_limit_mps2: Vector3<f32>,
    cfo: CfoParams,
    /// Time constant of the vehicle's thrust response, s (0: the thrust is the command).
    actuator_lag_s: f32,
    /// Time constant of the low-pass on the observer's compensation `f_hat` in eq:2-3, s
    /// (0: no filter).
    command_filter_s: f32,
}

impl VelocityLoopParams {
    /// Checks the gains, the integral bound (`|Ki int e_v| <= integral_limit_mps2`, m/s², per
    /// axis) and that the hover thrust fits the thrust limits.
    ///
    /// # Errors
    ///
    /// [`CfoError::InvalidKp`], [`CfoError::InvalidKi`] (NaN, infinite or negative),
    /// [`CfoError::InvalidKd`] (outside `[0, 1)`), [`CfoError::InvalidIntegralLimit`] (NaN,
    /// infinite or negative), each naming the axis; [`CfoError::HoverOutsideThrustLimits`] when
    /// `m g` is outside `[thrust_min_n, thrust_max_n]`.
    pub fn new(
        gains: PidGains,
        limits: ThrustLimits,
        integral_limit_mps2: Vector3<f32>,
        cfo: CfoParams,
    ) -> Result<Self, CfoError> {
        let non_negative = |x: &f32| x.is_finite() && *x >= 0.0;
        if let Some(axis) = gains.kp.iter().position(|k| !non_negative(k)) {
            return Err(CfoError::InvalidKp { axis });
        }
        if let Some(axis) = gains.ki.iter().position(|k| !non_negative(k)) {
            return Err(CfoError::InvalidKi { axis });
        }
        if let Some(axis) = gains
            .kd
            .iter()
            .position(|k| !(non_negative(k) && *k < KD_MAX))
        {
            return Err(CfoError::InvalidKd { axis });
        }
        if let Some(axis) = integral_limit_mps2.iter().position(|l| !non_negative(l)) {
            return Err(CfoError::InvalidIntegralLimit { axis });
        }
        let hover_n = cfo.mass_kg() * GRAVITY_MPS2;
        if !(hover_n >= limits.thrust_min_n() && hover_n <= limits.vertical_max_n()) {
            return Err(CfoError::HoverOutsideThrustLimits { hover_n });
        }
        Ok(Self {
            gains,
            limits,
            integral_limit_mps2,
            cfo,
            actuator_lag_s: 0.0,
            command_filter_s: 0.0,
        })
    }

    /// The same parameters with the time constant `lag_s` (s, >= 0) of the thrust the vehicle
    /// realises behind its autopilot: the observer is then told the first-order response
    /// `T_a += (T_cmd - T_a)(1 - exp(-dt / lag_s))` instead of the command (docs/design.md,
    /// "Velocity loop behind an attitude autopilot"). 0 (the default) keeps the paper's model,
    /// thrust = command.
    ///
    /// # Errors
    ///
    /// [`CfoError::InvalidActuatorLag`] when `lag_s` is NaN, infinite or negative.
    pub fn with_actuator_lag(self, lag_s: f32) -> Result<Self, CfoError> {
        if !(lag_s.is_finite() && lag_s >= 0.0) {
            return Err(CfoError::InvalidActuatorLag);
        }
        Ok(Self { actuator_lag_s: lag_s, ..self })
    }

    /// The same parameters with the observer's compensation low-passed in the thrust command:
    /// eq:2-3 takes `f_f += (f_hat - f_f)(1 - exp(-dt / tau_s))` instead of `f_hat` (`tau_s` in
    /// s, `>= 0`; docs/design.md, "Thrust command filter"). The PID terms are not filtered, and
    /// the observer is told the thrust sent, so it stays consistent. 0 (the default) is the
    /// paper's eq:2-3.
    ///
    /// # Errors
    ///
    /// [`CfoError::InvalidCommandFilter`] when `tau_s` is NaN, infinite or negative.
    pub fn with_command_filter(self, tau_s: f32) -> Result<Self, CfoError> {
        if !(tau_s.is_finite() && tau_s >= 0.0) {
            return Err(CfoError::InvalidCommandFilter);
        }
        Ok(Self { command_filter_s: tau_s, ..self })
    }

    /// Time constant of the low-pass on `f_hat` in the thrust command, s (0: none).
    #[must_use]
    pub fn command_filter_s(&self) -> f32 {
        self.command_filter_s
    }

    /// Time constant of the vehicle's thrust response the observer assumes, s.
    #[must_use]
    pub fn actuator_lag_s(&self) -> f32 {
        self.actuator_lag_s
    }

    /// The PID gains.
    #[must_use]
    pub fn gains(&self) -> &PidGains {
        &self.gains
    }

    /// The thrust limits.
    #[must_use]
    pub fn limits(&self) -> &ThrustLimits {
        &self.limits
    }

    /// Bound on `|Ki int e_v|`, m/s², per axis.
    #[must_use]
    pub fn integral_limit_mps2(&self) -> Vector3<f32> {
        self.integral_limit_mps2
    }

    /// The observer's parameters (they hold the mass).
    #[must_use]
    pub fn cfo(&self) -> &CfoParams {
        &self.cfo
    }

    /// UAV mass `m`, kg.
    #[must_use]
    pub fn mass_kg(&self) -> f32 {
        self.cfo.mass_kg()
    }

    /// Hover thrust `m g`, N.
    #[must_use]
    pub fn hover_thrust_n(&self) -> f32 {
        self.cfo.mass_kg() * GRAVITY_MPS2
    }
}

impl Default for VelocityLoopParams {
    /// Paper gains, [`ThrustLimits::default`], 2 m/s² integral bound, [`CfoParams::default`]
    /// (2 kg, hover 19.6 N).
    fn default() -> Self {
        Self {
            gains: PidGains::default(),
            limits: ThrustLimits::default(),
            integral_limit_mps2: Vector3::repeat(DEFAULT_INTEGRAL_LIMIT_MPS2),
            cfo: CfoParams::default(),
            actuator_lag_s: 0.0,
            command_filter_s: 0.0,
        }
    }
}

/// One step's output of the [`VelocityLoop`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustOutput {
    /// Thrust to apply, N, ENU; always finite and within the [`ThrustLimits`].
    pub thrust_n: Vector3<f32>,
    /// The observer's cable-term estimate `f_hat`, N, ENU.
    pub f_hat_n: Vector3<f32>,
    /// What happened in this step (the most severe of the loop's and the observer's).
    pub status: Status,
}

/// Velocity controller of one UAV: eq:2-3 with a compensation function observer.
///
/// ```text
/// T_d = m (Kp e_v + Ki int e_v + Kd e_v') + f_hat - G,   e_v = v_d - v    (eq:2-3, eq:2-2)
/// ```
///
/// then [`ThrustLimits::clamp`]. Decisions:
///
/// - **Derivative on the measurement.** `e_v' = v_d' - v'`, with `v_d' = 0` as the paper assumes
///   under eq:2-3, is taken as `-v_hat'`, the observer's acceleration estimate
///   ([`Cfo::acceleration_estimate_mps2`]): no setpoint kick and no differentiated sensor noise.
/// - **Anti-windup.** Conditional integration (an axis is not integrated while the clamp cut its
///   demand and the error would push it further) plus a clamp `|Ki int e_v| <= limit`. The
///   integral is stored already multiplied by `Ki` (m/s²).
/// - **Observer input.** The observer is stepped with the thrust this loop returned last time,
///   assumed applied since.
///
/// Inputs of [`update`](Self::update): commanded and measured velocity (m/s, ENU) and the time
/// since the previous call (s). Failsafe ([`Status::InvalidInput`]):
///
/// - `v_meas` non-finite, or `dt_s` non-finite or `<= 0`: no feedback is possible; the output
///   is the compensated hover, taken as the mean thrust of the last [`BLIND_HOLD_TAU_S`]
///   (the observer's `f_hat - G` plus the integral's trim, without the observer's fast
///   swings), minus a brake `m Kp v_blind` on the observer's last velocity estimate
///   dead-reckoned under that brake (`v_blind' = -Kp v_blind`); the integral is held, the observer skips
///   the step and re-seeds at the next measurement, keeping its slow state
///   (`docs/design.md`, "Team failsafe").
/// - `v_cmd` non-finite (measurement fine): the command is taken as zero (brake to a hover),
///   the observer runs, the integral is held.
///
/// The output is always finite and within the limits: [`ThrustLimits::clamp`] replaces a
/// non-finite demand by the plain hover thrust `m g` up.
///
/// # Examples
///
/// ```
/// use approx::assert_relative_eq;
/// use nalgebra::Vector3;
/// use vt_cfo::{gravity_mps2, Status, VelocityLoop, VelocityLoopParams};
///
/// let params = VelocityLoopParams::default(); // 2 kg, paper gains, mu = 15 rad/s, 500 Hz
/// let (m, dt_s) = (params.mass_kg(), params.cfo().period_s());
/// let mut ctl = VelocityLoop::new(params);
/// let cable_n = Vector3::new(4.0, -2.0, 12.0); // unknown to the controller
/// let v_cmd = Vector3::new(1.0, 0.0, 0.0);
/// let mut v = Vector3::zeros();
/// for _ in 0..30_000 { // 60 s
///     let out = ctl.update(v_cmd, v, dt_s);
///     assert_ne!(out.status, Status::InvalidInput);
///     v += (out.thrust_n + gravity_mps2() * m - cable_n) / m * dt_s; // eq:1-1
/// }
/// assert_relative_eq!(v, v_cmd, epsilon = 0.01);
/// assert_relative_eq!(ctl.observer().estimate_n(), cable_n, epsilon = 0.01);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityLoop {
    params: VelocityLoopParams,
    cfo: Cfo,
    /// `Ki int e_v`, m/s².
    integral_mps2: Vector3<f32>,
    /// The thrust the vehicle applies, as the observer models it, N: the last update's output
    /// (no actuator lag) or its first-order response (`actuator_lag_s > 0`).
    thrust_applied_n: Vector3<f32>,
    /// `(dt, 1 - exp(-dt / actuator_lag_s))` of the last step (`exp` is costly on the MCU).
    lag_gain: (f32, f32),
    /// The low-passed compensation `f_f`, N (unused without a command filter).
    f_hat_filtered_n: Vector3<f32>,
    /// `(dt, 1 - exp(-dt / command_filter_s))` of the last step.
    filter_gain: (f32, f32),
    /// Mean of the thrust returned while measurements were usable, N (time constant
    /// [`BLIND_HOLD_TAU_S`]): the no-measurement failsafe's hover thrust.
    thrust_mean_n: Vector3<f32>,
    /// `(dt, dt / BLIND_HOLD_TAU_S)` of the last step with a measurement.
    mean_gain: (f32, f32),
    /// Without measurements: the velocity, dead-reckoned from the observer's last estimate
    /// under the failsafe's braking, m/s; `None` while measurements arrive.
    v_blind_mps: Option<Vector3<f32>>,
    /// The applied thrust of the last steps (newest = `thrust_applied_n`), for the delay
    /// compensation ([`crate::prediction`]).
    history: ThrustHistory,
    /// What the last step predicted.
    prediction: Prediction,
    /// Cap on the observer's bandwidth, rad/s (`f32::INFINITY`: none; [`Self::set_bandwidth_cap`]).
    bandwidth_cap_rad_s: f32,
    status: Status,
}

impl VelocityLoop {
    /// A loop at rest: zero integral, unseeded observer, last thrust = hover.
    #[must_use]
    pub fn new(params: VelocityLoopParams) -> Self {
        Self {
            params,
            cfo: Cfo::new(params.cfo),
            integral_mps2: Vector3::zeros(),
            thrust_applied_n: hover_vector_n(&params),
            lag_gain: (0.0, 1.0),
            f_hat_filtered_n: Vector3::zeros(),
            filter_gain: (0.0, 1.0),
            thrust_mean_n: hover_vector_n(&params),
            mean_gain: (0.0, 0.0),
            v_blind_mps: None,
            history: ThrustHistory::new(hover_vector_n(&params)),
            prediction: Prediction::undelayed(Vector3::zeros()),
            bandwidth_cap_rad_s: f32::INFINITY,
            status: Status::Ok,
        }
    }

    /// Sets the tilt cone's tangent from now on (the tangent of the largest tilt from the
    /// vertical; a non-finite or non-positive one is ignored). The landing after the release
    /// leans further than the transport (`vt_dissipative::landing::landing_tilt_max_tan`).
    pub fn set_tilt_max_tan(&mut self, tilt_max_tan: f32) {
        self.params.limits = self.params.limits.with_tilt_max_tan(tilt_max_tan);
    }

    /// Caps the observer's bandwidth at `cap_rad_s` (rad/s) from now on, under the configured
    /// `mu` and the delay's schedule ([`crate::prediction`]); `f32::INFINITY`, or any
    /// non-finite or non-positive value, lifts the cap. The observer's state is kept. An
    /// unchanged cap costs one comparison. Used with [`UNLOADED_BANDWIDTH_RAD_S`] while the
    /// cable carries no load.
    pub fn set_bandwidth_cap(&mut self, cap_rad_s: f32) {
        let cap = if vt_fpu::positive_finite(cap_rad_s) { cap_rad_s } else { f32::INFINITY };
        if cap == self.bandwidth_cap_rad_s {
            return;
        }
        self.bandwidth_cap_rad_s = cap;
        self.cfo.set_bandwidth(self.observer_bandwidth_rad_s(self.prediction.delay_steps, self.params.cfo.period_s()));
    }

    /// The observer's bandwidth for a delay of `k` steps of `period_s`, rad/s: the delay's
    /// schedule ([`crate::prediction`]) under the cap.
    fn observer_bandwidth_rad_s(&self, k: usize, period_s: f32) -> f32 {
        scheduled_bandwidth_rad_s(self.params.cfo.bandwidth_rad_s(), k, period_s).min(self.bandwidth_cap_rad_s)
    }

    /// The cap on the observer's bandwidth, rad/s (`f32::INFINITY`: none).
    #[must_use]
    pub fn bandwidth_cap_rad_s(&self) -> f32 {
        self.bandwidth_cap_rad_s
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &VelocityLoopParams {
        &self.params
    }

    /// The observer (read-only).
    #[must_use]
    pub fn observer(&self) -> &Cfo {
        &self.cfo
    }

    /// The integral term `Ki int e_v`, m/s².
    #[must_use]
    pub fn integral_mps2(&self) -> Vector3<f32> {
        self.integral_mps2
    }

    /// The status of the last update.
    #[must_use]
    pub fn status(&self) -> Status {
        self.status
    }

    /// Warm start at mission start: the observer's cable-force estimate preset to `f_hat_n`
    /// (N, ENU) and the last thrust to the one that balances it, `f_hat - G` (eq:2-3 with zero
    /// velocity error), so that the first steps hold the hover the vehicle is in instead of
    /// dropping to `-G` while the observer converges from zero (docs/design.md, "Capacity-aware
    /// formation"). A non-finite `f_hat_n` leaves the loop unchanged.
    pub fn preload(&mut self, f_hat_n: Vector3<f32>) {
        let thrust_n = f_hat_n - self.params.cfo.weight_n();
        if !vt_fpu::all_finite(&thrust_n) {
            return;
        }
        self.cfo.preload(f_hat_n, thrust_n);
        self.thrust_applied_n = thrust_n;
        // The vehicle has been hovering with this thrust (the delay compensation's history and
        // the blind hold's mean thrust).
        self.history.fill(thrust_n);
        self.thrust_mean_n = thrust_n;
        self.f_hat_filtered_n = f_hat_n;
    }

    /// What the last step predicted from its measurement (delay, velocity now, displacement
    /// since the sample).
    #[must_use]
    pub fn prediction(&self) -> &Prediction {
        &self.prediction
    }

    /// Back to the state of [`new`](Self::new).
    pub fn reset(&mut self) {
        *self = Self::new(self.params);
    }

    /// One control step (eq:2-3) on a measurement taken now; see the type's docs for inputs,
    /// units and failsafes.
    pub fn update(
        &mut self,
        v_cmd_mps: Vector3<f32>,
        v_meas_mps: Vector3<f32>,
        dt_s: f32,
    ) -> ThrustOutput {
        self.update_delayed(v_cmd_mps, v_meas_mps, 0.0, dt_s)
    }

    /// One control step (eq:2-3) on a velocity measured `age_s` seconds ago
    /// ([`crate::prediction`]): the observer is paired with the thrust applied at the sample
    /// time, and the PID acts on the velocity predicted to now. `age_s = 0` (or below half a
    /// step, or not finite) is [`update`](Self::update); ages beyond
    /// [`crate::prediction::DELAY_CAPACITY_STEPS`] steps are capped there.
    pub fn update_delayed(
        &mut self,
        v_cmd_mps: Vector3<f32>,
        v_meas_mps: Vector3<f32>,
        age_s: f32,
        dt_s: f32,
    ) -> ThrustOutput {
        let p = self.params;
        let m = p.mass_kg();
        let hover_n = p.hover_thrust_n();
        let weight_n = p.cfo.weight_n(); // G = m g_vec (eq:1-1)

        // Tested once: the filter, the blind hold and the actuator model take the answer.
        let dt_ok = vt_fpu::positive_finite(dt_s);
        let meas_ok = dt_ok && vt_fpu::all_finite(&v_meas_mps);
        let cmd_ok = vt_fpu::all_finite(&v_cmd_mps);

        let (demand_n, f_hat_n, e_v, status) = if meas_ok {
            let k = delay_steps(age_s, dt_s);
            if k != self.prediction.delay_steps {
                // Observer bandwidth scheduled from the delay (crate::prediction), under the cap.
                self.cfo.set_bandwidth(self.observer_bandwidth_rad_s(k, dt_s));
            }
            // The thrust applied over the step that ended at the sample time (k = 0: the last
            // step's, `thrust_applied_n`).
            let (f_hat_n, accel_hat_mps2) = self.cfo.update_measured(v_meas_mps, self.history.at(k), dt_s);
            self.prediction = self.predict(v_meas_mps, f_hat_n, k, dt_s);
            // Failsafe for a bad command: brake to zero velocity.
            let v_d = if cmd_ok { v_cmd_mps } else { Vector3::zeros() };
            // e_v = v_d - v (eq:2-2), v predicted to now.
            let e_v = v_d - self.prediction.velocity_mps;
            // e_v' = v_d' - v' ~ -v_hat' (v_d' = 0, as assumed under eq:2-3): the observer's
            // acceleration estimate after this step.
            let e_v_dot = -accel_hat_mps2;
            let accel_mps2 = p.gains.kp.component_mul(&e_v)
                + self.integral_mps2
                + p.gains.kd.component_mul(&e_v_dot);
            // eq:2-3, with `f_hat` low-passed when a command filter is set.
            let demand_n = accel_mps2 * m + self.filtered(f_hat_n, dt_s, dt_ok) - weight_n;
            let status = if cmd_ok {
                self.cfo.status()
            } else {
                Status::InvalidInput
            };
            (demand_n, f_hat_n, e_v, status)
        } else {
            // No usable measurement (docs/design.md, "Team failsafe"): the observer skips the
            // step (it re-seeds on the next measurement, keeping its slow state). The thrust is
            // the compensated hover, taken as the mean recent thrust (without the observer's
            // fast swings), minus a brake on the dead-reckoned velocity: the P term of eq:2-3
            // on `v_blind`, which decays as `v_blind' = -Kp v_blind` if the brake acts as
            // commanded. The UAV stops within about `|v| / Kp` metres instead of coasting.
            // The first step without starts from the observer's velocity estimate (the last
            // measurement, predicted one step).
            let v_blind = *self.v_blind_mps.get_or_insert_with(|| self.cfo.velocity_estimate_mps());
            let f_hat_n = self.cfo.skip();
            self.prediction = Prediction::undelayed(Vector3::zeros());
            let brake_mps2 = p.gains.kp.component_mul(&v_blind);
            if dt_ok {
                let decay = Vector3::repeat(1.0) - (p.gains.kp * dt_s).map(|g| g.min(1.0));
                self.v_blind_mps = Some(v_blind.component_mul(&decay));
            }
            (
                self.thrust_mean_n - brake_mps2 * m,
                f_hat_n,
                Vector3::zeros(),
                Status::InvalidInput,
            )
        };

        // Finite for every demand: the clamp replaces a non-finite one by the hover, and its
        // validated limits keep every branch finite (tested: thrust.rs,
        // `clamp_output_is_finite_and_within_limits_for_any_input`), so no second test here.
        let thrust_n = p.limits.clamp(demand_n, hover_n);
        let excess_n = demand_n - thrust_n;
        let saturated = excess_n != Vector3::zeros();

        if status != Status::InvalidInput {
            self.integrate(&e_v, &excess_n, dt_s);
        }
        if meas_ok {
            self.v_blind_mps = None;
            // Exponential mean over BLIND_HOLD_TAU_S (explicit Euler, gain at most 1; the gain
            // is recomputed only when `dt` changes). Finite: `thrust_n` is (the clamp's), and
            // the gain is in (0, 1].
            if self.mean_gain.0 != dt_s {
                self.mean_gain = (dt_s, (dt_s * (1.0 / BLIND_HOLD_TAU_S)).min(1.0));
            }
            self.thrust_mean_n += (thrust_n - self.thrust_mean_n) * self.mean_gain.1;
        }

        let status = if saturated {
            status.max(Status::Saturated)
        } else {
            status
        };
        self.thrust_applied_n = self.applied_after(thrust_n, dt_s, dt_ok);
        self.history.push(self.thrust_applied_n);
        self.status = status;
        ThrustOutput {
            thrust_n,
            f_hat_n,
            status,
        }
    }

    /// The measurement `k` steps old carried forward to now (crate::prediction): eq:1-1
    /// integrated over the applied thrusts with the estimate `f_hat`, and the trapezoid for the
    /// displacement. A non-finite prediction falls back to the measurement.
    fn predict(&mut self, v_meas_mps: Vector3<f32>, f_hat_n: Vector3<f32>, k: usize, dt_s: f32) -> Prediction {
        if k == 0 {
            return Prediction::undelayed(v_meas_mps);
        }
        let p = self.params;
        let steps = k as f32;
        // v(t) = v(t - k h) + (h / m)(sum T_a + k (G - f_hat))   (eq:1-1)
        let impulse_n = self.history.sum_newest(k) + (p.cfo.weight_n() - f_hat_n) * steps;
        let velocity_mps = v_meas_mps + impulse_n * (dt_s / p.mass_kg());
        let displacement_m = (v_meas_mps + velocity_mps) * (0.5 * steps * dt_s);
        if vt_fpu::all_finite(&velocity_mps) && vt_fpu::all_finite(&displacement_m) {
            Prediction { delay_steps: k, velocity_mps, displacement_m }
        } else {
            Prediction::undelayed(v_meas_mps)
        }
    }

    /// The thrust applied over the next step when `thrust_n` is commanded now: the command
    /// itself, or the vehicle's first-order response to it over `dt_s` (exact discretisation,
    /// `T_a += (T_cmd - T_a)(1 - exp(-dt / lag))`); a `dt_s` that is not finite and > 0
    /// (`dt_ok` false: the caller tested it) holds the response.
    fn applied_after(&mut self, thrust_n: Vector3<f32>, dt_s: f32, dt_ok: bool) -> Vector3<f32> {
        let lag_s = self.params.actuator_lag_s;
        if lag_s <= 0.0 {
            return thrust_n;
        }
        if !dt_ok {
            return self.thrust_applied_n;
        }
        let gain = first_order_gain(&mut self.lag_gain, dt_s, lag_s);
        let next = self.thrust_applied_n + (thrust_n - self.thrust_applied_n) * gain;
        if vt_fpu::all_finite(&next) {
            next
        } else {
            thrust_n
        }
    }

    /// The compensation after the command filter (docs/design.md, "Thrust command filter"):
    /// `f_f += (f_hat - f_f)(1 - exp(-dt / tau))`, exact for an `f_hat` held over the step;
    /// `f_hat` itself without a filter. A `dt_s` that is not finite and > 0 (`dt_ok` false:
    /// the caller tested it), or a non-finite result, holds `f_f`.
    fn filtered(&mut self, f_hat_n: Vector3<f32>, dt_s: f32, dt_ok: bool) -> Vector3<f32> {
        let tau_s = self.params.command_filter_s;
        if tau_s <= 0.0 {
            return f_hat_n;
        }
        if dt_ok {
            let gain = first_order_gain(&mut self.filter_gain, dt_s, tau_s);
            let next = self.f_hat_filtered_n + (f_hat_n - self.f_hat_filtered_n) * gain;
            if vt_fpu::all_finite(&next) {
                self.f_hat_filtered_n = next;
            }
        }
        self.f_hat_filtered_n
    }

    /// Conditional integration of `Ki e_v` with the magnitude clamp (anti-windup).
    fn integrate(&mut self, e_v: &Vector3<f32>, excess_n: &Vector3<f32>, dt_s: f32) {
        let ki = self.params.gains.ki;
        let limit = self.params.integral_limit_mps2;
        let i = self.integral_mps2;
        self.integral_mps2 = Vector3::new(
            integrate_axis(i.x, ki.x * e_v.x * dt_s, excess_n.x, limit.x),
            integrate_axis(i.y, ki.y * e_v.y * dt_s, excess_n.y, limit.y),
            integrate_axis(i.z, ki.z * e_v.z * dt_s, excess_n.z, limit.z),
        );
    }
}

/// One axis of the anti-windup integrator: skip the increment when the clamp cut this axis
/// (`excess = demand - applied != 0`) and the increment has the excess's sign (it would push
/// further into saturation; `Ki >= 0`); skip a non-finite increment; clamp to `+-limit`.
fn integrate_axis(integral_mps2: f32, increment_mps2: f32, excess_n: f32, limit_mps2: f32) -> f32 {
    let winds_up = excess_n * increment_mps2 > 0.0;
    let next = if winds_up || !vt_fpu::is_finite(increment_mps2) {
        integral_mps2
    } else {
        integral_mps2 + increment_mps2
    };
    // `next` is finite (a non-finite increment is skipped); a NaN limit is ignored, as by
    // `f32::max`/`min`, which cost a call to `fmaxf`/`fminf` each on the Cortex-M4F.
    vt_fpu::min(vt_fpu::max(next, -limit_mps2), limit_mps2)
}

/// The exact first-order gain `1 - exp(-dt / tau)` for the step `dt_s` (s) and time constant
/// `tau_s` (s, > 0), cached in `cache = (dt, gain)` and recomputed only when `dt` changes
/// (`exp` is costly on the MCU).
fn first_order_gain(cache: &mut (f32, f32), dt_s: f32, tau_s: f32) -> f32 {
    if cache.0 != dt_s {
        *cache = (dt_s, -libm::expm1f(-dt_s / tau_s));
    }
    cache.1
}

/// `-G = (0, 0, m g)`, N.
fn hover_vector_n(p: &VelocityLoopParams) -> Vector3<f32> {
    Vector3::new(0.0, 0.0, p.hover_thrust_n())
}


#[cfg(test)]
#[path = "velocity_loop_tests.rs"]
mod tests;
