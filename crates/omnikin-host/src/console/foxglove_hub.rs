//! The console's Foxglove stream ([`FoxHub`]): the relay publishes the telemetry as the MCAP
//! files' JSON messages on their channels, each connected Foxglove client reads it from its own
//! cursor; and the `foxglove.websocket.v1` protocol's pieces that are not HTTP (the channel
//! advertisement, `messageData` frames, subscriptions). The WebSocket server is the front
//! end's (`omnikin console --foxglove`).

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex};

use omnikin_io::mcap_log::foxglove::{self as fg, TOPICS, Topic};
use serde::Deserialize;
use serde_json::{Value, json};

/// Messages kept for slow clients (about 2 s of telemetry on all channels).
const RING: usize = 512;

/// The channel id of a topic: its index in [`TOPICS`] plus one.
pub fn channel_id(t: Topic) -> u32 {
    TOPICS
        .iter()
        .position(|x| *x == t)
        .map_or(0, |i| i as u32 + 1)
}

/// One encoded message: channel id, log time (ns), JSON payload.
pub type Entry = (u32, u64, Arc<Vec<u8>>);

/// The stream of encoded messages, shared by the relay (writer) and the clients: the newest
/// sequence number and the last `RING` messages with theirs.
#[derive(Default)]
pub struct FoxHub {
    inner: Mutex<(u64, VecDeque<(u64, Entry)>)>,
}

impl FoxHub {
    /// Publishes one message of `topic` at log time `ns`.
    pub fn publish(&self, topic: Topic, ns: u64, v: &Value) {
        let id = channel_id(topic);
        let data = Arc::new(v.to_string().into_bytes());
        let mut g = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        g.0 += 1;
        let seq = g.0;
        if g.1.len() == RING {
            g.1.pop_front();
        }
        g.1.push_back((seq, (id, ns, data)));
    }

    /// The messages published after `cursor`, and the newest sequence number.
    pub fn since(&self, cursor: u64) -> (Vec<Entry>, u64) {
        let g = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        let out =
            g.1.iter()
                .filter(|(s, _)| *s > cursor)
                .map(|(_, e)| e.clone())
                .collect();
        (out, g.0)
    }

    /// The newest sequence number (a new client starts from it).
    pub fn cursor(&self) -> u64 {
        self.inner.lock().unwrap_or_else(|p| p.into_inner()).0
    }
}

/// The advertisement of every channel.
pub fn advertise() -> Value {
    let channels: Vec<Value> = TOPICS
        .iter()
        .map(|t| {
            json!({"id": channel_id(*t), "topic": t.name, "encoding": fg::MESSAGE_ENCODING,
                "schemaName": t.schema.name, "schema": t.schema.text(),
                "schemaEncoding": fg::SCHEMA_ENCODING})
        })
        .collect();
    json!({"op": "advertise", "channels": channels})
}

/// A `messageData` frame: opcode 1, subscription id, log time (ns), payload.
pub fn message_data(subscription: u32, ns: u64, payload: &[u8]) -> Vec<u8> {
    let mut b = Vec::with_capacity(13 + payload.len());
    b.push(1);
    b.extend_from_slice(&subscription.to_le_bytes());
    b.extend_from_slice(&ns.to_le_bytes());
    b.extend_from_slice(payload);
    b
}

#[derive(Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
enum ClientOp {
    Subscribe {
        subscriptions: Vec<Sub>,
    },
    Unsubscribe {
        #[serde(rename = "subscriptionIds")]
        subscription_ids: Vec<u32>,
    },
}

#[derive(Deserialize)]
struct Sub {
    id: u32,
    #[serde(rename = "channelId")]
    channel_id: u32,
}

/// Applies one client message to its subscriptions (channel id → subscription id); unknown
/// operations and channels are ignored, as the protocol allows.
pub fn apply(text: &str, subs: &mut HashMap<u32, u32>) {
    match serde_json::from_str::<ClientOp>(text) {
        Ok(ClientOp::Subscribe { subscriptions }) => {
            for s in subscriptions {
                if (1..=TOPICS.len() as u32).contains(&s.channel_id) {
                    subs.insert(s.channel_id, s.id);
                }
            }
        }
        Ok(ClientOp::Unsubscribe { subscription_ids }) => {
            subs.retain(|_, sid| !subscription_ids.contains(sid));
        }
        Err(_) => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_and_subscriptions() {
        let f = message_data(7, 0x0102_0304_0506_0708, b"{}");
        assert_eq!(f[0], 1);
        assert_eq!(u32::from_le_bytes(f[1..5].try_into().unwrap()), 7);
        assert_eq!(
            u64::from_le_bytes(f[5..13].try_into().unwrap()),
            0x0102_0304_0506_0708
        );
        assert_eq!(&f[13..], b"{}");
        let mut subs = HashMap::new();
        apply(
            r#"{"op":"subscribe","subscriptions":[{"id":3,"channelId":1},{"id":4,"channelId":99}]}"#,
            &mut subs,
        );
        assert_eq!(subs, HashMap::from([(1, 3)]));
        apply("garbage", &mut subs);
        apply(r#"{"op":"unsubscribe","subscriptionIds":[3]}"#, &mut subs);
        assert!(subs.is_empty());
        let a = advertise();
        let ch = a["channels"].as_array().unwrap();
        assert_eq!(ch.len(), TOPICS.len());
        assert_eq!(ch[0]["topic"], "/pose");
        assert_eq!(ch[0]["schemaName"], "foxglove.PoseInFrame");
        assert_eq!(channel_id(fg::POSE), 1);
    }
}
