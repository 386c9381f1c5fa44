//! Fuzzes the robot's receive path with arbitrary bytes: the stream reader, COBS, CRC,
//! version, HMAC tag, replay window and postcard body decoding, with and without a key, as a
//! byte stream (serial) and as datagrams (UDP). Checks that it never panics and that every
//! frame it reports is counted exactly once; a frame that decodes must re-encode to a frame
//! that decodes to the same message.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin::link::{Endpoint, FrameReader, Key, MAX_FRAME, encode_frame, parse_frame};

fuzz_target!(|data: &[u8]| {
    let key = Key::new(b"fuzzing key, 32 bytes long .....").unwrap();
    for k in [None, Some(key)] {
        // Stream: one reader over all bytes.
        let mut end = Endpoint::new(k, 1);
        let mut reader = FrameReader::<MAX_FRAME>::new();
        let mut reported = 0u32;
        let mut decoded = Vec::new();
        reader.feed(data, &mut end, |r| {
            reported += 1;
            if let Ok(m) = r {
                decoded.push(m);
            }
        });
        let tail = reader.end_of_datagram(&mut end) as u32;
        let c = *end.counters();
        assert_eq!(c.ok + c.dropped(), reported + tail);
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
        // Datagrams: the same bytes split at every 0x00-free run of 64 bytes.
        let mut end = Endpoint::new(k, 1);
        for chunk in data.chunks(64) {
            reader.feed(chunk, &mut end, |_| {});
            reader.end_of_datagram(&mut end);
        }
        // The stateless decoder on the raw input.
        let mut copy = data.to_vec();
        let _ = parse_frame(&mut copy, k.as_ref());
    }
});
