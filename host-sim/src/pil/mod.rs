//! Processor-in-the-loop (PIL): the f64 plant on the host, each UAV's controller inside its own
//! QEMU (`mps2-an386`) running the `qemu` firmware ELF, MAVLink 2 frames over each instance's
//! emulated UART (a Unix socket per instance), in lockstep with simulated time.
//!
//! # Lockstep
//! The firmware runs with `VT_LOCKSTEP = 1`: each own `LOCAL_POSITION_NED` it receives is one
//! low-level period. Per low-level period the host sends every UAV, in this order, the load's
//! state and the neighbours' positions (only when the high level is due) and then its own state;
//! the firmware answers with telemetry and, last, `SET_ATTITUDE_TARGET`, which the host waits
//! for before stepping the plant. Simulated time is carried in `time_boot_ms`; the emulator's
//! own clock plays no part, so results do not depend on host speed.
//!
//! The host plays the autopilot (own state in, attitude setpoint out, flown by the plant's UAV
//! model: the rigid body's attitude and rate loops, or the point mass), the load tracker, the
//! team network (the link model) and the ground station (parameters, the tube as a mission,
//! `MAV_CMD_MISSION_START`). The flight is the one mission loop ([`crate::mission::fly`]) with
//! the companions as the team ([`PortTeam`]).
//!
//! # SIL twin and bit-exactness
//! The same mission is flown again with every UAV's firmware replaced by
//! [`vt_companion::Companion`] compiled for the host (the crate the firmware wraps), fed the
//! identical byte stream. Both runs record every command the controllers produced (attitude
//! quaternion and collective at each low-level step; velocity command and cable-force
//! estimate at each high-level step) and [`PilReport`] compares them bit for bit. The controller
//! crates are `f32` code without fused multiply-add and use the `libm` crate on both sides
//! (`nalgebra/libm-force` on the host), so any difference is a finding, reported with its
//! first occurrence.
//!
//! The world (sensing, noise, latency, wind, link, faults) is the mission loop's, the same
//! for every backend: the high level reads the last low-level sample, the low level the fresh
//! own state.

pub mod bench;
pub mod cli;
pub mod config;
pub mod flight;
pub mod port;
pub mod report;
pub mod wire;

pub use bench::{bench, bench_scenario, BenchReport, StepCounts, BENCH_TEAM_SIZES};
pub use cli::{cli, cli_bench};
pub use config::{configure, recv_until, start_mission, start_mission_with_reason, team_setup, team_setup_for, team_setup_with, TeamSetup, UavConfig};
pub use crate::companion::{WireWaypoint, LOAD_COMPONENT_ID, LOAD_TIMEOUT_S, OWN_TIMEOUT_S, SYSID_BASE};
pub use flight::{fly, fly_team, CommandKind, CommandRecord, FlightOutput, PortTeam, StartHook};
pub use port::{build_firmware, decode_defmt, default_firmware_path, firmware_dir, qemu_available, Port, QemuOptions, QemuPort, SilPort};
pub use report::{compare, run, write_report, CycleStats, Difference, PilOptions, PilReport};
pub use wire::{local_position, Encoder, Encoders, Rx, TickFrames};
pub use vt_companion::AUTOPILOT_COMPONENT_ID;

use std::time::Duration;

/// System id the host uses as ground station.
pub const GCS_SYSTEM_ID: u8 = 255;
/// Component id the host uses as ground station (`MAV_COMP_ID_MISSIONPLANNER`).
pub const GCS_COMPONENT_ID: u8 = 190;
/// How long the host waits for one answer from an emulator before giving up.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(30);

/// A PIL run that could not be carried out.
#[derive(Debug, Clone, PartialEq)]
pub struct PilError(pub String);

impl std::fmt::Display for PilError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PilError {}

pub(crate) fn err<T>(msg: impl Into<String>) -> Result<T, PilError> {
    Err(PilError(msg.into()))
}
