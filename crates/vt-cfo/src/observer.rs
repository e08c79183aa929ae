//! Compensation function observer (CFO) for the cable force on one UAV (REFERENCE §4).
//!
//! Source: G. Qi, X. Li, Z. Chen, "Problems of extended state observer and proposal of
//! compensation function observer for unknown model and application in UAV", IEEE Trans. SMC:
//! Systems 52(5), 2022; used by the paper to obtain `f_hat` for eq:2-3.

use nalgebra::Vector3;

use crate::{gravity_mps2, CfoError, Status};

/// Largest `bandwidth_rad_s * period_s` the forward-Euler observer accepts.
///
/// With the discretisation used by [`Cfo::update`] the estimation error obeys
/// `x_{k+1} = A x_k` with a double eigenvalue at `1 - mu h` (REFERENCE §4, `l1 = 2 mu`,
/// `l2 = mu^2`): stable for `0 < mu h < 2`, free of oscillation for `mu h < 1`, and close to the
/// continuous design (`exp(-mu h)`) only for `mu h << 1`. `0.5` keeps the pole at or above `0.5`
/// and the peak gain from the true to the estimated disturbance at or below `1.5`.
pub const MAX_BANDWIDTH_PERIOD: f32 = 0.5;

/// Default observer bandwidth `mu`, rad/s (REFERENCE §6 prototype: `mu = 15`).
const DEFAULT_BANDWIDTH_RAD_S: f32 = 15.0;
/// Default UAV mass, kg (REFERENCE §5: the simulation's UAVs weigh 2 kg).
const DEFAULT_MASS_KG: f32 = 2.0;
/// Default control period, s (REFERENCE §6: low level at 500 Hz).
const DEFAULT_PERIOD_S: f32 = 0.002;
/// `l1 = L1_PER_BANDWIDTH * mu` (REFERENCE §4: `l1 = 2 mu`, double pole at `-mu`).
const L1_PER_BANDWIDTH: f32 = 2.0;

/// Validated parameters of a [`Cfo`].
///
/// # Examples
///
/// ```
/// use vt_cfo::{CfoError, CfoParams};
///
/// let params = CfoParams::new(15.0, 2.0, 0.002)?;
/// assert_eq!(params.bandwidth_rad_s(), 15.0);
/// // 500 rad/s at 500 Hz breaks the forward-Euler bound mu h <= 0.5.
/// assert!(matches!(
///     CfoParams::new(500.0, 2.0, 0.002),
///     Err(CfoError::BandwidthTooHighForPeriod { .. })
/// ));
/// # Ok::<(), CfoError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CfoParams {
    bandwidth_rad_s: f32,
    mass_kg: f32,
    period_s: f32,
}

impl CfoParams {
    /// Checks and stores the observer bandwidth `mu` (rad/s), the UAV mass (kg) and the nominal
    /// control period `h` (s) the observer will be stepped with.
    ///
    /// # Errors
    ///
    /// [`CfoError::InvalidBandwidth`], [`CfoError::InvalidMass`], [`CfoError::InvalidPeriod`] for
    /// a NaN, infinite or non-positive value; [`CfoError::BandwidthTooHighForPeriod`] when
    /// `mu h > MAX_BANDWIDTH_PERIOD`.
    pub fn new(bandwidth_rad_s: f32, mass_kg: f32, period_s: f32) -> Result<Self, CfoError> {
        if !(bandwidth_rad_s.is_finite() && bandwidth_rad_s > 0.0) {
            return Err(CfoError::InvalidBandwidth);
        }
        if !(mass_kg.is_finite() && mass_kg > 0.0) {
            return Err(CfoError::InvalidMass);
        }
        if !(period_s.is_finite() && period_s > 0.0) {
            return Err(CfoError::InvalidPeriod);
        }
        let mu_h = bandwidth_rad_s * period_s;
        if mu_h > MAX_BANDWIDTH_PERIOD {
            return Err(CfoError::BandwidthTooHighForPeriod { mu_h });
        }
        Ok(Self {
            bandwidth_rad_s,
            mass_kg,
            period_s,
        })
    }

    /// Observer bandwidth `mu`, rad/s.
    #[must_use]
    pub fn bandwidth_rad_s(&self) -> f32 {
        self.bandwidth_rad_s
    }

    /// UAV mass `m`, kg.
    #[must_use]
    pub fn mass_kg(&self) -> f32 {
        self.mass_kg
    }

    /// Nominal control period `h`, s.
    #[must_use]
    pub fn period_s(&self) -> f32 {
        self.period_s
    }

    /// Longest step the observer integrates, s (`MAX_BANDWIDTH_PERIOD / mu`); a longer step
    /// re-seeds it instead.
    #[must_use]
    pub fn max_step_s(&self) -> f32 {
        MAX_BANDWIDTH_PERIOD / self.bandwidth_rad_s
    }

    /// Weight `G = m g_vec`, N (eq:1-1).
    #[must_use]
    pub fn weight_n(&self) -> Vector3<f32> {
        gravity_mps2() * self.mass_kg
    }
}

impl Default for CfoParams {
    /// `mu = 15 rad/s`, `m = 2 kg`, `h = 2 ms` (`mu h = 0.03`).
    fn default() -> Self {
        Self {
            bandwidth_rad_s: DEFAULT_BANDWIDTH_RAD_S,
            mass_kg: DEFAULT_MASS_KG,
            period_s: DEFAULT_PERIOD_S,
        }
    }
}

/// Compensation function observer: estimates the cable term `f` of `m v' = T + G - f`, all
/// three axes at once (REFERENCE §4).
///
/// Model per axis: `v' = (T + G)/m + a` with the lumped unknown `a = -f/m`. With the measured
/// velocity `v` and the innovation `e = v - v_hat`:
///
/// ```text
/// a_hat  = z + l1 e                      (REFERENCE §4)
/// v_hat' = (T + G)/m + a_hat             (REFERENCE §4)
/// z'     = l2 e,   l1 = 2 mu, l2 = mu^2  (REFERENCE §4)
/// f_hat  = -m a_hat                      (REFERENCE §4; the force the cable exerts is -f_hat)
/// ```
///
/// Discretised with forward Euler over the step `dt_s` (see [`MAX_BANDWIDTH_PERIOD`]).
///
/// Inputs of [`update`](Self::update): measured velocity (m/s, ENU), the thrust that was applied
/// since the previous call (N, ENU) and the time since the previous call (s).
/// NaN/infinite input or `dt_s <= 0`: the step is skipped, the state kept, the status set to
/// [`Status::InvalidInput`], and the next valid step re-seeds `v_hat`. A step longer than
/// [`CfoParams::max_step_s`] also re-seeds `v_hat` (the disturbance state `z` is kept). A state
/// that goes non-finite is reset to the measurement.
///
/// # Examples
///
/// ```
/// use approx::assert_relative_eq;
/// use nalgebra::Vector3;
/// use vt_cfo::{gravity_mps2, Cfo, CfoParams};
///
/// let mass_kg = 2.0;
/// let dt_s = 0.002;
/// let mut cfo = Cfo::new(CfoParams::new(15.0, mass_kg, dt_s)?);
/// // A cable pulls the UAV down with 10 N (f = +10 N z); the thrust only carries the weight.
/// let f_n = Vector3::new(0.0, 0.0, 10.0);
/// let thrust_n = -gravity_mps2() * mass_kg;
/// let mut v_mps = Vector3::zeros();
/// for _ in 0..500 {
///     cfo.update(v_mps, thrust_n, dt_s);
///     v_mps += (thrust_n + gravity_mps2() * mass_kg - f_n) / mass_kg * dt_s; // eq:1-1
/// }
/// assert_relative_eq!(cfo.estimate_n(), f_n, epsilon = 0.05);
/// # Ok::<(), vt_cfo::CfoError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cfo {
    params: CfoParams,
    /// `l1 = 2 mu`, 1/s.
    l1_per_s: f32,
    /// `l2 = mu^2`, 1/s².
    l2_per_s2: f32,
    v_hat_mps: Vector3<f32>,
    /// Integral state `z`, m/s².
    z_mps2: Vector3<f32>,
    /// Last innovation `e = v - v_hat`, m/s.
    innovation_mps: Vector3<f32>,
    /// Last estimate of the lumped unknown `a_hat`, m/s².
    a_hat_mps2: Vector3<f32>,
    /// Thrust passed to the last update (applied over the last step), N.
    thrust_last_n: Vector3<f32>,
    /// `v_hat` holds a valid prediction for the next measurement.
    seeded: bool,
    status: Status,
}

impl Cfo {
    /// A fresh observer; the first valid measurement seeds `v_hat` (estimate zero until then).
    #[must_use]
    pub fn new(params: CfoParams) -> Self {
        let mu = params.bandwidth_rad_s;
        Self {
            params,
            l1_per_s: L1_PER_BANDWIDTH * mu, // REFERENCE §4: l1 = 2 mu
            l2_per_s2: mu * mu,              // REFERENCE §4: l2 = mu^2
            v_hat_mps: Vector3::zeros(),
            z_mps2: Vector3::zeros(),
            innovation_mps: Vector3::zeros(),
            a_hat_mps2: Vector3::zeros(),
            thrust_last_n: -params.weight_n(),
            seeded: false,
            status: Status::Ok,
        }
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &CfoParams {
        &self.params
    }

    /// Runs the observer at bandwidth `min(mu, bandwidth_rad_s)` from now on (`l1 = 2 mu'`,
    /// `l2 = mu'^2`, REFERENCE §4): never above the configured `mu`, so the forward-Euler bound
    /// still holds; a non-finite or non-positive value restores the configured `mu`. The state
    /// is kept.
    pub fn set_bandwidth(&mut self, bandwidth_rad_s: f32) {
        let configured = self.params.bandwidth_rad_s;
        let mu = if bandwidth_rad_s.is_finite() && bandwidth_rad_s > 0.0 {
            bandwidth_rad_s.min(configured)
        } else {
            configured
        };
        self.l1_per_s = L1_PER_BANDWIDTH * mu; // REFERENCE §4: l1 = 2 mu
        self.l2_per_s2 = mu * mu; // REFERENCE §4: l2 = mu^2
    }

    /// The bandwidth the observer runs at, rad/s (`l1 / 2`).
    #[must_use]
    pub fn bandwidth_rad_s(&self) -> f32 {
        self.l1_per_s / L1_PER_BANDWIDTH
    }

    /// One observer step; returns the estimated cable term `f_hat`, N (ENU).
    ///
    /// `v_meas_mps`: measured velocity now; `thrust_applied_n`: the thrust applied since the
    /// previous call; `dt_s`: the time since the previous call. See the type's docs for what
    /// non-finite input does.
    pub fn update(
        &mut self,
        v_meas_mps: Vector3<f32>,
        thrust_applied_n: Vector3<f32>,
        dt_s: f32,
    ) -> Vector3<f32> {
        if !(vt_fpu::all_finite(&v_meas_mps) && vt_fpu::positive_finite(dt_s)) {
            // Skip, keep the state; the prediction no longer matches the next measurement.
            return self.skip();
        }
        self.update_measured(v_meas_mps, thrust_applied_n, dt_s).0
    }

    /// [`update`](Self::update) for a caller that has checked `v_meas_mps` finite and `dt_s`
    /// finite and positive (the velocity loop, which tests them for its own failsafe): the same
    /// result for such inputs, without testing them a second time; with it the
    /// [`acceleration_estimate_mps2`](Self::acceleration_estimate_mps2) after the step, whose
    /// model term `(T + G) / m` the step has just computed from the same thrust (the same bits,
    /// not computed twice).
    pub(crate) fn update_measured(
        &mut self,
        v_meas_mps: Vector3<f32>,
        thrust_applied_n: Vector3<f32>,
        dt_s: f32,
    ) -> (Vector3<f32>, Vector3<f32>) {
        if !vt_fpu::all_finite(&thrust_applied_n) {
            // Skip, keep the state; the prediction no longer matches the next measurement.
            return (self.skip(), self.acceleration_estimate_mps2());
        }
        if !self.seeded {
            // First measurement since new()/reset(), or the first after skipped steps.
            let after_skip = self.status == Status::InvalidInput;
            self.seed(v_meas_mps, thrust_applied_n);
            self.status = if after_skip {
                Status::ObserverReset
            } else {
                Status::Ok
            };
            return (self.estimate_n(), self.acceleration_estimate_mps2());
        }
        if dt_s > self.params.max_step_s() {
            // Forward Euler would leave its stability margin: re-seed, keep z.
            self.seed(v_meas_mps, thrust_applied_n);
            self.status = Status::ObserverReset;
            return (self.estimate_n(), self.acceleration_estimate_mps2());
        }

        let m = self.params.mass_kg;
        // Prediction over the elapsed step: v_hat' = (T + G)/m + a_hat, z' = l2 e (REFERENCE §4).
        let model_mps2 = (thrust_applied_n + self.params.weight_n()) / m;
        let v_hat_mps = self.v_hat_mps + (model_mps2 + self.a_hat_mps2) * dt_s;
        let z_mps2 = self.z_mps2 + self.innovation_mps * (self.l2_per_s2 * dt_s);
        // Correction with the new measurement: e = v - v_hat, a_hat = z + l1 e (REFERENCE §4).
        let innovation_mps = v_meas_mps - v_hat_mps;
        let a_hat_mps2 = z_mps2 + innovation_mps * self.l1_per_s;

        if vt_fpu::zero_if_finite(&v_hat_mps) + vt_fpu::zero_if_finite(&z_mps2) + vt_fpu::zero_if_finite(&a_hat_mps2) == 0.0 {
            self.v_hat_mps = v_hat_mps;
            self.z_mps2 = z_mps2;
            self.innovation_mps = innovation_mps;
            self.a_hat_mps2 = a_hat_mps2;
            self.thrust_last_n = thrust_applied_n;
            self.status = Status::Ok;
        } else {
            self.reset(v_meas_mps);
            self.thrust_last_n = thrust_applied_n;
            self.status = Status::ObserverReset;
        }
        // `thrust_last_n` is `thrust_applied_n` on both branches: this is
        // `acceleration_estimate_mps2()` with its model term already at hand.
        (self.estimate_n(), model_mps2 + self.a_hat_mps2)
    }

    /// A step without a usable measurement (what [`update`](Self::update) does with one): the
    /// state is kept and the next valid measurement re-seeds the prediction (keeping the slow
    /// state `z`). Returns the estimate `f_hat`, N.
    pub fn skip(&mut self) -> Vector3<f32> {
        self.seeded = false;
        self.status = Status::InvalidInput;
        self.estimate_n()
    }

    /// Restarts at velocity `v_mps` with a zero disturbance estimate. A non-finite `v_mps`
    /// leaves the observer unseeded (the next valid measurement seeds it).
    pub fn reset(&mut self, v_mps: Vector3<f32>) {
        self.z_mps2 = Vector3::zeros();
        self.a_hat_mps2 = Vector3::zeros();
        self.innovation_mps = Vector3::zeros();
        self.thrust_last_n = -self.params.weight_n();
        self.status = Status::Ok;
        if vt_fpu::all_finite(&v_mps) {
            self.v_hat_mps = v_mps;
            self.seeded = true;
        } else {
            self.v_hat_mps = Vector3::zeros();
            self.seeded = false;
        }
    }

    /// Estimated cable term `f_hat = -m a_hat`, N, ENU (REFERENCE §4). The force the cable
    /// exerts on the UAV is `-f_hat`.
    #[must_use]
    pub fn estimate_n(&self) -> Vector3<f32> {
        -self.a_hat_mps2 * self.params.mass_kg
    }

    /// Estimated acceleration `v_hat' = (T + G)/m + a_hat`, m/s², ENU, with the thrust of the
    /// last step (REFERENCE §4). The velocity loop's derivative term uses it.
    #[must_use]
    pub fn acceleration_estimate_mps2(&self) -> Vector3<f32> {
        (self.thrust_last_n + self.params.weight_n()) / self.params.mass_kg + self.a_hat_mps2
    }

    /// Predicted velocity `v_hat` for the next measurement, m/s, ENU.
    #[must_use]
    pub fn velocity_estimate_mps(&self) -> Vector3<f32> {
        self.v_hat_mps
    }

    /// What the last [`update`](Self::update) did.
    #[must_use]
    pub fn status(&self) -> Status {
        self.status
    }

    /// Presets the disturbance estimate to `f_hat_n` (N, ENU; non-finite: ignored) with
    /// `thrust_applied_n` as the last thrust, keeping the prediction unseeded: a warm start at
    /// mission start when the cable force is already known from the declared load
    /// (docs/design.md, "Capacity-aware formation": bumpless transfer). `f_hat = -m a_hat`
    /// (REFERENCE §4), so `z = a_hat = -f_hat / m`.
    pub fn preload(&mut self, f_hat_n: Vector3<f32>, thrust_applied_n: Vector3<f32>) {
        let a = -f_hat_n / self.params.mass_kg;
        if !(vt_fpu::all_finite(&a) && vt_fpu::all_finite(&thrust_applied_n)) {
            return;
        }
        self.z_mps2 = a;
        self.a_hat_mps2 = a;
        self.innovation_mps = Vector3::zeros();
        self.thrust_last_n = thrust_applied_n;
        self.seeded = false;
    }

    /// Starts the prediction at the measurement, keeping the disturbance state `z`.
    fn seed(&mut self, v_meas_mps: Vector3<f32>, thrust_applied_n: Vector3<f32>) {
        self.v_hat_mps = v_meas_mps;
        self.innovation_mps = Vector3::zeros();
        self.a_hat_mps2 = self.z_mps2; // a_hat = z + l1 * 0
        self.thrust_last_n = thrust_applied_n;
        self.seeded = true;
    }
}


#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    const DT_S: f32 = 0.002;
    const MASS_KG: f32 = 2.0;
    /// Peak gain from the apparent disturbance to `a_hat` for `mu h <= 0.5` (impulse-response
    /// l1 norm of `mu h q (2q - 2 + mu h) / (q - 1 + mu h)^2`, at most 1.5).
    const PEAK_GAIN: f32 = 1.5;

    fn cfo(mu: f32) -> Cfo {
        Cfo::new(CfoParams::new(mu, MASS_KG, DT_S).unwrap())
    }

    /// One plant step of eq:1-1, forward Euler as the observer's model.
    fn plant_step(v_mps: Vector3<f32>, thrust_n: Vector3<f32>, f_n: Vector3<f32>) -> Vector3<f32> {
        v_mps + (thrust_n + gravity_mps2() * MASS_KG - f_n) / MASS_KG * DT_S
    }

    #[test]
    fn params_reject_bandwidth_times_period_above_half() {
        assert!(CfoParams::new(250.0, MASS_KG, DT_S).is_ok()); // mu h = 0.5
        assert_eq!(
            CfoParams::new(260.0, MASS_KG, DT_S).map(|_| ()),
            Err(CfoError::BandwidthTooHighForPeriod { mu_h: 260.0 * DT_S })
        );
    }

    #[test]
    fn params_reject_non_positive_or_non_finite_values() {
        assert_eq!(
            CfoParams::new(0.0, MASS_KG, DT_S),
            Err(CfoError::InvalidBandwidth)
        );
        assert_eq!(
            CfoParams::new(f32::NAN, MASS_KG, DT_S),
            Err(CfoError::InvalidBandwidth)
        );
        assert_eq!(CfoParams::new(15.0, -1.0, DT_S), Err(CfoError::InvalidMass));
        assert_eq!(
            CfoParams::new(15.0, f32::INFINITY, DT_S),
            Err(CfoError::InvalidMass)
        );
        assert_eq!(
            CfoParams::new(15.0, MASS_KG, 0.0),
            Err(CfoError::InvalidPeriod)
        );
    }

    #[test]
    fn default_params_are_valid() {
        let d = CfoParams::default();
        assert_eq!(
            CfoParams::new(d.bandwidth_rad_s(), d.mass_kg(), d.period_s()),
            Ok(d)
        );
    }

    #[test]
    fn first_update_seeds_velocity_and_reports_zero_force() {
        let mut c = cfo(15.0);
        let v = Vector3::new(1.0, -2.0, 0.5);
        let f = c.update(v, -CfoParams::default().weight_n(), DT_S);
        assert_eq!(f, Vector3::zeros());
        assert_eq!(c.velocity_estimate_mps(), v);
        assert_eq!(c.status(), Status::Ok);
    }

    #[test]
    fn acceleration_estimate_is_zero_in_undisturbed_hover() {
        let mut c = cfo(15.0);
        let hover = -CfoParams::default().weight_n();
        for _ in 0..100 {
            c.update(Vector3::zeros(), hover, DT_S);
        }
        assert_relative_eq!(
            c.acceleration_estimate_mps2(),
            Vector3::zeros(),
            epsilon = 1e-5
        );
        assert_relative_eq!(c.estimate_n(), Vector3::zeros(), epsilon = 1e-5);
    }

    #[test]
    fn non_finite_input_skips_update_keeps_state_and_flags() {
        let mut c = cfo(15.0);
        let hover = -CfoParams::default().weight_n();
        let f = Vector3::new(3.0, 0.0, 5.0);
        let mut v = Vector3::zeros();
        for _ in 0..200 {
            c.update(v, hover, DT_S);
            v = plant_step(v, hover, f);
        }
        let before = c.estimate_n();
        for bad in [
            c.update(Vector3::new(f32::NAN, 0.0, 0.0), hover, DT_S),
            c.update(v, Vector3::new(0.0, f32::INFINITY, 0.0), DT_S),
            c.update(v, hover, 0.0),
            c.update(v, hover, f32::NAN),
        ] {
            assert_eq!(bad, before);
            assert_eq!(c.status(), Status::InvalidInput);
        }
        // The next valid step re-seeds the velocity and keeps the disturbance state.
        c.update(v, hover, DT_S);
        assert_eq!(c.status(), Status::ObserverReset);
        assert_eq!(c.velocity_estimate_mps(), v);
        assert!((c.estimate_n() - before).norm() < 0.5);
    }

    #[test]
    fn long_step_reseeds_velocity_and_keeps_disturbance() {
        let mut c = cfo(15.0);
        let hover = -CfoParams::default().weight_n();
        let f = Vector3::new(0.0, 0.0, 8.0);
        let mut v = Vector3::zeros();
        for _ in 0..1000 {
            c.update(v, hover, DT_S);
            v = plant_step(v, hover, f);
        }
        let before = c.estimate_n();
        let v_jump = v + Vector3::new(0.0, 0.0, -3.0);
        c.update(v_jump, hover, 1.0); // 1 s >> 0.5 / 15 s
        assert_eq!(c.status(), Status::ObserverReset);
        assert_eq!(c.velocity_estimate_mps(), v_jump);
        assert_relative_eq!(c.estimate_n(), before, epsilon = 0.05);
    }

    #[test]
    fn non_finite_state_resets_to_measurement() {
        let mut c = cfo(15.0);
        let hover = -CfoParams::default().weight_n();
        c.update(Vector3::new(-3.0e38, 0.0, 0.0), hover, DT_S);
        let v = Vector3::new(3.0e38, 0.0, 0.0);
        let f = c.update(v, hover, DT_S); // innovation overflows to inf
        assert_eq!(c.status(), Status::ObserverReset);
        assert_eq!(c.velocity_estimate_mps(), v);
        assert_eq!(f, Vector3::zeros());
    }

    #[test]
    fn reset_seeds_velocity_and_clears_estimate() {
        let mut c = cfo(15.0);
        let hover = -CfoParams::default().weight_n();
        let mut v = Vector3::zeros();
        for _ in 0..100 {
            c.update(v, hover, DT_S);
            v = plant_step(v, hover, Vector3::new(1.0, 2.0, 3.0));
        }
        c.reset(Vector3::new(1.0, 1.0, 1.0));
        assert_eq!(c.estimate_n(), Vector3::zeros());
        assert_eq!(c.velocity_estimate_mps(), Vector3::new(1.0, 1.0, 1.0));
        assert_relative_eq!(c.acceleration_estimate_mps2(), Vector3::zeros());
    }

    /// The velocity loop takes the acceleration estimate from `update_measured`: it must be
    /// `acceleration_estimate_mps2()` after the step, bit for bit, on every path (seed, normal,
    /// a long step's re-seed, a skipped thrust, a state reset by overflow).
    #[test]
    fn update_measured_returns_the_acceleration_estimate_bit_for_bit() {
        let mut c = cfo(15.0);
        let steps: [(Vector3<f32>, Vector3<f32>, f32); 8] = [
            (Vector3::new(0.1, -0.2, 0.3), Vector3::new(1.0, -2.0, 25.0), DT_S),
            (Vector3::new(0.2, -0.1, -0.0), Vector3::new(-0.0, 0.5, 19.0), DT_S),
            (Vector3::new(0.3, 0.0, 0.1), Vector3::new(2.0, 1.0, 18.5), DT_S),
            (Vector3::new(0.3, 0.0, 0.1), Vector3::new(2.0, 1.0, 18.5), 1.0),
            (Vector3::new(0.3, 0.0, 0.1), Vector3::new(f32::NAN, 1.0, 18.5), DT_S),
            (Vector3::new(0.2, 0.1, 0.1), Vector3::new(2.0, 1.0, 18.5), DT_S),
            (Vector3::new(3e38, -3e38, 0.1), Vector3::new(f32::MAX, 1.0, 18.5), DT_S),
            (Vector3::new(0.2, 0.1, 0.1), Vector3::new(2.0, 1.0, 18.5), DT_S),
        ];
        for (v, t, dt) in steps {
            let (f_hat, accel) = c.update_measured(v, t, dt);
            assert_eq!(f_hat.map(f32::to_bits), c.estimate_n().map(f32::to_bits));
            assert_eq!(accel.map(f32::to_bits), c.acceleration_estimate_mps2().map(f32::to_bits), "{v:?} {t:?} {dt}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// A constant cable force on a point mass flown with the compensating thrust
        /// `T = clamp(f_hat - G)` is estimated within 5 % + 0.05 N after `5/mu` s.
        #[test]
        fn estimate_converges_to_constant_force_within_five_over_mu(
            fx in -30.0f32..30.0, fy in -30.0f32..30.0, fz in -30.0f32..30.0,
            mu in 5.0f32..40.0,
            v0x in -2.0f32..2.0, v0z in -2.0f32..2.0,
        ) {
            let f_n = {
                let f = Vector3::new(fx, fy, fz);
                if f.norm() > 50.0 { f * (50.0 / f.norm()) } else { f }
            };
            let limits = crate::ThrustLimits::default();
            let hover_n = MASS_KG * crate::GRAVITY_MPS2;
            let mut c = cfo(mu);
            let mut v = Vector3::new(v0x, 0.0, v0z);
            let mut thrust = limits.clamp(-gravity_mps2() * MASS_KG, hover_n);
            // The first call only seeds; the error then decays for 5/mu s.
            let steps = 1 + libm::ceilf(5.0 / (mu * DT_S)) as usize;
            for _ in 0..steps {
                let f_hat = c.update(v, thrust, DT_S);
                v = plant_step(v, thrust, f_n);
                thrust = limits.clamp(f_hat - gravity_mps2() * MASS_KG, hover_n);
            }
            let err = (c.estimate_n() - f_n).norm();
            prop_assert!(err < 0.05 * f_n.norm() + 0.05, "err {err} for f {f_n:?} mu {mu}");
        }

        /// Random (physically inconsistent) bounded velocities and thrusts never make the
        /// estimate diverge: `|f_hat_j| <= m * PEAK_GAIN * max|alpha_j|` with the apparent
        /// disturbance `alpha = dv/h - (T + G)/m` bounded by `2 V/h + T_max/m + g`.
        #[test]
        fn estimate_stays_bounded_for_bounded_random_inputs(
            seed in any::<u64>(),
            mu in 5.0f32..250.0,
        ) {
            const V_MAX_MPS: f32 = 20.0;
            const T_MAX_N: f32 = 100.0;
            const STEPS: usize = 20_000;
            let mut c = Cfo::new(CfoParams::new(mu, MASS_KG, DT_S).unwrap());
            let alpha_max = 2.0 * V_MAX_MPS / DT_S + T_MAX_N / MASS_KG + crate::GRAVITY_MPS2;
            let bound_n = MASS_KG * PEAK_GAIN * alpha_max;
            let mut state = seed | 1;
            let mut rand = move || {
                // xorshift64*: uniform in [-1, 1)
                state ^= state >> 12;
                state ^= state << 25;
                state ^= state >> 27;
                let x = state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40;
                (x as f32 / (1u64 << 23) as f32) - 1.0
            };
            for _ in 0..STEPS {
                let v = Vector3::new(rand(), rand(), rand()) * V_MAX_MPS;
                let t = Vector3::new(rand(), rand(), rand()) * T_MAX_N;
                let f_hat = c.update(v, t, DT_S);
                prop_assert!(vt_fpu::all_finite(&f_hat));
                prop_assert!(f_hat.amax() <= bound_n, "|f_hat| {} > {bound_n}", f_hat.amax());
                prop_assert_eq!(c.status(), Status::Ok);
            }
        }
    }
}
