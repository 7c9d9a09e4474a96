//! The debugger's entry points: `view` (a live trial served to the browser and
//! the rerun web viewer), `record` (one `.rrd` per trial) and the latency and
//! size benchmarks.

use crate::error::{Context as _, Required as _};
use std::net::{IpAddr, Ipv4Addr, SocketAddr, TcpListener as StdListener};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use seespot_sim::{Grid, Seeds, TaskId, WorldConfig};
use serde::Serialize;
use serde_json::json;

use crate::documents::to_text;
use crate::recording::{Recorder, WebViewer};
use crate::registry::DeciderFactory;
use crate::server::{self, AppState};
use crate::session::{Phase, Session, SessionConfig};
use crate::token::AccessToken;

/// Options of `seespot view`.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    pub task: TaskId,
    pub seed: u64,
    pub resolution: usize,
    /// Sensor noise on every observation (a replay of a noisy trial).
    pub noise: seespot_sim::noise::SensorNoise,
    /// Address of the page. Off loopback it needs `allow_remote`, and every
    /// request then needs the run's token (in [`ViewUrls::page`]); the rerun
    /// viewer and its gRPC stream, which cannot check a token, stay on
    /// 127.0.0.1.
    pub bind: IpAddr,
    /// Serve on a non-loopback `bind` (protected by a per-run token).
    pub allow_remote: bool,
    /// Page port (0: any free port).
    pub port: u16,
    /// rerun web viewer port (0: any free port).
    pub viewer_port: u16,
    /// rerun gRPC port (0: any free port).
    pub grpc_port: u16,
    /// Also write the recording here.
    pub save: Option<PathBuf>,
    /// Serve no rerun viewer (the page alone).
    pub no_viewer: bool,
    /// Start from these block poses (a scene file's `[[blocks]]`) instead of
    /// the start drawn from the seed.
    pub layout: Option<[seespot_sim::BlockPose; seespot_sim::NUM_BLOCKS]>,
    /// The evaluation the page's `/review` lists and replays.
    pub review: Option<crate::review::ReviewSource>,
    /// Other evaluations whose runs the review's difference view can set
    /// beside the reviewed one's (`seespot view --compare DIR`), as
    /// `N:RUN` (N from 1, in this order).
    pub compare: Vec<crate::review::ReviewSource>,
    /// The summary of the evaluation trial this session replays (`view
    /// --replay`), shown as the page's replay banner, as after its **Replay**
    /// button; `factory` must then be the replay's.
    pub replay: Option<String>,
}

/// The URLs a running `view` serves.
#[derive(Clone, Debug, Serialize)]
pub struct ViewUrls {
    /// The page, with `?token=…` when the server is bound off loopback.
    pub page: String,
    /// The review of an evaluation (`/review`, with the token when needed).
    pub review: String,
    pub viewer: Option<String>,
    pub grpc: Option<String>,
}

fn free_port(bind: IpAddr) -> crate::error::Result<u16> {
    let l = StdListener::bind(SocketAddr::new(bind, 0)).files(|| format!("cannot bind {bind}"))?;
    Ok(l.local_addr()?.port())
}

/// Runs `seespot view`: builds the session, serves the page (and the rerun
/// viewer with its gRPC stream), calls `ready` with the URLs, and runs until
/// `shutdown` resolves (Ctrl-C in the CLI). The recording is flushed and
/// dropped before returning, so a `--save` file gets its footer.
pub async fn serve_view(
    opts: ViewOptions,
    factory: DeciderFactory,
    ready: impl FnOnce(&ViewUrls) + Send,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> crate::error::Result<()> {
    let bind = opts.bind;
    let remote = !bind.is_loopback();
    if remote && !opts.allow_remote {
        crate::refuse!(
            "--bind {bind} is not a loopback address: anyone who can reach it could drive the debugger; pass --allow-remote to serve it protected by a per-run token"
        );
    }
    let token = remote.then(AccessToken::random);
    // The rerun servers cannot check the token: they stay on loopback.
    let rerun_bind = if remote {
        IpAddr::V4(Ipv4Addr::LOCALHOST)
    } else {
        bind
    };
    let world = WorldConfig {
        grid: Grid::new(opts.resolution),
        noise: opts.noise,
    };
    let mut viewer_server = None;
    // Built without rerun, the page is served alone (`--save` is refused).
    let (recorder, grpc_url) = if opts.no_viewer || !crate::recording::AVAILABLE {
        (
            opts.save
                .as_deref()
                .map(|p| Recorder::to_file(opts.task, p))
                .transpose()?,
            None,
        )
    } else {
        let grpc_port = if opts.grpc_port == 0 {
            free_port(rerun_bind)?
        } else {
            opts.grpc_port
        };
        let rec = Recorder::serve(
            opts.task,
            &rerun_bind.to_string(),
            grpc_port,
            opts.save.as_deref(),
        )?;
        (
            Some(rec),
            Some(format!(
                "rerun+http://{}/proxy",
                SocketAddr::new(rerun_bind, grpc_port)
            )),
        )
    };
    let viewer_url = match &grpc_url {
        None => None,
        Some(g) => {
            let (srv, url) = WebViewer::serve(&rerun_bind.to_string(), opts.viewer_port, g)?;
            viewer_server = Some(srv);
            Some(url)
        }
    };
    let config = SessionConfig {
        task: opts.task,
        seed: opts.seed,
        world,
    };
    let layout = opts.layout;
    let replay = opts.replay.clone();
    let demos = opts.review.as_ref().map(|r| r.layout.demos.clone());
    let review_dir = opts.review.as_ref().map(|r| r.dir.clone());
    let session = tokio::task::spawn_blocking(move || {
        let mut s = Session::new(factory, config, recorder)?;
        if let Some(demos) = demos {
            s.set_demos(demos);
        }
        if let Some(dir) = review_dir {
            s.set_review_dir(dir);
        }
        if let Some(poses) = layout {
            s.set_layout(poses);
        }
        if let Some(summary) = replay {
            s.mark_replay(summary);
        }
        Ok::<_, crate::error::VizError>(s)
    })
    .await??;
    let info = json!({
        "viewer_url": viewer_url,
        "grpc_url": grpc_url,
        "rerun_version": "0.36.3",
        "recordings": crate::recording::AVAILABLE,
        "seespot_version": seespot_sim::VERSION,
        "tasks": TaskId::ALL.iter().map(|t| t.as_str()).collect::<Vec<_>>(),
        "workspace_size": seespot_sim::workspace::WORKSPACE_SIZE,
        "jaw_opening": seespot_sim::world::JAW_OPENING,
        "block_size": seespot_sim::BLOCK_SIZE,
    });
    let state = AppState::with_review(session, info, opts.review.clone());
    state.set_compare(opts.compare.clone());
    let listener = tokio::net::TcpListener::bind(SocketAddr::new(bind, opts.port))
        .await
        .files(|| format!("cannot bind the page server to {bind}:{}", opts.port))?;
    let urls = ViewUrls {
        page: server::url(listener.local_addr()?, token.as_ref()),
        review: server::url_of(listener.local_addr()?, "/review", token.as_ref()),
        viewer: viewer_url,
        grpc: grpc_url,
    };
    // Poll `shutdown` once before saying we are ready, so the signal
    // listeners it sets up on first poll (`ctrl_c`) are in place: a Ctrl-C,
    // SIGTERM or SIGHUP sent as soon as the URLs are printed finishes the
    // run instead of killing it, or being lost where SIGHUP is ignored.
    let mut shutdown: std::pin::Pin<Box<dyn std::future::Future<Output = ()> + Send>> =
        Box::pin(shutdown);
    if futures_util::FutureExt::now_or_never(&mut shutdown).is_some() {
        // Already asked to stop: serve nothing, finish as on a later signal.
        shutdown = Box::pin(std::future::ready(()));
    }
    ready(&urls);
    server::serve_page(listener, state.clone(), token, shutdown).await?;
    // Finish the recording: stop any run, then drop the stream (writes the footer).
    server::stop(&state);
    let st = state.clone();
    tokio::task::spawn_blocking(move || {
        st.session().take_recorder().inspect(Recorder::flush);
    })
    .await?;
    drop(viewer_server);
    Ok(())
}

/// One recorded trial.
#[derive(Clone, Debug, Serialize)]
pub struct RecordedTrial {
    pub path: PathBuf,
    pub seed: u64,
    pub actions: usize,
    pub succeeded: bool,
    pub max_progress: u8,
    pub bytes: u64,
}

/// What `seespot record` runs.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    pub task: TaskId,
    /// The trials' seeds.
    pub seeds: Seeds,
    pub resolution: usize,
    /// Folder of the `<task>-<seed>.rrd` files.
    pub out: PathBuf,
}

/// Runs the trials of `opts` and writes `out/<task>-<seed>.rrd` for each.
/// `stop` is polled between phases: when set, the current file is finished
/// (the stream dropped, so the footer is written) and recording stops.
pub fn record_trials(
    opts: &RecordOptions,
    factory: &DeciderFactory,
    stop: &AtomicBool,
    mut progress: impl FnMut(&RecordedTrial),
) -> crate::error::Result<Vec<RecordedTrial>> {
    let RecordOptions {
        task,
        seeds,
        resolution,
        ref out,
    } = *opts;
    std::fs::create_dir_all(out).files(|| format!("cannot create {}", out.display()))?;
    let world = WorldConfig {
        grid: Grid::new(resolution),
        ..WorldConfig::default()
    };
    let mut done = Vec::new();
    for seed in seeds.iter() {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let path = out.join(format!("{}-{seed}.rrd", task.file_stem()));
        let recorder = Recorder::to_file(task, &path)?;
        let config = SessionConfig { task, seed, world };
        let f: DeciderFactory = {
            // Each session owns its factory; reuse ours through a reference-counted shim.
            let shared: &DeciderFactory = factory;
            let (d, note) = shared(task, world)?;
            let cell = std::sync::Mutex::new(Some((d, note)));
            Box::new(move |_, _| {
                cell.lock()
                    .map_err(|_| crate::error::VizError::request("poisoned"))?
                    .take()
                    .required(|| "decider already used".into())
            })
        };
        let mut session = Session::new(f, config, Some(recorder))?;
        while !session.ended() && !stop.load(Ordering::SeqCst) {
            session.next_phase()?;
        }
        let t = session.trial();
        let (actions, succeeded, max_progress) = (t.actions(), t.succeeded(), t.max_progress());
        drop(session.take_recorder());
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        let r = RecordedTrial {
            path,
            seed,
            actions,
            succeeded,
            max_progress,
            bytes,
        };
        progress(&r);
        done.push(r);
    }
    Ok(done)
}

/// Latency of one phase step as the page sees it: the `next_phase` request,
/// the new state and the frame of the chosen pair serialized.
#[derive(Clone, Debug, Serialize)]
pub struct PhaseTiming {
    pub action: usize,
    pub phase: Phase,
    pub ms: f64,
    /// Of `ms`, the decider's own time (embed phase only: the networks and the
    /// correspondence); the rest is the debugger's overhead.
    pub decide_ms: f64,
    pub frame_bytes: usize,
}

/// Summary of [`bench_view`].
#[derive(Clone, Debug, Serialize)]
pub struct ViewBench {
    pub task: TaskId,
    pub seed: u64,
    pub resolution: usize,
    pub decider: String,
    pub phases: Vec<PhaseTiming>,
    pub median_ms: f64,
    pub p90_ms: f64,
    pub max_ms: f64,
    /// Median per phase kind.
    pub median_by_phase: Vec<(Phase, f64)>,
    /// The debugger's overhead (`ms - decide_ms`): median and max over all phases.
    pub overhead_median_ms: f64,
    pub overhead_max_ms: f64,
    /// Bytes of the in-memory recording of the whole trial (a proxy for `.rrd` size).
    pub recording_bytes: usize,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// Steps one trial phase by phase (at most `max_actions` actions), timing from
/// each "next phase" request to the page's data (state + frame JSON) being
/// ready, with recording on (in memory).
pub fn bench_view(
    task: TaskId,
    seed: u64,
    resolution: usize,
    max_actions: usize,
    factory: DeciderFactory,
) -> crate::error::Result<ViewBench> {
    let world = WorldConfig {
        grid: Grid::new(resolution),
        ..WorldConfig::default()
    };
    // Built without rerun, the benchmark times the session alone.
    let (recorder, storage) = if crate::recording::AVAILABLE {
        let (r, s) = Recorder::memory(task)?;
        (Some(r), Some(s))
    } else {
        (None, None)
    };
    let mut s = Session::new(factory, SessionConfig { task, seed, world }, recorder)?;
    let decider = s.state().decider;
    let mut phases = Vec::new();
    while !s.ended() && s.trial().actions() < max_actions {
        let t0 = Instant::now();
        let phase = s.next_phase()?;
        let state = to_text(&s.state());
        let pair = s.decision().map_or(0, |d| d.chosen);
        let frame = to_text(&s.frame(pair));
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let decide_ms = if phase == Phase::Embed {
            s.last_decide_ms()
        } else {
            0.0
        };
        phases.push(PhaseTiming {
            action: s.trial().actions(),
            phase,
            ms,
            decide_ms,
            frame_bytes: frame.len() + state.len(),
        });
    }
    drop(s.take_recorder());
    let recording_bytes = storage
        .and_then(|s| s.into_bytes().ok())
        .map_or(0, |b| b.len());
    let mut all: Vec<f64> = phases.iter().map(|p| p.ms).collect();
    all.sort_by(f64::total_cmp);
    let mut overhead: Vec<f64> = phases.iter().map(|p| p.ms - p.decide_ms).collect();
    overhead.sort_by(f64::total_cmp);
    let median_by_phase = Phase::ALL
        .iter()
        .map(|ph| {
            let mut v: Vec<f64> = phases
                .iter()
                .filter(|p| p.phase == *ph)
                .map(|p| p.ms)
                .collect();
            v.sort_by(f64::total_cmp);
            (*ph, percentile(&v, 0.5))
        })
        .collect();
    Ok(ViewBench {
        task,
        seed,
        resolution,
        decider,
        median_ms: percentile(&all, 0.5),
        p90_ms: percentile(&all, 0.9),
        max_ms: all.last().copied().unwrap_or(0.0),
        phases,
        median_by_phase,
        overhead_median_ms: percentile(&overhead, 0.5),
        overhead_max_ms: overhead.last().copied().unwrap_or(0.0),
        recording_bytes,
    })
}

/// A future that resolves on Ctrl-C, SIGTERM or SIGHUP (a closed terminal),
/// or never if none can be listened to, so each finishes a `--save`
/// recording; SIGKILL cannot be caught.
pub async fn ctrl_c() {
    use tokio::signal::unix::{SignalKind, signal};
    let on = |kind: SignalKind| async move {
        match signal(kind) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        r = tokio::signal::ctrl_c() => {
            if r.is_err() {
                std::future::pending::<()>().await;
            }
        }
        () = on(SignalKind::terminate()) => {}
        () = on(SignalKind::hangup()) => {}
    }
}

/// Installs a Ctrl-C / SIGTERM / SIGHUP handler that sets the returned flag (for blocking loops
/// such as [`record_trials`]); runs the signal listener on its own thread.
pub fn ctrl_c_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = flag.clone();
    // The listeners are in place when this returns (the thread says so after
    // polling them once), so a signal sent right after is not lost.
    let (listening, ready) = std::sync::mpsc::channel::<()>();
    let spawned = std::thread::Builder::new()
        .name("ctrl-c".into())
        .spawn(move || {
            let Ok(rt) = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            else {
                return;
            };
            rt.block_on(async {
                let mut signal = Box::pin(ctrl_c());
                let early = futures_util::FutureExt::now_or_never(&mut signal).is_some();
                let _ = listening.send(());
                if !early {
                    signal.await;
                }
                eprintln!("\ninterrupted: finishing the current recording…");
                f.store(true, Ordering::SeqCst);
            });
        });
    if spawned.is_ok() {
        // An error means the thread ended without listening: nothing to wait for.
        let _ = ready.recv();
    }
    flag
}
