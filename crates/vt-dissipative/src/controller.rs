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
use crate::passing::{formation_faded, passing_velocity};
use crate::separation::{separation_barrier, separation_velocity, SEPARATION_AUTHORITY};
use crate::shape::{min_quantum, narrowest_half_width_m, next_quantum, quantum, ramped_half_width_m, ShapeParams, QUANTA, RAMP_BEHIND_M, RAMP_LEAD_M};
use crate::keeping::{keeping_velocity, team_keeping_velocity, team_mean_keeping, TEAM_KEEPING_EVERY};
use crate::springs::{dashpot_velocity, spring_velocity, team_spring_gain, Formation, NodeId};
use crate::vertical::{VerticalLoop, VerticalParams};
use crate::{ControlError, Status, Vec2, Vec3};
use vt_tube::{sat, BarrierParams, Tube};

mod params;
mod tube_shape;
pub use params::DissipativeParams;
pub(crate) use params::validate_gains;
pub use tube_shape::DRIFT_AVERAGE_S;
use tube_shape::TubeShape;

/// Rate at which the widening of a tube being joined shrinks besides following the node,
/// m/s ([`DissipativeController::join_tube`]): a tenth of the paper's `v_m` (3 m/s), so the
/// barrier moves slower than any node can.
pub const JOIN_SHRINK_MPS: f32 = 0.3;

/// Gain of the anchored team hold's position hold, 1/s: PX4's horizontal position gain
/// (`MPC_XY_P`, default 0.95 1/s), rounded; docs/design.md, "Team failsafe".
pub const HOLD_POSITION_GAIN_PER_S: f32 = 1.0;

/// What one UAV knows at a high-level step (Remark 2). World ENU, m and m/s.
#[derive(Debug, Clone, Copy)]
pub struct Measurements<'a> {
    /// Own position, m.
    pub own_pos_m: Vec3,
    /// Own velocity, m/s (the dashpots beside the springs, [`DissipativeParams::dashpot`]).
    pub own_vel_mps: Vec3,
    /// Load position, m.
    pub load_pos_m: Vec3,
    /// Load velocity, m/s.
    pub load_vel_mps: Vec3,
    /// Neighbours' positions by UAV id (own slot ignored); `None` = missing or stale.
    pub neighbours_m: &'a [Option<Vec3>],
    /// Neighbours' horizontal velocities by UAV id, m/s, read where `neighbours_m` holds a
    /// position (may be empty: no dashpot, [`DissipativeParams::dashpot`]).
    pub neighbours_vel_mps: &'a [Vec2],
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
    /// The separation barrier (`None`: off).
    separation: Option<BarrierParams>,
    /// Rest lengths now: the take-off ones (eq:2-7) times the formation scale `rest_scale`
    /// (recomputed from `rest_scale` relative to the last scale when it changes).
    rest: RestLengths<N>,
    /// The formation scale `rest` was computed for.
    rest_scale: f32,
    /// The load altitude reference at the last update, m: a rising one is a ground start's
    /// lift or climb ramp, whose tracking lag is not an overload.
    last_ref_m: f32,
    center_m: Vec2,
    own_hint: usize,
    center_hint: usize,
    vertical: VerticalLoop,
    /// Team hold (docs/design.md, "Team failsafe"): the passing term is off.
    team_hold: bool,
    /// Team hold just began: the next update re-seats the tray-centre replica.
    reseat: bool,
    /// Where the UAV holds its horizontal position in team hold once a neighbour is missing
    /// (the anchor), world ENU, m.
    anchor_m: Option<Vec2>,
    /// This team hold is anchored from its next step, every neighbour fresh or not (a hold for
    /// an obstacle, [`DissipativeController::anchor_team_hold`]); cleared when the hold ends.
    anchor_wanted: bool,
    /// How much wider than the tube this UAV's barriers see it while it joins a re-planned
    /// tube it was not yet inside, m (0: not joining; [`DissipativeController::join_tube`]).
    join_m: f32,
    /// Capacity-aware formation scale (`FormationScale::NEUTRAL` unless configured).
    scale: FormationScale,
    /// The formation shaped to the tube ahead (`None`: the paper's rest lengths; shape.rs).
    shape: Option<TubeShape<N>>,
    /// Team keeping (extension, keeping.rs): the tube keeping term is the team's mean plus half
    /// the own node's; the mean held and the steps since it was computed.
    team_keeping: bool,
    team_mean: Vec2,
    team_age: u8,
    /// The load's altitude is being changed (lift, climb, descent): the springs fly
    /// `heave_spring_share` of `k2`.
    heaving: bool,
}

/// How far above the separation floor a formation squeezed narrower than its narrowest stadium
/// must keep its pairs, m ([`DissipativeController::shaped_need_half_width_m`]): what flights
/// close below the static geometry (0.13 m for the paper team at the narrowest stadium, 0.15 m
/// at the next, up to about 0.25 m behind PX4's stock gains; docs/design.md, "The width the
/// shaped formation needs").
pub const SQUEEZE_GUARD_M: f32 = 0.25;

/// What the tube-shaped formation needs to keep the capacity-aware formation's separation
/// floor (shape.rs, [`crate::shape::separated_half_length_m`]).
#[derive(Debug, Clone, Copy)]
pub struct ShapeSeparation<'a> {
    /// Every UAV's position at take-off, its cable taut, m.
    pub takeoff_m: &'a [Vec3],
    /// The load's position at take-off, m.
    pub load_m: Vec3,
    /// Distance every pair of UAVs keeps where they fly, m (`CapacityParams::separation_m`).
    pub separation_m: f32,
    /// Least `sum_i cos theta_i` a lengthened stadium keeps (0: no declared load); the
    /// companion passes the load's own `W / f` (`CapacityParams::weight_cos_sum`: a passage may
    /// spend the capacity margin, never the load; docs/design.md, "Heavy loads keep their pairs
    /// apart").
    pub min_cos_sum: f32,
}


impl<const N: usize> DissipativeController<N> {
    /// Controller of UAV `id` with rest lengths from the take-off `formation` (eq:2-7); a team
    /// of more than ten flies the spring gain [`team_spring_gain`] (`k2 * 10 / n`).
    ///
    /// # Errors
    /// Invalid parameters, or `id` not below the formation's team size.
    pub fn new(id: usize, params: DissipativeParams, formation: &Formation<N>) -> Result<Self, ControlError> {
        params.validate()?;
        let n = formation.n_uavs();
        if id >= n {
            return Err(ControlError::IdOutOfRange { id, n_uavs: n });
        }
        // The spring gain scaled to the team (springs.rs): `params.k2` beyond ten UAVs.
        let params = DissipativeParams { k2: team_spring_gain(params.k2, n), ..params };
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
            separation: separation_barrier(params.k3, &params.separation),
            rest,
            rest_scale: 1.0,
            last_ref_m: f32::INFINITY,
            center_m: formation.node_m(NodeId::Center),
            own_hint: 0,
            center_hint: 0,
            vertical: VerticalLoop::new(params.vertical),
            team_hold: false,
            reseat: false,
            anchor_m: None,
            anchor_wanted: false,
            join_m: 0.0,
            scale: FormationScale::NEUTRAL,
            heaving: false,
            shape: None,
            team_keeping: false,
            team_mean: Vec2::zeros(),
            team_age: 0,
        })
    }

    /// Switches the team hold on or off for the following steps (`docs/design.md`, "Team
    /// failsafe"): the passing term eq:2-13 of the own node is off and the tray-centre replica
    /// moves to the nodes' centroid at the hold's first step and then stands still (zero tray
    /// velocity), so nothing drives the team along the tube and the centre springs anchor it
    /// where it is; the springs eq:2-5, the tube keeping eq:2-14 and the altitude
    /// law act as in transport. With the passing potential gone and the centre fixed, the
    /// spring and barrier energy alone is a Lyapunov function of the node dynamics: the team
    /// comes to rest in its formation around the held centre, inside the tube. Once a
    /// neighbour is missing during the hold, the UAV instead holds its own horizontal position
    /// where it was then (gain [`HOLD_POSITION_GAIN_PER_S`]) plus the tube keeping.
    pub fn set_team_hold(&mut self, hold: bool) {
        if hold && !self.team_hold {
            self.reseat = true;
        }
        self.team_hold = hold;
        if !hold {
            self.anchor_m = None;
            self.anchor_wanted = false;
        }
    }

    /// The load's altitude is being changed (a ground start's lift, climb and descent,
    /// [`crate::phases::Phase::heaving`]): the springs fly `heave_spring_share` of `k2`.
    pub fn set_heaving(&mut self, heaving: bool) {
        self.heaving = heaving;
    }

    /// Anchors the team hold in force (nothing outside one): from the next step the UAV holds
    /// its own horizontal position where it is then, plus the tube keeping, as when a
    /// neighbour goes missing, until the hold ends. For a hold in front of an obstacle (issue
    /// 28's no-route hold; extension, docs/design.md, "The no-route hold holds in place"): a
    /// tube planned on a map seen in part may hold what the team has seen since, and the
    /// springs restoring the formation, which a narrow passage had squeezed, could carry a UAV
    /// into it.
    pub fn anchor_team_hold(&mut self) {
        if self.team_hold {
            self.anchor_wanted = true;
        }
    }

    /// Joins a tube this UAV's node may not lie inside yet (a tube re-planned in flight,
    /// issue 28; extension to the paper, docs/design.md, "Joining a re-planned tube"). Both
    /// barriers (own node and tray-centre replica) see the tube widened on both sides by
    /// `join_m`: at the first step `(r_safe + r_active) / 2 - d`, `d` the node's boundary
    /// distance, so the node sits mid-band in the widened tube (the barrier is finite and no
    /// higher than mid-band); then `join_m <- max(0, min(join_m - JOIN_SHRINK_MPS dt,
    /// (r_safe + r_active) / 2 - d))`: it follows the node inwards, shrinks at a bounded rate
    /// besides (a node resting inside the band is brought out of the widening), and ends. So
    /// the UAV flies the team's new tube, passing and formation included, where declining it
    /// left it on its old tube.
    pub fn join_tube(&mut self) {
        self.join_m = f32::INFINITY;
        self.team_age = 0;
    }

    /// The widening still in force while joining a tube, m (0: none).
    pub fn join_widening_m(&self) -> f32 {
        self.join_m
    }

    /// True while the team hold is on.
    pub fn team_hold(&self) -> bool {
        self.team_hold
    }

    /// The load altitude reference of the altitude law, m, and its load sharing on or off (the
    /// ground sequence's ramp, [`crate::phases`]; a non-finite `z_m` is ignored).
    pub fn set_load_altitude_ref(&mut self, z_m: f32, sharing: crate::vertical::Sharing) {
        if z_m.is_finite() {
            self.params.vertical.load_altitude_ref_m = z_m;
        }
        self.vertical.set_load_altitude_ref(z_m, sharing);
    }

    /// Turns on the capacity-aware formation law (docs/design.md, "Capacity-aware formation"):
    /// rest lengths scaled by `scale`'s `lambda`, the passing term by its progress factor.
    /// Without it the controller is the paper's, bit for bit.
    pub fn set_capacity(&mut self, scale: FormationScale) {
        self.scale = scale;
    }

    /// Turns the team keeping on or off (extension; [`team_keeping_velocity`], docs/design.md
    /// "The tube keeps the team, not one node"). Off, the keeping term is the paper's, bit for bit.
    pub fn set_team_keeping(&mut self, on: bool) {
        self.team_keeping = on;
        self.team_age = 0;
    }

    /// Turns on the formation shaped to the tube ahead (extension; shape.rs, docs/design.md "A
    /// formation shaped to the tube") for the take-off `formation` this controller was built
    /// from. Until [`Self::shape_to_tube`] narrows it, the formation is the ring. With
    /// `separation` (bodies declared), the stadium lengthens to keep its floor where the UAVs
    /// fly ([`crate::shape::separated_half_length_m`]); `None`: as long as the ring.
    ///
    /// # Errors
    /// Invalid `params`; a `separation` with fewer take-off positions than UAVs, a floor that is
    /// not finite and positive, a negative need, or a cable length not in `[1 mm, 65.5 m]`.
    pub fn set_shape(&mut self, params: ShapeParams, formation: &Formation<N>, separation: Option<ShapeSeparation<'_>>) -> Result<(), ControlError> {
        params.validate()?;
        let mut lengths_mm = [0u16; N];
        let (mut separation_m, mut min_cos_sum) = (0.0, 0.0);
        if let Some(sep) = separation {
            let ok = sep.takeoff_m.len() >= self.n && sep.separation_m.is_finite() && sep.separation_m > 0.0 && sep.min_cos_sum.is_finite() && sep.min_cos_sum >= 0.0;
            if !ok {
                return Err(ControlError::InvalidParameter("shape.separation"));
            }
            for (d, p) in lengths_mm.iter_mut().zip(sep.takeoff_m.iter()).take(self.n) {
                let mm = vt_fpu::norm(&(p - sep.load_m)) * 1e3;
                if !(mm.is_finite() && mm >= 1.0 && mm <= f32::from(u16::MAX)) {
                    return Err(ControlError::InvalidParameter("shape.separation"));
                }
                *d = libm::roundf(mm) as u16;
            }
            (separation_m, min_cos_sum) = (sep.separation_m, sep.min_cos_sum);
        }
        let centre_m = formation.node_m(NodeId::Center);
        let mut nodes_m = [Vec2::zeros(); N];
        let mut radius_m: f32 = 0.0;
        for (j, p) in nodes_m.iter_mut().enumerate().take(self.n) {
            *p = formation.node_m(NodeId::Uav(j));
            radius_m = vt_fpu::max(radius_m, vt_fpu::norm(&(*p - centre_m)));
        }
        let load_node_m = formation.node_m(NodeId::Load);
        self.shape = Some(TubeShape { params, nodes_m, load_node_m, centre_m, radius_m, lengths_mm, separation_m, min_cos_sum, half_length_m: radius_m, frame: None, drift: Vec2::new(1.0, 0.0), quantum: QUANTA, speed_quantum: QUANTA });
        Ok(())
    }

    /// The tube-shaped formation's look at the tube (every few steps; `load_sec` the load's
    /// section): the stadium whose half-width fits the narrowest section from one ring radius
    /// behind the load to one radius plus `ahead_m` ahead of it (with a separation floor, the
    /// sections beyond the formation's reach weighed by their distance, [`ramped_half_width_m`]),
    /// less the barrier's safety radius and `margin_m`, in [`QUANTA`] steps (narrower at once,
    /// wider with hysteresis);
    /// the rest lengths change only when the step does. Nothing without [`Self::set_shape`].
    #[cold]
    #[inline(never)]
    pub fn shape_to_tube<const S: usize>(&mut self, tube: &Tube<S>, load_sec: &vt_tube::Section) {
        let Some(shape) = self.shape.as_mut() else {
            return;
        };
        // The frame is fixed at the first look (the ring's drift is measured only before it).
        let frame = match shape.frame {
            Some(f) => f,
            None => {
                let f = shape.turned_frame(&load_sec.tangent);
                shape.frame = Some(f);
                f
            }
        };
        let ring_m = shape.radius_m * self.rest_scale;
        // With a separation floor the narrow sections are weighed by where they lie (the shape
        // narrows as a passage comes); without one the narrowest section of the window decides.
        let Some(narrowest) = narrowest_half_width_m(tube, load_sec.s_m, ring_m, ring_m + shape.params.ahead_m) else {
            return;
        };
        let ask = |w: f32| quantum(w - self.params.r_safe_m - shape.params.margin_m, ring_m, min_quantum(self.n));
        // The passage speed follows the window's narrowest section (a passage entering the
        // look-ahead slows the team at once, as before the ramp).
        shape.speed_quantum = next_quantum(shape.speed_quantum, ask(narrowest));
        let w = if shape.separation_m > 0.0 {
            // The formation reaches the longer of the ring's radius and the stadium's half-length
            // flown ahead of and behind its centre.
            let reach_m = vt_fpu::max(ring_m, shape.half_length_m * self.rest_scale);
            let Some(w) = ramped_half_width_m(tube, load_sec.s_m, ring_m, reach_m, shape.params.ahead_m, RAMP_LEAD_M, RAMP_BEHIND_M) else {
                return;
            };
            w
        } else {
            narrowest
        };
        let q = next_quantum(shape.quantum, ask(w));
        if q == shape.quantum {
            return;
        }
        shape.quantum = q;
        shape.half_length_m = shape.half_length_for(q, frame, self.n, self.params.tray.height_above_load_m, &self.scale);
        shape.write_rest_lengths(self.id, q, frame, self.n, self.rest_scale, &mut self.rest);
    }

    /// The narrowest tube half-width in which the formation shaped to the tube keeps its
    /// separation floor by construction, m: `r_safe + margin + r q / QUANTA` for the narrowest
    /// width `q` (quanta) from which every wider stadium's pairs keep the floor where they fly,
    /// or, below the narrowest stadium, the squeezed one's with a guard
    /// (`TubeShape::floor_width_quanta`). A planner that gives the team less asks the formation for a shape
    /// it cannot fly apart (docs/design.md, "The width the shaped formation needs"). `None`
    /// without a shape or a floor (bodies not declared). The stadium's frame is the first look's,
    /// or before it `tangent` (the tube's direction at the load). Out of line and cold: a few
    /// hundred pair distances per quantum, called once per re-plan.
    #[cold]
    #[inline(never)]
    pub fn shaped_need_half_width_m(&self, tangent: &Vec2) -> Option<f32> {
        let shape = self.shape.as_ref()?;
        if !(shape.separation_m > 0.0) {
            return None;
        }
        let frame = shape.frame.unwrap_or_else(|| shape.turned_frame(tangent));
        if !(frame.iter().all(|x| x.is_finite()) && vt_fpu::norm(&frame) > 0.0) {
            return None;
        }
        let width_q = shape.floor_width_quanta(min_quantum(self.n), frame, self.n, self.params.tray.height_above_load_m, &self.scale);
        let ring_m = shape.radius_m * self.rest_scale;
        Some(self.params.r_safe_m + shape.params.margin_m + ring_m * width_q / QUANTA as f32)
    }

    /// The tube-shaped formation's half-width now, fraction of the ring's radius (1: the ring,
    /// or the shape off).
    pub fn shape_fraction(&self) -> f32 {
        self.shape.as_ref().map_or(1.0, |s| s.quantum as f32 / QUANTA as f32)
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

    /// The parameters in use (`k2` as flown: [`team_spring_gain`] of the given one).
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
        // The passage speed (extension, shape.rs): slower while the separated stadium is
        // narrower than the ring (1 otherwise: the same bits).
        let v_max = self.params.v_max_mps * self.shape.as_ref().map_or(1.0, TubeShape::speed_fraction);
        let p = &self.params;
        let inputs_ok = vt_fpu::zero_if_finite(&m.own_pos_m) + vt_fpu::zero_if_finite(&m.load_pos_m) + vt_fpu::zero_if_finite(&m.load_vel_mps) == 0.0;
        if !inputs_ok {
            status.invalid_input = true;
            return self.hold(m, status);
        }
        let load_xy = m.load_pos_m.xy();
        let (q_i, floored) = p.tray.project(&m.own_pos_m, &m.load_pos_m);
        status.projection_floored = floored;
        // Capacity-aware formation: rest lengths x lambda, passing x progress (capacity.rs).
        // While the reference climbs (a ground start's lift and climb ramps) the load trails it
        // by the altitude law's lag, which is no overload: the sag is not counted then (the
        // lift's own overload watch and the transport's sag cover a load the team cannot lift).
        let z_ref = p.vertical.load_altitude_ref_m;
        let sag_ref = if z_ref > self.last_ref_m { vt_fpu::min(z_ref, m.load_pos_m.z) } else { z_ref };
        self.last_ref_m = z_ref;
        let so = self.scale.update(m.load_pos_m.z, sag_ref, dt_s);
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
                Some(pj) if vt_fpu::all_finite(&pj) => *slot = Some(p.tray.project(&pj, &m.load_pos_m).0),
                _ => status.neighbours_dropped = status.neighbours_dropped.saturating_add(1),
            }
        }

        if self.team_hold {
            if let Some(shape) = self.shape.as_mut() {
                shape.track_drift(&nodes, &load_xy, self.n, dt_s);
            }
        }
        // Own node: passing + springs + tube keeping (eq:2-16).
        let Some(sec) = tube.locate(q_i, self.own_hint) else {
            status.invalid_input = true;
            return self.hold(m, status);
        };
        self.own_hint = sec.segment;
        if self.join_m > 0.0 {
            // Joining a re-planned tube: the widening follows the node in and shrinks by
            // JOIN_SHRINK_MPS besides (join_tube).
            let mid_band = 0.5 * (p.r_safe_m + p.r_active_m);
            let shrunk = if vt_fpu::positive_finite(dt_s) { self.join_m - JOIN_SHRINK_MPS * dt_s } else { self.join_m };
            self.join_m = vt_fpu::max(vt_fpu::min(shrunk, mid_band - sec.boundary_distance_m(q_i)), 0.0);
        }
        // Team hold (docs/design.md, "Team failsafe"): no passing term. Once a neighbour is
        // missing during the hold, the UAV holds its own horizontal position where it was then
        // (the anchor; see below): the missing springs no longer fix its place in the formation.
        let mut vbar = Vec2::zeros();
        // The tray-centre replica's section: its own step below, and the passing term's fade.
        let center_sec = if self.team_hold { None } else { tube.locate(self.center_m, self.center_hint) };
        if !self.team_hold {
            vbar = passing_velocity(&formation_faded(&sec, center_sec.as_ref()), &q_i, p.k1, v_max) * so.progress;
        } else {
            // Entering team hold: the tray-centre replica moves to the nodes' centroid, so the
            // team rests around where it is, not around where the replica had led it
            // (extension; docs/design.md, "Safety finding and fix: the held centre").
            if self.reseat {
                self.reseat = false;
                if let Some(c) = centroid(&nodes, self.n) {
                    self.center_m = c;
                }
            }
            if (status.neighbours_dropped > 0 || self.anchor_wanted) && self.anchor_m.is_none() {
                self.anchor_m = Some(m.own_pos_m.xy());
            }
        }
        // The springs' gain: softer while the load heaves (springs.rs, heave_spring_share).
        let k2 = if self.heaving { p.k2 * p.heave_spring_share } else { p.k2 };
        for (j, (q_j, rest)) in nodes.iter().zip(self.rest.own_m.iter()).enumerate().take(self.n) {
            if let (Some(q_j), true) = (q_j, j != self.id) {
                let (v, c) = spring_velocity(&q_i, q_j, *rest, k2, self.id < j);
                vbar += v;
                status.coincident_nodes |= c;
            }
        }
        let (v_l, c_l) = spring_velocity(&q_i, &load_xy, self.rest.own_load_m, k2, true);
        let (v_u, c_u) = spring_velocity(&q_i, &self.center_m, self.rest.own_center_m, k2, true);
        status.coincident_nodes |= c_l | c_u;
        let (v_t, d_t) = self.keeping(tube, &sec, &q_i, m);
        let v_t = if self.team_keeping {
            let join_m = self.join_m;
            if self.team_age == 0 {
                self.team_mean = team_mean_keeping(tube, &nodes, self.n, self.id, v_t, &sec, self.params.v_max_mps, &self.barrier, |s| joined(s, join_m));
            }
            self.team_age = (self.team_age + 1) % TEAM_KEEPING_EVERY;
            team_keeping_velocity(self.team_mean, v_t)
        } else {
            v_t
        };
        status.outside_tube = d_t <= 0.0;
        vbar += v_l + v_u + v_t;

        // Tray-centre replica: same law over its springs to the UAV nodes, explicit Euler; in
        // team hold it stands still (zero tray velocity: the anchor of the held formation).
        if vt_fpu::positive_finite(dt_s) && !self.team_hold {
            self.step_center(center_sec, &nodes, so.progress, v_max, dt_s, &mut status);
        }

        // Map back to the UAV (eq:2-20) and saturate (eq:2-21).
        let v_xy = match self.anchor_m {
            // Anchored team hold: position hold at the anchor plus the tube keeping, without
            // the springs and the load's velocity (a neighbour the UAV cannot see is safe only
            // if every UAV stays where it was when the link went quiet; docs/design.md).
            Some(anchor) => {
                (anchor - m.own_pos_m.xy()) * HOLD_POSITION_GAIN_PER_S
                    + self.params.tray.node_velocity_to_uav(&v_t, m.own_pos_m.z, &m.load_pos_m, &Vec3::zeros())
            }
            None => {
                let v = self.params.tray.node_velocity_to_uav(&vbar, m.own_pos_m.z, &m.load_pos_m, &m.load_vel_mps);
                // The dashpots beside the springs (extension, springs.rs): a team near its
                // capacity, outside the load's heave (whose springs fly softer already).
                if self.params.dashpot > 0.0 && !self.heaving {
                    v + dashpot_velocity(self.id, &m.own_pos_m, &m.own_vel_mps, m.neighbours_m.get(..self.n).unwrap_or(m.neighbours_m), m.neighbours_vel_mps, self.params.dashpot)
                } else {
                    v
                }
            }
        };
        let mut v_xy = sat(v_xy, v_max);
        // Separation barrier on the UAVs' own positions (extension, separation.rs), added to the
        // saturated command with up to twice its authority, then saturated again: at its cap
        // it always turns the command away from the neighbour.
        if let Some(b) = &self.separation {
            let (v_sep, c) = separation_velocity(self.id, &m.own_pos_m, m.neighbours_m.get(..self.n).unwrap_or(m.neighbours_m), b, self.params.separation.three_d);
            status.coincident_nodes |= c;
            v_xy = sat(v_xy + sat(v_sep, SEPARATION_AUTHORITY * v_max), v_max);
        }
        let v_z = self.vertical.update(&m.own_pos_m, &m.load_pos_m, m.own_cable_force_n, dt_s);
        let vel = Vec3::new(v_xy.x, v_xy.y, v_z);
        if !vt_fpu::all_finite(&vel) {
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
    fn keeping<const S: usize>(&self, tube: &Tube<S>, sec: &vt_tube::Section, q_i: &Vec2, m: &Measurements<'_>) -> (Vec2, f32) {
        let h = self.params.tray.height_above_load_m;
        let dz = m.own_pos_m.z - m.load_pos_m.z;
        if dz > h {
            let p_i = m.own_pos_m.xy();
            if let Some(s_uav) = tube.locate(p_i, sec.segment) {
                let (v, d) = keeping_velocity(&self.joining(&s_uav), &p_i, &self.barrier);
                return (v * (h / dz), d);
            }
        }
        keeping_velocity(&self.joining(sec), q_i, &self.barrier)
    }

    /// `sec` as the barriers see it while joining a tube: both half-widths `join_m` wider.
    #[inline]
    fn joining(&self, sec: &vt_tube::Section) -> vt_tube::Section {
        joined(sec, self.join_m)
    }

    /// One explicit-Euler step of the tray-centre replica in its section `center_sec` (located
    /// at `self.center_m`; `None`: it stands still).
    fn step_center(&mut self, center_sec: Option<vt_tube::Section>, nodes: &[Option<Vec2>; N], progress: f32, v_max: f32, dt_s: f32, status: &mut Status) {
        let p = &self.params;
        let q_u = self.center_m;
        let Some(sec) = center_sec else {
            return;
        };
        self.center_hint = sec.segment;
        let mut v = passing_velocity(&sec, &q_u, p.k1, v_max) * progress;
        for (q_j, rest) in nodes.iter().zip(self.rest.center_m.iter()).take(self.n) {
            if let Some(q_j) = q_j {
                let (vs, c) = spring_velocity(&q_u, q_j, *rest, p.k2, false);
                v += vs;
                status.coincident_nodes |= c;
            }
        }
        v += keeping_velocity(&self.joining(&sec), &q_u, &self.barrier).0;
        let next = q_u + sat(v, v_max) * dt_s;
        if vt_fpu::all_finite(&next) {
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
    let v_z = if vt_fpu::all_finite(&m.load_pos_m) && vt_fpu::all_finite(&m.own_pos_m) {
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

/// `sec` with both half-widths `join_m` wider when `join_m > 0` (a tube being joined).
#[inline]
fn joined(sec: &vt_tube::Section, join_m: f32) -> vt_tube::Section {
    if join_m > 0.0 {
        vt_tube::Section { half_width_m: sec.half_width_m + join_m, ..*sec }
    } else {
        *sec
    }
}

/// The centroid of the first `n` nodes seen (`None`: dropped), m; `None` when none is seen. Out
/// of line: it runs once per team hold (the replica's re-seat), and the control step's MCU
/// budget is counted on the transport path.
#[cold]
#[inline(never)]
fn centroid<const N: usize>(nodes: &[Option<Vec2>; N], n: usize) -> Option<Vec2> {
    let (mut sum, mut k) = (Vec2::zeros(), 0.0f32);
    for q in nodes.iter().take(n).flatten() {
        sum += q;
        k += 1.0;
    }
    (k > 0.0).then(|| sum / k)
}

#[cfg(test)]
#[path = "controller_tests.rs"]
mod tests;
