//! Physical plant of the software-in-the-loop simulator (REFERENCE §1, eq:1-1 .. eq:1-4).
//!
//! Point-mass UAVs, a point-mass load, one elastic cable from each UAV to the load
//! ([`crate::cable`] semantics). World frame ENU (z up), metres, seconds, newtons, f64.
//!
//! - UAV i: `p_i' = v_i`, `m_i v_i' = T_i + m_i g_vec + F_cable,i + F_ext,i`,
//!   with `F_cable,i = -tau_i u_i` (REFERENCE writes it `-f_i`).
//! - Load: `m_l v_l' = m_l g_vec + sum_i tau_i u_i + F_ext,l`.
//! - `g_vec = (0, 0, -GRAVITY_MPS2)`.
//!
//! Integration: each call of [`Plant::step`] advances `dt` in `substeps` equal sub-steps of
//! semi-implicit (symplectic) Euler: `v += h a(p, v)`, then `p += h v` with the new `v`.

use core::fmt;

use nalgebra::Vector3;

use crate::cable::{cable_force, CableForce, CableParams};
use crate::disturbance::{drag_n, shear_factor};
use vt_companion::flight::Setpoint;

pub mod command;
mod rigid;
mod setup;

pub use setup::build;

/// Gravitational acceleration, m/s^2.
pub const GRAVITY_MPS2: f64 = 9.81;

/// Gravity vector in the world ENU frame, m/s^2.
#[must_use]
pub fn gravity_vec_mps2() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -GRAVITY_MPS2)
}

/// Mass and actuator limits of one UAV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UavParams {
    /// Mass `m_i`, kg (> 0).
    pub mass_kg: f64,
    /// Largest thrust magnitude, N (>= 0; `f64::INFINITY` = unlimited).
    pub thrust_max_n: f64,
    /// Time constant of the first-order thrust lag, s (>= 0; 0 = thrust follows the command
    /// instantly).
    pub thrust_lag_s: f64,
}

/// Mass of the load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadParams {
    /// Mass `m_l`, kg (> 0).
    pub mass_kg: f64,
}

/// State of one UAV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UavState {
    /// Position, world ENU, m.
    pub pos_m: Vector3<f64>,
    /// Velocity, world ENU, m/s.
    pub vel_mps: Vector3<f64>,
    /// Actual thrust vector (after the magnitude limit and the lag), world ENU, N.
    pub thrust_n: Vector3<f64>,
}

/// State of the load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadState {
    /// Position, world ENU, m.
    pub pos_m: Vector3<f64>,
    /// Velocity, world ENU, m/s.
    pub vel_mps: Vector3<f64>,
}

/// Why [`Plant::new`] rejected its input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlantError {
    /// The per-UAV lists differ in length.
    CountMismatch {
        /// Number of UAV parameter sets.
        uavs: usize,
        /// Number of cables.
        cables: usize,
        /// Number of initial UAV positions.
        positions: usize,
    },
    /// A UAV's mass is not a finite number > 0.
    UavMass {
        /// Index of the UAV.
        index: usize,
    },
    /// A UAV's thrust limit is NaN or negative.
    UavThrustMax {
        /// Index of the UAV.
        index: usize,
    },
    /// A UAV's thrust lag time constant is not a finite number >= 0.
    UavThrustLag {
        /// Index of the UAV.
        index: usize,
    },
    /// The load's mass is not a finite number > 0.
    LoadMass,
    /// A cable's rest length, stiffness or damping is not a finite number >= 0, or its `f_max`
    /// is NaN or negative.
    Cable {
        /// Index of the cable (= index of its UAV).
        index: usize,
    },
    /// An initial UAV position is not finite.
    UavPosition {
        /// Index of the UAV.
        index: usize,
    },
    /// The initial load position is not finite.
    LoadPosition,
    /// `substeps` is 0.
    ZeroSubsteps,
    /// A rigid-body UAV's parameters were rejected.
    Quadrotor {
        /// Index of the UAV.
        index: usize,
        /// The parameter and what it must satisfy.
        error: crate::quadrotor::QuadError,
    },
}

impl fmt::Display for PlantError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::CountMismatch {
                uavs,
                cables,
                positions,
            } => write!(
                f,
                "count mismatch: {uavs} UAV parameter sets, {cables} cables, {positions} UAV positions"
            ),
            Self::UavMass { index } => write!(f, "UAV {index}: mass must be finite and > 0 kg"),
            Self::UavThrustMax { index } => {
                write!(f, "UAV {index}: thrust limit must be >= 0 N (not NaN)")
            }
            Self::UavThrustLag { index } => {
                write!(f, "UAV {index}: thrust lag must be finite and >= 0 s")
            }
            Self::LoadMass => write!(f, "load: mass must be finite and > 0 kg"),
            Self::Cable { index } => write!(
                f,
                "cable {index}: rest length, stiffness and damping must be finite and >= 0, f_max >= 0"
            ),
            Self::UavPosition { index } => write!(f, "UAV {index}: initial position is not finite"),
            Self::LoadPosition => write!(f, "load: initial position is not finite"),
            Self::ZeroSubsteps => write!(f, "substeps must be >= 1"),
            Self::Quadrotor { index, error } => write!(f, "UAV {index}: {error}"),
        }
    }
}

impl std::error::Error for PlantError {}

/// UAVs, load and cables, integrated with semi-implicit Euler.
///
/// `uavs` and `load` are public so that a scenario can set initial velocities or thrusts; do
/// not change the length of `uavs` (the per-UAV lists are zipped, so extra or missing entries
/// are ignored rather than panicking).
#[derive(Debug, Clone)]
pub struct Plant {
    /// UAV states, one per UAV, in the order of the parameters given to [`Plant::new`].
    pub uavs: Vec<UavState>,
    /// Load state.
    pub load: LoadState,
    uav_params: Vec<UavParams>,
    load_params: LoadParams,
    cables: Vec<CableParams>,
    substeps: usize,
    /// Cable forces used in the last sub-step (at construction: at the initial state).
    last_forces: Vec<CableForce>,
    /// `last_forces[i].tension_n`, kept contiguous for [`Plant::tensions_n`].
    tensions_n: Vec<f64>,
    /// Scratch of [`Plant::step`], reused so that a step does not allocate: limited thrust
    /// command per UAV (`None` = hold the actual thrust).
    targets: Vec<Option<Vector3<f64>>>,
    /// Scratch of [`Plant::step`]: external force per UAV (zero when missing or non-finite), N.
    ext_uav: Vec<Vector3<f64>>,
    /// Thrust-lag factor per UAV for the sub-step `alpha_h_s` (cached: `exp_m1` is costly).
    alphas: Vec<f64>,
    /// Sub-step, s, for which `alphas` holds (NaN: not computed yet).
    alpha_h_s: f64,
    /// Breaking strength per cable, N (`f64::INFINITY`: never breaks).
    breaking_n: Vec<f64>,
    /// Cables that broke since the last [`Plant::take_breaks`]: (index, tension N, strength N).
    breaks: Vec<(usize, f64, f64)>,
    /// Scratch of [`Plant::step_setpoints`]: thrust command per point-mass UAV, N.
    thrust_buf: Vec<Vector3<f64>>,
    /// Scratch of [`Plant::step_setpoints`]: drag per UAV, N.
    ext_buf: Vec<Vector3<f64>>,
    /// The `rigid_body` UAVs, one per UAV (empty: point-mass UAVs); see [`rigid`].
    quads: Vec<crate::quadrotor::Quadrotor>,
    /// Each UAV's maximum thrust as built, N ([`Plant::set_thrust_scale`] scales it).
    thrust_built_n: Vec<f64>,
    /// Turbulent gust of each UAV, then the load's, on top of the uniform wind, m/s
    /// ([`Plant::set_gusts`]; empty: none).
    gusts_mps: Vec<Vector3<f64>>,
    /// Last valid setpoint of each quadrotor, held when a setpoint is lost.
    rigid_targets: Vec<crate::quadrotor::AttitudeTarget>,
    /// The setpoint each target was converted from (converted again only when it changes).
    rigid_setpoints: Vec<Option<Setpoint>>,
    /// Altitude of the load's centre resting on the ground, m ([`Plant::set_load_rest_z`]).
    load_rest_z_m: f64,
    /// Roughness length of the ground, m ([`Plant::set_surface_roughness`]; 0: uniform wind).
    roughness_m: f64,
}

/// Coulomb friction coefficient of the load on the ground (a crate on dry soil or grass,
/// 0.4-0.6; project choice, docs/plant.md "Ground contact").
pub const GROUND_FRICTION: f64 = 0.5;

#[inline]
fn finite3(v: &Vector3<f64>) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

/// The wind body `index` (UAVs `0..n`, the load `n`) meets at `height_m` above the ground,
/// m/s: the uniform wind `wind_mps` sheared over ground of roughness `roughness_m`
/// ([`shear_factor`]) plus the body's turbulent gust from `gusts_mps` (none when missing).
fn body_wind(wind_mps: &Vector3<f64>, height_m: f64, roughness_m: f64, gusts_mps: &[Vector3<f64>], index: usize) -> Vector3<f64> {
    let gust = gusts_mps.get(index).copied().unwrap_or_else(Vector3::zeros);
    // Calm air: the sheared wind is zero at any height (the shear factor is finite), so the two
    // logarithms are skipped; `0 x f + g` and `g` are the same bits (`-0 + x = x` for x != -0,
    // and a zero gust is +0).
    if *wind_mps == Vector3::zeros() {
        return Vector3::zeros() + gust;
    }
    wind_mps * shear_factor(height_m, roughness_m) + gust
}

/// Scale `v` (N) down to magnitude `max_n` (N) if it is longer; direction kept.
/// Robust to finite vectors whose norm overflows.
/// A body's velocity after a ground contact (m/s): the velocity into the ground taken away (a
/// perfectly inelastic normal impulse) and friction taking up to [`GROUND_FRICTION`] times that
/// impulse from the horizontal velocity (Coulomb friction in impulse form).
fn ground_friction(v: Vector3<f64>) -> Vector3<f64> {
    let into = (-v.z).max(0.0);
    let slide = v.x.hypot(v.y);
    let keep = if slide > 0.0 { (1.0 - GROUND_FRICTION * into / slide).max(0.0) } else { 0.0 };
    Vector3::new(v.x * keep, v.y * keep, v.z.max(0.0))
}

fn clamp_magnitude(v: Vector3<f64>, max_n: f64) -> Vector3<f64> {
    let norm = v.norm();
    if norm <= max_n {
        return v;
    }
    if norm.is_finite() {
        return v * (max_n / norm);
    }
    // Finite components, overflowing norm: normalise by the largest component first.
    let largest = v.amax();
    if largest > 0.0 && largest.is_finite() {
        let w = v / largest;
        let n = w.norm();
        if n > 0.0 && n.is_finite() {
            return w * (max_n / n);
        }
    }
    Vector3::zeros()
}

impl Plant {
    /// Build a plant at rest: UAV `i` at `uav_positions_m[i]` (m) on cable `cables[i]`, the load
    /// at `load_position_m` (m), all velocities and actual thrusts zero (set
    /// `uavs[i].thrust_n` to start with spinning rotors). `substeps` (>= 1) sub-steps are taken
    /// per [`Plant::step`].
    ///
    /// # Errors
    /// [`PlantError`] naming the first invalid input: list lengths differ, a mass is not finite
    /// and > 0, a thrust limit is NaN or negative, a lag is not finite and >= 0, a cable parameter
    /// is invalid, a position is not finite, or `substeps == 0`.
    pub fn new(
        uav_params: Vec<UavParams>,
        cables: Vec<CableParams>,
        load_params: LoadParams,
        uav_positions_m: &[Vector3<f64>],
        load_position_m: Vector3<f64>,
        substeps: usize,
    ) -> Result<Self, PlantError> {
        if uav_params.len() != cables.len() || uav_params.len() != uav_positions_m.len() {
            return Err(PlantError::CountMismatch {
                uavs: uav_params.len(),
                cables: cables.len(),
                positions: uav_positions_m.len(),
            });
        }
        for (index, p) in uav_params.iter().enumerate() {
            if !(p.mass_kg.is_finite() && p.mass_kg > 0.0) {
                return Err(PlantError::UavMass { index });
            }
            if p.thrust_max_n.is_nan() || p.thrust_max_n < 0.0 {
                return Err(PlantError::UavThrustMax { index });
            }
            if !(p.thrust_lag_s.is_finite() && p.thrust_lag_s >= 0.0) {
                return Err(PlantError::UavThrustLag { index });
            }
        }
        if !(load_params.mass_kg.is_finite() && load_params.mass_kg > 0.0) {
            return Err(PlantError::LoadMass);
        }
        for (index, c) in cables.iter().enumerate() {
            let ok = [c.rest_length_m, c.stiffness_n_per_m, c.damping_ns_per_m]
                .iter()
                .all(|x| x.is_finite() && *x >= 0.0)
                && c.f_max_n >= 0.0;
            if !ok {
                return Err(PlantError::Cable { index });
            }
        }
        if let Some(index) = uav_positions_m.iter().position(|p| !finite3(p)) {
            return Err(PlantError::UavPosition { index });
        }
        if !finite3(&load_position_m) {
            return Err(PlantError::LoadPosition);
        }
        if substeps == 0 {
            return Err(PlantError::ZeroSubsteps);
        }
        let uavs = uav_positions_m
            .iter()
            .map(|&pos_m| UavState {
                pos_m,
                vel_mps: Vector3::zeros(),
                thrust_n: Vector3::zeros(),
            })
            .collect();
        let mut plant = Self {
            uavs,
            load: LoadState {
                pos_m: load_position_m,
                vel_mps: Vector3::zeros(),
            },
            uav_params,
            load_params,
            cables,
            substeps,
            last_forces: Vec::new(),
            tensions_n: Vec::new(),
            targets: Vec::new(),
            ext_uav: Vec::new(),
            alphas: Vec::new(),
            alpha_h_s: f64::NAN,
            breaking_n: Vec::new(),
            breaks: Vec::new(),
            thrust_buf: Vec::new(),
            ext_buf: Vec::new(),
            quads: Vec::new(),
            rigid_targets: Vec::new(),
            rigid_setpoints: Vec::new(),
            thrust_built_n: Vec::new(),
            gusts_mps: Vec::new(),
            load_rest_z_m: 0.0,
            roughness_m: 0.0,
        };
        plant.thrust_built_n = plant.uav_params.iter().map(|p| p.thrust_max_n).collect();
        plant.last_forces = plant.cable_forces();
        plant.tensions_n = plant.last_forces.iter().map(|f| f.tension_n).collect();
        Ok(plant)
    }

    /// Scales UAV `index`'s maximum thrust to `scale` times the built one (issue 27: battery
    /// sag): point-mass UAVs through their thrust limit, quadrotors through their rotors
    /// ([`crate::quadrotor::Quadrotor::set_thrust_scale`]). An out-of-range index or a
    /// non-finite or negative scale does nothing.
    pub fn set_thrust_scale(&mut self, index: usize, scale: f64) {
        if !(scale.is_finite() && scale >= 0.0) {
            return;
        }
        if let (Some(p), Some(b)) = (self.uav_params.get_mut(index), self.thrust_built_n.get(index)) {
            p.thrust_max_n = b * scale;
        }
        if let Some(q) = self.quads.get_mut(index) {
            q.set_thrust_scale(scale);
        }
    }

    /// Sets each body's turbulent gust for the next steps, m/s, world ENU: one per UAV, then the
    /// load's ([`crate::turbulence`]). Added to the uniform wind in every drag term; missing or
    /// non-finite entries count as none.
    pub fn set_gusts(&mut self, gusts_mps: &[Vector3<f64>]) {
        self.gusts_mps.clear();
        self.gusts_mps.extend(gusts_mps.iter().map(|g| if finite3(g) { *g } else { Vector3::zeros() }));
    }

    /// The ground's roughness length, m: the wind passed to [`Plant::step_setpoints`] is the
    /// wind at 20 ft and above, and each body meets [`shear_factor`] of it at its height (the
    /// turbulent gusts of [`Plant::set_gusts`] are added unscaled). 0 (the default) blows the
    /// same wind at every height; a negative or non-finite value is ignored.
    pub fn set_surface_roughness(&mut self, roughness_m: f64) {
        if roughness_m.is_finite() && roughness_m >= 0.0 {
            self.roughness_m = roughness_m;
        }
    }

    /// The wind body `index` (UAVs `0..n`, the load `n`) meets at `height_m`, m/s
    /// ([`body_wind`]).
    fn body_wind(&self, wind_mps: &Vector3<f64>, height_m: f64, index: usize) -> Vector3<f64> {
        body_wind(wind_mps, height_m, self.roughness_m, &self.gusts_mps, index)
    }

    /// Cuts cable `index` (fault injection): from now on it carries no force.
    /// An out-of-range index does nothing.
    pub fn cut_cable(&mut self, index: usize) {
        if let Some(c) = self.cables.get_mut(index) {
            c.f_max_n = 0.0;
            c.stiffness_n_per_m = 0.0;
            c.damping_ns_per_m = 0.0;
        }
    }

    /// Number of UAVs.
    #[must_use]
    pub fn n_uavs(&self) -> usize {
        self.uav_params.len()
    }

    /// UAV parameters, one per UAV.
    #[must_use]
    pub fn uav_params(&self) -> &[UavParams] {
        &self.uav_params
    }

    /// Load parameters.
    #[must_use]
    pub fn load_params(&self) -> &LoadParams {
        &self.load_params
    }

    /// Cable parameters, one per UAV.
    #[must_use]
    pub fn cable_params(&self) -> &[CableParams] {
        &self.cables
    }

    /// Sub-steps per [`Plant::step`].
    #[must_use]
    pub fn substeps(&self) -> usize {
        self.substeps
    }

    /// Cable forces evaluated at the current state, one per UAV (N, m).
    #[must_use]
    pub fn cable_forces(&self) -> Vec<CableForce> {
        self.cables
            .iter()
            .enumerate()
            .filter_map(|(i, c)| self.hook(i).map(|(p, v)| cable_force(p, v, self.load.pos_m, self.load.vel_mps, c)))
            .collect()
    }

    /// Cable forces applied in the last sub-step of the last [`Plant::step`] (evaluated at the
    /// state at the start of that sub-step); after [`Plant::new`], at the initial state.
    #[must_use]
    pub fn last_cable_forces(&self) -> &[CableForce] {
        &self.last_forces
    }

    /// Cable tensions applied in the last sub-step, N, one per UAV (see
    /// [`Plant::last_cable_forces`]).
    #[must_use]
    pub fn tensions_n(&self) -> &[f64] {
        &self.tensions_n
    }

    /// Advance the plant by `dt_s` (s) in `substeps` semi-implicit Euler sub-steps.
    ///
    /// - `thrust_cmd_n[i]`: commanded thrust of UAV `i`, world ENU, N, held over the step.
    ///   It is limited to magnitude `thrust_max_n` (direction kept), then passed through the
    ///   first-order lag `T += alpha (T_cmd - T)`, `alpha = 1 - exp(-h / thrust_lag_s)`
    ///   (exact discretisation per sub-step `h`; `alpha = 1` when the lag is 0). A non-finite
    ///   or missing command (slice shorter than the UAV count) holds the previous actual thrust,
    ///   like a lost setpoint.
    /// - `ext_force_uav_n[i]`: external force on UAV `i` (e.g. wind), N; an empty slice means
    ///   none, missing or non-finite entries count as zero.
    /// - `ext_force_load_n`: external force on the load, N; non-finite counts as zero.
    ///
    /// A `dt_s` that is not finite and > 0 leaves the plant unchanged.
    pub fn step(
        &mut self,
        thrust_cmd_n: &[Vector3<f64>],
        ext_force_uav_n: &[Vector3<f64>],
        ext_force_load_n: Vector3<f64>,
        dt_s: f64,
    ) {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return;
        }
        let h = dt_s / self.substeps as f64;
        let g = gravity_vec_mps2();
        let ext_load = if finite3(&ext_force_load_n) {
            ext_force_load_n
        } else {
            Vector3::zeros()
        };

        // Limited command and lag factor per UAV: constant over the step. The buffers are
        // reused (no allocation per step); the lag factors only change with the sub-step.
        self.targets.clear();
        self.targets
            .extend(self.uav_params.iter().enumerate().map(|(i, p)| {
                thrust_cmd_n
                    .get(i)
                    .filter(|c| finite3(c))
                    .map(|c| clamp_magnitude(*c, p.thrust_max_n))
            }));
        if h != self.alpha_h_s || self.alphas.len() != self.uav_params.len() {
            self.alphas.clear();
            self.alphas.extend(self.uav_params.iter().map(|p| {
                if p.thrust_lag_s > 0.0 {
                    -(-h / p.thrust_lag_s).exp_m1()
                } else {
                    1.0
                }
            }));
            self.alpha_h_s = h;
        }
        self.ext_uav.clear();
        self.ext_uav.extend((0..self.uav_params.len()).map(|i| {
            ext_force_uav_n
                .get(i)
                .filter(|f| finite3(f))
                .copied()
                .unwrap_or_else(Vector3::zeros)
        }));
        // One force slot per (UAV, cable) pair, as `cable_forces` would return.
        let n_pairs = self.uavs.len().min(self.cables.len());
        self.last_forces.resize(n_pairs, CableForce::slack(0.0));

        for _ in 0..self.substeps {
            // One pass per UAV, each UAV's terms in the same order as the textbook form
            // (forces at the state at the start of the sub-step, thrust lag, velocity, then
            // position with the new velocity). A UAV's update does not change what another
            // UAV's cable sees (the load moves after the pass), so fusing the passes gives the
            // same numbers bit for bit.
            let (load_pos_m, load_vel_mps) = (self.load.pos_m, self.load.vel_mps);
            let mut load_force = self.load_params.mass_kg * g + ext_load;
            let mut updated = 0;
            for (((((uav, p), c), slot), target), (alpha, ext)) in self
                .uavs
                .iter_mut()
                .zip(&self.uav_params)
                .zip(&self.cables)
                .zip(self.last_forces.iter_mut())
                .zip(&self.targets)
                .zip(self.alphas.iter().zip(&self.ext_uav))
            {
                let f = cable_force(uav.pos_m, uav.vel_mps, load_pos_m, load_vel_mps, c);
                *slot = f;
                if f.tension_n > self.breaking_n.get(updated).copied().unwrap_or(f64::INFINITY) {
                    self.breaks.push((updated, f.tension_n, self.breaking_n.get(updated).copied().unwrap_or(f64::INFINITY)));
                }
                if let Some(t) = target {
                    uav.thrust_n += (*t - uav.thrust_n) * *alpha;
                }
                let force = uav.thrust_n + p.mass_kg * g + f.on_uav_n + ext;
                uav.vel_mps += force * (h / p.mass_kg);
                uav.pos_m += uav.vel_mps * h;
                load_force += f.on_load_n;
                updated += 1;
            }
            // UAV entries without parameters (see the struct doc) only drift.
            for uav in self.uavs.iter_mut().skip(updated) {
                uav.pos_m += uav.vel_mps * h;
            }
            self.load.vel_mps += load_force * (h / self.load_params.mass_kg);
            self.load.pos_m += self.load.vel_mps * h;
        }
        self.tensions_n.clear();
        self.tensions_n
            .extend(self.last_forces.iter().map(|f| f.tension_n));
        self.apply_breaks();
    }

    /// Cuts the cables that broke in the last step (a broken cable carries no force from the
    /// next step on; the step in which it broke carried the breaking tension).
    fn apply_breaks(&mut self) {
        for k in 0..self.breaks.len() {
            if let Some(&(i, _, _)) = self.breaks.get(k) {
                self.cut_cable(i);
                if let Some(b) = self.breaking_n.get_mut(i) {
                    *b = f64::INFINITY;
                }
            }
        }
    }

    /// Sets each cable's breaking strength, N (`f64::INFINITY`: never breaks; missing entries
    /// never break).
    pub fn set_breaking_strengths(&mut self, breaking_n: Vec<f64>) {
        self.breaking_n = breaking_n;
    }

    /// The cables that broke since the last call: (index, tension N, breaking strength N).
    pub fn take_breaks(&mut self) -> Vec<(usize, f64, f64)> {
        let mut seen: Vec<(usize, f64, f64)> = Vec::new();
        for b in self.breaks.drain(..) {
            if !seen.iter().any(|s| s.0 == b.0) {
                seen.push(b);
            }
        }
        seen
    }

    /// Advances `dt_s` under the autopilots' setpoints (one per UAV, see [`command`]). A
    /// rigid-body plant flies them through each quadrotor's autopilot ([`rigid`]); a
    /// point-mass UAV's thrust vector follows `collective * thrust_max * R(q) e_z` through its
    /// lag; `motors_off[i]` forces UAV `i`'s thrust to zero (a thrust-loss fault). `wind_mps`
    /// (world ENU) drags every body with area `uav_drag_area_m2` / `load_drag_area_m2`
    /// (quadratic, [`drag_n`]; none in calm air, as in the paper's model). A non-finite
    /// setpoint holds the previous thrust.
    pub fn step_setpoints(
        &mut self,
        setpoints: &[Setpoint],
        motors_off: &[bool],
        wind_mps: &Vector3<f64>,
        uav_drag_area_m2: f64,
        load_drag_area_m2: f64,
        dt_s: f64,
    ) {
        if !self.quads.is_empty() {
            self.step_rigid(setpoints, motors_off, wind_mps, load_drag_area_m2, dt_s);
            return;
        }
        let mut thrust = std::mem::take(&mut self.thrust_buf);
        thrust.clear();
        thrust.extend(self.uav_params.iter().enumerate().map(|(i, p)| {
            if motors_off.get(i).copied().unwrap_or(false) {
                Vector3::zeros()
            } else {
                setpoints
                    .get(i)
                    .and_then(|sp| command::thrust_vector_n(sp, p.thrust_max_n))
                    .unwrap_or_else(|| Vector3::repeat(f64::NAN))
            }
        }));
        let calm = *wind_mps == Vector3::zeros() && self.gusts_mps.is_empty();
        let mut ext = std::mem::take(&mut self.ext_buf);
        ext.clear();
        if !calm {
            ext.extend(self.uavs.iter().enumerate().map(|(i, u)| drag_n(&self.body_wind(wind_mps, u.pos_m.z, i), &u.vel_mps, uav_drag_area_m2)));
        }
        let load_wind = self.body_wind(wind_mps, self.load.pos_m.z, self.uavs.len());
        let ext_load = if calm { Vector3::zeros() } else { drag_n(&load_wind, &self.load.vel_mps, load_drag_area_m2) };
        self.step(&thrust, &ext, ext_load, dt_s);
        self.thrust_buf = thrust;
        self.ext_buf = ext;
    }

    /// The altitude of the load's centre when it rests on the ground, m (its envelope's
    /// radius above z = 0; 0 until set).
    pub fn set_load_rest_z(&mut self, z_m: f64) {
        if z_m.is_finite() && z_m >= 0.0 {
            self.load_rest_z_m = z_m;
        }
    }

    /// The ground (docs/plant.md, "Ground contact"), after each plant step. A UAV below z = 0
    /// stops there, at rest. The load's centre never goes below its resting altitude: the
    /// contact takes the velocity into the ground away (a perfectly inelastic normal impulse:
    /// no penetration, no bounce) and friction takes up to [`GROUND_FRICTION`] times that
    /// impulse from the horizontal velocity (Coulomb friction in impulse form, as in
    /// time-stepping rigid-body engines: resting, the normal impulse is `m g dt` per step and
    /// friction holds up to `mu m g`). Returns the load's speed into the ground when it made
    /// contact this step, m/s.
    pub fn ground_contact(&mut self) -> Option<f64> {
        if !self.quads.is_empty() {
            self.ground_quadrotors();
        }
        for u in &mut self.uavs {
            if u.pos_m.z < 0.0 {
                u.pos_m.z = 0.0;
                u.vel_mps = ground_friction(u.vel_mps);
            }
        }
        let rest = self.load_rest_z_m;
        let (p, v) = (&mut self.load.pos_m, &mut self.load.vel_mps);
        if p.z >= rest {
            return None;
        }
        p.z = rest;
        let into = (-v.z).max(0.0);
        *v = ground_friction(*v);
        Some(into)
    }

    /// Every state finite (the `nonfinite` criterion of a mission's success).
    #[must_use]
    pub fn is_finite(&self) -> bool {
        finite3(&self.load.pos_m)
            && finite3(&self.load.vel_mps)
            && self.uavs.iter().all(|u| finite3(&u.pos_m) && finite3(&u.vel_mps) && finite3(&u.thrust_n))
    }

    /// Mechanical energy of the current state, J: kinetic energy of all bodies, gravitational
    /// potential `m g z` (zero at z = 0), and the elastic energy `0.5 k (len - len0)^2` of every
    /// taut cable.
    ///
    /// Energy statements (conservation without damping and external forces, decrease with
    /// damping) hold only in the uncapped elastic regime: once a tension reaches `f_max` the cable
    /// force is no longer conservative and this elastic term is not its potential.
    #[must_use]
    pub fn mechanical_energy_j(&self) -> f64 {
        let uav_j: f64 = self
            .uavs
            .iter()
            .zip(&self.uav_params)
            .map(|(u, p)| {
                0.5 * p.mass_kg * u.vel_mps.norm_squared() + p.mass_kg * GRAVITY_MPS2 * u.pos_m.z
            })
            .sum();
        let m_l = self.load_params.mass_kg;
        let load_j =
            0.5 * m_l * self.load.vel_mps.norm_squared() + m_l * GRAVITY_MPS2 * self.load.pos_m.z;
        let elastic_j: f64 = self
            .uavs
            .iter()
            .zip(&self.cables)
            .map(|(u, c)| c.elastic_energy_j((u.pos_m - self.load.pos_m).norm()))
            .sum();
        uav_j + load_j + elastic_j
    }

    /// Ideal-hover thrust, N, one per UAV: `m_i g z_hat - F_cable,i` with the cable force at the
    /// current state, i.e. the thrust that makes each UAV's net force zero right now (gravity and
    /// cable cancelled). A test and initialisation helper, not a controller for the mission;
    /// it is not limited to `thrust_max_n` (the plant limits it when applied).
    #[must_use]
    pub fn hover_thrust(&self) -> Vec<Vector3<f64>> {
        self.uav_params
            .iter()
            .zip(self.cable_forces())
            .map(|(p, f)| -p.mass_kg * gravity_vec_mps2() - f.on_uav_n)
            .collect()
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::panic)]
mod tests;
