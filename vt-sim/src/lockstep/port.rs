//! One UAV's link to its companion ([`Port`]): its host twin ([`SilPort`]), a UDP socket
//! ([`crate::sitl::udp::UdpPort`]), or the firmware in QEMU (host-sim's `pil::QemuPort`).

use std::collections::VecDeque;
use crate::companion::HostCompanion;
use vt_companion::{Companion, Framer, Io};
use super::wire::*;
use super::PilError;

/// One UAV's link to its companion: the firmware in QEMU, or its host twin.
pub trait Port {
    /// Sends bytes (frames or anything else).
    ///
    /// # Errors
    /// The link is closed.
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError>;
    /// The next message from the companion.
    ///
    /// # Errors
    /// Nothing arrives within the timeout (QEMU), or nothing is pending (host twin).
    fn recv(&mut self) -> Result<Rx, PilError>;
    /// Waits for the companion to stop (after a shutdown request) and returns its exit code
    /// and raw log; a host twin has neither.
    ///
    /// # Errors
    /// It does not stop in time.
    fn finish(self: Box<Self>) -> Result<(Option<i32>, Vec<u8>), PilError> {
        Ok((Some(0), Vec::new()))
    }
}

impl Port for Box<dyn Port> {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        self.as_mut().send(bytes)
    }
    fn recv(&mut self) -> Result<Rx, PilError> {
        self.as_mut().recv()
    }
    fn finish(self: Box<Self>) -> Result<(Option<i32>, Vec<u8>), PilError> {
        (*self).finish()
    }
}

/// The board side of the host twin: frames into a byte queue, no clock (lockstep needs none).
struct TwinIo<'a> {
    out: &'a mut Vec<u8>,
}

impl Io for TwinIo<'_> {
    fn now_ms(&self) -> u32 {
        0
    }
    fn cycles(&self) -> u32 {
        0
    }
    fn send(&mut self, frame: &[u8]) {
        self.out.extend_from_slice(frame);
    }
}

/// The firmware's companion compiled for the host (software in the loop), fed bytes.
pub struct SilPort {
    companion: HostCompanion,
    framer: Framer,
    pending: VecDeque<Rx>,
}

impl Default for SilPort {
    fn default() -> Self {
        Self::new()
    }
}

impl SilPort {
    /// A fresh companion.
    pub fn new() -> Self {
        Self { companion: HostCompanion::new(), framer: Framer::new(), pending: VecDeque::new() }
    }

    /// The companion (for inspection in tests); `None` only while the twin is being dropped.
    pub fn companion(&self) -> Option<&Companion<'static>> {
        self.companion.get()
    }
}

impl Port for SilPort {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        let mut out = Vec::new();
        let Some(companion) = self.companion.get_mut() else {
            return Err(PilError("host twin: dropped".into()));
        };
        let _request = companion.on_bytes(bytes, &mut TwinIo { out: &mut out });
        // Issue 28: the board gives the companion its map's storage once `PR_MAP` asks for
        // one (the firmware's perception build holds it in `static`s from boot).
        if companion.params().get_u32(vt_companion::Param::PrMap) == 1 {
            self.companion.provide_map();
        }
        decode_into(&mut self.framer, &out, &mut self.pending);
        Ok(())
    }

    fn recv(&mut self) -> Result<Rx, PilError> {
        self.pending.pop_front().ok_or_else(|| PilError("host twin: no reply pending".into()))
    }
}
