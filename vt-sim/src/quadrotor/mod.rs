//! 6-DOF rigid-body quadrotor behind a PX4-style autopilot (issue 14, model `rigid_body`).
//!
//! # Frames
//!
//! World ENU (z up, gravity `-g z`); body FLU (x forward, y left, z up along the thrust);
//! attitude `q` rotates body FLU to world ENU (Hamilton, scalar first), as
//! `vt_cfo::AttitudeSetpoint`. Body rates `omega` are in FLU.
//!
//! # Equations of motion (docs/plant.md; Mahony, Kumar & Corke 2012, eqs. 1-3; Mellinger &
//! Kumar 2011, eqs. 1-3; RotorPy, Folk et al. 2023, `multirotor.py`)
//!
//! ```text
//! m v'  = R (F_rot + D_body + D_rot) + F_ext - m g z
//! L'    = R (tau_rot + tau_drag + r_a x R^T F_ext)      (L = R I omega, world, about the CoM)
//! q'    = q (0, omega) / 2
//! T_i'  = (T_cmd,i - T_i) / tau_m                      (first-order motors)
//! ```
//!
//! `L' = R tau` is Euler's `I omega' = tau - omega x I omega` written in the world frame.
//! Drag, RotorPy's model with the air-relative velocity `v_a = v - w` (body frame):
//! `D_body = -|v_a| c_D .* v_a` (quadratic, per body axis) and, per rotor hub `i` at `r_i`,
//! `D_rot,i = -k_d omega_i (v_a + omega x r_i)_xy` with `omega_i = sqrt(T_i / k_T)` (H-force,
//! in the rotor plane), which also gives the torque `r_i x D_rot,i`.
//!
//! # Integrator (one call of [`Quadrotor::step`])
//!
//! Autopilot (when due) and mixer; motors by their exact first-order discretisation
//! `T += (T_cmd - T)(1 - exp(-h / tau_m))`; translation by semi-implicit Euler (`v` then `p`
//! with the new `v`); rotation by `L += h R tau`, then the quaternion exponential map
//! `q <- q exp(omega_mid h / 2)` (renormalised) with the midpoint rates
//! `omega_mid = I^-1 R(q exp(omega h / 4))^T L`, `omega = I^-1 R^T L` (the turn half a step
//! ahead by Rodrigues' formula to second order), then `omega` again from the new `q`.
//! Integrating `L` in the world frame keeps the momentum of a torque-free body exact (an
//! explicit body-frame Euler step of `omega` grows the energy by `h^2 |omega'|^2` per step);
//! the exponential map keeps `q` on the unit sphere for any rate.
//!
//! # Defined behaviour on bad input
//!
//! A non-finite target keeps the last valid one; a non-finite external force or wind counts
//! as zero; forces beyond [`EXT_FORCE_LIMIT_N`] and winds beyond [`WIND_LIMIT_MPS`] are
//! clamped in magnitude; drag never reverses the airspeed within one step; a step that is not
//! finite and positive does nothing, one longer than [`MAX_SUBSTEP_S`] is split.

mod autopilot;
pub mod imu;
mod mixer;
mod pair;
mod params;

pub use autopilot::{attitude_rate_setpoint, AttitudeTarget, Autopilot, AutopilotOutput};
pub use mixer::{Mixer, Saturation};
pub use params::{AutopilotParams, QuadError, QuadParams};

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Gravitational acceleration, m/s^2 (the value of `plant::GRAVITY_MPS2` and
/// `vt_cfo::GRAVITY_MPS2`, REFERENCE §1).
pub const GRAVITY_MPS2: f64 = 9.81;
/// Largest external (cable) force magnitude applied, N (project bound: 500 times a 2 kg UAV's
/// weight, far beyond any cable's breaking load; keeps the state finite for any input).
pub const EXT_FORCE_LIMIT_N: f64 = 1.0e4;
/// Largest wind speed applied, m/s (project bound, well beyond any flyable wind).
pub const WIND_LIMIT_MPS: f64 = 100.0;
/// Longest physics sub-step, s (longer steps are split; the plant runs at 1-2 kHz).
pub const MAX_SUBSTEP_S: f64 = 0.005;
/// Rotor hub positions in units of the rotor offset `d`, body FLU (PX4 Quadrotor X order:
/// front-right, rear-left, front-left, rear-right).
const ROTOR_XY: [[f64; 2]; 4] = [[1.0, -1.0], [-1.0, 1.0], [1.0, 1.0], [-1.0, -1.0]];
/// Below this half-angle per step (rad) the exponential map uses its Taylor series (no
/// trigonometry; at 1 kHz it covers body rates up to 50 rad/s).
const SERIES_HALF_ANGLE_RAD: f64 = 0.025;

/// One quadrotor: rigid body, four lagged rotors, drag, and its autopilot.
#[derive(Debug, Clone)]
pub struct Quadrotor {
    /// Validated parameters.
    params: QuadParams,
    /// Allocation (from `params`).
    mixer: Mixer,
    /// Position of the centre of mass, world ENU, m.
    pos_m: Vector3<f64>,
    /// Velocity, world ENU, m/s.
    vel_mps: Vector3<f64>,
    /// Attitude, body FLU to world ENU.
    attitude: UnitQuaternion<f64>,
    /// The same attitude as a rotation matrix (kept with `attitude` by [`Self::set_attitude`]).
    rot: Matrix3<f64>,
    /// Body rates, FLU, rad/s (from `ang_mom_world`).
    body_rates_rps: Vector3<f64>,
    /// Angular momentum about the centre of mass, world ENU, kg m^2/s (integrated state).
    ang_mom_world: Vector3<f64>,
    /// Actual rotor thrusts, N.
    rotor_thrusts_n: [f64; 4],
    /// Commanded rotor thrusts (mixer output), N.
    rotor_cmd_n: [f64; 4],
    /// What the mixer had to give up at its last run.
    saturation: Saturation,
    /// Inner loops.
    autopilot: Autopilot,
    /// `1 / I` per body axis, 1/(kg m^2).
    inv_inertia: Vector3<f64>,
    /// `1 / m`, 1/kg.
    inv_mass: f64,
    /// `-k_d / sqrt(k_T)`: the H-force gain `-k_d omega_i` per square root of the rotor's
    /// thrust (`omega_i = sqrt(T_i / k_T)`), N s/m per sqrt(N).
    h_force_per_sqrt_n: f64,
    /// Rotor hub positions in the body plane (x, y), m ([`ROTOR_XY`] times the offset).
    rotor_hubs_m: [[f64; 2]; 4],
    /// `(h, 1 - exp(-h / tau_m))` of the last step length (saves an `exp` per step).
    motor_gain: (f64, f64),
    /// Each rotor's maximum thrust as built, N ([`Self::set_thrust_scale`] scales it).
    nominal_rotor_max_n: f64,
    /// The gyro and attitude estimate the loops read (`None`: the true state; [`imu`]).
    imu: Option<imu::Imu>,
}

impl Quadrotor {
    /// A quadrotor at `pos_m` (m, ENU) moving at `vel_mps` (m/s, ENU), level, nose east, not
    /// rotating, rotors at idle and the autopilot holding level at zero thrust. Call
    /// [`trim_hover`](Self::trim_hover) for a start at equilibrium.
    ///
    /// # Errors
    ///
    /// [`QuadError`] naming the bad field of `params`, or `pos_m` / `vel_mps` when not finite.
    pub fn new(params: QuadParams, pos_m: Vector3<f64>, vel_mps: Vector3<f64>) -> Result<Self, QuadError> {
        params.validate()?;
        let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
        if !finite(&pos_m) {
            return Err(QuadError { field: "pos_m", expected: "three finite numbers" });
        }
        if !finite(&vel_mps) {
            return Err(QuadError { field: "vel_mps", expected: "three finite numbers" });
        }
        let mixer = Mixer {
            rotor_offset_m: params.rotor_offset_m(),
            yaw_moment_coeff_m: params.yaw_moment_coeff_m,
            thrust_min_n: params.rotor_thrust_min_n,
            thrust_max_n: params.rotor_thrust_max_n,
        };
        let level = AttitudeTarget { attitude: UnitQuaternion::identity(), thrust_norm: 0.0 };
        let idle = [params.rotor_thrust_min_n; 4];
        Ok(Self {
            params,
            mixer,
            pos_m,
            vel_mps,
            attitude: UnitQuaternion::identity(),
            rot: Matrix3::identity(),
            body_rates_rps: Vector3::zeros(),
            ang_mom_world: Vector3::zeros(),
            rotor_thrusts_n: idle,
            rotor_cmd_n: idle,
            saturation: Saturation::default(),
            autopilot: Autopilot::new(params.autopilot, params.inertia_kgm2, params.thrust_max_total_n(), level),
            motor_gain: (0.0, 0.0),
            nominal_rotor_max_n: params.rotor_thrust_max_n,
            inv_inertia: params.inertia_kgm2.map(|x| 1.0 / x),
            inv_mass: 1.0 / params.mass_kg,
            h_force_per_sqrt_n: -params.rotor_drag_coeff / params.thrust_coeff_n_per_rps2.sqrt(),
            rotor_hubs_m: ROTOR_XY.map(|[x, y]| [x * params.rotor_offset_m(), y * params.rotor_offset_m()]),
            imu: None,
        })
    }

    /// The loops read attitude and rates through `imu` from now on (issue 27 §3; `None`: the
    /// true state).
    pub fn set_imu(&mut self, imu: Option<imu::Imu>) {
        self.imu = imu;
    }

    /// Puts the vehicle at rest in the equilibrium that balances gravity and the constant
    /// external force `ext_force_world_n` (N, ENU) at the attachment point: thrust axis along
    /// `m g z - F_ext` (level when the force is vertical; heading kept), rotor thrusts that
    /// also cancel the cable's torque `r_a x F_ext`, and the autopilot holding that attitude
    /// and thrust with its rate integral preloaded with that torque. Position is kept. A
    /// non-finite force counts as zero; a required thrust beyond the rotors' is saturated.
    pub fn trim_hover(&mut self, ext_force_world_n: Vector3<f64>) {
        let f_ext = sanitise(ext_force_world_n, EXT_FORCE_LIMIT_N);
        let p = self.params;
        let thrust_w = Vector3::z() * (p.mass_kg * GRAVITY_MPS2) - f_ext;
        let thrust_n = thrust_w.norm();
        let heading = self.attitude * Vector3::x();
        self.set_attitude(if thrust_n > 1e-9 { body_z_to_attitude(&(thrust_w / thrust_n), &heading) } else { level_with_heading(&heading) });
        let f_body = self.attitude.inverse() * f_ext;
        let torque = -p.attach_point_body_m.cross(&f_body);
        let (thrusts, sat) = self.mixer.mix(thrust_n, [torque.x, torque.y, torque.z]);
        self.rotor_thrusts_n = thrusts;
        self.rotor_cmd_n = thrusts;
        self.saturation = sat;
        self.vel_mps = Vector3::zeros();
        self.body_rates_rps = Vector3::zeros();
        self.ang_mom_world = Vector3::zeros();
        let target = AttitudeTarget { attitude: self.attitude, thrust_norm: thrust_n / p.thrust_max_total_n() };
        self.autopilot.reset(target, torque);
    }

    /// Advances by `h_s` (s): the autopilot when its loops are due (tracking `target`), the
    /// mixer, the motors and one integration step (module doc) under the external force
    /// `ext_force_at_attach_world_n` (N, ENU) applied at the attachment point and the wind
    /// `wind_world_mps` (m/s, ENU). Bad input: module doc.
    pub fn step(&mut self, target: &AttitudeTarget, ext_force_at_attach_world_n: Vector3<f64>, wind_world_mps: Vector3<f64>, h_s: f64) {
        let usable = h_s > 0.0 && h_s.is_finite();
        if !usable {
            return;
        }
        let f_ext = sanitise(ext_force_at_attach_world_n, EXT_FORCE_LIMIT_N);
        let wind = sanitise(wind_world_mps, WIND_LIMIT_MPS);
        if h_s <= MAX_SUBSTEP_S {
            self.substep(target, &f_ext, &wind, h_s);
            return;
        }
        let n = (h_s / MAX_SUBSTEP_S).ceil();
        let h = h_s / n;
        let mut remaining = n;
        while remaining > 0.0 {
            self.substep(target, &f_ext, &wind, h);
            remaining -= 1.0;
        }
    }

    /// One step of `h_s` (s) on a cable to the load at `load_pos_m` (m) moving at
    /// `load_vel_mps` (m/s): the cable's force from the attachment point at the start of the
    /// step ([`crate::cable::cable_force`]) applied there over the step ([`Quadrotor::step`]),
    /// with the wind `wind_world_mps` (m/s). Returns the force.
    pub fn step_on_cable(&mut self, cable: &crate::cable::CableParams, load_pos_m: &Vector3<f64>, load_vel_mps: &Vector3<f64>, target: &AttitudeTarget, wind_world_mps: Vector3<f64>, h_s: f64) -> crate::cable::CableForce {
        let f = crate::cable::cable_force(self.attach_point_world_m(), self.attach_velocity_world_mps(), *load_pos_m, *load_vel_mps, cable);
        self.step(target, f.on_uav_n, wind_world_mps, h_s);
        f
    }

    /// [`Quadrotor::step_on_cable`] of two vehicles at once (`qs[k]` on `cables[k]` under
    /// `targets[k]` in `wind_world_mps[k]`): the same forces and states, bit for bit, as two
    /// calls, in fewer instructions (both integrate in the two lanes of one SIMD register;
    /// [`pair`]).
    pub fn step_pair_on_cables(qs: [&mut Quadrotor; 2], cables: [&crate::cable::CableParams; 2], load_pos_m: &Vector3<f64>, load_vel_mps: &Vector3<f64>, targets: [&AttitudeTarget; 2], wind_world_mps: [Vector3<f64>; 2], h_s: f64) -> [crate::cable::CableForce; 2] {
        let [a, b] = qs;
        if !(h_s > 0.0 && h_s.is_finite() && h_s <= MAX_SUBSTEP_S) {
            let fa = a.step_on_cable(cables[0], load_pos_m, load_vel_mps, targets[0], wind_world_mps[0], h_s);
            let fb = b.step_on_cable(cables[1], load_pos_m, load_vel_mps, targets[1], wind_world_mps[1], h_s);
            return [fa, fb];
        }
        pair::step_pair_on_cables([a, b], cables, (load_pos_m, load_vel_mps), targets, wind_world_mps, h_s)
    }

    /// One step of at most [`MAX_SUBSTEP_S`] with sanitised inputs.
    fn substep(&mut self, target: &AttitudeTarget, f_ext: &Vector3<f64>, wind: &Vector3<f64>, h: f64) {
        self.loops_and_motors(target, h);
        self.integrate(f_ext, wind, h);
    }

    /// The first part of a step of `h` (s): the autopilot (through the IMU when there is one)
    /// when its loops are due, the mixer when the rate loop ran, and the motors' lag.
    fn loops_and_motors(&mut self, target: &AttitudeTarget, h: f64) {
        let (demand, ran) = match self.imu.as_mut() {
            Some(imu) => {
                let (q, w) = imu.measure(&self.attitude, &self.body_rates_rps, h);
                self.autopilot.update(target, &q, &w, h)
            }
            None => self.autopilot.update(target, &self.attitude, &self.body_rates_rps, h),
        };
        if ran {
            let (cmd, sat) = self.mixer.mix(demand.force_n, [demand.torque_nm.x, demand.torque_nm.y, demand.torque_nm.z]);
            self.rotor_cmd_n = cmd;
            self.saturation = sat;
        }
        if self.motor_gain.0 != h {
            self.motor_gain = (h, 1.0 - (-h / self.params.motor_time_constant_s).exp());
        }
        let k = self.motor_gain.1;
        for (t, c) in self.rotor_thrusts_n.iter_mut().zip(self.rotor_cmd_n) {
            *t += (c - *t) * k;
        }
    }

    /// The second part of a step of `h` (s), with sanitised inputs: forces and torques at the
    /// rotors' thrusts of [`Self::loops_and_motors`], then one integration step (module doc).
    fn integrate(&mut self, f_ext: &Vector3<f64>, wind: &Vector3<f64>, h: f64) {
        let p = &self.params;
        let rot = self.rot;
        let rot_t = rot.transpose();
        let omega = self.body_rates_rps;
        let (thrust_n, rotor_torque) = self.mixer.wrench(&self.rotor_thrusts_n);
        let mut torque_b = Vector3::from(rotor_torque);

        // Drag (RotorPy): body quadratic + rotor H-force, on the body-frame airspeed.
        let v_air_b = rot_t * (self.vel_mps - wind);
        let v_air = norm3(&v_air_b);
        let mut drag_b = -v_air * p.body_drag_n_per_mps2.component_mul(&v_air_b);
        // Per hub r = (r_x, r_y, 0): the hub's in-plane airspeed is (v_a + omega x r)_xy =
        // (v_x - omega_z r_y, v_y + omega_z r_x); the H-force -k_d omega_i v_hub,xy lies in
        // the rotor plane, so its torque r x D is about body z alone: r_x D_y - r_y D_x.
        // omega_i = sqrt(T_i / k_T); the four roots side by side (independent of each other).
        let sqrt_t = self.rotor_thrusts_n.map(|t| t.max(0.0).sqrt());
        for (&[rx, ry], &root) in self.rotor_hubs_m.iter().zip(&sqrt_t) {
            let gain = root * self.h_force_per_sqrt_n;
            let hx = (v_air_b.x - omega.z * ry) * gain;
            let hy = (v_air_b.y + omega.z * rx) * gain;
            drag_b.x += hx;
            drag_b.y += hy;
            torque_b.z += rx * hy - ry * hx;
        }
        // Drag cannot reverse the airspeed within one step (explicit-Euler stability bound):
        // |D| h <= m |v_a|, tested on squares (the square root only when it binds).
        let drag_sq = drag_b.dot(&drag_b);
        let bound = p.mass_kg * v_air;
        if drag_sq * h * h > bound * bound && drag_sq > 0.0 {
            drag_b *= bound / (drag_sq.sqrt() * h);
        }

        // Cable force at the attachment point: force at the CoM plus the torque r_a x F.
        let f_ext_b = rot_t * f_ext;
        torque_b += p.attach_point_body_m.cross(&f_ext_b);

        // Translation: semi-implicit Euler.
        let force_w = rot * (Vector3::new(drag_b.x, drag_b.y, drag_b.z + thrust_n)) + f_ext;
        let accel = force_w * self.inv_mass - Vector3::z() * GRAVITY_MPS2;
        self.vel_mps += accel * h;
        self.pos_m += self.vel_mps * h;

        // Rotation: world angular momentum, then the exponential map with the midpoint rates
        // (second order, so the torque-free energy error is O(h^2) per unit time, not O(h)).
        self.ang_mom_world += rot * torque_b * h;
        let inv_i = self.inv_inertia;
        // Body momentum b = R^T L at the start; half a step ahead the body has turned by
        // phi = omega h / 2, where the body momentum is Rot(phi)^T b = b - phi x b +
        // phi x (phi x b) / 2 + O(phi^3) (Rodrigues to second order: the midpoint rule's
        // own order; |phi| < 0.03 rad at 1 kHz and 50 rad/s).
        // R^T (L + R tau h) = I omega + tau h: the body momentum without another rotation.
        let b = self.params.inertia_kgm2.component_mul(&omega) + torque_b * h;
        let phi = inv_i.component_mul(&b) * (0.5 * h);
        let phi_b = phi.cross(&b);
        let b_mid = b - phi_b + phi.cross(&phi_b) * 0.5;
        let omega_mid = inv_i.component_mul(&b_mid);
        self.set_attitude(exp_step(&self.attitude, &omega_mid, h));
        self.body_rates_rps = inv_i.component_mul(&(self.rot.transpose() * self.ang_mom_world));
    }

    /// Sets the attitude and its rotation matrix together.
    fn set_attitude(&mut self, q: UnitQuaternion<f64>) {
        self.attitude = q;
        self.rot = *q.to_rotation_matrix().matrix();
    }

    /// Scales the rotors' maximum thrust to `scale` times the built one (issue 27: a thrust
    /// that differs from what the firmware believes, battery sag): the same normalised command
    /// gives `scale` times the thrust, the rotors' idle stays. `scale` is clamped so that the
    /// maximum stays above the idle thrust; a non-finite one is ignored.
    pub fn set_thrust_scale(&mut self, scale: f64) {
        if !scale.is_finite() {
            return;
        }
        let floor = 2.0 * self.params.rotor_thrust_min_n / self.nominal_rotor_max_n;
        let max = self.nominal_rotor_max_n * scale.max(floor);
        self.params.rotor_thrust_max_n = max;
        self.mixer.thrust_max_n = max;
        self.autopilot.set_thrust_max_total(4.0 * max);
    }

    /// Parameters in use.
    #[must_use]
    pub fn params(&self) -> &QuadParams {
        &self.params
    }

    /// Position of the centre of mass, world ENU, m.
    #[must_use]
    pub fn pos_m(&self) -> Vector3<f64> {
        self.pos_m
    }

    /// Velocity of the centre of mass, world ENU, m/s.
    #[must_use]
    pub fn vel_mps(&self) -> Vector3<f64> {
        self.vel_mps
    }

    /// Attitude, body FLU to world ENU (Hamilton).
    #[must_use]
    pub fn attitude(&self) -> UnitQuaternion<f64> {
        self.attitude
    }

    /// Body rates, FLU, rad/s.
    #[must_use]
    pub fn body_rates_rps(&self) -> Vector3<f64> {
        self.body_rates_rps
    }

    /// Actual rotor thrusts (after the motor lag), PX4 X order, N.
    #[must_use]
    pub fn rotor_thrusts_n(&self) -> [f64; 4] {
        self.rotor_thrusts_n
    }

    /// What the mixer had to give up at its last run.
    #[must_use]
    pub fn saturation(&self) -> Saturation {
        self.saturation
    }

    /// The autopilot's inner loops (target held, rate setpoint).
    #[must_use]
    pub fn autopilot(&self) -> &Autopilot {
        &self.autopilot
    }

    /// Current collective thrust vector (actual rotor thrusts along body z), world ENU, N.
    #[must_use]
    pub fn thrust_world_n(&self) -> Vector3<f64> {
        self.rot.column(2) * self.rotor_thrusts_n.iter().sum::<f64>()
    }

    /// Position of the cable attachment point, world ENU, m.
    #[must_use]
    pub fn attach_point_world_m(&self) -> Vector3<f64> {
        self.pos_m + self.rot * self.params.attach_point_body_m
    }

    /// Velocity of the cable attachment point, `v + R (omega x r_a)`, world ENU, m/s.
    #[must_use]
    pub fn attach_velocity_world_mps(&self) -> Vector3<f64> {
        self.vel_mps + self.rot * self.body_rates_rps.cross(&self.params.attach_point_body_m)
    }

    /// Kinetic energy, translational plus rotational, J.
    #[must_use]
    pub fn kinetic_energy_j(&self) -> f64 {
        let w = self.body_rates_rps;
        0.5 * self.params.mass_kg * self.vel_mps.norm_squared() + 0.5 * w.dot(&self.params.inertia_kgm2.component_mul(&w))
    }

    /// Linear momentum `m v`, world ENU, kg m/s.
    #[must_use]
    pub fn linear_momentum(&self) -> Vector3<f64> {
        self.vel_mps * self.params.mass_kg
    }

    /// Angular momentum about the centre of mass, `R I omega`, world ENU, kg m^2/s.
    #[must_use]
    pub fn angular_momentum_world(&self) -> Vector3<f64> {
        self.ang_mom_world
    }

    /// Turns the vehicle level, not rotating, nose along the horizontal part of `heading_world`
    /// (ENU; a zero or non-finite heading faces east) with the autopilot holding that attitude
    /// at zero thrust (initial conditions: call before [`trim_hover`](Self::trim_hover)).
    pub fn face(&mut self, heading_world: Vector3<f64>) {
        let h = if heading_world.iter().all(|x| x.is_finite()) { heading_world } else { Vector3::x() };
        self.set_attitude(level_with_heading(&h));
        self.body_rates_rps = Vector3::zeros();
        self.ang_mom_world = Vector3::zeros();
        let target = AttitudeTarget { attitude: self.attitude, thrust_norm: 0.0 };
        self.autopilot.reset(target, Vector3::zeros());
    }

    /// Sets the body rates (rad/s, FLU), keeping the rest of the state (tests, initial
    /// conditions); non-finite rates are ignored.
    pub fn set_body_rates_rps(&mut self, omega_rps: Vector3<f64>) {
        if omega_rps.iter().all(|x| x.is_finite()) {
            self.body_rates_rps = omega_rps;
            self.ang_mom_world = self.attitude * self.params.inertia_kgm2.component_mul(&omega_rps);
        }
    }
}

/// `v`, or zero when a component is not finite, clamped to magnitude `limit`.
fn sanitise(v: Vector3<f64>, limit: f64) -> Vector3<f64> {
    if !v.iter().all(|x| x.is_finite()) {
        return Vector3::zeros();
    }
    // The square root only for a vector near or beyond the limit.
    if v.dot(&v) <= limit * limit * 0.99 {
        return v;
    }
    let n = norm3(&v);
    if n > limit { v * (limit / n) } else { v }
}

/// Euclidean norm with the hardware square root (nalgebra's goes through `libm` here).
fn norm3(v: &Vector3<f64>) -> f64 {
    v.dot(v).sqrt()
}

/// `q / |q|` (hardware square root; `q` non-zero).
fn unit(q: Quaternion<f64>) -> UnitQuaternion<f64> {
    let n = q.coords.dot(&q.coords).sqrt();
    UnitQuaternion::new_unchecked(q / n)
}

/// `q / |q|` for a `q` within rounding of the unit sphere (the product of two unit
/// quaternions): one Newton step of `1 / sqrt(n2)` from 1, `(3 - n2) / 2`, whose error
/// `3 (n2 - 1)^2 / 8` is below 1e-24 for `|n2 - 1| < 1e-12` (no square root, no division).
fn renormalised(q: Quaternion<f64>) -> UnitQuaternion<f64> {
    let n2 = q.coords.dot(&q.coords);
    UnitQuaternion::new_unchecked(q * (1.5 - 0.5 * n2))
}

/// `q exp(omega h / 2)`: the rotation by `omega h` in the body frame, renormalised. With
/// `a = |omega| h / 2`: `exp = (cos a, sin(a)/a * omega h / 2)`; below `a` =
/// [`SERIES_HALF_ANGLE_RAD`] by the Taylor series to `a^4` (error below `a^6 / 720`, 4e-13).
fn exp_step(q: &UnitQuaternion<f64>, omega: &Vector3<f64>, h: f64) -> UnitQuaternion<f64> {
    let v = omega * (0.5 * h);
    let a2 = v.dot(&v);
    let (c, sinc) = if a2 < SERIES_HALF_ANGLE_RAD * SERIES_HALF_ANGLE_RAD {
        // Reciprocal factorials as constants: a multiplication, not a division, per term.
        (1.0 - a2 * 0.5 + a2 * a2 * (1.0 / 24.0), 1.0 - a2 * (1.0 / 6.0) + a2 * a2 * (1.0 / 120.0))
    } else {
        let a = a2.sqrt();
        let (s, c) = a.sin_cos();
        (c, s / a)
    };
    renormalised(q.into_inner() * Quaternion::new(c, v.x * sinc, v.y * sinc, v.z * sinc))
}

/// Attitude whose body z is `z_b` (unit, ENU) with the nose as close as possible to `heading`
/// (PX4 `ControlMath::bodyzToAttitude`, as `vt_cfo::thrust_to_attitude`).
fn body_z_to_attitude(z_b: &Vector3<f64>, heading: &Vector3<f64>) -> UnitQuaternion<f64> {
    let psi = heading.y.atan2(heading.x);
    let y_c = Vector3::new(-psi.sin(), psi.cos(), 0.0);
    let mut x_b = y_c.cross(z_b);
    if z_b.z < 0.0 {
        x_b = -x_b;
    }
    let n = x_b.norm();
    if n <= 1e-9 || !n.is_finite() {
        return level_with_heading(heading);
    }
    let x_b = x_b / n;
    let y_b = z_b.cross(&x_b);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x_b, y_b, *z_b])))
}

/// Level attitude with the nose along the horizontal part of `heading` (east if vertical).
fn level_with_heading(heading: &Vector3<f64>) -> UnitQuaternion<f64> {
    let psi = if heading.x.abs() + heading.y.abs() > 1e-12 { heading.y.atan2(heading.x) } else { 0.0 };
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), psi)
}

#[cfg(test)]
mod tests;
