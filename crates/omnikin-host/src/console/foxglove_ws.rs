//! `console --foxglove ADDR`: the console's telemetry live over the Foxglove WebSocket protocol
//! (`foxglove.websocket.v1`), on the same channels and with the same JSON messages as the MCAP
//! files (the MCAP writer's [`Encoder`](omnikin_io::mcap_log::Encoder)), so Foxglove's "Open
//! connection" shows what a recording would hold.
//!
//! Read-only: the server advertises the channels, takes `subscribe` / `unsubscribe` and sends
//! `messageData` frames; it offers no client publishing, services or parameters. The same
//! rules as the page: the console's token in the URL, loopback Host names when bound to
//! loopback; any Origin (Foxglove's desktop app sends none, its web app its own).

use std::collections::HashMap;
use std::io::Write;
use std::net::TcpStream;
use std::sync::atomic::Ordering;

use serde_json::json;
use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Error, Message, WebSocket};

pub use super::foxglove_hub::FoxHub;
use super::foxglove_hub::{advertise, apply, message_data};
use super::http;
use super::hub::Hub;

/// The subprotocol Foxglove asks for.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Largest client message, bytes (subscribe lists are short).
const MAX_CLIENT_MESSAGE: usize = 64 * 1024;
/// Bytes queued for a client before it is given up.
const MAX_QUEUED: usize = 4 * 1024 * 1024;

/// The access rules for a request head on the Foxglove port: the same as the page's socket
/// except the Origin (the page's own is stood in, so only the token, the Host and the upgrade
/// are checked). The upgrade answer, with the subprotocol when the client asked for it, or
/// the refusal.
pub fn admit(head: &[u8], policy: &http::Policy) -> Result<String, http::Refusal> {
    let mut req = http::parse(head).ok_or((400, "bad request"))?;
    let host = req.header("host").unwrap_or("").to_string();
    req.headers.retain(|(n, _)| n != "origin");
    req.headers
        .push(("origin".into(), format!("http://{host}")));
    req.path = "/ws".into();
    let key = match http::route(&req, policy)? {
        http::PageRoute::WebSocket(k) => k,
        // `route` gives a websocket or a refusal for `/ws`.
        _ => return Err((400, "bad request: a websocket upgrade is required")),
    };
    let proto = req
        .header("sec-websocket-protocol")
        .is_some_and(|p| p.split(',').any(|s| s.trim() == SUBPROTOCOL));
    let mut answer = http::upgrade_response(&key);
    if proto {
        answer.truncate(answer.len() - 2);
        answer.push_str(&format!("Sec-WebSocket-Protocol: {SUBPROTOCOL}\r\n\r\n"));
    }
    Ok(answer)
}

/// One admitted client: sends the upgrade `answer`, then [`serve`]s until it closes, fails,
/// falls behind or the console shuts down. `leftover`: bytes read past the request head.
pub fn exchange(mut stream: TcpStream, answer: &str, leftover: Vec<u8>, hub: &Hub, fox: &FoxHub) {
    if stream.set_nonblocking(false).is_err()
        || stream
            .set_write_timeout(Some(super::ws::WRITE_TIMEOUT))
            .is_err()
        || stream
            .write_all(answer.as_bytes())
            .and_then(|()| stream.flush())
            .is_err()
    {
        return;
    }
    serve(stream, leftover, hub, fox);
}

fn serve(stream: TcpStream, leftover: Vec<u8>, hub: &Hub, fox: &FoxHub) {
    if stream.set_read_timeout(Some(super::ws::POLL)).is_err() {
        return;
    }
    let _ = stream.set_nodelay(true);
    let cfg = WebSocketConfig::default()
        .read_buffer_size(8 * 1024)
        .write_buffer_size(0)
        .max_write_buffer_size(MAX_QUEUED)
        .max_message_size(Some(MAX_CLIENT_MESSAGE))
        .max_frame_size(Some(MAX_CLIENT_MESSAGE));
    let mut ws = WebSocket::from_partially_read(stream, leftover, Role::Server, Some(cfg));
    let info = json!({"op": "serverInfo", "name": "omnikin console", "capabilities": [],
        "supportedEncodings": [], "metadata": {}, "sessionId": crate::link_io::epoch_seq().to_string()});
    if ws.write(Message::text(info.to_string())).is_err()
        || ws.write(Message::text(advertise().to_string())).is_err()
        || ws.flush().is_err()
    {
        return;
    }
    let mut subs: HashMap<u32, u32> = HashMap::new();
    let mut cursor = fox.cursor();
    while !hub.shutdown.load(Ordering::SeqCst) {
        match ws.read() {
            Ok(Message::Text(t)) => apply(t.as_str(), &mut subs),
            Ok(Message::Close(_)) => {
                let _ = ws.flush();
                return;
            }
            Ok(_) => {}
            Err(Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(_) => return,
        }
        let (msgs, next) = fox.since(cursor);
        cursor = next;
        for (channel, ns, data) in msgs {
            if let Some(sid) = subs.get(&channel)
                && ws
                    .write(Message::binary(message_data(*sid, ns, &data)))
                    .is_err()
            {
                return;
            }
        }
        if ws.flush().is_err() {
            return;
        }
    }
    let _ = ws.close(None);
    let _ = ws.flush();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn admission_takes_the_token_and_host_but_any_origin() {
        let p = http::Policy {
            token: "0123456789abcdef0123456789abcdef".into(),
            port: 8765,
            loopback: true,
        };
        let head = |target: &str, host: &str, extra: &str| {
            format!(
                "GET {target} HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n{extra}\r\n"
            )
        };
        let t = "/?token=0123456789abcdef0123456789abcdef";
        let ok = admit(
            head(t, "127.0.0.1:8765", "Origin: https://app.foxglove.dev\r\n").as_bytes(),
            &p,
        )
        .unwrap();
        assert!(ok.starts_with("HTTP/1.1 101") && !ok.contains("Sec-WebSocket-Protocol"));
        let ok = admit(
            head(
                t,
                "localhost:8765",
                &format!("Sec-WebSocket-Protocol: {SUBPROTOCOL}\r\n"),
            )
            .as_bytes(),
            &p,
        )
        .unwrap();
        assert!(ok.ends_with(&format!("Sec-WebSocket-Protocol: {SUBPROTOCOL}\r\n\r\n")));
        assert_eq!(
            admit(head("/", "127.0.0.1:8765", "").as_bytes(), &p)
                .unwrap_err()
                .0,
            403
        );
        assert_eq!(
            admit(head(t, "evil.example:8765", "").as_bytes(), &p)
                .unwrap_err()
                .0,
            403
        );
        assert_eq!(admit(b"\x00garbage\r\n\r\n", &p).unwrap_err().0, 400);
    }
}
