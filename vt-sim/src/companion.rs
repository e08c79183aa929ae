//! The firmware's companion on the host: the one place a scenario becomes the companion's
//! parameter set and tube upload, and companions with pooled tube storage.
//!
//! Every backend flies `vt_companion`'s logic with the parameters [`params_for`] makes: the SIL
//! team sets them directly ([`crate::mission::CompanionTeam`]), the twin and the firmware in
//! QEMU receive them as `PARAM_SET` ([`crate::lockstep::configure`]). What the companion can derive
//! from its own parameters (the horizontal reserve, `VT_Z_MIN`, `VT_CABLE_LMAX`, `VL_T_MIN`,
//! `FS_NBR_TMO`) is sent as [`AUTO`] and derived aboard (`vt_companion::params`).

use crate::models::UavModel;
use crate::scenario::{Scenario, StaleNeighbour};
use crate::sim::{ControllerKind, SimError};
use vt_companion::perception::{Perception, PlannerSpace};
use vt_companion::replanning::Replanning;
use vt_companion::{Companion, CompanionTube, Item, Param, Params, ReplanSlot, AUTO, MAX_UAVS};
use vt_dissipative::TrayParams;

/// System id of UAV 0 (`VT_SYSID_BASE`).
pub const SYSID_BASE: u8 = 1;
/// Component id of the load tracker on every UAV (`VT_LOAD_COMP`, `MAV_COMP_ID_CAMERA`).
pub const LOAD_COMPONENT_ID: u8 = 100;
/// Own-state timeout the simulator configures in lockstep (`FS_OWN_TMO`), s: ten low-level
/// periods at 500 Hz.
pub const OWN_TIMEOUT_S: f32 = 0.02;
/// Own-state timeout on the wall clock (`--realtime`, a real link), s: the firmware's default.
pub const OWN_TIMEOUT_REALTIME_S: f32 = 0.1;
/// Load-state timeout the simulator configures (`FS_LOAD_TMO`), s.
pub const LOAD_TIMEOUT_S: f32 = 0.5;

/// A tube waypoint as it crosses the wire (`MISSION_ITEM_INT`, docs/protocol.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireWaypoint {
    /// North, 1e-4 m.
    pub x: i32,
    /// East, 1e-4 m.
    pub y: i32,
    /// Left half-width, m.
    pub w_left_m: f32,
    /// Right half-width, m.
    pub w_right_m: f32,
}

impl WireWaypoint {
    /// Item `seq` of the mission upload.
    pub fn item(&self, seq: u16) -> Item {
        Item::tube_waypoint(seq, self.x, self.y, self.w_left_m, self.w_right_m)
    }
}

/// `v` (m) in the mission protocol's units of 0.1 mm (`MISSION_ITEM_INT.x`, `.y`): the nearest
/// count, `None` beyond the `i32` range or for a non-finite `v`.
fn wire_units(v: f64) -> Option<i32> {
    let x = (v * 1e4).round();
    (x.is_finite() && x.abs() <= f64::from(i32::MAX)).then_some(x as i32)
}

/// A count of 0.1 mm back in metres, as the companion computes it (`vt_companion::mission`).
fn metres_from_wire(x: i32) -> f32 {
    x as f32 / vt_companion::mission::LOCAL_SCALE_PER_M
}

/// `v` (m) on the mission protocol's 0.1 mm grid, as the companion reconstructs it: the
/// nearest grid value, as `f32`, in `f64`. Values beyond the `i32` range are returned unchanged
/// ([`tube_waypoints`] refuses them).
pub fn on_wire_grid_m(v: f64) -> f64 {
    wire_units(v).map_or(v, |x| f64::from(metres_from_wire(x)))
}

/// The scenario's tube as the mission protocol carries it.
///
/// # Errors
/// A waypoint is not representable at 0.1 mm without changing its `f32` value (the companion
/// would fly another tube than the simulator's metrics measure).
pub fn tube_waypoints(s: &Scenario) -> Result<Vec<WireWaypoint>, SimError> {
    let mut out = Vec::with_capacity(s.tube.waypoints.len());
    for (k, w) in s.tube.waypoints.iter().enumerate() {
        let (east, north, wl, wr) = (w[0], w[1], w[2], w[3]);
        // What the companion rebuilds must equal the scenario's value as f32.
        let exact = |v: f64| wire_units(v).filter(|&x| metres_from_wire(x) == v as f32);
        let (Some(x), Some(y)) = (exact(north), exact(east)) else {
            return Err(SimError(format!("tube waypoint {k}: not representable in 0.1 mm units without changing its f32 value")));
        };
        out.push(WireWaypoint { x, y, w_left_m: wl as f32, w_right_m: wr as f32 });
    }
    Ok(out)
}

/// The companion parameter set of UAV `i` of `s` flying `kind`, with cables rated
/// `cable_rated_n` (N; the scenario's or the run's `--f-max`) and `VT_LOCKSTEP = lockstep`:
/// the one map from a scenario to the firmware's parameters (docs/design.md, "One flight
/// logic"). Each value passes the companion's own range check.
///
/// # Errors
/// A value the companion refuses, naming the parameter.
pub fn params_for(s: &Scenario, i: usize, kind: ControllerKind, cable_rated_n: f64, lockstep: bool) -> Result<Params, SimError> {
    let n = s.cables.lengths_m.len();
    if n > MAX_UAVS || i >= n {
        return Err(SimError(format!("UAV {i} of {n}: the companion holds at most {MAX_UAVS}")));
    }
    let c = &s.controller;
    let vl = &s.velocity_loop;
    let (k1, k2, k3, v_max, r_safe, r_active) = match kind {
        ControllerKind::Dissipative => (c.k1, c.k2, c.k3, c.v_max_mps, c.r_safe_m, c.r_active_m),
        ControllerKind::Baseline => {
            let b = &s.baseline;
            (b.k1, b.k2, b.k3, b.v_max_mps, b.r_safe_m, b.r_active_m)
        }
    };
    let (bandwidth, lag, filter) = vl.tuning(s.uavs.model);
    let cap = &c.capacity;
    let f = |x: f64| x as f32;
    let (drag_q, drag_l) = level_drag(s);
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    let values = [
        (Param::Id, i as f32),
        (Param::NUavs, n as f32),
        (Param::SysidBase, f32::from(SYSID_BASE)),
        (Param::LoadComp, f32::from(LOAD_COMPONENT_ID)),
        (Param::Lockstep, flag(lockstep)),
        (Param::HlHz, s.rates.high_level_hz as f32),
        (Param::LlHz, s.rates.low_level_hz as f32),
        (Param::FsOwnTmo, if lockstep { OWN_TIMEOUT_S } else { OWN_TIMEOUT_REALTIME_S }),
        (Param::FsLoadTmo, LOAD_TIMEOUT_S),
        (Param::FsNbrTmo, AUTO),
        (Param::FsNbrAct, flag(s.failsafe.stale_neighbour == StaleNeighbour::Hold)),
        (Param::FsResume, f(s.failsafe.resume_s)),
        (Param::K1, f(k1)),
        (Param::K2, f(k2)),
        (Param::K3, f(k3)),
        (Param::VMax, f(v_max)),
        (Param::RSafe, f(r_safe)),
        (Param::RActive, f(r_active)),
        (Param::TrayH, f(c.tray_height_m)),
        (Param::TrayHMin, TrayParams::default().min_height_above_load_m),
        (Param::LoadZRef, f(s.load.altitude_m)),
        (Param::LoadKg, f(s.load.mass_kg)),
        (Param::CableK, f(s.cables.stiffness_n_per_m)),
        (Param::CableLMax, AUTO),
        (Param::CableRated, f(cable_rated_n)),
        (Param::MarginMin, f(s.preflight.min_margin)),
        (Param::ThrRes, f(s.preflight.thrust_reserve)),
        (Param::Kz, f(c.kz_per_s)),
        (Param::VzMax, f(c.vz_max_mps)),
        (Param::ZMin, AUTO),
        (Param::KShare, f(c.share_gain_mps_per_n)),
        (Param::KLoadAlt, f(c.load_altitude_gain_per_s)),
        (Param::DzMax, f(c.share_offset_max_m)),
        (Param::KpX, f(vl.kp[0])),
        (Param::KpY, f(vl.kp[1])),
        (Param::KpZ, f(vl.kp[2])),
        (Param::KiX, f(vl.ki[0])),
        (Param::KiY, f(vl.ki[1])),
        (Param::KiZ, f(vl.ki[2])),
        (Param::KdX, f(vl.kd[0])),
        (Param::KdY, f(vl.kd[1])),
        (Param::KdZ, f(vl.kd[2])),
        (Param::ILimX, INTEGRAL_LIMIT_MPS2),
        (Param::ILimY, INTEGRAL_LIMIT_MPS2),
        (Param::ILimZ, INTEGRAL_LIMIT_MPS2),
        (Param::ThrustMin, AUTO),
        (Param::ThrustMax, f(s.uavs.thrust_max_n)),
        (Param::TiltMax, s.uavs.tilt_max_deg.to_radians() as f32),
        (Param::CfoMu, f(bandwidth)),
        (Param::ActLag, f(lag)),
        (Param::CmdTau, f(filter)),
        (Param::Mass, f(s.uavs.mass_kg)),
        (Param::Yaw, 0.0),
        (Param::CapOn, flag(cap.enabled)),
        (Param::CapMargin, f(cap.margin)),
        (Param::SepMin, f(cap.separation_m.unwrap_or(s.mission.safety_distance_m + c.r_safe_m))),
        (Param::CapRate, f(cap.rate_per_s)),
        (Param::SagLo, f(cap.sag_start_m)),
        (Param::SagHi, f(cap.sag_full_m)),
        (Param::Shape, flag(s.controller.shape.enabled)),
        (Param::ShapeMrg, f(s.controller.shape.margin_m)),
        (Param::ShapeAhd, f(s.controller.shape.ahead_m)),
        (Param::ShapeTeam, flag(s.controller.shape.team_keeping)),
        (Param::HReserve, vl.horizontal_reserve(s.uavs.model).map_or(AUTO, f)),
        (Param::CalN, s.controller.survey_samples as f32),
        (Param::CableL, f(s.cables.lengths_m[i])),
        (Param::WindDecl, s.mission.max_wind_mps.map_or(AUTO, f)),
        (Param::WindGust, f(s.mission.gust_margin_mps)),
        (Param::BodyR, f(s.uavs.body_radius_m.unwrap_or(0.0))),
        (Param::ClrMin, f(s.mission.clearance_floor())),
        (Param::DragQ, f(drag_q)),
        (Param::DragL, f(drag_l)),
        (Param::LoadCda, f(s.disturbances.load_drag_area_m2)),
        (Param::Start, flag(s.mission.start == crate::scenario::MissionStart::Ground)),
        (Param::EndTol, f(s.mission.end_tolerance_m)),
        (Param::LoadGz, f(s.load.envelope_radius_m())),
        (Param::TkoS, f(crate::sim::ground_takeoff_s(s))),
        (Param::Ctrl, match kind {
            ControllerKind::Dissipative => 0.0,
            ControllerKind::Baseline => 1.0,
        }),
    ];
    // Issue 28: the onboard map's world and the planner's figures (`PR_MAP` 0: the tube is given).
    let map = crate::mission::replan::perception_config(s).map_or_else(Vec::new, |m| m.params().to_vec());
    let mut p = Params::new();
    for (param, v) in values.into_iter().chain(map) {
        p.set(param, v).map_err(|e| SimError(format!("UAV {i}: parameter {} = {v}: {e:?}", param.info().name)))?;
    }
    Ok(p)
}

/// `VL_DRAG_Q`, `VL_DRAG_L`: the horizontal drag of one UAV of the plant, `(c_q, c_l)`.
/// Rigid body: its body drag and its rotors' H-force at the loaded hover (weight plus the
/// load's share, [`crate::quadrotor::QuadParams::level_drag`]). Point mass: the scenario's
/// drag area, quadratic only (`disturbance::drag_n`).
fn level_drag(s: &Scenario) -> (f64, f64) {
    match s.uavs.model {
        UavModel::RigidBody => {
            let n = s.cables.lengths_m.len().max(1) as f64;
            let hover_n = (s.uavs.mass_kg + s.load.mass_kg / n) * crate::quadrotor::GRAVITY_MPS2;
            crate::quadrotor::QuadParams::sized(s.uavs.mass_kg, s.uavs.thrust_max_n).level_drag(hover_n)
        }
        UavModel::PointMass => (0.5 * crate::disturbance::AIR_DENSITY_KG_M3 * s.disturbances.uav_drag_area_m2, 0.0),
    }
}

/// `VL_ILIM_*`: the bound on the velocity loop's integral term, m/s^2.
const INTEGRAL_LIMIT_MPS2: f32 = 2.0;

/// The parameters of a companion as `PARAM_SET` pairs, in table order (every one: a companion
/// configured from its defaults and one configured from a previous mission end up the same).
pub fn param_list(p: &Params) -> Vec<(Param, f32)> {
    vt_companion::params::ALL.iter().map(|&q| (q, p.get(q))).collect()
}

/// Tube storage of dropped companions, reused by new ones: a companion borrows its tube for its
/// lifetime (`'static` on the MCU), so the host's take theirs from this pool (leaked once,
/// about 9 KiB each); memory is bounded by the most companions alive at once.
static TUBE_POOL: Pool<CompanionTube> = std::sync::Mutex::new(Vec::new());

/// A companion on the host with its tube storage from the pool (given back when dropped).
pub struct HostCompanion {
    /// Always `Some` until dropped.
    companion: Option<Box<Companion<'static>>>,
}

impl Default for HostCompanion {
    fn default() -> Self {
        Self::new()
    }
}

impl HostCompanion {
    /// A fresh companion: default parameters, no tube.
    pub fn new() -> Self {
        Self { companion: Some(Box::new(Companion::new(pooled_tube()))) }
    }

    /// The companion (`None` only while being dropped).
    pub fn get(&self) -> Option<&Companion<'static>> {
        self.companion.as_deref()
    }

    /// The companion, mutable (`None` only while being dropped).
    pub fn get_mut(&mut self) -> Option<&mut Companion<'static>> {
        self.companion.as_deref_mut()
    }
}

impl HostCompanion {
    /// Issue 28: gives the companion the storage of in-flight re-planning (its map and two
    /// tubes, from the pools and given back when dropped), where a firmware's perception build
    /// keeps them in `static`s; the companion configures it from its `PR_*` parameters. Once:
    /// a companion that has it keeps it.
    pub fn provide_map(&mut self) {
        if let Some(c) = self.companion.as_deref_mut().filter(|c| c.replanning().is_none()) {
            c.attach_replanning(take_from(&SLOT_POOL, ReplanSlot::new), Replanning::new(pooled_perception(), take_from(&SPACE_POOL, PlannerSpace::zeroed), pooled_tube(), pooled_tube()));
        }
    }
}

impl Drop for HostCompanion {
    fn drop(&mut self) {
        if let Some(mut c) = self.companion.take() {
            if let Some((r, slot)) = c.detach_replanning() {
                give_back_replanning(r);
                give_back(&SLOT_POOL, slot);
            }
            give_back_tube(c.into_tube());
        }
    }
}

fn give_back_replanning(r: Replanning<'static, 'static>) {
    let (map, space, spare, check) = r.into_parts();
    give_back_perception(map);
    if let Some(s) = space {
        give_back(&SPACE_POOL, s);
    }
    if let Some(s) = spare {
        give_back_tube(s);
    }
    if let Some(c) = check {
        give_back_tube(c);
    }
}

/// Storage leaked once and reused: what dropped companions gave back (the pool bounds the
/// memory by the most alive at once).
type Pool<T> = std::sync::Mutex<Vec<&'static mut T>>;

/// Storage from `pool`, or a new `make()` leaked.
fn take_from<T>(pool: &Pool<T>, make: impl FnOnce() -> T) -> &'static mut T {
    let pooled = pool.lock().ok().and_then(|mut p| p.pop());
    pooled.unwrap_or_else(|| Box::leak(Box::new(make())))
}

/// Gives `t` back to `pool`.
fn give_back<T>(pool: &Pool<T>, t: &'static mut T) {
    if let Ok(mut p) = pool.lock() {
        p.push(t);
    }
}

/// Tube storage from the pool, or a new one.
fn pooled_tube() -> &'static mut CompanionTube {
    take_from(&TUBE_POOL, CompanionTube::placeholder)
}

fn give_back_tube(t: &'static mut CompanionTube) {
    give_back(&TUBE_POOL, t);
}

/// Onboard maps of dropped re-plannings, reused (about 34 KiB each).
static PERCEPTION_POOL: Pool<Perception> = std::sync::Mutex::new(Vec::new());
/// Planner work spaces of dropped re-plannings, reused (about 43 KiB each).
static SPACE_POOL: Pool<PlannerSpace> = std::sync::Mutex::new(Vec::new());
/// Re-planning states of dropped companions, reused (about 6 KiB each).
static SLOT_POOL: Pool<ReplanSlot<'static>> = std::sync::Mutex::new(Vec::new());

fn pooled_perception() -> &'static mut Perception {
    take_from(&PERCEPTION_POOL, Perception::placeholder)
}

fn give_back_perception(p: &'static mut Perception) {
    give_back(&PERCEPTION_POOL, p);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::UavModel;
    use crate::scenario::{self, LoadedScenario};
    use std::path::Path;

    fn shipped() -> Vec<LoadedScenario> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios");
        let mut names: Vec<_> = std::fs::read_dir(&dir)
            .expect("scenarios/")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        names.sort();
        assert!(names.len() >= 5, "{names:?}");
        names.iter().map(|p| scenario::load(Some(p)).unwrap_or_else(|e| panic!("{}: {e}", p.display()))).collect()
    }

    /// Issue 26: what host-sim computed and pushed before (`sim::horizontal_reserve`,
    /// `sim::min_height_m`, `sim::max_cable_m`, `0.05 thrust_max`, `0.5 / hl_hz`), now derived
    /// aboard from the companion's own parameters. The old host formulas are kept here as the
    /// reference, on every shipped scenario and both UAV models.
    #[test]
    fn the_companion_derives_what_host_sim_used_to_push() {
        for ls in shipped() {
            for model in [UavModel::PointMass, UavModel::RigidBody] {
                let mut s = ls.scenario.clone();
                s.uavs.model = model;
                let n = s.cables.lengths_m.len();
                let longest = s.cables.lengths_m.iter().copied().fold(0.0f64, f64::max);
                let label = format!("{} ({})", s.name, model.name());
                for i in 0..n {
                    let p = params_for(&s, i, ControllerKind::Dissipative, s.cables.rated_n, true).expect("parameters");
                    let len = s.cables.lengths_m[i];
                    // VT_Z_MIN: min(1, half the nominal cable), bit for bit.
                    assert_eq!(p.min_height_m(), 1.0f32.min((0.5 * len) as f32), "{label} UAV {i}: VT_Z_MIN");
                    // VL_T_MIN: 5 % of the thrust limit, bit for bit.
                    assert_eq!(p.thrust_min_n(), 0.05 * s.uavs.thrust_max_n as f32, "{label}: VL_T_MIN");
                    // FS_NBR_TMO: half a high-level period in lockstep, to the millisecond.
                    assert_eq!(p.neighbour_timeout_ms(), ((0.5 / s.rates.high_level_hz as f32) * 1000.0) as u32, "{label}: FS_NBR_TMO");
                    // VL_H_RES: the scenario's value, else min(0.5, sqrt(1 - ((m g + pull) / T)^2))
                    // (host: f64; aboard: f32). The pull was the cable's rating; since issue 29 it
                    // is the declared load's share with a margin (the formation's, at least the
                    // vertical cap's 15 %) when that is less.
                    let host = s.velocity_loop.horizontal_reserve(model).unwrap_or_else(|| {
                        let margin = s.controller.capacity.margin.max(f64::from(vt_companion::params::VERTICAL_PULL_MARGIN));
                        let share = (1.0 + margin) * s.load.mass_kg * crate::plant::GRAVITY_MPS2 / n as f64;
                        let pull = if share > 0.0 && share < s.cables.rated_n { share } else { s.cables.rated_n };
                        let need = (s.uavs.mass_kg * crate::plant::GRAVITY_MPS2 + pull) / s.uavs.thrust_max_n;
                        let room = if need < 1.0 { (1.0 - need * need).sqrt() } else { 0.0 };
                        0.5f64.min(room)
                    });
                    let aboard = f64::from(p.horizontal_reserve());
                    assert!((aboard - host).abs() <= 4.0 * f64::from(f32::EPSILON), "{label}: VL_H_RES aboard {aboard} host {host}");
                    // VT_CABLE_LMAX: 1.5 x the UAV's own nominal cable (the host used the team's
                    // longest: the same for the longest cable, docs/design.md "One flight logic").
                    assert_eq!(p.max_cable_m(), 1.5 * len as f32, "{label} UAV {i}: VT_CABLE_LMAX");
                    if len == longest {
                        assert!((f64::from(p.max_cable_m()) - 1.5 * longest).abs() <= 1.5 * longest * f64::from(f32::EPSILON), "{label}");
                    }
                }
            }
        }
    }

    /// The wind check's drag parameters: the companion's defaults are the experiment airframe's
    /// on the rigid-body plant (1.47 kg, 30 N, carrying a third of 3.06 kg), as documented; the
    /// point mass has quadratic drag only; no declared wind maps to `-1` (no check).
    #[test]
    fn the_drag_the_wind_check_uses_is_the_plants() {
        let exp = shipped().into_iter().find(|ls| ls.scenario.name == "experiment-3uav").expect("experiment");
        let mut s = exp.scenario;
        let p = params_for(&s, 0, ControllerKind::Dissipative, s.cables.rated_n, false).expect("parameters");
        let d = Params::new();
        for q in [Param::DragQ, Param::DragL, Param::LoadCda] {
            let rel = (p.get(q) - d.get(q)).abs() / d.get(q);
            assert!(rel < 0.01, "{}: plant {} default {}", q.info().name, p.get(q), d.get(q));
        }
        assert_eq!(p.declared_wind_mps(), None);
        // Rotor drag grows with the rotor speed: more load, more drag.
        s.load.mass_kg *= 2.0;
        let heavier = params_for(&s, 0, ControllerKind::Dissipative, s.cables.rated_n, false).expect("parameters");
        assert!(heavier.get(Param::DragL) > p.get(Param::DragL));
        s.uavs.model = UavModel::PointMass;
        s.mission.max_wind_mps = Some(4.0);
        s.mission.gust_margin_mps = 1.5;
        let pm = params_for(&s, 0, ControllerKind::Dissipative, s.cables.rated_n, false).expect("parameters");
        assert_eq!(pm.get(Param::DragL), 0.0);
        assert_eq!(pm.get(Param::DragQ), (0.5 * crate::disturbance::AIR_DENSITY_KG_M3 * s.disturbances.uav_drag_area_m2) as f32);
        assert_eq!(pm.declared_wind_mps(), Some((4.0, 1.5)));
    }

    #[test]
    fn every_parameter_passes_the_companions_range_check_and_baseline_gains_go_to_vt_k() {
        for ls in shipped() {
            let s = &ls.scenario;
            let p = params_for(s, 0, ControllerKind::Baseline, s.cables.rated_n, false).expect("parameters");
            assert_eq!(p.get(Param::Ctrl), 1.0);
            assert_eq!(p.get(Param::K1), s.baseline.k1 as f32);
            assert_eq!(p.get(Param::RActive), s.baseline.r_active_m as f32);
            assert_eq!(param_list(&p).len(), vt_companion::params::COUNT);
        }
    }
}
