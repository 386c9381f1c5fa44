//! Fuzzes the framing layer with raw bytes: the robot's receive path — `FrameReader` (stream
//! and datagram modes), COBS, CRC-32C, version, HMAC tag, replay window and the postcard body —
//! with and without a key. Checks that it never panics and never allocates, that every frame
//! it reports is counted in exactly one counter, and that a frame that decodes re-encodes to a
//! frame that decodes to the same message. Random bytes rarely pass the CRC: the seeds (valid
//! frames of every message type) and `link_session` (which fixes the CRC and MAC up) go past it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin::link::{Endpoint, FrameReader, Key, MAX_FRAME, encode_frame, parse_frame};
use omnikin_fuzz::alloc::{Counting, measure};
use omnikin_fuzz::link::FUZZ_KEY;

#[global_allocator]
static ALLOC: Counting = Counting;

fuzz_target!(|data: &[u8]| {
    let key = Key::new(FUZZ_KEY).unwrap();
    for k in [None, Some(key)] {
        // Stream: one reader over all bytes.
        let mut end = Endpoint::new(k, 1);
        let mut reader = FrameReader::<MAX_FRAME>::new();
        let mut reported = 0u32;
        // Room for every frame the input can hold, so that collecting does not allocate.
        let mut decoded = Vec::with_capacity(data.len() + 1);
        let (tail, usage) = measure(|| {
            reader.feed(data, &mut end, |r| {
                reported += 1;
                if let Ok(m) = r {
                    decoded.push(m);
                }
            });
            reader.end_of_datagram(&mut end) as u32
        });
        assert_eq!(usage.allocations, 0, "the receive path allocated");
        let c = *end.counters();
        assert_eq!(c.ok + c.dropped(), reported + tail);
        assert_eq!(c.ok as usize, decoded.len());
        // Whatever decoded round-trips.
        for (seq, msg) in decoded {
            let mut buf = [0u8; MAX_FRAME];
            let n = encode_frame(&msg, seq, k.as_ref(), &mut buf)
                .expect("a decoded message re-encodes");
            let first = buf;
            let (s2, m2) = parse_frame(&mut buf[..n - 1], k.as_ref()).expect("and decodes again");
            assert_eq!(s2, seq);
            // NaN payloads compare unequal; compare the encodings instead.
            let mut again = [0u8; MAX_FRAME];
            let n2 = encode_frame(&m2, s2, k.as_ref(), &mut again).unwrap();
            assert_eq!(&first[..n], &again[..n2]);
        }
        // Datagrams: the same bytes cut every 64 bytes; each cut frame is one framing drop.
        let mut end = Endpoint::new(k, 1);
        let mut reported = 0u32;
        let mut tails = 0u32;
        for chunk in data.chunks(64) {
            reader.feed(chunk, &mut end, |_| reported += 1);
            tails += reader.end_of_datagram(&mut end) as u32;
        }
        let c = *end.counters();
        assert_eq!(c.ok + c.dropped(), reported + tails);
        // The stateless decoder on the raw input.
        let mut copy = data.to_vec();
        let _ = parse_frame(&mut copy, k.as_ref());
    }
});
