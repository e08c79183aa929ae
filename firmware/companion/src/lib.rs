//! The cooperative-transport companion computer without its hardware: the MAVLink v2 link, the
//! configuration (parameters and the tube as a mission), the data freshness failsafe, and the
//! two control steps that run the controller crates (`vt-dissipative` high level,
//! `vt-cfo` low level).
//!
//! The firmware (`firmware/src`) owns one [`Companion`] per board and feeds it bytes, time and
//! ticks; host-sim's processor-in-the-loop runner owns one per UAV as the software-in-the-loop
//! twin of the firmware, fed the same bytes. Same code, same `f32` inputs, same commands
//! (`docs/firmware.md`).
//!
//! # Frames and units
//! Wire (MAVLink): local NED, body FRD, metres, seconds, newtons. Inside: world ENU and body FLU,
//! as in the controller crates. [`frames`] converts; every conversion but the quaternion's is
//! exact (swaps and sign flips).
//!
//! # Structure
//! - [`framer`]: [`Framer`], bytes to CRC-checked MAVLink 2 frames, every defect counted.
//! - [`params`]: [`Params`], the parameter table (`PARAM_SET` names, ranges, defaults).
//! - [`mission`]: [`MissionUpload`], the tube's waypoints over the MAVLink mission protocol.
//! - [`flight`]: [`Flight`], the armed controllers: high-level step, low-level step, failsafe.
//! - [`perception`]: [`perception::Perception`], the onboard map and in-flight re-planning (issue 28).
//! - [`replanning`]: [`replanning::Replanning`], the decisions of in-flight re-planning around
//!   the map: scans folded, stops, the designated planner, offers, the no-route hold.
//! - [`scans`]: range scans as `OBSTACLE_DISTANCE` and back (issue 28).
//! - [`refusal`]: why a mission start was refused, as telemetry (code and `STATUSTEXT` lines).
//! - [`companion`]: [`Companion`], message dispatch, lockstep ticks, telemetry.
//! - [`frames`]: NED/ENU and FRD/FLU conversions.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod companion;
pub mod flight;
pub mod framer;
pub mod frames;
pub mod mission;
pub mod params;
pub mod perception;
pub mod refusal;
pub mod replanning;
pub mod scans;

pub use companion::{Companion, Io, Mode, Request, Source};
#[cfg(feature = "perception")]
pub use companion::ReplanSlot;
pub use flight::{Flight, HoldReasons, MemberBits};
#[cfg(feature = "std")]
pub use flight::shaped_need_at_arming_m;
pub use framer::{Frame, Framer, LinkCounters};
pub use mission::{Item, MissionResult, MissionUpload};
pub use params::{Param, ParamError, Params, AUTO};

/// Team capacity of the fixed-size controller types: the crates' default (32) on the flight
/// MCU; 128 with the `large-teams` feature (host builds: the simulator's 100-UAV scenario). The
/// control steps loop over the team's `VT_N_UAVS` members only, so the capacity changes memory,
/// not results (the twin with 128 and the firmware with 32 agree bit for bit, tests/pil.rs).
#[cfg(not(feature = "large-teams"))]
pub const MAX_UAVS: usize = vt_dissipative::MAX_UAVS;
/// Team capacity of the fixed-size controller types (`large-teams`: host builds).
#[cfg(feature = "large-teams")]
pub const MAX_UAVS: usize = 128;
/// Arc-length table size of the tube; host-sim's `TUBE_SAMPLES` is the same constant, so the
/// firmware and the simulator build the same table.
pub const TUBE_SAMPLES: usize = vt_tube::DEFAULT_SAMPLES;
/// The tube type of the companion.
pub type CompanionTube = vt_tube::Tube<TUBE_SAMPLES>;
/// Waypoint capacity of a tube upload (the spline's capacity).
pub const MAX_WAYPOINTS: usize = vt_tube::tube::MAX_WAYPOINTS;

/// 3-D vector, world ENU.
pub type Vec3 = nalgebra::Vector3<f32>;

/// MAVLink component id of the companion (`MAV_COMP_ID_ONBOARD_COMPUTER`).
pub const COMPANION_COMPONENT_ID: u8 = 191;
/// MAVLink component id of the autopilot that sends `LOCAL_POSITION_NED` and receives
/// `SET_ATTITUDE_TARGET` (`MAV_COMP_ID_AUTOPILOT1`).
pub const AUTOPILOT_COMPONENT_ID: u8 = 1;

/// Logs through defmt when the `defmt` feature is on; compiles to nothing otherwise.
macro_rules! log {
    ($level:ident, $($arg:tt)*) => {
        #[cfg(feature = "defmt")]
        defmt::$level!($($arg)*);
    };
}
pub(crate) use log;
