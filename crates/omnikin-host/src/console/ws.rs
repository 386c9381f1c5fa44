//! One page's websocket (`tungstenite` over the accepted `TcpStream`, after the handshake in
//! [`super::http`]): the page's messages go to the [`Hub`], the hub's stream goes to the page.
//! Reads wait at most [`POLL`], writes at most [`WRITE_TIMEOUT`] (a page that stops reading
//! is dropped), messages are at most [`MAX_MESSAGE`] bytes.

use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Error, Message, WebSocket};

use super::hub::{Hub, MAX_MESSAGE, Page};

/// A page's place in the hub, given up however [`serve`] ends (its controls are freed).
struct Joined<'a>(&'a Hub, Page);

impl Drop for Joined<'_> {
    fn drop(&mut self) {
        self.0.leave(&self.1);
    }
}

/// How long one read waits before the stream is checked for messages to send.
pub const POLL: Duration = Duration::from_millis(20);
/// How long a write may block before the page is given up.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(2);
/// Bytes queued for a page before it is given up (about 4 s of telemetry).
const MAX_QUEUED: usize = 4 * 1024 * 1024;

/// Serves one page until it closes, fails, falls behind or the console shuts down.
/// `leftover`: bytes read past the upgrade request.
pub fn serve(stream: TcpStream, leftover: Vec<u8>, hub: Arc<Hub>) {
    if stream.set_read_timeout(Some(POLL)).is_err()
        || stream.set_write_timeout(Some(WRITE_TIMEOUT)).is_err()
    {
        return;
    }
    let _ = stream.set_nodelay(true);
    let cfg = WebSocketConfig::default()
        .read_buffer_size(16 * 1024)
        .write_buffer_size(0)
        .max_write_buffer_size(MAX_QUEUED)
        .max_message_size(Some(MAX_MESSAGE))
        .max_frame_size(Some(MAX_MESSAGE));
    let addr = stream
        .peer_addr()
        .map_or_else(|_| "unknown address".into(), |a| a.to_string());
    let mut ws = WebSocket::from_partially_read(stream, leftover, Role::Server, Some(cfg));
    let page = Joined(&hub, hub.join(addr));
    // The page learns its own number first (to tell "you hold the controls" from another page).
    let you = serde_json::json!({"type": "page", "id": page.1.id, "name": page.1.name()});
    let (first, mut cursor) = hub.subscribe();
    if std::iter::once(Arc::from(you.to_string()))
        .chain(first)
        .try_for_each(|m| ws.write(Message::text(&*m)))
        .and_then(|()| ws.flush())
        .is_err()
    {
        return;
    }
    loop {
        if hub.shutdown.load(Ordering::SeqCst) {
            let _ = ws.close(None);
            let _ = ws.flush();
            return;
        }
        match ws.read() {
            Ok(Message::Text(t)) => {
                if let Err(e) = hub.handle(&page.1, t.as_str()) {
                    let m = serde_json::json!({"type": "error", "text": e});
                    if ws.write(Message::text(m.to_string())).is_err() {
                        return;
                    }
                }
            }
            Ok(Message::Close(_)) => {
                // tungstenite queued the answer; flush it and stop.
                let _ = ws.flush();
                return;
            }
            Ok(_) => {} // binary, ping (answered by tungstenite), pong
            Err(Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(_) => return, // protocol error, too large, closed: drop the page
        }
        let (msgs, next) = hub.since(cursor);
        cursor = next;
        for m in msgs {
            if ws.write(Message::text(&*m)).is_err() {
                return;
            }
        }
        if ws.flush().is_err() {
            return;
        }
    }
}
