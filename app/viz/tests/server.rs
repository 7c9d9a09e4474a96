//! The page server against bad input: path traversal, malformed and unknown
//! WebSocket messages, two clients at once, a client that vanishes mid-run.
//! Talks raw HTTP / WebSocket over TCP so nothing normalizes the requests.

use std::sync::Arc;
use std::time::Duration;

use seespot_sim::TaskId;
use seespot_viz::live;
use seespot_viz::registry::{self, DeciderKind};
use seespot_viz::server::{self, AppState};
use seespot_viz::session::{PairQuery, Session, SessionConfig};
use seespot_viz::token::AccessToken;
use serde_json::Value;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// A server on a free loopback port over a 64 px feature-baseline session.
async fn start() -> (std::net::SocketAddr, Arc<AppState>) {
    let (listener, state) = bind_session("127.0.0.1:0").await;
    let addr = listener.local_addr().expect("addr");
    let st = state.clone();
    tokio::spawn(
        async move { server::serve_page(listener, st, None, std::future::pending()).await },
    );
    (addr, state)
}

/// A listener on `addr` and a 64 px feature-baseline session to serve.
async fn bind_session(addr: &str) -> (tokio::net::TcpListener, Arc<AppState>) {
    let config = SessionConfig::at(TaskId::Stack, 1, 64);
    let factory = registry::factory(
        DeciderKind::Features,
        seespot_ssr::Layout::new("/nonexistent/models", "/nonexistent/demos"),
    );
    let session = tokio::task::spawn_blocking(move || Session::new(factory, config, None))
        .await
        .expect("join")
        .expect("session");
    let state = AppState::new(
        session,
        serde_json::json!({"viewer_url": null, "tasks": ["stack"]}),
    );
    let listener = tokio::net::TcpListener::bind(addr).await.expect("bind");
    (listener, state)
}

/// Sends a raw HTTP/1.1 request line for `target`; returns (status, body).
async fn raw_get(addr: std::net::SocketAddr, target: &str) -> (u16, String) {
    let mut s = TcpStream::connect(addr).await.expect("connect");
    let req = format!("GET {target} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.expect("write");
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).await.expect("read");
    let text = String::from_utf8_lossy(&buf).to_string();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = text.split("\r\n\r\n").nth(1).unwrap_or_default().to_owned();
    (status, body)
}

/// A minimal WebSocket client (RFC 6455): text frames only, client frames masked.
struct Ws {
    s: TcpStream,
}

impl Ws {
    async fn connect(addr: std::net::SocketAddr) -> Self {
        let mut s = TcpStream::connect(addr).await.expect("connect");
        let req = format!(
            "GET /ws HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
        );
        s.write_all(req.as_bytes()).await.expect("write");
        let mut head = Vec::new();
        let mut b = [0u8; 1];
        while !head.ends_with(b"\r\n\r\n") {
            s.read_exact(&mut b).await.expect("handshake");
            head.push(b[0]);
        }
        assert!(
            String::from_utf8_lossy(&head).starts_with("HTTP/1.1 101"),
            "{}",
            String::from_utf8_lossy(&head)
        );
        Self { s }
    }

    async fn send(&mut self, text: &str) {
        let payload = text.as_bytes();
        let mut frame = vec![0x81u8];
        let mask = [0x12u8, 0x34, 0x56, 0x78];
        if payload.len() < 126 {
            frame.push(0x80 | payload.len() as u8);
        } else {
            frame.push(0x80 | 126);
            frame.extend_from_slice(&(payload.len() as u16).to_be_bytes());
        }
        frame.extend_from_slice(&mask);
        frame.extend(payload.iter().enumerate().map(|(i, b)| b ^ mask[i % 4]));
        self.s.write_all(&frame).await.expect("send");
    }

    /// The next text message, parsed as JSON.
    async fn recv(&mut self) -> Value {
        loop {
            let mut h = [0u8; 2];
            self.s.read_exact(&mut h).await.expect("frame header");
            let mut len = u64::from(h[1] & 0x7f);
            if len == 126 {
                let mut l = [0u8; 2];
                self.s.read_exact(&mut l).await.expect("len16");
                len = u64::from(u16::from_be_bytes(l));
            } else if len == 127 {
                let mut l = [0u8; 8];
                self.s.read_exact(&mut l).await.expect("len64");
                len = u64::from_be_bytes(l);
            }
            let mut payload = vec![0u8; len as usize];
            self.s.read_exact(&mut payload).await.expect("payload");
            if h[0] & 0x0f == 1 {
                return serde_json::from_slice(&payload).expect("json");
            }
        }
    }

    /// Skips messages until one of type `ty` arrives.
    async fn until(&mut self, ty: &str) -> Value {
        let fut = async {
            loop {
                let m = self.recv().await;
                if m["type"] == ty {
                    return m;
                }
            }
        };
        tokio::time::timeout(Duration::from_secs(60), fut)
            .await
            .expect("timed out waiting for a message")
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn serves_only_embedded_assets() {
    let (addr, _) = start().await;
    let (status, body) = raw_get(addr, "/").await;
    assert_eq!(status, 200);
    assert!(body.contains("seespot"));
    assert_eq!(raw_get(addr, "/app.js").await.0, 200);
    for target in [
        "/../Cargo.toml",
        "/%2e%2e/Cargo.toml",
        "/%2e%2e%2fCargo.toml",
        "/..%2f..%2fCargo.toml",
        "/web/../Cargo.toml",
        "/app.js/../../Cargo.toml",
        "//etc/passwd",
        "/index.html%00.js",
        "/tests/page.test.js",
        "/package.json",
    ] {
        let (status, body) = raw_get(addr, target).await;
        assert_eq!(status, 404, "{target} answered {status}");
        assert!(
            !body.contains("[workspace]") && !body.contains("root:"),
            "{target} leaked a file"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_and_unknown_messages_get_errors_and_the_server_keeps_running() {
    let (addr, _) = start().await;
    let mut ws = Ws::connect(addr).await;
    ws.until("state").await;
    for bad in [
        "not json",
        "{\"no_type\": 1}",
        "{\"type\": \"fly\"}",
        "{\"type\": \"reset\", \"task\": \"juggle\"}",
        "{\"type\": \"reset\", \"seed\": -3}",
        "{\"type\": \"query\", \"pair\": \"x\"}",
        "[1,2,3]",
    ] {
        ws.send(bad).await;
        let m = ws.until("error").await;
        assert!(
            m["message"].as_str().is_some_and(|s| !s.is_empty()),
            "{bad}: {m}"
        );
        // The page words an error by its kind: a malformed request is one.
        assert_eq!(m["kind"], "request", "{bad}: {m}");
    }
    // A query before any decision is an error too, not a crash.
    ws.send("{\"type\": \"query\", \"pair\": 0, \"policy\": 0, \"y\": 1, \"x\": 1}")
        .await;
    let m = ws.until("error").await;
    assert_eq!(m["kind"], "request", "{m}");
    // Still serving: a real step works.
    ws.send("{\"type\": \"next_phase\"}").await;
    let s = ws.until("state").await;
    assert_eq!(s["phase"], "embed");
    assert_eq!(raw_get(addr, "/api/state").await.0, 200);
    // A malformed `pair` on either route gets the same 400 error document.
    for (route, request) in [("frame", "frame"), ("embedding", "embedding")] {
        let (status, body) = raw_get(addr, &format!("/api/{route}?pair=-1")).await;
        assert_eq!(status, 400, "{route}: {body}");
        assert!(
            body.contains("`pair` must be a non-negative integer")
                && body.contains(&format!("\"request\":\"{request}\"")),
            "{route}: {body}"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_clients_see_the_same_trial_and_a_vanished_client_stops_nothing() {
    let (addr, state) = start().await;
    let mut a = Ws::connect(addr).await;
    let mut b = Ws::connect(addr).await;
    a.until("state").await;
    b.until("state").await;
    a.send("{\"type\": \"next_phase\"}").await;
    let sa = a.until("state").await;
    let sb = b.until("state").await;
    assert_eq!(sa["version"], sb["version"]);
    assert_eq!(sb["phase"], "embed");
    // b asks a query; only b gets the answer, and it is the backend's answer.
    b.send("{\"type\": \"query\", \"pair\": 0, \"policy\": 1, \"y\": 30, \"x\": 30}")
        .await;
    let q = b.until("query").await;
    assert_eq!(q["policy"], 1);
    let direct = state
        .session()
        .query(PairQuery {
            pair: 0,
            policy: 1,
            y: 30,
            x: 30,
        })
        .expect("query");
    assert_eq!(q["map"], direct.map.as_str());
    // a starts a run to the end and disappears at once.
    a.send("{\"type\": \"run\"}").await;
    drop(a);
    let end = tokio::time::timeout(Duration::from_secs(120), async {
        loop {
            let m = b.until("state").await;
            if !m["end"].is_null() && !server::running(&state) {
                return m;
            }
        }
    })
    .await
    .expect("the run did not finish");
    assert!(end["action_index"].as_u64().is_some_and(|n| n > 0));
}

/// The status line of a raw request for `target` with the given extra headers.
async fn status_with(addr: std::net::SocketAddr, target: &str, headers: &str) -> String {
    let mut s = TcpStream::connect(addr).await.expect("connect");
    let req = format!("GET {target} HTTP/1.1\r\n{headers}Connection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.expect("write");
    // Only the status line: an accepted WebSocket upgrade keeps the connection open.
    let mut line = Vec::new();
    let mut b = [0u8; 1];
    while !line.ends_with(b"\r\n") {
        if s.read(&mut b).await.expect("read") == 0 {
            break;
        }
        line.push(b[0]);
    }
    String::from_utf8_lossy(&line).trim_end().to_owned()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_10_foreign_origin_and_host_are_refused() {
    let (addr, _) = start().await;
    let port = addr.port();
    let upgrade = "Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n";
    // Cross-site WebSocket hijacking: a page of another origin cannot connect.
    for origin in [
        "http://evil.example",
        "null",
        &format!("http://127.0.0.1.evil.example:{port}"),
        &format!("https://127.0.0.1:{port}"),
        "http://127.0.0.1:1",
    ] {
        let line = status_with(
            addr,
            "/ws",
            &format!("Host: {addr}\r\nOrigin: {origin}\r\n{upgrade}"),
        )
        .await;
        assert!(line.contains(" 403"), "Origin {origin}: {line}");
    }
    // DNS rebinding: a foreign Host is refused on every route.
    for target in ["/", "/api/state", "/api/decision", "/ws"] {
        let line = status_with(
            addr,
            target,
            &format!("Host: evil.example:{port}\r\n{upgrade}"),
        )
        .await;
        assert!(line.contains(" 403"), "{target}: {line}");
        let line = status_with(addr, target, "").await;
        assert!(
            line.contains(" 403") || line.contains(" 400"),
            "{target} without Host: {line}"
        );
    }
    // The page's own origin, under any loopback name, is served.
    for host in [addr.to_string(), format!("localhost:{port}")] {
        let line = status_with(
            addr,
            "/api/state",
            &format!("Host: {host}\r\nOrigin: http://{host}\r\n"),
        )
        .await;
        assert!(line.contains(" 200"), "{host}: {line}");
    }
    let line = status_with(
        addr,
        "/ws",
        &format!("Host: {addr}\r\nOrigin: http://{addr}\r\n{upgrade}"),
    )
    .await;
    assert!(line.contains(" 101"), "{line}");
}

/// A token-protected server bound to every interface (as `seespot view --bind
/// 0.0.0.0 --allow-remote`), reached here over 127.0.0.1.
async fn start_remote() -> (std::net::SocketAddr, AccessToken) {
    let (listener, state) = bind_session("0.0.0.0:0").await;
    let port = listener.local_addr().expect("addr").port();
    let token = AccessToken::random();
    let t = token.clone();
    tokio::spawn(async move {
        server::serve_page(listener, state, Some(t), std::future::pending()).await
    });
    (std::net::SocketAddr::from(([127, 0, 0, 1], port)), token)
}

/// The whole response head of a raw request (status line and headers).
async fn head_with(addr: std::net::SocketAddr, target: &str, headers: &str) -> String {
    let mut s = TcpStream::connect(addr).await.expect("connect");
    let req = format!("GET {target} HTTP/1.1\r\n{headers}Connection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.expect("write");
    let mut head = Vec::new();
    let mut b = [0u8; 1];
    while !head.ends_with(b"\r\n\r\n") {
        if s.read(&mut b).await.expect("read") == 0 {
            break;
        }
        head.push(b[0]);
    }
    String::from_utf8_lossy(&head).into_owned()
}

const UPGRADE: &str = "Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_10_non_loopback_bind_is_refused_without_allow_remote() {
    let opts = live::ViewOptions {
        task: TaskId::Stack,
        seed: 1,
        resolution: 64,
        noise: Default::default(),
        bind: "0.0.0.0".parse().expect("ip"),
        allow_remote: false,
        port: 0,
        viewer_port: 0,
        grpc_port: 0,
        save: None,
        no_viewer: true,
        layout: None,
        review: None,
        compare: Vec::new(),
        replay: None,
    };
    let factory = registry::factory(
        DeciderKind::Features,
        seespot_ssr::Layout::new("/nonexistent/models", "/nonexistent/demos"),
    );
    let e = live::serve_view(opts, factory, |_| panic!("served"), std::future::ready(()))
        .await
        .expect_err("a non-loopback bind without --allow-remote");
    assert!(e.to_string().contains("--allow-remote"), "{e}");
    // The server itself refuses to serve a non-loopback listener without a token.
    let (listener, state) = bind_session("0.0.0.0:0").await;
    let e = server::serve_page(listener, state, None, std::future::ready(()))
        .await
        .expect_err("a non-loopback listener without a token");
    assert!(e.to_string().contains("token"), "{e}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_10_remote_bind_needs_the_token_on_every_route() {
    let (addr, token) = start_remote().await;
    let host = format!("Host: {addr}\r\n");
    // No token, or a wrong one: 403 on the page, the API and the WebSocket.
    let wrong = "0".repeat(64);
    for target in ["/", "/app.js", "/api/state", "/api/info", "/ws"] {
        for (query, cookie) in [
            ("".to_owned(), "".to_owned()),
            (format!("?token={wrong}"), "".to_owned()),
            ("?token=".to_owned(), "".to_owned()),
            (
                "".to_owned(),
                format!("Cookie: seespot-token-{}={wrong}\r\n", addr.port()),
            ),
            (
                "".to_owned(),
                format!("Cookie: seespot-token-1={}\r\n", token.as_str()),
            ),
        ] {
            let line = status_with(
                addr,
                &format!("{target}{query}"),
                &format!("{host}{cookie}{UPGRADE}"),
            )
            .await;
            assert!(line.contains(" 403"), "{target}{query} {cookie}: {line}");
        }
    }
    // The printed URL's token opens the page and sets the cookie.
    let head = head_with(addr, &format!("/?token={}", token.as_str()), &host).await;
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    let set_cookie = head
        .lines()
        .find(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
        .unwrap_or_else(|| panic!("no cookie set: {head}"));
    let cookie_name = AccessToken::cookie_name(addr.port());
    assert!(
        set_cookie.contains(&format!("{cookie_name}={}", token.as_str())),
        "{set_cookie}"
    );
    assert!(set_cookie.contains("HttpOnly"), "{set_cookie}");
    assert!(set_cookie.contains("SameSite=Strict"), "{set_cookie}");
    // With the cookie, as the page's own requests carry it: 200 and 101.
    let cookie = format!("Cookie: other=1; {cookie_name}={}\r\n", token.as_str());
    for target in ["/app.js", "/api/state", "/api/info"] {
        let line = status_with(addr, target, &format!("{host}{cookie}")).await;
        assert!(line.contains(" 200"), "{target}: {line}");
    }
    let origin = format!("Origin: http://{addr}\r\n");
    let line = status_with(addr, "/ws", &format!("{host}{origin}{cookie}{UPGRADE}")).await;
    assert!(line.contains(" 101"), "{line}");
    // The token in the query string works for the WebSocket too.
    let line = status_with(
        addr,
        &format!("/ws?token={}", token.as_str()),
        &format!("{host}{UPGRADE}"),
    )
    .await;
    assert!(line.contains(" 101"), "{line}");
    // Another site's page cannot use it even with the cookie: its Origin is not the Host.
    let line = status_with(
        addr,
        "/ws",
        &format!("{host}Origin: http://evil.example\r\n{cookie}{UPGRADE}"),
    )
    .await;
    assert!(line.contains(" 403"), "{line}");
}
