//! The traditional virtual-tube controller (Quan et al., RAS 2023; REFERENCE §2), the paper's
//! comparison (Fig. (c)(d)): each UAV alone, no springs, no load model:
//! `w_i = sat(u1 + u2 + u3, v_m)`, `u1 = k1 t_c`, `u2` the robot-robot barrier, `u3` the tube
//! term, all evaluated at the UAV's own horizontal position. Its altitude law is the same as
//! the dissipative controller's (the comparison in the paper is horizontal only).

use crate::controller::{hold_command, validate_gains, Command, Measurements};
use crate::keeping::keeping_velocity;
use crate::vertical::{VerticalLoop, VerticalParams};
use crate::{ControlError, Status, Vec2, Vec3};
use vt_tube::{sat, BarrierParams, Tube};

/// Parameters of the traditional virtual-tube controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaselineParams {
    /// Passing gain `k1`, m/s (`u1 = k1 t_c`).
    pub k1: f32,
    /// Robot-barrier gain `k2`, m^2/s.
    pub k2: f32,
    /// Tube-barrier gain `k3`, m^2/s.
    pub k3: f32,
    /// Velocity limit `v_m`, m/s.
    pub v_max_mps: f32,
    /// Robot safety radius `r_s`, m.
    pub r_safe_m: f32,
    /// Activation radius `r_a`, m.
    pub r_active_m: f32,
    /// Altitude law.
    pub vertical: VerticalParams,
}

impl Default for BaselineParams {
    /// Published parameters (REFERENCE §2): `r_s = 0.5`, `r_a = 0.7`, `k1 = 2`, `k2 = k3 = 1`,
    /// `v_max = 3`.
    fn default() -> Self {
        Self { k1: 2.0, k2: 1.0, k3: 1.0, v_max_mps: 3.0, r_safe_m: 0.5, r_active_m: 0.7, vertical: VerticalParams::default() }
    }
}

impl BaselineParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        validate_gains([self.k1, self.k2, self.k3], self.v_max_mps, self.r_safe_m, self.r_active_m)?;
        self.vertical.validate()
    }
}

/// One UAV's traditional virtual-tube controller.
#[derive(Debug, Clone)]
pub struct BaselineController {
    id: usize,
    n: usize,
    params: BaselineParams,
    tube_barrier: BarrierParams,
    robot_barrier: BarrierParams,
    hint: usize,
    vertical: VerticalLoop,
    /// Team hold (docs/design.md, "Team failsafe"): the passing term `u1` is off.
    team_hold: bool,
}

impl BaselineController {
    /// Controller of UAV `id` in a team of `n_uavs`.
    ///
    /// # Errors
    /// Invalid parameters or `id >= n_uavs`.
    pub fn new(id: usize, n_uavs: usize, params: BaselineParams) -> Result<Self, ControlError> {
        params.validate()?;
        if id >= n_uavs {
            return Err(ControlError::IdOutOfRange { id, n_uavs });
        }
        Ok(Self {
            id,
            n: n_uavs,
            params,
            tube_barrier: BarrierParams::tube(params.k3, params.r_safe_m, params.r_active_m),
            robot_barrier: BarrierParams::robot(params.k2, params.r_safe_m, params.r_active_m),
            hint: 0,
            vertical: VerticalLoop::new(params.vertical),
            team_hold: false,
        })
    }

    /// Team hold on or off (`docs/design.md`, "Team failsafe"): the passing term `u1` is off;
    /// the robot and tube barriers and the altitude law act as in transport.
    pub fn set_team_hold(&mut self, hold: bool) {
        self.team_hold = hold;
    }

    /// The load altitude reference of the altitude law, m, and its load sharing on or off (as
    /// [`crate::DissipativeController::set_load_altitude_ref`]).
    pub fn set_load_altitude_ref(&mut self, z_m: f32, sharing: crate::vertical::Sharing) {
        if z_m.is_finite() {
            self.params.vertical.load_altitude_ref_m = z_m;
        }
        self.vertical.set_load_altitude_ref(z_m, sharing);
    }

    /// One step: own velocity command. Same failure handling as the dissipative controller.
    pub fn update<const S: usize>(&mut self, tube: &Tube<S>, m: &Measurements<'_>, dt_s: f32) -> Command {
        let mut status = Status::default();
        if !(vt_fpu::all_finite(&m.own_pos_m) && vt_fpu::all_finite(&m.load_pos_m)) {
            status.invalid_input = true;
            return hold_command(&self.params.vertical, self.vertical.offset_m(), m, Vec2::zeros(), status);
        }
        let q = m.own_pos_m.xy();
        let Some(sec) = tube.locate(q, self.hint) else {
            status.invalid_input = true;
            return hold_command(&self.params.vertical, self.vertical.offset_m(), m, Vec2::zeros(), status);
        };
        self.hint = sec.segment;
        let u1 = if self.team_hold { Vec2::zeros() } else { sec.tangent * self.params.k1 };
        let mut u2 = Vec2::zeros();
        for j in 0..self.n {
            if j == self.id {
                continue;
            }
            match m.neighbours_m.get(j).copied().flatten() {
                Some(pj) if vt_fpu::all_finite(&pj) => {
                    let d = q - pj.xy();
                    let dist = vt_fpu::sqrt(d.norm_squared());
                    let b = self.robot_barrier.eval(dist);
                    if dist >= crate::springs::COINCIDENT_M {
                        u2 -= d * (b.deriv / dist);
                    } else {
                        status.coincident_nodes = true;
                        let dir = if self.id < j { 1.0 } else { -1.0 };
                        u2.x -= dir * b.deriv;
                    }
                }
                _ => status.neighbours_dropped = status.neighbours_dropped.saturating_add(1),
            }
        }
        let (u3, d_t) = keeping_velocity(&sec, &q, &self.tube_barrier);
        status.outside_tube = d_t <= 0.0;
        let w = sat(u1 + u2 + u3, self.params.v_max_mps);
        let v_z = self.vertical.update(&m.own_pos_m, &m.load_pos_m, m.own_cable_force_n, dt_s);
        let vel = Vec3::new(w.x, w.y, v_z);
        if !vt_fpu::all_finite(&vel) {
            status.nonfinite_command = true;
            return hold_command(&self.params.vertical, self.vertical.offset_m(), m, Vec2::zeros(), status);
        }
        Command { vel_mps: vel, node_m: q, tray_center_m: Vec2::zeros(), boundary_distance_m: d_t, section_s_m: sec.s_m, status }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use vt_tube::Waypoint;

    fn straight() -> Tube<256> {
        Tube::from_waypoints(&[Waypoint::new(0.0, 0.0, 3.0, 3.0), Waypoint::new(50.0, 0.0, 3.0, 3.0)]).unwrap()
    }

    fn m<'a>(own: Vec3, nb: &'a [Option<Vec3>]) -> Measurements<'a> {
        Measurements { own_pos_m: own, own_vel_mps: Vec3::zeros(), load_pos_m: Vec3::new(own.x, own.y, 0.0), load_vel_mps: Vec3::zeros(), neighbours_m: nb, neighbours_vel_mps: &[], own_cable_force_n: None }
    }

    #[test]
    fn alone_on_the_centreline_it_flies_k1_along_the_tube() {
        let mut c = BaselineController::new(0, 1, BaselineParams::default()).unwrap();
        let own = Vec3::new(10.0, 0.0, 8.0);
        let cmd = c.update(&straight(), &m(own, &[Some(own)]), 0.02);
        assert_relative_eq!(cmd.vel_mps.xy(), Vec2::new(2.0, 0.0), epsilon = 1e-5);
    }

    #[test]
    fn close_neighbour_repels() {
        let mut c = BaselineController::new(0, 2, BaselineParams::default()).unwrap();
        let own = Vec3::new(10.0, 0.0, 8.0);
        let other = Vec3::new(10.0, 1.1, 8.0); // inside r_a + r_s = 1.2 m
        let cmd = c.update(&straight(), &m(own, &[Some(own), Some(other)]), 0.02);
        assert!(cmd.vel_mps.y < 0.0, "must move away from the neighbour: {:?}", cmd.vel_mps);
        assert!(cmd.vel_mps.xy().norm() <= 3.0);
    }

    #[test]
    fn coincident_neighbour_and_nan_are_finite() {
        let mut c = BaselineController::new(1, 3, BaselineParams::default()).unwrap();
        let own = Vec3::new(10.0, 0.0, 8.0);
        let nb = [Some(own), Some(own), Some(Vec3::new(f32::NAN, 0.0, 0.0))];
        let cmd = c.update(&straight(), &m(own, &nb), 0.02);
        assert!(cmd.status.coincident_nodes);
        assert_eq!(cmd.status.neighbours_dropped, 1);
        assert!(cmd.vel_mps.iter().all(|x| x.is_finite()));
        let cmd = c.update(&straight(), &m(Vec3::repeat(f32::NAN), &nb), 0.02);
        assert!(cmd.status.invalid_input && cmd.vel_mps == Vec3::zeros());
    }

    #[test]
    fn rejects_bad_parameters() {
        let p = BaselineParams { r_active_m: 0.4, ..Default::default() };
        assert_eq!(BaselineController::new(0, 1, p).unwrap_err(), ControlError::InvalidParameter("r_active_m"));
        assert_eq!(
            BaselineController::new(3, 2, BaselineParams::default()).unwrap_err(),
            ControlError::IdOutOfRange { id: 3, n_uavs: 2 }
        );
    }
}
