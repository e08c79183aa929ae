//! The onboard occupancy map: planar range scans folded into a log-odds grid, read back as the
//! planner's obstacle raster (issue 28: tubes generated in flight from a 2-D LiDAR).
//!
//! A law with no I/O, `no_std`, no allocation, `f32` (the conventions of `vt-plan`).
//! World frame ENU, metres, horizontal plane; angles in radians counter-clockwise from east.
//!
//! # Model
//! - [`Scan`]: one planar scan in the world frame, up to [`MAX_BEAMS`] = 72 beams (MAVLink
//!   `OBSTACLE_DISTANCE`), each a [`Return`]: `Hit(range)`, `Clear` or `Unknown`.
//! - [`OccupancyGrid`]: `width x height` cells of side `resolution_m` in a fixed `CELLS`-byte
//!   array, one `i8` per cell: log-odds in 1/16 nat, `> 0` occupied, `< 0` free, `0` unknown.
//!   [`PackedOccupancyGrid`]: the same map at four bits a cell, for one sensor model whose
//!   clamped hits and misses reach at most 16 values ([`store`]; the flight's reaches 14), bit
//!   for bit the byte grid's.
//! - [`OccupancyGrid::integrate`]: every beam frees the cells its ray crosses and occupies the
//!   cell of its hit point ([`LogOddsParams`], OctoMap's sensor model and clamping: Hornung et
//!   al., Autonomous Robots 2013). Rays are walked exactly ([`ray::traverse`], Amanatides and
//!   Woo, Eurographics 1987); the caller hears of every newly occupied cell.
//! - [`OccupancyGrid::integrate_sectors`]: the fold for `OBSTACLE_DISTANCE`, whose beams are
//!   sectors: the scan's free space filled as one polygon row by row (or sector by sector when
//!   the sectors overlap), each hit across its arc nearby ([`sector`]); the one the flight MCU
//!   runs (about 0.1 M Cortex-M4 instructions a 72-sector scan of 15 m at 0.25 m).
//! - [`OccupancyGrid::write_planner_cells`]: the occupied cells, optionally coarsened, in the
//!   convention of `vt_plan::distance_transform` (0.0 occupied, `f32::INFINITY` free or
//!   unknown).
//!
//! # Costs
//! RAM: `CELLS` bytes plus a few words ([`OccupancyGrid::ram_bytes`]); 70 x 30 m at 0.25 m is
//! 280 x 120 = 33,600 cells, about 34 KB, or 17 KB packed (plus its 0.5 KB of tables). Time:
//! a ray of range `R` crosses at most `|dx| + |dy| + 3 <= 1.42 R / resolution + 3` cells (never
//! more than `width + height - 1`), each an `i8` saturating add and a binary search among the
//! scan's <= 72 hit cells; a 72-beam scan of 10 m range at 0.25 m touches at most 72 x 60 =
//! 4,320 cells. No trigonometry per cell (one `sinf`/`cosf` pair per beam, twice).
//!
//! # Examples
//! ```
//! use vt_map::{LogOddsParams, OccupancyGrid, Return, Scan, Vec2};
//!
//! // 10 x 8 m at 0.25 m, lower-left corner at the world origin.
//! let mut map = OccupancyGrid::<1280>::new(40, 32, 0.25, Vec2::new(0.0, 0.0))?;
//! // One beam due east from (1, 4) m that hits something 3 m away.
//! let mut scan = Scan::new(Vec2::new(1.0, 4.0), 0.0, 0.0, 8.0);
//! scan.returns.push(Return::Hit(3.0)).ok();
//! let mut seen = Vec::new();
//! let stats = map.integrate(&scan, &LogOddsParams::default(), |i, j| seen.push((i, j)));
//! assert_eq!(seen, [(16, 16)]); // the cell holding (4, 4) m
//! assert_eq!(stats.cells_updated, 13); // 12 free cells and the hit
//! assert!(map.is_free(4, 16) && map.is_occupied(16, 16));
//!
//! let mut planner = [0.0_f32; 320];
//! let (w, h) = map.write_planner_cells(2, &mut planner)?; // 0.5 m cells for vt-plan
//! assert_eq!((w, h, planner[8 * w + 8]), (20, 16, 0.0));
//! # Ok::<(), vt_map::MapError>(())
//! ```
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

#[cfg(test)]
mod brute_force;
mod error;
mod fan;
pub mod grid;
pub mod integrate;
mod lanes;
pub mod log_odds;
pub mod ray;
pub mod scan;
pub mod sector;
pub mod store;

pub use error::MapError;
pub use grid::{LogOddsGrid, OccupancyGrid, PackedOccupancyGrid};
pub use integrate::IntegrateStats;
pub use log_odds::{probability, LogOddsParams, LOG_ODDS_PER_NAT};
pub use scan::{Return, Scan, MAX_BEAMS};
pub use sector::SectorFold;
pub use store::{Bytes, CellStore, Nibbles};

/// 2-D vector, world ENU, metres.
pub type Vec2 = nalgebra::Vector2<f32>;
