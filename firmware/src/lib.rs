//! Firmware of the cooperative-transport companion computer (issue 4).
//!
//! Beside the autopilot, it receives the UAV's own state, the load's state and the
//! neighbours' positions over MAVLink 2, runs the high-level controller (tube + springs) and the
//! low-level velocity loop + CFO at their own rates, and sends the autopilot an attitude +
//! thrust setpoint. Everything that is not hardware lives in `vt-companion` (host-testable and
//! flown software-in-the-loop by host-sim); this crate is the board glue:
//!
//! - `rx_task`: link bytes -> [`Companion::on_bytes`] (and, in lockstep, the control steps).
//! - `tx_task`: frames queued by the companion -> link.
//! - `high_level_task`, `low_level_task`: embassy `Ticker`s at `VT_HL_HZ` / `VT_LL_HZ`; the
//!   low-level task feeds the watchdog after each healthy step.
//!
//! Boards (exactly one feature, one binary each in `src/bin/`): `qemu` (mps2-an386) and
//! `stm32f405`. See `docs/firmware.md`.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[cfg(all(feature = "qemu", feature = "stm32f405"))]
compile_error!("select exactly one board feature: `qemu` or `stm32f405`");
#[cfg(not(any(feature = "qemu", feature = "stm32f405")))]
compile_error!("select a board feature: `--features qemu` or `--features stm32f405`");

mod board;
#[cfg(feature = "perception-bench")]
pub mod perception_bench;

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex;
use embassy_sync::pipe::Pipe;
use embassy_time::{Duration, Instant, Ticker, Timer};
use static_cell::{ConstStaticCell, StaticCell};
use vt_companion::{Companion, CompanionTube, Io, Request};

/// Bytes queued for the link (a full parameter list, the largest burst, is about 1.9 KB).
#[cfg(not(feature = "perception"))]
const TX_CAPACITY: usize = 2048;
/// Bytes queued for the link: a re-planning companion's tube offer (`MISSION_COUNT` and up to
/// 64 `MISSION_ITEM_INT`, about 3.4 KB) with a period's telemetry.
#[cfg(feature = "perception")]
const TX_CAPACITY: usize = 8192;
/// Receive chunk handed to the companion at once.
const RX_CHUNK: usize = 128;
/// Transmit chunk written to the UART at once.
const TX_CHUNK: usize = 256;
/// Period of the link statistics in the debug log, s.
const LINK_REPORT_S: u32 = 2;
/// How long the shutdown path waits for queued frames to leave, ms.
const SHUTDOWN_FLUSH_MS: u64 = 20;
/// The receive task looks at a slice of the painted stack at most this often, ms.
/// A whole walk of the unused stack is about 24 k words on the 128 KiB layout, some 100 k
/// instructions. Done after every link read, it cost more than the control steps (PIL: one read
/// per received byte). Done once a second, it still held the executor for about 0.6 ms on the
/// STM32. The paint keeps the high-water mark, so a later look loses nothing.
const STACK_LOOK_MS: u64 = 10;
/// Stack words per look: about 4 k instructions; a whole pass over the unused stack in about
/// 24 looks, a quarter of a second.
const STACK_LOOK_WORDS: usize = 1_024;
/// The stack's high-water mark as the receive task last found it, bytes (telemetry reads it).
static STACK_MARK: AtomicU32 = AtomicU32::new(0);

/// The companion, shared by the tasks. An async mutex: control steps run with interrupts
/// enabled (the tasks share one thread executor, so the lock is never held across an await).
type Shared = Mutex<CriticalSectionRawMutex, Companion<'static>>;
/// Storage of the companion.
static COMPANION: StaticCell<Shared> = StaticCell::new();
/// The tube's tables (all zero until built in place: `.bss`, no flash image).
static TUBE: ConstStaticCell<CompanionTube> = ConstStaticCell::new(CompanionTube::placeholder());
/// Outgoing frames.
static TX: Pipe<CriticalSectionRawMutex, TX_CAPACITY> = Pipe::new();
/// Frames dropped because the transmit queue was full.
static TX_DROPPED: AtomicU32 = AtomicU32::new(0);

/// The companion's view of the board.
struct LinkIo;

impl Io for LinkIo {
    fn now_ms(&self) -> u32 {
        Instant::now().as_millis() as u32
    }

    fn cycles(&self) -> u32 {
        board::cycles()
    }

    fn send(&mut self, frame: &[u8]) {
        // Whole frames only: a partial frame would corrupt the stream.
        if TX.free_capacity() >= frame.len() {
            // `try_write` stops at the ring's wrap-around: write until the frame is in.
            let mut rest = frame;
            while !rest.is_empty() {
                match TX.try_write(rest) {
                    Ok(n) => rest = rest.get(n..).unwrap_or(&[]),
                    Err(_) => break, // cannot happen: capacity was checked under the lock
                }
            }
        } else {
            TX_DROPPED.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn stack_used_bytes(&self) -> u32 {
        STACK_MARK.load(Ordering::Relaxed)
    }

    fn tx_room(&self) -> usize {
        TX.free_capacity()
    }

    fn plans_aside(&self) -> bool {
        // The perception build runs the re-plan's search in `planner_task`, below the control
        // tasks' priority.
        cfg!(feature = "perception")
    }
}

#[embassy_executor::task]
async fn rx_task(companion: &'static Shared, mut rx: board::LinkRx) {
    let mut buf = [0u8; RX_CHUNK];
    let mut stack_reported = 0;
    let mut stack_look = Instant::from_ticks(0);
    let mut stack_watch = board::StackWatch::new();
    loop {
        let n = rx.read(&mut buf).await;
        let request = {
            let mut c = companion.lock().await;
            c.add_overruns(rx.take_overruns());
            c.on_bytes(buf.get(..n).unwrap_or(&[]), &mut LinkIo)
        };
        let now = Instant::now();
        if now >= stack_look {
            stack_look = now + Duration::from_millis(STACK_LOOK_MS);
            let stack = stack_watch.look(STACK_LOOK_WORDS);
            STACK_MARK.store(stack, Ordering::Relaxed);
            if stack > stack_reported {
                stack_reported = stack;
                defmt::debug!("stack high-water mark {=u32} bytes", stack);
            }
        }
        match request {
            Some(Request::Shutdown) => {
                defmt::info!("shutdown requested; stack high-water mark {=u32} bytes", board::stack_used_bytes());
                Timer::after_millis(SHUTDOWN_FLUSH_MS).await;
                board::shutdown();
            }
            Some(Request::Reboot) => {
                Timer::after_millis(SHUTDOWN_FLUSH_MS).await;
                board::reboot();
            }
            None => {}
        }
    }
}

#[embassy_executor::task]
async fn tx_task(companion: &'static Shared, mut tx: board::LinkTx) {
    let mut buf = [0u8; TX_CHUNK];
    loop {
        let n = TX.read(&mut buf).await;
        tx.write(buf.get(..n).unwrap_or(&[])).await;
        // Room again: what waited for it (the rest of a parameter list).
        if TX.is_empty() {
            companion.lock().await.poll(&mut LinkIo);
        }
    }
}

#[embassy_executor::task]
async fn high_level_task(companion: &'static Shared) {
    let mut ticks: u32 = 0;
    loop {
        let hz = companion.lock().await.high_level_hz().max(1);
        let mut ticker = Ticker::every(Duration::from_hz(u64::from(hz)));
        loop {
            ticker.next().await;
            let mut c = companion.lock().await;
            if c.high_level_hz() != hz {
                break; // rate changed by PARAM_SET: restart the Ticker
            }
            c.high_level_step(&mut LinkIo);
            ticks = ticks.wrapping_add(1);
            if ticks.is_multiple_of(hz * LINK_REPORT_S) {
                defmt::debug!(
                    "link: {} values: {} tx dropped {=u32} tx queued {=usize}",
                    c.link_counters(),
                    c.value_counters(),
                    TX_DROPPED.load(Ordering::Relaxed),
                    TX.len()
                );
            }
        }
    }
}

#[embassy_executor::task]
async fn low_level_task(companion: &'static Shared, mut watchdog: board::Watchdog) {
    loop {
        let hz = companion.lock().await.low_level_hz().max(1);
        let mut ticker = Ticker::every(Duration::from_hz(u64::from(hz)));
        loop {
            ticker.next().await;
            let mut c = companion.lock().await;
            if c.low_level_hz() != hz {
                break;
            }
            // Fed only by a healthy control loop: a stalled executor, a stuck step or a
            // non-finite setpoint lets it expire.
            if c.low_level_step(&mut LinkIo) {
                watchdog.feed();
            }
        }
    }
}

/// The executor (the board's: WFI-based under QEMU, WFE-based on the STM32).
static EXECUTOR: StaticCell<board::Executor> = StaticCell::new();

/// The companion in its static cell. Not inlined: the value (about 3.5 KiB) goes through this
/// function's frame, which is gone before the executor starts; inlined into [`run`], whose frame
/// stays live under the executor forever, it held 3.8 KiB of stack for good.
#[inline(never)]
fn companion() -> &'static Shared {
    let c = COMPANION.init(Mutex::new(Companion::new(TUBE.take())));
    #[cfg(feature = "perception")]
    if let Ok(mut c) = c.try_lock() {
        perception::attach(&mut c);
    }
    c
}

/// Issue 28 aboard (feature `perception`): the re-planning's storage, given to the companion
/// at boot; it configures it from its `PR_*` parameters.
#[cfg(feature = "perception")]
mod perception {
    use static_cell::ConstStaticCell;
    use vt_companion::perception::{Perception, PlannerSpace};
    use vt_companion::replanning::Replanning;
    use vt_companion::{Companion, CompanionTube};

    // Built in place from `const` placeholders: never on the stack. The map and the planner's
    // work space (60 KiB) live in the core-coupled RAM, apart from everything the control loop
    // and the link's DMA touch (`memory-qemu-perception.x`; docs/firmware.md, "Memory of the
    // perception build"). A `.bss.*` section cannot hold a non-zero byte (the compiler refuses
    // one), so their placeholders are all zero, as `board::zero_ccm` leaves them at boot.
    #[allow(unsafe_code)] // a placement only: the linker script's `.ccmbss`
    #[link_section = ".bss.ccm.MAP"]
    static MAP: ConstStaticCell<Perception> = ConstStaticCell::new(Perception::placeholder());
    #[allow(unsafe_code)]
    #[link_section = ".bss.ccm.SPACE"]
    static SPACE: ConstStaticCell<PlannerSpace> = ConstStaticCell::new(PlannerSpace::zeroed());
    static SPARE: ConstStaticCell<CompanionTube> = ConstStaticCell::new(CompanionTube::placeholder());
    static CHECK: ConstStaticCell<CompanionTube> = ConstStaticCell::new(CompanionTube::placeholder());
    static SLOT: ConstStaticCell<vt_companion::ReplanSlot<'static>> = ConstStaticCell::new(vt_companion::ReplanSlot::new());

    /// How often the planner task looks for a re-plan to run, ms.
    const PLANNER_LOOK_MS: u64 = 5;
    /// The `lock-pause` test build's pause inside each of the planner task's holds, cycles.
    #[cfg(feature = "lock-pause")]
    const LOCK_PAUSE_CYCLES: u32 = 400_000;

    /// The re-plan's search (`vt_companion::replanning::PlanJob`), in thread mode: every
    /// control task preempts it. It holds the companion only to take the job and give it back,
    /// and then at the control tasks' ceiling ([`at_ceiling`]).
    #[embassy_executor::task]
    pub(super) async fn planner_task(companion: &'static super::Shared) {
        loop {
            embassy_time::Timer::after_millis(PLANNER_LOOK_MS).await;
            // An offer's tube first (a few million instructions), then a re-plan's search.
            if let Some(mut job) = at_ceiling(companion, |c| c.take_build_job()) {
                let built = job.run();
                at_ceiling(companion, |c| c.return_build_job(job, built));
            }
            if let Some(mut job) = at_ceiling(companion, |c| c.take_plan_job()) {
                let t0 = crate::board::cycles();
                let result = job.run();
                let cycles = crate::board::cycles().wrapping_sub(t0);
                at_ceiling(companion, |c| c.return_plan_job(job, result, cycles));
            }
        }
    }

    /// `f` on the companion with the control tasks masked (`board::above_control`): they never
    /// find it held by thread mode, so they never wait on it (two control tasks waiting on it
    /// would wake each other forever above the holder). They hold it only between awaits, so
    /// thread mode finds it free; were it held, the loop lets the interrupts run between tries.
    fn at_ceiling<R>(companion: &'static super::Shared, f: impl FnOnce(&mut Companion<'static>) -> R) -> R {
        let mut f = Some(f);
        loop {
            let done = crate::board::above_control(|| match companion.try_lock() {
                Ok(mut c) => f.take().map(|f| {
                    // Test builds only: held long enough that control tasks come due meanwhile.
                    #[cfg(feature = "lock-pause")]
                    cortex_m::asm::delay(LOCK_PAUSE_CYCLES);
                    f(&mut c)
                }),
                Err(_) => None,
            });
            if let Some(r) = done {
                return r;
            }
            core::hint::spin_loop();
        }
    }

    /// Gives `c` the map and its two tubes.
    pub(super) fn attach(c: &mut Companion<'static>) {
        let _none = c.attach_replanning(SLOT.take(), Replanning::new(MAP.take(), SPACE.take(), SPARE.take(), CHECK.take()));
    }
}

/// Boots the board and runs the tasks forever (called by each board's binary, `src/bin/`).
/// The perception build runs the link and control tasks in the board's control interrupt and
/// the re-plan's search in thread mode below it (`planner_task`); the flight builds run
/// everything in thread mode.
pub fn run() -> ! {
    // Before any static there is touched: the CCM's statics at their all-zero initial values.
    #[cfg(feature = "perception")]
    board::zero_ccm();
    let b = board::init();
    defmt::info!("vt-firmware {=str} on {=str}", env!("CARGO_PKG_VERSION"), board::NAME);
    board::boot_report();
    let companion = companion();
    #[cfg(feature = "perception")]
    {
        spawn_control(board::control_executor(), companion, b);
        board::start_control();
        EXECUTOR.init(board::Executor::new()).run(|spawner| match perception::planner_task(companion) {
            Ok(t) => spawner.spawn(t),
            Err(_) => defmt::error!("cannot spawn planner_task"),
        })
    }
    #[cfg(not(feature = "perception"))]
    EXECUTOR.init(board::Executor::new()).run(|spawner| spawn_control(spawner, companion, b))
}

/// The link and control tasks.
fn spawn_control(spawner: embassy_executor::Spawner, companion: &'static Shared, b: board::Board) {
    {
        match rx_task(companion, b.rx) {
            Ok(t) => spawner.spawn(t),
            Err(_) => defmt::error!("cannot spawn rx_task"),
        }
        match tx_task(companion, b.tx) {
            Ok(t) => spawner.spawn(t),
            Err(_) => defmt::error!("cannot spawn tx_task"),
        }
        match high_level_task(companion) {
            Ok(t) => spawner.spawn(t),
            Err(_) => defmt::error!("cannot spawn high_level_task"),
        }
        match low_level_task(companion, b.watchdog) {
            Ok(t) => spawner.spawn(t),
            Err(_) => defmt::error!("cannot spawn low_level_task"),
        }
    }
}
