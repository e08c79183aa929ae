//! One UAV's distributed dissipative controller: synthesis eq:2-16, mapping eq:2-20 and
//! saturation eq:2-21 (REFERENCE §3).
//!
//! For its own node `q_i` the command is (signs as intended, REFERENCE §3: advance along the
//! tube, restore the springs' rest lengths, push away from the boundary)
//! `vbar_i = sat(k1 l eta t_c, v_m) + sum_j vbar_ij + vbar_t,i`
//! with the spring sum over the other UAV nodes, the load node and the tray centre.
//!
//! The tray centre `u` is a virtual state. Remark 2 allows a UAV only its own state, the
//! load's and its neighbours' positions, so every UAV integrates its own replica of `q_u`
//! with the same law (passing + springs to all UAV nodes + tube keeping, saturated at `v_m`).
//! With the same inputs all replicas coincide; with delayed or dropped data they differ
//! slightly, which the springs tolerate (the centre only sets a weak shape reference).

use crate::capacity::FormationScale;
use crate::passing::passing_velocity;
use crate::keeping::keeping_velocity;
use crate::springs::{spring_velocity, Formation, NodeId};
use crate::tray::TrayParams;
use crate::vertical::{VerticalLoop, VerticalParams};
use crate::{ControlError, Status, Vec2, Vec3};
use vt_tube::{sat, BarrierParams, Tube};

/// Gain of the anchored team hold's position hold, 1/s: PX4's horizontal position gain
/// (`MPC_XY_P`, default 0.95 1/s), rounded; docs/design.md, "Team failsafe".
pub const HOLD_POSITION_GAIN_PER_S: f32 = 1.0;

/// Gains and limits of the dissipative controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DissipativeParams {
    /// Passing gain `k1`, 1/s.
    pub k1: f32,
    /// Spring gain `k2`, 1/s.
    pub k2: f32,
    /// Tube-barrier gain `k3`, m^2/s.
    pub k3: f32,
    /// Velocity limit `v_m` (eq:2-13, eq:2-21), m/s.
    pub v_max_mps: f32,
    /// Tube barrier safety radius `r_s`, m.
    pub r_safe_m: f32,
    /// Tube barrier activation radius `r_a`, m.
    pub r_active_m: f32,
    /// Virtual tray geometry.
    pub tray: TrayParams,
    /// Altitude law.
    pub vertical: VerticalParams,
}

impl Default for DissipativeParams {
    /// The paper's simulation gains (REFERENCE §5): `k1 = k2 = k3 = 1`, `v_m = 1.5 m/s`;
    /// barrier radii `r_s = 0.5 m`, `r_a = 1.5 m` (REFERENCE §6).
    fn default() -> Self {
        Self {
            k1: 1.0,
            k2: 1.0,
            k3: 1.0,
            v_max_mps: 1.5,
            r_safe_m: 0.5,
            r_active_m: 1.5,
            tray: TrayParams::default(),
            vertical: VerticalParams::default(),
        }
    }
}

impl DissipativeParams {
    /// The paper's outdoor-experiment gains: `k1 = 0.3`, `k2 = 0.1`, `k3 = 1`, `v_m = 1 m/s`.
    pub fn paper_experiment() -> Self {
        Self { k1: 0.3, k2: 0.1, k3: 1.0, v_max_mps: 1.0, ..Self::default() }
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        validate_gains([self.k1, self.k2, self.k3], self.v_max_mps, self.r_safe_m, self.r_active_m)?;
        self.tray.validate()?;
        self.vertical.validate()
    }

    /// The tube barrier eq:2-15-1 these parameters define.
    pub fn tube_barrier(&self) -> BarrierParams {
        BarrierParams::tube(self.k3, self.r_safe_m, self.r_active_m)
    }
}

/// Checks the gains `k1..k3`, the speed limit and the barrier radii shared by both
/// controllers' parameter sets, naming the first bad one.
pub(crate) fn validate_gains(k: [f32; 3], v_max_mps: f32, r_safe_m: f32, r_active_m: f32) -> Result<(), ControlError> {
    let pos = |x: f32| x.is_finite() && x > 0.0;
    let checks: [(bool, &'static str); 6] = [
        (pos(k[0]), "k1"),
        (pos(k[1]), "k2"),
        (pos(k[2]), "k3"),
        (pos(v_max_mps), "v_max_mps"),
        (pos(r_safe_m), "r_safe_m"),
        (r_active_m.is_finite() && r_active_m > r_safe_m, "r_active_m"),
    ];
    match checks.iter().find(|(ok, _)| !ok) {
        Some((_, name)) => Err(ControlError::InvalidParameter(name)),
        None => Ok(()),
    }
}

/// What one UAV knows at a high-level step (Remark 2). World ENU, m and m/s.
#[derive(Debug, Clone, Copy)]
pub struct Measurements<'a> {
    /// Own position, m.
    pub own_pos_m: Vec3,
    /// Load position, m.
    pub load_pos_m: Vec3,
    /// Load velocity, m/s.
    pub load_vel_mps: Vec3,
    /// Neighbours' positions by UAV id (own slot ignored); `None` = missing or stale.
    pub neighbours_m: &'a [Option<Vec3>],
    /// The velocity loop's estimate of the cable force on this UAV (`f_hat`, REFERENCE §4), N;
    /// `None` when unavailable (load sharing then holds its offset).
    pub own_cable_force_n: Option<Vec3>,
}

/// One UAV's velocity command and what went into it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Velocity command for the velocity loop (eq:2-21), m/s, world ENU.
    pub vel_mps: Vec3,
    /// Own virtual node `q_i`, m.
    pub node_m: Vec2,
    /// This UAV's replica of the tray centre `q_u`, m.
    pub tray_center_m: Vec2,
    /// Own node's boundary distance `d_t`, m.
    pub boundary_distance_m: f32,
    /// Own node's section `s(q_i)`, m.
    pub section_s_m: f32,
    /// Health flags.
    pub status: Status,
}

/// One UAV's rest lengths (eq:2-7), m: to every UAV node (own slot unused), to the load node,
/// to the tray centre, and the tray centre's to every UAV node.
#[derive(Debug, Clone, Copy)]
struct RestLengths<const N: usize> {
    own_m: [f32; N],
    own_load_m: f32,
    own_center_m: f32,
    center_m: [f32; N],
}

impl<const N: usize> RestLengths<N> {
    /// Every length times `scale` (the capacity-aware formation, capacity.rs: the ratio of the
    /// new formation scale to the old; one rounding per change, the same on every backend); the
    /// first `n`.
    fn scaled(&self, scale: f32, n: usize) -> Self {
        let mut out = *self;
        for (o, r) in out.own_m.iter_mut().zip(self.own_m.iter()).take(n) {
            *o = r * scale;
        }
        for (o, r) in out.center_m.iter_mut().zip(self.center_m.iter()).take(n) {
            *o = r * scale;
        }
        out.own_load_m = self.own_load_m * scale;
        out.own_center_m = self.own_center_m * scale;
        out
    }
}

/// The distributed dissipative controller of UAV `id` in a team of up to `N`.
#[derive(Debug, Clone)]
pub struct DissipativeController<const N: usize> {
    id: usize,
    n: usize,
    params: DissipativeParams,
    barrier: BarrierParams,
    /// Rest lengths now: the take-off ones (eq:2-7) times the formation scale `rest_scale`
    /// (recomputed from `rest_scale` relative to the last scale when it changes).
    rest: RestLengths<N>,
    /// The formation scale `rest` was computed for.
    rest_scale: f32,
    center_m: Vec2,
    own_hint: usize,
    center_hint: usize,
    vertical: VerticalLoop,
    /// Team hold (docs/design.md, "Team failsafe"): the passing term is off.
    team_hold: bool,
    /// Where the UAV holds its horizontal position in team hold once a neighbour is missing
    /// (the anchor), world ENU, m.
    anchor_m: Option<Vec2>,
    /// Capacity-aware formation scale (`FormationScale::NEUTRAL` unless configured).
    scale: FormationScale,
}

impl<const N: usize> DissipativeController<N> {
    /// Controller of UAV `id` with rest lengths from the take-off `formation` (eq:2-7).
    ///
    /// # Errors
    /// Invalid parameters, or `id` not below the formation's team size.
    pub fn new(id: usize, params: DissipativeParams, formation: &Formation<N>) -> Result<Self, ControlError> {
        params.validate()?;
        let n = formation.n_uavs();
        if id >= n {
            return Err(ControlError::IdOutOfRange { id, n_uavs: n });
        }
        let mut rest_own_m = [0.0; N];
        let mut rest_center_m = [0.0; N];
        for (j, (ro, rc)) in rest_own_m.iter_mut().zip(rest_center_m.iter_mut()).enumerate().take(n) {
            *ro = formation.rest_length_m(NodeId::Uav(id), NodeId::Uav(j));
            *rc = formation.rest_length_m(NodeId::Center, NodeId::Uav(j));
        }
        let rest = RestLengths {
            own_m: rest_own_m,
            own_load_m: formation.rest_length_m(NodeId::Uav(id), NodeId::Load),
            own_center_m: formation.rest_length_m(NodeId::Uav(id), NodeId::Center),
            center_m: rest_center_m,
        };
        Ok(Self {
            id,
            n,
            params,
            barrier: params.tube_barrier(),
            rest,
            rest_scale: 1.0,
            center_m: formation.node_m(NodeId::Center),
            own_hint: 0,
            center_hint: 0,
            vertical: VerticalLoop::new(params.vertical),
            team_hold: false,
            anchor_m: None,
            scale: FormationScale::NEUTRAL,
        })
    }

    /// Switches the team hold on or off for the following steps (`docs/design.md`, "Team
    /// failsafe"): the passing term eq:2-13 of the own node is off and the tray-centre replica
    /// stands still (zero tray velocity), so nothing drives the team along the tube and the
    /// centre springs anchor it; the springs eq:2-5, the tube keeping eq:2-14 and the altitude
    /// law act as in transport. Once a neighbour is missing during the hold, a spring of rest
    /// length 0 also holds the own node where it was then. With the passing potential gone and
    /// the centre (and anchor) fixed, the spring and barrier energy alone is a Lyapunov
    /// function of the node dynamics: the team comes to rest in its formation around the held
    /// centre, inside the tube.
    pub fn set_team_hold(&mut self, hold: bool) {
        self.team_hold = hold;
        if !hold {
            self.anchor_m = None;
        }
    }

    /// True while the team hold is on.
    pub fn team_hold(&self) -> bool {
        self.team_hold
    }

    /// Turns on the capacity-aware formation law (docs/design.md, "Capacity-aware formation"):
    /// rest lengths scaled by `scale`'s `lambda`, the passing term by its progress factor.
    /// Without it the controller is the paper's, bit for bit.
    pub fn set_capacity(&mut self, scale: FormationScale) {
        self.scale = scale;
    }

    /// [`Self::set_capacity`] as a builder.
    #[must_use]
    pub fn with_capacity(mut self, scale: FormationScale) -> Self {
        self.set_capacity(scale);
        self
    }

    /// The formation scale `lambda` now (1 = the take-off formation).
    pub fn formation_scale(&self) -> f32 {
        self.scale.scale()
    }

    /// This controller's UAV id.
    pub fn id(&self) -> usize {
        self.id
    }

    /// The parameters in use.
    pub fn params(&self) -> &DissipativeParams {
        &self.params
    }

    /// The tray-centre replica `q_u`, m.
    pub fn tray_center_m(&self) -> Vec2 {
        self.center_m
    }

    /// One high-level step of period `dt_s`: own velocity command from the measurements.
    ///
    /// Non-finite own or load state gives hold (zero horizontal velocity; the altitude law if
    /// the own altitude is finite, else zero) with `status.invalid_input`. Missing or
    /// non-finite neighbours are dropped from the spring set and counted. The output is
    /// always finite and within `v_m` horizontally and `v_z,max` vertically.
    pub fn update<const S: usize>(&mut self, tube: &Tube<S>, m: &Measurements<'_>, dt_s: f32) -> Command {
        let mut status = Status::default();
        let p = self.params;
        let inputs_ok = finite3(&m.own_pos_m) && finite3(&m.load_pos_m) && finite3(&m.load_vel_mps);
        if !inputs_ok {
            status.invalid_input = true;
            return self.hold(m, status);
        }
        let load_xy = m.load_pos_m.xy();
        let (q_i, floored) = p.tray.project(&m.own_pos_m, &m.load_pos_m);
        status.projection_floored = floored;
        // Capacity-aware formation: rest lengths x lambda, passing x progress (capacity.rs).
        let so = self.scale.update(m.load_pos_m.z, p.vertical.load_altitude_ref_m, dt_s);
        status.overload = so.overload > 0.0;
        if so.scale != self.rest_scale {
            self.rest = self.rest.scaled(so.scale / self.rest_scale, self.n);
            self.rest_scale = so.scale;
        }

        // Neighbour nodes (eq:2-4), dropped when missing or non-finite.
        let mut nodes: [Option<Vec2>; N] = [None; N];
        for (j, slot) in nodes.iter_mut().enumerate().take(self.n) {
            if j == self.id {
                *slot = Some(q_i);
                continue;
            }
            match m.neighbours_m.get(j).copied().flatten() {
                Some(pj) if finite3(&pj) => *slot = Some(p.tray.project(&pj, &m.load_pos_m).0),
                _ => status.neighbours_dropped = status.neighbours_dropped.saturating_add(1),
            }
        }

        // Own node: passing + springs + tube keeping (eq:2-16).
        let Some(sec) = tube.locate(q_i, self.own_hint) else {
            status.invalid_input = true;
            return self.hold(m, status);
        };
        self.own_hint = sec.segment;
        // Team hold (docs/design.md, "Team failsafe"): no passing term. Once a neighbour is
        // missing during the hold, the UAV holds its own horizontal position where it was then
        // (the anchor; see below): the missing springs no longer fix its place in the formation.
        let mut vbar = Vec2::zeros();
        if !self.team_hold {
            vbar = passing_velocity(&sec, &q_i, p.k1, p.v_max_mps) * so.progress;
        } else if status.neighbours_dropped > 0 && self.anchor_m.is_none() {
            self.anchor_m = Some(m.own_pos_m.xy());
        }
        for (j, (q_j, rest)) in nodes.iter().zip(self.rest.own_m.iter()).enumerate().take(self.n) {
            if let (Some(q_j), true) = (q_j, j != self.id) {
                let (v, c) = spring_velocity(&q_i, q_j, *rest, p.k2, self.id < j);
                vbar += v;
                status.coincident_nodes |= c;
            }
        }
        let (v_l, c_l) = spring_velocity(&q_i, &load_xy, self.rest.own_load_m, p.k2, true);
        let (v_u, c_u) = spring_velocity(&q_i, &self.center_m, self.rest.own_center_m, p.k2, true);
        status.coincident_nodes |= c_l | c_u;
        let (v_t, d_t) = self.keeping(tube, &sec, &q_i, m);
        status.outside_tube = d_t <= 0.0;
        vbar += v_l + v_u + v_t;

        // Tray-centre replica: same law over its springs to the UAV nodes, explicit Euler; in
        // team hold it stands still (zero tray velocity: the anchor of the held formation).
        if dt_s.is_finite() && dt_s > 0.0 && !self.team_hold {
            self.step_center(tube, &nodes, so.progress, dt_s, &mut status);
        }

        // Map back to the UAV (eq:2-20) and saturate (eq:2-21).
        let v_xy = match self.anchor_m {
            // Anchored team hold: position hold at the anchor plus the tube keeping, without
            // the springs and the load's velocity (a neighbour the UAV cannot see is safe only
            // if every UAV stays where it was when the link went quiet; docs/design.md).
            Some(anchor) => {
                (anchor - m.own_pos_m.xy()) * HOLD_POSITION_GAIN_PER_S
                    + p.tray.node_velocity_to_uav(&v_t, m.own_pos_m.z, &m.load_pos_m, &Vec3::zeros())
            }
            None => p.tray.node_velocity_to_uav(&vbar, m.own_pos_m.z, &m.load_pos_m, &m.load_vel_mps),
        };
        let v_xy = sat(v_xy, p.v_max_mps);
        let v_z = self.vertical.update(&m.own_pos_m, &m.load_pos_m, m.own_cable_force_n, dt_s);
        let vel = Vec3::new(v_xy.x, v_xy.y, v_z);
        if !finite3(&vel) {
            status.nonfinite_command = true;
            return self.hold(m, status);
        }
        Command {
            vel_mps: vel,
            node_m: q_i,
            tray_center_m: self.center_m,
            boundary_distance_m: d_t,
            section_s_m: sec.s_m,
            status,
        }
    }

    /// Tube-keeping term (eq:2-14/15) in node velocity, and the boundary distance it keeps.
    /// Normally at the own node: below the tray plane the UAV lies between the load and its
    /// node, so a node inside the tube keeps the UAV inside. A UAV higher than `H` above the
    /// load (the load sank far below its reference: overload) lies *beyond* its node; the term
    /// is then evaluated at the UAV's own horizontal position and scaled by `H / (z_i - z_l)`,
    /// so that eq:2-20 hands the UAV exactly the barrier velocity of its own position
    /// (docs/design.md, "Overload in flight").
    fn keeping<const S: usize>(&mut self, tube: &Tube<S>, sec: &vt_tube::Section, q_i: &Vec2, m: &Measurements<'_>) -> (Vec2, f32) {
        let h = self.params.tray.height_above_load_m;
        let dz = m.own_pos_m.z - m.load_pos_m.z;
        if dz > h {
            let p_i = m.own_pos_m.xy();
            if let Some(s_uav) = tube.locate(p_i, sec.segment) {
                let (v, d) = keeping_velocity(&s_uav, &p_i, &self.barrier);
                return (v * (h / dz), d);
            }
        }
        keeping_velocity(sec, q_i, &self.barrier)
    }

    fn step_center<const S: usize>(&mut self, tube: &Tube<S>, nodes: &[Option<Vec2>; N], progress: f32, dt_s: f32, status: &mut Status) {
        let p = &self.params;
        let q_u = self.center_m;
        let Some(sec) = tube.locate(q_u, self.center_hint) else {
            return;
        };
        self.center_hint = sec.segment;
        let mut v = passing_velocity(&sec, &q_u, p.k1, p.v_max_mps) * progress;
        for (q_j, rest) in nodes.iter().zip(self.rest.center_m.iter()).take(self.n) {
            if let Some(q_j) = q_j {
                let (vs, c) = spring_velocity(&q_u, q_j, *rest, p.k2, false);
                v += vs;
                status.coincident_nodes |= c;
            }
        }
        v += keeping_velocity(&sec, &q_u, &self.barrier).0;
        let next = q_u + sat(v, p.v_max_mps) * dt_s;
        if next.x.is_finite() && next.y.is_finite() {
            self.center_m = next;
        }
    }

    /// Hold: zero horizontal velocity, altitude law if possible.
    fn hold(&self, m: &Measurements<'_>, status: Status) -> Command {
        hold_command(&self.params.vertical, self.vertical.offset_m(), m, self.center_m, status)
    }
}

/// Hold command shared by both controllers: zero horizontal velocity; the altitude law when
/// own altitude and load position are finite, else zero vertical velocity.
pub(crate) fn hold_command(vertical: &VerticalParams, offset_m: f32, m: &Measurements<'_>, center_m: Vec2, status: Status) -> Command {
    let v_z = if finite3(&m.load_pos_m) && finite3(&m.own_pos_m) {
        vertical.vertical_velocity_mps(m.own_pos_m.z - offset_m, vt_fpu::norm(&(m.own_pos_m.xy() - m.load_pos_m.xy())))
    } else {
        0.0
    };
    let v_z = if v_z.is_finite() { v_z } else { 0.0 };
    Command {
        vel_mps: Vec3::new(0.0, 0.0, v_z),
        node_m: Vec2::zeros(),
        tray_center_m: center_m,
        boundary_distance_m: 0.0,
        section_s_m: 0.0,
        status,
    }
}

#[inline]
pub(crate) fn finite3(v: &Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;
    use vt_tube::Waypoint;

    const N: usize = 16;
    const DT_S: f32 = 0.02;
    const LOAD_Z_M: f32 = 5.0;

    /// 60 m tube, 6 m half-width at the ends, 2.2 m in the middle, gentle S.
    fn tube() -> Tube<256> {
        Tube::from_waypoints(&[
            Waypoint::new(0.0, 0.0, 6.0, 6.0),
            Waypoint::new(15.0, 2.0, 5.0, 5.0),
            Waypoint::new(30.0, 0.0, 2.2, 2.2),
            Waypoint::new(45.0, -2.0, 5.0, 5.0),
            Waypoint::new(60.0, 0.0, 6.0, 6.0),
        ])
        .unwrap()
    }

    fn params() -> DissipativeParams {
        DissipativeParams {
            vertical: VerticalParams { load_altitude_ref_m: LOAD_Z_M, cable_length_m: 8.0, ..Default::default() },
            ..Default::default()
        }
    }

    /// n UAVs whose nodes sit on a 3 m circle around the load at (x0, 0).
    fn takeoff(n: usize, x0: f32) -> (Vec<Vec3>, Vec3) {
        let load = Vec3::new(x0, 0.0, LOAD_Z_M);
        let h = 8.0 / (1.0f32 + 0.09).sqrt(); // taut 8 m cable, node radius 3 at H = 10
        let uavs = (0..n)
            .map(|i| {
                let a = i as f32 / n as f32 * core::f32::consts::TAU;
                Vec3::new(x0 + 0.3 * h * a.cos(), 0.3 * h * a.sin(), LOAD_Z_M + h)
            })
            .collect();
        (uavs, load)
    }

    fn team(n: usize, uavs: &[Vec3], load: &Vec3) -> Vec<DissipativeController<N>> {
        let f = Formation::<N>::from_takeoff(uavs, load, &params().tray).unwrap();
        (0..n).map(|i| DissipativeController::new(i, params(), &f).unwrap()).collect()
    }

    fn neighbours(uavs: &[Vec3]) -> Vec<Option<Vec3>> {
        uavs.iter().copied().map(Some).collect()
    }

    #[test]
    fn nan_inputs_give_hold_and_are_flagged() {
        let (uavs, load) = takeoff(4, 5.0);
        let mut ctl = team(4, &uavs, &load);
        let nb = neighbours(&uavs);
        let t = tube();
        for (own, l) in [
            (Vec3::new(f32::NAN, 0.0, 12.0), load),
            (uavs[0], Vec3::new(0.0, f32::INFINITY, 5.0)),
            (Vec3::repeat(f32::NAN), load),
        ] {
            let m = Measurements { own_pos_m: own, load_pos_m: l, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
            let c = ctl[0].update(&t, &m, DT_S);
            assert!(c.status.invalid_input);
            assert_eq!(c.vel_mps.xy(), Vec2::zeros());
            assert!(c.vel_mps.z.is_finite());
        }
    }

    #[test]
    fn nan_and_missing_neighbours_are_dropped_and_counted() {
        let (uavs, load) = takeoff(4, 5.0);
        let mut ctl = team(4, &uavs, &load);
        let nb = [Some(uavs[0]), None, Some(Vec3::new(f32::NAN, 0.0, 1.0)), Some(uavs[3])];
        let m = Measurements { own_pos_m: uavs[0], load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
        let c = ctl[0].update(&tube(), &m, DT_S);
        assert_eq!(c.status.neighbours_dropped, 2);
        assert!(!c.status.invalid_input);
        assert!(c.vel_mps.iter().all(|x| x.is_finite()));
        // A short slice (fewer entries than UAVs) drops the rest.
        let m = Measurements { neighbours_m: &nb[..1], ..m };
        assert_eq!(ctl[0].update(&tube(), &m, DT_S).status.neighbours_dropped, 3);
    }

    #[test]
    fn coincident_uavs_get_finite_separating_commands() {
        let (mut uavs, load) = takeoff(4, 5.0);
        let mut ctl = team(4, &uavs, &load);
        uavs[1] = uavs[0];
        let nb = neighbours(&uavs);
        let t = tube();
        let mk = |own| Measurements { own_pos_m: own, load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
        let c0 = ctl[0].update(&t, &mk(uavs[0]), DT_S);
        let c1 = ctl[1].update(&t, &mk(uavs[1]), DT_S);
        assert!(c0.status.coincident_nodes && c1.status.coincident_nodes);
        assert!(c0.vel_mps.iter().chain(c1.vel_mps.iter()).all(|x| x.is_finite()));
        assert!((c0.vel_mps - c1.vel_mps).norm() > 1e-3, "coincident UAVs must be driven apart");
    }

    #[test]
    fn uav_below_the_load_is_floored_finite_and_limited() {
        let (mut uavs, load) = takeoff(4, 5.0);
        let mut ctl = team(4, &uavs, &load);
        uavs[0].z = LOAD_Z_M - 3.0;
        let nb = neighbours(&uavs);
        let m = Measurements { own_pos_m: uavs[0], load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
        let c = ctl[0].update(&tube(), &m, DT_S);
        assert!(c.status.projection_floored);
        assert!(c.vel_mps.xy().norm() <= params().v_max_mps);
        assert!(c.vel_mps.z > 0.0, "a UAV below the load must climb");
    }

    #[test]
    fn uav_exactly_at_the_tray_plane_is_nominal() {
        let (mut uavs, load) = takeoff(4, 5.0);
        let mut ctl = team(4, &uavs, &load);
        uavs[2].z = LOAD_Z_M + params().tray.height_above_load_m;
        let nb = neighbours(&uavs);
        let m = Measurements { own_pos_m: uavs[2], load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
        let c = ctl[2].update(&tube(), &m, DT_S);
        assert!(!c.status.projection_floored);
        assert_relative_eq!(c.node_m, uavs[2].xy(), epsilon = 1e-5);
    }

    #[test]
    fn symmetric_formation_on_a_straight_tube_moves_rigidly() {
        // Straight symmetric tube, formation at rest length: every UAV gets the same velocity.
        let t = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 8.0, 8.0), Waypoint::new(80.0, 0.0, 8.0, 8.0)])
            .unwrap();
        let (uavs, load) = takeoff(6, 10.0);
        let mut ctl = team(6, &uavs, &load);
        let nb = neighbours(&uavs);
        let cmds: Vec<Command> = ctl
            .iter_mut()
            .zip(uavs.iter())
            .map(|(c, u)| {
                c.update(&t, &Measurements { own_pos_m: *u, load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None }, DT_S)
            })
            .collect();
        for c in &cmds {
            assert!(c.status.is_nominal(), "{:?}", c.status);
            assert_relative_eq!(c.vel_mps.xy(), cmds[0].vel_mps.xy(), epsilon = 1e-4);
        }
        // Passing at v_m mapped by (z_i - z_l)/H.
        let h = 8.0 / (1.0f32 + 0.09).sqrt();
        assert_relative_eq!(cmds[0].vel_mps.x, 1.5 * h / 10.0, epsilon = 1e-3);
    }

    #[test]
    fn tray_center_replicas_agree() {
        let (uavs, load) = takeoff(5, 5.0);
        let mut ctl = team(5, &uavs, &load);
        let nb = neighbours(&uavs);
        let t = tube();
        for _ in 0..50 {
            for (c, u) in ctl.iter_mut().zip(uavs.iter()) {
                c.update(&t, &Measurements { own_pos_m: *u, load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None }, DT_S);
            }
        }
        for c in &ctl {
            assert_eq!(c.tray_center_m(), ctl[0].tray_center_m());
        }
    }

    /// Kinematic closed loop of the virtual system (Prop. 2): UAVs follow their commands
    /// exactly, the load hangs below the UAVs' centroid. Returns (min node d_t, min node
    /// distance, final load s, final spring-shape error).
    fn fly(n: usize, steps: usize) -> (f32, f32, f32) {
        fly_with_hold(n, steps, 0..0).0
    }

    /// [`fly`] with the whole team in team hold during the steps `hold`; also returns the
    /// load's arc position at every step.
    fn fly_with_hold(n: usize, steps: usize, hold: core::ops::Range<usize>) -> ((f32, f32, f32), Vec<f32>) {
        let t = tube();
        let (mut uavs, mut load) = takeoff(n, 4.0);
        let mut ctl = team(n, &uavs, &load);
        let (mut min_dt, mut min_sep) = (f32::MAX, f32::MAX);
        let tray = params().tray;
        let mut s_load = Vec::with_capacity(steps);
        for k in 0..steps {
            for c in ctl.iter_mut() {
                c.set_team_hold(hold.contains(&k));
            }
            let nb = neighbours(&uavs);
            let vel: Vec<Vec3> = ctl
                .iter_mut()
                .zip(uavs.iter())
                .map(|(c, u)| {
                    let m = Measurements { own_pos_m: *u, load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
                    let cmd = c.update(&t, &m, DT_S);
                    assert!(cmd.status.neighbours_dropped == 0 && !cmd.status.invalid_input);
                    min_dt = min_dt.min(cmd.boundary_distance_m);
                    cmd.vel_mps
                })
                .collect();
            for (u, v) in uavs.iter_mut().zip(vel.iter()) {
                *u += v * DT_S;
            }
            let c: Vec2 = uavs.iter().map(|u| u.xy()).sum::<Vec2>() / n as f32;
            load = Vec3::new(c.x, c.y, LOAD_Z_M);
            for i in 0..n {
                for j in i + 1..n {
                    let qi = tray.project(&uavs[i], &load).0;
                    let qj = tray.project(&uavs[j], &load).0;
                    min_sep = min_sep.min((qi - qj).norm());
                }
            }
            s_load.push(t.locate(load.xy(), 0).unwrap().s_m);
        }
        let s_end = t.locate(load.xy(), 0).unwrap().s_m;
        ((min_dt, min_sep, s_end), s_load)
    }

    #[test]
    fn team_hold_removes_exactly_the_passing_term() {
        // Same controller twice, one in team hold: the commands differ by the passing term
        // eq:2-13 of the own node mapped by eq:2-20 (load at rest: factor (z_i - z_l)/H).
        let (mut uavs, load) = takeoff(4, 8.0);
        let mut go = team(4, &uavs, &load).swap_remove(0);
        uavs[0].y += 0.7; // off its rest position: the springs act on UAV 0
        let nb = neighbours(&uavs);
        let t = tube();
        let mut hold = go.clone();
        hold.set_team_hold(true);
        assert!(hold.team_hold() && !go.team_hold());
        let m = Measurements { own_pos_m: uavs[0], load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
        let (a, b) = (go.update(&t, &m, DT_S), hold.update(&t, &m, DT_S));
        let sec = t.locate(a.node_m, 0).unwrap();
        let ratio = (uavs[0].z - load.z) / params().tray.height_above_load_m;
        let pass = crate::passing::passing_velocity(&sec, &a.node_m, params().k1, params().v_max_mps) * ratio;
        assert!(pass.norm() > 0.5, "the transport command advances ({pass:?})");
        assert!(a.vel_mps.xy().norm() < params().v_max_mps, "not saturated: the difference is exact");
        assert_relative_eq!(a.vel_mps.xy() - b.vel_mps.xy(), pass, epsilon = 1e-5);
        assert_eq!(a.vel_mps.z, b.vel_mps.z, "altitude law unchanged");
        assert!(b.vel_mps.xy().norm() > 1e-3, "springs and tube keeping still act in team hold");
        // The tray-centre replica stands still in team hold (and advances in transport).
        let c0 = hold.tray_center_m();
        hold.update(&t, &m, DT_S);
        assert_eq!(hold.tray_center_m(), c0);
        assert!(go.tray_center_m().x > c0.x);
    }

    #[test]
    fn in_team_hold_a_missing_neighbour_anchors_the_uav_where_it_was() {
        // UAV 0 of four in team hold loses UAV 2: from then on it holds its horizontal
        // position where it was (gain HOLD_POSITION_GAIN_PER_S), the tube keeping on, the
        // springs and the load's velocity off; with every neighbour present no anchor acts.
        let (uavs, load) = takeoff(4, 8.0);
        let t = tube();
        let mut c = team(4, &uavs, &load).swap_remove(0);
        c.set_team_hold(true);
        let all = neighbours(&uavs);
        let m = |own: Vec3, nb, vl: Vec3| Measurements { own_pos_m: own, load_pos_m: load, load_vel_mps: vl, neighbours_m: nb, own_cable_force_n: None };
        let at_rest = c.update(&t, &m(uavs[0], &all, Vec3::zeros()), DT_S).vel_mps;
        assert!(at_rest.xy().norm() < 1e-4, "formation at rest, all neighbours: {at_rest:?}");
        let partial = [Some(uavs[0]), Some(uavs[1]), None, Some(uavs[3])];
        c.update(&t, &m(uavs[0], &partial, Vec3::zeros()), DT_S); // anchored here
        let moved = uavs[0] + Vec3::new(0.3, 0.0, 0.0);
        let swing = Vec3::new(0.0, 0.5, 0.0); // the load swinging does not move the anchored UAV
        let with_anchor = c.update(&t, &m(moved, &partial, swing), DT_S).vel_mps;
        // The same controller anchored at `moved`: only the tube keeping (the UAV is where it holds).
        let mut there = team(4, &uavs, &load).swap_remove(0);
        there.set_team_hold(true);
        let keeping = there.update(&t, &m(moved, &partial, swing), DT_S).vel_mps;
        assert!(keeping.xy().norm() < 0.05, "mid-tube the keeping term is small: {keeping:?}");
        assert_relative_eq!(with_anchor.xy() - keeping.xy(), Vec2::new(-0.3, 0.0) * HOLD_POSITION_GAIN_PER_S, epsilon = 1e-5);
        assert_eq!(keeping, there.update(&t, &m(moved, &partial, Vec3::zeros()), DT_S).vel_mps);
        // The hold ends: the anchor is forgotten; with every neighbour back, no anchor is set.
        c.set_team_hold(false);
        c.set_team_hold(true);
        let fresh = c.update(&t, &m(moved, &all, Vec3::zeros()), DT_S).vel_mps;
        let mut free = team(4, &uavs, &load).swap_remove(0);
        free.set_team_hold(true);
        assert_eq!(fresh, free.update(&t, &m(moved, &all, Vec3::zeros()), DT_S).vel_mps);
        assert!(fresh.xy().norm() > 0.05, "the springs pull UAV 0 back into the formation: {fresh:?}");
    }

    #[test]
    fn team_hold_stops_the_virtual_system_in_its_formation_and_it_resumes() {
        // Transport for 600 steps (12 s), team hold for 500, transport to the end.
        let ((min_dt, min_sep, s_end), s) = fly_with_hold(6, 3000, 600..1100);
        let held = s[1099] - s[700];
        assert!(held.abs() < 0.05, "load moved {held} m during the last 8 s of the hold");
        assert!(s[600] - s[500] > 0.5, "the team was advancing before the hold");
        assert!(min_dt > params().r_safe_m, "node came within {min_dt} m of the boundary");
        assert!(min_sep > 0.5, "nodes came within {min_sep} m");
        assert!(s_end > tube().length_m() - 3.0, "after the hold the load only reached s = {s_end}");
    }

    #[test]
    fn virtual_system_passes_the_narrow_tube_without_touching_the_boundary() {
        let (min_dt, min_sep, s_end) = fly(6, 3000);
        assert!(min_dt > params().r_safe_m, "node came within {min_dt} m of the boundary");
        assert!(min_sep > 0.5, "nodes came within {min_sep} m");
        assert!(s_end > tube().length_m() - 3.0, "load only reached s = {s_end}");
    }

    /// Overload (issue 15): with the load far below its reference a UAV flies higher than `H`
    /// above it and lies beyond its node; the tube term then acts at the UAV's own position.
    #[test]
    fn uav_above_the_tray_is_kept_by_its_own_position() {
        let t = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 3.0, 3.0), Waypoint::new(40.0, 0.0, 3.0, 3.0)]).unwrap();
        let (uavs, load) = takeoff(4, 10.0);
        let mut ctl = team(4, &uavs, &load);
        let low_load = Vec3::new(10.0, 0.0, LOAD_Z_M - 6.0);
        let own = Vec3::new(10.0, 2.8, low_load.z + 15.0); // 0.2 m from the boundary, node at y = 1.87
        let mut nb = neighbours(&uavs);
        nb[0] = Some(own);
        let m = Measurements { own_pos_m: own, load_pos_m: low_load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
        let c = ctl[0].update(&t, &m, DT_S);
        assert_relative_eq!(c.boundary_distance_m, 0.2, epsilon = 1e-3);
        assert!(c.vel_mps.y < -0.5, "UAV 0.2 m from the boundary must be pushed inwards: {:?}", c.vel_mps);
        // Below the tray plane the node's distance is the one kept (the paper's law).
        let own = Vec3::new(10.0, 2.0, load.z + 8.0);
        nb[0] = Some(own);
        let m = Measurements { own_pos_m: own, load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
        assert_relative_eq!(ctl[0].update(&t, &m, DT_S).boundary_distance_m, 3.0 - 2.5, epsilon = 1e-3);
    }

    /// The capacity-aware formation scales every rest length: in the kinematic loop the nodes
    /// settle on the take-off shape scaled by the plan's `lambda`; without a declared load the
    /// controller is bit for bit the paper's.
    #[test]
    fn formation_settles_at_the_capacity_scale() {
        use crate::capacity::{CapacityParams, CapacityPlan, FormationScale};
        let t = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 8.0, 8.0), Waypoint::new(2000.0, 0.0, 8.0, 8.0)]).unwrap();
        let (mut uavs, load) = takeoff(6, 10.0);
        let cap = CapacityParams { load_mass_kg: 10.0, ..CapacityParams::default() };
        let plan = CapacityPlan { scale_min: 0.4, scale: 0.5, lean_cos_min: 1.0, capacity_n: 0.0, weight_n: 0.0 };
        let mut ctl: Vec<_> = team(6, &uavs, &load).into_iter().map(|c| c.with_capacity(FormationScale::new(&plan, &cap))).collect();
        let mut plain = team(6, &uavs, &load);
        let mut off: Vec<_> = team(6, &uavs, &load)
            .into_iter()
            .map(|c| c.with_capacity(FormationScale::new(&plan, &CapacityParams::default())))
            .collect();
        let tray = params().tray;
        let r0 = (tray.project(&uavs[0], &load).0 - tray.project(&uavs[3], &load).0).norm();
        let mut load = load;
        for _ in 0..2000 {
            let nb = neighbours(&uavs);
            let mut vel = Vec::new();
            for i in 0..6 {
                let m = Measurements { own_pos_m: uavs[i], load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, own_cable_force_n: None };
                let a = plain[i].update(&t, &m, DT_S);
                assert_eq!(a, off[i].update(&t, &m, DT_S), "the law without a declared load must be the paper's");
                vel.push(ctl[i].update(&t, &m, DT_S).vel_mps);
            }
            for (u, v) in uavs.iter_mut().zip(&vel) {
                *u += v * DT_S;
            }
            let c: Vec2 = uavs.iter().map(|u| u.xy()).sum::<Vec2>() / 6.0;
            load = Vec3::new(c.x, c.y, LOAD_Z_M);
        }
        assert_relative_eq!(ctl[0].formation_scale(), 0.5, epsilon = 1e-6);
        let r = (tray.project(&uavs[0], &load).0 - tray.project(&uavs[3], &load).0).norm();
        assert_relative_eq!(r / r0, 0.5, epsilon = 0.02);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn command_is_always_finite_and_limited(
            dx in -1e4f32..1e4, dy in -1e4f32..1e4, dz in -1e3f32..1e3,
            lx in -100f32..100.0, ly in -100f32..100.0, lz in -100f32..100.0,
            vl in -1e3f32..1e3, k in 0usize..4, poison in 0usize..6,
        ) {
            let (mut uavs, load0) = takeoff(4, 5.0);
            let mut ctl = team(4, &uavs, &load0);
            let special = [f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30, -1e30, 0.0];
            uavs[k] += Vec3::new(dx, dy, dz);
            if poison < 3 { uavs[(k + 1) % 4].x = special[poison]; }
            let load = Vec3::new(lx, ly, lz);
            let nb = neighbours(&uavs);
            let m = Measurements { own_pos_m: uavs[0], load_pos_m: load, load_vel_mps: Vec3::new(vl, -vl, 0.0), neighbours_m: &nb, own_cable_force_n: None };
            let c = ctl[0].update(&tube(), &m, DT_S);
            prop_assert!(c.vel_mps.iter().all(|x| x.is_finite()));
            prop_assert!(c.vel_mps.xy().norm() <= params().v_max_mps);
            prop_assert!(c.vel_mps.z.abs() <= params().vertical.vz_max_mps);
        }
    }
}
