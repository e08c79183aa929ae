//! The PIL report: SIL and PIL command streams compared bit for bit, loop timing,
//! `pil_report.json`.

use crate::scenario::LoadedScenario;
use crate::sim::{self};
use crate::summary::Summary;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use vt_sim::lockstep::flight::*;
use super::qemu::*;
use vt_sim::lockstep::port::*;
use vt_sim::lockstep::wire::*;
use super::{compare, err, Difference, PilError, SYSID_BASE};

/// Options of `host-sim pil`.
#[derive(Debug, Clone)]
pub struct PilOptions {
    /// The `qemu` firmware ELF.
    pub firmware: PathBuf,
    /// The emulator.
    pub qemu: String,
    /// Output directory (also holds the sockets).
    pub out_dir: PathBuf,
    /// Shorten the flight (s).
    pub duration_s: Option<f64>,
    /// Override of the scenario's UAV model.
    pub uav_model: Option<crate::models::UavModel>,
    /// Override of the scenario's cable model.
    pub cable_model: Option<crate::models::CableModel>,
    /// Also write the PIL flight as an MCAP log here (docs/replay.md).
    pub mcap: Option<PathBuf>,
}

/// Cycle statistics of one companion (board cycles: the 25 MHz timer under QEMU).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CycleStats {
    /// UAV index.
    pub uav: usize,
    /// Samples.
    pub samples: usize,
    /// Mean high-level step.
    pub high_level_mean: f64,
    /// Worst high-level step.
    pub high_level_max: f64,
    /// Mean low-level step.
    pub low_level_mean: f64,
    /// Worst low-level step.
    pub low_level_max: f64,
}

/// `pil_report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct PilReport {
    /// Scenario name.
    pub scenario: String,
    /// Team size.
    pub n_uavs: usize,
    /// Commands compared (attitude setpoints + velocity commands, all UAVs).
    pub commands_compared: usize,
    /// Largest absolute difference over every compared value.
    pub max_abs_diff: f64,
    /// Every compared value identical bit for bit, and the same number of commands.
    pub bit_exact: bool,
    /// The first difference, if any.
    pub first_difference: Option<Difference>,
    /// The PIL run's summary.
    pub summary: Summary,
    /// The PIL run's timeline: faults, and each UAV's hold and resume (team failsafe).
    pub events: Vec<crate::record::RecordEvent>,
    /// The host twin's (SIL) summary.
    pub sil_summary: Summary,
    /// `sim::run` on the same scenario: the controller crates called directly (SIL-crates),
    /// through the same mission loop (docs/design.md says where it may differ from the twin).
    pub host_sim_summary: Option<Summary>,
    /// How the runs were synchronised.
    pub lockstep: String,
    /// The firmware ELF.
    pub firmware: String,
    /// `qemu-system-arm --version`, first line.
    pub qemu: String,
    /// Error counters last reported by each firmware (`SYS_STATUS`: checksum+framing, unknown
    /// ids, bad values, overruns, discarded bytes).
    pub firmware_errors: Vec<[u16; 5]>,
    /// Loop timing reported by each firmware (25 MHz timer cycles under QEMU; host speed dependent
    /// without `-icount`).
    pub cycles: Vec<CycleStats>,
    /// Exit codes of the emulators after the shutdown command.
    pub qemu_exit_codes: Vec<Option<i32>>,
    /// Decoded defmt log of UAV 0's firmware.
    pub defmt_log_uav0: Vec<String>,
    /// Wall-clock seconds: SIL flight, PIL flight.
    pub wall_time_s: [f64; 2],
    /// Issue 28 (map unknown; the emulators then run under `-icount shift=0`): the longest
    /// re-plan any firmware made in the flight, Cortex-M4 instructions (its `REPLAN.z` board
    /// cycles times UAV 0's boot calibration); `None` with a known map.
    pub replan_worst_instructions: Option<f64>,
}

fn cycle_stats(out: &FlightOutput) -> Vec<CycleStats> {
    let stat = |v: &[f32]| {
        let m = v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64;
        let mx = v.iter().fold(0.0f64, |a, &x| a.max(f64::from(x)));
        (m, mx)
    };
    out.hl_cycles
        .iter()
        .zip(out.ll_cycles.iter())
        .enumerate()
        .map(|(uav, (h, l))| {
            // Skip the first sample: the first high-level step warms the tube lookup.
            let h = h.get(1..).unwrap_or(&[]);
            let l = l.get(1..).unwrap_or(&[]);
            let (hm, hx) = stat(h);
            let (lm, lx) = stat(l);
            CycleStats { uav, samples: h.len(), high_level_mean: hm, high_level_max: hx, low_level_mean: lm, low_level_max: lx }
        })
        .collect()
}

fn qemu_version(qemu: &str) -> String {
    Command::new(qemu)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.lines().next().map(str::to_string))
        .unwrap_or_default()
}

/// Flies `ls` SIL (host twins) and PIL (one QEMU per UAV), compares the commands, and writes
/// `pil_report.json` and the PIL run's `summary.json` into `opts.out_dir`.
///
/// # Errors
/// Any flight failure, or the report cannot be written.
pub fn run(ls: &LoadedScenario, opts: &PilOptions) -> Result<PilReport, PilError> {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    let run_opts = sim::RunOptions { duration_s: opts.duration_s, record: true, uav_model: opts.uav_model, cable_model: opts.cable_model, ..sim::RunOptions::default() };
    let dt = 1.0 / f64::from(s.rates.plant_hz);

    let t0 = Instant::now();
    let mut sil_ports: Vec<SilPort> = (0..n).map(|_| SilPort::new()).collect();
    let sil = fly(ls, &mut sil_ports, &run_opts, "SIL")?;
    let sil_wall = t0.elapsed().as_secs_f64();

    let t0 = Instant::now();
    let sock_dir = opts.out_dir.join("sockets");
    let mut qemus = Vec::with_capacity(n);
    for i in 0..n {
        // With re-planning aboard, instruction counts (the re-plan's budget) need `-icount`.
        let icount = crate::mission::replan::perception_config(s).is_some();
        let o = QemuOptions { qemu: opts.qemu.clone(), icount, socket_dir: sock_dir.clone(), name: format!("uav{i}") };
        qemus.push(QemuPort::spawn(&opts.firmware, &o)?);
    }
    let pil = match fly(ls, &mut qemus, &run_opts, "PIL") {
        Ok(p) => p,
        Err(e) => {
            // Attach what the firmware logged: the first thing to read when a run fails.
            let mut msg = e.0;
            for (i, q) in qemus.iter().enumerate() {
                let lines = decode_defmt(&opts.firmware, &q.defmt_bytes()).unwrap_or_default();
                let tail = lines.len().saturating_sub(8);
                for l in lines.get(tail..).unwrap_or(&[]) {
                    msg.push_str(&format!("\n  UAV {i} firmware: {l}"));
                }
            }
            return err(msg);
        }
    };
    let pil_wall = t0.elapsed().as_secs_f64();
    // Shut the emulators down cleanly and collect their logs.
    let mut exit_codes = Vec::new();
    let mut defmt0 = Vec::new();
    for (i, q) in qemus.into_iter().enumerate() {
        let mut enc = Encoder::default();
        let (code, bytes) = q.shutdown(&mut enc, SYSID_BASE + i as u8)?;
        exit_codes.push(code);
        if i == 0 {
            defmt0 = decode_defmt(&opts.firmware, &bytes).unwrap_or_else(|e| vec![format!("<{e}>")]);
        }
    }
    let _ = std::fs::remove_dir(&sock_dir);

    let (commands_compared, max_abs_diff, bit_exact, first_difference) = compare(&sil.commands, &pil.commands, dt);
    let replan_worst_instructions = match (pil.replan_worst_cycles.iter().copied().reduce(f32::max), super::bench::calibration(&defmt0)) {
        (Some(cycles), Ok((_, _, per_tick))) => Some(f64::from(cycles) * per_tick),
        _ => None,
    };
    let host_sim_summary = sim::run(ls, &sim::RunOptions { record: false, ..run_opts.clone() }).ok().map(|o| o.summary);
    let report = PilReport {
        scenario: s.name.clone(),
        n_uavs: n,
        commands_compared,
        max_abs_diff,
        bit_exact,
        first_difference,
        summary: pil.summary.clone(),
        events: pil.record.events.clone(),
        sil_summary: sil.summary.clone(),
        host_sim_summary,
        lockstep: "event-driven: VT_LOCKSTEP=1, each own LOCAL_POSITION_NED is one low-level period; the host waits for \
                   SET_ATTITUDE_TARGET before stepping the plant; simulated time travels in time_boot_ms"
            .into(),
        firmware: opts.firmware.display().to_string(),
        qemu: qemu_version(&opts.qemu),
        firmware_errors: pil.status.clone(),
        cycles: cycle_stats(&pil),
        qemu_exit_codes: exit_codes,
        defmt_log_uav0: defmt0,
        wall_time_s: [sil_wall, pil_wall],
        replan_worst_instructions,
    };
    write_report(&opts.out_dir, &report)?;
    // The PIL flight as the browser replay (docs/replay.md), beside the report.
    let scene = sim::scene(ls);
    crate::replay::write(&opts.out_dir, &scene, &[&pil.record]).map_err(PilError)?;
    if let Some(path) = &opts.mcap {
        crate::mcap_log::write(path, &scene, &[&pil.record]).map_err(PilError)?;
    }
    Ok(report)
}

/// Writes `pil_report.json` and `summary.json` (the PIL run's) into `dir`.
///
/// # Errors
/// I/O.
pub fn write_report(dir: &Path, report: &PilReport) -> Result<(), PilError> {
    std::fs::create_dir_all(dir).map_err(|e| PilError(format!("{}: {e}", dir.display())))?;
    let w = |name: &str, text: String| std::fs::write(dir.join(name), text + "\n").map_err(|e| PilError(format!("{name}: {e}")));
    w("pil_report.json", serde_json::to_string_pretty(report).map_err(|e| PilError(e.to_string()))?)?;
    w("summary.json", serde_json::to_string_pretty(&report.summary).map_err(|e| PilError(e.to_string()))?)?;
    Ok(())
}
