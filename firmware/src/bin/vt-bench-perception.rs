//! The perception instruction-count bench for QEMU (build with `--features perception-bench`;
//! `firmware/src/perception_bench.rs`).
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    vt_firmware::perception_bench::run()
}
