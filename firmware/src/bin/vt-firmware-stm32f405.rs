//! The firmware for the `stm32f405` board (build with `--features stm32f405`); everything is in the library.
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    vt_firmware::run()
}
