//! The local web server behind `web/`: the page's assets (embedded in the
//! binary, so nothing else on disk can be served), a small JSON API and a
//! WebSocket that steps the trial and answers click-to-query.
//!
//! WebSocket protocol: the message types of [`crate::protocol`]; every tab gets
//! `{"type": "state", ...}` after each change (see [`Session::state`]).
//!
//! A tab that disconnects changes nothing: stepping runs on blocking tasks that
//! finish whether or not anyone still listens.
//!
//! Access: every request must name this server in `Host` (and `Origin`, when
//! present; see [`AllowedHosts`]). A server on a non-loopback address also
//! needs the run's [`AccessToken`] on every request (`?token=` or its cookie).

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use axum::Router;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::{StatusCode, Uri, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use futures_util::{SinkExt, StreamExt};
use serde_json::Value;
use tokio::sync::{broadcast, mpsc};

use crate::documents::to_text;
use crate::error::VizError;
use crate::protocol::{ClientMessage, ServerMessage};
use crate::review::ReviewSource;
use crate::session::{PairQuery, PreparedReplay, Session};
use crate::token::AccessToken;
use seespot_sim::TaskId;

mod access;
mod assets;
mod difference;

pub use access::AllowedHosts;
use access::{Access, guard};

pub use assets::ASSETS;

/// Largest WebSocket message accepted from a tab, bytes.
pub const MAX_MESSAGE_BYTES: usize = 16 * 1024;

/// Shared by every request.
pub struct AppState {
    session: Mutex<Session>,
    tx: broadcast::Sender<String>,
    running: AtomicBool,
    /// Static facts for the page: the rerun viewer's URL, versions.
    info: Value,
    /// The evaluation `/review` lists, and its document once built.
    review: Option<ReviewSource>,
    review_doc: Mutex<Option<crate::documents::ReviewDoc>>,
    /// The two trials the difference view shows, once opened.
    difference: Mutex<Option<crate::difference::Difference>>,
    /// Other evaluations the difference view can compare with (folders 1, 2, ...).
    compare: Mutex<Vec<ReviewSource>>,
    /// The replay being prepared, in words, if one is.
    preparing: Mutex<Option<String>>,
}

impl std::fmt::Debug for AppState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AppState")
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

impl AppState {
    pub fn new(session: Session, info: Value) -> Arc<Self> {
        Self::with_review(session, info, None)
    }

    /// [`Self::new`] with an evaluation for `/review` to list and replay.
    pub fn with_review(session: Session, info: Value, review: Option<ReviewSource>) -> Arc<Self> {
        let (tx, _) = broadcast::channel(64);
        Arc::new(Self {
            session: Mutex::new(session),
            tx,
            running: AtomicBool::new(false),
            info,
            review,
            review_doc: Mutex::new(None),
            difference: Mutex::new(None),
            compare: Mutex::new(Vec::new()),
            preparing: Mutex::new(None),
        })
    }

    /// Other evaluations whose runs the difference view can set beside the
    /// reviewed one's, named `N:RUN` (N from 1, in this order).
    pub fn set_compare(&self, compare: Vec<ReviewSource>) {
        *self
            .compare
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = compare;
    }

    /// The reviewed evaluation (folder 0), then the others, if it reviews one.
    fn sources(&self) -> Option<Vec<ReviewSource>> {
        let first = self.review.clone()?;
        let others = self
            .compare
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone();
        Some(std::iter::once(first).chain(others).collect())
    }

    /// The page's facts as of now: the static ones, with the task box's
    /// tasks listed afresh (the built-in tasks, then every custom task with
    /// demonstrations in the demos folder, one saved a moment ago included).
    fn info_now(&self) -> Value {
        let mut info = self.info.clone();
        if let Some(r) = &self.review {
            info["tasks"] = serde_json::json!(
                seespot_sim::TaskId::ALL
                    .into_iter()
                    .chain(r.layout.custom_tasks())
                    .map(|t| t.to_string())
                    .collect::<Vec<_>>()
            );
        }
        info
    }

    /// Locks the session; a panic while stepping does not poison the server.
    pub fn session(&self) -> MutexGuard<'_, Session> {
        self.session
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// What every tab is sent from now on (states, `busy`), as JSON text.
    pub fn subscribe(&self) -> broadcast::Receiver<String> {
        self.tx.subscribe()
    }

    fn broadcast_state(&self) {
        let s = to_text(&self.session().state());
        // No receivers is fine: nobody is watching.
        let _ = self.tx.send(s);
    }
}

/// The router: assets, `/api/*` and `/ws`.
pub fn router(state: Arc<AppState>) -> Router {
    Router::new()
        .route("/api/info", get(info))
        .route("/api/state", get(api_state))
        .route("/api/decision", get(api_decision))
        .route("/api/frame", get(api_frame))
        .route("/api/scene", get(api_scene))
        .route("/api/embedding", get(api_embedding))
        .route("/api/review", get(api_review))
        .route("/api/replay.rrd", get(api_replay_rrd))
        .route("/api/divergences", get(difference::divergences))
        .route("/api/runs", get(difference::runs))
        .route("/api/difference", get(difference::open))
        .route("/api/difference/view", get(difference::view))
        .route("/ws", get(ws))
        .fallback(asset)
        .with_state(state)
}

/// Serves an embedded asset by exact path, else 404. Paths are never mapped to
/// the file system.
async fn asset(uri: Uri) -> Response {
    match ASSETS.iter().find(|(p, _, _)| *p == uri.path()) {
        Some((_, ty, body)) => (
            [
                (header::CONTENT_TYPE, *ty),
                (header::CACHE_CONTROL, "no-cache"),
            ],
            *body,
        )
            .into_response(),
        None => (StatusCode::NOT_FOUND, "not found").into_response(),
    }
}

async fn info(State(s): State<Arc<AppState>>) -> Response {
    let st = s.clone();
    let info = tokio::task::spawn_blocking(move || st.info_now())
        .await
        .unwrap_or_else(|_| s.info.clone());
    axum::Json(info).into_response()
}

async fn api_state(State(s): State<Arc<AppState>>) -> Response {
    let st = s.clone();
    blocking(move || st.session().state()).await
}

async fn api_decision(
    State(s): State<Arc<AppState>>,
    Query(q): Query<HashMap<String, String>>,
) -> Response {
    let maps = q.get("maps").is_some_and(|v| v == "1" || v == "true");
    let st = s.clone();
    blocking(move || st.session().decision_json(maps)).await
}

/// The `pair` query field (0 when absent); `None` when it is not a
/// non-negative integer.
fn pair_param(q: &HashMap<String, String>) -> Option<usize> {
    q.get("pair").map_or(Some(0), |p| p.parse().ok())
}

/// The 400 for a malformed `pair`: the error message document naming `request`.
fn bad_pair(request: &'static str) -> Response {
    (
        StatusCode::BAD_REQUEST,
        ServerMessage::Error {
            message: "`pair` must be a non-negative integer".into(),
            request: Some(request),
            kind: "request",
        }
        .to_text(),
    )
        .into_response()
}

async fn api_frame(
    State(s): State<Arc<AppState>>,
    Query(q): Query<HashMap<String, String>>,
) -> Response {
    let Some(pair) = pair_param(&q) else {
        return bad_pair("frame");
    };
    let st = s.clone();
    blocking(move || st.session().frame(pair)).await
}

/// What a pair's policy sees, as colours (`Session::embedding`); 409 when
/// there is nothing to show.
async fn api_embedding(
    State(s): State<Arc<AppState>>,
    Query(q): Query<HashMap<String, String>>,
) -> Response {
    let Some(pair) = pair_param(&q) else {
        return bad_pair("embedding");
    };
    let st = s.clone();
    blocking_or_conflict(
        move || st.session().embedding(pair),
        |v| axum::Json(v).into_response(),
    )
    .await
}

/// The review of the server's evaluation ([`ReviewSource::document`]); 404
/// when it reviews none, 409 when its records cannot be read.
async fn api_review(State(s): State<Arc<AppState>>) -> Response {
    let Some(src) = s.review.clone() else {
        return (
            StatusCode::NOT_FOUND,
            "this debugger reviews no evaluation (seespot view --review DIR)",
        )
            .into_response();
    };
    let st = s.clone();
    let doc = move || {
        let mut cached = st
            .review_doc
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if cached.is_none() {
            *cached = Some(src.document()?);
        }
        Ok::<_, crate::error::VizError>(cached.clone().unwrap_or_default())
    };
    blocking_or_conflict(doc, |v| axum::Json(v).into_response()).await
}

/// A trial of the reviewed evaluation, named by `method`, `task` and `seed`,
/// run again to its end: its rerun recording as a download.
async fn api_replay_rrd(
    State(s): State<Arc<AppState>>,
    Query(q): Query<HashMap<String, String>>,
) -> Response {
    let Some(src) = s.review.clone() else {
        return (StatusCode::NOT_FOUND, "this debugger reviews no evaluation").into_response();
    };
    let field = |k: &str| {
        q.get(k)
            .cloned()
            .ok_or_else(|| format!("query field `{k}` is missing"))
    };
    let parsed = (|| {
        let method = field("method")?;
        let task: TaskId = field("task")?
            .parse()
            .map_err(|e| format!("query field `task`: {e}"))?;
        let seed: u64 = field("seed")?
            .parse()
            .map_err(|e| format!("query field `seed`: {e}"))?;
        Ok::<_, String>((method, task, seed))
    })();
    let (method, task, seed) = match parsed {
        Ok(p) => p,
        Err(e) => return (StatusCode::BAD_REQUEST, e).into_response(),
    };
    let name = format!(
        "attachment; filename=\"{method}-{}-{seed}.rrd\"",
        task.file_stem()
    );
    blocking_or_conflict(
        move || src.record(&method, task, seed),
        |bytes| {
            (
                [
                    (header::CONTENT_TYPE, "application/octet-stream".to_owned()),
                    (header::CONTENT_DISPOSITION, name),
                ],
                bytes,
            )
                .into_response()
        },
    )
    .await
}

/// The current layout as a scene file (`seespot view --scene` starts from it),
/// offered as a download.
async fn api_scene(State(s): State<Arc<AppState>>) -> Response {
    let st = s.clone();
    blocking_or_conflict(
        move || st.session().layout_toml(),
        |text| {
            (
                [
                    (header::CONTENT_TYPE, "application/toml; charset=utf-8"),
                    (
                        header::CONTENT_DISPOSITION,
                        "attachment; filename=\"seespot-layout.toml\"",
                    ),
                ],
                text,
            )
                .into_response()
        },
    )
    .await
}

/// Runs `f` on a blocking thread: its value through `ok`, its error as 409
/// (the request cannot be served in this state), a panic as 500.
async fn blocking_or_conflict<T: Send + 'static>(
    f: impl FnOnce() -> crate::error::Result<T> + Send + 'static,
    ok: impl FnOnce(T) -> Response,
) -> Response {
    match tokio::task::spawn_blocking(f).await {
        Ok(Ok(v)) => ok(v),
        Ok(Err(e)) => (StatusCode::CONFLICT, e.to_string()).into_response(),
        Err(e) => (
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("internal error: {e}"),
        )
            .into_response(),
    }
}

async fn blocking<T: serde::Serialize + Send + 'static>(
    f: impl FnOnce() -> T + Send + 'static,
) -> Response {
    match tokio::task::spawn_blocking(f).await {
        Ok(v) => axum::Json(v).into_response(),
        Err(e) => (
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("internal error: {e}"),
        )
            .into_response(),
    }
}

async fn ws(State(s): State<Arc<AppState>>, upgrade: WebSocketUpgrade) -> Response {
    upgrade
        .max_message_size(MAX_MESSAGE_BYTES)
        .on_upgrade(move |socket| client(socket, s))
}

fn error(message: impl Into<String>, request: Option<&str>) -> String {
    failed(&VizError::request(message), request)
}

/// The error message of a request that failed with `e`, with its kind.
fn failed(e: &VizError, request: Option<&str>) -> String {
    ServerMessage::Error {
        message: e.to_string(),
        request,
        kind: e.kind(),
    }
    .to_text()
}

/// One tab: forwards broadcasts and direct replies, and handles its requests.
async fn client(socket: WebSocket, s: Arc<AppState>) {
    let (mut sink, mut stream) = socket.split();
    // Raised when this tab leaves: a replay it asked for stops finetuning.
    let left = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let mut rx = s.tx.subscribe();
    let (direct_tx, mut direct_rx) = mpsc::channel::<String>(16);
    let info = s.info_now();
    let hello = ServerMessage::Info { info: &info }.to_text();
    let st = s.clone();
    let state = tokio::task::spawn_blocking(move || to_text(&st.session().state()))
        .await
        .unwrap_or_default();
    let writer = tokio::spawn(async move {
        for m in [hello, state] {
            if sink.send(Message::Text(m.into())).await.is_err() {
                return;
            }
        }
        loop {
            let msg = tokio::select! {
                m = rx.recv() => match m {
                    Ok(m) => m,
                    Err(broadcast::error::RecvError::Lagged(_)) => continue,
                    Err(broadcast::error::RecvError::Closed) => return,
                },
                m = direct_rx.recv() => match m {
                    Some(m) => m,
                    None => return,
                },
            };
            if sink.send(Message::Text(msg.into())).await.is_err() {
                return;
            }
        }
    });
    while let Some(Ok(msg)) = stream.next().await {
        let text = match msg {
            Message::Text(t) => t.as_str().to_owned(),
            Message::Binary(_) => {
                let _ = direct_tx
                    .send(error(
                        "binary messages are not understood; send JSON text",
                        None,
                    ))
                    .await;
                continue;
            }
            Message::Close(_) => break,
            _ => continue,
        };
        // A replay may take minutes to prepare: it answers on its own task,
        // so this tab's other requests are served meanwhile.
        if matches!(
            ClientMessage::parse(&text),
            Ok(ClientMessage::Replay { .. })
        ) {
            let (s, tx, left) = (s.clone(), direct_tx.clone(), left.clone());
            tokio::spawn(PAGE_LEFT.scope(left, async move {
                if let Some(reply) = handle(&s, &text).await {
                    let _ = tx.send(reply).await;
                }
            }));
            continue;
        }
        if let Some(reply) = handle(&s, &text).await
            && direct_tx.send(reply).await.is_err()
        {
            break;
        }
    }
    left.store(true, Ordering::SeqCst);
    writer.abort();
}

tokio::task_local! {
    /// The flag raised when the tab whose request this task serves leaves
    /// (`client`), which the work it starts stops on
    /// ([`seespot_policy::cancel`]).
    static PAGE_LEFT: Arc<std::sync::atomic::AtomicBool>;
}

/// Handles one request; returns the direct reply, if any (state changes are broadcast).
pub async fn handle(s: &Arc<AppState>, text: &str) -> Option<String> {
    let msg = match ClientMessage::parse(text) {
        Ok(m) => m,
        Err((message, kind)) => return Some(error(message, kind.as_deref())),
    };
    let kind = msg.kind();
    let read_only = matches!(
        msg,
        ClientMessage::Stop
            | ClientMessage::State
            | ClientMessage::Query { .. }
            | ClientMessage::Ping
    );
    if s.running.load(Ordering::SeqCst) && !read_only {
        return Some(error(
            "a run to the end is in progress; send `stop` first",
            Some(kind),
        ));
    }
    let st = s.clone();
    let reply = match msg {
        ClientMessage::Ping => return Some(ServerMessage::Pong.to_text()),
        ClientMessage::State => return Some(to_text(&st.session().state())),
        ClientMessage::NextPhase => step(st, |ses| ses.next_phase().map(|_| ())).await,
        ClientMessage::NextAction => step(st, Session::next_action).await,
        ClientMessage::Reset { task, seed } => {
            step(st, move |ses| {
                let task = task.unwrap_or(ses.trial().task());
                let seed = seed.unwrap_or(ses.trial().seed());
                ses.reset(task, seed)
            })
            .await
        }
        ClientMessage::Goto { index } => step(st, move |ses| ses.goto(index)).await,
        ClientMessage::SetBlocks { blocks } => step(st, move |ses| ses.set_blocks(&blocks)).await,
        ClientMessage::Replay { method, task, seed } => {
            let Some(src) = s.review.clone() else {
                return Some(error(
                    "this debugger reviews no evaluation (seespot view --review DIR)",
                    Some(kind),
                ));
            };
            return Some(replay(st, src, method, task, seed).await);
        }
        ClientMessage::Live => {
            step(st, |ses| {
                ses.go_live();
                Ok(())
            })
            .await
        }
        ClientMessage::Query { pair, policy, y, x } => {
            let r = tokio::task::spawn_blocking(move || {
                st.session().query(PairQuery { pair, policy, y, x })
            })
            .await;
            return Some(match r {
                Ok(Ok(v)) => to_text(&v),
                Ok(Err(e)) => failed(&e, Some(kind)),
                Err(e) => failed(&e.into(), Some(kind)),
            });
        }
        ClientMessage::Demonstrate {
            task,
            seed,
            colours_matter,
        } => step(st, move |ses| ses.demonstrate(task, seed, colours_matter)).await,
        ClientMessage::DemoAct { action } => step(st, move |ses| ses.demo_act(action)).await,
        ClientMessage::DemoUndo => step(st, Session::demo_undo).await,
        ClientMessage::DemoStop => {
            step(st, |ses| {
                ses.demo_stop();
                Ok(())
            })
            .await
        }
        ClientMessage::DemoSave { overwrite } => {
            let saved = std::sync::Arc::new(std::sync::Mutex::new(None));
            let out = saved.clone();
            let r = step(st, move |ses| {
                let dir = ses.demo_save(overwrite)?;
                *out.lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(dir);
                Ok(())
            })
            .await;
            let dir = saved
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .take();
            return Some(match (r, dir) {
                (Ok(()), Some(dir)) => ServerMessage::DemoSaved {
                    dir: dir.display().to_string(),
                }
                .to_text(),
                (Err(e), _) => failed(&e, Some(kind)),
                (Ok(()), None) => error("the demonstration was not saved", Some(kind)),
            });
        }
        ClientMessage::Run => {
            s.running.store(true, Ordering::SeqCst);
            s.broadcast_state();
            tokio::task::spawn_blocking(move || run_to_end(&st));
            return None;
        }
        ClientMessage::Stop => {
            s.running.store(false, Ordering::SeqCst);
            return None;
        }
    };
    match reply {
        Ok(()) => None,
        Err(e) => Some(failed(&e, Some(kind))),
    }
}

/// Clears [`AppState::preparing`] when the preparation it guards ends,
/// however it ends.
struct Preparing<'a>(&'a AppState);

impl Drop for Preparing<'_> {
    fn drop(&mut self) {
        *self
            .0
            .preparing
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = None;
    }
}

/// Loads the replay of trial (`method`, `task`, `seed`) of `src` into the
/// session. Its decider is made on a blocking thread without holding the
/// session, since a finetuned run may finetune its models for minutes
/// first: meanwhile every tab hears `busy` once a second and every other
/// request is served. One replay is prepared at a time. Returns the reply.
async fn replay(
    s: Arc<AppState>,
    src: ReviewSource,
    method: String,
    task: TaskId,
    seed: u64,
) -> String {
    const KIND: Option<&str> = Some("replay");
    let what = format!("the replay of {method} on {task} seed {seed}");
    {
        let mut p = s
            .preparing
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(other) = &*p {
            return error(
                format!("{other} is being prepared; wait for it, then ask again"),
                KIND,
            );
        }
        *p = Some(what.clone());
    }
    let _preparing = Preparing(&s);
    let m = method.clone();
    let replay = match tokio::task::spawn_blocking(move || src.replay(&m, task, seed)).await {
        Ok(Ok(r)) => r,
        Ok(Err(e)) => return failed(&e, KIND),
        Err(e) => return failed(&e.into(), KIND),
    };
    match load_replay(&s, &what, replay).await {
        Ok(()) => ServerMessage::Replay { method, task, seed }.to_text(),
        Err(e) => failed(&e, KIND),
    }
}

/// Makes `replay`'s decider on a blocking thread, telling every tab once a
/// second that `what` is being prepared (`busy`), then loads it into the
/// session; the session is not held meanwhile, so every other request is
/// served.
pub async fn load_replay(
    s: &Arc<AppState>,
    what: &str,
    replay: crate::registry::Replay,
) -> Result<(), VizError> {
    let why = replay.slow.clone();
    let started = std::time::Instant::now();
    // Finetuning for it stops if the tab that asked leaves.
    let left = PAGE_LEFT.try_with(Arc::clone).ok();
    let mut work = tokio::task::spawn_blocking(move || match left {
        Some(flag) => {
            seespot_policy::cancel::scoped(flag, "the page that asked for the replay left", || {
                PreparedReplay::new(replay)
            })
        }
        None => PreparedReplay::new(replay),
    });
    let mut tick = tokio::time::interval(std::time::Duration::from_secs(1));
    let prepared = loop {
        tokio::select! {
            r = &mut work => break r,
            _ = tick.tick() => {
                let busy = ServerMessage::Busy {
                    what: Some(what),
                    why: why.as_deref(),
                    seconds: started.elapsed().as_secs(),
                };
                let _ = s.tx.send(busy.to_text());
            }
        }
    };
    // Done, made or not: every tab stops saying it is busy.
    let done = ServerMessage::Busy {
        what: None,
        why: None,
        seconds: started.elapsed().as_secs(),
    };
    let _ = s.tx.send(done.to_text());
    let prepared = prepared??;
    step(s.clone(), move |ses| ses.install_replay(prepared)).await
}

/// Runs actions until the trial ends, `stop` arrives or an action fails; a
/// failure is kept as the session's last error (shown on every tab) rather
/// than dropped.
fn run_to_end(st: &AppState) {
    while st.running.load(Ordering::SeqCst) {
        let r = {
            let mut ses = st.session();
            if ses.ended() {
                break;
            }
            ses.next_action()
        };
        st.broadcast_state();
        if let Err(e) = r {
            st.session().set_error(format!("run stopped: {e}"));
            break;
        }
    }
    st.running.store(false, Ordering::SeqCst);
    if let Some(r) = st.session().recorder() {
        r.flush();
    }
    st.broadcast_state();
}

/// Runs `f` on the session on a blocking thread, then broadcasts the new state.
async fn step(
    s: Arc<AppState>,
    f: impl FnOnce(&mut Session) -> crate::error::Result<()> + Send + 'static,
) -> Result<(), VizError> {
    let st = s.clone();
    let r = tokio::task::spawn_blocking(move || {
        let r = f(&mut st.session());
        st.broadcast_state();
        r
    })
    .await;
    match r {
        Ok(r) => r,
        Err(e) => Err(e.into()),
    }
}

/// Stops a run to the end after its current action.
pub fn stop(s: &AppState) {
    s.running.store(false, Ordering::SeqCst);
}

/// Whether a run to the end is in progress.
pub fn running(s: &AppState) -> bool {
    s.running.load(Ordering::SeqCst)
}

/// Serves the page on `listener` until `shutdown` resolves. Every request must
/// name this server in `Host` (and `Origin`, when present; see
/// [`AllowedHosts`]). A listener on a non-loopback address is refused unless
/// a `token` protects it; with one, every request must carry it.
pub async fn serve_page(
    listener: tokio::net::TcpListener,
    state: Arc<AppState>,
    token: Option<AccessToken>,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> crate::error::Result<()> {
    let addr = listener.local_addr()?;
    if !addr.ip().is_loopback() && token.is_none() {
        crate::refuse!(
            "the page server on {addr} would be reachable from other machines; it needs an access token (seespot view --allow-remote)"
        );
    }
    let allowed = if token.is_some() {
        AllowedHosts::for_token_server(addr)
    } else {
        AllowedHosts::for_addr(addr)
    };
    let access = Arc::new(Access {
        allowed,
        token,
        port: addr.port(),
    });
    let app = router(state).layer(axum::middleware::from_fn_with_state(access, guard));
    axum::serve(listener, app)
        .with_graceful_shutdown(shutdown)
        .await?;
    Ok(())
}

/// The address the page server is bound to, as a URL; with the run's token
/// when it has one. An unspecified address (`0.0.0.0`) is shown as this
/// machine's host name, which other machines can use.
pub fn url(addr: SocketAddr, token: Option<&AccessToken>) -> String {
    url_of(addr, "/", token)
}

/// The URL of `path` (starting with `/`) on the server at `addr`, with the
/// token when it needs one.
pub fn url_of(addr: SocketAddr, path: &str, token: Option<&AccessToken>) -> String {
    let host = if addr.ip().is_unspecified() {
        std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .map(|h| h.trim().to_owned())
            .filter(|h| !h.is_empty())
            .map_or(addr.to_string(), |h| format!("{h}:{}", addr.port()))
    } else {
        addr.to_string()
    };
    match token {
        Some(t) => format!("http://{host}{path}?token={}", t.as_str()),
        None => format!("http://{host}{path}"),
    }
}
