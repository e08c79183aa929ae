//! Capacity-aware formation: the paper's Remark 1 made automatic (issue 15; law, proof sketch
//! and measurements in `docs/design.md`, "Capacity-aware formation").
//!
//! Remark 1 lets the designer choose the springs' rest lengths from "the lengths of the cables
//! and the load capacity of the UAVs". Here the team does it itself, from the declared load:
//!
//! - **Geometry.** Scaling every rest length by `lambda` (eq:2-7 times `lambda`) scales the
//!   formation about the load node, so node `i` sits `lambda d_i` from the load node on the
//!   tray (`d_i` its take-off offset) and cable `i` leans `theta_i` from the vertical with
//!   `tan theta_i = lambda |d_i| / H` (eq:2-4: the node is on the cable line, `H` above the
//!   load). UAV `i` then sits at `P_i = L_i (lambda d_i, H) / sqrt(lambda^2 |d_i|^2 + H^2)`
//!   relative to the load (`L_i` its taut cable length).
//! - **Capacity.** With `f` the vertical pull one UAV may give its cable (the paper's
//!   `f_max`), the team lifts at most `C(lambda) = f sum_i cos theta_i`, decreasing in
//!   `lambda` (REFERENCE §6: the capped vertical capacity at a lean).
//! - **Separation floor.** `lambda_min` is the smallest scale in `[SCALE_FLOOR, 1]` down to
//!   which every pair keeps `|P_i - P_j| >= separation_m` (scanned from 1 downwards, then
//!   bisected); a take-off formation already below the floor is never contracted (`1`).
//! - **Declared load.** `lambda* = max { lambda in [lambda_min, 1] : C(lambda) >= (1 + rho) W }`,
//!   `W = m_load g`; `lambda_min` when even the most vertical formation misses the margin
//!   (the pre-flight check decides whether to fly). Light loads keep the designed formation
//!   (`lambda* = 1`); heavy ones stand the cables as vertical as the floor allows.
//! - **In flight** ([`FormationScale`]): `lambda` moves towards its target at a bounded rate
//!   `|lambda'| <= rate` (the springs' energy argument with time-varying rest lengths needs
//!   slow, bounded adaptation; docs/design.md). The target blends from `lambda*` to
//!   `lambda_min` with the overload signal `w = 1 - sigma(sag, sag_start, sag_full)`
//!   (REFERENCE §2's `sigma`), `sag = z_l,ref - z_l` the load's drop below its reference: a
//!   load that sinks means the lift is short, so the cables stand up and progress along the
//!   tube gives way (`progress = 1 - w` scales the passing term). Every input is the same for
//!   every UAV (declared mass, take-off positions, the load's altitude), so all UAVs compute
//!   the same `lambda` and the springs stay antisymmetric (Prop. 1).

use crate::tray::TrayParams;
use crate::{ControlError, Vec2, Vec3};

/// Gravitational acceleration used for the load's weight, m/s² (as `vt_cfo::GRAVITY_MPS2` and
/// the simulator's plant).
pub const GRAVITY_MPS2: f32 = 9.81;

/// Smallest formation scale the law considers (cables almost vertical).
pub const SCALE_FLOOR: f32 = 1.0 / 32.0;

/// Steps of the downward scan for the separation floor (then bisection).
const SCAN_STEPS: u32 = 32;
/// Bisection iterations (resolution `2^-20` of the bracket).
const BISECT_STEPS: u32 = 20;
/// Opening rate over closing rate of the formation scale: the formation stands up at
/// `rate_per_s` when the load sinks and opens again four times slower, so that an overload the
/// declared mass did not announce is met with a fast response and a cautious return (an opening
/// that loses too much capacity shows as sag again while the deficit is still small).
pub const OPEN_RATE_FRACTION: f32 = 0.25;
/// Smallest UAV height above the load accepted for the take-off force estimate, m.
const MIN_TAKEOFF_HEIGHT_M: f32 = 0.1;

/// Parameters of the capacity-aware formation (firmware `VT_LOAD_KG`, `VT_CAP_N`, ...).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CapacityParams {
    /// Declared load mass, kg; 0 = not declared: the law is off (the formation is kept as
    /// designed, no overload response, no observer warm start: the paper's controller).
    pub load_mass_kg: f32,
    /// Vertical pull one UAV may give its cable, N (the paper's `f_max`, the rated capacity).
    pub uav_capacity_n: f32,
    /// Required capacity margin `rho`: the law asks `C(lambda) >= (1 + rho) W`.
    pub margin: f32,
    /// Smallest UAV-UAV distance the adapted formation keeps, m.
    pub separation_m: f32,
    /// Largest closing rate of the formation scale, `-lambda'`, 1/s (it opens at
    /// [`OPEN_RATE_FRACTION`] of it).
    pub rate_per_s: f32,
    /// Load sag below its reference where the overload response begins, m.
    pub sag_start_m: f32,
    /// Load sag where the overload response is complete (most vertical, no progress), m.
    pub sag_full_m: f32,
}

impl Default for CapacityParams {
    /// Law off (no declared load); the paper's 20 N capacity, 5 % margin, 0.9 m separation
    /// (0.4 m floor + 0.5 m safety radius), closing at 0.2 /s, overload response from 0.3 m to
    /// 0.8 m of sag.
    fn default() -> Self {
        Self {
            load_mass_kg: 0.0,
            uav_capacity_n: 20.0,
            margin: 0.05,
            separation_m: 0.9,
            rate_per_s: 0.2,
            sag_start_m: 0.3,
            sag_full_m: 0.8,
        }
    }
}

impl CapacityParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let checks: [(bool, &'static str); 7] = [
            (self.load_mass_kg.is_finite() && self.load_mass_kg >= 0.0, "capacity.load_mass_kg"),
            (pos(self.uav_capacity_n), "capacity.uav_capacity_n"),
            (self.margin.is_finite() && self.margin >= 0.0, "capacity.margin"),
            (pos(self.separation_m), "capacity.separation_m"),
            (pos(self.rate_per_s), "capacity.rate_per_s"),
            (pos(self.sag_start_m), "capacity.sag_start_m"),
            (self.sag_full_m.is_finite() && self.sag_full_m > self.sag_start_m, "capacity.sag_full_m"),
        ];
        match checks.iter().find(|(ok, _)| !ok) {
            Some((_, name)) => Err(ControlError::InvalidParameter(name)),
            None => Ok(()),
        }
    }

    /// Declared load weight `W = m g`, N.
    pub fn weight_n(&self) -> f32 {
        self.load_mass_kg * GRAVITY_MPS2
    }

    /// The law's need on `sum_i cos theta_i`: `(1 + rho) W / f` (0 without a declared load).
    pub fn need_cos_sum(&self) -> f32 {
        (1.0 + self.margin) * self.weight_n() / self.uav_capacity_n
    }

    /// The load's own need on `sum_i cos theta_i`, without the margin: `W / f` (0 without a
    /// declared load). The tube-shaped formation may spend the margin to keep its pairs apart in
    /// a passage, never the load itself (docs/design.md, "Heavy loads keep their pairs apart").
    pub fn weight_cos_sum(&self) -> f32 {
        self.weight_n() / self.uav_capacity_n
    }
}

/// What the law chose for a team and its declared load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CapacityPlan {
    /// `lambda_min`: the most vertical formation the separation floor allows.
    pub scale_min: f32,
    /// `lambda*`: the formation scale for the declared load.
    pub scale: f32,
    /// Cosine from the vertical of the most leaning cable at `lambda*` (1 = vertical).
    pub lean_cos_min: f32,
    /// Team vertical capacity `C(lambda*) = f sum cos theta_i`, N.
    pub capacity_n: f32,
    /// Declared load weight `W`, N (0 when not declared).
    pub weight_n: f32,
}

/// Capacity margin `rho` from which a team flies its full speed `v_max` (extension, issue 27;
/// docs/design.md, "A team near its capacity flies slower").
pub const SPEED_FULL_MARGIN: f32 = 0.03;
/// The smallest fraction of `v_max` a team near its capacity flies at.
pub const SPEED_MIN_FRACTION: f32 = 0.5;

/// Gain of the dashpot beside each UAV-UAV spring a team near its capacity flies
/// ([`dashpot_gain`], [`crate::springs::dashpot_velocity`]), dimensionless.
pub const NEAR_CAPACITY_DASHPOT: f32 = 0.1;

/// The dashpot gain a team with capacity margin `margin` (`rho`, [`CapacityPlan::margin`])
/// flies beside its springs: [`NEAR_CAPACITY_DASHPOT`] where it flies slower
/// ([`speed_fraction`] below 1), else 0 (extension; docs/design.md, "A dashpot beside the
/// springs of a team near its capacity").
pub fn dashpot_gain(margin: f32) -> f32 {
    if speed_fraction(margin) < 1.0 { NEAR_CAPACITY_DASHPOT } else { 0.0 }
}

/// The fastest descent, m/s, from which a team with capacity margin `margin` (`rho`,
/// [`CapacityPlan::margin`]) can still brake its load to `touchdown_mps` (m/s) within `band_m`
/// (m) above the ground: `sqrt(touchdown^2 + 2 rho g band)` (extension; docs/design.md, "A team
/// near its capacity descends as fast as it can brake"). The cables' spare vertical capacity is
/// `C - W = rho W`, so the load decelerates at `rho g` at the most. A margin of zero or less, or
/// not a number, gives `touchdown_mps`.
pub fn braking_descent_mps(margin: f32, touchdown_mps: f32, band_m: f32) -> f32 {
    let spare = if margin > 0.0 { margin } else { 0.0 };
    vt_fpu::sqrt(touchdown_mps * touchdown_mps + 2.0 * spare * crate::calibration::GRAVITY_MPS2 * band_m)
}

/// The fraction of `v_max` a team with capacity margin `margin` (`rho`,
/// [`CapacityPlan::margin`]) flies at: 1 from [`SPEED_FULL_MARGIN`] (and without a declared
/// load), `rho / SPEED_FULL_MARGIN` below it, never under [`SPEED_MIN_FRACTION`] (a margin of
/// zero or less, or not a number, flies the slowest).
pub fn speed_fraction(margin: f32) -> f32 {
    if margin >= SPEED_FULL_MARGIN {
        1.0
    } else if margin > 0.0 {
        vt_fpu::max(SPEED_MIN_FRACTION, margin / SPEED_FULL_MARGIN)
    } else {
        SPEED_MIN_FRACTION
    }
}

impl CapacityPlan {
    /// The plan that keeps the formation as designed (`lambda_min = lambda* = 1`).
    pub const NEUTRAL: Self = Self { scale_min: 1.0, scale: 1.0, lean_cos_min: 1.0, capacity_n: 0.0, weight_n: 0.0 };

    /// Capacity margin at `lambda*`: `C / W - 1` (infinite without a declared load).
    pub fn margin(&self) -> f32 {
        if self.weight_n > 0.0 {
            self.capacity_n / self.weight_n - 1.0
        } else {
            f32::INFINITY
        }
    }
}

/// The team as the law sees it: per UAV, its node offset from the load node at scale 1 and its
/// taut cable length.
trait Team {
    fn n(&self) -> usize;
    /// Node offset `d_i` on the tray at scale 1, m.
    fn offset(&self, i: usize) -> Vec2;
    /// Taut cable length `L_i`, m.
    fn length(&self, i: usize) -> f32;
}

struct Slices<'a> {
    offsets: &'a [Vec2],
    lengths: &'a [f32],
}

impl Team for Slices<'_> {
    fn n(&self) -> usize {
        self.offsets.len().min(self.lengths.len())
    }
    fn offset(&self, i: usize) -> Vec2 {
        self.offsets.get(i).copied().unwrap_or_else(Vec2::zeros)
    }
    fn length(&self, i: usize) -> f32 {
        self.lengths.get(i).copied().unwrap_or(0.0)
    }
}

struct Circle<'a> {
    radius_m: f32,
    lengths: &'a [f32],
}

impl Team for Circle<'_> {
    fn n(&self) -> usize {
        self.lengths.len()
    }
    fn offset(&self, i: usize) -> Vec2 {
        // Nodes equally spaced on the circle (the scenario's take-off formation; its rotation
        // changes neither leans nor pair distances). Configuration only: trigonometry allowed,
        // `vt_fpu`'s (`libm`'s brings about 7 KiB of range reduction and `f64` to the MCU).
        let a = core::f32::consts::TAU * i as f32 / self.lengths.len().max(1) as f32;
        let (sin, cos) = vt_fpu::sin_cos(a).unwrap_or((0.0, 1.0));
        Vec2::new(self.radius_m * cos, self.radius_m * sin)
    }
    fn length(&self, i: usize) -> f32 {
        self.lengths.get(i).copied().unwrap_or(0.0)
    }
}

struct Takeoff<'a> {
    uavs: &'a [Vec3],
    load: Vec3,
    tray: TrayParams,
}

impl Team for Takeoff<'_> {
    fn n(&self) -> usize {
        self.uavs.len()
    }
    fn offset(&self, i: usize) -> Vec2 {
        self.uavs.get(i).map_or_else(Vec2::zeros, |p| self.tray.project(p, &self.load).0 - self.load.xy())
    }
    fn length(&self, i: usize) -> f32 {
        self.uavs.get(i).map_or(0.0, |p| vt_fpu::norm(&(p - self.load)))
    }
}

/// Cosine of cable lean for a node offset of length `r` at scale `lambda` (tray `h` above the
/// load): `H / sqrt(H^2 + lambda^2 r^2)`.
#[inline]
pub(crate) fn lean_cos(r_m: f32, lambda: f32, h_m: f32) -> f32 {
    let x = lambda * r_m;
    h_m / vt_fpu::sqrt(h_m * h_m + x * x)
}

/// UAV position relative to the load at scale `lambda` (see the module docs), m.
#[inline]
pub(crate) fn uav_rel(d: Vec2, len_m: f32, lambda: f32, h_m: f32) -> Vec3 {
    let x = d * lambda;
    let k = len_m / vt_fpu::sqrt(x.norm_squared() + h_m * h_m);
    Vec3::new(x.x * k, x.y * k, h_m * k)
}

/// `C(lambda) / f` and the smallest cosine.
fn capacity_sum(t: &dyn Team, lambda: f32, h_m: f32) -> (f32, f32) {
    (0..t.n()).fold((0.0, 1.0), |(s, c_min), i| {
        let c = lean_cos(vt_fpu::norm(&t.offset(i)), lambda, h_m);
        (s + c, if c < c_min { c } else { c_min })
    })
}

/// True when every pair is at least `sep_m` apart at scale `lambda`.
fn separated(t: &dyn Team, lambda: f32, h_m: f32, sep_m: f32) -> bool {
    let sep2 = sep_m * sep_m;
    let n = t.n();
    (0..n).all(|i| {
        let pi = uav_rel(t.offset(i), t.length(i), lambda, h_m);
        (i + 1..n).all(|j| (pi - uav_rel(t.offset(j), t.length(j), lambda, h_m)).norm_squared() >= sep2)
    })
}

fn check_team(t: &dyn Team, h_m: f32) -> Result<(), ControlError> {
    if !(h_m.is_finite() && h_m > 0.0) {
        return Err(ControlError::InvalidParameter("tray.height_above_load_m"));
    }
    if t.n() == 0 {
        return Err(ControlError::BadTakeoff { index: 0 });
    }
    for i in 0..t.n() {
        let d = t.offset(i);
        let l = t.length(i);
        if !(d.x.is_finite() && d.y.is_finite() && l.is_finite() && l > 0.0) {
            return Err(ControlError::BadTakeoff { index: i });
        }
    }
    Ok(())
}

fn plan_team(t: &dyn Team, h_m: f32, p: &CapacityParams) -> Result<CapacityPlan, ControlError> {
    p.validate()?;
    check_team(t, h_m)?;
    // lambda_min: scan down from 1 while every pair keeps the floor, then bisect the step.
    let scale_min = if !separated(t, 1.0, h_m, p.separation_m) {
        1.0
    } else {
        let step = (1.0 - SCALE_FLOOR) / SCAN_STEPS as f32;
        let mut ok = 1.0f32;
        let mut bad = None;
        for k in 1..=SCAN_STEPS {
            let l = 1.0 - step * k as f32;
            if separated(t, l, h_m, p.separation_m) {
                ok = l;
            } else {
                bad = Some(l);
                break;
            }
        }
        match bad {
            None => SCALE_FLOOR,
            Some(mut bad) => {
                for _ in 0..BISECT_STEPS {
                    let mid = 0.5 * (ok + bad);
                    if separated(t, mid, h_m, p.separation_m) {
                        ok = mid;
                    } else {
                        bad = mid;
                    }
                }
                ok
            }
        }
    };
    // lambda*: the widest formation (C decreasing in lambda) that meets the margin.
    let weight_n = p.weight_n();
    let need = p.need_cos_sum();
    let scale = if weight_n <= 0.0 || capacity_sum(t, 1.0, h_m).0 >= need {
        1.0
    } else if capacity_sum(t, scale_min, h_m).0 < need {
        scale_min
    } else {
        let (mut ok, mut bad) = (scale_min, 1.0f32);
        for _ in 0..BISECT_STEPS {
            let mid = 0.5 * (ok + bad);
            if capacity_sum(t, mid, h_m).0 >= need {
                ok = mid;
            } else {
                bad = mid;
            }
        }
        ok
    };
    let (sum, lean_cos_min) = capacity_sum(t, scale, h_m);
    Ok(CapacityPlan { scale_min, scale, lean_cos_min, capacity_n: p.uav_capacity_n * sum, weight_n })
}

/// The law for a team given by its nodes' take-off offsets from the load node on the tray
/// (`offsets_m`, m) and taut cable lengths (`cable_lengths_m`, m), tray `tray_height_m` above
/// the load.
///
/// # Errors
/// Invalid `params` or tray height ([`ControlError::InvalidParameter`]); empty team, slices
/// of different lengths, non-finite offsets or non-positive lengths ([`ControlError::BadTakeoff`]).
pub fn plan(offsets_m: &[Vec2], cable_lengths_m: &[f32], tray_height_m: f32, params: &CapacityParams) -> Result<CapacityPlan, ControlError> {
    if offsets_m.len() != cable_lengths_m.len() {
        return Err(ControlError::BadTakeoff { index: offsets_m.len().min(cable_lengths_m.len()) });
    }
    plan_team(&Slices { offsets: offsets_m, lengths: cable_lengths_m }, tray_height_m, params)
}

/// The law for the scenario-style formation: nodes equally spaced on a circle of radius
/// `radius_m` around the load node (the order of `cable_lengths_m`, m, is the order around
/// the circle). This is the function a pre-flight check calls: [`CapacityPlan::lean_cos_min`]
/// and [`CapacityPlan::capacity_n`] are the lean and the capacity the adapted formation
/// reaches for the declared load.
///
/// # Errors
/// As [`plan`]; a non-finite or negative radius is [`ControlError::InvalidParameter`].
pub fn plan_circle(radius_m: f32, cable_lengths_m: &[f32], tray_height_m: f32, params: &CapacityParams) -> Result<CapacityPlan, ControlError> {
    if !(radius_m.is_finite() && radius_m >= 0.0) {
        return Err(ControlError::InvalidParameter("formation radius"));
    }
    plan_team(&Circle { radius_m, lengths: cable_lengths_m }, tray_height_m, params)
}

/// The law for the measured take-off state (every UAV's position and the load's, m): nodes by
/// eq:2-4, cable lengths as the UAV-load distances of the taut start. Every UAV of the team
/// computes the same plan from the same take-off measurement.
///
/// # Errors
/// As [`plan`]; a UAV not above the load by the tray's height floor, or non-finite, is
/// [`ControlError::BadTakeoff`].
pub fn plan_from_takeoff(uav_pos_m: &[Vec3], load_pos_m: &Vec3, tray: &TrayParams, params: &CapacityParams) -> Result<CapacityPlan, ControlError> {
    tray.validate()?;
    if !(load_pos_m.iter().all(|x| x.is_finite())) {
        return Err(ControlError::BadTakeoff { index: 0 });
    }
    for (i, u) in uav_pos_m.iter().enumerate() {
        if !(u.iter().all(|x| x.is_finite()) && u.z - load_pos_m.z >= tray.min_height_above_load_m) {
            return Err(ControlError::BadTakeoff { index: i });
        }
    }
    plan_team(&Takeoff { uavs: uav_pos_m, load: *load_pos_m, tray: *tray }, tray.height_above_load_m, params)
}

/// The cable force on one UAV expected at a hovering start with the declared load shared
/// equally in the vertical (`f = (W / n) d / d_z`, `d` = own position minus load position;
/// the force the cable exerts on the UAV is `-f`, the CFO's sign, REFERENCE §4), N. `None`
/// without a declared load, for `n = 0`, non-finite input or a UAV less than 0.1 m above the
/// load. Used to warm-start the velocity loop's observer at mission start.
pub fn takeoff_cable_force_n(own_pos_m: &Vec3, load_pos_m: &Vec3, load_mass_kg: f32, n_uavs: usize) -> Option<Vec3> {
    let d = own_pos_m - load_pos_m;
    let ok = load_mass_kg.is_finite() && load_mass_kg > 0.0 && n_uavs > 0 && d.iter().all(|x| x.is_finite()) && d.z >= MIN_TAKEOFF_HEIGHT_M;
    ok.then(|| d * (load_mass_kg * GRAVITY_MPS2 / (n_uavs as f32 * d.z)))
}

/// One step's output of [`FormationScale`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleOutput {
    /// Formation scale `lambda` applied to every rest length.
    pub scale: f32,
    /// Factor on the passing term, `1 - w` in `[0, 1]`.
    pub progress: f32,
    /// Overload signal `w` in `[0, 1]` (0: load at or above `sag_start` of its reference).
    pub overload: f32,
}

/// The formation scale in flight: rate-limited towards the plan's target, blended towards
/// `lambda_min` by the load's sag (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormationScale {
    scale_min: f32,
    scale_target: f32,
    scale: f32,
    rate_per_s: f32,
    sag_start_m: f32,
    sag_full_m: f32,
    overload: f32,
}

impl FormationScale {
    /// Starts at the take-off formation (`lambda = 1`) with the plan's target; [`Self::NEUTRAL`]
    /// without a declared load (`params.load_mass_kg = 0`: the law is off).
    pub fn new(plan: &CapacityPlan, params: &CapacityParams) -> Self {
        if !(params.load_mass_kg > 0.0) {
            return Self::NEUTRAL;
        }
        // A plan with non-finite scales (not one of this module's) keeps the formation.
        let lo = if plan.scale_min.is_finite() { vt_tube::limit(plan.scale_min, SCALE_FLOOR, 1.0) } else { 1.0 };
        let target = if plan.scale.is_finite() { vt_tube::limit(plan.scale, lo, 1.0) } else { 1.0 };
        Self {
            scale_min: lo,
            scale_target: target,
            scale: 1.0,
            rate_per_s: params.rate_per_s,
            sag_start_m: params.sag_start_m,
            sag_full_m: params.sag_full_m,
            overload: 0.0,
        }
    }

    /// The law off: scale 1 and full progress whatever the load does.
    pub const NEUTRAL: Self =
        Self { scale_min: 1.0, scale_target: 1.0, scale: 1.0, rate_per_s: 0.0, sag_start_m: f32::MAX, sag_full_m: f32::MAX, overload: 0.0 };

    /// `lambda_min`: the smallest scale the law may fly (the separation floor's).
    pub fn scale_min(&self) -> f32 {
        self.scale_min
    }

    /// `lambda*`: the scale the law aims for without an overload.
    pub fn scale_target(&self) -> f32 {
        self.scale_target
    }

    /// Current scale `lambda`.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// One step of `dt_s` with the load's measured altitude `load_z_m` and its reference
    /// `load_ref_z_m`, m. A non-finite altitude or step holds the state.
    pub fn update(&mut self, load_z_m: f32, load_ref_z_m: f32, dt_s: f32) -> ScaleOutput {
        let sag = load_ref_z_m - load_z_m;
        if sag <= self.sag_start_m && self.scale == self.scale_target {
            // Nominal: no sag, formation at its target (the common case; nothing to integrate).
            self.overload = 0.0;
            return ScaleOutput { scale: self.scale, progress: 1.0, overload: 0.0 };
        }
        if sag.is_finite() && dt_s.is_finite() && dt_s > 0.0 && self.rate_per_s > 0.0 {
            // w = 1 - sigma(sag, sag_start, sag_full) (REFERENCE §2's sigma: 1 below, 0 above).
            self.overload = 1.0 - vt_tube::sigma(sag, self.sag_start_m, self.sag_full_m);
            let target = self.scale_target - self.overload * (self.scale_target - self.scale_min);
            let step = self.rate_per_s * dt_s;
            let next = self.scale + vt_tube::limit(target - self.scale, -step, OPEN_RATE_FRACTION * step);
            if next.is_finite() {
                self.scale = vt_tube::limit(next, self.scale_min.min(1.0), 1.0);
            }
        }
        ScaleOutput { scale: self.scale, progress: 1.0 - self.overload, overload: self.overload }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    /// The paper's cables (REFERENCE §5), 3 m node circle, tray 10 m above the load.
    const PAPER_CABLES: [f32; 10] = [8.3, 7.0, 8.6, 8.8, 8.3, 8.5, 8.4, 7.7, 8.3, 7.3];

    fn paper(load_kg: f32) -> CapacityParams {
        CapacityParams { load_mass_kg: load_kg, ..CapacityParams::default() }
    }

    #[test]
    fn light_load_keeps_the_designed_formation() {
        // 18 kg: 10 x 20 N x cos(atan 0.3) = 191.6 N >= 1.05 x 176.6 N (REFERENCE §6).
        let p = plan_circle(3.0, &PAPER_CABLES, 10.0, &paper(18.0)).unwrap();
        assert_eq!(p.scale, 1.0);
        assert_relative_eq!(p.capacity_n, 200.0 / (1.09f32).sqrt(), epsilon = 0.05);
        assert_relative_eq!(p.lean_cos_min, 1.0 / (1.09f32).sqrt(), epsilon = 1e-5);
        assert!(p.margin() > 0.08);
    }

    /// The braking descent: `v_touch` with no margin (or none known), growing with the margin
    /// as `sqrt(v_touch^2 + 2 rho g band)` (0.30 m/s at the packed team's 0.4 % over a 1 m band
    /// from 0.1 m/s; the ground start's 0.5 m/s from a 1.22 % margin on), monotone.
    #[test]
    fn a_team_descends_as_fast_as_its_capacity_can_brake() {
        for m in [0.0, -0.2, f32::NAN, f32::NEG_INFINITY] {
            assert_relative_eq!(braking_descent_mps(m, 0.1, 1.0), 0.1, epsilon = 1e-7);
        }
        assert_relative_eq!(braking_descent_mps(0.004, 0.1, 1.0), (0.01f32 + 2.0 * 0.004 * 9.81).sqrt(), epsilon = 1e-6);
        assert!((braking_descent_mps(0.004, 0.1, 1.0) - 0.297).abs() < 0.001);
        assert!((braking_descent_mps(0.0122, 0.1, 1.0) - 0.5).abs() < 0.002);
        let mut last = 0.0;
        for k in 0..=100 {
            let v = braking_descent_mps(k as f32 * 1e-3, 0.1, 1.0);
            assert!(v >= last, "{k}");
            last = v;
        }
    }

    /// A team flies the dashpots beside its springs where it flies slower (below a 3 % margin,
    /// and for a margin that is none or not a number), and none from the full speed's margin on
    /// or without a declared load.
    #[test]
    fn a_team_near_its_capacity_flies_dashpots_beside_its_springs() {
        for m in [f32::INFINITY, 1.0, 0.086, SPEED_FULL_MARGIN] {
            assert_eq!(dashpot_gain(m), 0.0, "{m}");
        }
        for m in [0.0299, 0.0225, 0.0044, 0.0, -0.1, f32::NAN] {
            assert_eq!(dashpot_gain(m), NEAR_CAPACITY_DASHPOT, "{m}");
        }
    }

    /// A team near its capacity flies slower: full speed from a 3 % margin and without a
    /// declared load, in proportion below, half speed at the least, and at the least for a
    /// margin that is none, negative or not a number.
    #[test]
    fn a_team_near_its_capacity_flies_slower() {
        for m in [f32::INFINITY, 1.0, 0.086, SPEED_FULL_MARGIN] {
            assert_eq!(speed_fraction(m), 1.0, "{m}");
        }
        assert_relative_eq!(speed_fraction(0.0225), 0.75, epsilon = 1e-6);
        for m in [0.015, 0.0044, 0.0, -0.1, f32::NEG_INFINITY, f32::NAN] {
            assert_eq!(speed_fraction(m), SPEED_MIN_FRACTION, "{m}");
        }
        let mut last = 0.0;
        for k in 0..=400 {
            let f = speed_fraction(k as f32 * 1e-4);
            assert!(f >= last && (SPEED_MIN_FRACTION..=1.0).contains(&f), "monotone and bounded at {k}: {f}");
            last = f;
        }
    }

    /// The stadium's bound (the load alone) lies below the law's need (the load and its margin)
    /// by exactly the margin, and both vanish without a declared load.
    #[test]
    fn the_weight_bound_is_the_need_without_its_margin() {
        let p = paper(19.4);
        assert_relative_eq!(p.weight_cos_sum(), 19.4 * GRAVITY_MPS2 / 20.0, epsilon = 1e-5);
        assert_relative_eq!(p.need_cos_sum(), (1.0 + p.margin) * p.weight_cos_sum(), epsilon = 1e-5);
        assert!(p.weight_cos_sum() < p.need_cos_sum());
        assert_eq!((paper(0.0).weight_cos_sum(), paper(0.0).need_cos_sum()), (0.0, 0.0));
    }

    #[test]
    fn heavy_load_stands_the_cables_up_to_the_separation_floor() {
        let p = plan_circle(3.0, &PAPER_CABLES, 10.0, &paper(19.8)).unwrap();
        // 1.05 x 194.2 N > 200 N: the margin cannot be met, so the most vertical formation.
        assert_eq!(p.scale, p.scale_min);
        assert!(p.scale_min < 0.7 && p.scale_min > 0.3, "{p:?}");
        assert!(p.capacity_n > 19.8 * GRAVITY_MPS2, "{p:?}");
        // ... and the floor holds there, and is tight (a little more contraction breaks it).
        let t = Circle { radius_m: 3.0, lengths: &PAPER_CABLES };
        assert!(separated(&t, p.scale_min, 10.0, 0.9));
        assert!(!separated(&t, p.scale_min - 0.01, 10.0, 0.9));
    }

    #[test]
    fn intermediate_load_meets_the_margin_exactly() {
        let params = paper(19.0);
        let p = plan_circle(3.0, &PAPER_CABLES, 10.0, &params).unwrap();
        assert!(p.scale > p.scale_min && p.scale < 1.0, "{p:?}");
        assert_relative_eq!(p.capacity_n, 1.05 * params.weight_n(), max_relative = 1e-4);
        // Monotone: heavier declared load, more vertical formation.
        let q = plan_circle(3.0, &PAPER_CABLES, 10.0, &paper(19.4)).unwrap();
        assert!(q.scale < p.scale && q.lean_cos_min > p.lean_cos_min);
    }

    #[test]
    fn undeclared_load_and_tight_takeoff_keep_scale_one() {
        let p = plan_circle(3.0, &PAPER_CABLES, 10.0, &paper(0.0)).unwrap();
        assert_eq!((p.scale, p.weight_n), (1.0, 0.0));
        assert!(p.margin().is_infinite());
        // A formation already closer than the floor is never contracted.
        let p = plan_circle(0.2, &PAPER_CABLES, 10.0, &paper(19.8)).unwrap();
        assert_eq!((p.scale_min, p.scale), (1.0, 1.0));
    }

    #[test]
    fn takeoff_plan_matches_the_circle_plan() {
        // The same team measured at take-off: nodes on the 3 m circle, taut cables.
        let load = Vec3::new(4.0, 0.0, 6.0);
        let uavs: Vec<Vec3> = PAPER_CABLES
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let a = core::f32::consts::TAU * i as f32 / 10.0;
                let c = 10.0 / (109.0f32).sqrt();
                load + Vec3::new(l * c * 0.3 * a.cos(), l * c * 0.3 * a.sin(), l * c)
            })
            .collect();
        let a = plan_from_takeoff(&uavs, &load, &TrayParams::default(), &paper(19.8)).unwrap();
        let b = plan_circle(3.0, &PAPER_CABLES, 10.0, &paper(19.8)).unwrap();
        assert_relative_eq!(a.scale, b.scale, epsilon = 1e-3);
        assert_relative_eq!(a.capacity_n, b.capacity_n, epsilon = 1e-2);
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let bad = CapacityParams { margin: f32::NAN, ..paper(1.0) };
        assert_eq!(plan_circle(3.0, &PAPER_CABLES, 10.0, &bad), Err(ControlError::InvalidParameter("capacity.margin")));
        let bad = CapacityParams { sag_full_m: 0.1, ..paper(1.0) };
        assert_eq!(bad.validate(), Err(ControlError::InvalidParameter("capacity.sag_full_m")));
        assert_eq!(plan_circle(3.0, &[], 10.0, &paper(1.0)), Err(ControlError::BadTakeoff { index: 0 }));
        assert_eq!(plan_circle(3.0, &[8.0, -1.0], 10.0, &paper(1.0)), Err(ControlError::BadTakeoff { index: 1 }));
        assert_eq!(plan_circle(f32::NAN, &[8.0], 10.0, &paper(1.0)), Err(ControlError::InvalidParameter("formation radius")));
        assert!(matches!(plan_circle(3.0, &[8.0], 0.0, &paper(1.0)), Err(ControlError::InvalidParameter(_))));
        assert_eq!(plan(&[Vec2::zeros()], &[], 10.0, &paper(1.0)), Err(ControlError::BadTakeoff { index: 0 }));
        let load = Vec3::zeros();
        let below = [Vec3::new(1.0, 0.0, 0.1)];
        assert_eq!(plan_from_takeoff(&below, &load, &TrayParams::default(), &paper(1.0)), Err(ControlError::BadTakeoff { index: 0 }));
    }

    #[test]
    fn takeoff_force_shares_the_weight_along_the_cable() {
        let f = takeoff_cable_force_n(&Vec3::new(3.0, 0.0, 10.0), &Vec3::zeros(), 20.0, 10).unwrap();
        assert_relative_eq!(f.z, 2.0 * GRAVITY_MPS2, epsilon = 1e-5);
        assert_relative_eq!(f.x, 0.3 * f.z, epsilon = 1e-5);
        assert!(takeoff_cable_force_n(&Vec3::new(3.0, 0.0, 10.0), &Vec3::zeros(), 0.0, 10).is_none());
        assert!(takeoff_cable_force_n(&Vec3::new(3.0, 0.0, 0.0), &Vec3::zeros(), 20.0, 10).is_none());
        assert!(takeoff_cable_force_n(&Vec3::new(f32::NAN, 0.0, 9.0), &Vec3::zeros(), 20.0, 10).is_none());
        assert!(takeoff_cable_force_n(&Vec3::new(1.0, 0.0, 9.0), &Vec3::zeros(), 20.0, 0).is_none());
    }

    #[test]
    fn scale_moves_at_the_bounded_rate_and_sag_drives_it_to_the_floor() {
        let params = paper(19.0);
        let plan = CapacityPlan { scale_min: 0.4, scale: 0.7, lean_cos_min: 1.0, capacity_n: 0.0, weight_n: 0.0 };
        let mut s = FormationScale::new(&plan, &params);
        let dt = 0.02;
        let mut prev = s.scale();
        for _ in 0..1000 {
            let o = s.update(6.0, 6.0, dt);
            assert!(o.scale <= prev && prev - o.scale <= params.rate_per_s * dt * (1.0 + 1e-5));
            assert_eq!((o.progress, o.overload), (1.0, 0.0));
            prev = o.scale;
        }
        assert_relative_eq!(s.scale(), 0.7, epsilon = 1e-5);
        // Load 1 m low (beyond sag_full): target lambda_min, no progress.
        let mut o = s.update(5.0, 6.0, dt);
        assert_eq!((o.progress, o.overload), (0.0, 1.0));
        for _ in 0..1000 {
            o = s.update(5.0, 6.0, dt);
        }
        assert_relative_eq!(o.scale, 0.4, epsilon = 1e-5);
        // The load back at its reference: the formation opens at a quarter of the rate.
        let o = s.update(6.0, 6.0, dt);
        assert_relative_eq!(o.scale, 0.4 + OPEN_RATE_FRACTION * params.rate_per_s * dt, epsilon = 1e-6);
        assert_eq!((o.progress, o.overload), (1.0, 0.0));
        // Half-way between the sag thresholds: half the response.
        let o = s.update(6.0 - 0.55, 6.0, dt);
        assert_relative_eq!(o.overload, 0.5, epsilon = 1e-5);
        // NaN holds.
        let before = s;
        s.update(f32::NAN, 6.0, dt);
        s.update(5.0, 6.0, f32::INFINITY);
        assert_eq!(s, before);
        // The neutral law never moves.
        let mut n = FormationScale::NEUTRAL;
        assert_eq!(n.update(-100.0, 6.0, dt), ScaleOutput { scale: 1.0, progress: 1.0, overload: 0.0 });
    }

    proptest! {
        #[test]
        fn plan_is_finite_bounded_and_keeps_the_floor(
            r in 0.5f32..6.0, h in 2.0f32..20.0, mass in 0.0f32..40.0, sep in 0.1f32..2.0,
            lens in proptest::collection::vec(2.0f32..12.0, 1..16),
        ) {
            let params = CapacityParams { load_mass_kg: mass, separation_m: sep, ..CapacityParams::default() };
            let p = plan_circle(r, &lens, h, &params).unwrap();
            prop_assert!(p.scale_min >= SCALE_FLOOR && p.scale_min <= 1.0);
            prop_assert!(p.scale >= p.scale_min && p.scale <= 1.0);
            prop_assert!(p.lean_cos_min > 0.0 && p.lean_cos_min <= 1.0);
            prop_assert!(p.capacity_n.is_finite() && p.capacity_n > 0.0);
            let t = Circle { radius_m: r, lengths: &lens };
            if p.scale_min < 1.0 {
                prop_assert!(separated(&t, p.scale, h, sep));
            }
        }
    }
}
