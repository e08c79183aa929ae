//! The SMSC LAN9118 Ethernet controller of the QEMU `mps2-an386` board (at `0x4020_0000`,
//! interrupt line 13; QEMU `hw/arm/mps2.c`, `hw/net/lan9118.c`; SMSC LAN9118 data sheet,
//! register map "System Control and Status Registers"): the PIL link.
//!
//! **Why Ethernet and not the UART.** QEMU's CMSDK UART holds one received byte, so every byte
//! costs the emulator a main-loop pass and a wake-up of the vCPU thread (~40 µs of host time),
//! and every transmitted byte a `send` system call. A packet carries a whole lockstep tick
//! (about a hundred bytes) for the price of one (docs/firmware.md, "The PIL link").
//!
//! **Framing (decision).** One Ethernet II frame carries a slice of the MAVLink byte stream:
//! destination broadcast, source [`SOURCE_MAC`], EtherType [`ETHERTYPE`] (IEEE 802 "local
//! experimental 1"), then the payload length (big-endian `u16`) and the payload, at most
//! [`MAX_PAYLOAD`] bytes. The length makes padding harmless: a frame shorter than Ethernet's
//! 60-byte minimum may be padded on a real segment (QEMU pads nothing). A frame with another
//! EtherType or an impossible length is dropped whole and counted.
//!
//! The driver runs the controller in 32-bit mode, promiscuous (its reset state), with the
//! receive-status-FIFO-level interrupt at level 0: one interrupt per arriving frame.
//!
//! # Unsafe
//! Volatile access to the controller's registers only ([`read`], [`write`]).
#![allow(unsafe_code)]

/// Base address of the controller's registers.
const BASE: usize = 0x4020_0000;
/// Receive data FIFO port (words, little-endian bytes).
const RX_DATA_FIFO: usize = 0x00;
/// Transmit data FIFO port: command A, command B, then the frame's words.
const TX_DATA_FIFO: usize = 0x20;
/// Receive status FIFO port (pops one frame's status).
const RX_STATUS_FIFO: usize = 0x40;
/// Interrupt configuration.
const IRQ_CFG: usize = 0x54;
/// Interrupt status (write 1 to clear).
const INT_STS: usize = 0x58;
/// Interrupt enable.
const INT_EN: usize = 0x5C;
/// Reads [`BYTE_TEST_VALUE`] when the bus and the controller work.
const BYTE_TEST: usize = 0x64;
/// Transmit configuration.
const TX_CFG: usize = 0x70;
/// Receive FIFO information: bits 23:16 frames waiting.
const RX_FIFO_INF: usize = 0x7C;
/// Transmit FIFO information: bits 15:0 free space.
const TX_FIFO_INF: usize = 0x80;
/// MAC control and status register command (indirect access to the MAC's registers).
const MAC_CSR_CMD: usize = 0xA4;
/// MAC control and status register data.
const MAC_CSR_DATA: usize = 0xA8;

const BYTE_TEST_VALUE: u32 = 0x8765_4321;
/// `IRQ_CFG`: interrupt output enabled, active high, push-pull.
const IRQ_CFG_ON: u32 = (1 << 8) | (1 << 4) | 1;
/// `INT_STS` / `INT_EN`: receive status FIFO level.
const INT_RSFL: u32 = 1 << 3;
/// `TX_CFG`: transmitter on, status FIFO may overrun (no one reads the transmit statuses).
const TX_CFG_ON: u32 = (1 << 2) | (1 << 1);
/// `MAC_CSR_CMD`: busy (starts the access), and the MAC control register's index.
const MAC_CSR_BUSY: u32 = 1 << 31;
const MAC_CR: u32 = 1;
/// MAC control: promiscuous (reset value kept), transmitter and receiver enabled.
const MAC_CR_ON: u32 = (1 << 18) | (1 << 3) | (1 << 2);
/// Transmit command A: first and last segment of the frame (bits 13, 12), buffer size 10:0.
const CMD_A_WHOLE_FRAME: u32 = (1 << 13) | (1 << 12);

/// The link's EtherType (IEEE 802 local experimental EtherType 1).
pub const ETHERTYPE: u16 = 0x88B5;
/// Source address of the firmware's frames (locally administered, unicast).
pub const SOURCE_MAC: [u8; 6] = [0x02, 0, 0, 0, 0, 0x01];
/// Ethernet header plus the payload length, bytes.
pub const HEADER: usize = 16;
/// Most payload bytes in one frame (so a frame always fits the receive pipe's room).
pub const MAX_PAYLOAD: usize = 512;

fn read(offset: usize) -> u32 {
    // SAFETY: the LAN9118 is a fixed MMIO block of the mps2-an386 board (0x4020_0000, 256 B);
    // word access is what its 32-bit mode expects.
    unsafe { core::ptr::read_volatile((BASE + offset) as *const u32) }
}

fn write(offset: usize, value: u32) {
    // SAFETY: as above; writes to these registers have no memory-safety effects.
    unsafe { core::ptr::write_volatile((BASE + offset) as *mut u32, value) }
}

/// Starts the controller: MAC transmitter and receiver on, one interrupt per received frame.
/// Returns `false` when the controller does not answer (the link then stays silent).
pub fn init() -> bool {
    if read(BYTE_TEST) != BYTE_TEST_VALUE {
        return false;
    }
    write(MAC_CSR_DATA, MAC_CR_ON);
    write(MAC_CSR_CMD, MAC_CSR_BUSY | MAC_CR);
    // The access completes within microseconds on silicon, at once in QEMU; bounded anyway.
    let mut spins = 0u32;
    while read(MAC_CSR_CMD) & MAC_CSR_BUSY != 0 && spins < 10_000 {
        spins += 1;
    }
    write(TX_CFG, TX_CFG_ON);
    write(INT_STS, u32::MAX);
    write(INT_EN, INT_RSFL);
    write(IRQ_CFG, IRQ_CFG_ON);
    true
}

/// Acknowledges the receive interrupt (a frame arriving later raises it again).
pub fn acknowledge() {
    write(INT_STS, INT_RSFL);
}

/// Turns the receive interrupt on or off (frames wait in the controller's FIFO meanwhile).
pub fn set_receive_interrupt(on: bool) {
    write(INT_EN, if on { INT_RSFL } else { 0 });
}

/// Whether the receive interrupt is on.
pub fn receive_interrupt_on() -> bool {
    read(INT_EN) & INT_RSFL != 0
}

/// Frames waiting in the receive FIFO.
pub fn frames_waiting() -> u32 {
    (read(RX_FIFO_INF) >> 16) & 0xFF
}

/// Pops the next frame and hands its payload to `sink` four bytes at a time (the last call
/// may carry fewer). Returns `false` when the frame was not the link's (other EtherType,
/// length beyond the frame): it is drained and dropped.
pub fn receive(mut sink: impl FnMut(&[u8])) -> bool {
    let status = read(RX_STATUS_FIFO);
    // Bits 29:16: the frame's length with its 4-byte CRC.
    let with_crc = ((status >> 16) & 0x3FFF) as usize;
    let words = with_crc.div_ceil(4);
    let frame = with_crc.saturating_sub(4);
    // Word 3 holds bytes 12..16: the EtherType and the payload length, both big-endian.
    let mut header = [0u32; HEADER / 4];
    for (i, h) in header.iter_mut().enumerate() {
        if i < words {
            *h = read(RX_DATA_FIFO);
        }
    }
    let [.., w3] = header;
    let kind = u16::from_be_bytes([w3 as u8, (w3 >> 8) as u8]);
    let len = usize::from(u16::from_be_bytes([(w3 >> 16) as u8, (w3 >> 24) as u8]));
    let ours = words >= HEADER / 4 && kind == ETHERTYPE && len <= MAX_PAYLOAD && HEADER + len <= frame;
    let mut left = if ours { len } else { 0 };
    for _ in (HEADER / 4).min(words)..words {
        let w = read(RX_DATA_FIFO).to_le_bytes();
        if left > 0 {
            let n = left.min(4);
            sink(w.get(..n).unwrap_or(&[]));
            left -= n;
        }
    }
    ours
}

/// Free space in the transmit FIFO, bytes.
fn tx_free_bytes() -> usize {
    ((read(TX_FIFO_INF) & 0xFFFF) as usize) * 4
}

/// Whether a frame with `payload` bytes fits the transmit FIFO now.
pub fn can_send(payload: usize) -> bool {
    tx_free_bytes() >= HEADER + payload + 8
}

/// Sends one frame carrying `payload` (at most [`MAX_PAYLOAD`] bytes; the rest is cut).
/// Call [`can_send`] first: the controller drops words beyond its FIFO.
pub fn send(payload: &[u8]) {
    let payload = payload.get(..payload.len().min(MAX_PAYLOAD)).unwrap_or(&[]);
    let frame_len = (HEADER + payload.len()) as u32;
    write(TX_DATA_FIFO, CMD_A_WHOLE_FRAME | frame_len);
    write(TX_DATA_FIFO, frame_len); // command B: tag 0, packet length
    let [s0, s1, s2, s3, s4, s5] = SOURCE_MAC;
    let [t0, t1] = ETHERTYPE.to_be_bytes();
    let [l0, l1] = (payload.len() as u16).to_be_bytes();
    write(TX_DATA_FIFO, u32::MAX); // destination: broadcast
    write(TX_DATA_FIFO, u32::from_le_bytes([0xFF, 0xFF, s0, s1]));
    write(TX_DATA_FIFO, u32::from_le_bytes([s2, s3, s4, s5]));
    write(TX_DATA_FIFO, u32::from_le_bytes([t0, t1, l0, l1]));
    for chunk in payload.chunks(4) {
        write(TX_DATA_FIFO, le_word(chunk));
    }
}

/// Up to four bytes as a little-endian word (missing bytes zero).
fn le_word(bytes: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    for (d, s) in b.iter_mut().zip(bytes) {
        *d = *s;
    }
    u32::from_le_bytes(b)
}
