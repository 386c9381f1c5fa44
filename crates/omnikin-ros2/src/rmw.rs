//! rmw_zenoh's names on the wire, without Zenoh itself: the key expression of a topic, the
//! liveliness tokens of the ROS 2 graph, the QoS text in those tokens, and the attachment of a
//! sample. A node built on any Zenoh binding (`omnikin_host::ros2_node` with the `zenoh` crate)
//! writes these, so `ros2 topic list` on a machine running rmw_zenoh sees it.
//!
//! The formats are rmw_zenoh's (ros2/rmw_zenoh, `docs/design.md` and
//! `rmw_zenoh_cpp/src/detail/liveliness_utils.cpp`, ROS 2 Jazzy):
//!
//! * a topic's data: `<domain>/<topic without its leading and trailing '/'>/<dds type>/<type hash>`,
//!   e.g. `0/cmd_vel/geometry_msgs::msg::dds_::Twist_/RIHS01_9c45…`;
//! * a service's queryable: the same with the service type's DDS name and hash,
//!   `0/estop/std_srvs::srv::dds_::Trigger_/RIHS01_eeff…` ([`service_key`]); a call is a Zenoh
//!   `get` there with the CDR request and the client's attachment, the answer a reply on the
//!   same key with the CDR response and an attachment of the call's sequence number, a new
//!   timestamp and the *client's* GID (`rmw_service_data.cpp`);
//! * a liveliness token: `@ros2_lv/<domain>/<session zid>/<node id>/<entity id>/<NN|MP|MS|SS|SC>/<enclave>/<namespace>/<node>`
//!   and, for a publisher, subscription, service or client,
//!   `/<topic>/<dds type>/<type hash>/<qos>`, every `/` inside a name written `%` (an empty
//!   namespace is `/`, so `%`);
//! * the QoS: `reliability:durability:history,depth:deadline s,ns:lifespan s,ns:liveliness,lease s,ns`,
//!   each field empty when it equals rmw_zenoh's default (reliable, volatile, keep last 42);
//! * the attachment of a sample (zenoh-ext serialization): the string `sequence_number`, an
//!   `i64`, `source_timestamp`, an `i64` (ns since the Unix epoch), `source_gid`, 16 bytes —
//!   each string a LEB128 length and its bytes, each `i64` 8 little-endian bytes. Later
//!   rmw_zenoh versions write the three values without their names; [`Attachment::decode`]
//!   reads both;
//! * an entity's GID: XXH3-128 of its liveliness token ([`gid`]).

use std::fmt::Write as _;

use crate::msg::{RosMessage, RosService};

/// The admin space of rmw_zenoh's liveliness tokens.
pub const ADMIN_SPACE: &str = "@ros2_lv";

/// What a liveliness token announces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entity {
    /// A node (`NN`).
    Node,
    /// A publisher (`MP`).
    Publisher,
    /// A subscription (`MS`).
    Subscription,
    /// A service server (`SS`).
    Service,
    /// A service client (`SC`).
    Client,
}

impl Entity {
    /// The two letters rmw_zenoh writes.
    pub fn code(self) -> &'static str {
        match self {
            Entity::Node => "NN",
            Entity::Publisher => "MP",
            Entity::Subscription => "MS",
            Entity::Service => "SS",
            Entity::Client => "SC",
        }
    }
}

/// A topic's QoS as rmw_zenoh's tokens carry it. Durations are `(s, ns)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Qos {
    /// 1 reliable, 2 best effort (rmw's `RMW_QOS_POLICY_RELIABILITY_*`).
    pub reliability: u8,
    /// 1 transient local, 2 volatile.
    pub durability: u8,
    /// 1 keep last, 2 keep all.
    pub history: u8,
    /// History depth, samples.
    pub depth: u32,
}

impl Qos {
    /// rmw_zenoh's default: reliable, volatile, keep last 42 (every field of the text empty).
    pub const DEFAULT: Qos = Qos {
        reliability: 1,
        durability: 2,
        history: 1,
        depth: 42,
    };

    /// rclcpp's default for publishers and subscriptions (`QoS(10)`): reliable, volatile,
    /// keep last 10 — what `ros2 topic pub`, nav2 and this node declare.
    pub const KEEP_LAST_10: Qos = Qos {
        depth: 10,
        ..Qos::DEFAULT
    };

    /// The QoS field of a liveliness token (module doc): only what differs from
    /// [`Qos::DEFAULT`]; deadline, lifespan and liveliness stay at their defaults (empty).
    pub fn to_keyexpr(self) -> String {
        let d = Qos::DEFAULT;
        let field = |v: u32, def: u32| {
            if v == def {
                String::new()
            } else {
                v.to_string()
            }
        };
        format!(
            "{}:{}:{},{}:,:,:,,",
            field(self.reliability.into(), d.reliability.into()),
            field(self.durability.into(), d.durability.into()),
            field(self.history.into(), d.history.into()),
            field(self.depth, d.depth),
        )
    }
}

/// A ROS name inside a token: every `/` becomes `%`.
pub fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// A node's identity in the graph.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeInfo {
    /// ROS domain id (`ROS_DOMAIN_ID`).
    pub domain: u32,
    /// The Zenoh session's id, as `ZenohId`'s `Display` writes it (hex).
    pub zid: String,
    /// The node's id within the session (rmw_zenoh counts from 0).
    pub node_id: u32,
    /// Namespace: `/` or `/name…` without a trailing `/`.
    pub namespace: String,
    /// Node name.
    pub name: String,
    /// Security enclave (`/` without one).
    pub enclave: String,
}

impl NodeInfo {
    /// A node `name` in `namespace` (normalised: leading `/`, no trailing `/`; empty is `/`).
    pub fn new(domain: u32, zid: impl Into<String>, namespace: &str, name: &str) -> Self {
        NodeInfo {
            domain,
            zid: zid.into(),
            node_id: 0,
            namespace: normalize_namespace(namespace),
            name: name.into(),
            enclave: "/".into(),
        }
    }

    /// The fully qualified name of a relative topic: `odom` in `/robot1` is `/robot1/odom`;
    /// an absolute topic (`/tf`) stays as it is.
    pub fn resolve(&self, topic: &str) -> String {
        if topic.starts_with('/') {
            topic.to_string()
        } else if self.namespace == "/" {
            format!("/{topic}")
        } else {
            format!("{}/{topic}", self.namespace)
        }
    }

    fn token_head(&self, entity_id: u32, e: Entity) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{}/{}/{}/{}/{}/{}",
            self.domain,
            self.zid,
            self.node_id,
            entity_id,
            e.code(),
            mangle(&self.enclave),
            mangle(&self.namespace),
            mangle(&self.name)
        )
    }

    /// The node's liveliness token (its entity id is its node id, as rmw_zenoh writes it).
    pub fn node_token(&self) -> String {
        self.token_head(self.node_id, Entity::Node)
    }

    /// The liveliness token of a publisher or subscription of this node: `entity_id` unique
    /// within the session, `topic` fully qualified ([`NodeInfo::resolve`]).
    pub fn entity_token<M: RosMessage>(
        &self,
        entity_id: u32,
        e: Entity,
        topic: &str,
        qos: Qos,
    ) -> String {
        self.token(entity_id, e, topic, &M::dds_type_name(), M::TYPE_HASH, qos)
    }

    /// The liveliness token of a service server ([`Entity::Service`]) or client of this node:
    /// the service's DDS name (`std_srvs::srv::dds_::Trigger_`) and its type hash in place of a
    /// message's, `service` fully qualified.
    pub fn service_token<S: RosService>(
        &self,
        entity_id: u32,
        e: Entity,
        service: &str,
        qos: Qos,
    ) -> String {
        self.token(
            entity_id,
            e,
            service,
            &S::dds_type_name(),
            S::TYPE_HASH,
            qos,
        )
    }

    fn token(
        &self,
        entity_id: u32,
        e: Entity,
        name: &str,
        dds: &str,
        hash: &str,
        qos: Qos,
    ) -> String {
        let mut s = self.token_head(entity_id, e);
        let _ = write!(s, "/{}/{}/{}/{}", mangle(name), dds, hash, qos.to_keyexpr());
        s
    }
}

/// `ns` with one leading `/` and no trailing `/` (`""` and `"/"` are `/`).
pub fn normalize_namespace(ns: &str) -> String {
    let t = ns.trim_matches('/');
    if t.is_empty() {
        "/".into()
    } else {
        format!("/{t}")
    }
}

/// The key expression of a topic's samples: `<domain>/<topic>/<dds type>/<type hash>`, the
/// topic fully qualified and without its leading and trailing `/`.
pub fn topic_key<M: RosMessage>(domain: u32, topic: &str) -> String {
    format!(
        "{domain}/{}/{}/{}",
        topic.trim_matches('/'),
        M::dds_type_name(),
        M::TYPE_HASH
    )
}

/// The key expression of a service (its queryable): `<domain>/<service>/<dds type>/<type hash>`,
/// as [`topic_key`] with the service type's names (`rmw_service_data.cpp`: a server declares a
/// queryable there; a client's request is a Zenoh `get` on it, and the reply is on the same key).
pub fn service_key<S: RosService>(domain: u32, service: &str) -> String {
    format!(
        "{domain}/{}/{}/{}",
        service.trim_matches('/'),
        S::dds_type_name(),
        S::TYPE_HASH
    )
}

/// The attachment rmw_zenoh puts on each sample (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Attachment {
    /// The publisher's sample counter, from 1.
    pub sequence_number: i64,
    /// When the sample was published, ns since the Unix epoch.
    pub source_timestamp: i64,
    /// The publisher's GID.
    pub source_gid: [u8; 16],
}

const ATTACHMENT_NAMES: [&str; 3] = ["sequence_number", "source_timestamp", "source_gid"];

impl Attachment {
    /// The bytes rmw_zenoh (Jazzy) writes: each value after its name.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(80);
        let name = |out: &mut Vec<u8>, n: &str| {
            out.push(n.len() as u8); // < 128: one LEB128 byte
            out.extend_from_slice(n.as_bytes());
        };
        name(&mut out, ATTACHMENT_NAMES[0]);
        out.extend_from_slice(&self.sequence_number.to_le_bytes());
        name(&mut out, ATTACHMENT_NAMES[1]);
        out.extend_from_slice(&self.source_timestamp.to_le_bytes());
        name(&mut out, ATTACHMENT_NAMES[2]);
        out.extend_from_slice(&self.source_gid);
        out
    }

    /// Reads an attachment with its names (rmw_zenoh on Jazzy) or without them (32 bytes:
    /// later versions); `None` for anything else. Reads only within `b`.
    pub fn decode(b: &[u8]) -> Option<Attachment> {
        fn i64_at(b: &[u8], at: usize) -> Option<i64> {
            Some(i64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
        }
        if b.len() == 32 && !b.starts_with(b"\x0fsequence_number") {
            return Some(Attachment {
                sequence_number: i64_at(b, 0)?,
                source_timestamp: i64_at(b, 8)?,
                source_gid: b.get(16..32)?.try_into().ok()?,
            });
        }
        fn name(b: &[u8], at: &mut usize, n: &str) -> Option<()> {
            let len = usize::from(*b.get(*at)?);
            (b.get(*at + 1..*at + 1 + len)? == n.as_bytes()).then_some(())?;
            *at += 1 + len;
            Some(())
        }
        let mut at = 0;
        name(b, &mut at, ATTACHMENT_NAMES[0])?;
        let sequence_number = i64_at(b, at)?;
        at += 8;
        name(b, &mut at, ATTACHMENT_NAMES[1])?;
        let source_timestamp = i64_at(b, at)?;
        at += 8;
        name(b, &mut at, ATTACHMENT_NAMES[2])?;
        let source_gid = b.get(at..at + 16)?.try_into().ok()?;
        (b.len() == at + 16).then_some(Attachment {
            sequence_number,
            source_timestamp,
            source_gid,
        })
    }
}

/// An entity's GID as rmw_zenoh computes it (`Entity::Entity` in `liveliness_utils.cpp`): the
/// XXH3-128 hash (seed 0, default secret) of its whole liveliness token, the low 64 bits then
/// the high 64 bits, each in little-endian byte order (a `memcpy` of each `uint64_t` on the
/// little-endian machines ROS 2 runs on). Subscribers compare GIDs; a service reply carries
/// the client's.
pub fn gid(token: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
    let mut g = [0u8; 16];
    g[..8].copy_from_slice(&(h as u64).to_le_bytes());
    g[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    g
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Odometry, Trigger, Twist};

    #[test]
    fn gids_are_xxh3_128_of_the_token_low_half_first() {
        // Known XXH3-128 values (seed 0), from the reference implementation's (xxHash's)
        // canonical output, checked with the `xxhash` Python package (the C library):
        // "" -> 99aa06d3014798d8 6001c324468d497f, "hello" -> b5e9c1ad071b3e7f c779cfaa5e523818
        // (high64, low64).
        let mut empty = [0u8; 16];
        empty[..8].copy_from_slice(&0x6001_c324_468d_497f_u64.to_le_bytes());
        empty[8..].copy_from_slice(&0x99aa_06d3_0147_98d8_u64.to_le_bytes());
        assert_eq!(gid(""), empty);
        let mut hello = [0u8; 16];
        hello[..8].copy_from_slice(&0xc779_cfaa_5e52_3818_u64.to_le_bytes());
        hello[8..].copy_from_slice(&0xb5e9_c1ad_071b_3e7f_u64.to_le_bytes());
        assert_eq!(gid("hello"), hello);
        assert_ne!(gid("a"), gid("b"));
    }

    #[test]
    fn services_are_keyed_and_announced_with_the_service_type() {
        assert_eq!(
            service_key::<Trigger>(0, "/estop"),
            "0/estop/std_srvs::srv::dds_::Trigger_/RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f"
        );
        let n = NodeInfo::new(3, "ab", "robot1", "omnikin");
        assert_eq!(
            n.service_token::<Trigger>(7, Entity::Service, "/robot1/clear", Qos::KEEP_LAST_10),
            "@ros2_lv/3/ab/0/7/SS/%/%robot1/omnikin/%robot1%clear/std_srvs::srv::dds_::Trigger_/RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f/::,10:,:,:,,"
        );
    }

    #[test]
    fn topic_keys_are_domain_topic_type_hash() {
        assert_eq!(
            topic_key::<Twist>(0, "/cmd_vel"),
            "0/cmd_vel/geometry_msgs::msg::dds_::Twist_/RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"
        );
        assert_eq!(
            topic_key::<Odometry>(7, "/robot1/odom"),
            "7/robot1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"
        );
    }

    #[test]
    fn tokens_are_written_as_rmw_zenoh_writes_them() {
        let n = NodeInfo::new(0, "c6b2f3a1", "", "omnikin");
        assert_eq!(n.node_token(), "@ros2_lv/0/c6b2f3a1/0/0/NN/%/%/omnikin");
        assert_eq!(
            n.entity_token::<Twist>(3, Entity::Subscription, "/cmd_vel", Qos::KEEP_LAST_10),
            "@ros2_lv/0/c6b2f3a1/0/3/MS/%/%/omnikin/%cmd_vel/geometry_msgs::msg::dds_::Twist_/RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a/::,10:,:,:,,"
        );
        let ns = NodeInfo::new(2, "ab", "/robot1/", "omnikin");
        assert_eq!(ns.resolve("odom"), "/robot1/odom");
        assert_eq!(ns.resolve("/tf"), "/tf");
        assert_eq!(
            ns.entity_token::<Odometry>(1, Entity::Publisher, "/robot1/odom", Qos::DEFAULT),
            "@ros2_lv/2/ab/0/1/MP/%/%robot1/omnikin/%robot1%odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0/::,:,:,:,,"
        );
    }

    #[test]
    fn qos_fields_differ_from_the_default_only() {
        let q = Qos {
            reliability: 2,
            durability: 1,
            history: 1,
            depth: 5,
        };
        assert_eq!(q.to_keyexpr(), "2:1:,5:,:,:,,");
    }

    #[test]
    fn attachments_round_trip_in_both_layouts() {
        let a = Attachment {
            sequence_number: 7,
            source_timestamp: 1_700_000_000_123_456_789,
            source_gid: gid("x"),
        };
        let b = a.encode();
        assert_eq!(b.len(), 1 + 15 + 8 + 1 + 16 + 8 + 1 + 10 + 16);
        assert_eq!(&b[..16], b"\x0fsequence_number");
        assert_eq!(Attachment::decode(&b), Some(a));
        let mut bare = Vec::new();
        bare.extend_from_slice(&7i64.to_le_bytes());
        bare.extend_from_slice(&a.source_timestamp.to_le_bytes());
        bare.extend_from_slice(&a.source_gid);
        assert_eq!(Attachment::decode(&bare), Some(a));
        // Truncated, extended or misnamed: refused, never read past the end.
        for n in 0..b.len() {
            assert_eq!(Attachment::decode(&b[..n]), None, "{n}");
        }
        let mut longer = b.clone();
        longer.push(0);
        assert_eq!(Attachment::decode(&longer), None);
        let mut renamed = b;
        renamed[1] = b'S';
        assert_eq!(Attachment::decode(&renamed), None);
        assert_ne!(gid("a"), gid("b"));
    }

    #[test]
    fn any_bytes_decode_or_are_refused_without_a_panic() {
        // Every one-byte change of both layouts, and pseudo-random inputs of 0..100 bytes.
        let a = Attachment {
            sequence_number: 1,
            source_timestamp: 2,
            source_gid: [3; 16],
        };
        let mut bare = Vec::new();
        bare.extend_from_slice(&1i64.to_le_bytes());
        bare.extend_from_slice(&2i64.to_le_bytes());
        bare.extend_from_slice(&[3; 16]);
        assert_eq!(Attachment::decode(&bare), Some(a));
        for base in [a.encode(), bare] {
            for i in 0..base.len() {
                for v in [0u8, 1, 0x0f, 0x7f, 0x80, 0xff] {
                    let mut b = base.clone();
                    b[i] = v;
                    let _ = Attachment::decode(&b);
                }
            }
        }
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let n = (x % 100) as usize;
            let b: Vec<u8> = (0..n).map(|i| (x >> (i % 8 * 8)) as u8).collect();
            let _ = Attachment::decode(&b);
        }
    }
}
