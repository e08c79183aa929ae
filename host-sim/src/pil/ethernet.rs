//! The host's side of the QEMU board's Ethernet link (firmware `src/board/lan9118.rs`): the
//! MAVLink byte stream in Ethernet II frames of the link's EtherType, carried over QEMU's
//! `-netdev stream` socket, where each frame is preceded by its length (big-endian `u32`).
//!
//! Frame: destination (6), source (6), EtherType [`ETHERTYPE`] (2, big-endian), payload length
//! (2, big-endian), payload (at most [`MAX_PAYLOAD`] bytes), then any padding.

/// The link's EtherType (IEEE 802 local experimental EtherType 1; the firmware's).
pub const ETHERTYPE: u16 = 0x88B5;
/// Ethernet header plus the payload length, bytes.
pub const HEADER: usize = 16;
/// Most payload bytes in one frame (the firmware's receive pipe holds two).
pub const MAX_PAYLOAD: usize = 512;
/// Source address of the host's frames (locally administered, unicast).
const HOST_MAC: [u8; 6] = [0x02, 0, 0, 0, 0, 0xFE];
/// Destination of the host's frames: broadcast (the firmware's controller is promiscuous).
const BROADCAST: [u8; 6] = [0xFF; 6];

/// `bytes` as stream records: one length-prefixed frame per [`MAX_PAYLOAD`] bytes.
pub fn encode(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len() + (bytes.len() / MAX_PAYLOAD + 1) * (HEADER + 4));
    for chunk in bytes.chunks(MAX_PAYLOAD) {
        let frame_len = (HEADER + chunk.len()) as u32;
        out.extend_from_slice(&frame_len.to_be_bytes());
        out.extend_from_slice(&BROADCAST);
        out.extend_from_slice(&HOST_MAC);
        out.extend_from_slice(&ETHERTYPE.to_be_bytes());
        out.extend_from_slice(&(chunk.len() as u16).to_be_bytes());
        out.extend_from_slice(chunk);
    }
    out
}

/// Splits the stream from QEMU into frames and frames into payloads.
#[derive(Debug, Default)]
pub struct Deframer {
    buf: Vec<u8>,
    /// Frames that were not the link's (other EtherType, impossible length), dropped.
    pub dropped: u64,
    /// The link's frames received, empty ones included (the firmware's first frame is an
    /// empty "link up").
    pub frames: u64,
}

/// A stream record longer than this is not a frame QEMU's NIC could send: the stream is out of
/// step and is reset (bytes).
const MAX_RECORD: usize = 65_536;

impl Deframer {
    /// Adds stream bytes; calls `payload` with each complete frame's payload, in order.
    pub fn push(&mut self, bytes: &[u8], mut payload: impl FnMut(&[u8])) {
        self.buf.extend_from_slice(bytes);
        let mut at = 0;
        while let Some(len) = self.buf.get(at..at + 4).and_then(|b| <[u8; 4]>::try_from(b).ok()).map(|b| u32::from_be_bytes(b) as usize) {
            if len > MAX_RECORD {
                self.dropped += 1;
                self.buf.clear();
                return;
            }
            let Some(frame) = self.buf.get(at + 4..at + 4 + len) else {
                break;
            };
            match link_payload(frame) {
                Some(p) => {
                    self.frames += 1;
                    payload(p);
                }
                None => self.dropped += 1,
            }
            at += 4 + len;
        }
        self.buf.drain(..at);
    }
}

/// The payload of one of the link's frames (`None`: not the link's).
fn link_payload(frame: &[u8]) -> Option<&[u8]> {
    let kind = u16::from_be_bytes([*frame.get(12)?, *frame.get(13)?]);
    let len = usize::from(u16::from_be_bytes([*frame.get(14)?, *frame.get(15)?]));
    if kind != ETHERTYPE || len > MAX_PAYLOAD {
        return None;
    }
    frame.get(HEADER..HEADER + len)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn collect(d: &mut Deframer, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        d.push(bytes, |p| out.extend_from_slice(p));
        out
    }

    #[test]
    fn bytes_survive_frames_and_any_split_of_the_stream() {
        let bytes: Vec<u8> = (0..3000u32).map(|i| (i * 7 % 251) as u8).collect();
        let stream = encode(&bytes);
        assert_eq!(stream.len(), bytes.len() + 6 * (HEADER + 4), "six frames of at most 512 bytes");
        for step in [1, 3, 17, 1000, stream.len()] {
            let mut d = Deframer::default();
            let got: Vec<u8> = stream.chunks(step).flat_map(|c| collect(&mut d, c)).collect();
            assert_eq!(got, bytes, "split every {step} bytes");
            assert_eq!(d.dropped, 0);
        }
    }

    #[test]
    fn padding_is_ignored_and_foreign_frames_are_dropped() {
        // A 3-byte payload padded to Ethernet's 60-byte minimum.
        let mut frame = encode(&[1, 2, 3]);
        frame.resize(4 + 60, 0xAA);
        frame[..4].copy_from_slice(&60u32.to_be_bytes());
        // An IPv4 frame of the same size.
        let mut foreign = frame.clone();
        foreign[4 + 12..4 + 14].copy_from_slice(&0x0800u16.to_be_bytes());
        // A payload length beyond the frame.
        let mut long = frame.clone();
        long[4 + 14..4 + 16].copy_from_slice(&2000u16.to_be_bytes());
        let mut d = Deframer::default();
        let stream = [frame.clone(), foreign, long, frame].concat();
        assert_eq!(collect(&mut d, &stream), vec![1, 2, 3, 1, 2, 3]);
        assert_eq!((d.dropped, d.frames), (2, 2));
    }

    #[test]
    fn an_impossible_record_length_resets_the_stream() {
        let mut d = Deframer::default();
        assert!(collect(&mut d, &u32::MAX.to_be_bytes()).is_empty());
        assert_eq!(d.dropped, 1);
        assert_eq!(collect(&mut d, &encode(&[9])), vec![9], "in step again");
    }

    #[test]
    fn an_empty_send_sends_nothing_and_an_empty_frame_counts() {
        assert!(encode(&[]).is_empty());
        let mut link_up = encode(&[7]);
        link_up[..4].copy_from_slice(&(HEADER as u32).to_be_bytes());
        link_up.truncate(4 + HEADER);
        link_up[4 + 15] = 0;
        let mut d = Deframer::default();
        assert!(collect(&mut d, &link_up).is_empty());
        assert_eq!((d.dropped, d.frames), (0, 1));
    }
}
