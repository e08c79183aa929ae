//! The companion's MAVLink link on Linux: a UDP socket or a serial port (docs/deploy.md).

use std::io::{self, Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;

/// Largest datagram or read chunk, bytes (a MAVLink 2 frame is at most 280).
pub const READ_CHUNK: usize = 2048;

/// A byte link to the autopilot and the team.
pub trait Link {
    /// Waits at most `timeout` for bytes; returns how many were read into `buf` (0: none).
    ///
    /// # Errors
    /// The link failed for good.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;

    /// Sends one complete MAVLink frame.
    ///
    /// # Errors
    /// The link failed for good.
    fn send(&mut self, frame: &[u8]) -> io::Result<()>;

    /// True when each read returns one datagram of whole frames (UDP), false for a byte
    /// stream (serial), where a frame may straddle reads.
    fn datagrams(&self) -> bool {
        false
    }
}

/// MAVLink over UDP: one frame per datagram, to every `remote` (the autopilot, the ground
/// station: what a MAVLink router would fan out), or to whoever sent last when none is given
/// (as PX4's and mavlink-router's UDP servers answer their clients).
pub struct Udp {
    socket: UdpSocket,
    remotes: Vec<SocketAddr>,
    last_sender: Option<SocketAddr>,
}

impl Udp {
    /// Binds `bind`; sends to every address of `remotes`.
    ///
    /// # Errors
    /// The address cannot be bound.
    pub fn open(bind: SocketAddr, remotes: Vec<SocketAddr>) -> io::Result<Self> {
        let socket = UdpSocket::bind(bind)?;
        socket.set_nonblocking(true)?;
        Ok(Self { socket, remotes, last_sender: None })
    }

    /// The bound address (the port the OS chose for `:0`).
    ///
    /// # Errors
    /// The socket has no local address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }
}

impl Link for Udp {
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        match self.try_recv(buf)? {
            0 => {}
            n => return Ok(n),
        }
        // Wait on poll(2), whose timeout is exact to the high-resolution timer (a read
        // timeout on the socket would be rounded up to the kernel's tick).
        let ts = rustix::event::Timespec { tv_sec: timeout.as_secs().try_into().unwrap_or(i64::MAX), tv_nsec: timeout.subsec_nanos().into() };
        let mut fds = [rustix::event::PollFd::new(&self.socket, rustix::event::PollFlags::IN)];
        match rustix::event::poll(&mut fds, Some(&ts)) {
            Ok(_) | Err(rustix::io::Errno::INTR) => {}
            Err(e) => return Err(e.into()),
        }
        self.try_recv(buf)
    }

    fn datagrams(&self) -> bool {
        true
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let to: &[SocketAddr] = if self.remotes.is_empty() { self.last_sender.as_slice() } else { &self.remotes };
        for addr in to {
            match self.socket.send_to(frame, addr) {
                Ok(_) => {}
                // A peer that is not listening, or a full buffer: the frame is lost, as on a radio.
                Err(e) if matches!(e.kind(), io::ErrorKind::ConnectionRefused | io::ErrorKind::WouldBlock) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }
}

impl Udp {
    /// One datagram if one is waiting (the socket does not block), else 0.
    fn try_recv(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.socket.recv_from(buf) {
            Ok((n, from)) => {
                self.last_sender = Some(from);
                Ok(n)
            }
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => Ok(0),
            // An ICMP "port unreachable" from an earlier send (the peer not up yet): not fatal.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Ok(0),
            Err(e) => Err(e),
        }
    }
}

/// MAVLink over a serial port (8N1, no flow control), e.g. a Raspberry Pi UART wired to PX4
/// `TELEM2` or ArduPilot `SERIAL2`.
pub struct Serial {
    port: Box<dyn serialport::SerialPort>,
}

impl Serial {
    /// Opens `path` at `baud`.
    ///
    /// # Errors
    /// The port cannot be opened or configured.
    pub fn open(path: &str, baud: u32) -> io::Result<Self> {
        let port = serialport::new(path, baud).timeout(Duration::from_millis(1)).open().map_err(io::Error::from)?;
        Ok(Self { port })
    }
}

impl Link for Serial {
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.port.set_timeout(timeout.max(Duration::from_micros(100))).map_err(io::Error::from)?;
        match self.port.read(buf) {
            Ok(n) => Ok(n),
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => Ok(0),
            Err(e) => Err(e),
        }
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        self.port.write_all(frame)
    }
}
