//! What the relay and the browsers share: the stream of JSON messages to the pages (bounded
//! ring, plus the newest message of each "sticky" kind that a page opened later needs first),
//! the bounded command queue to the relay, and the e-stop request, which bypasses the queue.
//!
//! **One page holds the controls.** Teleop, stop, clear and plans are taken from the page that
//! holds them; the first page to send one holds them while nobody does, and keeps them until
//! it closes, releases them, or another page takes them over explicitly (`take_control`, an
//! act its user makes, announced to every page). Every other page sees who holds them and can
//! only e-stop: an e-stop from any page always goes through. Recording is open to every page
//! (it does not move the robot).

use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex, MutexGuard};

use omnikin_plan::Plan;
use serde::Deserialize;

/// Messages kept for the pages (at 20 Hz telemetry, about 12 s).
pub const RING: usize = 256;
/// Events replayed to a page that connects later.
pub const EVENTS: usize = 100;
/// Commands waiting for the relay; a page that sends faster is told "busy".
pub const QUEUE: usize = 64;
/// Largest message a page may send, bytes (a plan CSV with about 50 000 rows).
pub const MAX_MESSAGE: usize = 8 * 1024 * 1024;

/// A command from a page, for the relay.
#[derive(Debug)]
pub enum HubCommand {
    /// Teleop while the dead-man is held: fractions of the console's --speed and --turn,
    /// each clamped to [-1, 1] (robot frame: forward, left, counter-clockwise).
    Teleop {
        /// Forward.
        vx: f64,
        /// Left.
        vy: f64,
        /// Counter-clockwise.
        yaw: f64,
    },
    /// Controlled stop (dead-man released, or the Stop button).
    Stop,
    /// Clear the e-stop latch and the fault history.
    Clear,
    /// A plan to preview (parsed from the page's CSV).
    Plan {
        /// The file name the page gave.
        name: String,
        /// The plan.
        plan: Box<Plan>,
    },
    /// Upload the previewed plan and run it.
    PlanRun {
        /// First set the pose estimate to the plan's first pose.
        set_pose: bool,
    },
    /// Start (`true`) or stop recording the telemetry to MCAP.
    Record(bool),
}

/// A page's message, as JSON (`{"type": "...", ...}`).
#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum PageMessage {
    Teleop { vx: f64, vy: f64, yaw: f64 },
    Stop,
    Estop,
    Clear,
    Plan { name: String, csv: String },
    PlanRun { set_pose: bool },
    Record { on: bool },
    TakeControl,
    ReleaseControl,
}

/// A page, as the hub knows it: its number (from 1, in the order pages opened) and address.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Page {
    /// Number of the page, from 1.
    pub id: u64,
    /// Its TCP peer address.
    pub addr: String,
}

impl Page {
    /// "page 2 (127.0.0.1:41234)": how pages and events name it.
    pub fn name(&self) -> String {
        format!("page {} ({})", self.id, self.addr)
    }
}

/// Longest plan file name kept (the rest is cut).
const MAX_NAME: usize = 120;

/// Clamps a teleop axis to [-1, 1]; `None` for a non-finite one.
fn axis(v: f64) -> Option<f64> {
    v.is_finite().then(|| v.clamp(-1.0, 1.0))
}

/// The shared state.
pub struct Hub {
    inner: Mutex<Inner>,
    /// Set by any page's e-stop; the relay takes it before anything else.
    pub estop: AtomicBool,
    /// Set when the console is shutting down.
    pub shutdown: AtomicBool,
    /// Open websocket clients.
    pub clients: AtomicUsize,
    /// `console --robot`: the robot's name and body limits; an uploaded plan asking for more
    /// is refused ([`crate::body_limits::plan_excess`]).
    pub robot_limits: std::sync::OnceLock<(String, omnikin::description::BodyLimits)>,
    tx: SyncSender<HubCommand>,
}

struct Inner {
    next: u64,
    ring: VecDeque<(u64, Arc<str>)>,
    sticky: BTreeMap<&'static str, Arc<str>>,
    events: VecDeque<Arc<str>>,
    pages: u64,
    holder: Option<Page>,
}

impl Hub {
    /// A hub and the relay's end of the command queue.
    pub fn new() -> (Arc<Self>, Receiver<HubCommand>) {
        let (tx, rx) = sync_channel(QUEUE);
        (
            Arc::new(Hub {
                inner: Mutex::new(Inner {
                    next: 1,
                    ring: VecDeque::with_capacity(RING),
                    sticky: BTreeMap::new(),
                    events: VecDeque::with_capacity(EVENTS),
                    pages: 0,
                    holder: None,
                }),
                estop: AtomicBool::new(false),
                shutdown: AtomicBool::new(false),
                clients: AtomicUsize::new(0),
                robot_limits: std::sync::OnceLock::new(),
                tx,
            }),
            rx,
        )
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panicking holder cannot leave the ring inconsistent (every update is one push).
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Sends `msg` to every page; `sticky` keeps it as the newest of its kind for pages that
    /// connect later; events are kept for them too.
    pub fn publish(&self, msg: &serde_json::Value, sticky: Option<&'static str>) {
        Self::push(&mut self.lock(), msg, sticky);
    }

    fn push(g: &mut Inner, msg: &serde_json::Value, sticky: Option<&'static str>) {
        let text: Arc<str> = msg.to_string().into();
        let seq = g.next;
        g.next += 1;
        if g.ring.len() == RING {
            g.ring.pop_front();
        }
        g.ring.push_back((seq, text.clone()));
        if let Some(k) = sticky {
            g.sticky.insert(k, text.clone());
        }
        if msg["type"] == "event" {
            if g.events.len() == EVENTS {
                g.events.pop_front();
            }
            g.events.push_back(text);
        }
    }

    /// A page opened: its number and address (for "held by page 2 (127.0.0.1:41234)").
    pub fn join(&self, addr: String) -> Page {
        let mut g = self.lock();
        g.pages += 1;
        Page { id: g.pages, addr }
    }

    /// A page closed: if it held the controls, they are free.
    pub fn leave(&self, page: &Page) {
        let mut g = self.lock();
        if g.holder.as_ref() == Some(page) {
            Self::set_holder(
                &mut g,
                None,
                &format!("{} closed: the controls are free", page.name()),
            );
        }
    }

    /// Who holds the controls now.
    #[cfg(test)]
    pub fn holder(&self) -> Option<Page> {
        self.lock().holder.clone()
    }

    /// Changes the holder and tells every page (a sticky `control` message and an event).
    fn set_holder(g: &mut Inner, to: Option<Page>, why: &str) {
        g.holder = to;
        let h = g.holder.as_ref();
        let msg = serde_json::json!({
            "type": "control",
            "holder": h.map(|p| p.id),
            "name": h.map(Page::name),
        });
        Self::push(g, &msg, Some("control"));
        Self::push(
            g,
            &serde_json::json!({"type": "event", "level": "info", "text": why}),
            None,
        );
    }

    /// What a new page gets first (the sticky messages, then the kept events) and the
    /// cursor from which it follows the stream.
    pub fn subscribe(&self) -> (Vec<Arc<str>>, u64) {
        let g = self.lock();
        let mut first: Vec<Arc<str>> = g.sticky.values().cloned().collect();
        first.extend(g.events.iter().cloned());
        (first, g.next)
    }

    /// Messages after `cursor` (at most the ring: a page that fell behind skips ahead) and
    /// the new cursor.
    pub fn since(&self, cursor: u64) -> (Vec<Arc<str>>, u64) {
        let g = self.lock();
        let out = g
            .ring
            .iter()
            .filter(|(s, _)| *s >= cursor)
            .map(|(_, m)| m.clone())
            .collect();
        (out, g.next)
    }

    /// Handles one text message of `page`; `Err` is the answer for that page alone (never
    /// a crash: every field is checked, a plan is parsed here, outside the relay's loop).
    pub fn handle(&self, page: &Page, text: &str) -> Result<(), String> {
        let m: PageMessage = serde_json::from_str(text).map_err(|e| format!("bad message: {e}"))?;
        let cmd = match m {
            PageMessage::Estop => {
                self.estop.store(true, Ordering::SeqCst);
                return Ok(());
            }
            PageMessage::TakeControl => {
                let mut g = self.lock();
                if g.holder.as_ref() != Some(page) {
                    let why = match &g.holder {
                        Some(h) => format!("{} took the controls from {}", page.name(), h.name()),
                        None => format!("{} holds the controls", page.name()),
                    };
                    Self::set_holder(&mut g, Some(page.clone()), &why);
                }
                return Ok(());
            }
            PageMessage::ReleaseControl => {
                let mut g = self.lock();
                if g.holder.as_ref() == Some(page) {
                    let why = format!("{} released the controls", page.name());
                    Self::set_holder(&mut g, None, &why);
                }
                return Ok(());
            }
            PageMessage::Teleop { vx, vy, yaw } => match (axis(vx), axis(vy), axis(yaw)) {
                (Some(vx), Some(vy), Some(yaw)) => HubCommand::Teleop { vx, vy, yaw },
                _ => return Err("teleop: vx, vy and yaw must be finite numbers".into()),
            },
            PageMessage::Stop => HubCommand::Stop,
            PageMessage::Clear => HubCommand::Clear,
            PageMessage::PlanRun { set_pose } => HubCommand::PlanRun { set_pose },
            PageMessage::Record { on } => HubCommand::Record(on),
            PageMessage::Plan { name, csv } => {
                let name: String = name
                    .chars()
                    .filter(|c| !c.is_control())
                    .take(MAX_NAME)
                    .collect();
                let plan = Plan::read_csv(csv.as_bytes(), &name)
                    .map_err(|e| format!("plan {name}: {e}"))?;
                if plan.samples.len() < 2 {
                    return Err(format!("plan {name}: needs at least 2 samples"));
                }
                if let Some((robot, limits)) = self.robot_limits.get() {
                    let peaks = crate::body_limits::peaks(&plan);
                    let excess = crate::body_limits::plan_excess(limits, &peaks);
                    if !excess.is_empty() {
                        return Err(format!(
                            "plan {name}: refused for {robot}: {}; the robot would lag behind it",
                            excess.join("; ")
                        ));
                    }
                }
                HubCommand::Plan {
                    name,
                    plan: Box::new(plan),
                }
            }
        };
        // A valid command that moves the robot or changes what it will do: only from the holder
        // (recording is open to every page).
        if !matches!(cmd, HubCommand::Record(_)) {
            let mut g = self.lock();
            match &g.holder {
                Some(h) if h != page => {
                    return Err(format!(
                        "refused: the controls are held by {} (take control first; E-STOP always works)",
                        h.name()
                    ));
                }
                Some(_) => {}
                None => {
                    let why = format!("{} holds the controls", page.name());
                    Self::set_holder(&mut g, Some(page.clone()), &why);
                }
            }
        }
        match self.tx.try_send(cmd) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(_)) => {
                Err("busy: the relay has too many commands waiting; this one was dropped".into())
            }
            Err(TrySendError::Disconnected(_)) => Err("the relay has stopped".into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p1() -> Page {
        Page {
            id: 1,
            addr: "127.0.0.1:1".into(),
        }
    }

    #[test]
    fn one_page_holds_the_controls_and_any_page_can_estop() {
        let (hub, rx) = Hub::new();
        let (a, b) = (
            hub.join("127.0.0.1:1001".into()),
            hub.join("127.0.0.1:1002".into()),
        );
        assert_eq!((a.id, b.id), (1, 2));
        assert_eq!(hub.holder(), None);
        // A bad command claims nothing.
        assert!(
            hub.handle(&b, r#"{"type":"teleop","vx":"x","vy":0,"yaw":0}"#)
                .is_err()
        );
        assert_eq!(hub.holder(), None);
        // The first valid control claims them.
        hub.handle(&a, r#"{"type":"teleop","vx":1,"vy":0,"yaw":0}"#)
            .unwrap();
        assert_eq!(hub.holder(), Some(a.clone()));
        assert!(matches!(rx.try_recv(), Ok(HubCommand::Teleop { .. })));
        // The other page: refused, told who holds them, nothing reaches the relay.
        for m in [
            r#"{"type":"teleop","vx":1,"vy":0,"yaw":0}"#,
            r#"{"type":"stop"}"#,
            r#"{"type":"clear"}"#,
            r#"{"type":"plan_run","set_pose":false}"#,
        ] {
            let e = hub.handle(&b, m).unwrap_err();
            assert!(e.contains("held by page 1 (127.0.0.1:1001)"), "{e}");
        }
        assert!(rx.try_recv().is_err());
        // ...but its e-stop goes through, and so does recording.
        hub.handle(&b, r#"{"type":"estop"}"#).unwrap();
        assert!(hub.estop.load(Ordering::SeqCst));
        hub.handle(&b, r#"{"type":"record","on":true}"#).unwrap();
        assert!(matches!(rx.try_recv(), Ok(HubCommand::Record(true))));
        // An explicit take-over, announced; then the first page is refused.
        hub.handle(&b, r#"{"type":"take_control"}"#).unwrap();
        assert_eq!(hub.holder(), Some(b.clone()));
        assert!(hub.handle(&a, r#"{"type":"stop"}"#).is_err());
        let (first, _) = hub.subscribe();
        assert!(
            first.iter().any(|m| m.contains(r#""holder":2"#)),
            "{first:?}"
        );
        assert!(
            first
                .iter()
                .any(|m| m.contains("page 2 (127.0.0.1:1002) took the controls from page 1"))
        );
        // Releasing (only by the holder) and closing free them.
        hub.handle(&a, r#"{"type":"release_control"}"#).unwrap();
        assert_eq!(hub.holder(), Some(b.clone()));
        hub.leave(&b);
        assert_eq!(hub.holder(), None);
        hub.handle(&a, r#"{"type":"stop"}"#).unwrap();
        assert_eq!(hub.holder(), Some(a));
    }

    #[test]
    fn hostile_messages_are_answered_not_obeyed() {
        let (hub, rx) = Hub::new();
        for m in [
            "",
            "null",
            "[]",
            "{}",
            r#"{"type":"launch"}"#,
            r#"{"type":"teleop","vx":"1","vy":0,"yaw":0}"#,
            r#"{"type":"teleop","vx":1,"vy":0}"#,
            r#"{"type":"teleop","vx":1e999,"vy":0,"yaw":0}"#,
            r#"{"type":"teleop","vx":1,"vy":0,"yaw":0,"speed":100}"#,
            r#"{"type":"plan","name":"x.csv","csv":"t,x\n1,2\n"}"#,
            r#"{"type":"plan","name":"x.csv","csv":"\u0000\u0001"}"#,
            r#"{"type":"plan_run","set_pose":"yes"}"#,
        ] {
            assert!(hub.handle(&p1(), m).is_err(), "{m}");
        }
        assert!(rx.try_recv().is_err(), "nothing reached the relay");
        assert!(!hub.estop.load(Ordering::SeqCst));
    }

    #[test]
    fn teleop_is_clamped_to_full_scale() {
        let (hub, rx) = Hub::new();
        hub.handle(&p1(), r#"{"type":"teleop","vx":50,"vy":-3,"yaw":0.25}"#)
            .unwrap();
        match rx.try_recv().unwrap() {
            HubCommand::Teleop { vx, vy, yaw } => assert_eq!((vx, vy, yaw), (1.0, -1.0, 0.25)),
            c => panic!("{c:?}"),
        }
    }

    #[test]
    fn estop_bypasses_a_full_queue() {
        let (hub, _rx) = Hub::new();
        for _ in 0..QUEUE {
            hub.handle(&p1(), r#"{"type":"stop"}"#).unwrap();
        }
        assert!(
            hub.handle(&p1(), r#"{"type":"stop"}"#)
                .unwrap_err()
                .contains("busy")
        );
        hub.handle(&p1(), r#"{"type":"estop"}"#).unwrap();
        assert!(hub.estop.load(Ordering::SeqCst));
    }

    #[test]
    fn ring_is_bounded_and_sticky_kept() {
        let (hub, _rx) = Hub::new();
        hub.publish(
            &serde_json::json!({"type": "link", "state": "connected"}),
            Some("link"),
        );
        for i in 0..(RING + 10) {
            hub.publish(&serde_json::json!({"type": "telemetry", "i": i}), None);
        }
        hub.publish(&serde_json::json!({"type": "event", "text": "x"}), None);
        let (all, next) = hub.since(0);
        assert_eq!(all.len(), RING);
        assert!(all[RING - 1].contains("event"));
        let (first, cursor) = hub.subscribe();
        assert_eq!(cursor, next);
        assert!(first[0].contains("connected") && first[1].contains("\"x\""));
        assert!(hub.since(cursor).0.is_empty());
    }

    #[test]
    fn a_plan_beyond_the_robots_limits_is_refused_at_upload() {
        use omnikin::description::{BodyLimits, LimitSource};
        let (hub, rx) = Hub::new();
        let limits = BodyLimits {
            max_accel: 0.5,
            max_accel_source: LimitSource::File,
            max_yaw_accel: 4.0,
            max_yaw_accel_source: LimitSource::WheelLimits,
            max_jerk: None,
            max_jerk_source: LimitSource::Unlimited,
        };
        // 0 → 0.2 m/s in 0.1 s: 2 m/s².
        let msg = r#"{"type":"plan","name":"fast.csv","csv":"t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n0,0,0,0,0,0,0,0,0,0\n0.1,0.01,0,0,0.2,0,0,0,0,0\n0.2,0.03,0,0,0.2,0,0,0,0,0\n"}"#;
        // Without --robot it is accepted (nothing to compare with).
        hub.handle(&p1(), msg).unwrap();
        assert!(matches!(rx.try_recv().unwrap(), HubCommand::Plan { .. }));
        hub.robot_limits.set(("kiwi".into(), limits)).unwrap();
        let e = hub.handle(&p1(), msg).unwrap_err();
        assert!(
            e.contains("refused for kiwi: the plan asks 2 m/s² of acceleration")
                && e.contains("the robot's 0.5 m/s² (the robot file's limits.max_accel)"),
            "{e}"
        );
        assert!(rx.try_recv().is_err());
    }
}
