//! The simulation library of the cooperative-transport controller (issue 26: host-sim split
//! along its seams): scenarios, the world (sensing, link, wind, faults), the plants (rigid-body
//! quadrotors, point masses, cables), the metrics and `summary.json`, the one mission loop, the
//! companions as its team (in process, or behind MAVLink ports in lockstep), host-sim as a
//! MAVLink simulator (`sitl`: UDP ports, the ground station, real time, RotorPy) and the score
//! of a trajectory flown elsewhere. No plots, replay, MCAP or QEMU: those are host-sim's
//! (`cargo tree -p vt-sim` shows what this builds). A thin composition: no control law lives
//! here.
#![forbid(unsafe_code)]

pub mod cable;
pub mod clearance;
pub mod companion;
pub mod disturbance;
pub mod lidar;
pub mod link;
pub mod lockstep;
pub mod map;
pub mod metrics;
pub mod mission;
pub mod models;
pub mod observer_lag;
pub mod obstacles;
pub mod phases;
pub mod plan;
pub mod plant;
pub mod quadrotor;
pub mod record;
pub mod scenario;
pub mod sensing;
pub mod score;
pub mod sim;
pub mod sitl;
pub mod summary;
pub mod turbulence;
