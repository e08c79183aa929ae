//! Dissipative cooperative-transport controller with virtual-tube passing
//! (the paper's §III, eq:2-4 .. eq:2-21; REFERENCE §3), plus the traditional virtual-tube
//! controller used as the paper's baseline (REFERENCE §2).
//!
//! # Frames and units
//! World frame ENU (z up), metres, seconds. Virtual nodes live in the horizontal plane of the
//! virtual tray, `H` metres above the load ([`tray`]); all 2-D vectors are `(x, y)` there.
//!
//! # Structure
//! - [`tray`]: node projection eq:2-4 (corrected) and the velocity mapping eq:2-20 (corrected).
//! - [`springs`]: virtual springs eq:2-5 .. eq:2-7 and their energy (Prop. 1).
//! - [`passing`]: passing term eq:2-13. [`keeping`]: tube-keeping term eq:2-14/eq:2-15.
//! - [`separation`]: the UAV-UAV separation barrier (extension for real airframes, issue 27).
//! - [`shape`]: the formation shaped to the tube ahead (extension, issues 27 and 29).
//! - [`vertical`]: the altitude law (the paper gives none; see `docs/design.md`).
//! - [`capacity`]: the capacity-aware formation (Remark 1 made automatic; issue 15).
//! - [`calibration`]: take-off cable calibration and the tension share (run once, at start).
//! - [`feasibility`]: the pre-flight check that the team can carry the load with margin.
//! - [`controller`]: one UAV's distributed command, synthesis eq:2-16 and saturation eq:2-21.
//! - [`baseline`]: traditional virtual-tube control (no springs, robot-robot barrier).
//! - [`phases`]: the mission from the ground: lift-off, transport, set-down (issue 27).
//! - [`team_hold`]: the team failsafe's mode and resume hysteresis (`docs/design.md`).
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod baseline;
pub mod calibration;
pub mod capacity;
pub mod controller;
pub mod dwell;
mod error;
pub mod feasibility;
pub mod keeping;
pub mod landing;
pub mod passing;
pub mod phases;
pub mod separation;
pub mod shape;
pub mod springs;
pub mod survey;
mod status;
pub mod team_hold;
pub mod tray;
pub mod vertical;
pub mod wind;

pub use baseline::{BaselineController, BaselineParams};
pub use capacity::{CapacityParams, CapacityPlan, FormationScale};
pub use calibration::{calibrate, Calibration, CalibrationError, CalibrationParams};
pub use controller::{Command, DissipativeController, DissipativeParams, Measurements, ShapeSeparation};
pub use error::ControlError;
pub use phases::{Abort, Phase, PhaseParams, PhaseProfile};
pub use shape::ShapeParams;
pub use feasibility::{Feasibility, FeasibilityError, FeasibilityParams};
pub use springs::Formation;
pub use status::Status;
pub use survey::{PositionMean, TakeoffSurvey};
pub use team_hold::{TeamHoldSupervisor, TeamMode};
pub use tray::TrayParams;
pub use vertical::VerticalParams;
pub use wind::{WindCapacity, WindError, WindLimit, WindParams};

/// 2-D vector (tray plane), m or m/s.
pub type Vec2 = nalgebra::Vector2<f32>;
/// 3-D vector (world ENU), m or m/s.
pub type Vec3 = nalgebra::Vector3<f32>;

/// Largest team this crate's fixed-capacity types are instantiated with by default.
pub const MAX_UAVS: usize = 32;
