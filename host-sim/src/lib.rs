//! host-sim: the command line, reports, plots, replay, MCAP logs, campaigns and
//! processor-in-the-loop (QEMU) around the simulation library [`vt_sim`] (scenario, world,
//! plant, link, metrics, the mission loop, the MAVLink transport), whose modules are
//! re-exported here under their own names.
#![forbid(unsafe_code)]

pub use vt_sim::{cable, clearance, companion, sensing, disturbance, lidar, link, lockstep, map, metrics, mission, models, obstacles, phases, plan, plant, quadrotor, record, scenario, score, sim, summary};

pub mod campaign;
pub mod mcap_log;
pub mod pil;
pub mod plan_plot;
pub mod plots;
pub mod replay;
pub mod report;

/// host-sim as a MAVLink simulator ([`vt_sim::sitl`]) and its command line.
pub mod sitl {
    pub use vt_sim::sitl::*;
    pub mod cli;
}
