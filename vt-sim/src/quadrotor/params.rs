//! Physical and autopilot parameters of the rigid-body quadrotor, with the presets of the
//! paper's UAV (2 kg, 50 N) and the experiment's (1.47 kg, 30 N).
//!
//! # Sources
//!
//! - **Reference airframe**: the 3DR Iris of PX4's Gazebo SITL (`iris.sdf`: 1.5 kg,
//!   `Ixx = Iyy = 0.029125`, `Izz = 0.055225` kg m^2, rotors about 0.25 m from the centre,
//!   `motorConstant` 5.84e-6 N/(rad/s)^2, `maxRotVelocity` 1100 rad/s (7.07 N per rotor,
//!   28.3 N in all), `momentConstant` 0.06 m, `timeConstantUp/Down` 0.0125 / 0.025 s,
//!   `rotorDragCoefficient` 1.75e-4 N/((rad/s)(m/s))). Its size and thrust are close to the
//!   experiment's UAV, so the presets are small scalings of it ([`QuadParams::sized`]).
//! - **Body drag**: RotorPy (Folk et al. 2023) `hummingbird_params.py`: parasitic drag
//!   `c_D = (0.5e-2, 0.5e-2, 1e-2)` N/(m/s)^2 for 0.5 kg, scaled with frontal area.
//! - **Autopilot**: PX4 `mc_att_control` defaults (`MC_ROLL_P = MC_PITCH_P = 6.5`,
//!   `MC_YAW_P = 2.8`, `MC_YAW_WEIGHT = 0.4`, `MC_ROLLRATE_MAX = MC_PITCHRATE_MAX = 220`
//!   deg/s, `MC_YAWRATE_MAX = 200` deg/s); the rate PID in physical units (docs/plant.md).
//!
//! Scaling rules of [`QuadParams::sized`] (geometric similarity, `m` the mass): arm
//! `L ~ m^(1/3)`; inertia `I ~ m L^2 ~ m^(5/3)`; frontal area `~ m^(2/3)`; maximum rotor
//! speed `~ 1/L` (same blade-tip speed); torque-to-thrust ratio `k_m ~ L` (propeller diameter
//! `~ L`); rotor drag `k_d ~ k_T omega_max` (same drag-to-thrust ratio per m/s at a given
//! fraction of full rotor speed); motor time constant and autopilot gains unchanged (gains are
//! in angular-acceleration units, so the loops keep their bandwidth).

use core::fmt;

use nalgebra::Vector3;

/// Reference airframe (PX4 Gazebo Iris) mass, kg.
const REF_MASS_KG: f64 = 1.5;
/// Reference inertia about body x, y, z (PX4 Gazebo Iris), kg m^2.
const REF_INERTIA_KGM2: [f64; 3] = [0.029125, 0.029125, 0.055225];
/// Reference arm length, centre to rotor (Iris rotors at (0.13, 0.22) / (0.13, 0.20) m), m.
const REF_ARM_M: f64 = 0.25;
/// Reference propeller radius: the Iris's 10 x 4.7 inch propellers (PX4 Gazebo `iris.sdf`
/// rotor visual `iris_prop_ccw.dae`, 0.254 m diameter), m.
const REF_PROP_RADIUS_M: f64 = 0.127;
/// Guard added to the rotor-tip radius in the body envelope: the radial extent of a prop guard
/// ring and the blades' flex (project choice; docs/plant.md, "Body envelope"), m.
pub const ENVELOPE_GUARD_M: f64 = 0.03;
/// Reference maximum rotor speed (Iris `maxRotVelocity`), rad/s.
const REF_OMEGA_MAX_RPS: f64 = 1100.0;
/// Reference thrust coefficient (Iris `motorConstant`), N/(rad/s)^2.
const REF_THRUST_COEFF: f64 = 5.84e-6;
/// Reference yaw-moment-to-thrust ratio (Iris `momentConstant`), m.
const REF_YAW_MOMENT_COEFF_M: f64 = 0.06;
/// Reference rotor drag coefficient (Iris `rotorDragCoefficient`), N/((rad/s)(m/s)).
const REF_ROTOR_DRAG: f64 = 1.75e-4;
/// Motor time constant: the Iris's spin-up 0.0125 s and spin-down 0.025 s, one constant near
/// their mean, s.
const MOTOR_TIME_CONSTANT_S: f64 = 0.02;
/// Idle thrust of an armed rotor as a fraction of its maximum (project choice: props keep
/// spinning, as PX4's `PWM_MAIN_MIN`/`DSHOT_MIN` idle does).
const ROTOR_IDLE_FRACTION: f64 = 0.02;
/// Cable hook below the centre of mass, m (project choice within the 5-10 cm).
const ATTACH_DEPTH_M: f64 = 0.08;
/// RotorPy Hummingbird mass, kg, and its parasitic drag per body axis, N/(m/s)^2.
const DRAG_REF_MASS_KG: f64 = 0.5;
const DRAG_REF_COEFF: [f64; 3] = [0.5e-2, 0.5e-2, 1e-2];
/// PX4 attitude loop: runs on every attitude estimate (~250 Hz on common flight controllers), Hz.
const ATTITUDE_RATE_HZ: f64 = 250.0;
/// PX4 rate loop: on every gyro sample (`IMU_GYRO_RATEMAX` up to 1-2 kHz), Hz.
const RATE_LOOP_HZ: f64 = 1000.0;
/// PX4 `MC_ROLL_P`, `MC_PITCH_P`, `MC_YAW_P`, 1/s.
const ATT_GAIN_PER_S: [f64; 3] = [6.5, 6.5, 2.8];
/// PX4 `MC_YAW_WEIGHT`.
const YAW_WEIGHT: f64 = 0.4;
/// PX4 `MC_ROLLRATE_MAX`, `MC_PITCHRATE_MAX` (220 deg/s), `MC_YAWRATE_MAX` (200 deg/s), rad/s.
const RATE_LIMIT_RPS: [f64; 3] = [3.839_724_354_387_525, 3.839_724_354_387_525, 3.490_658_503_988_659];
/// Rate-loop proportional gain, angular acceleration per rate error, 1/s (tuning: rate-loop
/// bandwidth `K_P / (1 + K_D)` = 16.7 rad/s, 2.6 times the attitude gain, so the cascade has
/// damping 0.8, below the motor's 1/0.02 s = 50 rad/s; docs/plant.md).
const RATE_P_PER_S: [f64; 3] = [25.0, 25.0, 12.0];
/// Rate-loop integral gain, 1/s^2 (PX4 default ratio `MC_ROLLRATE_I / MC_ROLLRATE_P` =
/// 0.2/0.15 per second; yaw 0.1/0.2).
const RATE_I_PER_S2: [f64; 3] = [33.3, 33.3, 6.0];
/// Rate-loop derivative gain on the measured angular acceleration, dimensionless (PX4 ratio
/// `MC_ROLLRATE_D / MC_ROLLRATE_P` = 0.02 s; yaw has none).
const RATE_D: [f64; 3] = [0.5, 0.5, 0.0];
/// Integral limit as a fraction of the axis' full-differential angular acceleration (PX4
/// `MC_RR_INT_LIM`, `MC_PR_INT_LIM`, `MC_YR_INT_LIM` = 0.3 of normalised torque).
const RATE_INT_LIM_FRACTION: f64 = 0.3;

/// Why [`QuadParams::validate`] rejected a parameter set: the field and what is wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QuadError {
    /// Name of the offending field, as in [`QuadParams`] / [`AutopilotParams`].
    pub field: &'static str,
    /// What the field must satisfy.
    pub expected: &'static str,
}

impl fmt::Display for QuadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "quadrotor parameter `{}`: expected {}", self.field, self.expected)
    }
}

impl std::error::Error for QuadError {}

/// Gains and rates of the autopilot's inner loops (PX4 `AttitudeControl` + `RateControl`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutopilotParams {
    /// Attitude-loop rate, Hz (> 0, at most the rate loop's).
    pub attitude_rate_hz: f64,
    /// Body-rate loop rate, Hz (> 0); runs every plant step if the step is longer.
    pub rate_loop_hz: f64,
    /// Attitude P gain per body axis (roll, pitch, yaw), 1/s (PX4 `MC_*_P`, > 0).
    pub attitude_gain_per_s: Vector3<f64>,
    /// Weight of yaw against roll/pitch in the attitude error, in (0, 1] (PX4 `MC_YAW_WEIGHT`).
    pub yaw_weight: f64,
    /// Body-rate setpoint limit per axis, rad/s (> 0; PX4 `MC_*RATE_MAX`).
    pub rate_limit_rps: Vector3<f64>,
    /// Rate P gain per axis: angular acceleration per rate error, 1/s (>= 0).
    pub rate_p_per_s: Vector3<f64>,
    /// Rate I gain per axis, 1/s^2 (>= 0).
    pub rate_i_per_s2: Vector3<f64>,
    /// Rate D gain per axis on the measured angular acceleration, dimensionless, in [0, 1).
    pub rate_d: Vector3<f64>,
    /// Bound of the rate integral per axis, rad/s^2 (>= 0; PX4 `MC_*R_INT_LIM` in physical units).
    pub rate_int_lim_radps2: Vector3<f64>,
}

/// Parameters of one X-configuration quadrotor (body frame FLU, see [`super`]).
///
/// Rotor layout (PX4 "Quadrotor X" numbering): rotor 1 front-right `(+d, -d)` spinning
/// counter-clockwise seen from above, 2 rear-left `(-d, +d)` CCW, 3 front-left `(+d, +d)`
/// clockwise, 4 rear-right `(-d, -d)` CW, `d = arm_length_m / sqrt 2`. A CCW rotor's reaction
/// torque on the body is clockwise: `tau_z = -yaw_moment_coeff_m * T` (CW rotor: `+`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuadParams {
    /// Mass, kg (> 0). Source: the scenario (paper 2 kg, experiment 1.47 kg).
    pub mass_kg: f64,
    /// Diagonal inertia about body x, y, z, kg m^2 (> 0, each at most the sum of the other two).
    /// Source: Iris, scaled by `(m / 1.5 kg)^(5/3)`.
    pub inertia_kgm2: Vector3<f64>,
    /// Distance from the centre of mass to each rotor hub, m (> 0). Source: Iris 0.25 m,
    /// scaled by `(m / 1.5 kg)^(1/3)`.
    pub arm_length_m: f64,
    /// Propeller radius, m (> 0). Source: Iris 10-inch propellers (0.127 m), scaled with the arm.
    pub prop_radius_m: f64,
    /// Rotor thrust coefficient `k_T` in `T = k_T omega^2`, N/(rad/s)^2 (> 0); sets the rotor
    /// speed used by the rotor-drag model. Source: `T_max / omega_max^2`, Iris-scaled
    /// `omega_max`.
    pub thrust_coeff_n_per_rps2: f64,
    /// Rotor drag-torque coefficient `k_m`: yaw torque `+-k_m T`, m (>= 0). Source: Iris
    /// `momentConstant` 0.06 m, scaled with the arm.
    pub yaw_moment_coeff_m: f64,
    /// First-order motor time constant from commanded to actual rotor thrust, s (> 0).
    /// Source: Iris spin-up/down 0.0125/0.025 s.
    pub motor_time_constant_s: f64,
    /// Smallest thrust of one armed rotor (idle), N (>= 0). Source: 2 % of the maximum.
    pub rotor_thrust_min_n: f64,
    /// Largest thrust of one rotor, N (> min). Source: the scenario's total thrust / 4.
    pub rotor_thrust_max_n: f64,
    /// Cable attachment point relative to the centre of mass, body FLU, m (finite). Source:
    /// project choice, 8 cm below.
    pub attach_point_body_m: Vector3<f64>,
    /// Quadratic parasitic (body) drag per body axis, `D = -|v_a| c_D v_a`, N/(m/s)^2 (>= 0).
    /// Source: RotorPy Hummingbird, scaled by `(m / 0.5 kg)^(2/3)`.
    pub body_drag_n_per_mps2: Vector3<f64>,
    /// Rotor (H-force / induced) drag coefficient `k_d`: each rotor adds
    /// `-k_d omega_i (v_ix, v_iy, 0)` (in-plane hub airspeed), N/((rad/s)(m/s)) (>= 0).
    /// Source: Iris `rotorDragCoefficient`, scaled with `k_T omega_max`.
    pub rotor_drag_coeff: f64,
    /// Autopilot inner loops.
    pub autopilot: AutopilotParams,
}

impl QuadParams {
    /// A quadrotor of `mass_kg` whose four rotors give `thrust_max_total_n` together, scaled
    /// from the reference airframe by the rules of the module doc. Not validated: call
    /// [`validate`](Self::validate) (non-positive input gives non-finite or zero fields that
    /// it rejects).
    #[must_use]
    pub fn sized(mass_kg: f64, thrust_max_total_n: f64) -> Self {
        let mass_ratio = mass_kg / REF_MASS_KG;
        let length_ratio = mass_ratio.cbrt();
        let arm_length_m = REF_ARM_M * length_ratio;
        let inertia_scale = mass_ratio * length_ratio * length_ratio;
        let inertia_kgm2 = Vector3::from(REF_INERTIA_KGM2) * inertia_scale;
        let rotor_thrust_max_n = thrust_max_total_n / 4.0;
        let omega_max_rps = REF_OMEGA_MAX_RPS / length_ratio;
        let thrust_coeff_n_per_rps2 = rotor_thrust_max_n / (omega_max_rps * omega_max_rps);
        let rotor_drag_coeff = REF_ROTOR_DRAG * (thrust_coeff_n_per_rps2 * omega_max_rps)
            / (REF_THRUST_COEFF * REF_OMEGA_MAX_RPS);
        let area_ratio = (mass_kg / DRAG_REF_MASS_KG).powf(2.0 / 3.0);
        // Full-differential angular acceleration per axis: two rotors at max, two at min
        // (roll/pitch: `2 d span`; yaw: `2 k_m span`).
        let d = arm_length_m * core::f64::consts::FRAC_1_SQRT_2;
        let span_n = rotor_thrust_max_n * (1.0 - ROTOR_IDLE_FRACTION);
        let authority = Vector3::new(
            2.0 * d * span_n / inertia_kgm2.x,
            2.0 * d * span_n / inertia_kgm2.y,
            2.0 * REF_YAW_MOMENT_COEFF_M * length_ratio * span_n / inertia_kgm2.z,
        );
        Self {
            mass_kg,
            inertia_kgm2,
            arm_length_m,
            prop_radius_m: REF_PROP_RADIUS_M * length_ratio,
            thrust_coeff_n_per_rps2,
            yaw_moment_coeff_m: REF_YAW_MOMENT_COEFF_M * length_ratio,
            motor_time_constant_s: MOTOR_TIME_CONSTANT_S,
            rotor_thrust_min_n: ROTOR_IDLE_FRACTION * rotor_thrust_max_n,
            rotor_thrust_max_n,
            attach_point_body_m: Vector3::new(0.0, 0.0, -ATTACH_DEPTH_M),
            body_drag_n_per_mps2: Vector3::from(DRAG_REF_COEFF) * area_ratio,
            rotor_drag_coeff,
            autopilot: AutopilotParams {
                attitude_rate_hz: ATTITUDE_RATE_HZ,
                rate_loop_hz: RATE_LOOP_HZ,
                attitude_gain_per_s: Vector3::from(ATT_GAIN_PER_S),
                yaw_weight: YAW_WEIGHT,
                rate_limit_rps: Vector3::from(RATE_LIMIT_RPS),
                rate_p_per_s: Vector3::from(RATE_P_PER_S),
                rate_i_per_s2: Vector3::from(RATE_I_PER_S2),
                rate_d: Vector3::from(RATE_D),
                rate_int_lim_radps2: authority * RATE_INT_LIM_FRACTION,
            },
        }
    }

    /// The same airframe behind PX4's stock rate controller (issue 27): PX4 v1.14
    /// `MC_ROLLRATE_P/I/D = 0.15 / 0.2 / 0.003` (pitch alike), `MC_YAWRATE_P/I/D = 0.2 / 0.1 / 0`,
    /// which act on torque normalised by the airframe's authority, so in physical units they
    /// are those times each axis's full-differential angular acceleration (docs/plant.md,
    /// "Autopilot inner loops"). The attitude gains and limits are already PX4's defaults.
    #[must_use]
    pub fn with_px4_default_rate_gains(mut self) -> Self {
        let authority = self.autopilot.rate_int_lim_radps2 / RATE_INT_LIM_FRACTION;
        self.autopilot.rate_p_per_s = Vector3::new(0.15, 0.15, 0.2).component_mul(&authority);
        self.autopilot.rate_i_per_s2 = Vector3::new(0.2, 0.2, 0.1).component_mul(&authority);
        self.autopilot.rate_d = Vector3::new(0.003, 0.003, 0.0).component_mul(&authority);
        self
    }

    /// The paper's simulated UAV: 2 kg, 50 N in all (REFERENCE §5, §6).
    #[must_use]
    pub fn paper() -> Self {
        Self::sized(2.0, 50.0)
    }

    /// The paper's experimental UAV: 1.47 kg, 30 N in all (REFERENCE §5).
    #[must_use]
    pub fn experiment() -> Self {
        Self::sized(1.47, 30.0)
    }

    /// Largest collective thrust, N (`4 * rotor_thrust_max_n`).
    #[must_use]
    pub fn thrust_max_total_n(&self) -> f64 {
        4.0 * self.rotor_thrust_max_n
    }

    /// Distance of each rotor hub from the body x and y axes, `arm / sqrt 2`, m.
    #[must_use]
    pub fn rotor_offset_m(&self) -> f64 {
        self.arm_length_m * core::f64::consts::FRAC_1_SQRT_2
    }

    /// Radius of the body envelope, m: the rotor-tip radius (arm + propeller) plus
    /// [`ENVELOPE_GUARD_M`] (docs/plant.md, "Body envelope"). Clearances are measured from this
    /// sphere around the centre of mass.
    #[must_use]
    pub fn envelope_radius_m(&self) -> f64 {
        self.arm_length_m + self.prop_radius_m + ENVELOPE_GUARD_M
    }

    /// The horizontal drag of this airframe as the wind capacity law models it
    /// (`vt_dissipative::wind`), flying level with total thrust `thrust_n` (N) spread evenly:
    /// `(c_q, c_l)`, the quadratic body drag along x, N/(m/s)^2, and the rotors' linear H-force
    /// `4 k_d omega` with `omega = sqrt(T / (4 k_T))`, N/(m/s) (the terms of the step's drag).
    #[must_use]
    pub fn level_drag(&self, thrust_n: f64) -> (f64, f64) {
        let omega_rps = (thrust_n.max(0.0) / (4.0 * self.thrust_coeff_n_per_rps2)).sqrt();
        (self.body_drag_n_per_mps2.x, 4.0 * self.rotor_drag_coeff * omega_rps)
    }

    /// Checks every field.
    ///
    /// # Errors
    ///
    /// [`QuadError`] naming the first field that is non-finite or out of its range (ranges in
    /// the field docs).
    pub fn validate(&self) -> Result<(), QuadError> {
        let positive = |field, x: f64| check(field, x.is_finite() && x > 0.0, "a finite number > 0");
        let non_negative =
            |field, x: f64| check(field, x.is_finite() && x >= 0.0, "a finite number >= 0");
        let all = |v: &Vector3<f64>, f: &dyn Fn(f64) -> bool| v.iter().all(|&x| f(x));
        positive("mass_kg", self.mass_kg)?;
        check("inertia_kgm2", all(&self.inertia_kgm2, &|x| x.is_finite() && x > 0.0), "three finite numbers > 0")?;
        let i = self.inertia_kgm2;
        check(
            "inertia_kgm2",
            i.x <= i.y + i.z && i.y <= i.x + i.z && i.z <= i.x + i.y,
            "each principal moment at most the sum of the other two (triangle inequality)",
        )?;
        positive("arm_length_m", self.arm_length_m)?;
        positive("prop_radius_m", self.prop_radius_m)?;
        positive("thrust_coeff_n_per_rps2", self.thrust_coeff_n_per_rps2)?;
        non_negative("yaw_moment_coeff_m", self.yaw_moment_coeff_m)?;
        positive("motor_time_constant_s", self.motor_time_constant_s)?;
        non_negative("rotor_thrust_min_n", self.rotor_thrust_min_n)?;
        check(
            "rotor_thrust_max_n",
            self.rotor_thrust_max_n.is_finite() && self.rotor_thrust_max_n > self.rotor_thrust_min_n,
            "a finite number > rotor_thrust_min_n",
        )?;
        check("attach_point_body_m", all(&self.attach_point_body_m, &f64::is_finite), "three finite numbers")?;
        check(
            "body_drag_n_per_mps2",
            all(&self.body_drag_n_per_mps2, &|x| x.is_finite() && x >= 0.0),
            "three finite numbers >= 0",
        )?;
        non_negative("rotor_drag_coeff", self.rotor_drag_coeff)?;
        self.autopilot.validate()
    }
}

impl AutopilotParams {
    /// Checks every field (ranges in the field docs).
    ///
    /// # Errors
    ///
    /// [`QuadError`] naming the first bad field (prefixed `autopilot.`).
    pub fn validate(&self) -> Result<(), QuadError> {
        let a = self;
        let all = |v: &Vector3<f64>, f: &dyn Fn(f64) -> bool| v.iter().all(|&x| f(x));
        let pos = |x: f64| x.is_finite() && x > 0.0;
        let non_neg = |x: f64| x.is_finite() && x >= 0.0;
        check("autopilot.rate_loop_hz", pos(a.rate_loop_hz), "a finite number > 0")?;
        check(
            "autopilot.attitude_rate_hz",
            pos(a.attitude_rate_hz) && a.attitude_rate_hz <= a.rate_loop_hz,
            "a finite number > 0, at most rate_loop_hz",
        )?;
        check("autopilot.attitude_gain_per_s", all(&a.attitude_gain_per_s, &pos), "three finite numbers > 0")?;
        check("autopilot.yaw_weight", a.yaw_weight > 0.0 && a.yaw_weight <= 1.0, "a number in (0, 1]")?;
        check("autopilot.rate_limit_rps", all(&a.rate_limit_rps, &pos), "three finite numbers > 0")?;
        check("autopilot.rate_p_per_s", all(&a.rate_p_per_s, &non_neg), "three finite numbers >= 0")?;
        check("autopilot.rate_i_per_s2", all(&a.rate_i_per_s2, &non_neg), "three finite numbers >= 0")?;
        // D on the measured acceleration adds `D` to the effective inertia of a discrete
        // difference: D >= 1 makes the one-step recursion marginal (as vt-cfo's Kd < 1).
        check("autopilot.rate_d", all(&a.rate_d, &|x| (0.0..1.0).contains(&x)), "three numbers in [0, 1)")?;
        check("autopilot.rate_int_lim_radps2", all(&a.rate_int_lim_radps2, &non_neg), "three finite numbers >= 0")
    }
}

/// `Ok` when `ok`, else the error naming `field`.
fn check(field: &'static str, ok: bool, expected: &'static str) -> Result<(), QuadError> {
    if ok {
        Ok(())
    } else {
        Err(QuadError { field, expected })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_valid_and_match_the_papers_uavs() {
        for (p, m, t) in [(QuadParams::paper(), 2.0, 50.0), (QuadParams::experiment(), 1.47, 30.0)] {
            assert_eq!(p.validate(), Ok(()));
            assert!((p.mass_kg - m).abs() < 1e-12);
            assert!((p.thrust_max_total_n() - t).abs() < 1e-12);
            // Rotor speed at full thrust: tip-speed scaling of the Iris's 1100 rad/s.
            let omega_max = (p.rotor_thrust_max_n / p.thrust_coeff_n_per_rps2).sqrt();
            assert!((omega_max * p.arm_length_m - REF_OMEGA_MAX_RPS * REF_ARM_M).abs() < 1e-6);
        }
    }

    /// Stock PX4 rate gains on the paper's airframe (authority about 101 rad/s^2 in roll):
    /// P about 15 1/s, against the project's tuned 25 (docs/plant.md).
    #[test]
    fn px4_default_rate_gains_scale_with_the_authority() {
        let tuned = QuadParams::paper();
        let stock = tuned.with_px4_default_rate_gains();
        let a = tuned.autopilot.rate_int_lim_radps2 / RATE_INT_LIM_FRACTION;
        assert!((stock.autopilot.rate_p_per_s.x - 15.0).abs() < 1.0, "{}", stock.autopilot.rate_p_per_s.x);
        assert!((stock.autopilot.rate_i_per_s2.y - 0.2 * a.y).abs() < 1e-9);
        assert!(stock.autopilot.rate_d.x < 1.0 && stock.autopilot.rate_d.z == 0.0);
        assert!(stock.validate().is_ok());
        assert_eq!(stock.autopilot.attitude_gain_per_s, tuned.autopilot.attitude_gain_per_s);
    }

    /// Issue 27: the paper's 2 kg airframe measures about 0.83 m from rotor tip to rotor tip
    /// (0.275 m arm, 11-inch propellers); its envelope adds the guard.
    #[test]
    fn envelope_of_the_paper_airframe_spans_its_rotor_tips() {
        let p = QuadParams::sized(2.0, 50.0);
        let tip = p.arm_length_m + p.prop_radius_m;
        assert!((2.0 * tip - 0.83).abs() < 0.01, "tip to tip {:.3} m", 2.0 * tip);
        assert!((2.0 * p.prop_radius_m / 0.0254 - 11.0).abs() < 0.1, "propeller {:.2} in", 2.0 * p.prop_radius_m / 0.0254);
        assert!((p.envelope_radius_m() - tip - ENVELOPE_GUARD_M).abs() < 1e-12);
        // Geometric similarity: the envelope grows as the cube root of the mass.
        let heavy = QuadParams::sized(16.0, 400.0);
        assert!((heavy.envelope_radius_m() - ENVELOPE_GUARD_M - 2.0 * tip).abs() < 1e-9);
    }

    #[test]
    fn sized_at_the_reference_mass_is_the_reference_airframe() {
        let p = QuadParams::sized(REF_MASS_KG, 4.0 * REF_THRUST_COEFF * REF_OMEGA_MAX_RPS * REF_OMEGA_MAX_RPS);
        assert!((p.arm_length_m - REF_ARM_M).abs() < 1e-12);
        assert!((p.prop_radius_m - REF_PROP_RADIUS_M).abs() < 1e-12);
        assert!((p.inertia_kgm2.x - REF_INERTIA_KGM2[0]).abs() < 1e-12);
        assert!((p.thrust_coeff_n_per_rps2 - REF_THRUST_COEFF).abs() < 1e-15);
        assert!((p.rotor_drag_coeff - REF_ROTOR_DRAG).abs() < 1e-15);
    }

    #[test]
    fn validate_names_the_bad_field() {
        let mut p = QuadParams::paper();
        p.rotor_thrust_max_n = p.rotor_thrust_min_n;
        assert_eq!(p.validate().map_err(|e| e.field), Err("rotor_thrust_max_n"));
        let mut p = QuadParams::paper();
        p.inertia_kgm2.z = 1.0;
        assert_eq!(p.validate().map_err(|e| e.field), Err("inertia_kgm2"));
        let mut p = QuadParams::paper();
        p.autopilot.rate_d.y = 1.0;
        assert_eq!(p.validate().map_err(|e| e.field), Err("autopilot.rate_d"));
        let mut p = QuadParams::paper();
        p.attach_point_body_m.x = f64::NAN;
        assert_eq!(p.validate().map_err(|e| e.field), Err("attach_point_body_m"));
        assert!(QuadParams::sized(0.0, 50.0).validate().is_err());
    }
}
