//! One MAVLink endpoint over UDP as a [`Port`]: the simulator's side of a UAV (`host-sim serve`,
//! as a PX4 SITL instance's UDP port) or the ground station's side of a companion.

use crate::lockstep::{err, PilError, Port, Rx};
use std::collections::VecDeque;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};
use vt_companion::Framer;

/// A UDP socket talking to one peer, decoding what it receives into [`Rx`].
pub struct UdpPort {
    socket: UdpSocket,
    peer: Option<SocketAddr>,
    framer: Framer,
    pending: VecDeque<Rx>,
    timeout: Duration,
    nonblocking: bool,
    read_timeout: Option<Duration>,
}

impl UdpPort {
    /// Binds `bind` (port 0: any); talks to `peer`, or to the first sender when `None`.
    ///
    /// # Errors
    /// The address cannot be bound.
    pub fn bind(bind: SocketAddr, peer: Option<SocketAddr>, timeout: Duration) -> Result<Self, PilError> {
        let socket = UdpSocket::bind(bind).map_err(|e| PilError(format!("udp {bind}: {e}")))?;
        Ok(Self { socket, peer, framer: Framer::new(), pending: VecDeque::new(), timeout, nonblocking: false, read_timeout: None })
    }

    /// The bound address.
    ///
    /// # Errors
    /// The socket has none.
    pub fn local_addr(&self) -> Result<SocketAddr, PilError> {
        self.socket.local_addr().map_err(|e| PilError(e.to_string()))
    }

    /// Sets the peer.
    pub fn set_peer(&mut self, peer: SocketAddr) {
        self.peer = Some(peer);
    }

    /// The peer, once known.
    pub fn peer(&self) -> Option<SocketAddr> {
        self.peer
    }

    /// The next message if one arrives within `wait` (`None`: nothing).
    ///
    /// # Errors
    /// The socket failed.
    pub fn poll(&mut self, wait: Duration) -> Result<Option<Rx>, PilError> {
        if let Some(rx) = self.pending.pop_front() {
            return Ok(Some(rx));
        }
        // A zero wait must not block: the kernel rounds a read time-out up to a scheduler tick
        // (4 ms), longer than the companions' 2 ms between setpoints.
        let nonblocking = wait.is_zero();
        if nonblocking != self.nonblocking {
            self.socket.set_nonblocking(nonblocking).map_err(|e| PilError(e.to_string()))?;
            self.nonblocking = nonblocking;
        }
        if !nonblocking && self.read_timeout != Some(wait) {
            self.socket.set_read_timeout(Some(wait)).map_err(|e| PilError(e.to_string()))?;
            self.read_timeout = Some(wait);
        }
        let mut buf = [0u8; 4096];
        match self.socket.recv_from(&mut buf) {
            Ok((n, from)) => {
                if self.peer.is_none() {
                    self.peer = Some(from);
                }
                crate::lockstep::wire::decode_into(&mut self.framer, buf.get(..n).unwrap_or(&[]), &mut self.pending);
                Ok(self.pending.pop_front())
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut | std::io::ErrorKind::ConnectionRefused) => Ok(None),
            Err(e) => err(format!("udp receive: {e}")),
        }
    }
}

impl Port for UdpPort {
    fn send(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        let Some(peer) = self.peer else {
            return err("udp: peer unknown (nothing received yet)");
        };
        match self.socket.send_to(bytes, peer) {
            Ok(_) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => Ok(()),
            Err(e) => err(format!("udp send to {peer}: {e}")),
        }
    }

    fn recv(&mut self) -> Result<Rx, PilError> {
        let t0 = Instant::now();
        loop {
            let left = self.timeout.saturating_sub(t0.elapsed());
            if left.is_zero() {
                return err(format!("no reply from {} within {:.0} s", self.peer.map_or("?".into(), |p| p.to_string()), self.timeout.as_secs_f64()));
            }
            if let Some(rx) = self.poll(left.min(Duration::from_millis(100)))? {
                return Ok(rx);
            }
        }
    }
}
