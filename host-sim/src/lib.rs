//! Software-in-the-loop simulator for the virtual-tube cooperative-transport controller:
//! the f64 plant of REFERENCE §1, the crates' controllers (one instance per UAV), scenarios,
//! metrics and reports. A thin composition: no control law lives here.
#![forbid(unsafe_code)]

pub mod cable;
pub mod campaign;
pub mod companion;
pub mod disturbance;
pub mod link;
pub mod metrics;
pub mod mission;
pub mod models;
pub mod mcap_log;
pub mod map;
pub mod pil;
pub mod plan;
pub mod plan_plot;
pub mod plant;
pub mod quadrotor;
pub mod plots;
pub mod record;
pub mod replay;
pub mod report;
pub mod scenario;
pub mod score;
pub mod sim;
pub mod sitl;
pub mod summary;
