//! Instruction counts of the firmware's control steps (Cortex-M4 under `qemu -icount`).

use crate::scenario::LoadedScenario;
use mavlink::dialects::common::{
    MavCmd, COMMAND_LONG_DATA,
};
use serde::Serialize;

use std::path::Path;
use vt_companion::COMPANION_COMPONENT_ID;
use vt_dissipative::MAX_UAVS;
use vt_sim::lockstep::flight::*;
use super::qemu::*;
use vt_sim::lockstep::port::*;
use vt_sim::lockstep::wire::*;
use super::{err, PilError, GCS_COMPONENT_ID, GCS_SYSTEM_ID, SYSID_BASE};

/// Team sizes the instruction counts are measured for.
pub const BENCH_TEAM_SIZES: [usize; 3] = [3, 10, 30];

/// The scenario flown for a team of `n`: the experiment (3), the paper's mission (10), or the
/// paper's mission with its ten cables repeated (any other size up to the capacity).
///
/// # Errors
/// The scenario files cannot be read, or `n` exceeds the capacity.
pub fn bench_scenario(n: usize) -> Result<LoadedScenario, PilError> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios");
    let load = |f: &str| crate::scenario::load(Some(&dir.join(f))).map_err(|e| PilError(e.to_string()));
    match n {
        3 => load("experiment-3uav.toml"),
        10 => load("paper-10uav.toml"),
        _ if n == 0 || n > MAX_UAVS => err(format!("team of {n} outside 1..={MAX_UAVS}")),
        _ => {
            let mut ls = load("paper-10uav.toml")?;
            let base = ls.scenario.cables.lengths_m.clone();
            ls.scenario.cables.lengths_m = base.iter().copied().cycle().take(n).collect();
            ls.scenario.name = format!("paper-{n}uav (bench)");
            Ok(ls)
        }
    }
}

/// Instruction counts of one team size (UAV 0's firmware under `-icount shift=0`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepCounts {
    /// Team size.
    pub n_uavs: usize,
    /// Scenario flown.
    pub scenario: String,
    /// High-level steps measured.
    pub high_level_steps: usize,
    /// Mean instructions of a high-level step (tube + springs + vertical law).
    pub high_level_mean: f64,
    /// Worst high-level step.
    pub high_level_max: f64,
    /// Low-level steps measured (one per high-level step: the one before it).
    pub low_level_steps: usize,
    /// Mean instructions of a low-level step (velocity loop + CFO + attitude).
    pub low_level_mean: f64,
    /// Worst low-level step.
    pub low_level_max: f64,
    /// Stack high-water mark of the firmware at the end, bytes.
    pub stack_peak_bytes: Option<u64>,
    /// Instructions of the one-off tube build (`Tube::rebuild`, on the mission upload).
    pub tube_build_instructions: Option<f64>,
}

/// `pil-bench` output.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// Instructions per 25 MHz timer cycle, measured by the firmware's calibration loop.
    pub instructions_per_tick: f64,
    /// The calibration as logged: (instructions, ticks).
    pub calibration: (u64, u64),
    /// Per team size.
    pub steps: Vec<StepCounts>,
    /// Simulated seconds flown per team size.
    pub duration_s: f64,
    /// The firmware ELF.
    pub firmware: String,
}

/// The integer right after `prefix` in a decoded log line (its digits up to the first other
/// character).
pub(super) fn parse_after(line: &str, prefix: &str) -> Option<u64> {
    line.split(prefix).nth(1)?.split(|c: char| !c.is_ascii_digit()).next()?.parse().ok()
}

/// The firmware's boot calibration (`board::boot_report`): instructions, timer cycles, and
/// their ratio (40 under `-icount shift=0`).
///
/// # Errors
/// The log has no calibration line, or it measured 0 ticks (no `-icount`).
pub(super) fn calibration(log: &[String]) -> Result<(u64, u64, f64), PilError> {
    let (i, t) = log
        .iter()
        .filter(|l| l.starts_with("calibration:"))
        .find_map(|l| parse_after(l, "calibration: ").zip(parse_after(l, "instructions in ")))
        .ok_or_else(|| PilError("no calibration in the firmware log".into()))?;
    if t == 0 {
        return err("calibration measured 0 ticks (is -icount active?)");
    }
    Ok((i, t, i as f64 / t as f64))
}

/// Measures instructions per high-level and low-level step for each team size in `teams`
/// (`pil-bench` uses [`BENCH_TEAM_SIZES`]), flying `duration_s` each: UAV 0 runs in QEMU with `-icount shift=0` (one instruction per virtual ns, so one 25 MHz SysTick
/// tick is 40 instructions; the firmware's calibration loop checks that), the rest of the team
/// as host twins. The counts cover the control steps only (`Flight::high_level`,
/// `Flight::low_level`), not MAVLink decoding or encoding, and include the few SysTick
/// interrupts that fall inside a step.
///
/// # Errors
/// A flight fails, or the firmware's log lacks the calibration.
pub fn bench(firmware: &Path, qemu: &str, socket_dir: &Path, teams: &[usize], duration_s: f64) -> Result<BenchReport, PilError> {
    let mut steps = Vec::new();
    let mut calib = None;
    for &n in teams {
        let ls = bench_scenario(n)?;
        let o = QemuOptions { qemu: qemu.into(), icount: true, socket_dir: socket_dir.into(), name: format!("bench{n}") };
        let q = QemuPort::spawn(firmware, &o)?;
        let mut ports: Vec<Box<dyn Port>> = vec![Box::new(q)];
        ports.extend((1..n).map(|_| Box::new(SilPort::new()) as Box<dyn Port>));
        let opts = crate::sim::RunOptions { duration_s: Some(duration_s), record: false, ..crate::sim::RunOptions::default() };
        let out = fly(&ls, &mut ports, &opts, "bench")?;
        let Some(first) = ports.into_iter().next() else { return err("no port") };
        // Shut UAV 0's emulator down through its link and read its log.
        let (code, bytes) = shutdown_boxed(first, &mut Encoder::default())?;
        if code != Some(0) {
            return err(format!("bench emulator exited with {code:?}"));
        }
        let log = decode_defmt(firmware, &bytes)?;
        let stack = super::image::stack_high_water_bytes(&log);
        let mut tube_ticks = None;
        for l in &log {
            if let Some(c) = parse_after(l, "built in ") {
                tube_ticks = Some(c);
            }
        }
        let (i, t, k) = calibration(&log)?;
        calib = Some((i, t));
        let stat = |v: &[f32]| {
            let v = v.get(1..).unwrap_or(&[]); // the first step warms the tube lookup up
            let mean = v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64;
            let max = v.iter().fold(0.0f64, |a, &x| a.max(f64::from(x)));
            (v.len(), mean * k, max * k)
        };
        let (hn, hm, hx) = stat(&out.hl_cycles[0]);
        let (ln, lm, lx) = stat(&out.ll_cycles[0]);
        steps.push(StepCounts {
            n_uavs: n,
            scenario: ls.scenario.name.clone(),
            high_level_steps: hn,
            high_level_mean: hm,
            high_level_max: hx,
            low_level_steps: ln,
            low_level_mean: lm,
            low_level_max: lx,
            stack_peak_bytes: stack,
            tube_build_instructions: tube_ticks.map(|c| c as f64 * k),
        });
    }
    let (i, t) = calib.unwrap_or((0, 1));
    Ok(BenchReport {
        instructions_per_tick: i as f64 / t.max(1) as f64,
        calibration: (i, t),
        steps,
        duration_s,
        firmware: firmware.display().to_string(),
    })
}

impl BenchReport {
    /// The object `cargo xtask bench` reads from `firmware/bench.sh` (issue 5's hook).
    pub fn hook_json(&self) -> serde_json::Value {
        let per = |f: &dyn Fn(&StepCounts) -> f64| {
            serde_json::Value::Object(self.steps.iter().map(|s| (s.n_uavs.to_string(), serde_json::json!(f(s).round() as u64))).collect())
        };
        let ll = self.steps.iter().map(|s| s.low_level_mean).fold(0.0f64, f64::max);
        let stack = self.steps.iter().filter_map(|s| s.stack_peak_bytes).max();
        serde_json::json!({
            "mcu_instructions_per_uav_step": per(&|s| s.high_level_mean + s.low_level_mean),
            "mcu_instructions_high_level": per(&|s| s.high_level_mean),
            "mcu_instructions_low_level": ll.round() as u64,
            "firmware_stack_peak_bytes": { "qemu": stack },
            "instructions_per_tick": self.instructions_per_tick,
            "steps": self.steps,
        })
    }
}

/// Shuts down a boxed port that holds a [`QemuPort`] (sends the command, drains, waits).
fn shutdown_boxed(mut port: Box<dyn Port>, enc: &mut Encoder) -> Result<(Option<i32>, Vec<u8>), PilError> {
    let cmd = COMMAND_LONG_DATA {
        param1: 2.0,
        command: MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
        target_system: SYSID_BASE,
        target_component: COMPANION_COMPONENT_ID,
        ..COMMAND_LONG_DATA::default()
    };
    port.send(&enc.frame(GCS_SYSTEM_ID, GCS_COMPONENT_ID, &cmd))?;
    port.finish()
}
