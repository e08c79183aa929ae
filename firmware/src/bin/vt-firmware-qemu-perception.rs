//! The firmware for the `qemu` board with in-flight re-planning (build with
//! `--features qemu,perception`); everything is in the library.
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    vt_firmware::run()
}
