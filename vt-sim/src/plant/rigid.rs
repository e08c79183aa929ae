//! The `rigid_body` UAV model inside the plant: each UAV is a [`Quadrotor`] (6-DOF body, four
//! lagged rotors, drag, PX4-style autopilot; docs/plant.md) flying the firmware's setpoint,
//! its cable hooked at the quadrotor's attachment point below the centre of mass.
//!
//! Per sub-step `h` (the cable forces at the state at the start of the sub-step, as in the
//! point-mass model):
//! - cable `i` from UAV `i`'s attachment point (position and velocity `v + omega x r_a`) to the
//!   load ([`cable_force`]); its force acts at the attachment point ([`Quadrotor::step`] turns it
//!   into a force at the centre of mass and the torque `r_a x F`);
//! - each quadrotor advances one step under its setpoint (autopilot when due, mixer, motors,
//!   semi-implicit Euler + quaternion exponential map);
//! - the load: `m_l v_l' = m_l g + sum_i tau_i u_i + D_l`, semi-implicit Euler, with the
//!   quadratic drag `D_l` on its air-relative velocity in still air as well as in wind
//!   (the rigid-body model drags every body; the paper's point-mass model has no drag in calm
//!   air).
//!
//! `Plant::uavs` mirrors the quadrotors' centres of mass, velocities and thrust vectors after
//! every step, so sensors, metrics and records read one state for both models.

use nalgebra::{UnitQuaternion, Vector3};
use vt_companion::flight::Setpoint;

use super::{body_wind, command, gravity_vec_mps2, Plant};
use crate::cable::cable_force;
use crate::disturbance::drag_n;
use crate::quadrotor::{AttitudeTarget, QuadError, Quadrotor};

/// Trim iterations that place each quadrotor so that its (tilted) attachment point sits on the
/// take-off node: the tilt depends on the cable force, the force on the attachment point; the
/// map contracts by `|r_a| |F| / (m g)`, well below 1, so three passes reach micrometres.
const TRIM_PASSES: usize = 3;

/// Heading of every UAV at take-off, ENU: north, what the firmware holds at its default
/// `VL_YAW = 0` (NED yaw 0), the value `companion::params_for` sends.
const HEADING_ENU: Vector3<f64> = Vector3::new(0.0, 1.0, 0.0);

impl Plant {
    /// Replaces the point-mass UAVs by `quads` (one per UAV, in order), each moved so that its
    /// attachment point lies where the point-mass UAV was (the take-off node the cables were
    /// laid out for) and trimmed in hover against its cable at rest.
    ///
    /// # Errors
    /// [`QuadError`] for parameters the quadrotor rejects.
    pub(super) fn fit_quadrotors(&mut self, mut quads: Vec<Quadrotor>) -> Result<(), QuadError> {
        let load_pos = self.load.pos_m;
        for ((q, u), c) in quads.iter_mut().zip(&self.uavs).zip(&self.cables) {
            let node = u.pos_m;
            let f = cable_force(node, Vector3::zeros(), load_pos, Vector3::zeros(), c);
            for _ in 0..TRIM_PASSES {
                let offset = q.attach_point_world_m() - q.pos_m();
                *q = Quadrotor::new(*q.params(), node - offset, Vector3::zeros())?;
                q.face(HEADING_ENU);
                q.trim_hover(f.on_uav_n);
            }
        }
        self.rigid_targets = quads
            .iter()
            .map(|q| AttitudeTarget { attitude: q.attitude(), thrust_norm: q.autopilot().target().thrust_norm })
            .collect();
        self.rigid_setpoints = vec![None; quads.len()];
        self.quads = quads;
        self.mirror_quadrotors();
        self.last_forces = self.cable_forces();
        self.tensions_n = self.last_forces.iter().map(|f| f.tension_n).collect();
        Ok(())
    }

    /// The quadrotors of a `rigid_body` plant (empty for point-mass UAVs).
    #[must_use]
    pub fn quadrotors(&self) -> &[Quadrotor] {
        &self.quads
    }

    /// Where UAV `i`'s cable is hooked and how fast that point moves, world ENU (m, m/s): the
    /// quadrotor's attachment point, or the point mass itself.
    pub(super) fn hook(&self, i: usize) -> Option<(Vector3<f64>, Vector3<f64>)> {
        match self.quads.get(i) {
            Some(q) => Some((q.attach_point_world_m(), q.attach_velocity_world_mps())),
            None => self.uavs.get(i).map(|u| (u.pos_m, u.vel_mps)),
        }
    }

    /// Copies each quadrotor's centre of mass, velocity and thrust vector into `uavs`.
    fn mirror_quadrotors(&mut self) {
        for (u, q) in self.uavs.iter_mut().zip(&self.quads) {
            u.pos_m = q.pos_m();
            u.vel_mps = q.vel_mps();
            u.thrust_n = q.thrust_world_n();
        }
    }

    /// [`Plant::step_setpoints`] for the rigid-body model (module doc). A setpoint that is not
    /// finite or not a rotation keeps the last valid target (a lost setpoint); `motors_off[i]`
    /// commands zero collective at the current attitude (the rotors spin down to idle).
    pub(super) fn step_rigid(&mut self, setpoints: &[Setpoint], motors_off: &[bool], wind_mps: &Vector3<f64>, load_drag_area_m2: f64, dt_s: f64) {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return;
        }
        self.rigid_setpoints.resize(self.rigid_targets.len(), None);
        for (i, ((t, q), last)) in self.rigid_targets.iter_mut().zip(&self.quads).zip(self.rigid_setpoints.iter_mut()).enumerate() {
            if motors_off.get(i).copied().unwrap_or(false) {
                *t = AttitudeTarget { attitude: q.attitude(), thrust_norm: 0.0 };
                *last = None;
            } else if let Some(sp) = setpoints.get(i) {
                // Setpoints change at the low-level rate, the plant steps faster: convert each
                // one once (the same target either way).
                if *last == Some(*sp) {
                    continue;
                }
                *last = Some(*sp);
                if let (Some(attitude), Some(thrust_norm)) = (command::attitude_enu_flu(sp), command::collective(sp)) {
                    *t = AttitudeTarget { attitude, thrust_norm };
                }
            }
        }
        let wind = if wind_mps.iter().all(|x| x.is_finite()) { *wind_mps } else { Vector3::zeros() };
        let h = dt_s / self.substeps as f64;
        let g = gravity_vec_mps2();
        let n = self.quads.len().min(self.cables.len());
        self.last_forces.truncate(n);
        for _ in 0..self.substeps {
            let (load_pos, load_vel) = (self.load.pos_m, self.load.vel_mps);
            let load_wind = self.body_wind(&wind, load_pos.z, n);
            let mut load_force = self.load_params.mass_kg * g + drag_n(&load_wind, &load_vel, load_drag_area_m2);
            // The quadrotors two by two ([`Quadrotor::step_pair_on_cables`]: the same forces and
            // states as one by one, bit for bit); a UAV's step does not change what another's
            // cable sees (the load moves after the pass), and the load's force adds up in the
            // UAVs' order.
            let pairs = self.quads.chunks_mut(2).zip(self.cables.chunks(2)).zip(self.rigid_targets.chunks(2));
            for (k, ((qs, cs), ts)) in pairs.enumerate() {
                let wind_at = |lane: usize, q: &Quadrotor| body_wind(&wind, q.pos_m().z, self.roughness_m, &self.gusts_mps, 2 * k + lane);
                let forces = match (qs, cs, ts) {
                    ([qa, qb], [ca, cb], [ta, tb]) => {
                        let w = [wind_at(0, qa), wind_at(1, qb)];
                        Quadrotor::step_pair_on_cables([qa, qb], [ca, cb], &load_pos, &load_vel, [ta, tb], w, h).map(Some)
                    }
                    ([q, ..], [c, ..], [t, ..]) => {
                        let w = wind_at(0, q);
                        [Some(q.step_on_cable(c, &load_pos, &load_vel, t, w, h)), None]
                    }
                    _ => [None, None],
                };
                for (lane, f) in forces.into_iter().enumerate().filter_map(|(lane, f)| f.map(|f| (lane, f))) {
                    let i = 2 * k + lane;
                    let breaking = self.breaking_n.get(i).copied().unwrap_or(f64::INFINITY);
                    if f.tension_n > breaking {
                        self.breaks.push((i, f.tension_n, breaking));
                    }
                    load_force += f.on_load_n;
                    if let Some(slot) = self.last_forces.get_mut(i) {
                        *slot = f;
                    } else {
                        self.last_forces.push(f);
                    }
                }
            }
            self.load.vel_mps += load_force * (h / self.load_params.mass_kg);
            self.load.pos_m += self.load.vel_mps * h;
        }
        self.mirror_quadrotors();
        self.tensions_n.clear();
        self.tensions_n.extend(self.last_forces.iter().map(|f| f.tension_n));
        self.apply_breaks();
    }

    /// Every quadrotor's loops read their attitude and rates through its own IMU
    /// (`quadrotor::imu`), seeded from `seed`, errors scaled by `scale` (issue 27 §3).
    pub fn fit_imus(&mut self, seed: u64, scale: f64) {
        for (i, q) in self.quads.iter_mut().enumerate() {
            q.set_imu(Some(crate::quadrotor::imu::Imu::new(seed, i, scale)));
        }
    }

    /// The ground stops a quadrotor: one whose centre of mass is below z = 0 is put back on the
    /// ground, level, with no vertical velocity and its horizontal velocity less the friction
    /// (a landed or crashed vehicle: its autopilot restarts holding level at zero thrust).
    pub(super) fn ground_quadrotors(&mut self) {
        for q in &mut self.quads {
            let p = q.pos_m();
            if p.z < 0.0 {
                // Coulomb friction in impulse form, as the load's (`Plant::ground_contact`): a
                // landed UAV pulled by its cable or pushed by the wind slides once the pull
                // passes `GROUND_FRICTION` times its weight.
                let v = super::ground_friction(q.vel_mps());
                if let Ok(rest) = Quadrotor::new(*q.params(), Vector3::new(p.x, p.y, 0.0), Vector3::new(v.x, v.y, 0.0)) {
                    *q = rest;
                }
            }
        }
        self.mirror_quadrotors();
    }

    /// Attitude of UAV `i`, body FLU to world ENU (identity for a point mass, which has none).
    #[must_use]
    pub fn attitude(&self, i: usize) -> UnitQuaternion<f64> {
        self.quads.get(i).map_or_else(UnitQuaternion::identity, Quadrotor::attitude)
    }
}
