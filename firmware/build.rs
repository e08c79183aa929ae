//! Puts the selected board's `memory.x` (and, for QEMU, `device.x`) on the linker search path.
//!
//! - `qemu`: `memory-qemu.x` (mps2-an386) and a `device.x` naming the board's interrupts;
//!   with `perception-bench`, `memory-qemu-bench.x` (the board's full RAM; not a flight
//!   layout); with `perception`, `memory-qemu-perception.x` (the STM32F405's 128 KiB of SRAM
//!   and 64 KiB of CCM, the map and the planner's work space in the CCM).
//! - `stm32f405`: the repository's top-level `memory.x` (embassy-stm32 provides `device.x`).
use std::env;
use std::fs;
use std::path::PathBuf;

/// mps2-an386 interrupt lines used by the firmware (QEMU `hw/arm/mps2.c`: UART0 RX is IRQ 0,
/// TX IRQ 1; UART 0-2 overruns are ORed onto IRQ 12). All others go to the default handler.
const DEVICE_X: &str = "PROVIDE(UART0RX = DefaultHandler);\nPROVIDE(UART0TX = DefaultHandler);\nPROVIDE(UARTOVF = DefaultHandler);\n";

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    let qemu = env::var_os("CARGO_FEATURE_QEMU").is_some();
    let stm32 = env::var_os("CARGO_FEATURE_STM32F405").is_some();
    let bench = env::var_os("CARGO_FEATURE_PERCEPTION_BENCH").is_some();
    let perception = env::var_os("CARGO_FEATURE_PERCEPTION").is_some();
    let memory = match (qemu, stm32) {
        (true, false) if bench => "memory-qemu-bench.x",
        (true, false) if perception => "memory-qemu-perception.x",
        (true, false) => "memory-qemu.x",
        (false, true) => "../memory.x",
        _ => {
            println!("cargo:warning=select exactly one board feature: `qemu` or `stm32f405`");
            return;
        }
    };
    println!("cargo:rerun-if-changed={memory}");
    println!("cargo:rerun-if-changed=build.rs");
    if let Err(e) = fs::copy(memory, out.join("memory.x")) {
        println!("cargo:warning=cannot copy {memory}: {e}");
    }
    if qemu {
        if let Err(e) = fs::write(out.join("device.x"), DEVICE_X) {
            println!("cargo:warning=cannot write device.x: {e}");
        }
    }
    println!("cargo:rustc-link-search={}", out.display());
}
