//! The perception firmware with the planner task's pause inside its hold of the companion
//! (build with `--features qemu,perception,lock-pause`; a test build, tests/pil.rs); everything
//! is in the library.
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    vt_firmware::run()
}
