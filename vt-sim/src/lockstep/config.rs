//! What the ground station tells each companion before the mission: the parameter table,
//! the tube as a MAVLink mission, and `MAV_CMD_MISSION_START`.

use super::port::Port;
use super::wire::{Encoder, Rx};
use super::{err, PilError, GCS_COMPONENT_ID, GCS_SYSTEM_ID};
use crate::companion::{param_list, params_for, tube_waypoints, WireWaypoint};
use crate::scenario::LoadedScenario;
use crate::sim::{self, ControllerKind, Takeoff};
use mavlink::dialects::common::{
    MavCmd, MavFrame, MavParamType, COMMAND_LONG_DATA, MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA,
};
use mavlink::MessageData;
use vt_companion::{Param, COMPANION_COMPONENT_ID};

/// Everything one UAV's companion is told before the mission.
#[derive(Debug, Clone, PartialEq)]
pub struct UavConfig {
    /// Its MAVLink system id.
    pub system_id: u8,
    /// Every parameter of the companion's table, in table order ([`crate::companion::params_for`]).
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
    team_setup_for(ls, ControllerKind::Dissipative, to, cable_rated_n, lockstep)
}

/// [`team_setup_with`] for the high-level law `kind` (`VT_CTRL`).
///
/// # Errors
/// As [`team_setup`].
pub fn team_setup_for(ls: &LoadedScenario, kind: ControllerKind, to: Takeoff, cable_rated_n: f64, lockstep: bool) -> Result<TeamSetup, PilError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    let waypoints = tube_waypoints(s).map_err(|e| PilError(e.0))?;
    let configs = (0..n)
        .map(|i| {
            // The one parameter map (the SIL team sets the same values directly).
            let params = params_for(s, i, kind, cable_rated_n, lockstep).map_err(|e| PilError(e.0))?;
            Ok(UavConfig { system_id: params.own_system_id(), params: param_list(&params), waypoints: waypoints.clone() })
        })
        .collect::<Result<_, PilError>>()?;
    Ok(TeamSetup { configs, takeoff: to })
}

fn gcs<D: MessageData>(enc: &mut Encoder, d: &D) -> Vec<u8> {
    enc.frame(GCS_SYSTEM_ID, GCS_COMPONENT_ID, d)
}

/// Reads messages until `want` returns `Some`, skipping the others.
///
/// # Errors
/// The port's errors, or more than `limit` other messages in between.
pub fn recv_until<T, P: Port + ?Sized>(port: &mut P, limit: usize, want: impl FnMut(&Rx) -> Option<T>) -> Result<T, PilError> {
    recv_within(port, limit, want)?.ok_or_else(|| PilError("expected reply not received".into()))
}

/// [`recv_until`], with `None` for `limit` other messages in between (told apart from the
/// port's errors).
///
/// # Errors
/// The port's errors.
pub fn recv_within<T, P: Port + ?Sized>(port: &mut P, limit: usize, mut want: impl FnMut(&Rx) -> Option<T>) -> Result<Option<T>, PilError> {
    for _ in 0..limit {
        let rx = port.recv()?;
        if let Some(t) = want(&rx) {
            return Ok(Some(t));
        }
    }
    Ok(None)
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
        // A link that fails says so; 64 frames without the echo mean an unknown parameter.
        let echoed = recv_within(port, 64, |rx| match rx {
            Rx::ParamValue(n, v) if n == name => Some(*v),
            _ => None,
        })
        .map_err(|e| PilError(format!("parameter {name}: no echo ({e})")))?
        .ok_or_else(|| PilError(format!("parameter {name}: no echo in 64 frames: a companion built before the parameter existed?")))?;
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
    // Room for a re-planning companion's tube offer (up to 65 frames) with its telemetry.
    recv_until(port, 1024, |rx| match rx {
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
