//! Issue 28 on the flight MCU's core: the onboard map update and the re-plan, measured in
//! Cortex-M4 instructions under `qemu-system-arm -icount shift=0` (`vt-bench-perception`,
//! firmware/src/perception_bench.rs). Instruction counts are a property of the binary and its
//! inputs, not of the machine running QEMU, so these are not timed tests.

mod common;

use std::path::{Path, PathBuf};

use host_sim::pil;

const QEMU: &str = "qemu-system-arm";

/// The bench ELF, or `None` (with the reason printed) when QEMU is missing.
fn bench_elf() -> Option<PathBuf> {
    if !common::qemu_present(QEMU, "the perception bench") {
        return None;
    }
    Some(pil::build_perception_bench().expect("the perception bench firmware builds"))
}

fn out_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("perception-mcu").join(name)
}

#[test]
fn onboard_map_update_and_replan_run_on_the_mcu_core() {
    let Some(elf) = bench_elf() else { return };
    let r = pil::perception_bench(&elf, QEMU, &out_dir("sockets")).expect("the bench runs");
    eprintln!("{r:#?}");
    std::fs::create_dir_all(out_dir("")).unwrap();
    std::fs::write(out_dir("perception_bench.json"), serde_json::to_string_pretty(&r).unwrap()).unwrap();
    println!("\n{}", r.hook_json());
    assert!((r.instructions_per_tick - 40.0).abs() < 0.2, "icount calibration {}", r.instructions_per_tick);
    assert_eq!(r.scans, 75);
    assert!(r.blocked, "the pillar in the tube was not seen as blocking it");
    assert!(r.replans_ok, "a re-plan found no tube in the bench world (it has a route)");
    assert!(r.map_update_mean > 0.0 && r.map_update_max >= r.map_update_mean);
    assert!(r.replan_empty_map > 0.0 && r.replan_seen_map > 0.0);
    // Issue 28's budgets on the flight MCU's core (168 MHz): one scan into the map within 1 ms,
    // 168 k instructions (the worst of the bench's scans with the tube trigger, and the fold
    // alone on the synthetic scans: all clear is the most free space); a full re-plan on the
    // 70 x 30 m map within 100 ms, 16.8 M, on the empty map and on the map after the scans.
    assert!(r.map_update_max <= MAP_UPDATE_BUDGET, "map update {} > {MAP_UPDATE_BUDGET} instructions", r.map_update_max);
    for (what, t) in ["all clear", "all hit at 9.9 m", "all hit at 5.9 m"].iter().zip(r.fold_synthetic) {
        assert!(t > 0.0 && t <= MAP_UPDATE_BUDGET, "fold of a scan {what}: {t} > {MAP_UPDATE_BUDGET} instructions");
    }
    for (what, t) in [("empty", r.replan_empty_map), ("seen", r.replan_seen_map)] {
        assert!(t <= REPLAN_BUDGET, "re-plan on the {what} map: {t} > {REPLAN_BUDGET} instructions");
    }
}

/// Issue 28's budget for one scan into the onboard map, Cortex-M4 instructions (1 ms at
/// 168 MHz).
const MAP_UPDATE_BUDGET: f64 = 168_000.0;
/// Issue 28's budget for a full re-plan on the 70 x 30 m onboard map, Cortex-M4 instructions
/// (100 ms at 168 MHz).
const REPLAN_BUDGET: f64 = 16_800_000.0;
