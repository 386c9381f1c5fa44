//! Fuzzes both ends' receive paths with arbitrary bytes: the stream reader, COBS, CRC,
//! version, kind, an open frame's opening, tag, session lookup, replay window, handshake and
//! postcard body decoding, with and without a key, as a byte stream (serial) and as datagrams
//! (UDP), the robot's clock advancing 1 ms per frame. Checks that it never panics and never
//! allocates, that every frame it reports is counted exactly once, that `peek_kind` names the
//! kind of every frame `parse_frame` accepts (and nothing it rejects as not v3), that
//! `parse_frame` returns an opening exactly for open frames and that an open frame re-encodes
//! (`encode_open`) to a frame that parses to the same opening, and that a message that decodes
//! re-encodes to a frame that decodes to the same bytes. Random bytes rarely pass the CRC: the
//! seeds (valid frames of every kind) and `link_session` (which fixes the CRC and the MAC up)
//! go past it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin::link::{
    FrameKind, FrameReader, Key, MAX_FRAME, OperatorLink, PROTOCOL_VERSION, RobotEvent, RobotInfo,
    RobotKind, RobotLink, decode_message, encode_message, encode_open, parse_frame, peek_kind, v1,
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

/// Robot time between two frames, µs.
const FRAME_US: u64 = 1_000;

/// What `peek_kind` and `parse_frame` say of one frame (still COBS-encoded, without its
/// delimiter) must agree: a frame that parses was visibly of its kind; an open frame, and only
/// one, has an opening, and it survives re-encoding. No allocation.
fn check_parse(frame: &[u8], mac: Option<&omnikin::link::MacKey>) {
    let peeked = peek_kind(frame);
    let mut copy = [0u8; MAX_FRAME];
    let Some(copy) = copy.get_mut(..frame.len()) else {
        return;
    };
    copy.copy_from_slice(frame);
    let Ok(p) = parse_frame(copy) else {
        return;
    };
    assert_eq!(
        peeked,
        Some(p.header.kind),
        "peek_kind of a frame that parses"
    );
    assert_eq!(
        p.opening.is_some(),
        p.header.kind == FrameKind::Open,
        "opening of {p:?}"
    );
    if let (Some(o), Ok(m)) = (p.opening, decode_message(p.body)) {
        let mut buf = [0u8; MAX_FRAME];
        let n = encode_open(p.header.session, p.header.seq, &o, &m, mac, &mut buf)
            .expect("a decoded open frame re-encodes");
        assert_eq!(peek_kind(&buf[..n - 1]), Some(FrameKind::Open));
        let q = parse_frame(&mut buf[..n - 1]).expect("and parses again");
        assert_eq!(q.opening, Some(o));
        assert_eq!(
            (q.header.session, q.header.seq),
            (p.header.session, p.header.seq)
        );
        assert!(q.verify(mac).is_ok());
    }
}

const INFO: RobotInfo = RobotInfo {
    protocol: PROTOCOL_VERSION,
    kind: RobotKind::Sphere,
    plan_capacity: 256,
    rate_hz: 100.0,
    watchdog: 0.5,
    authenticated: false,
    limits: omnikin::link::RobotLimits {
        max_accel: 1.0,
        max_yaw_accel: 4.0,
        max_jerk: f32::INFINITY,
    },
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
        let mut now = 0u64;
        let mac = k.as_ref().map(Key::mac);
        let ((), usage) = measure(|| {
            reader.feed(data, |f| {
                reported += 1;
                now += FRAME_US;
                match f {
                    Some(f) => {
                        let n = f.len();
                        copy[..n].copy_from_slice(f);
                        check_parse(f, mac);
                        if let Ok(RobotEvent::Message { seq, msg, .. }) =
                            robot.receive(f, now, &[], &INFO, &mut Fixed, &mut reply)
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
        let mut now = 0u64;
        for chunk in data.chunks(64) {
            reader.feed(chunk, |f| {
                reported += 1;
                now += FRAME_US;
                match f {
                    Some(f) => {
                        let _ = robot.receive(f, now, &[], &INFO, &mut Fixed, &mut reply);
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
        check_parse(data, k.as_ref().map(Key::mac));
        let mut copy = data.to_vec();
        let _ = parse_frame(&mut copy);
        let mut copy = data.to_vec();
        let _ = v1::parse(&mut copy, k.as_ref());
    }
});
