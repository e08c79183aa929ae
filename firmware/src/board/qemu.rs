//! QEMU `mps2-an386` (Arm MPS2 with the AN386 image: Cortex-M4F at 25 MHz).
//!
//! - Link: the board's LAN9118 Ethernet controller ([`lan9118`]; QEMU `-netdev`), MAVLink in
//!   frames of the link's EtherType; receive interrupt (line 13) into a byte pipe, transmit
//!   into the controller's FIFO.
//! - Time: a SysTick `embassy-time` driver, 1 kHz ticks from the 25 MHz core clock.
//! - Cycles: the CMSDK APB timer 1, free-running at the 25 MHz peripheral clock ([`cycles`]).
//!   Under `-icount shift=0` one instruction is one virtual nanosecond, so a cycle is 40
//!   instructions (checked at boot with a loop of known length). The DWT cycle counter reads 0
//!   under QEMU.
//! - Logs: defmt over semihosting (decoded on the host); panics and shutdown exit QEMU with
//!   semihosting `SYS_EXIT`.
//! - Watchdog: the board has none in QEMU; a software one in the SysTick handler exits QEMU
//!   with a failure code when the low-level loop has not fed it for [`WATCHDOG_TIMEOUT_MS`].
//!
//! # Unsafe
//! This module and [`lan9118`] hold the firmware's only `unsafe` code (allowed there, denied
//! elsewhere): volatile access to the Ethernet controller's registers (fixed MMIO addresses of
//! the board, in [`lan9118`]), unmasking an NVIC line,
//! the `InterruptNumber` implementation (the numbers are the board's), the interrupt vector
//! table (a `#[no_mangle]` `#[link_section]` static the linker script expects), the executor's
//! pender (`#[export_name]`), and the calibration loop (inline asm).
#![allow(unsafe_code)]

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::NVIC;
use cortex_m_rt::exception;
use critical_section::Mutex as CsMutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_time_queue_utils::Queue;

use super::{lan9118, stack_used_bytes, Board};
use defmt_semihosting as _; // the global defmt logger

/// Set by the executor's pender: a task was woken.
static PENDING: AtomicBool = AtomicBool::new(true);

#[export_name = "__pender"]
fn pender(context: *mut ()) {
    #[cfg(feature = "perception")]
    if context as usize == Irq::Control as usize {
        NVIC::pend(Irq::Control);
        return;
    }
    let _ = context; // the thread-mode executor's: null
    PENDING.store(true, Ordering::SeqCst);
}

/// The perception build's control executor: the link and the control tasks run in the
/// interrupt of line [`Irq::Control`], at a priority below the link's and the clock's and above
/// thread mode, where the re-plan's search runs (docs/firmware.md, "The perception build").
#[cfg(feature = "perception")]
static CONTROL: core::sync::atomic::AtomicPtr<embassy_executor::raw::Executor> = core::sync::atomic::AtomicPtr::new(core::ptr::null_mut());

/// NVIC priority of the control executor's line (lower urgency than the Ethernet line's and
/// SysTick's, 0; thread mode is below every interrupt).
#[cfg(feature = "perception")]
const CONTROL_PRIORITY: u8 = 0x80;

/// The perception build: the control executor (its tasks spawned through the returned spawner
/// run once [`start_control`] unmasks its line).
#[cfg(feature = "perception")]
pub fn control_executor() -> embassy_executor::Spawner {
    static EXEC: static_cell::StaticCell<embassy_executor::raw::Executor> = static_cell::StaticCell::new();
    let exec: &'static embassy_executor::raw::Executor = EXEC.init(embassy_executor::raw::Executor::new(Irq::Control as usize as *mut ()));
    CONTROL.store(core::ptr::from_ref(exec).cast_mut(), Ordering::SeqCst);
    exec.spawner()
}

/// The perception build: sets the control line's priority and unmasks it.
#[cfg(feature = "perception")]
pub fn start_control() {
    // SAFETY: `init` took the core peripherals; this only writes the control line's priority
    // register, once, before the line is unmasked (embassy's interrupt executor's rule).
    unsafe {
        let mut p = cortex_m::Peripherals::steal();
        p.NVIC.set_priority(Irq::Control, CONTROL_PRIORITY);
    }
    // SAFETY: the executor behind the line is initialised ([`control_executor`]).
    unsafe { NVIC::unmask(Irq::Control) };
}

/// Runs `f` with the control executor's line masked (`BASEPRI` at [`CONTROL_PRIORITY`]; the
/// link's and the clock's interrupts, at 0, still run): the priority ceiling of what thread
/// mode shares with the control tasks. Holding the companion below them without it, thread
/// mode can be preempted by two control tasks that then wait on it together; embassy's mutex
/// keeps one waker, so each wakes the other, the control interrupt never ends, and thread mode
/// never gets to release it (a livelock, found in CI; docs/firmware.md, "The perception build").
#[cfg(feature = "perception")]
pub fn above_control<R>(f: impl FnOnce() -> R) -> R {
    let old = cortex_m::register::basepri::read();
    cortex_m::register::basepri_max::write(CONTROL_PRIORITY);
    let r = f();
    // SAFETY: restores the value read above (0 in thread mode, where this is called).
    unsafe { cortex_m::register::basepri::write(old) };
    r
}

/// The control executor's interrupt: polls its tasks.
#[cfg(feature = "perception")]
#[no_mangle]
unsafe extern "C" fn CONTROL_IRQ() {
    let exec = CONTROL.load(Ordering::SeqCst);
    if !exec.is_null() {
        // SAFETY: the executor is a `'static` initialised before the line was unmasked, and it
        // is polled from this one interrupt only, as `raw::Executor::poll` requires.
        unsafe { (*exec).poll() };
    }
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

/// Received link bytes (filled by the Ethernet interrupt, a frame at a time).
static RX_PIPE: Pipe<CriticalSectionRawMutex, RX_PIPE_BYTES> = Pipe::new();
/// Receive pipe size, bytes: room for two frames.
const RX_PIPE_BYTES: usize = 2 * lan9118::MAX_PAYLOAD;
/// Frames the link dropped (not the link's EtherType, or malformed), reported as overruns.
static RX_OVERRUNS: AtomicU32 = AtomicU32::new(0);
/// Software watchdog: ticks since the last feed, and whether it is armed.
static WATCHDOG_AGE: AtomicU32 = AtomicU32::new(0);
static WATCHDOG_ARMED: AtomicBool = AtomicBool::new(false);

/// The board's interrupt lines used here.
#[derive(Clone, Copy)]
enum Irq {
    Ethernet = 13,
    /// Not wired to a peripheral on the AN386: the perception build's control executor.
    #[cfg(feature = "perception")]
    Control = 31,
}

// SAFETY: the number is the line QEMU wires the LAN9118's interrupt to (mps2.c, AN385/AN386).
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

/// Device interrupts (32 on mps2-an386): the Ethernet controller on line 13, the rest to the
/// default handler.
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
pub static __INTERRUPTS: [Vector; 32] = {
    let mut v = [const { Vector { handler: DefaultHandler } }; 32];
    v[13] = Vector { handler: ETHERNET };
    #[cfg(feature = "perception")]
    {
        v[31] = Vector { handler: CONTROL_IRQ };
    }
    v
};

/// Ethernet interrupt: moves each waiting frame's payload into [`RX_PIPE`]. When the pipe has
/// no room for a whole frame it turns the interrupt off and leaves the frames in the
/// controller's FIFO: nothing is lost; [`LinkRx::read`] turns it on again after draining.
#[no_mangle]
unsafe extern "C" fn ETHERNET() {
    lan9118::acknowledge();
    while lan9118::frames_waiting() > 0 {
        if RX_PIPE.free_capacity() < lan9118::MAX_PAYLOAD {
            lan9118::set_receive_interrupt(false);
            return;
        }
        // Room was checked for the largest payload. `try_write` stops at the ring's
        // wrap-around: write until the bytes are in.
        let ours = lan9118::receive(|bytes| {
            let mut rest = bytes;
            while let Ok(n @ 1..) = RX_PIPE.try_write(rest) {
                rest = rest.get(n..).unwrap_or(&[]);
            }
        });
        if !ours {
            RX_OVERRUNS.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Link receive half.
pub struct LinkRx;

impl LinkRx {
    /// Waits for at least one byte; returns how many were copied.
    pub async fn read(&mut self, buf: &mut [u8]) -> usize {
        let n = RX_PIPE.read(buf).await;
        if !lan9118::receive_interrupt_on() {
            lan9118::set_receive_interrupt(true);
            NVIC::pend(Irq::Ethernet); // drain what waited in the controller meanwhile
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
    /// Sends `bytes` in frames of at most [`lan9118::MAX_PAYLOAD`]. While the controller's
    /// transmit FIFO is full the task yields, so the control loops keep running (and the
    /// queue in front drops whole frames instead).
    pub async fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(lan9118::MAX_PAYLOAD) {
            while !lan9118::can_send(chunk.len()) {
                embassy_futures::yield_now().await;
            }
            lan9118::send(chunk);
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

/// The AN386's CMSDK APB timer 1 (`cmsdk-apb-timer` in QEMU's mps2 model), run free as the
/// cycle counter: a 32-bit down counter at the 25 MHz peripheral clock, no interrupt.
const TIMER1_BASE: usize = 0x4000_1000;
/// Timer registers: control (bit 0 enable), current value, reload value.
const TIMER_CTRL: usize = 0x00;
const TIMER_VALUE: usize = 0x04;
const TIMER_RELOAD: usize = 0x08;

fn timer_write(offset: usize, value: u32) {
    // SAFETY: a word-aligned register of the timer block, which nothing else uses.
    unsafe { core::ptr::write_volatile((TIMER1_BASE + offset) as *mut u32, value) }
}

/// Free-running 25 MHz cycles, wrapping (every 172 s; differences of shorter spans are exact).
///
/// Timer 1 counts down from `u32::MAX` and reloads there, so its complement counts up and
/// wraps with `u32`'s arithmetic. No interrupt is involved: an earlier counter built on SysTick
/// counted its wrap interrupts, and QEMU computes SysTick's count from its clock on every read
/// but raises the wrap interrupt from a timer callback, so a read in between came out a whole
/// period early (one million instructions under `-icount shift=0`): a fresh-clone CI run of
/// 2026-11-28 measured a mean of 25,286 instructions per control step at n = 10 against 4,875.
pub fn cycles() -> u32 {
    // SAFETY: a word-aligned register of the timer block, read only here.
    !unsafe { core::ptr::read_volatile((TIMER1_BASE + TIMER_VALUE) as *const u32) }
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
    defmt::info!("calibration: {=u32} instructions in {=u32} timer cycles", instructions, ticks);
    defmt::info!("stack used at boot: {=u32} bytes", stack_used_bytes());
}

/// Sets up SysTick, the cycle timer and the Ethernet link.
pub fn init() -> Board {
    if let Some(mut p) = cortex_m::Peripherals::take() {
        let syst = &mut p.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SYSTICK_RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
    }
    timer_write(TIMER_CTRL, 0);
    timer_write(TIMER_RELOAD, u32::MAX);
    timer_write(TIMER_VALUE, u32::MAX);
    timer_write(TIMER_CTRL, 1);
    if lan9118::init() {
        // Link up: an empty frame tells the host that frames are received from now on (QEMU's
        // controller drops what arrives while its receiver is off).
        lan9118::send(&[]);
    } else {
        defmt::error!("Ethernet controller not found: the link stays silent");
    }
    // SAFETY: the handler and the pipe it fills are ready; unmasking cannot break a critical
    // section (none is held here).
    unsafe { NVIC::unmask(Irq::Ethernet) };
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
