//! The firmware for the `qemu` board (build with `--features qemu`); everything is in the library.
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    vt_firmware::run()
}
