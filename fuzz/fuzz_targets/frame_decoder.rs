//! Fuzzes both ends' receive paths with arbitrary bytes: the stream reader, COBS, CRC,
//! version, kind, tag, session lookup, replay window, handshake and postcard body decoding,
//! with and without a key, as a byte stream (serial) and as datagrams (UDP). Checks that it
//! never panics and never allocates, that every frame it reports is counted exactly once, and
//! that a message that decodes re-encodes to a frame that decodes to the same bytes. Random
//! bytes rarely pass the CRC: the seeds (valid frames of every kind) and `link_session` (which
//! fixes the CRC and the MAC up) go past it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin::link::{
    FrameReader, Key, MAX_FRAME, OperatorLink, PROTOCOL_VERSION, RobotEvent, RobotInfo, RobotKind,
    RobotLink, decode_message, encode_message, parse_frame, v1,
};
use omnikin::runtime::hal::{Entropy, EntropyError};
use omnikin_fuzz::alloc::{Counting, measure};
use omnikin_fuzz::link::FUZZ_KEY;

#[global_allocator]
static ALLOC: Counting = Counting;

struct Fixed;
impl Entropy for Fixed {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
        buf.fill(0x5a);
        Ok(())
    }
}

const INFO: RobotInfo = RobotInfo {
    protocol: PROTOCOL_VERSION,
    kind: RobotKind::Sphere,
    plan_capacity: 256,
    rate_hz: 100.0,
    watchdog: 0.5,
    authenticated: false,
};

fuzz_target!(|data: &[u8]| {
    let key = Key::new(FUZZ_KEY).unwrap();
    for k in [None, Some(key)] {
        // Stream: one reader over all bytes, into both ends.
        let mut robot = RobotLink::new(k.clone());
        let mut op = OperatorLink::new(k.clone());
        let mut reader = FrameReader::<MAX_FRAME>::new();
        let mut reported = 0u32;
        // Room for every frame the input can hold, so that collecting does not allocate.
        let mut decoded = Vec::with_capacity(data.len() + 1);
        let mut reply = [0u8; MAX_FRAME];
        let mut copy = [0u8; MAX_FRAME];
        let ((), usage) = measure(|| {
            reader.feed(data, |f| {
                reported += 1;
                match f {
                    Some(f) => {
                        let n = f.len();
                        copy[..n].copy_from_slice(f);
                        if let Ok(RobotEvent::Message { seq, msg, .. }) =
                            robot.receive(f, &INFO, &mut Fixed, &mut reply)
                        {
                            decoded.push((seq, msg));
                        }
                        let _ = op.receive(&mut copy[..n]);
                    }
                    None => {
                        robot.count_framing_drop();
                        op.count_framing_drop();
                    }
                }
            });
            if reader.end_of_datagram() {
                reported += 1;
                robot.count_framing_drop();
                op.count_framing_drop();
            }
        });
        assert_eq!(usage.allocations, 0, "a receive path allocated");
        for c in [*robot.counters(), *op.counters()] {
            assert_eq!(c.ok + c.dropped(), reported);
        }
        // Whatever decoded round-trips.
        for (seq, msg) in decoded {
            let mut buf = [0u8; MAX_FRAME];
            let mac = k.as_ref().map(Key::mac);
            let n =
                encode_message(1, seq, &msg, mac, &mut buf).expect("a decoded message re-encodes");
            let first = buf;
            let p = parse_frame(&mut buf[..n - 1]).expect("and parses again");
            assert!(p.verify(mac).is_ok());
            let m2 = decode_message(p.body).expect("and decodes again");
            // NaN payloads compare unequal; compare the encodings instead.
            let mut again = [0u8; MAX_FRAME];
            let n2 = encode_message(1, seq, &m2, mac, &mut again).unwrap();
            assert_eq!(&first[..n], &again[..n2]);
        }
        // Datagrams: the same bytes cut every 64 bytes; each cut frame is one framing drop.
        let mut robot = RobotLink::new(k.clone());
        let mut reported = 0u32;
        for chunk in data.chunks(64) {
            reader.feed(chunk, |f| {
                reported += 1;
                match f {
                    Some(f) => {
                        let _ = robot.receive(f, &INFO, &mut Fixed, &mut reply);
                    }
                    None => robot.count_framing_drop(),
                }
            });
            if reader.end_of_datagram() {
                reported += 1;
                robot.count_framing_drop();
            }
        }
        let c = *robot.counters();
        assert_eq!(c.ok + c.dropped(), reported);
        // The stateless decoders on the raw input.
        let mut copy = data.to_vec();
        let _ = parse_frame(&mut copy);
        let mut copy = data.to_vec();
        let _ = v1::parse(&mut copy, k.as_ref());
    }
});
