//! The parameter table: every gain, limit, rate and team setting the companion needs, set over
//! MAVLink with `PARAM_SET` (`MAV_PARAM_TYPE_REAL32`; integer parameters carry an integral
//! float) and read back with `PARAM_REQUEST_READ` / `PARAM_REQUEST_LIST`.
//!
//! Each entry has a name (at most 16 characters, the MAVLink limit), a unit, a default (the
//! paper's outdoor experiment, REFERENCE §5, and the project's scenario
//! `scenarios/experiment-3uav.toml`) and a range checked on `PARAM_SET`. Cross-parameter
//! validation (e.g. `r_active > r_safe`) is the crates' own, run when the mission starts
//! ([`Params::dissipative`], [`Params::velocity_loop`]).

use nalgebra::{Unit, Vector2, Vector3};
use vt_cfo::{CfoError, CfoParams, PidGains, ThrustLimits, VelocityLoopParams};
use vt_dissipative::calibration::MIN_COS_LEAN;
use vt_dissipative::wind::WindParams;
use vt_dissipative::{Calibration, CalibrationParams, CapacityParams, ControlError, DissipativeParams, FeasibilityParams, PhaseParams, ShapeParams, TrayParams, VerticalParams};

/// Ground start: the tension each cable is brought to before the survey, as a fraction of the
/// declared share (enough for the observer to see a taut cable, far from lifting).
pub const PRETENSION_FRACTION: f32 = 0.3;
/// Ground start: the load counts as lifted this high above the ground, m.
pub const LIFT_CLEAR_M: f32 = 0.2;
/// Ground start: the lift is abandoned when the ramp rises this much further first, m.
pub const LIFT_EXTRA_M: f32 = 0.5;
/// Ground start: the descent slows to `VT_LIFT_VZ` this high above the ground, m.
pub const TOUCHDOWN_BAND_M: f32 = 1.0;
/// Ground start: settling holds (survey at tension, after arrival, after slack), s.
pub const SETTLE_S: f32 = 2.0;
/// Ground start: the fastest climb or descent of the load reference, m/s.
pub const CLIMB_VZ_CAP_MPS: f32 = 0.5;

/// One parameter's description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamInfo {
    /// MAVLink `param_id`.
    pub name: &'static str,
    /// Default value.
    pub default: f32,
    /// Smallest accepted value.
    pub min: f32,
    /// Largest accepted value.
    pub max: f32,
    /// Only integral values are accepted.
    pub integer: bool,
    /// [`AUTO`] is also accepted: the value is derived aboard from the other parameters
    /// ([`Params`]' accessors say how).
    pub auto: bool,
}

/// The value of an `auto` parameter that asks the companion to derive it (PX4's `-1`
/// convention).
pub const AUTO: f32 = -1.0;

/// The cap on the derived horizontal thrust reserve (`VL_H_RES = -1`), a fraction of `VL_T_MAX`
/// (docs/design.md, "Overload in flight": measured against 0 .. 0.5 on the nominal and overload
/// campaigns of the rigid-body plant).
pub const HORIZONTAL_RESERVE_CAP: f32 = 0.5;
/// The smallest margin the vertical thrust cap keeps over the declared load's share, fraction
/// (`reserve_pull_n`; docs/design.md, "Vertical margin of the thrust cap"): with the capacity
/// law's 5 % alone, a team flying 93 % of its capacity could not climb back from a swing of its
/// load, which sank 1.05-1.21 m below its reference (issue 29's generated seeds 5091, 5195).
pub const VERTICAL_PULL_MARGIN: f32 = 0.15;
/// The derived smallest vertical thrust (`VL_T_MIN = -1`) as a fraction of `VL_T_MAX` (keeps
/// the rotors spinning; PX4's `MPC_THR_MIN` is 12 % of throttle, 5 % of thrust is this project's
/// choice).
pub const THRUST_MIN_FRACTION: f32 = 0.05;
/// The derived height floor (`VT_Z_MIN = -1`): at most this, m ...
pub const Z_MIN_CAP_M: f32 = 1.0;
/// ... or this fraction of the nominal cable `VT_CABLE_L` when that is less.
pub const Z_MIN_CABLE_FRACTION: f32 = 0.5;
/// The derived longest plausible cable (`VT_CABLE_LMAX = -1`) over the nominal `VT_CABLE_L`: room
/// for any length error a real cable has, far from a wrong measurement.
pub const CABLE_LMAX_FACTOR: f32 = 1.5;
/// The derived neighbour timeout (`FS_NBR_TMO = -1`) outside lockstep, s.
pub const NEIGHBOUR_TIMEOUT_S: f32 = 0.5;

const fn real(name: &'static str, default: f32, min: f32, max: f32) -> ParamInfo {
    ParamInfo { name, default, min, max, integer: false, auto: false }
}

const fn int(name: &'static str, default: f32, min: f32, max: f32) -> ParamInfo {
    ParamInfo { name, default, min, max, integer: true, auto: false }
}

/// A real parameter that defaults to [`AUTO`] (derived aboard).
const fn derived(name: &'static str, min: f32, max: f32) -> ParamInfo {
    ParamInfo { name, default: AUTO, min, max, integer: false, auto: true }
}

/// Largest gain accepted by the table (the crates check the rest).
const GAIN_MAX: f32 = 1.0e3;
/// Largest length accepted by the table, m.
const LENGTH_MAX_M: f32 = 1.0e3;
/// Largest altitude reference magnitude, m.
const ALTITUDE_MAX_M: f32 = 1.0e4;
/// Largest thrust or force, N.
const FORCE_MAX_N: f32 = 1.0e4;
/// Largest mass, kg.
const MASS_MAX_KG: f32 = 1.0e4;

macro_rules! params {
    ($($variant:ident => $info:expr, $doc:literal;)*) => {
        /// A parameter of the companion.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[repr(u8)]
        pub enum Param {
            $(#[doc = $doc] $variant,)*
        }

        /// Every parameter, in table order (the MAVLink `param_index`).
        pub const ALL: &[Param] = &[$(Param::$variant,)*];

        /// The descriptions, indexed by `Param as usize`.
        pub const TABLE: &[ParamInfo] = &[$($info,)*];
    };
}

params! {
    Id => int("VT_ID", 0.0, 0.0, (crate::MAX_UAVS - 1) as f32), "This UAV's index in the team, `0..VT_N_UAVS`.";
    NUavs => int("VT_N_UAVS", 3.0, 1.0, crate::MAX_UAVS as f32), "Team size (at most the build's `MAX_UAVS`).";
    SysidBase => int("VT_SYSID_BASE", 1.0, 1.0, 223.0), "MAVLink system id of UAV 0; UAV `j` is `VT_SYSID_BASE + j`.";
    LoadComp => int("VT_LOAD_COMP", 100.0, 1.0, 255.0), "Component id of the load tracker on the own system (`MAV_COMP_ID_CAMERA`).";
    Lockstep => int("VT_LOCKSTEP", 0.0, 0.0, 1.0), "1: each own `LOCAL_POSITION_NED` is one low-level period (processor in the loop); 0: Tickers.";
    HlHz => int("VT_HL_HZ", 50.0, 1.0, 1000.0), "High-level (tube + springs) rate, Hz.";
    LlHz => int("VT_LL_HZ", 500.0, 1.0, 2000.0), "Low-level (velocity loop + CFO) rate, Hz; a multiple of `VT_HL_HZ`.";
    FsOwnTmo => real("FS_OWN_TMO", 0.1, 0.001, 10.0), "Own state older than this: hold, s.";
    FsLoadTmo => real("FS_LOAD_TMO", 0.5, 0.001, 10.0), "Load state older than this: hold, s.";
    FsNbrTmo => derived("FS_NBR_TMO", 0.001, 10.0), "A neighbour's position older than this is stale, s (-1: half a high-level period in lockstep, where the simulator's link model relays only fresh positions; 0.5 s otherwise).";
    FsNbrAct => int("FS_NBR_ACT", 1.0, 0.0, 1.0), "Stale neighbour: 1 the team holds (failsafe), 0 drop its springs and fly on.";
    FsResume => real("FS_RESUME", 1.0, 0.0, 10.0), "Team hold: resume after this long without any alarm, s (rounded to high-level steps).";
    K1 => real("VT_K1", 0.3, 0.0, GAIN_MAX), "Passing gain `k1`, 1/s (eq:2-13).";
    K2 => real("VT_K2", 0.1, 0.0, GAIN_MAX), "Spring gain `k2`, 1/s (eq:2-5); a team above ten flies `k2 * 10 / n` (`team_spring_gain`), an airframe slower than `VL_ACT_LAG` 0.08 s `k2 * 0.08 / lag` (`lag_spring_scale`).";
    K3 => real("VT_K3", 1.0, 0.0, GAIN_MAX), "Tube barrier gain `k3`, m^2/s (eq:2-15-1).";
    VMax => real("VT_V_MAX", 1.0, 0.0, 50.0), "Velocity limit `v_m`, m/s (eq:2-21).";
    RSafe => real("VT_R_SAFE", 0.5, 0.0, LENGTH_MAX_M), "Tube barrier safety radius `r_s`, m.";
    RActive => real("VT_R_ACT", 1.2, 0.0, LENGTH_MAX_M), "Tube barrier activation radius `r_a`, m.";
    TrayH => real("VT_TRAY_H", 4.0, 0.0, LENGTH_MAX_M), "Tray height above the load `H`, m (eq:2-4).";
    TrayHMin => real("VT_TRAY_HMIN", 0.5, 0.0, LENGTH_MAX_M), "Projection floor of `z_i - z_l`, m.";
    LoadZRef => real("VT_LOAD_ZREF", 3.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Load altitude reference, m (ENU up).";
    LoadKg => real("VT_LOAD_KG", 3.06, 0.0, MASS_MAX_KG), "Declared load mass, kg (take-off calibration and pre-flight check).";
    CableK => real("VT_CABLE_K", 800.0, 0.0, 1.0e7), "Nominal cable stiffness, N/m (static stretch at take-off).";
    CableLMax => derived("VT_CABLE_LMAX", 0.0, LENGTH_MAX_M), "Longest plausible cable, m (take-off calibration refuses longer; -1: 1.5 `VT_CABLE_L`).";
    CableRated => real("VT_CABLE_RATED", 30.0, 0.0, FORCE_MAX_N), "Rated cable tension, N (pre-flight check).";
    MarginMin => real("VT_MARGIN_MIN", 0.01, -0.99, 10.0), "Required vertical-force margin of the pre-flight check, fraction.";
    ThrRes => real("VT_THR_RES", vt_dissipative::feasibility::DEFAULT_THRUST_RESERVE, 0.0, 0.5), "Fraction of `VL_T_MAX` the pre-flight check keeps for control: the rotors are rated at `(1 - VT_THR_RES) VL_T_MAX`.";
    Kz => real("VT_KZ", 1.0, 0.0, GAIN_MAX), "Altitude gain `k_z`, 1/s.";
    VzMax => real("VT_VZ_MAX", 1.0, 0.0, 50.0), "Vertical speed limit, m/s.";
    ZMin => derived("VT_Z_MIN", 0.0, LENGTH_MAX_M), "Smallest UAV height above the load reference, m; also the shortest cable the calibration accepts (-1: 1 m, or half `VT_CABLE_L` when shorter).";
    KShare => real("VT_K_SHARE", 0.0, 0.0, GAIN_MAX), "Load-sharing gain `k_T`, (m/s)/N.";
    KLoadAlt => real("VT_K_LALT", 0.0, 0.0, GAIN_MAX), "Load-altitude gain `k_L` of the sharing integrator, 1/s.";
    DzMax => real("VT_DZ_MAX", 0.0, 0.0, LENGTH_MAX_M), "Bound on the sharing offset, m.";
    KpX => real("VL_KP_X", 2.0, 0.0, GAIN_MAX), "Velocity loop `Kp`, east, 1/s (eq:2-3).";
    KpY => real("VL_KP_Y", 2.0, 0.0, GAIN_MAX), "Velocity loop `Kp`, north, 1/s.";
    KpZ => real("VL_KP_Z", 2.0, 0.0, GAIN_MAX), "Velocity loop `Kp`, up, 1/s.";
    KiX => real("VL_KI_X", 0.1, 0.0, GAIN_MAX), "Velocity loop `Ki`, east, 1/s^2.";
    KiY => real("VL_KI_Y", 0.1, 0.0, GAIN_MAX), "Velocity loop `Ki`, north, 1/s^2.";
    KiZ => real("VL_KI_Z", 0.1, 0.0, GAIN_MAX), "Velocity loop `Ki`, up, 1/s^2.";
    KdX => real("VL_KD_X", 0.1, 0.0, 1.0), "Velocity loop `Kd`, east.";
    KdY => real("VL_KD_Y", 0.1, 0.0, 1.0), "Velocity loop `Kd`, north.";
    KdZ => real("VL_KD_Z", 0.1, 0.0, 1.0), "Velocity loop `Kd`, up.";
    ILimX => real("VL_ILIM_X", 2.0, 0.0, 100.0), "Integral bound `|Ki int e_v|`, east, m/s^2.";
    ILimY => real("VL_ILIM_Y", 2.0, 0.0, 100.0), "Integral bound, north, m/s^2.";
    ILimZ => real("VL_ILIM_Z", 2.0, 0.0, 100.0), "Integral bound, up, m/s^2.";
    ThrustMin => derived("VL_T_MIN", 0.0, FORCE_MAX_N), "Smallest vertical thrust, N (-1: 5 % of `VL_T_MAX`).";
    ThrustMax => real("VL_T_MAX", 30.0, 0.0, FORCE_MAX_N), "Thrust limit, N (collective 1 in `SET_ATTITUDE_TARGET`).";
    TiltMax => real("VL_TILT_MAX", core::f32::consts::FRAC_PI_6, 0.0, 1.57), "Tilt limit, rad.";
    CfoMu => real("VL_CFO_MU", 15.0, 0.0, 1.0e4), "CFO bandwidth `mu`, rad/s (REFERENCE §4).";
    ActLag => real("VL_ACT_LAG", 0.0, 0.0, 1.0), "Time constant of the thrust the autopilot realises, as the CFO models it, s (0: thrust = command).";
    CmdTau => real("VL_CMD_TAU", 0.0, 0.0, 1.0), "Time constant of the low-pass on the thrust demand, s (0: none; docs/design.md, \"Thrust command filter\").";
    Mass => real("VL_MASS", 1.47, 0.0, 1.0e3), "UAV mass, kg.";
    Yaw => real("VL_YAW", 0.0, -3.15, 3.15), "Heading held while transporting, rad (NED yaw: 0 north, pi/2 east).";
    CapOn => int("VT_CAP_ON", 1.0, 0.0, 1.0), "1: capacity-aware formation (issue 15) from `VT_LOAD_KG` and `VT_CABLE_RATED`; 0: the paper's controller.";
    CapMargin => real("VT_CAP_MRG", 0.05, 0.0, 10.0), "Capacity margin the formation is chosen for.";
    SepMin => real("VT_SEP_MIN", 0.9, 0.0, LENGTH_MAX_M), "Smallest UAV-UAV distance the adapted formation keeps, m.";
    CapRate => real("VT_CAP_RATE", 0.2, 0.0, 100.0), "Largest closing rate of the formation scale, 1/s (opens at a quarter of it).";
    SagLo => real("VT_SAG_LO", 0.3, 0.0, LENGTH_MAX_M), "Load sag where the overload response begins, m.";
    SagHi => real("VT_SAG_HI", 0.8, 0.0, LENGTH_MAX_M), "Load sag where the overload response is complete, m.";
    HReserve => derived("VL_H_RES", 0.0, 0.99), "Fraction of `VL_T_MAX` kept for the horizontal thrust when the vertical saturates (0: vertical priority; -1: as much as the airframe affords with its weight plus `VT_CABLE_RATED`, or the declared share when less, under the vertical cap, at most 0.5, `ThrustLimits::rated_pull_reserve`).";
    CalN => int("VT_CAL_N", 100.0, 1.0, 100000.0), "Take-off survey: take-off positions averaged over this many samples per source before `MISSION_START` (1: the last sample; docs/design.md, \"Take-off survey\").";
    CableL => real("VT_CABLE_L", 3.0, 0.0, LENGTH_MAX_M), "Nominal length of this UAV's cable, m (derives `VT_Z_MIN` and `VT_CABLE_LMAX`; the calibration measures the true one).";
    WindDecl => derived("VT_WIND_DECL", 0.0, 100.0), "Declared steady wind at the site for the mission, m/s (forecast or measured; -1: none declared, no wind check at the start). Refused at `MISSION_START` above the team's wind capacity (`vt_dissipative::wind`).";
    WindGust => real("VT_WIND_GUST", 0.0, 0.0, 100.0), "Gust margin added to `VT_WIND_DECL` in the start check, m/s (a ground start also measures one over its hover, two standard deviations of the airspeed its observer saw: the larger is checked; docs/design.md, \"The gusts the hover sees\").";
    WindVp => real("VT_WIND_VP", 0.3, 0.0, 50.0), "Ground speed the team must keep into the wind to make progress, m/s (the wind check's `v_p`).";
    DragQ => real("VL_DRAG_Q", 0.0103, 0.0, 100.0), "Quadratic horizontal body drag of this UAV `c_q`, N/(m/s)^2 (`rho C_dA / 2`; default: the 1.47 kg experiment airframe, docs/plant.md).";
    DragL => real("VL_DRAG_L", 0.74, 0.0, 1.0e3), "Linear horizontal rotor drag of this UAV at loaded hover `c_l`, N/(m/s) (default: the 1.47 kg experiment airframe carrying its share of 3.06 kg).";
    LoadCda => real("VT_LOAD_CDA", 0.3, 0.0, 1.0e3), "Drag area of the load `C_dA`, m^2.";
    BodyR => real("VT_BODY_R", 0.0, 0.0, 5.0), "Radius of the sphere that bounds this UAV (rotor tips and guards), m (0: a point, the paper's controller; the 1.47 kg experiment airframe measures 0.40 with a 0.03 m guard). Above 0 it turns on the separation barrier at `2 VT_BODY_R + VT_CLR_MIN` and raises `VT_R_SAFE` and `VT_SEP_MIN` to what the body needs (docs/design.md, \"Envelopes and clearances\").";
    ClrMin => real("VT_CLR_MIN", 0.2, 0.0, 5.0), "Clearance kept between surfaces (UAV to UAV, UAV to tube boundary), m.";
    Start => int("VT_START", 0.0, 0.0, 1.0), "Mission start: 0 in the air, at the take-off formation with taut cables (the paper); 1 from the ground: the load rests on the ground, the UAVs hover low with slack cables; take-off, tension, lift and climb come before the transport, descent, set-down and slack after it (docs/design.md, \"Lift-off and set-down\").";
    TkoS => real("VT_TKO_S", 8.0, 0.0, 600.0), "Ground start: length of the take-off phase, s.";
    LiftVz => real("VT_LIFT_VZ", 0.1, 0.01, 5.0), "Ground start: lift and touchdown speed of the load reference, m/s (the tension build-up climbs at twice it).";
    SlackM => real("VT_SLACK", 0.5, 0.05, 10.0), "Ground start: how far below taut the UAVs fly with slack cables (take-off, slack), m.";
    EndTol => real("VT_END_TOL", 1.0, 0.0, 100.0), "Arrival: the load within this arc length of the tube's end, m (ground start: the descent follows).";
    Ctrl => int("VT_CTRL", 0.0, 0.0, 1.0), "High-level controller: 0 the paper's dissipative controller; 1 traditional virtual-tube control (the baseline, REFERENCE §2: `VT_K1`..`VT_R_ACT` are its gains, no springs).";
    LoadGz => real("VT_LOAD_GZ", 0.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Air start: the load's altitude resting on the ground, m (ENU up, the local frame's origin on the ground: the load's half-height), where a set-down in a wind the team cannot hold puts it (a ground start measures it).";
    Shape => int("VT_SHAPE", 0.0, 0.0, 1.0), "Formation shape: 0 the take-off ring (the paper's rest lengths); 1 shaped to the tube ahead, a stadium of the ring's perimeter as narrow as the narrowest section ahead allows (extension; `vt_dissipative::shape`, docs/design.md \"A formation shaped to the tube\").";
    ShapeMrg => real("VT_SHAPE_MRG", 0.5, 0.0, LENGTH_MAX_M), "Shaped formation: room kept between the nodes and the tube barrier's safety radius, m.";
    ShapeAhd => real("VT_SHAPE_AHD", 6.0, 0.0, LENGTH_MAX_M), "Shaped formation: how far past the formation's front the tube's width is looked at, m.";
    ShapeTeam => int("VT_SHAPE_TEAM", 1.0, 0.0, 1.0), "Shaped formation: 1 the team keeps the tube together (each UAV's keeping term is the mean of every node's plus half its own; extension, `vt_dissipative::keeping`, docs/design.md \"The tube keeps the team, not one node\"); 0 each node its own, as the paper.";
    PrMap => int("PR_MAP", 0.0, 0.0, 1.0), "Onboard map (issue 28): 0 the tube is given before the flight; 1 unknown: the companion maps its range scans and the team's, and the team re-plans its tube in flight on the world `PR_X0`..`PR_Y1` to `PR_GOAL_X/Y` (a build without the `perception` feature refuses the start, refusal 11).";
    PrX0 => real("PR_X0", 0.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Onboard map: the world's west edge, m (ENU x).";
    PrX1 => real("PR_X1", 50.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Onboard map: the world's east edge, m.";
    PrY0 => real("PR_Y0", -10.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Onboard map: the world's south edge, m (ENU y).";
    PrY1 => real("PR_Y1", 10.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Onboard map: the world's north edge, m.";
    PrCell => real("PR_CELL", 0.25, 0.01, 10.0), "Onboard map: cell side, m (the world must fit `perception::MAP_CELLS` cells).";
    PrGoalX => real("PR_GOAL_X", 50.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Re-planning: the mission's goal, ENU x, m.";
    PrGoalY => real("PR_GOAL_Y", 0.0, -ALTITUDE_MAX_M, ALTITUDE_MAX_M), "Re-planning: the mission's goal, ENU y, m.";
    PrPeriod => int("PR_PERIOD_MS", 500.0, 1.0, 60000.0), "Re-planning: the scheduled re-plan period, ms.";
    PrHalfW => real("PR_HALF_W", 0.9, 0.01, LENGTH_MAX_M), "Re-planning: the half-width every section of a planned tube must have, m (`vt_plan::PlanParams::need_half_width_m`).";
    PrMargin => real("PR_MARGIN", 0.4, 0.0, LENGTH_MAX_M), "Re-planning: kept between a planned tube and every obstacle, m.";
    PrMaxHw => real("PR_MAX_HW", 5.5, 0.01, LENGTH_MAX_M), "Re-planning: the widest half-width of a planned tube, m.";
    PrLattice => real("PR_LATTICE", 0.25, 0.01, LENGTH_MAX_M), "Re-planning: the search lattice's spacing, m.";
    PrKw => real("PR_K_W", 0.5, 0.0, GAIN_MAX), "Re-planning: the weight of narrowness in the search's edge cost `k_w` (0: shortest path).";
}

/// Number of parameters.
pub const COUNT: usize = TABLE.len();

impl Param {
    /// The parameter's description.
    pub fn info(self) -> ParamInfo {
        TABLE.get(self as usize).copied().unwrap_or(real("?", 0.0, 0.0, 0.0))
    }

    /// The parameter called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        ALL.iter().copied().find(|p| p.info().name == name)
    }

    /// The parameter at `param_index`, if any.
    pub fn from_index(index: usize) -> Option<Self> {
        ALL.get(index).copied()
    }

    /// One of the onboard map's `PR_*` parameters (the table's last).
    pub fn is_map(self) -> bool {
        self as u8 >= Param::PrMap as u8
    }
}

/// Why a `PARAM_SET` was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamError {
    /// No parameter has this name.
    UnknownName,
    /// NaN, infinite, out of range, or not integral for an integer parameter.
    BadValue,
    /// Parameters are locked while the mission runs.
    Locked,
}

/// The current values.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    values: [f32; COUNT],
}

impl Default for Params {
    fn default() -> Self {
        Self::new()
    }
}

impl Params {
    /// Every parameter at its default.
    #[allow(clippy::indexing_slicing)] // const evaluation: an out-of-range index fails the build
    pub const fn new() -> Self {
        let mut values = [0.0; COUNT];
        let mut k = 0;
        while k < COUNT {
            values[k] = TABLE[k].default;
            k += 1;
        }
        Self { values }
    }

    /// Value of `p`.
    #[inline]
    pub fn get(&self, p: Param) -> f32 {
        self.values.get(p as usize).copied().unwrap_or(0.0)
    }

    /// Integer value of `p` (integer parameters are integral by construction).
    #[inline]
    pub fn get_u32(&self, p: Param) -> u32 {
        self.get(p) as u32
    }

    /// Sets `p` after the range check.
    ///
    /// # Errors
    /// [`ParamError::BadValue`].
    pub fn set(&mut self, p: Param, value: f32) -> Result<(), ParamError> {
        let info = p.info();
        let integral = !info.integer || libm::truncf(value) == value;
        let auto = info.auto && value == AUTO;
        if !(auto || (value.is_finite() && value >= info.min && value <= info.max && integral)) {
            return Err(ParamError::BadValue);
        }
        if let Some(slot) = self.values.get_mut(p as usize) {
            *slot = value;
        }
        Ok(())
    }

    /// This UAV's MAVLink system id (`VT_SYSID_BASE + VT_ID`).
    pub fn own_system_id(&self) -> u8 {
        self.system_id_of(self.get_u32(Param::Id) as usize)
    }

    /// MAVLink system id of UAV `j`.
    pub fn system_id_of(&self, j: usize) -> u8 {
        (self.get_u32(Param::SysidBase) as usize).saturating_add(j).min(usize::from(u8::MAX)) as u8
    }

    /// What the take-off calibration needs (`vt_dissipative::calibrate`): the declared load,
    /// the nominal stiffness, the plausible cable range `(VT_Z_MIN, VT_CABLE_LMAX]`.
    pub fn calibration(&self) -> CalibrationParams {
        CalibrationParams {
            load_mass_kg: self.get(Param::LoadKg),
            stiffness_n_per_m: self.get(Param::CableK),
            min_length_m: self.min_height_m(),
            max_length_m: self.max_cable_m(),
            min_cos_lean: MIN_COS_LEAN,
        }
    }

    /// What the pre-flight check needs (`vt_dissipative::feasibility::check`), for the
    /// formation's lean `cos_lean` (cos of the angle from vertical).
    pub fn feasibility(&self, cos_lean: f32) -> FeasibilityParams {
        FeasibilityParams {
            n_uavs: self.get_u32(Param::NUavs) as usize,
            load_mass_kg: self.get(Param::LoadKg),
            uav_mass_kg: self.get(Param::Mass),
            thrust_max_n: self.get(Param::ThrustMax),
            tilt_max_rad: self.get(Param::TiltMax),
            cable_rated_n: self.get(Param::CableRated),
            cos_lean,
            min_margin: self.get(Param::MarginMin),
            thrust_reserve: self.get(Param::ThrRes),
        }
    }

    /// What the wind capacity law needs (`vt_dissipative::wind`) at the take-off lean
    /// `cos_lean` (validated by the law).
    pub fn wind(&self, cos_lean: f32) -> WindParams {
        WindParams {
            n_uavs: self.get_u32(Param::NUavs) as usize,
            uav_mass_kg: self.get(Param::Mass),
            thrust_max_n: self.get(Param::ThrustMax),
            tilt_max_rad: self.get(Param::TiltMax),
            uav_drag_quad_n_per_mps2: self.get(Param::DragQ),
            uav_drag_lin_n_per_mps: self.get(Param::DragL),
            load_mass_kg: self.get(Param::LoadKg),
            load_drag_area_m2: self.get(Param::LoadCda),
            cable_rated_n: self.get(Param::CableRated),
            cos_lean,
            progress_mps: self.get(Param::WindVp),
        }
    }

    /// The declared steady wind and its gust margin for the start check, m/s; `None` when no
    /// wind is declared (`VT_WIND_DECL = -1`).
    pub fn declared_wind_mps(&self) -> Option<(f32, f32)> {
        let w = self.get(Param::WindDecl);
        (w >= 0.0).then(|| (w, self.get(Param::WindGust)))
    }

    /// The high-level controller's parameters with the take-off calibration `cal` (validated
    /// by `vt-dissipative`).
    ///
    /// # Errors
    /// The crate's [`ControlError`] naming the field.
    pub fn dissipative(&self, cal: &Calibration) -> Result<DissipativeParams, ControlError> {
        let g = |p| self.get(p);
        let params = DissipativeParams {
            k1: g(Param::K1),
            // An airframe slower than the paper's flies a softer formation (`lag_spring_scale`).
            k2: g(Param::K2) * vt_dissipative::springs::lag_spring_scale(g(Param::ActLag)),
            heave_spring_share: vt_dissipative::springs::heave_spring_share(g(Param::ActLag)),
            k3: g(Param::K3),
            v_max_mps: g(Param::VMax),
            r_safe_m: self.r_safe_m(),
            r_active_m: g(Param::RActive),
            separation: self.separation_spec(),
            // Set at the arming from the capacity plan (flight::arming, capacity::dashpot_gain).
            dashpot: 0.0,
            tray: self.tray(),
            vertical: VerticalParams {
                load_altitude_ref_m: g(Param::LoadZRef),
                cable_length_m: cal.cable_length_m,
                cable_stretch_m: cal.stretch_m,
                kz_per_s: g(Param::Kz),
                vz_max_mps: g(Param::VzMax),
                min_height_m: self.min_height_m(),
                tension_share_n: cal.tension_share_n,
                share_gain_mps_per_n: g(Param::KShare),
                load_altitude_gain_per_s: g(Param::KLoadAlt),
                share_offset_max_m: g(Param::DzMax),
            },
        };
        params.validate()?;
        Ok(params)
    }

    /// True for a ground start (`VT_START = 1`).
    pub fn ground_start(&self) -> bool {
        self.get_u32(Param::Start) == 1
    }

    /// The ground sequence's parameters with the load resting at `ground_z_m` (validated by
    /// `vt-dissipative`): climb and descent at half `VT_VZ_MAX` (at most 0.5 m/s), the tension
    /// build-up at twice `VT_LIFT_VZ` to [`PRETENSION_FRACTION`] of the declared share
    /// `VT_LOAD_KG g / VT_N_UAVS`.
    ///
    /// # Errors
    /// The crate's [`ControlError`] naming the field.
    pub fn phases(&self, ground_z_m: f32) -> Result<PhaseParams, ControlError> {
        let g = |p| self.get(p);
        let p = PhaseParams {
            ground_z_m,
            transport_z_m: g(Param::LoadZRef),
            slack_m: g(Param::SlackM),
            takeoff_s: g(Param::TkoS),
            tension_vz_mps: 2.0 * g(Param::LiftVz),
            pretension_n: PRETENSION_FRACTION * self.declared_share_n(),
            lift_vz_mps: g(Param::LiftVz),
            climb_vz_mps: (0.5 * g(Param::VzMax)).min(CLIMB_VZ_CAP_MPS),
            lift_clear_m: LIFT_CLEAR_M,
            lift_extra_m: LIFT_EXTRA_M,
            touchdown_band_m: TOUCHDOWN_BAND_M,
            settle_s: SETTLE_S,
        };
        p.validate()?;
        Ok(p)
    }

    /// The altitude law before the arming of a ground start: the nominal cable `VT_CABLE_L`,
    /// no stretch, no load sharing.
    pub fn nominal_vertical(&self) -> VerticalParams {
        VerticalParams {
            load_altitude_ref_m: self.get(Param::LoadZRef),
            cable_length_m: self.get(Param::CableL),
            cable_stretch_m: 0.0,
            kz_per_s: self.get(Param::Kz),
            vz_max_mps: self.get(Param::VzMax),
            min_height_m: self.min_height_m(),
            tension_share_n: 0.0,
            share_gain_mps_per_n: 0.0,
            load_altitude_gain_per_s: 0.0,
            share_offset_max_m: 0.0,
        }
    }

    /// The tube-shaped formation's settings, `None` when `VT_SHAPE` is 0 (the paper's ring).
    pub fn shape(&self) -> Option<ShapeParams> {
        (self.get_u32(Param::Shape) == 1).then(|| ShapeParams { margin_m: self.get(Param::ShapeMrg), ahead_m: self.get(Param::ShapeAhd) })
    }

    /// Whether the shaped formation keeps the tube as a team (`VT_SHAPE_TEAM` 1 with `VT_SHAPE`
    /// 1; `vt_dissipative::keeping::team_keeping_velocity`).
    pub fn team_keeping(&self) -> bool {
        self.get_u32(Param::Shape) == 1 && self.get_u32(Param::ShapeTeam) == 1
    }

    /// The capacity-aware formation's parameters (validated by `vt-dissipative`; issue 15).
    ///
    /// # Errors
    /// The crate's [`ControlError`] naming the field.
    pub fn capacity(&self) -> Result<CapacityParams, ControlError> {
        let g = |p| self.get(p);
        let params = CapacityParams {
            load_mass_kg: if self.get_u32(Param::CapOn) == 1 { g(Param::LoadKg) } else { 0.0 },
            uav_capacity_n: g(Param::CableRated),
            margin: g(Param::CapMargin),
            separation_m: g(Param::SepMin).max(self.formation_separation_m()),
            rate_per_s: g(Param::CapRate),
            sag_start_m: g(Param::SagLo),
            sag_full_m: g(Param::SagHi),
        };
        params.validate()?;
        Ok(params)
    }

    /// The virtual tray.
    pub fn tray(&self) -> TrayParams {
        TrayParams { height_above_load_m: self.get(Param::TrayH), min_height_above_load_m: self.get(Param::TrayHMin) }
    }

    /// The velocity loop's parameters (validated by `vt-cfo`); the CFO period is `1 / VT_LL_HZ`.
    ///
    /// # Errors
    /// The crate's [`CfoError`].
    pub fn velocity_loop(&self) -> Result<VelocityLoopParams, CfoError> {
        let g = |p| self.get(p);
        let v = |x, y, z| Vector3::new(g(x), g(y), g(z));
        let gains = PidGains { kp: v(Param::KpX, Param::KpY, Param::KpZ), ki: v(Param::KiX, Param::KiY, Param::KiZ), kd: v(Param::KdX, Param::KdY, Param::KdZ) };
        let limits = ThrustLimits::new(self.thrust_min_n(), g(Param::ThrustMax), g(Param::TiltMax))?.with_horizontal_reserve(self.horizontal_reserve())?;
        let cfo = CfoParams::new(g(Param::CfoMu), g(Param::Mass), self.low_level_dt_s())?;
        VelocityLoopParams::new(gains, limits, v(Param::ILimX, Param::ILimY, Param::ILimZ), cfo)?.with_actuator_lag(g(Param::ActLag))?.with_command_filter(g(Param::CmdTau))
    }

    /// High-level period `1 / VT_HL_HZ`, s (as host-sim computes it: `1.0 / hz as f32`).
    pub fn high_level_dt_s(&self) -> f32 {
        1.0 / self.get(Param::HlHz)
    }

    /// Low-level period `1 / VT_LL_HZ`, s.
    pub fn low_level_dt_s(&self) -> f32 {
        1.0 / self.get(Param::LlHz)
    }

    /// Low-level periods per high-level period, if `VT_LL_HZ` is a multiple of `VT_HL_HZ`.
    pub fn low_per_high(&self) -> Option<u32> {
        let (hl, ll) = (self.get_u32(Param::HlHz), self.get_u32(Param::LlHz));
        (hl > 0 && ll % hl == 0).then(|| ll / hl)
    }

    /// The heading held while transporting, as an ENU unit vector: NED yaw `psi` is
    /// `(sin psi, cos psi)` in (east, north). Trigonometry here runs once, at mission start.
    pub fn heading(&self) -> Unit<Vector2<f32>> {
        let yaw = self.get(Param::Yaw);
        let (sin, cos) = vt_fpu::sin_cos(yaw).unwrap_or((0.0, 1.0));
        let h = Vector2::new(sin, cos);
        Unit::try_new(h, 1e-6).unwrap_or_else(|| Unit::new_unchecked(Vector2::new(0.0, 1.0)))
    }

    /// Timeout of `p` (one of the `FS_*` parameters) in milliseconds; `FS_NBR_TMO` as
    /// [`Self::neighbour_timeout_ms`].
    pub fn timeout_ms(&self, p: Param) -> u32 {
        if p == Param::FsNbrTmo {
            return self.neighbour_timeout_ms();
        }
        (self.get(p) * 1000.0) as u32
    }

    /// The value of `p` unless it is [`AUTO`].
    fn explicit(&self, p: Param) -> Option<f32> {
        let v = self.get(p);
        (v != AUTO || !p.info().auto).then_some(v)
    }

    /// The altitude law's height floor and the shortest cable the calibration accepts
    /// (`VT_Z_MIN`), m: derived as `min(1, 0.5 VT_CABLE_L)`.
    pub fn min_height_m(&self) -> f32 {
        self.explicit(Param::ZMin).unwrap_or_else(|| {
            let half = Z_MIN_CABLE_FRACTION * self.get(Param::CableL);
            if half < Z_MIN_CAP_M { half } else { Z_MIN_CAP_M }
        })
    }

    /// The longest plausible cable (`VT_CABLE_LMAX`), m: derived as `1.5 VT_CABLE_L`.
    pub fn max_cable_m(&self) -> f32 {
        self.explicit(Param::CableLMax).unwrap_or_else(|| CABLE_LMAX_FACTOR * self.get(Param::CableL))
    }

    /// The smallest vertical thrust (`VL_T_MIN`), N: derived as 5 % of `VL_T_MAX`.
    pub fn thrust_min_n(&self) -> f32 {
        self.explicit(Param::ThrustMin).unwrap_or_else(|| THRUST_MIN_FRACTION * self.get(Param::ThrustMax))
    }

    /// Horizontal centre distance the separation barrier keeps between UAVs, m:
    /// `2 VT_BODY_R + VT_CLR_MIN`, so that the bodies keep `VT_CLR_MIN` between their surfaces;
    /// 0 (off, the paper's controller) when `VT_BODY_R` is 0.
    pub fn separation_m(&self) -> f32 {
        vt_dissipative::separation::separation_pole_band(self.get(Param::BodyR), self.get(Param::ClrMin), false).pole_m
    }

    /// The capacity-aware formation's separation floor from the body, m: [`Self::separation_m`]
    /// plus [`vt_dissipative::separation::FORMATION_GUARD_M`], so that the pairs keep the floor
    /// where the UAVs fly and not only where their nodes lie; 0 when `VT_BODY_R` is 0.
    pub fn formation_separation_m(&self) -> f32 {
        let sep = self.separation_m();
        if sep > 0.0 { sep + vt_dissipative::separation::FORMATION_GUARD_M } else { 0.0 }
    }

    /// The separation barrier flown ([`vt_dissipative::separation::separation_pole_band`]): its
    /// pole at [`Self::separation_m`] with a 0.3 m band, or with the formation shaped to the tube
    /// (`VT_SHAPE` 1) the contact barrier, its pole at contact (`2 VT_BODY_R`), its band
    /// `VT_CLR_MIN`, on the 3-D distance. The full barrier against the
    /// shaped formation's neighbours, 1.2-1.5 m apart inside its band, slowed the paper mission
    /// to a crawl (docs/design.md, "A formation shaped to the tube"); the contact barrier is
    /// zero while a pair keeps the floor (docs/design.md, "The contact barrier").
    pub fn separation_spec(&self) -> vt_dissipative::separation::SeparationSpec {
        vt_dissipative::separation::separation_pole_band(self.get(Param::BodyR), self.get(Param::ClrMin), self.get_u32(Param::Shape) == 1)
    }

    /// The tube barrier's safety radius flown, m: `VT_R_SAFE`, raised to
    /// `VT_BODY_R + VT_CLR_MIN` so that the body keeps `VT_CLR_MIN` from the boundary.
    pub fn r_safe_m(&self) -> f32 {
        let body = self.get(Param::BodyR);
        let r = self.get(Param::RSafe);
        if body > 0.0 { r.max(body + self.get(Param::ClrMin)) } else { r }
    }

    /// The horizontal thrust reserve (`VL_H_RES`), fraction of `VL_T_MAX`: derived by
    /// [`ThrustLimits::rated_pull_reserve`] from `VL_MASS`, [`Self::reserve_pull_n`] and
    /// `VL_T_MAX`, capped at [`HORIZONTAL_RESERVE_CAP`].
    pub fn horizontal_reserve(&self) -> f32 {
        self.explicit(Param::HReserve).unwrap_or_else(|| {
            ThrustLimits::rated_pull_reserve(self.get(Param::Mass), self.reserve_pull_n(), self.get(Param::ThrustMax), HORIZONTAL_RESERVE_CAP)
        })
    }

    /// One UAV's share of the declared load's weight, `VT_LOAD_KG g / VT_N_UAVS`, N.
    pub fn declared_share_n(&self) -> f32 {
        self.get(Param::LoadKg) * vt_cfo::GRAVITY_MPS2 / self.get(Param::NUavs).max(1.0)
    }

    /// The cable pull the vertical cap keeps beyond the UAV's weight, N: `VT_CABLE_RATED`,
    /// or the declared load's share with a margin, `(1 + max(VT_CAP_MRG,
    /// VERTICAL_PULL_MARGIN)) VT_LOAD_KG g / VT_N_UAVS`, when that is less (issue 29;
    /// docs/design.md, "Overload in flight": rotors weaker than their cable then still keep a
    /// horizontal reserve; "Vertical margin of the thrust cap").
    pub fn reserve_pull_n(&self) -> f32 {
        let rated = self.get(Param::CableRated);
        let margin = vt_fpu::max(self.get(Param::CapMargin), VERTICAL_PULL_MARGIN);
        let share = (1.0 + margin) * self.declared_share_n();
        if share > 0.0 && share < rated { share } else { rated }
    }

    /// A neighbour's position is stale after this long (`FS_NBR_TMO`), ms: derived as half a
    /// high-level period in lockstep (the simulator's link model relays, once per high-level
    /// period, only the positions it holds fresh: the companion then uses exactly those;
    /// docs/design.md, "Team failsafe"), 0.5 s otherwise.
    pub fn neighbour_timeout_ms(&self) -> u32 {
        let s = match self.explicit(Param::FsNbrTmo) {
            Some(s) => s,
            None if self.get_u32(Param::Lockstep) == 1 => 0.5 / self.get(Param::HlHz),
            None => NEIGHBOUR_TIMEOUT_S,
        };
        (s * 1000.0) as u32
    }
}

#[cfg(test)]
#[path = "params_tests.rs"]
mod tests;
