//! The console's front door: one thread per listening socket reads the request heads of many
//! connections at once, so a connection that has not yet sent a complete head costs a file
//! descriptor and at most [`MAX_HEAD`](super::http::MAX_HEAD) bytes, never a thread or a worker
//! slot (issue 30, observation 5: 50 slowloris connections held all 16 HTTP and 4 Foxglove
//! slots for the 5 s head timeout of the thread-per-connection design).
//!
//! A [`HeadGate`] owns a non-blocking listener and its unfinished connections ("pending"), all
//! registered with one [`mio::Poll`]. Each [`HeadGate::turn`] accepts, reads what arrived and hands
//! every complete head to the caller with its socket; the caller applies the access rules and
//! only then gives it a worker. The rules for pending connections:
//! - a complete head within [`HEAD_TIMEOUT`] of the accept, else `408` and closed (nginx's
//!   `client_header_timeout`, Apache `mod_reqtimeout`'s `header=`; no extension for data
//!   received, as `MinRate` would give, because a head is at most 8 KiB: one or two segments);
//! - at most [`MAX_PENDING_PER_ADDRESS`] from one address (nginx's `limit_conn` per
//!   `$binary_remote_addr`, but applied to unfinished heads only; an IPv6 address counts by
//!   its /64 prefix, the block one host is given): one more from that address closes that
//!   address's oldest, so one address cannot evict another's connections;
//! - at most [`MAX_PENDING`] in all: one more closes the oldest pending connection.
//!
//! A client with the page's URL sends its head at once, so its connection is the newest in the
//! pool and completes before it could become the oldest, also when it shares its address with
//! an attacker (loopback: the console's default).

use std::collections::HashMap;
use std::io::{ErrorKind, Read};
use std::net::{IpAddr, SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

use mio::net::{TcpListener as MioListener, TcpStream as MioStream};
use mio::{Events, Interest, Poll, Token};

use super::http;

/// How long a client may take to send its request head, from the accept.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(2);
/// Most connections without a complete head, per listener.
pub const MAX_PENDING: usize = 128;
/// Most connections without a complete head from one address ([`address_key`]), per listener.
pub const MAX_PENDING_PER_ADDRESS: usize = 32;

/// The listener's token; pending connections count up from 0.
const LISTENER: Token = Token(usize::MAX);

/// A connection whose head is complete, for the access rules.
pub struct Head {
    /// The socket, still non-blocking (answers written at once are best effort; a worker
    /// sets it blocking with its timeouts).
    pub stream: TcpStream,
    /// The request head, through its blank line.
    pub head: Vec<u8>,
    /// Bytes that came after the head (the start of a websocket stream).
    pub rest: Vec<u8>,
}

/// A connection still sending its head.
struct Pending {
    stream: MioStream,
    /// The peer's [`address_key`].
    from: u128,
    since: Instant,
    buf: Vec<u8>,
}

/// A listener and the connections it has accepted that have not sent a complete head.
pub struct HeadGate {
    poll: Poll,
    events: Events,
    listener: MioListener,
    pending: HashMap<usize, Pending>,
    next: usize,
    evicted: u64,
    /// An accept failed for another reason than an empty backlog (out of descriptors): try
    /// again next turn, as the edge-triggered listener may not report the waiting ones again.
    retry_accept: bool,
}

impl HeadGate {
    /// Takes a bound listener (made non-blocking here).
    pub fn new(listener: TcpListener) -> std::io::Result<Self> {
        listener.set_nonblocking(true)?;
        let mut listener = MioListener::from_std(listener);
        let poll = Poll::new()?;
        poll.registry()
            .register(&mut listener, LISTENER, Interest::READABLE)?;
        Ok(HeadGate {
            poll,
            events: Events::with_capacity(256),
            listener,
            pending: HashMap::new(),
            next: 0,
            evicted: 0,
            retry_accept: false,
        })
    }

    /// Connections without a complete head right now.
    #[cfg(test)]
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Connections closed so far to make room for newer ones.
    pub fn evicted(&self) -> u64 {
        self.evicted
    }

    /// Waits at most `wait` (less when a head's deadline comes first) for connections and
    /// bytes, then hands each complete head to `on_head` and closes the connections whose
    /// time is up. Only the poll itself failing is an error.
    pub fn turn(&mut self, wait: Duration, on_head: &mut impl FnMut(Head)) -> std::io::Result<()> {
        let now = Instant::now();
        let wait = self
            .pending
            .values()
            .map(|p| (p.since + HEAD_TIMEOUT).saturating_duration_since(now))
            .min()
            .map_or(wait, |d| d.min(wait));
        match self.poll.poll(&mut self.events, Some(wait)) {
            Ok(()) => {}
            Err(e) if e.kind() == ErrorKind::Interrupted => return Ok(()),
            Err(e) => return Err(e),
        }
        let mut ready: Vec<Token> = self.events.iter().map(|e| e.token()).collect();
        if std::mem::take(&mut self.retry_accept) && !ready.contains(&LISTENER) {
            ready.push(LISTENER);
        }
        for t in ready {
            if t == LISTENER {
                self.accept_all(on_head);
            } else {
                self.read(t.0, on_head);
            }
        }
        self.expire();
        Ok(())
    }

    /// Accepts every waiting connection (the listener is edge-triggered).
    fn accept_all(&mut self, on_head: &mut impl FnMut(Head)) {
        loop {
            match self.listener.accept() {
                Ok((stream, peer)) => self.admit(stream, peer, on_head),
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) if e.kind() == ErrorKind::WouldBlock => return,
                Err(_) => {
                    self.retry_accept = true;
                    return;
                }
            }
        }
    }

    /// Makes room for a new connection, then reads what it has already sent.
    fn admit(&mut self, mut stream: MioStream, peer: SocketAddr, on_head: &mut impl FnMut(Head)) {
        let from = address_key(peer.ip());
        if self.pending.values().filter(|p| p.from == from).count() >= MAX_PENDING_PER_ADDRESS {
            self.evict_oldest(|p| p.from == from);
        } else if self.pending.len() >= MAX_PENDING {
            self.evict_oldest(|_| true);
        }
        let id = self.next;
        self.next += 1;
        if self
            .poll
            .registry()
            .register(&mut stream, Token(id), Interest::READABLE)
            .is_err()
        {
            return;
        }
        self.pending.insert(
            id,
            Pending {
                stream,
                from,
                since: Instant::now(),
                buf: Vec::new(),
            },
        );
        self.read(id, on_head);
    }

    /// Closes the oldest pending connection among those `which` selects, with a `503`.
    fn evict_oldest(&mut self, which: impl Fn(&Pending) -> bool) {
        // Ids count up in the order of the accepts: the smallest is the oldest.
        let oldest = self
            .pending
            .iter()
            .filter(|(_, p)| which(p))
            .map(|(id, _)| *id)
            .min();
        if let Some(p) = oldest.and_then(|id| self.close(id)) {
            self.evicted += 1;
            answer(
                p.stream,
                503,
                "the console is busy: request head too slow\n",
            );
        }
    }

    /// Reads everything connection `id` has sent; a complete head goes to `on_head`.
    fn read(&mut self, id: usize, on_head: &mut impl FnMut(Head)) {
        let Some(p) = self.pending.get_mut(&id) else {
            return;
        };
        let mut chunk = [0u8; 2048];
        let outcome = loop {
            let searched = p.buf.len();
            match p.stream.read(&mut chunk) {
                Ok(0) => break Err(None),
                Ok(n) => p.buf.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == ErrorKind::WouldBlock => return,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(_) => break Err(None),
            }
            match http::head_end(&p.buf, searched) {
                Ok(Some(end)) => break Ok(end),
                Ok(None) => {}
                Err(http::TooLarge) => break Err(Some(431)),
            }
        };
        let Some(mut p) = self.close(id) else {
            return;
        };
        match outcome {
            Ok(end) => {
                let rest = p.buf.split_off(end);
                on_head(Head {
                    stream: p.stream.into(),
                    head: p.buf,
                    rest,
                });
            }
            Err(Some(status)) => answer(p.stream, status, "request head too large\n"),
            Err(None) => {}
        }
    }

    /// Closes, with a `408`, every connection whose head is overdue.
    fn expire(&mut self) {
        let now = Instant::now();
        let late: Vec<usize> = self
            .pending
            .iter()
            .filter(|(_, p)| now >= p.since + HEAD_TIMEOUT)
            .map(|(id, _)| *id)
            .collect();
        for id in late {
            if let Some(p) = self.close(id) {
                answer(p.stream, 408, "request head timed out\n");
            }
        }
    }

    /// Takes connection `id` out of the pool and the poll.
    fn close(&mut self, id: usize) -> Option<Pending> {
        let mut p = self.pending.remove(&id)?;
        let _ = self.poll.registry().deregister(&mut p.stream);
        Some(p)
    }
}

/// What the per-address cap counts by: an IPv4 address (also written IPv4-mapped in IPv6),
/// or the /64 prefix of an IPv6 address (a host may use any address of its /64). IPv4 keys are
/// below 2^32 and IPv6 keys have their low 64 bits zero: they meet only at `0.0.0.0` and the
/// zero prefix, `::/64`, whose one possible peer is `::1` (loopback).
pub fn address_key(ip: IpAddr) -> u128 {
    match ip {
        IpAddr::V4(v4) => u128::from(u32::from(v4)),
        IpAddr::V6(v6) => match v6.to_ipv4_mapped() {
            Some(v4) => u128::from(u32::from(v4)),
            None => u128::from(v6) & !u128::from(u64::MAX),
        },
    }
}

/// A best-effort answer on a non-blocking socket (a short response fits any send buffer; if
/// it does not, the connection is closed without it), then the close.
fn answer(mut stream: MioStream, status: u16, why: &str) {
    let _ = http::respond(&mut stream, status, "text/plain", why.as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn gate() -> (HeadGate, SocketAddr) {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let at = l.local_addr().unwrap();
        (HeadGate::new(l).unwrap(), at)
    }

    /// Turns the gate until `done` holds or 5 s pass; the heads it handed over.
    fn turn_until(g: &mut HeadGate, done: impl Fn(&HeadGate, &[Head]) -> bool) -> Vec<Head> {
        let mut heads = Vec::new();
        let end = Instant::now() + Duration::from_secs(5);
        while !done(g, &heads) && Instant::now() < end {
            g.turn(Duration::from_millis(20), &mut |h| heads.push(h))
                .unwrap();
        }
        heads
    }

    #[test]
    fn addresses_count_by_host_and_ipv6_by_its_64_prefix() {
        let k = |s: &str| address_key(s.parse().unwrap());
        assert_eq!(k("192.0.2.7"), k("::ffff:192.0.2.7"));
        assert_ne!(k("192.0.2.7"), k("192.0.2.8"));
        assert_eq!(k("2001:db8:1:2::1"), k("2001:db8:1:2:ffff:ffff:ffff:ffff"));
        assert_ne!(k("2001:db8:1:2::1"), k("2001:db8:1:3::1"));
        // An IPv6 prefix never collides with an IPv4 host.
        assert_ne!(k("::"), k("0.0.0.1"));
        assert_ne!(k("::1"), k("127.0.0.1"));
    }

    #[test]
    fn a_head_sent_in_pieces_is_handed_over_with_what_follows() {
        let (mut g, at) = gate();
        let mut c = TcpStream::connect(at).unwrap();
        c.write_all(b"GET /?token=x HTTP/1.1\r\nHo").unwrap();
        turn_until(&mut g, |g, _| g.pending() == 1);
        c.write_all(b"st: a\r\n\r\nafter").unwrap();
        let heads = turn_until(&mut g, |_, h| !h.is_empty());
        assert_eq!(heads.len(), 1);
        assert_eq!(heads[0].head, b"GET /?token=x HTTP/1.1\r\nHost: a\r\n\r\n");
        assert_eq!(heads[0].rest, b"after");
        assert_eq!(g.pending(), 0);
    }

    #[test]
    fn one_address_holds_at_most_its_share_and_the_newest_gets_in() {
        let (mut g, at) = gate();
        let slow: Vec<TcpStream> = (0..MAX_PENDING_PER_ADDRESS + 8)
            .map(|_| {
                let mut c = TcpStream::connect(at).unwrap();
                c.write_all(b"GET / HTTP/1.1\r\n").unwrap();
                c
            })
            .collect();
        turn_until(&mut g, |g, _| g.evicted() == 8);
        assert_eq!(g.evicted(), 8);
        assert_eq!(g.pending(), MAX_PENDING_PER_ADDRESS);
        // The first ones were closed with a 503, the newest are still waiting.
        let mut first = &slow[0];
        first
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        let mut r = String::new();
        let _ = first.read_to_string(&mut r);
        assert!(r.starts_with("HTTP/1.1 503"), "{r}");
        // A complete head from the same address still gets through.
        let mut c = TcpStream::connect(at).unwrap();
        c.write_all(b"GET / HTTP/1.1\r\n\r\n").unwrap();
        let heads = turn_until(&mut g, |_, h| !h.is_empty());
        assert_eq!(heads.len(), 1);
        assert!(g.pending() <= MAX_PENDING_PER_ADDRESS);
    }

    #[test]
    fn too_large_and_overdue_heads_are_answered_and_closed() {
        let (mut g, at) = gate();
        let mut big = TcpStream::connect(at).unwrap();
        // Exactly the bound: the gate reads it all, so its close does not reset the answer.
        big.write_all(&vec![b'a'; http::MAX_HEAD]).unwrap();
        let mut idle = TcpStream::connect(at).unwrap();
        idle.write_all(b"GET / HTTP/1.1\r\n").unwrap();
        let start = Instant::now();
        let heads = turn_until(&mut g, |g, _| {
            g.pending() == 0 && start.elapsed() > Duration::from_millis(100)
        });
        assert!(heads.is_empty());
        assert!(
            start.elapsed() >= HEAD_TIMEOUT,
            "the idle one waited its time"
        );
        for (mut c, status) in [(big, "431"), (idle, "408")] {
            c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            let mut r = Vec::new();
            let _ = c.read_to_end(&mut r);
            let r = String::from_utf8_lossy(&r);
            assert!(r.starts_with(&format!("HTTP/1.1 {status}")), "{r}");
        }
    }
}
