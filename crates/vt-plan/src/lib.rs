//! Virtual-tube planning: from an obstacle map to the waypoints of a valid tube.
//!
//! A law with no I/O, `no_std`, no allocation, `f32` (the same conventions as `vt-tube`).
//! World frame ENU, metres, horizontal plane. The algorithm (docs/planning.md):
//!
//! 1. [`ClearanceMap`]: the distance from a point to the nearest obstacle, exact for geometric
//!    obstacles ([`ObstacleMap`]: circles, polygons, walls) or from a Euclidean distance
//!    transform for occupancy grids ([`GridMap`], [`distance_transform`]), or exact from an
//!    occupancy grid in bits ([`OccupancyMap`], the flight MCU's).
//! 2. [`search`]: A* over a square lattice of candidate disc centres; a node is usable when its
//!    free disc (clearance less a margin, capped) holds the required half-width. When no chain
//!    exists, a widest-path search names the narrowest passage.
//! 3. [`corridor`]: the lattice path becomes a chain of overlapping free discs.
//! 4. [`planner`]: the generator curve (vt-tube's natural cubic spline) passes through the
//!    centres of the disc intersections; half-widths are the curve's clearance less the margin,
//!    capped so the tube never folds; `vt_tube::Tube::from_waypoints` is the acceptance gate.
//!
//! Work space (lattice arrays, distance field) is borrowed from the caller as slices, so the
//! planner allocates nothing at any map size.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod corridor;
mod error;
pub mod grid;
pub mod map;
mod node_clearance;
pub mod occupancy;
pub mod planner;
pub mod search;

pub use corridor::{Disc, MAX_DISCS};
pub use error::PlanError;
pub use grid::{distance_transform, distance_transform_eighths, distance_transform_squares, DistanceCells, GridMap, EIGHTHS_FAR, SQUARES_FAR, SQUARES_NONE};
pub use map::{ClearanceMap, Obstacle, ObstacleMap};
pub use planner::{plan, plan_in, Bottleneck, PlanParams, PlannedTube};
pub use node_clearance::SweepSpace;
pub use occupancy::{OccupancyBits, OccupancyMap};
pub use search::{Lattice, NodeIndex, RadiusCell, Workspace};

/// 2-D vector, metres.
pub type Vec2 = nalgebra::Vector2<f32>;

