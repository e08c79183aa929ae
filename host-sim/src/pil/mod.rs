//! Processor-in-the-loop (PIL): the f64 plant on the host, each UAV's controller inside its own
//! QEMU (`mps2-an386`) running the `qemu` firmware ELF, MAVLink 2 frames over each instance's
//! emulated Ethernet controller ([`ethernet`]; a Unix socket per instance), in lockstep with
//! simulated time
//! ([`vt_sim::lockstep`], re-exported here: the protocol, the ports, the team).
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
pub mod ethernet;
pub mod image;
pub mod perception_bench;
pub mod qemu;
pub mod report;

pub use bench::{bench, bench_scenario, BenchReport, StepCounts, BENCH_TEAM_SIZES};
pub use cli::{cli, cli_bench};
pub use perception_bench::{build_perception_bench, perception_bench, PerceptionBench};
pub use qemu::{build_firmware, build_firmware_bin, build_firmware_for, decode_defmt, default_firmware_path, firmware_dir, qemu_available, QemuOptions, QemuPort};
pub use report::{run, write_report, CycleStats, PilOptions, PilReport};
pub use vt_sim::lockstep::*;
