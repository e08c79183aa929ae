//! The companions behind MAVLink ports in lockstep: the wire (frames, the tick's messages, what
//! a companion answers), the ground station's configuration (parameters, the tube, the start),
//! one UAV's [`Port`] (its host twin [`SilPort`] here; a UDP socket in [`crate::sitl`]; the
//! firmware in QEMU in host-sim's PIL) and the team over those ports as a backend of the one
//! mission loop ([`PortTeam`]), every command recorded for the bit-for-bit [`compare`].
//!
//! # Lockstep
//! The companion runs with `VT_LOCKSTEP = 1`: each own `LOCAL_POSITION_NED` it receives is one
//! low-level period. Per low-level period the host sends every UAV, in this order, the load's
//! state and the neighbours' positions (only when the high level is due) and then its own state;
//! the companion answers with telemetry and, last, `SET_ATTITUDE_TARGET`, which the host waits
//! for before stepping the plant. Simulated time is carried in `time_boot_ms`; no clock of the
//! host or the emulator plays a part, so results do not depend on host speed.
//!
//! The host plays the autopilot (own state in, attitude setpoint out, flown by the plant's UAV
//! model), the load tracker, the team network (the link model) and the ground station
//! (parameters, the tube as a mission, `MAV_CMD_MISSION_START`). The flight is the one mission
//! loop ([`crate::mission::fly`]) with the companions as the team ([`PortTeam`]).

pub mod compare;
pub mod config;
pub mod flight;
pub mod port;
pub mod relay;
pub mod wire;

pub use compare::{compare, Difference};
pub use config::{configure, recv_until, start_mission, start_mission_with_reason, sync, team_setup, team_setup_for, team_setup_with, TeamSetup, UavConfig};
pub use crate::companion::{WireWaypoint, LOAD_COMPONENT_ID, LOAD_TIMEOUT_S, OWN_TIMEOUT_S, SYSID_BASE};
pub use flight::{fly, fly_team, CommandKind, CommandRecord, FlightOutput, PortTeam, StartHook};
pub use port::{Port, SilPort};
pub use wire::{local_position, Encoder, Encoders, Rx, TickFrames};
pub use vt_companion::AUTOPILOT_COMPONENT_ID;

use std::time::Duration;

/// System id the host uses as ground station.
pub const GCS_SYSTEM_ID: u8 = 255;
/// Component id the host uses as ground station (`MAV_COMP_ID_MISSIONPLANNER`).
pub const GCS_COMPONENT_ID: u8 = 190;
/// How long the host waits for one answer from a companion before giving up.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(30);

/// A flight over ports that could not be carried out (a link, a process, a refusal).
#[derive(Debug, Clone, PartialEq)]
pub struct PilError(pub String);

impl std::fmt::Display for PilError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PilError {}

/// `Err(PilError(msg))`.
///
/// # Errors
/// Always.
pub fn err<T>(msg: impl Into<String>) -> Result<T, PilError> {
    Err(PilError(msg.into()))
}
