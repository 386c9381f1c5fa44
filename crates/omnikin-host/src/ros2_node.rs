//! The robot as a native ROS 2 node over Zenoh (feature `ros2`): `omnikin robot --sim --ros2`
//! and `omnikin ros2 --connect`. No ROS installation: the node writes what rmw_zenoh writes
//! ([`omnikin_ros2::rmw`]: key expressions, liveliness tokens, attachments) with the `zenoh`
//! crate, so `ros2 topic list`, `ros2 topic echo /odom`, nav2 and RViz on a machine running
//! rmw_zenoh see it as a node.
//!
//! The node is an operator of the robot's link ([`crate::operator::Session`]): `cmd_vel`
//! becomes the link's robot-frame velocity command, which the robot's runtime holds to its
//! limits and watchdog; when `cmd_vel` falls silent for [`Ros2Options::cmd_timeout`] the node
//! sends a controlled stop (and if the node itself dies, the robot's watchdog stops the robot).
//! Each telemetry frame (at the rate [`Ros2Options::rate`] at most) becomes, in the node's
//! namespace:
//!
//! | topic | type | what |
//! |---|---|---|
//! | `cmd_vel` (in) | `geometry_msgs/msg/Twist` (`TwistStamped` with `stamped`) | robot frame (`base_link`): `linear.x`, `linear.y` m/s, `angular.z` rad/s |
//! | `odom` | `nav_msgs/msg/Odometry` | `odom` → `base_link`: the estimate, the measured twist, the fusion filter's covariance |
//! | `tf` | `tf2_msgs/msg/TFMessage` | `odom` → `base_link` |
//! | `joint_states` | `sensor_msgs/msg/JointState` | `wheel_i`, `steer_i`: encoder angles, commanded rates |
//! | `imu` | `sensor_msgs/msg/Imu` | gyro and accelerometer, when the robot sends them |
//! | `diagnostics` | `diagnostic_msgs/msg/DiagnosticArray` | mode and faults, at 1 Hz and on every change |
//! | `/clock` | `rosgraph_msgs/msg/Clock` | the stamps' time, with [`Ros2Options::clock`] only |
//!
//! and two services, `std_srvs/srv/Trigger`, as rmw_zenoh serves them (a Zenoh queryable on
//! [`service_key`], an `SS` liveliness token, the reply on the service's key with the request's
//! sequence number and the client's GID in its attachment):
//!
//! | service | does | answers `success: true` when |
//! |---|---|---|
//! | `estop` | latches the robot's e-stop (any request: an e-stop is never refused for its form) | the robot's telemetry shows the e-stop latched by one of the `EStop`s sent for it |
//! | `clear` | clears the e-stop latch | the telemetry acknowledges the `Clear` and the mode is no longer e-stop |
//!
//! and `success: false` with the mode and faults when the robot does not confirm within
//! [`CONFIRM`] (or the node stops first).
//!
//! Stamps are the robot's clock mapped once onto the Unix epoch at the first telemetry frame
//! (so differences are exact robot time; with `--time-scale` other than 1 they drift from the
//! wall clock); with [`Ros2Options::clock`] (`robot --sim --ros2`) the node publishes that
//! time on `/clock`, so nodes with `use_sim_time` agree with the stamps at any time scale.
//! An incoming sample is read with or without rmw_zenoh's attachment; one that does not decode
//! (or is larger than [`MAX_SAMPLE`]) is counted and dropped.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Result, anyhow, bail};
use omnikin::link::{Estimate, Message, RobotInfo, Telemetry};
use omnikin::runtime::{Frame, Mode};
use omnikin_ros2::msg::{
    Clock, DiagnosticArray, Imu, JointState, Odometry, TfMessage, Time, Trigger, TriggerRequest,
    TriggerResponse, Twist, TwistStamped, from_cdr, to_cdr,
};
use omnikin_ros2::node::{self as conv, Frames};
use omnikin_ros2::rmw::{Attachment, Entity, NodeInfo, Qos, gid, service_key, topic_key};
use zenoh::Wait;
use zenoh::handlers::{FifoChannel, FifoChannelHandler, RingChannel, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::query::{Query, Queryable};
use zenoh::sample::Sample;

use crate::names::OptionNames;
use crate::operator::Session;
use crate::robot_serve::{RobotServer, ServeSummary};

/// The largest incoming sample decoded, bytes (a `TwistStamped` with a 4 KiB `frame_id`);
/// larger ones are counted as bad and dropped unread.
pub const MAX_SAMPLE: usize = 4096;

/// Samples a subscription holds between two reads (the oldest are dropped first).
const QUEUE: usize = 16;

/// Requests a service holds between two reads (rmw_zenoh's service QoS depth, keep last 10;
/// more wait in Zenoh's queue, none is dropped unanswered).
const SERVICE_QUEUE: usize = 10;

/// How long the `estop` and `clear` services wait for the robot's telemetry to confirm, s
/// (then they answer `success: false`).
pub const CONFIRM: Duration = Duration::from_secs(1);

/// The node's options (`--zenoh`, `--zenoh-listen`, `--domain`, `--namespace`, `--stamped`,
/// `--ros2-rate`).
#[derive(Clone, Debug)]
pub struct Ros2Options {
    /// Zenoh endpoints to connect to (a router or a peer), e.g. `tcp/127.0.0.1:7447`.
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on (other peers connect here).
    pub listen: Vec<String>,
    /// Find peers by UDP multicast scouting too (off: only `connect`, and the peers a router
    /// tells of).
    pub multicast: bool,
    /// ROS domain id (`ROS_DOMAIN_ID`), 0–232.
    pub domain: u32,
    /// Namespace of the node and its relative topics (`""`: none).
    pub namespace: String,
    /// Node name.
    pub node_name: String,
    /// `cmd_vel` is `geometry_msgs/msg/TwistStamped` (ROS 2 Jazzy's nav2 option
    /// `enable_stamped_cmd_vel`) instead of `Twist`.
    pub stamped: bool,
    /// Largest publication rate of `odom`, `tf`, `joint_states`, `imu`, Hz (robot time);
    /// `None`: every telemetry frame.
    pub rate: Option<f64>,
    /// `cmd_vel` silence after which the node sends a controlled stop, s.
    pub cmd_timeout: f64,
    /// Publish `/clock` (`rosgraph_msgs/msg/Clock`) with every telemetry frame: the robot's
    /// time, the same stamps as the messages', for nodes with `use_sim_time` (a simulated
    /// robot under `--time-scale` runs faster or slower than the wall clock).
    pub clock: bool,
}

impl Ros2Options {
    /// The defaults: connect to `tcp/127.0.0.1:7447` (rmw_zenoh's router), listen on a free
    /// loopback port, no multicast, domain 0, no namespace, node `omnikin`, `Twist`, every
    /// telemetry frame, 0.5 s command timeout, no `/clock`.
    pub fn new() -> Self {
        Ros2Options {
            connect: vec!["tcp/127.0.0.1:7447".into()],
            listen: vec!["tcp/127.0.0.1:0".into()],
            multicast: false,
            domain: 0,
            namespace: String::new(),
            node_name: "omnikin".into(),
            stamped: false,
            rate: None,
            cmd_timeout: 0.5,
            clock: false,
        }
    }
}

impl Default for Ros2Options {
    fn default() -> Self {
        Self::new()
    }
}

/// What the node counted (the `ros2` object of the commands' JSON summary).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Ros2Counters {
    /// `cmd_vel` samples taken.
    pub cmd_vel: u64,
    /// Of those, with rmw_zenoh's attachment.
    pub cmd_vel_with_attachment: u64,
    /// Incoming samples dropped: not CDR of the type, too large, or not finite.
    pub bad_samples: u64,
    /// Controlled stops sent after `cmd_vel` fell silent.
    pub silence_stops: u64,
    /// `odom` messages published.
    pub odom: u64,
    /// Calls of the `estop` service.
    pub estop_requests: u64,
    /// Calls of the `clear` service.
    pub clear_requests: u64,
    /// Service calls answered `success: true` (the robot confirmed).
    pub service_confirmed: u64,
    /// Service calls answered `success: false` (not confirmed in time, or refused).
    pub service_failed: u64,
}

struct Pub {
    publisher: Publisher<'static>,
    gid: [u8; 16],
    seq: i64,
    _token: LivelinessToken,
}

impl Pub {
    fn put(&mut self, bytes: Vec<u8>) -> Result<()> {
        self.seq += 1;
        let a = Attachment {
            sequence_number: self.seq,
            source_timestamp: i64::try_from(unix_ns()).unwrap_or(i64::MAX),
            source_gid: self.gid,
        };
        self.publisher
            .put(bytes)
            .attachment(a.encode())
            .wait()
            .map_err(|e| anyhow!("zenoh: cannot publish: {e}"))
    }
}

struct Sub {
    subscriber: Subscriber<RingChannelHandler<Sample>>,
    _token: LivelinessToken,
}

/// A `std_srvs/srv/Trigger` service server: a queryable on its key and its `SS` token.
struct Srv {
    queryable: Queryable<FifoChannelHandler<Query>>,
    key: String,
    _token: LivelinessToken,
}

/// A service call as received: the query and its rmw_zenoh attachment (when it had one).
type Request = (Query, Option<Attachment>);

/// A call being served: the query to answer, its rmw_zenoh attachment (when it had one), and
/// the first link sequence number of the commands sent for it.
struct Call {
    query: Query,
    key: String,
    attachment: Option<Attachment>,
    first_seq: u64,
    deadline: Instant,
}

/// The node: a Zenoh session, its publishers and subscriptions, and their liveliness tokens.
pub struct Ros2Node {
    session: zenoh::Session,
    info: NodeInfo,
    _node_token: LivelinessToken,
    next_id: u32,
    options: Ros2Options,
    odom: Pub,
    tf: Pub,
    joints: Pub,
    imu: Option<Pub>,
    diag: Pub,
    clock: Option<Pub>,
    cmd_vel: Sub,
    estop: Srv,
    clear: Srv,
    /// What the node counted.
    pub counters: Ros2Counters,
}

fn unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

fn zerr(what: &str) -> impl FnOnce(zenoh::Error) -> anyhow::Error + '_ {
    move |e| anyhow!("zenoh: {what}: {e}")
}

impl Ros2Node {
    /// Opens the Zenoh session (peer mode) and declares the node, its publishers and its
    /// subscriptions with their liveliness tokens.
    ///
    /// # Errors
    /// A bad endpoint or domain, a listen endpoint that cannot be bound.
    pub fn open(o: &Ros2Options) -> Result<Self> {
        if o.domain > 232 {
            bail!("--domain {}: a ROS domain id is 0 to 232", o.domain);
        }
        if let Some(r) = o.rate
            && !(r.is_finite() && r > 0.0)
        {
            bail!("--ros2-rate must be > 0 Hz (got {r})");
        }
        if !o
            .node_name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_')
            || o.node_name.is_empty()
        {
            bail!("node name {:?}: letters, digits and _ only", o.node_name);
        }
        let ns_ok = o
            .namespace
            .split('/')
            .all(|p| p.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'));
        if !ns_ok {
            bail!(
                "--namespace {:?}: names of letters, digits and _ separated by /",
                o.namespace
            );
        }
        let mut c = zenoh::Config::default();
        let json = |v: &[String]| serde_json::to_string(v).unwrap_or_else(|_| "[]".into());
        c.insert_json5("mode", "\"peer\"")
            .and_then(|_| c.insert_json5("connect/endpoints", &json(&o.connect)))
            .and_then(|_| c.insert_json5("listen/endpoints", &json(&o.listen)))
            .and_then(|_| {
                c.insert_json5(
                    "scouting/multicast/enabled",
                    if o.multicast { "true" } else { "false" },
                )
            })
            .map_err(|e| anyhow!("--zenoh: {e}"))?;
        let session = zenoh::open(c)
            .wait()
            .map_err(zerr("cannot open a session"))?;
        let info = NodeInfo::new(
            o.domain,
            session.zid().to_string(),
            &o.namespace,
            &o.node_name,
        );
        let node_token = session
            .liveliness()
            .declare_token(info.node_token())
            .wait()
            .map_err(zerr("cannot declare the node"))?;
        let mut next_id = 1;
        let publisher = |topic: &str, token: String, key: String| -> Result<Pub> {
            let publisher = session.declare_publisher(key).wait().map_err(zerr(topic))?;
            let t = session
                .liveliness()
                .declare_token(token.clone())
                .wait()
                .map_err(zerr(topic))?;
            Ok(Pub {
                publisher,
                gid: gid(&token),
                seq: 0,
                _token: t,
            })
        };
        macro_rules! declare_pub {
            ($ty:ty, $topic:expr) => {{
                let topic = info.resolve($topic);
                let id = next_id;
                next_id += 1;
                publisher(
                    $topic,
                    info.entity_token::<$ty>(id, Entity::Publisher, &topic, Qos::KEEP_LAST_10),
                    topic_key::<$ty>(o.domain, &topic),
                )?
            }};
        }
        let odom = declare_pub!(Odometry, "odom");
        let tf = declare_pub!(TfMessage, "/tf");
        let joints = declare_pub!(JointState, "joint_states");
        let diag = declare_pub!(DiagnosticArray, "/diagnostics");
        let clock = if o.clock {
            Some(declare_pub!(Clock, "/clock"))
        } else {
            None
        };
        let subscribe = |topic: &str, token: String, key: String| -> Result<Sub> {
            let subscriber = session
                .declare_subscriber(key)
                .with(RingChannel::new(QUEUE))
                .wait()
                .map_err(zerr(topic))?;
            let t = session
                .liveliness()
                .declare_token(token)
                .wait()
                .map_err(zerr(topic))?;
            Ok(Sub {
                subscriber,
                _token: t,
            })
        };
        macro_rules! declare_sub {
            ($ty:ty, $topic:expr) => {{
                let topic = info.resolve($topic);
                let id = next_id;
                next_id += 1;
                subscribe(
                    $topic,
                    info.entity_token::<$ty>(id, Entity::Subscription, &topic, Qos::KEEP_LAST_10),
                    topic_key::<$ty>(o.domain, &topic),
                )?
            }};
        }
        let cmd_vel = if o.stamped {
            declare_sub!(TwistStamped, "cmd_vel")
        } else {
            declare_sub!(Twist, "cmd_vel")
        };
        let mut service = |name: &str| -> Result<Srv> {
            let topic = info.resolve(name);
            let id = next_id;
            next_id += 1;
            let key = service_key::<Trigger>(o.domain, &topic);
            let queryable = session
                .declare_queryable(key.clone())
                .complete(true)
                .with(FifoChannel::new(SERVICE_QUEUE))
                .wait()
                .map_err(zerr(name))?;
            let token =
                info.service_token::<Trigger>(id, Entity::Service, &topic, Qos::KEEP_LAST_10);
            let t = session
                .liveliness()
                .declare_token(token)
                .wait()
                .map_err(zerr(name))?;
            Ok(Srv {
                queryable,
                key,
                _token: t,
            })
        };
        let estop = service("estop")?;
        let clear = service("clear")?;
        Ok(Ros2Node {
            session,
            info,
            _node_token: node_token,
            next_id,
            options: o.clone(),
            odom,
            tf,
            joints,
            imu: None,
            diag,
            clock,
            cmd_vel,
            estop,
            clear,
            counters: Ros2Counters::default(),
        })
    }

    /// The node's identity: domain, Zenoh session id, namespace, name.
    pub fn info(&self) -> &NodeInfo {
        &self.info
    }

    /// The keys the node's entities use, for the log line: `cmd_vel`'s and `odom`'s.
    pub fn keys(&self) -> (String, String) {
        (
            self.cmd_vel.subscriber.key_expr().to_string(),
            self.odom.publisher.key_expr().to_string(),
        )
    }

    /// Takes the newest valid `cmd_vel` command of those received since the last call
    /// (`[vx, vy, yaw_rate]`, robot frame, m/s and rad/s); the others are counted.
    pub fn take_command(&mut self) -> Option<[f64; 3]> {
        let mut newest = None;
        while let Ok(Some(s)) = self.cmd_vel.subscriber.try_recv() {
            let bytes = s.payload().to_bytes();
            let twist = if bytes.len() > MAX_SAMPLE {
                None
            } else if self.options.stamped {
                from_cdr::<TwistStamped>(&bytes).ok().map(|t| t.twist)
            } else {
                from_cdr::<Twist>(&bytes).ok()
            };
            match twist.as_ref().and_then(conv::command) {
                Some(c) => {
                    self.counters.cmd_vel += 1;
                    if s.attachment()
                        .is_some_and(|a| Attachment::decode(&a.to_bytes()).is_some())
                    {
                        self.counters.cmd_vel_with_attachment += 1;
                    }
                    newest = Some(c);
                }
                None => self.counters.bad_samples += 1,
            }
        }
        newest
    }

    /// The calls of `estop` (then `clear`) received since the last call. A request that is
    /// not CDR of `std_srvs/srv/Trigger_Request` still counts (the request carries nothing)
    /// and is counted in `bad_samples` too.
    fn take_requests(&mut self) -> (Vec<Request>, Vec<Request>) {
        let mut bad = 0;
        let mut drain = |s: &Srv| {
            let mut calls = Vec::new();
            while let Ok(Some(q)) = s.queryable.try_recv() {
                let ok = q.payload().is_some_and(|p| {
                    let b = p.to_bytes();
                    b.len() <= MAX_SAMPLE && from_cdr::<TriggerRequest>(&b).is_ok()
                });
                if !ok {
                    bad += 1;
                }
                let a = q
                    .attachment()
                    .and_then(|a| Attachment::decode(&a.to_bytes()));
                calls.push((q, a));
            }
            calls
        };
        let e = drain(&self.estop);
        let c = drain(&self.clear);
        self.counters.bad_samples += bad;
        self.counters.estop_requests += e.len() as u64;
        self.counters.clear_requests += c.len() as u64;
        (e, c)
    }

    /// Answers `call`: a CDR `Trigger_Response` on the service's key, with rmw_zenoh's
    /// attachment when the request had one (its sequence number and the client's GID, the
    /// time now), as `ServiceData::send_response` does.
    fn answer(&mut self, call: Call, success: bool, message: String) {
        if success {
            self.counters.service_confirmed += 1;
        } else {
            self.counters.service_failed += 1;
        }
        let attachment = call.attachment.map(|a| {
            Attachment {
                sequence_number: a.sequence_number,
                source_timestamp: i64::try_from(unix_ns()).unwrap_or(i64::MAX),
                source_gid: a.source_gid,
            }
            .encode()
        });
        let r = TriggerResponse { success, message };
        // A client gone before its answer is not the node's failure: ignored.
        let _ = call
            .query
            .reply(call.key, to_cdr(&r))
            .attachment(attachment)
            .wait();
    }

    /// Publishes `odom`, `tf`, `joint_states` and (when the telemetry carries one) `imu` of
    /// `t` stamped `stamp`; `steer`: the robot has steer motors.
    ///
    /// # Errors
    /// Zenoh refusing a publication.
    pub fn publish(
        &mut self,
        t: &Telemetry,
        e: Option<&Estimate>,
        steer: bool,
        stamp: Time,
    ) -> Result<()> {
        let frames = Frames::default();
        self.odom
            .put(to_cdr(&conv::odometry(t, e, stamp, &frames)))?;
        self.counters.odom += 1;
        self.tf.put(to_cdr(&conv::tf(t, stamp, &frames)))?;
        self.joints
            .put(to_cdr(&conv::joint_states(t, steer, stamp)))?;
        if conv::has_imu(t) {
            if self.imu.is_none() {
                self.imu = Some(self.declare_imu()?);
            }
            if let Some(p) = self.imu.as_mut() {
                p.put(to_cdr(&conv::imu(t, stamp, &frames)))?;
            }
        }
        Ok(())
    }

    fn declare_imu(&mut self) -> Result<Pub> {
        let topic = self.info.resolve("imu");
        let id = self.next_id;
        self.next_id += 1;
        let token = self
            .info
            .entity_token::<Imu>(id, Entity::Publisher, &topic, Qos::KEEP_LAST_10);
        let publisher = self
            .session
            .declare_publisher(topic_key::<Imu>(self.options.domain, &topic))
            .wait()
            .map_err(zerr("imu"))?;
        let t = self
            .session
            .liveliness()
            .declare_token(token.clone())
            .wait()
            .map_err(zerr("imu"))?;
        Ok(Pub {
            publisher,
            gid: gid(&token),
            seq: 0,
            _token: t,
        })
    }

    /// Publishes `/clock` at `stamp` (when [`Ros2Options::clock`]).
    ///
    /// # Errors
    /// Zenoh refusing a publication.
    pub fn publish_clock(&mut self, stamp: Time) -> Result<()> {
        match self.clock.as_mut() {
            Some(p) => p.put(to_cdr(&Clock { clock: stamp })),
            None => Ok(()),
        }
    }

    /// Publishes `diagnostics` of `t`.
    ///
    /// # Errors
    /// Zenoh refusing a publication.
    pub fn publish_diagnostics(&mut self, t: &Telemetry, stamp: Time) -> Result<()> {
        let name = format!("{}: robot", self.options.node_name);
        self.diag.put(to_cdr(&conv::diagnostics(t, &name, stamp)))
    }
}

/// Which service a call is of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Service {
    EStop,
    Clear,
}

/// Runs the node on an operator session until `stop()` holds or the session fails:
/// handshake, then `cmd_vel` → velocity commands (a controlled stop after
/// [`Ros2Options::cmd_timeout`] of silence), telemetry → topics, service calls → e-stop and
/// clear. Leaves the session with a stop and `Bye` on every exit, and answers the calls still
/// waiting for the robot (`success: false`).
///
/// # Errors
/// The session's (handshake, lost link, signal) and Zenoh's.
pub fn run(s: &mut Session, node: &mut Ros2Node, stop: &dyn Fn() -> bool) -> Result<RobotInfo> {
    let info = s.hello()?;
    let mut calls = Vec::new();
    let r = serve(s, node, &info, stop, &mut calls);
    for (_, c) in calls {
        node.answer(
            c,
            false,
            "the node stopped before the robot confirmed".into(),
        );
    }
    if s.op.confirmed() {
        let _ = s.send(&Message::Stop);
    }
    let f = s.finish();
    r.and(f).map(|_| info)
}

/// `robot --sim … --ros2`: serves the simulated robot `server` in a thread of its own and
/// makes the node `open` gives its operator over the loopback link (`key`: the server's key
/// file) until the robot stops (`--max-time`, a signal, `stop`). The served robot's summary carries the node's
/// counters under `ros2`. A node failure is the error unless a signal ended the robot first
/// (the stop asked for, carried out).
///
/// # Errors
/// A server that listens on no UDP address (the node reaches the robot there), the simulated
/// robot's, and the node's session's.
pub fn serve_simulated(
    server: RobotServer,
    key: Option<&std::path::Path>,
    open: impl FnOnce() -> Result<Ros2Node>,
    stop: &AtomicBool,
) -> Result<ServeSummary> {
    let addr = server.local_addr().ok_or_else(|| {
        anyhow!("--ros2 needs a UDP --listen address (the node reaches the robot there)")
    })?;
    let mut node = open()?;
    let node = &mut node;
    let local = if addr.ip().is_unspecified() {
        std::net::SocketAddr::from(([127, 0, 0, 1], addr.port()))
    } else {
        addr
    };
    let done = AtomicBool::new(false);
    let (served, bridged) = std::thread::scope(|scope| {
        let robot = scope.spawn(|| {
            let r = server.run(Some(stop));
            done.store(true, Ordering::SeqCst);
            r
        });
        let bridged = Session::open(&local.to_string(), key, 20.0, 2.0, None, OptionNames::CLI)
            .and_then(|mut s| run(&mut s, node, &|| done.load(Ordering::SeqCst)));
        stop.store(true, Ordering::SeqCst);
        let served = robot
            .join()
            .map_err(|_| anyhow!("the simulated robot's thread panicked"));
        (served, bridged)
    });
    let mut served = served??;
    if let Err(e) = bridged
        && served.interrupted.is_none()
    {
        return Err(e);
    }
    if let Some(m) = served.summary.as_object_mut() {
        m.insert("ros2".into(), serde_json::to_value(node.counters)?);
    }
    Ok(served)
}

/// What the robot's telemetry `t` says of a call whose commands start at link sequence number
/// `first_seq`: `Some(true)` confirmed, `Some(false)` not confirmed by `deadline`, `None` not
/// yet.
fn verdict(
    kind: Service,
    first_seq: u64,
    deadline: Instant,
    t: &Telemetry,
    now: Instant,
) -> Option<bool> {
    let done = match kind {
        Service::EStop => t.mode == Mode::EStop && t.estop_seq >= first_seq,
        Service::Clear => t.ack_seq >= first_seq && t.mode != Mode::EStop,
    };
    if done {
        Some(true)
    } else if now >= deadline {
        Some(false)
    } else {
        None
    }
}

fn serve(
    s: &mut Session,
    node: &mut Ros2Node,
    info: &RobotInfo,
    stop: &dyn Fn() -> bool,
    calls: &mut Vec<(Service, Call)>,
) -> Result<()> {
    let steer = info.kind.steerable();
    let timeout = Duration::try_from_secs_f64(node.options.cmd_timeout)
        .map_err(|_| anyhow!("command timeout {} s", node.options.cmd_timeout))?;
    let period_us = node.options.rate.map(|r| (1e6 / r) as u64);
    let mut cmd: Option<([f64; 3], Instant)> = None;
    let mut next = Instant::now();
    let mut offset_ns: Option<i128> = None;
    let mut last_pub: Option<u64> = None;
    let mut last_diag: Option<(u64, Mode, u16)> = None;
    let mut stopping = false;
    while !stop() {
        if let Some(c) = node.take_command() {
            if cmd.is_none_or(|(old, at)| old != c || at.elapsed() >= timeout) {
                next = Instant::now(); // a new motion or a changed one: send at once
            }
            cmd = Some((c, Instant::now()));
            stopping = false;
        }
        // Each sent once per batch of calls, in three frames: the link is a datagram link,
        // and both are idempotent (the e-stop's latch, the clear of a latch). A clear asked
        // with an e-stop in the same batch is refused: the e-stop wins.
        let (estops, clears) = node.take_requests();
        let deadline = Instant::now() + CONFIRM;
        if !estops.is_empty() {
            let first_seq = s.next_seq();
            for _ in 0..3 {
                s.send(&Message::EStop)?;
            }
            for (query, attachment) in estops {
                let key = node.estop.key.clone();
                calls.push((
                    Service::EStop,
                    Call {
                        query,
                        key,
                        attachment,
                        first_seq,
                        deadline,
                    },
                ));
            }
            for (query, attachment) in clears {
                let key = node.clear.key.clone();
                let c = Call {
                    query,
                    key,
                    attachment,
                    first_seq,
                    deadline,
                };
                node.answer(
                    c,
                    false,
                    "not cleared: an e-stop was asked at the same time".into(),
                );
            }
        } else if !clears.is_empty() {
            let first_seq = s.next_seq();
            for _ in 0..3 {
                s.send(&Message::Clear)?;
            }
            for (query, attachment) in clears {
                let key = node.clear.key.clone();
                calls.push((
                    Service::Clear,
                    Call {
                        query,
                        key,
                        attachment,
                        first_seq,
                        deadline,
                    },
                ));
            }
        }
        let m = match cmd {
            Some((c, at)) if at.elapsed() < timeout => Message::SetVelocity {
                frame: Frame::Robot,
                vx: c[0] as f32,
                vy: c[1] as f32,
                yaw_rate: c[2] as f32,
            },
            Some(_) => {
                cmd = None;
                stopping = true;
                node.counters.silence_stops += 1;
                next = Instant::now();
                Message::Stop
            }
            None if stopping => Message::Stop,
            None => Message::Heartbeat,
        };
        let fresh = s.beat(&mut next, &m)?;
        s.alive()?;
        let Some(t) = s.latest.filter(|_| fresh) else {
            continue;
        };
        if stopping && matches!(t.mode, Mode::Idle | Mode::EStop) {
            stopping = false;
        }
        let now = Instant::now();
        let mut i = 0;
        while i < calls.len() {
            let (kind, c) = &calls[i];
            let Some(ok) = verdict(*kind, c.first_seq, c.deadline, &t, now) else {
                i += 1;
                continue;
            };
            let kind = *kind;
            let (_, c) = calls.swap_remove(i);
            let message = match (kind, ok) {
                (Service::EStop, true) => format!("e-stop latched (mode {})", t.mode),
                (Service::Clear, true) => format!("cleared (mode {})", t.mode),
                (_, false) => format!(
                    "not confirmed by the robot within {} s (mode {}, faults {})",
                    CONFIRM.as_secs_f64(),
                    t.mode,
                    t.faults
                ),
            };
            node.answer(c, ok, message);
        }
        let off =
            *offset_ns.get_or_insert_with(|| i128::from(unix_ns()) - i128::from(t.time_us) * 1000);
        let ns = u64::try_from(off + i128::from(t.time_us) * 1000).unwrap_or(0);
        let stamp = conv::stamp_ns(ns);
        node.publish_clock(stamp)?;
        if period_us.is_none_or(|p| last_pub.is_none_or(|l| t.time_us >= l.saturating_add(p))) {
            let e = s.estimate.filter(|e| e.time_us == t.time_us);
            node.publish(&t, e.as_ref(), steer, stamp)?;
            last_pub = Some(t.time_us);
        }
        let due = last_diag.is_none_or(|(at, mode, faults)| {
            t.time_us >= at.saturating_add(1_000_000) || mode != t.mode || faults != t.faults.0
        });
        if due {
            node.publish_diagnostics(&t, stamp)?;
            last_diag = Some((t.time_us, t.mode, t.faults.0));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_call_is_confirmed_only_by_telemetry_of_its_own_commands() {
        let now = Instant::now();
        let later = now + CONFIRM;
        let mut t = crate::test_support::telemetry(0);
        // E-stop: latched, but by an older e-stop (seq 4 < 5): not this call's, not yet.
        t.mode = Mode::EStop;
        t.estop_seq = 4;
        assert_eq!(verdict(Service::EStop, 5, later, &t, now), None);
        t.estop_seq = 6;
        assert_eq!(verdict(Service::EStop, 5, later, &t, now), Some(true));
        // Not latched by the deadline: refused.
        t.mode = Mode::Idle;
        assert_eq!(verdict(Service::EStop, 5, later, &t, later), Some(false));
        // Clear: acknowledged and out of e-stop; acknowledged but still latched is not.
        t.ack_seq = 9;
        assert_eq!(verdict(Service::Clear, 9, later, &t, now), Some(true));
        assert_eq!(verdict(Service::Clear, 10, later, &t, now), None);
        t.mode = Mode::EStop;
        assert_eq!(verdict(Service::Clear, 9, later, &t, now), None);
        assert_eq!(verdict(Service::Clear, 9, later, &t, later), Some(false));
    }
}
