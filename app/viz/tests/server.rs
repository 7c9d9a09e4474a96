//! The page server against bad input: path traversal, malformed and unknown
//! WebSocket messages, two clients at once, a client that vanishes mid-run.
//! Talks raw HTTP / WebSocket over TCP so nothing normalizes the requests.

use std::sync::Arc;
use std::time::Duration;

use seespot_sim::{Grid, TaskId, WorldConfig};
use seespot_viz::live::{self, DeciderKind};
use seespot_viz::server::{self, AppState};
use seespot_viz::session::{Session, SessionConfig};
use serde_json::Value;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// A server on a free port over a 64 px feature-baseline session.
async fn start() -> (std::net::SocketAddr, Arc<AppState>) {
    let config = SessionConfig {
        task: TaskId::Stack,
        seed: 1,
        world: WorldConfig {
            grid: Grid::new(64),
            ..WorldConfig::default()
        },
    };
    let factory = live::factory(
        DeciderKind::Features,
        "/nonexistent/models".into(),
        "/nonexistent/demos".into(),
    );
    let session = tokio::task::spawn_blocking(move || Session::new(factory, config, None))
        .await
        .expect("join")
        .expect("session");
    let state = AppState::new(
        session,
        serde_json::json!({"viewer_url": null, "tasks": ["stack"]}),
    );
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let addr = listener.local_addr().expect("addr");
    let st = state.clone();
    tokio::spawn(async move { server::serve_page(listener, st, std::future::pending()).await });
    (addr, state)
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
    }
    // A query before any decision is an error too, not a crash.
    ws.send("{\"type\": \"query\", \"pair\": 0, \"policy\": 0, \"y\": 1, \"x\": 1}")
        .await;
    ws.until("error").await;
    // Still serving: a real step works.
    ws.send("{\"type\": \"next_phase\"}").await;
    let s = ws.until("state").await;
    assert_eq!(s["phase"], "embed");
    assert_eq!(raw_get(addr, "/api/state").await.0, 200);
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
    let direct = state.session().query(0, 1, 30, 30).expect("query");
    assert_eq!(q["map"], direct["map"]);
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
