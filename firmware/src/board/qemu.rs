//! QEMU `mps2-an386` (Arm MPS2 with the AN386 image: Cortex-M4F at 25 MHz).
//!
//! - Link: CMSDK APB UART0 at `0x4000_4000` (QEMU `-serial`), receive interrupt IRQ 0 into a
//!   byte pipe; transmit by polling (QEMU's UART sends at once).
//! - Time: a SysTick `embassy-time` driver, 1 kHz ticks from the 25 MHz core clock.
//! - Cycles: SysTick ticks at 25 MHz. Under `-icount shift=0` one instruction is one virtual
//!   nanosecond, so one tick is 40 instructions ([`boot_report`] calibrates it with a loop of
//!   known length). The DWT cycle counter reads 0 under QEMU.
//! - Logs: defmt over semihosting (decoded on the host); panics and shutdown exit QEMU with
//!   semihosting `SYS_EXIT`.
//! - Watchdog: the board has none in QEMU; a software one in the SysTick handler exits QEMU
//!   with a failure code when the low-level loop has not fed it for [`WATCHDOG_TIMEOUT_MS`].
//!
//! # Unsafe
//! This module is the firmware's only `unsafe` code (allowed here, denied elsewhere): volatile
//! access to the UART registers (fixed MMIO addresses of the board), unmasking an NVIC line,
//! the `InterruptNumber` implementation (the numbers are the board's), the interrupt vector
//! table (a `#[no_mangle]` `#[link_section]` static the linker script expects), the executor's
//! pender (`#[export_name]`), and the calibration loop (inline asm).
#![allow(unsafe_code)]

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{NVIC, SYST};
use cortex_m_rt::exception;
use critical_section::Mutex as CsMutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_time_queue_utils::Queue;

use super::{stack_used_bytes, Board};
use defmt_semihosting as _; // the global defmt logger

/// Set by the executor's pender: a task was woken.
static PENDING: AtomicBool = AtomicBool::new(true);

#[export_name = "__pender"]
fn pender(_context: *mut ()) {
    PENDING.store(true, Ordering::SeqCst);
}

/// Thread-mode executor that sleeps with `WFI`. QEMU 7.2 treats `WFE` (what embassy's
/// thread executor sleeps with) as a yield, so an idle firmware would spin a host core at
/// 100 %; `WFI` halts the emulated CPU until an interrupt.
pub struct Executor {
    inner: embassy_executor::raw::Executor,
}

impl Executor {
    /// A new executor.
    pub fn new() -> Self {
        Self { inner: embassy_executor::raw::Executor::new(core::ptr::null_mut()) }
    }

    /// Spawns the initial tasks with `init`, then runs forever.
    pub fn run(&'static mut self, init: impl FnOnce(embassy_executor::Spawner)) -> ! {
        init(self.inner.spawner());
        loop {
            // SAFETY: polled from this one thread-mode loop only, as `raw::Executor` requires.
            unsafe { self.inner.poll() };
            // Sleep unless a task was woken meanwhile. With interrupts masked, a wake-up
            // between the check and WFI cannot be lost: WFI still returns on a pending interrupt.
            cortex_m::interrupt::free(|_| {
                if !PENDING.swap(false, Ordering::SeqCst) {
                    cortex_m::asm::wfi();
                }
            });
        }
    }
}

/// Board name for logs.
pub const NAME: &str = "qemu-mps2-an386";

/// Core (and SysTick) clock of the AN386 image, Hz (QEMU `SYSCLK_FRQ`).
const SYSCLK_HZ: u32 = 25_000_000;
/// embassy-time tick rate (must match the `tick-hz-1_000` feature), Hz.
const TICK_HZ: u32 = 1_000;
/// SysTick reload for one tick.
const SYSTICK_RELOAD: u32 = SYSCLK_HZ / TICK_HZ - 1;
/// Software watchdog timeout, ms.
/// (Long, because a busy host can stall an emulator for a while; the IWDG on hardware is 250 ms.)
pub const WATCHDOG_TIMEOUT_MS: u32 = 2_000;
/// Iterations of the calibration loop (two instructions each).
const CALIBRATION_ITERATIONS: u32 = 1_000_000;
/// Instructions per calibration iteration (`subs` + `bne`).
const CALIBRATION_INSTRUCTIONS_PER_ITERATION: u32 = 2;

/// UART0 base address (QEMU `hw/arm/mps2.c`).
const UART0_BASE: usize = 0x4000_4000;
/// Data register.
const UART_DATA: usize = 0x00;
/// State register: bit 0 TX full, bit 1 RX full.
const UART_STATE: usize = 0x04;
/// Control register.
const UART_CTRL: usize = 0x08;
/// Interrupt status / clear register.
const UART_INTCLEAR: usize = 0x0C;
/// Baud divider (>= 16; QEMU ignores the rate).
const UART_BAUDDIV: usize = 0x10;
const STATE_TXFULL: u32 = 1 << 0;
const STATE_RXFULL: u32 = 1 << 1;
const STATE_RXOVERRUN: u32 = 1 << 3;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_RX_INT_EN: u32 = 1 << 3;
const INT_RX: u32 = 1 << 1;
/// 25 MHz / 217 = 115200 Bd (nominal only under QEMU).
const BAUDDIV_115200: u32 = 217;

/// Received bytes (filled by the UART0 RX interrupt).
static RX_PIPE: Pipe<CriticalSectionRawMutex, 1024> = Pipe::new();
/// Receive overruns reported by the UART.
static RX_OVERRUNS: AtomicU32 = AtomicU32::new(0);
/// SysTick interrupts since boot (low 32 bits), for the cycle counter.
static TICKS: AtomicU32 = AtomicU32::new(0);
/// Software watchdog: ticks since the last feed, and whether it is armed.
static WATCHDOG_AGE: AtomicU32 = AtomicU32::new(0);
static WATCHDOG_ARMED: AtomicBool = AtomicBool::new(false);

fn uart_read(offset: usize) -> u32 {
    // SAFETY: UART0 is a fixed MMIO block of the mps2-an386 board; word access is valid.
    unsafe { core::ptr::read_volatile((UART0_BASE + offset) as *const u32) }
}

fn uart_write(offset: usize, value: u32) {
    // SAFETY: as above; writes to these registers have no memory-safety effects.
    unsafe { core::ptr::write_volatile((UART0_BASE + offset) as *mut u32, value) }
}

/// The board's interrupt lines used here.
#[derive(Clone, Copy)]
enum Irq {
    Uart0Rx = 0,
}

// SAFETY: the number is the line QEMU wires UART0's receive interrupt to (mps2.c).
unsafe impl cortex_m::interrupt::InterruptNumber for Irq {
    fn number(self) -> u16 {
        self as u16
    }
}

/// An entry of the device interrupt vector table.
pub union Vector {
    handler: unsafe extern "C" fn(),
    #[allow(dead_code)] // layout only: reserved vector slots
    reserved: usize,
}

extern "C" {
    fn DefaultHandler();
}

/// Device interrupts (32 on mps2-an386): UART0 RX on line 0, the rest to the default handler.
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
pub static __INTERRUPTS: [Vector; 32] = {
    let mut v = [const { Vector { handler: DefaultHandler } }; 32];
    v[0] = Vector { handler: UART0RX };
    v
};

/// UART0 receive interrupt: moves bytes into [`RX_PIPE`]. When the pipe is full it masks the
/// interrupt and leaves the byte in the UART (QEMU then holds back the stream): nothing is lost;
/// [`LinkRx::read`] unmasks it after draining.
#[no_mangle]
unsafe extern "C" fn UART0RX() {
    uart_write(UART_INTCLEAR, INT_RX);
    while uart_read(UART_STATE) & STATE_RXFULL != 0 {
        if RX_PIPE.free_capacity() == 0 {
            uart_write(UART_CTRL, uart_read(UART_CTRL) & !CTRL_RX_INT_EN);
            return;
        }
        let byte = uart_read(UART_DATA) as u8;
        let _ = RX_PIPE.try_write(&[byte]);
    }
    if uart_read(UART_STATE) & STATE_RXOVERRUN != 0 {
        RX_OVERRUNS.fetch_add(1, Ordering::Relaxed);
        uart_write(UART_STATE, STATE_RXOVERRUN); // write 1 to clear
    }
}

/// Link receive half.
pub struct LinkRx;

impl LinkRx {
    /// Waits for at least one byte; returns how many were copied.
    pub async fn read(&mut self, buf: &mut [u8]) -> usize {
        let n = RX_PIPE.read(buf).await;
        if uart_read(UART_CTRL) & CTRL_RX_INT_EN == 0 {
            uart_write(UART_CTRL, uart_read(UART_CTRL) | CTRL_RX_INT_EN);
            NVIC::pend(Irq::Uart0Rx); // drain what waited in the UART meanwhile
                }
        n
    }

    /// Overruns since the last call.
    pub fn take_overruns(&mut self) -> u32 {
        RX_OVERRUNS.swap(0, Ordering::Relaxed)
    }
}

/// Link transmit half.
pub struct LinkTx;

impl LinkTx {
    /// Writes every byte. QEMU's UART sends at once unless the host side of the socket is
    /// full; then the task yields, so the control loops keep running (and the queue in front
    /// drops whole frames instead).
    pub async fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while uart_read(UART_STATE) & STATE_TXFULL != 0 {
                embassy_futures::yield_now().await;
            }
            uart_write(UART_DATA, u32::from(b));
        }
    }
}

/// Software watchdog fed by the low-level loop.
pub struct Watchdog;

impl Watchdog {
    /// Restarts the timeout (and arms the watchdog on the first feed).
    pub fn feed(&mut self) {
        WATCHDOG_AGE.store(0, Ordering::Relaxed);
        WATCHDOG_ARMED.store(true, Ordering::Relaxed);
    }
}

/// SysTick `embassy-time` driver with a single timer queue.
struct SysTickDriver {
    ticks: CsMutex<Cell<u64>>,
    alarm: CsMutex<Cell<u64>>,
    queue: CsMutex<RefCell<Queue>>,
}

impl embassy_time_driver::Driver for SysTickDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.ticks.borrow(cs).get())
    }

    fn schedule_wake(&self, at: u64, waker: &core::task::Waker) {
        critical_section::with(|cs| {
            let mut q = self.queue.borrow(cs).borrow_mut();
            if q.schedule_wake(at, waker) {
                let now = self.ticks.borrow(cs).get();
                self.alarm.borrow(cs).set(q.next_expiration(now));
            }
        });
    }
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    ticks: CsMutex::new(Cell::new(0)),
    alarm: CsMutex::new(Cell::new(u64::MAX)),
    queue: CsMutex::new(RefCell::new(Queue::new())),
});

#[exception]
fn SysTick() {
    TICKS.fetch_add(1, Ordering::Relaxed);
    critical_section::with(|cs| {
        let ticks = DRIVER.ticks.borrow(cs);
        let now = ticks.get() + 1;
        ticks.set(now);
        let alarm = DRIVER.alarm.borrow(cs);
        if now >= alarm.get() {
            alarm.set(DRIVER.queue.borrow(cs).borrow_mut().next_expiration(now));
        }
    });
    if WATCHDOG_ARMED.load(Ordering::Relaxed) {
        let age = WATCHDOG_AGE.fetch_add(1, Ordering::Relaxed);
        if age >= WATCHDOG_TIMEOUT_MS * (TICK_HZ / 1000) {
            defmt::error!("watchdog: low-level loop silent for {=u32} ms", age / (TICK_HZ / 1000));
            semihosting::process::exit(3);
        }
    }
}

/// Last value returned by [`cycles`].
static LAST_CYCLES: AtomicU32 = AtomicU32::new(0);

/// Free-running 25 MHz SysTick clock cycles, wrapping; monotonic.
///
/// QEMU computes the SysTick count from its clock on every read but raises the wrap interrupt
/// from a timer callback, so a read can see the new period before the interrupt counted it:
/// a value behind the last one returned is moved on by one period.
pub fn cycles() -> u32 {
    let period = SYSTICK_RELOAD + 1;
    let c = loop {
        let a = TICKS.load(Ordering::Relaxed);
        let val = SYST::get_current();
        if TICKS.load(Ordering::Relaxed) == a {
            break a.wrapping_mul(period).wrapping_add(SYSTICK_RELOAD - val);
        }
    };
    let last = LAST_CYCLES.load(Ordering::Relaxed);
    let behind = last.wrapping_sub(c);
    let c = if behind != 0 && behind <= period { c.wrapping_add(period) } else { c };
    LAST_CYCLES.store(c, Ordering::Relaxed);
    c
}

/// Runs `iterations` of a two-instruction loop.
#[inline(never)]
fn calibration_loop(iterations: u32) {
    // SAFETY: register-only loop; no memory access, no stack use.
    unsafe {
        core::arch::asm!("1:", "subs {0}, {0}, #1", "bne 1b", inout(reg) iterations => _, options(nomem, nostack));
    }
}

/// Logs the instruction/tick calibration (meaningful under `-icount shift=0`) and the memory
/// layout.
pub fn boot_report() {
    let t0 = cycles();
    calibration_loop(CALIBRATION_ITERATIONS);
    let ticks = cycles().wrapping_sub(t0);
    let instructions = CALIBRATION_ITERATIONS * CALIBRATION_INSTRUCTIONS_PER_ITERATION;
    defmt::info!("calibration: {=u32} instructions in {=u32} SysTick ticks", instructions, ticks);
    defmt::info!("stack used at boot: {=u32} bytes", stack_used_bytes());
}

/// Sets up SysTick and UART0.
pub fn init() -> Board {
    if let Some(mut p) = cortex_m::Peripherals::take() {
        let syst = &mut p.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SYSTICK_RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
    }
    uart_write(UART_BAUDDIV, BAUDDIV_115200);
    uart_write(UART_CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INT_EN);
    // SAFETY: the handler and the pipe it fills are ready; unmasking cannot break a critical
    // section (none is held here).
    unsafe { NVIC::unmask(Irq::Uart0Rx) };
    Board { rx: LinkRx, tx: LinkTx, watchdog: Watchdog }
}

/// Ends the emulation with success.
pub fn shutdown() -> ! {
    semihosting::process::exit(0)
}

/// QEMU has no reset worth emulating here: ends the emulation with code 2.
pub fn reboot() -> ! {
    semihosting::process::exit(2)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    // Location only: formatting the message would link core's float formatting (~15 KB).
    match info.location() {
        Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("panic"),
    }
    semihosting::process::exit(101)
}
