//! STM32F405RG flight board (embassy-stm32).
//!
//! - Clock: 168 MHz from the internal 16 MHz oscillator through the PLL (no crystal needed;
//!   change `init` for a board with an HSE crystal).
//! - Link: USART1 (PA9 TX, PA10 RX) at 921 600 Bd, both directions on DMA2 (stream 7 TX,
//!   stream 2 RX), receive into a DMA ring buffer (no byte lost to interrupt latency).
//! - Time: embassy-stm32's TIM2 time driver. Cycles: the DWT cycle counter (168 MHz).
//! - Watchdog: the IWDG, [`WATCHDOG_TIMEOUT_US`], started at boot and fed only by healthy
//!   low-level steps (`low_level_task`).
//! - Logs: defmt over RTT (probe-rs). A panic (none is reachable: the control paths have no
//!   panicking operation) logs its location, not its message, and ends in `UDF` as
//!   panic-probe does, so probe-rs stops on it.
//!
//! Flash with `probe-rs run --chip STM32F405RGTx target/thumbv7em-none-eabihf/release/vt-firmware-stm32f405`.

use embassy_stm32::usart::{self, RingBufferedUartRx, Uart, UartTx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, dma, mode, peripherals};
use static_cell::StaticCell;
use defmt_rtt as _;

use super::{stack_used_bytes, Board};

pub use embassy_executor::Executor;

/// Board name for logs.
pub const NAME: &str = "stm32f405";
/// Link baud rate.
const BAUD: u32 = 921_600;
/// IWDG timeout, µs: 50 low-level periods at 500 Hz, and room for a tube rebuild.
pub const WATCHDOG_TIMEOUT_US: u32 = 250_000;
/// DMA receive ring, bytes (about 5 ms of link at full rate).
const RX_RING: usize = 512;

bind_interrupts!(struct Irqs {
    USART1 => usart::InterruptHandler<peripherals::USART1>;
    DMA2_STREAM7 => dma::InterruptHandler<peripherals::DMA2_CH7>;
    DMA2_STREAM2 => dma::InterruptHandler<peripherals::DMA2_CH2>;
});

static RX_BUF: StaticCell<[u8; RX_RING]> = StaticCell::new();

/// Link receive half (DMA ring buffer).
pub struct LinkRx {
    rx: RingBufferedUartRx<'static>,
    overruns: u32,
}

impl LinkRx {
    /// Waits for bytes; returns how many were copied. Errors (overrun, framing, noise) are
    /// counted and reading goes on.
    pub async fn read(&mut self, buf: &mut [u8]) -> usize {
        loop {
            match self.rx.read(buf).await {
                Ok(n) if n > 0 => return n,
                Ok(_) => {}
                Err(_) => self.overruns = self.overruns.wrapping_add(1),
            }
        }
    }

    /// Receive errors since the last call.
    pub fn take_overruns(&mut self) -> u32 {
        core::mem::take(&mut self.overruns)
    }
}

/// Link transmit half (DMA).
pub struct LinkTx {
    tx: UartTx<'static, mode::Async>,
}

impl LinkTx {
    /// Writes every byte.
    pub async fn write(&mut self, bytes: &[u8]) {
        if self.tx.write(bytes).await.is_err() {
            defmt::warn!("link: transmit error");
        }
    }
}

/// The IWDG.
pub struct Watchdog {
    wdg: IndependentWatchdog<'static, peripherals::IWDG>,
}

impl Watchdog {
    /// Reloads the IWDG.
    pub fn feed(&mut self) {
        self.wdg.pet();
    }
}

/// DWT cycle counter (168 MHz), wrapping.
pub fn cycles() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

/// Logs the stack used so far.
pub fn boot_report() {
    defmt::info!("stack used at boot: {=u32} bytes", stack_used_bytes());
}

/// Clocks, link, watchdog.
pub fn init() -> Board {
    let mut config = embassy_stm32::Config::default();
    {
        use embassy_stm32::rcc::*;
        config.rcc.hsi = true;
        config.rcc.pll_src = PllSource::HSI;
        // 16 MHz / 8 * 168 / 2 = 168 MHz system clock; / 7 = 48 MHz for USB.
        config.rcc.pll = Some(Pll {
            prediv: PllPreDiv::DIV8,
            mul: PllMul::MUL168,
            divp: Some(PllPDiv::DIV2),
            divq: Some(PllQDiv::DIV7),
            divr: None,
        });
        config.rcc.sys = Sysclk::PLL1_P;
        config.rcc.ahb_pre = AHBPrescaler::DIV1;
        config.rcc.apb1_pre = APBPrescaler::DIV4;
        config.rcc.apb2_pre = APBPrescaler::DIV2;
    }
    let p = embassy_stm32::init(config);
    if let Some(mut cp) = cortex_m::Peripherals::take() {
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
    }
    let mut uc = usart::Config::default();
    uc.baudrate = BAUD;
    let uart = match Uart::new(p.USART1, p.PA10, p.PA9, p.DMA2_CH7, p.DMA2_CH2, Irqs, uc) {
        Ok(u) => u,
        // Unreachable with the clock tree above: `Uart::new` refuses only a baud rate outside
        // what APB2 (84 MHz, 16x oversampling: up to 5.25 MBd) can divide to, and BAUD is
        // 921 600. Should a change make it reachable, the board resets (a defined state, the
        // watchdog's too) instead of panicking.
        Err(_) => {
            defmt::error!("USART1 configuration rejected: reset");
            reboot()
        }
    };
    let (tx, rx) = uart.split();
    let rx = rx.into_ring_buffered(RX_BUF.init([0; RX_RING]));
    let mut wdg = IndependentWatchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US);
    wdg.unleash();
    Board { rx: LinkRx { rx, overruns: 0 }, tx: LinkTx { tx }, watchdog: Watchdog { wdg } }
}

/// A flight computer does not stop: shutdown resets the MCU.
pub fn shutdown() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Resets the MCU.
pub fn reboot() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    // Location only, as on the QEMU board: panic-probe's message printing links `core::fmt`
    // (about 2.7 KiB of this board's flash).
    cortex_m::interrupt::disable();
    match info.location() {
        Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("panic"),
    }
    cortex_m::asm::udf()
}
