//! MAVLink 2 frame synchroniser: bytes in, CRC-checked frames out, every defect counted.
//!
//! The stream is scanned for the v2 marker `0xFD`; a candidate frame's length comes from its
//! header, its checksum is X.25 over header and payload plus the message's `CRC_EXTRA` from the
//! common dialect. A candidate that fails (unsupported incompatibility flags, bad checksum, id
//! unknown to the dialect) is dropped one byte at a time: scanning resumes at its second byte,
//! so a real frame swallowed by a false marker in garbage is still found. MAVLink 1 frames and
//! signed frames' signatures are not interpreted (a v1 frame is garbage here; a signature is
//! skipped, not checked).
//!
//! Nothing here can panic: every index is checked, the buffer never grows past one maximum frame.

use mavlink::dialects::common::MavMessage;
use mavlink::Message as _;

/// MAVLink 2 start-of-frame marker.
pub const STX_V2: u8 = 0xFD;
/// Marker, length, flags (2), sequence, system, component, message id (3): header bytes.
const HEADER_LEN: usize = 10;
/// Checksum bytes.
const CRC_LEN: usize = 2;
/// Signature bytes of a signed frame.
const SIGNATURE_LEN: usize = 13;
/// Incompatibility flag: the frame is signed.
const IFLAG_SIGNED: u8 = 0x01;
/// Id of `COMPONENT_INFORMATION`, the one common message whose `CRC_EXTRA` is 0.
const COMPONENT_INFORMATION_ID: u32 = 395;
/// Largest frame: header, 255 bytes of payload, checksum, signature.
pub const MAX_FRAME_LEN: usize = HEADER_LEN + 255 + CRC_LEN + SIGNATURE_LEN;

/// Link-level counters (monotonic, wrapping).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkCounters {
    /// Frames that passed the checksum.
    pub frames_ok: u32,
    /// Candidates with a bad checksum (id known to the dialect).
    pub crc_errors: u32,
    /// Candidates whose message id the common dialect does not know.
    pub unknown_ids: u32,
    /// Candidates with unsupported incompatibility flags.
    pub framing_errors: u32,
    /// Bytes outside any candidate (garbage between frames).
    pub bytes_discarded: u32,
    /// Bytes lost because frames were not drained in time.
    pub overruns: u32,
}

impl LinkCounters {
    /// All counters at zero (`Default` in `const` contexts).
    pub const ZERO: Self =
        Self { frames_ok: 0, crc_errors: 0, unknown_ids: 0, framing_errors: 0, bytes_discarded: 0, overruns: 0 };

    /// Every rejected candidate (checksum, unknown id, flags).
    pub fn rejected(&self) -> u32 {
        self.crc_errors.wrapping_add(self.unknown_ids).wrapping_add(self.framing_errors)
    }
}

/// A checked frame, borrowed from the [`Framer`] until the next call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    /// Sender system id.
    pub system_id: u8,
    /// Sender component id.
    pub component_id: u8,
    /// Sequence number.
    pub sequence: u8,
    /// Message id.
    pub message_id: u32,
    /// Payload (possibly truncated of trailing zeros, as MAVLink 2 allows).
    pub payload: &'a [u8],
}

/// The synchroniser state: at most one maximum frame of buffered bytes.
#[derive(Debug, Clone)]
pub struct Framer {
    buf: [u8; MAX_FRAME_LEN],
    len: usize,
    /// Length of the frame handed out by the last [`Framer::next_frame`], removed on the next call.
    consumed: usize,
    /// The datagram the buffered bytes came in has ended ([`Framer::end_datagram`]): an
    /// incomplete candidate is bogus, not waiting for more bytes.
    datagram_ended: bool,
    counters: LinkCounters,
}

impl Default for Framer {
    fn default() -> Self {
        Self::new()
    }
}

impl Framer {
    /// An empty synchroniser.
    pub const fn new() -> Self {
        Self { buf: [0; MAX_FRAME_LEN], len: 0, consumed: 0, datagram_ended: false, counters: LinkCounters::ZERO }
    }

    /// The counters so far.
    pub fn counters(&self) -> &LinkCounters {
        &self.counters
    }

    /// Adds `n` receive overruns counted below the framer (the board's link driver: bytes or
    /// frames lost before they reached it).
    pub fn add_overruns(&mut self, n: u32) {
        self.counters.overruns = self.counters.overruns.wrapping_add(n);
    }

    /// Appends one received byte. Call [`Framer::next_frame`] until it returns `None` after
    /// each byte (or each chunk of at most one frame's worth).
    pub fn push(&mut self, byte: u8) {
        self.drop_consumed();
        self.datagram_ended = false;
        if self.len == 0 && byte != STX_V2 {
            self.counters.bytes_discarded = self.counters.bytes_discarded.wrapping_add(1);
            return;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
            }
            None => self.counters.overruns = self.counters.overruns.wrapping_add(1),
        }
    }

    /// Marks the end of a datagram, on transports that carry whole frames per datagram (UDP:
    /// PX4, ArduPilot and mavlink-router never split a frame). Call [`Framer::next_frame`] until
    /// it returns `None` afterwards: a frame left incomplete is dropped as a framing error and
    /// the bytes after its marker are searched at once, instead of waiting for the next
    /// datagram to complete a bogus candidate. The next [`Framer::push`] clears the mark.
    pub fn end_datagram(&mut self) {
        self.datagram_ended = true;
    }

    /// An incomplete candidate at the front: wait for bytes, or drop it if its datagram ended.
    /// Returns true when the caller should search again.
    fn incomplete(&mut self) -> bool {
        if !self.datagram_ended || self.len == 0 {
            return false;
        }
        self.counters.framing_errors = self.counters.framing_errors.wrapping_add(1);
        self.resync();
        true
    }

    /// The next complete, checked frame in the buffer, if any.
    pub fn next_frame(&mut self) -> Option<Frame<'_>> {
        self.drop_consumed();
        loop {
            let (len, flags) = match (self.buf.get(1).copied(), self.buf.get(2).copied()) {
                (Some(l), Some(f)) if self.len >= 3 => (usize::from(l), f),
                _ if self.incomplete() => continue,
                _ => return None,
            };
            if flags & !IFLAG_SIGNED != 0 {
                self.counters.framing_errors = self.counters.framing_errors.wrapping_add(1);
                self.resync();
                continue;
            }
            let signature = if flags & IFLAG_SIGNED != 0 { SIGNATURE_LEN } else { 0 };
            let total = HEADER_LEN + len + CRC_LEN + signature;
            if self.len < total {
                if self.incomplete() {
                    continue;
                }
                return None;
            }
            let id = |k: usize| u32::from(self.buf.get(k).copied().unwrap_or(0));
            let message_id = id(7) | (id(8) << 8) | (id(9) << 16);
            let extra = MavMessage::extra_crc(message_id);
            // The dialect answers CRC_EXTRA 0 for ids it does not know (one real message,
            // COMPONENT_INFORMATION, also has 0).
            if extra == 0 && message_id != COMPONENT_INFORMATION_ID {
                self.counters.unknown_ids = self.counters.unknown_ids.wrapping_add(1);
                self.resync();
                continue;
            }
            let crc_at = HEADER_LEN + len;
            let expected = match (self.buf.get(crc_at).copied(), self.buf.get(crc_at + 1).copied()) {
                (Some(lo), Some(hi)) => u16::from_le_bytes([lo, hi]),
                _ if self.incomplete() => continue,
                _ => return None,
            };
            let actual = self.buf.get(1..crc_at).map(|d| mavlink::calculate_crc(d, extra));
            if actual == Some(expected) {
                self.counters.frames_ok = self.counters.frames_ok.wrapping_add(1);
                self.consumed = total;
                let at = |k: usize| self.buf.get(k).copied().unwrap_or(0);
                return Some(Frame {
                    sequence: at(4),
                    system_id: at(5),
                    component_id: at(6),
                    message_id,
                    payload: self.buf.get(HEADER_LEN..crc_at).unwrap_or(&[]),
                });
            }
            self.counters.crc_errors = self.counters.crc_errors.wrapping_add(1);
            self.resync();
        }
    }

    /// Removes the frame handed out last time.
    fn drop_consumed(&mut self) {
        if self.consumed > 0 {
            let n = self.consumed.min(self.len);
            self.buf.copy_within(n..self.len, 0);
            self.len -= n;
            self.consumed = 0;
            self.align_to_marker();
        }
    }

    /// Drops the current candidate's marker and scans on from its second byte.
    fn resync(&mut self) {
        if self.len > 0 {
            self.buf.copy_within(1..self.len, 0);
            self.len -= 1;
        }
        self.align_to_marker();
    }

    /// Discards bytes before the next marker.
    fn align_to_marker(&mut self) {
        let live = self.buf.get(..self.len).unwrap_or(&[]);
        let skip = live.iter().position(|&b| b == STX_V2).unwrap_or(self.len);
        if skip > 0 {
            self.counters.bytes_discarded = self.counters.bytes_discarded.wrapping_add(skip as u32);
            self.buf.copy_within(skip..self.len, 0);
            self.len -= skip;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::common::{HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA};
    use mavlink::{MAVLinkV2MessageRaw, MavHeader, MessageData};

    fn frame<D: MessageData>(d: &D, seq: u8) -> Vec<u8> {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_data(MavHeader { system_id: 7, component_id: 1, sequence: seq }, d);
        raw.raw_bytes().to_vec()
    }

    fn pos(x: f32) -> LOCAL_POSITION_NED_DATA {
        LOCAL_POSITION_NED_DATA { time_boot_ms: 5, x, y: 2.0, z: -3.0, vx: 0.5, vy: 0.0, vz: 0.0 }
    }

    fn feed(f: &mut Framer, bytes: &[u8]) -> Vec<(u32, u8, Vec<u8>)> {
        let mut out = Vec::new();
        for &b in bytes {
            f.push(b);
            while let Some(fr) = f.next_frame() {
                out.push((fr.message_id, fr.sequence, fr.payload.to_vec()));
            }
        }
        out
    }

    #[test]
    fn clean_stream_yields_every_frame() {
        let mut bytes = frame(&pos(1.0), 0);
        bytes.extend(frame(&HEARTBEAT_DATA::default(), 1));
        let mut f = Framer::new();
        let got = feed(&mut f, &bytes);
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].0, LOCAL_POSITION_NED_DATA::ID);
        assert_eq!(got[1].1, 1);
        assert_eq!(f.counters().rejected(), 0);
        assert_eq!(f.counters().bytes_discarded, 0);
    }

    #[test]
    fn corrupted_frame_is_counted_and_the_next_one_survives() {
        let mut bad = frame(&pos(1.0), 0);
        bad[14] ^= 0x40;
        let mut bytes = bad;
        bytes.extend(frame(&pos(2.0), 1));
        let mut f = Framer::new();
        let got = feed(&mut f, &bytes);
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].1, 1);
        assert_eq!(f.counters().crc_errors, 1);
    }

    #[test]
    fn truncated_frame_then_good_frame() {
        let cut = frame(&pos(1.0), 0);
        let mut bytes = cut[..cut.len() - 9].to_vec();
        bytes.extend(frame(&pos(2.0), 1));
        bytes.extend(frame(&pos(3.0), 2));
        let mut f = Framer::new();
        let got = feed(&mut f, &bytes);
        let seqs: Vec<u8> = got.iter().map(|g| g.1).collect();
        assert_eq!(seqs, vec![1, 2], "the swallowed frame is recovered by rescanning");
        assert!(f.counters().rejected() >= 1);
    }

    #[test]
    fn false_marker_with_long_length_in_garbage() {
        // A garbage 0xFD claims 250 bytes of payload and swallows two real frames.
        let mut bytes = vec![0x11, STX_V2, 250, 0, 0, 0, 0, 0, 0, 0];
        bytes.extend(frame(&pos(2.0), 1));
        bytes.extend(frame(&pos(3.0), 2));
        bytes.extend(vec![0x55; 300]);
        bytes.extend(frame(&pos(4.0), 3));
        let mut f = Framer::new();
        let got = feed(&mut f, &bytes);
        let seqs: Vec<u8> = got.iter().map(|g| g.1).collect();
        assert_eq!(seqs, vec![1, 2, 3]);
        assert!(f.counters().bytes_discarded >= 300);
    }

    /// Drains every frame after the end of a datagram.
    fn end(f: &mut Framer) -> Vec<u32> {
        f.end_datagram();
        let mut out = Vec::new();
        while let Some(fr) = f.next_frame() {
            out.push(fr.message_id);
        }
        out
    }

    #[test]
    fn a_datagram_ending_mid_frame_does_not_hold_back_the_next() {
        // Datagram 1: a good frame, then a marker claiming 250 bytes, then a good frame
        // inside the claimed span. On a stream both would wait for 250 more bytes; at the
        // datagram's end the stub is dropped and the frame inside it is found.
        let mut f = Framer::new();
        let mut d1 = frame(&pos(1.0), 0);
        d1.extend([STX_V2, 250, 0, 0]);
        d1.extend(frame(&HEARTBEAT_DATA::default(), 1));
        let got: Vec<u32> = feed(&mut f, &d1).iter().map(|g| g.0).collect();
        assert_eq!(got, [LOCAL_POSITION_NED_DATA::ID]);
        assert_eq!(end(&mut f), [HEARTBEAT_DATA::ID]);
        assert_eq!(f.counters().framing_errors, 1);
        // Datagram 2 starts clean; a lone marker at its end is dropped too.
        let mut d2 = frame(&pos(2.0), 2);
        d2.push(STX_V2);
        assert_eq!(feed(&mut f, &d2).len(), 1);
        assert!(end(&mut f).is_empty());
        assert_eq!(f.counters().framing_errors, 2);
        // Without the end mark (a serial stream) the same bytes wait: a frame may straddle reads.
        let mut g = Framer::new();
        assert!(feed(&mut g, &[STX_V2, 250, 0, 0]).is_empty());
        assert!(feed(&mut g, &frame(&HEARTBEAT_DATA::default(), 1)).is_empty());
    }

    #[test]
    fn unknown_id_is_counted_as_such() {
        let mut bytes = frame(&pos(1.0), 0);
        // Message id 0xABCDE is not in the common dialect; fix up its checksum with extra 0.
        bytes[7] = 0xDE;
        bytes[8] = 0xBC;
        bytes[9] = 0x0A;
        let n = bytes.len();
        let crc = mavlink::calculate_crc(&bytes[1..n - 2], 0).to_le_bytes();
        bytes[n - 2] = crc[0];
        bytes[n - 1] = crc[1];
        let mut f = Framer::new();
        assert!(feed(&mut f, &bytes).is_empty());
        assert_eq!(f.counters().unknown_ids, 1);
    }

    #[test]
    fn random_bytes_never_panic_and_stay_bounded() {
        let mut f = Framer::new();
        let mut x: u64 = 0x1234_5678;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Bias towards the marker and small lengths to exercise the candidate paths.
            let b = match x % 7 {
                0 => STX_V2,
                1 => (x >> 8) as u8 % 40,
                _ => (x >> 16) as u8,
            };
            f.push(b);
            while f.next_frame().is_some() {}
            assert!(f.len <= MAX_FRAME_LEN);
        }
        assert!(f.counters().rejected() > 0);
    }
}
