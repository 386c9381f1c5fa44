//! The console's HTTP side: where a request head ends (bounded in bytes; the time bound and the
//! reading are [`super::gate`]'s), the access rules (token, Host, Origin) and the routes. Pure
//! functions of the request where possible, so the rules are unit-tested without a socket.

use std::io::Write;

/// Largest request head read, bytes (request line and headers).
pub const MAX_HEAD: usize = 8 * 1024;
/// Most headers parsed in one request.
pub const MAX_HEADERS: usize = 48;

/// One parsed request head.
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    /// `GET`, `POST`, …
    pub method: String,
    /// The path without the query.
    pub path: String,
    /// The query string (after `?`, empty without one).
    pub query: String,
    /// Header names (lower case) and values.
    pub headers: Vec<(String, String)>,
}

impl Request {
    /// The first header named `name` (lower case).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// How many headers are named `name`.
    fn count(&self, name: &str) -> usize {
        self.headers.iter().filter(|(n, _)| n == name).count()
    }

    /// The value of query parameter `name` (no percent-decoding: the token is hex).
    pub fn query_param(&self, name: &str) -> Option<&str> {
        self.query.split('&').find_map(|kv| {
            let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
            (k == name).then_some(v)
        })
    }
}

/// A request head that is over [`MAX_HEAD`] bytes without its end.
#[derive(Debug, PartialEq)]
pub struct TooLarge;

/// Where the request head in `buf` ends: the index just past its blank line (`\r\n\r\n`),
/// `None` while it has not arrived, [`TooLarge`] when [`MAX_HEAD`] bytes came without it.
/// `from`: how much of `buf` was searched before (the search resumes 3 bytes earlier, so a
/// head read one byte at a time costs linear time, not quadratic).
pub fn head_end(buf: &[u8], from: usize) -> Result<Option<usize>, TooLarge> {
    let start = from.saturating_sub(3).min(buf.len());
    match buf[start..].windows(4).position(|w| w == b"\r\n\r\n") {
        Some(i) if start + i + 4 <= MAX_HEAD => Ok(Some(start + i + 4)),
        Some(_) => Err(TooLarge),
        None if buf.len() >= MAX_HEAD => Err(TooLarge),
        None => Ok(None),
    }
}

/// Parses a complete head (`httparse`): `None` when it is not a valid HTTP/1.x request.
pub fn parse(head: &[u8]) -> Option<Request> {
    let mut hs = [httparse::EMPTY_HEADER; MAX_HEADERS];
    let mut r = httparse::Request::new(&mut hs);
    match r.parse(head) {
        Ok(httparse::Status::Complete(_)) => {}
        _ => return None,
    }
    let target = r.path?;
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let headers = r
        .headers
        .iter()
        .map(|h| {
            (
                h.name.to_ascii_lowercase(),
                String::from_utf8_lossy(h.value).trim().to_string(),
            )
        })
        .collect();
    Some(Request {
        method: r.method?.to_string(),
        path: path.to_string(),
        query: query.to_string(),
        headers,
    })
}

/// Who may use the console: the per-start token, and the names this server answers to.
#[derive(Debug, Clone)]
pub struct Policy {
    /// The random per-start token (lower-case hex).
    pub token: String,
    /// The port the server is bound to.
    pub port: u16,
    /// Bound to a loopback address: only loopback Host names are served (a DNS-rebinding
    /// page that resolves its own name to 127.0.0.1 is refused by its Host header).
    pub loopback: bool,
}

/// Where an allowed request goes.
#[derive(Debug, PartialEq)]
pub enum PageRoute {
    /// The page (its HTML).
    Page,
    /// An embedded asset: content type and body.
    Asset(&'static str, &'static str),
    /// A websocket upgrade, with the client's `Sec-WebSocket-Key`.
    WebSocket(String),
}

/// A refusal: HTTP status and a one-line reason (the response body).
pub type Refusal = (u16, &'static str);

/// The page's files, embedded in the binary (no CDN: the machine may be offline).
pub const INDEX_HTML: &str = include_str!("../../console/index.html");
/// The page's script.
pub const APP_JS: &str = include_str!("../../console/app.js");
/// The page's style sheet.
pub const STYLE_CSS: &str = include_str!("../../console/style.css");

/// Compares two byte strings in time independent of where they differ.
pub fn ct_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// Whether `host` (a Host header, or the authority of an Origin) names this server on a
/// loopback name: `127.0.0.1:PORT`, `localhost:PORT` or `[::1]:PORT`.
fn loopback_host(host: &str, port: u16) -> bool {
    let h = host.to_ascii_lowercase();
    ["127.0.0.1", "localhost", "[::1]"]
        .iter()
        .any(|n| h == format!("{n}:{port}"))
}

/// The access rules and routes, in order: GET only (405); one Host header naming this
/// server when bound to loopback (403); the token (403); then the path — `/`, `/app.js`,
/// `/style.css`, and `/ws`, a websocket upgrade whose Origin is this page's own origin
/// (`http://` + the Host header; 403 otherwise) — and 404 for anything else.
pub fn route(r: &Request, p: &Policy) -> Result<PageRoute, Refusal> {
    if r.method != "GET" {
        return Err((405, "method not allowed: the console serves GET only"));
    }
    let host = match (r.count("host"), r.header("host")) {
        (1, Some(h)) => h,
        _ => return Err((400, "bad request: exactly one Host header is required")),
    };
    if p.loopback && !loopback_host(host, p.port) {
        return Err((
            403,
            "forbidden: this console answers only to 127.0.0.1, localhost or [::1] on its port",
        ));
    }
    let token_ok = r
        .query
        .split('&')
        .filter(|kv| kv.starts_with("token="))
        .count()
        == 1
        && r.query_param("token")
            .is_some_and(|t| ct_eq(t.as_bytes(), p.token.as_bytes()));
    if !token_ok {
        return Err((
            403,
            "forbidden: missing or wrong token (open the URL the console printed)",
        ));
    }
    match r.path.as_str() {
        "/" | "/index.html" => Ok(PageRoute::Page),
        "/app.js" => Ok(PageRoute::Asset("text/javascript; charset=utf-8", APP_JS)),
        "/style.css" => Ok(PageRoute::Asset("text/css; charset=utf-8", STYLE_CSS)),
        "/ws" => {
            let origin_ok = r.count("origin") == 1
                && r.header("origin").is_some_and(|o| {
                    o.strip_prefix("http://")
                        .is_some_and(|a| a.eq_ignore_ascii_case(host))
                });
            if !origin_ok {
                return Err((
                    403,
                    "forbidden: websocket Origin must be this console's own page",
                ));
            }
            let upgrade = r
                .header("upgrade")
                .is_some_and(|u| u.eq_ignore_ascii_case("websocket"));
            let connection = r.header("connection").is_some_and(|c| {
                c.split(',')
                    .any(|t| t.trim().eq_ignore_ascii_case("upgrade"))
            });
            let version = r.header("sec-websocket-version") == Some("13");
            match r.header("sec-websocket-key") {
                Some(k) if upgrade && connection && version && !k.is_empty() && k.len() <= 64 => {
                    Ok(PageRoute::WebSocket(k.to_string()))
                }
                _ => Err((
                    400,
                    "bad request: /ws takes a websocket upgrade (version 13)",
                )),
            }
        }
        _ => Err((404, "not found")),
    }
}

/// Security headers of every response: no caching, no framing, no referrer (the token is in
/// the URL), scripts and styles only from this server.
const SECURITY_HEADERS: &str = "Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nX-Frame-Options: DENY\r\nReferrer-Policy: no-referrer\r\nContent-Security-Policy: default-src 'none'; script-src 'self'; style-src 'self'; connect-src 'self'; img-src 'self' data:; frame-ancestors 'none'\r\n";

/// Writes a complete response and closes the exchange (`Connection: close`).
pub fn respond(w: &mut impl Write, status: u16, ctype: &str, body: &[u8]) -> std::io::Result<()> {
    let reason = match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "Error",
    };
    let head = format!(
        "HTTP/1.1 {status} {reason}\r\nContent-Type: {ctype}\r\nContent-Length: {}\r\nConnection: close\r\n{SECURITY_HEADERS}\r\n",
        body.len()
    );
    w.write_all(head.as_bytes())?;
    w.write_all(body)?;
    w.flush()
}

/// The answer to a websocket upgrade (RFC 6455 §4.2.2).
pub fn upgrade_response(key: &str) -> String {
    format!(
        "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {}\r\n\r\n",
        tungstenite::handshake::derive_accept_key(key.as_bytes())
    )
}

/// The page's HTML with the token in its asset URLs.
pub fn page(token: &str) -> String {
    INDEX_HTML.replace("{{TOKEN}}", token)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy() -> Policy {
        Policy {
            token: "0123456789abcdef0123456789abcdef".into(),
            port: 8090,
            loopback: true,
        }
    }

    fn req(raw: &str) -> Request {
        parse(raw.as_bytes()).expect("parses")
    }

    const T: &str = "0123456789abcdef0123456789abcdef";

    fn ws_req(host: &str, origin: Option<&str>, token: &str) -> Request {
        let o = origin
            .map(|o| format!("Origin: {o}\r\n"))
            .unwrap_or_default();
        req(&format!(
            "GET /ws?token={token} HTTP/1.1\r\nHost: {host}\r\n{o}Upgrade: websocket\r\nConnection: keep-alive, Upgrade\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n"
        ))
    }

    #[test]
    fn token_is_required_on_every_path() {
        let p = policy();
        for path in ["/", "/app.js", "/style.css", "/ws", "/nothing"] {
            for q in [
                "",
                "?token=",
                "?token=0123",
                "?tok=x",
                &format!("?token={T}x"),
            ] {
                let r = req(&format!(
                    "GET {path}{q} HTTP/1.1\r\nHost: 127.0.0.1:8090\r\n\r\n"
                ));
                assert_eq!(route(&r, &p).unwrap_err().0, 403, "{path}{q}");
            }
        }
        // A second token parameter is refused even when one of them is right.
        let r = req(&format!(
            "GET /?token=x&token={T} HTTP/1.1\r\nHost: 127.0.0.1:8090\r\n\r\n"
        ));
        assert_eq!(route(&r, &p).unwrap_err().0, 403);
        let r = req(&format!(
            "GET /?token={T} HTTP/1.1\r\nHost: localhost:8090\r\n\r\n"
        ));
        assert_eq!(route(&r, &p), Ok(PageRoute::Page));
        let r = req(&format!(
            "GET /app.js?x=1&token={T} HTTP/1.1\r\nHost: [::1]:8090\r\n\r\n"
        ));
        assert!(matches!(route(&r, &p), Ok(PageRoute::Asset(..))));
    }

    #[test]
    fn host_must_be_loopback_when_bound_to_loopback() {
        let p = policy();
        for host in [
            "evil.example:8090",
            "127.0.0.1:8091",
            "127.0.0.1",
            "attacker.test",
        ] {
            let r = req(&format!("GET /?token={T} HTTP/1.1\r\nHost: {host}\r\n\r\n"));
            assert_eq!(route(&r, &p).unwrap_err().0, 403, "{host}");
        }
        let r = req(&format!("GET /?token={T} HTTP/1.1\r\n\r\n"));
        assert_eq!(route(&r, &p).unwrap_err().0, 400);
        let r = req(&format!(
            "GET /?token={T} HTTP/1.1\r\nHost: 127.0.0.1:8090\r\nHost: evil:8090\r\n\r\n"
        ));
        assert_eq!(route(&r, &p).unwrap_err().0, 400);
        // Bound to 0.0.0.0 the names are the network's: any Host, the token still required.
        let open = Policy {
            loopback: false,
            ..policy()
        };
        let r = req(&format!(
            "GET /?token={T} HTTP/1.1\r\nHost: robot-pc.lan:8090\r\n\r\n"
        ));
        assert_eq!(route(&r, &open), Ok(PageRoute::Page));
        let r = req("GET / HTTP/1.1\r\nHost: robot-pc.lan:8090\r\n\r\n");
        assert_eq!(route(&r, &open).unwrap_err().0, 403);
    }

    #[test]
    fn websocket_origin_must_be_the_page() {
        let p = policy();
        assert_eq!(
            route(
                &ws_req("127.0.0.1:8090", Some("http://127.0.0.1:8090"), T),
                &p
            ),
            Ok(PageRoute::WebSocket("dGhlIHNhbXBsZSBub25jZQ==".into()))
        );
        for o in [
            None,
            Some("http://evil.example"),
            Some("https://127.0.0.1:8090"),
            Some("http://localhost:8090"), // another origin than the Host the page used
            Some("null"),
            Some("http://127.0.0.1:8090.evil.example"),
        ] {
            let r = ws_req("127.0.0.1:8090", o, T);
            assert_eq!(route(&r, &p).unwrap_err().0, 403, "{o:?}");
        }
        // The token is checked on the upgrade too.
        let r = ws_req("127.0.0.1:8090", Some("http://127.0.0.1:8090"), "nope");
        assert_eq!(route(&r, &p).unwrap_err().0, 403);
        // A plain GET of /ws is not an upgrade.
        let r = req(&format!(
            "GET /ws?token={T} HTTP/1.1\r\nHost: 127.0.0.1:8090\r\nOrigin: http://127.0.0.1:8090\r\n\r\n"
        ));
        assert_eq!(route(&r, &p).unwrap_err().0, 400);
    }

    #[test]
    fn only_get() {
        let r = req(&format!(
            "POST /?token={T} HTTP/1.1\r\nHost: 127.0.0.1:8090\r\nContent-Length: 0\r\n\r\n"
        ));
        assert_eq!(route(&r, &policy()).unwrap_err().0, 405);
    }

    #[test]
    fn heads_are_bounded() {
        let big = vec![b'a'; MAX_HEAD + 2048];
        assert_eq!(head_end(&big, 0), Err(TooLarge));
        assert_eq!(head_end(&big[..MAX_HEAD - 1], 0), Ok(None));
        // The end just inside the bound is a head; one byte further is not.
        let mut edge = vec![b'a'; MAX_HEAD - 4];
        edge.extend_from_slice(b"\r\n\r\n");
        assert_eq!(head_end(&edge, 0), Ok(Some(MAX_HEAD)));
        edge.insert(0, b'a');
        assert_eq!(head_end(&edge, 0), Err(TooLarge));
        assert_eq!(head_end(b"GET / HTTP/1.1\r\n", 0), Ok(None));
        let full = b"GET / HTTP/1.1\r\nHost: x\r\n\r\nabc";
        assert_eq!(head_end(full, 0), Ok(Some(full.len() - 3)));
        // Garbage is not a request.
        assert!(parse(b"\x00\x01\x02\r\n\r\n").is_none());
        assert!(parse(b"GET\r\n\r\n").is_none());
    }

    #[test]
    fn a_head_read_a_byte_at_a_time_is_found_where_it_ends() {
        let full = b"GET / HTTP/1.1\r\nHost: x\r\n\r\nrest";
        let mut searched = 0;
        for n in 1..=full.len() {
            let got = head_end(&full[..n], searched).unwrap();
            searched = n;
            if n < full.len() - 4 {
                assert_eq!(got, None, "{n} bytes");
            } else {
                assert_eq!(got, Some(full.len() - 4), "{n} bytes");
                return;
            }
        }
        panic!("the end was never found");
    }

    #[test]
    fn accept_key_matches_rfc6455() {
        // RFC 6455 §1.3's example.
        assert!(
            upgrade_response("dGhlIHNhbXBsZSBub25jZQ==").contains("s3pPLMBiTxaQ9kYGzzhZRbK+xOo=")
        );
    }

    #[test]
    fn page_carries_the_token_and_the_test_hooks() {
        let p = page(T);
        assert!(!p.contains("{{TOKEN}}"));
        assert!(p.contains(&format!("app.js?token={T}")));
        for id in ["pose", "estop", "link-state", "plan-upload"] {
            assert!(p.contains(&format!("data-testid=\"{id}\"")), "{id}");
        }
        assert!(!p.contains("http://") && !p.contains("https://"), "no CDN");
    }
}
