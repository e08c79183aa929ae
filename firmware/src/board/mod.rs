//! Board support: one module per board, the same items in each.
//!
//! `NAME`, `init() -> Board`, `LinkRx::{read, take_overruns}`, `LinkTx::write`,
//! `Watchdog::feed`, `cycles()`, `stack_used_bytes()`, `boot_report()`, `shutdown()`,
//! `reboot()`.

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
