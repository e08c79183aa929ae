//! What the ground station tells each companion before the mission: the parameter table,
//! the tube as a MAVLink mission, and `MAV_CMD_MISSION_START`.

use super::port::Port;
use super::wire::{Encoder, Rx};
use super::{err, PilError, GCS_COMPONENT_ID, GCS_SYSTEM_ID, LOAD_COMPONENT_ID, LOAD_TIMEOUT_S, OWN_TIMEOUT_S, SYSID_BASE};
use crate::scenario::{LoadedScenario, StaleNeighbour};
use crate::sim::{self, Takeoff};
use mavlink::dialects::common::{
    MavCmd, MavFrame, MavParamType, COMMAND_LONG_DATA, MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA,
};
use mavlink::MessageData;
use vt_companion::{Param, COMPANION_COMPONENT_ID};
use vt_dissipative::MAX_UAVS;

/// A waypoint as sent in `MISSION_ITEM_INT`.
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

/// Everything one UAV's companion is told before the mission.
#[derive(Debug, Clone, PartialEq)]
pub struct UavConfig {
    /// Its MAVLink system id.
    pub system_id: u8,
    /// Parameter values (every parameter of the table that the scenario determines).
    pub params: Vec<(Param, f32)>,
    /// The tube.
    pub waypoints: Vec<WireWaypoint>,
}

/// The team's configuration and take-off state for a scenario (nominal case: no
/// disturbances). Each companion calibrates its cable itself at `MISSION_START`.
#[derive(Debug, Clone)]
pub struct TeamSetup {
    /// One per UAV.
    pub configs: Vec<UavConfig>,
    /// Take-off geometry.
    pub takeoff: Takeoff,
}

/// Configuration of every UAV of `ls` (`lockstep`: `VT_LOCKSTEP = 1`), cables rated as the
/// scenario says.
///
/// # Errors
/// A waypoint is not representable at 0.1 mm, or the scenario's velocity loop is invalid.
pub fn team_setup(ls: &LoadedScenario, lockstep: bool) -> Result<TeamSetup, PilError> {
    let s = &ls.scenario;
    team_setup_with(ls, sim::takeoff(s, &ls.tube, s.cables.rated_n), s.cables.rated_n, lockstep)
}

/// [`team_setup`] for a given take-off geometry and cable rating `cable_rated_n` (N): what the
/// mission loop's world holds at take-off.
///
/// # Errors
/// As [`team_setup`].
pub fn team_setup_with(ls: &LoadedScenario, to: Takeoff, cable_rated_n: f64, lockstep: bool) -> Result<TeamSetup, PilError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    if n > MAX_UAVS {
        return err(format!("{n} UAVs > capacity {MAX_UAVS}"));
    }
    let mut waypoints = Vec::new();
    for (k, w) in s.tube.waypoints.iter().enumerate() {
        let (east, north, wl, wr) = (w[0], w[1], w[2], w[3]);
        let q = |v: f64| (v * 1e4).round();
        let (x, y) = (q(north), q(east));
        // The firmware computes `x as f32 / 1e4`; it must equal the scenario's value as f32.
        if (x as f32 / 1e4) != north as f32 || (y as f32 / 1e4) != east as f32 || x.abs() > f64::from(i32::MAX) || y.abs() > f64::from(i32::MAX) {
            return err(format!("tube waypoint {k}: not representable in 0.1 mm units without changing its f32 value"));
        }
        waypoints.push(WireWaypoint { x: x as i32, y: y as i32, w_left_m: wl as f32, w_right_m: wr as f32 });
    }
    let vl = sim::velocity_loop(s).map_err(|e| PilError(e.to_string()))?;
    let p = vl.params();
    let tray = sim::tray(s);
    let c = &s.controller;
    let r = &s.rates;
    let cap = sim::capacity_params(s, cable_rated_n);
    let configs = (0..n)
        .map(|i| {
            // What the companion calibrates and checks with at MISSION_START: the same f32
            // values CrateTeam::start passes to the crate (sim::calibration_params,
            // sim::feasibility_params; the lean is measured aboard, any value does here).
            let cal = sim::calibration_params(s, i);
            let feas = sim::feasibility_params(s, cable_rated_n, 1.0);
            let g = p.gains();
            let lim = p.integral_limit_mps2();
            let params = vec![
                (Param::NUavs, n as f32),
                (Param::Id, i as f32),
                (Param::SysidBase, f32::from(SYSID_BASE)),
                (Param::LoadComp, f32::from(LOAD_COMPONENT_ID)),
                (Param::Lockstep, if lockstep { 1.0 } else { 0.0 }),
                (Param::HlHz, r.high_level_hz as f32),
                (Param::LlHz, r.low_level_hz as f32),
                (Param::FsOwnTmo, OWN_TIMEOUT_S),
                (Param::FsLoadTmo, LOAD_TIMEOUT_S),
                // The host's link model ages the team's data (link.stale_timeout_s) and relays
                // only what is fresh, once per high-level period: half a period makes the
                // companion use exactly that (docs/design.md, "Team failsafe").
                (Param::FsNbrTmo, 0.5 / r.high_level_hz as f32),
                (Param::FsNbrAct, if s.failsafe.stale_neighbour == StaleNeighbour::Hold { 1.0 } else { 0.0 }),
                (Param::FsResume, s.failsafe.resume_s as f32),
                (Param::K1, c.k1 as f32),
                (Param::K2, c.k2 as f32),
                (Param::K3, c.k3 as f32),
                (Param::VMax, c.v_max_mps as f32),
                (Param::RSafe, c.r_safe_m as f32),
                (Param::RActive, c.r_active_m as f32),
                (Param::TrayH, tray.height_above_load_m),
                (Param::TrayHMin, tray.min_height_above_load_m),
                (Param::LoadZRef, s.load.altitude_m as f32),
                (Param::LoadKg, cal.load_mass_kg),
                (Param::CableK, cal.stiffness_n_per_m),
                (Param::CableLMax, cal.max_length_m),
                (Param::CableRated, feas.cable_rated_n),
                (Param::MarginMin, feas.min_margin),
                (Param::Kz, c.kz_per_s as f32),
                (Param::VzMax, c.vz_max_mps as f32),
                (Param::ZMin, cal.min_length_m),
                (Param::KShare, c.share_gain_mps_per_n as f32),
                (Param::KLoadAlt, c.load_altitude_gain_per_s as f32),
                (Param::DzMax, c.share_offset_max_m as f32),
                (Param::KpX, g.kp.x),
                (Param::KpY, g.kp.y),
                (Param::KpZ, g.kp.z),
                (Param::KiX, g.ki.x),
                (Param::KiY, g.ki.y),
                (Param::KiZ, g.ki.z),
                (Param::KdX, g.kd.x),
                (Param::KdY, g.kd.y),
                (Param::KdZ, g.kd.z),
                (Param::ILimX, lim.x),
                (Param::ILimY, lim.y),
                (Param::ILimZ, lim.z),
                (Param::ThrustMin, p.limits().thrust_min_n()),
                (Param::ThrustMax, p.limits().thrust_max_n()),
                (Param::TiltMax, s.uavs.tilt_max_deg.to_radians() as f32),
                (Param::CfoMu, p.cfo().bandwidth_rad_s()),
                (Param::ActLag, p.actuator_lag_s()),
                (Param::CmdTau, p.command_filter_s()),
                (Param::Mass, p.mass_kg()),
                (Param::Yaw, 0.0),
                (Param::CapOn, if cap.load_mass_kg > 0.0 { 1.0 } else { 0.0 }),
                (Param::CapMargin, cap.margin),
                (Param::SepMin, cap.separation_m),
                (Param::CapRate, cap.rate_per_s),
                (Param::SagLo, cap.sag_start_m),
                (Param::SagHi, cap.sag_full_m),
                (Param::HReserve, sim::horizontal_reserve(s) as f32),
                (Param::CalN, c.survey_samples as f32),
            ];
            UavConfig { system_id: SYSID_BASE + i as u8, params, waypoints: waypoints.clone() }
        })
        .collect();
    Ok(TeamSetup { configs, takeoff: to })
}

fn gcs<D: MessageData>(enc: &mut Encoder, d: &D) -> Vec<u8> {
    enc.frame(GCS_SYSTEM_ID, GCS_COMPONENT_ID, d)
}

/// Reads messages until `want` returns `Some`, skipping the others.
///
/// # Errors
/// The port's errors, or more than `limit` other messages in between.
pub fn recv_until<T, P: Port + ?Sized>(port: &mut P, limit: usize, mut want: impl FnMut(&Rx) -> Option<T>) -> Result<T, PilError> {
    for _ in 0..limit {
        let rx = port.recv()?;
        if let Some(t) = want(&rx) {
            return Ok(t);
        }
    }
    err("expected reply not received")
}

/// Sets every parameter (each echoed bit for bit) and uploads the tube.
///
/// # Errors
/// A parameter is refused or echoed differently, or the tube is not accepted.
pub fn configure<P: Port + ?Sized>(port: &mut P, cfg: &UavConfig, enc: &mut Encoder) -> Result<(), PilError> {
    for &(p, value) in &cfg.params {
        let name = p.info().name;
        let msg = PARAM_SET_DATA {
            param_value: value,
            target_system: 0,
            target_component: COMPANION_COMPONENT_ID,
            param_id: name.into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        };
        port.send(&gcs(enc, &msg))?;
        let echoed = recv_until(port, 64, |rx| match rx {
            Rx::ParamValue(n, v) if n == name => Some(*v),
            _ => None,
        })?;
        if echoed.to_bits() != value.to_bits() {
            return err(format!("parameter {name}: sent {value}, companion holds {echoed}"));
        }
    }
    let count = MISSION_COUNT_DATA { count: cfg.waypoints.len() as u16, target_system: cfg.system_id, target_component: COMPANION_COMPONENT_ID };
    port.send(&gcs(enc, &count))?;
    loop {
        let rx = recv_until(port, 64, |rx| match rx {
            Rx::MissionRequest(_) | Rx::MissionAck(_) => Some(rx.clone()),
            _ => None,
        })?;
        match rx {
            Rx::MissionRequest(seq) => {
                let Some(w) = cfg.waypoints.get(usize::from(seq)) else {
                    return err(format!("companion asked for waypoint {seq}"));
                };
                let item = MISSION_ITEM_INT_DATA {
                    param1: w.w_left_m,
                    param2: w.w_right_m,
                    x: w.x,
                    y: w.y,
                    seq,
                    command: MavCmd::MAV_CMD_NAV_WAYPOINT,
                    target_system: cfg.system_id,
                    target_component: COMPANION_COMPONENT_ID,
                    frame: MavFrame::MAV_FRAME_LOCAL_NED,
                    autocontinue: 1,
                    ..MISSION_ITEM_INT_DATA::default()
                };
                port.send(&gcs(enc, &item))?;
            }
            Rx::MissionAck(0) => return Ok(()),
            Rx::MissionAck(code) => return err(format!("tube refused (MAV_MISSION_RESULT {code})")),
            _ => {}
        }
    }
}

/// A round trip (`PARAM_REQUEST_READ` of `VT_ID`, answered after everything sent before it):
/// the companion has handled every frame sent so far.
///
/// # Errors
/// No answer.
pub fn sync<P: Port + ?Sized>(port: &mut P, system_id: u8, enc: &mut Encoder) -> Result<(), PilError> {
    let name = Param::Id.info().name;
    let req = PARAM_REQUEST_READ_DATA {
        param_index: -1,
        target_system: system_id,
        target_component: COMPANION_COMPONENT_ID,
        param_id: name.into(),
    };
    port.send(&gcs(enc, &req))?;
    recv_until(port, 256, |rx| match rx {
        Rx::ParamValue(n, _) if n == name => Some(()),
        _ => None,
    })
}

/// `MAV_CMD_MISSION_START`; returns the `MAV_RESULT` value.
///
/// # Errors
/// No acknowledgement.
pub fn start_mission<P: Port + ?Sized>(port: &mut P, system_id: u8, enc: &mut Encoder) -> Result<u32, PilError> {
    start_mission_with_reason(port, system_id, enc).map(|(r, _)| r)
}

/// `MAV_CMD_MISSION_START`; returns the `MAV_RESULT` value and the `STATUSTEXT`s the companion
/// sent before its acknowledgement (a refusal's reason and numbers, docs/protocol.md).
///
/// # Errors
/// No acknowledgement.
pub fn start_mission_with_reason<P: Port + ?Sized>(port: &mut P, system_id: u8, enc: &mut Encoder) -> Result<(u32, Vec<String>), PilError> {
    let cmd = COMMAND_LONG_DATA {
        command: MavCmd::MAV_CMD_MISSION_START,
        target_system: system_id,
        target_component: COMPANION_COMPONENT_ID,
        ..COMMAND_LONG_DATA::default()
    };
    port.send(&gcs(enc, &cmd))?;
    let mut texts = Vec::new();
    let result = recv_until(port, 64, |rx| match rx {
        Rx::CommandAck(c, r) if *c == MavCmd::MAV_CMD_MISSION_START as u32 => Some(*r),
        Rx::StatusText(_, t) => {
            texts.push(t.clone());
            None
        }
        _ => None,
    })?;
    Ok((result, texts))
}
