//! Virtual-tube geometry for the cooperative-transport controller.
//!
//! Everything here is 2-D, in the horizontal plane of the virtual tray (REFERENCE §2).
//! World frame: ENU, metres; `x` east, `y` north. The tube is the region swept by
//! cross-sections normal to a smooth generator curve `gamma(s)` (`s` = arc length, m),
//! with left/right half-widths `w_L(s)`, `w_R(s)`; `n(s)` is the tangent rotated +90 deg
//! (to the left of the direction of travel).
//!
//! - [`smooth`]: `sat` (eq:2-22), `sigma`, the smooth minimum `s` (REFERENCE §2).
//! - [`barrier`]: the tube barrier `V_t` (eq:2-15-1) and the robot-robot barrier `V_m`.
//! - [`spline`]: a natural cubic spline through waypoints (chord-length parameter).
//! - [`tube`]: the arc-length table, validation and the section lookup `s(q)` (eq:1-6, eq:1-7).
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod barrier;
mod error;
pub mod smooth;
pub mod spline;
pub mod tube;

pub use barrier::{Barrier, BarrierParams};
pub use error::TubeError;
pub use smooth::{limit, sat, sigma, sigma_deriv, smooth_min, smooth_min_deriv};
pub use spline::{Spline, Waypoint};
pub use tube::{Section, Tube, TubeSample, DEFAULT_SAMPLES};

/// 2-D vector, metres (or metres per second where named so).
pub type Vec2 = nalgebra::Vector2<f32>;
