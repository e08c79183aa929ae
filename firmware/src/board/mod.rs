//! Board support: one module per board, the same items in each.
//!
//! `NAME`, `init() -> Board`, `Executor`, `LinkRx::{read, take_overruns}`, `LinkTx::write`,
//! `Watchdog::feed`, `cycles()`, `boot_report()`, `shutdown()`, `reboot()`; and here, shared:
//! [`stack_used_bytes`].

#[cfg(feature = "qemu")]
mod lan9118;
#[cfg(feature = "qemu")]
mod qemu;
#[cfg(feature = "qemu")]
pub use qemu::*;

#[cfg(feature = "stm32f405")]
mod stm32f405;
#[cfg(feature = "stm32f405")]
pub use stm32f405::*;

/// What `init` hands to the tasks.
pub struct Board {
    /// Link receive half.
    pub rx: LinkRx,
    /// Link transmit half.
    pub tx: LinkTx,
    /// The watchdog (started).
    pub watchdog: Watchdog,
}

/// The paint cortex-m-rt writes over the stack before `main` (`paint-stack` feature,
/// `cortex_m_rt::STACK_PAINT_VALUE`).
const STACK_PAINT: u32 = 0xCCCC_CCCC;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Deepest stack use since reset, bytes: the painted region's first scrubbed word from below.
#[allow(unsafe_code)]
pub fn stack_used_bytes() -> u32 {
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let bottom = core::ptr::addr_of!(_stack_end) as usize;
    let mut p = bottom;
    while p < top {
        // SAFETY: [bottom, top) is the stack region of cortex-m-rt's linker script, inside RAM
        // and word-aligned (the script asserts it); a racy read only makes the figure late.
        let w = unsafe { core::ptr::read_volatile(p as *const u32) };
        if w != STACK_PAINT {
            break;
        }
        p += 4;
    }
    (top - p) as u32
}
