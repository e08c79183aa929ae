//! Board support: one module per board, the same items in each.
//!
//! `NAME`, `init() -> Board`, `Executor`, `LinkRx::{read, take_overruns}`, `LinkTx::write`,
//! `Watchdog::feed`, `cycles()`, `boot_report()`, `shutdown()`, `reboot()`; and here, shared:
//! [`stack_used_bytes`], [`StackWatch`].

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

#[cfg(feature = "perception")]
extern "C" {
    static mut __sccmbss: u32;
    static mut __eccmbss: u32;
}

/// Zeroes the core-coupled RAM's statics (`.ccmbss`, NOLOAD: cortex-m-rt zeroes `.bss` alone),
/// their `const` initial values being all zero. Called first thing at boot, before any of them
/// is touched.
#[cfg(feature = "perception")]
#[allow(unsafe_code)]
pub fn zero_ccm() {
    let (start, end) = (core::ptr::addr_of_mut!(__sccmbss) as usize, core::ptr::addr_of_mut!(__eccmbss) as usize);
    let mut p = start;
    while p < end {
        // SAFETY: [start, end) is the `.ccmbss` section of the linker script (word-aligned,
        // inside the CCM region); no reference to its statics exists yet, and zero is the
        // initial value of each of them (`.bss.ccm.*` sections: the compiler refuses a
        // non-zero byte there).
        unsafe { core::ptr::write_volatile(p as *mut u32, 0) };
        p += 4;
    }
}

/// The stack region `[bottom, top)`, addresses.
fn stack_region() -> (usize, usize) {
    (core::ptr::addr_of!(_stack_end) as usize, core::ptr::addr_of!(_stack_start) as usize)
}

/// The stack word at `p` (an address inside [`stack_region`], word-aligned).
#[allow(unsafe_code)]
fn stack_word(p: usize) -> u32 {
    // SAFETY: callers pass addresses in [bottom, top), the stack region of cortex-m-rt's linker
    // script, inside RAM and word-aligned (the script asserts it); a racy read only makes the
    // figure late.
    unsafe { core::ptr::read_volatile(p as *const u32) }
}

/// Deepest stack use since reset, bytes: the painted region's first scrubbed word from below.
/// Walks the whole unused stack (about 24 k words on the 128 KiB layout, some 100 k
/// instructions): for boot and shutdown; in flight [`StackWatch`] does it a slice at a time.
pub fn stack_used_bytes() -> u32 {
    let (bottom, top) = stack_region();
    let mut p = bottom;
    while p < top && stack_word(p) == STACK_PAINT {
        p += 4;
    }
    (top - p) as u32
}

/// The stack's high-water mark found a slice at a time, so that no call walks the whole
/// unused stack (bounded work beside the control loops; docs/firmware.md).
///
/// Each pass walks up from the bottom of the stack to the known mark; the first scrubbed word
/// it meets is the deepest use so far (the paint is never restored, so the mark only rises).
/// A pass takes `unused / words` calls; use that deepens the stack meanwhile below the
/// cursor is found by the next pass.
pub struct StackWatch {
    /// Next address to look at (0: a pass starts at the bottom).
    cursor: usize,
    /// The high-water mark found so far, bytes.
    mark: u32,
}

impl StackWatch {
    /// Nothing looked at yet.
    pub const fn new() -> Self {
        Self { cursor: 0, mark: 0 }
    }

    /// Looks at up to `words` stack words from where the last call stopped; returns the
    /// high-water mark, bytes (0 until a pass has found used stack).
    pub fn look(&mut self, words: usize) -> u32 {
        let (bottom, top) = stack_region();
        let known = top.saturating_sub(self.mark as usize);
        let mut p = if self.cursor < bottom || self.cursor >= known { bottom } else { self.cursor };
        for _ in 0..words {
            if p >= known {
                self.cursor = 0; // nothing deeper than the mark: start again at the bottom
                return self.mark;
            }
            if stack_word(p) != STACK_PAINT {
                self.mark = (top - p) as u32;
                self.cursor = 0;
                return self.mark;
            }
            p += 4;
        }
        self.cursor = p;
        self.mark
    }
}
