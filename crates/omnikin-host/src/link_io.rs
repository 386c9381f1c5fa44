//! Host side of the operator link: transports (UDP, serial port), key files, and the framing
//! loop shared by `omnikin robot` and `omnikin drive`.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::path::Path;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use omnikin::link::{FrameReader, Key, MAX_FRAME};
use omnikin::runtime::hal::{Entropy, EntropyError};

/// Where a link goes: `HOST:PORT` or `udp:HOST:PORT` (UDP), `serial:PATH[@BAUD]` (serial port,
/// default 115200 baud).
#[derive(Clone, Debug, PartialEq)]
pub enum Address {
    /// UDP socket address.
    Udp(SocketAddr),
    /// Serial device and baud rate.
    Serial(String, u32),
}

/// Parses an address (see [`Address`]); `what` names the flag in errors.
pub fn parse_address(s: &str, what: &str) -> Result<Address> {
    if let Some(rest) = s.strip_prefix("serial:") {
        let (path, baud) = match rest.rsplit_once('@') {
            Some((p, b)) => (
                p,
                b.parse::<u32>().ok().filter(|b| *b > 0).with_context(|| {
                    format!("{what}: baud rate must be a positive integer, got \"{b}\"")
                })?,
            ),
            None => (rest, 115_200),
        };
        if path.is_empty() {
            bail!("{what}: serial address needs a device path, e.g. serial:/dev/ttyUSB0@115200");
        }
        return Ok(Address::Serial(path.to_string(), baud));
    }
    let udp = s.strip_prefix("udp:").unwrap_or(s);
    let addr: SocketAddr = udp.parse().with_context(|| {
        format!("{what}: expected HOST:PORT (e.g. 127.0.0.1:7000), udp:HOST:PORT or serial:PATH[@BAUD], got \"{s}\"")
    })?;
    Ok(Address::Udp(addr))
}

/// Most bytes of a key file read (64 key bytes and any trailing whitespace).
const MAX_KEY_FILE: usize = 4096;

/// Reads a shared key file: its bytes with trailing whitespace removed, 16 to 64 bytes.
/// `what` names the option in errors (`--key`, or Python's `key`).
pub fn load_key(path: &Path, what: &str) -> Result<Key> {
    // A key is at most 64 bytes: read a little more than that, never the whole file (a
    // `--key /dev/zero` grew to 2 GB before failing "out of memory").
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_KEY_FILE as u64 + 1).read_to_end(&mut bytes))
        .with_context(|| format!("{what} {}: cannot read", path.display()))?;
    if bytes.len() > MAX_KEY_FILE {
        bail!(
            "{what} {}: key must be 16 to 64 bytes (after trailing whitespace), the file has more than {MAX_KEY_FILE} bytes",
            path.display()
        );
    }
    let mut end = bytes.len();
    while end > 0 && bytes[end - 1].is_ascii_whitespace() {
        end -= 1;
    }
    let k = &bytes[..end];
    if k.len() < 16 || k.len() > 64 {
        bail!(
            "{what} {}: key must be 16 to 64 bytes (after trailing whitespace), got {}",
            path.display(),
            k.len()
        );
    }
    Ok(Key::new(k)?)
}

/// A byte transport: UDP datagrams (one or more frames each) or a serial byte stream.
pub enum Transport {
    /// UDP: a socket and the peer to send to (the robot learns its peer from valid frames).
    Udp {
        /// The socket (non-blocking reads with a timeout).
        socket: UdpSocket,
        /// Where to send.
        peer: Option<SocketAddr>,
    },
    /// A serial port.
    Serial(Box<dyn serialport::SerialPort>),
}

/// Most UDP datagrams one [`Transport::recv`] takes (a robot's control cycle at 100 Hz then
/// reads up to 409 600 datagrams a second, far above any flood its CPU could answer).
pub const MAX_DATAGRAMS_PER_POLL: usize = 4096;

/// Received bytes: where from (UDP) and whether they end a datagram.
pub struct Chunk {
    /// Sender (UDP only).
    pub from: Option<SocketAddr>,
    /// The bytes.
    pub bytes: Vec<u8>,
    /// `true` for a UDP datagram (frames cannot continue past its end).
    pub datagram: bool,
}

impl Transport {
    /// Binds (`listen`) or connects to an address (`what` names it in errors: `--listen`).
    pub fn open(addr: &Address, listen: bool, what: &str) -> Result<Self> {
        match addr {
            Address::Udp(a) => {
                let socket = if listen {
                    UdpSocket::bind(a).with_context(|| format!("{what} {a}: cannot bind"))?
                } else {
                    let local: SocketAddr = if a.is_ipv4() {
                        "0.0.0.0:0".parse()?
                    } else {
                        "[::]:0".parse()?
                    };
                    UdpSocket::bind(local).context("cannot open a UDP socket")?
                };
                Ok(Transport::Udp {
                    socket,
                    peer: (!listen).then_some(*a),
                })
            }
            Address::Serial(path, baud) => {
                let port = serialport::new(path, *baud)
                    .timeout(Duration::from_millis(1))
                    .open()
                    .with_context(|| format!("{what} serial port {path}: cannot open"))?;
                Ok(Transport::Serial(port))
            }
        }
    }

    /// Sends one encoded frame (to the peer for UDP; nothing if no peer is known yet).
    pub fn send(&mut self, frame: &[u8]) -> Result<()> {
        let to = match self {
            Transport::Udp { peer, .. } => *peer,
            Transport::Serial(_) => None,
        };
        self.send_to(frame, to)
    }

    /// Sends one encoded frame to `to` (UDP; nothing when `None`) or down the serial line.
    pub fn send_to(&mut self, frame: &[u8], to: Option<SocketAddr>) -> Result<()> {
        match self {
            Transport::Udp { socket, .. } => {
                if let Some(p) = to {
                    // A full socket buffer or an unreachable peer is a lost frame, as on radio.
                    let _ = socket.send_to(frame, p);
                }
                Ok(())
            }
            Transport::Serial(port) => match port.write_all(frame) {
                // Nobody draining the line (a full output buffer): the frame is lost, as
                // on a radio link; the receiver resynchronises at the next delimiter.
                Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) => Ok(()),
                r => r.context("serial write"),
            },
        }
    }

    /// Waits up to `timeout` for the first bytes, then takes whatever else is pending (UDP: at
    /// most [`MAX_DATAGRAMS_PER_POLL`] datagrams, so that a flood cannot hold a control loop
    /// in its receive step; the rest waits for the next call).
    pub fn recv(&mut self, timeout: Duration) -> Result<Vec<Chunk>> {
        let mut out = vec![];
        let mut buf = [0u8; 4096];
        match self {
            Transport::Udp { socket, .. } => {
                // Zero means "only what is pending": a 1 µs socket timeout would round up to
                // a kernel tick (several ms).
                let mut wait = (!timeout.is_zero()).then_some(timeout);
                loop {
                    match wait {
                        Some(t) => {
                            socket.set_nonblocking(false)?;
                            socket.set_read_timeout(Some(t))?;
                        }
                        None => socket.set_nonblocking(true)?,
                    }
                    match socket.recv_from(&mut buf) {
                        Ok((n, from)) => {
                            out.push(Chunk {
                                from: Some(from),
                                bytes: buf[..n].to_vec(),
                                datagram: true,
                            });
                            wait = None;
                            if out.len() >= MAX_DATAGRAMS_PER_POLL {
                                break;
                            }
                        }
                        Err(e)
                            if matches!(
                                e.kind(),
                                ErrorKind::WouldBlock
                                    | ErrorKind::TimedOut
                                    | ErrorKind::ConnectionRefused
                            ) =>
                        {
                            if e.kind() == ErrorKind::ConnectionRefused && wait.is_some() {
                                continue;
                            }
                            break;
                        }
                        Err(e) => return Err(e).context("UDP receive"),
                    }
                }
            }
            Transport::Serial(port) => {
                port.set_timeout(timeout.max(Duration::from_millis(1)))?;
                loop {
                    match port.read(&mut buf) {
                        Ok(0) => break,
                        Ok(n) => {
                            out.push(Chunk {
                                from: None,
                                bytes: buf[..n].to_vec(),
                                datagram: false,
                            });
                            port.set_timeout(Duration::from_millis(0))?;
                        }
                        Err(e)
                            if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) =>
                        {
                            break;
                        }
                        Err(e) => return Err(e).context("serial read"),
                    }
                }
            }
        }
        Ok(out)
    }
}

/// Frame splitting on top of a transport (decoding is each end's: `RobotLink`/`OperatorLink`).
pub struct Link {
    /// The transport.
    pub transport: Transport,
    reader: FrameReader<MAX_FRAME>,
}

/// One frame's bytes (without the delimiter), with its sender.
pub struct RawFrame {
    /// Sender (UDP).
    pub from: Option<SocketAddr>,
    /// The bytes, or `None` for a frame dropped by the reader (too long, or cut off at the end
    /// of a datagram): count it as a framing drop.
    pub bytes: Option<Vec<u8>>,
}

impl Link {
    /// A link over `transport`.
    pub fn new(transport: Transport) -> Self {
        Self {
            transport,
            reader: FrameReader::new(),
        }
    }

    /// Receives for up to `timeout` and splits every complete frame.
    pub fn poll(&mut self, timeout: Duration) -> Result<Vec<RawFrame>> {
        let mut out = vec![];
        for chunk in self.transport.recv(timeout)? {
            let from = chunk.from;
            self.reader.feed(&chunk.bytes, |f| {
                out.push(RawFrame {
                    from,
                    bytes: f.map(|f| f.to_vec()),
                })
            });
            if chunk.datagram && self.reader.end_of_datagram() {
                out.push(RawFrame { from, bytes: None });
            }
        }
        Ok(out)
    }
}

/// A sender's transport address as the bytes the robot's link binds its handshake answer to
/// (`RobotLink::receive`'s `peer`): IPv4 or IPv6 address then port, big-endian; none for a
/// serial port (point to point). Returns the buffer and the used length.
pub fn peer_bytes(from: Option<SocketAddr>) -> ([u8; 18], usize) {
    let mut b = [0u8; 18];
    let n = match from {
        Some(SocketAddr::V4(a)) => {
            b[..4].copy_from_slice(&a.ip().octets());
            b[4..6].copy_from_slice(&a.port().to_be_bytes());
            6
        }
        Some(SocketAddr::V6(a)) => {
            b[..16].copy_from_slice(&a.ip().octets());
            b[16..18].copy_from_slice(&a.port().to_be_bytes());
            18
        }
        None => 0,
    };
    (b, n)
}

/// The operating system's random bytes (`getrandom`): the host's handshake nonces.
pub struct OsEntropy;

impl Entropy for OsEntropy {
    fn fill(&mut self, buf: &mut [u8]) -> std::result::Result<(), EntropyError> {
        getrandom::fill(buf).map_err(|_| EntropyError)
    }
}

/// Microseconds since the Unix epoch (plan ids; the sequence number of the v1 probe, which a
/// v1 robot's replay window needs above anything it saw before).
pub fn epoch_seq() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(1)
        .max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses() {
        assert_eq!(
            parse_address("127.0.0.1:7000", "--connect").unwrap(),
            Address::Udp("127.0.0.1:7000".parse().unwrap())
        );
        assert_eq!(
            parse_address("udp:127.0.0.1:7000", "--connect").unwrap(),
            Address::Udp("127.0.0.1:7000".parse().unwrap())
        );
        assert_eq!(
            parse_address("serial:/dev/ttyUSB0@57600", "--connect").unwrap(),
            Address::Serial("/dev/ttyUSB0".into(), 57600)
        );
        assert_eq!(
            parse_address("serial:/dev/ttyACM0", "--connect").unwrap(),
            Address::Serial("/dev/ttyACM0".into(), 115_200)
        );
        let e = parse_address("localhost", "--connect")
            .unwrap_err()
            .to_string();
        assert!(e.contains("--connect") && e.contains("HOST:PORT"), "{e}");
        let e = parse_address("serial:/dev/x@fast", "--listen")
            .unwrap_err()
            .to_string();
        assert!(e.contains("--listen") && e.contains("baud"), "{e}");
    }
}
