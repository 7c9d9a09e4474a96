//! Logging trials to rerun (the `rerun` feature): the 3-D scene, the
//! heightmaps, every (policy, demo) pair's match and rematch, and the
//! metrics, on the timelines of [`crate::paths`].
//!
//! Size: distance heatmaps are logged at full resolution but only at the
//! matched rotation (match) and the demo action's rotation (rematch), quantized
//! to `u16` (`DepthImage` with a `meter` scale and a colormap); depth heightmaps
//! are `u16` in units of 0.1 mm. A 224 px trial of ~10 actions is a few MB.

use crate::error::Context as _;
use std::path::{Path, PathBuf};

use rerun::blueprint::{
    Blueprint, ContainerLike, Horizontal, Spatial2DView, Spatial3DView, Tabs, TextDocumentView,
    TimePanel, TimeSeriesView, Vertical,
};
use rerun::{RecordingStream, RecordingStreamBuilder};
use seespot_sim::truth::Truth;
use seespot_sim::{BLOCK_COLORS, BLOCK_SIZE, Demo, Heightmaps, TaskId, Trial};
use seespot_ssr::Decision;

use super::{APPLICATION_ID, DEPTH_UNITS_PER_METRE};
use crate::paths;
use crate::phase::Phase;

/// Largest quantized heatmap value.
const HEAT_LEVELS: f32 = 65_000.0;

/// Colours of the pairs' arrows: demo -> F, and F -> rematch; the chosen pair's.
const ARROW_MATCH: [u8; 3] = [255, 255, 255];
const ARROW_REMATCH: [u8; 3] = [255, 170, 0];
const CHOSEN: [u8; 3] = [0, 230, 118];

/// A rerun recording of one or more trials.
pub struct Recorder {
    rec: RecordingStream,
    phase_tick: i64,
    /// Index of the current trial on the `trial` timeline.
    trial_index: u64,
    trials: u64,
    successes: u64,
    progress_sum: f64,
    save_path: Option<PathBuf>,
    /// Prepended to every entity path (`runs/<run>` when one recording holds
    /// two runs side by side; empty otherwise).
    prefix: String,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("save_path", &self.save_path)
            .finish_non_exhaustive()
    }
}

/// The default layout: the 3-D scene and status on the left, the live and demo
/// heightmaps on top, one tab per (policy, demo) pair, and the scalars.
pub fn blueprint(policies: &[String]) -> Blueprint {
    let mut tabs: Vec<ContainerLike> = Vec::new();
    for p in policies {
        for n in 0..2 {
            let matched =
                Spatial2DView::new(format!("match over live · {} / demo {n}", p.as_str()))
                    .with_origin("/")
                    .with_contents([
                        format!("+ /{}", paths::corr_match(p, n)),
                        format!("+ /{}", paths::corr_arrows(p, n)),
                    ]);
            let rematch = Spatial2DView::new(format!("rematch over demo {n} · {}", p.as_str()))
                .with_origin("/")
                .with_contents([
                    format!("+ /{}", paths::corr_rematch(p, n)),
                    format!("+ /{}", paths::corr_arrows(p, n)),
                ]);
            let sees = |name: String, path: String| {
                Spatial2DView::new(name)
                    .with_origin("/")
                    .with_contents([format!("+ /{path}")])
            };
            let pca = Vertical::new([
                sees(
                    format!("what {} sees · live", p.as_str()),
                    paths::corr_pca_live(p, n),
                )
                .into(),
                sees(
                    format!("what {} sees · demo {n}", p.as_str()),
                    paths::corr_pca_demo(p, n),
                )
                .into(),
            ]);
            tabs.push(
                Horizontal::new([matched.into(), rematch.into(), pca.into()])
                    .with_name(format!("{} / demo {n}", p.as_str()))
                    .into(),
            );
        }
    }
    let left = Vertical::new([
        Spatial3DView::new("scene").with_origin(paths::WORLD).into(),
        TextDocumentView::new("status")
            .with_origin(paths::STATUS)
            .into(),
    ])
    .with_row_shares([3.0, 2.0]);
    let image_tabs = |name: &str, color: String, depth: String, action: String| -> ContainerLike {
        Tabs::new([
            Spatial2DView::new(format!("{name} colour"))
                .with_origin("/")
                .with_contents([format!("+ /{color}"), format!("+ /{action}")])
                .into(),
            Spatial2DView::new(format!("{name} depth"))
                .with_origin("/")
                .with_contents([format!("+ /{depth}"), format!("+ /{action}")])
                .into(),
        ])
        .into()
    };
    let images = Horizontal::new([
        image_tabs(
            "live",
            paths::TEST_COLOR.into(),
            paths::TEST_DEPTH.into(),
            paths::TEST_ACTION.into(),
        ),
        image_tabs(
            "demo 0",
            paths::demo_color(0),
            paths::demo_depth(0),
            paths::demo_action(0),
        ),
        image_tabs(
            "demo 1",
            paths::demo_color(1),
            paths::demo_depth(1),
            paths::demo_action(1),
        ),
    ]);
    let scalars = Horizontal::new([
        TimeSeriesView::new("L and C per pair")
            .with_origin("/corr")
            .into(),
        TimeSeriesView::new("metrics")
            .with_origin("/metrics")
            .into(),
    ]);
    let right = Vertical::new([images.into(), Tabs::new(tabs).into(), scalars.into()])
        .with_row_shares([2.0, 3.0, 2.0]);
    Blueprint::new(Horizontal::new([left.into(), right.into()]).with_column_shares([2.0, 3.0]))
        .with_time_panel(TimePanel::new().with_timeline(paths::TIMELINE_PHASE))
}

/// The layout of one recording holding two runs' trials of one seed (under
/// [`paths::run`] each): per run, side by side, its 3-D scene, its live
/// heightmap with the executed action, and its status (the pairs table).
pub fn two_runs_blueprint(runs: [&str; 2]) -> Blueprint {
    let column = |run: &str| -> ContainerLike {
        let root = paths::run(run);
        Vertical::new([
            Spatial3DView::new(format!("{run} · scene"))
                .with_origin(format!("/{root}/{}", paths::WORLD))
                .into(),
            Spatial2DView::new(format!("{run} · live"))
                .with_origin("/")
                .with_contents([
                    format!("+ /{root}/{}", paths::TEST_COLOR),
                    format!("+ /{root}/{}", paths::TEST_ACTION),
                ])
                .into(),
            TextDocumentView::new(format!("{run} · status"))
                .with_origin(format!("/{root}/{}", paths::STATUS))
                .into(),
        ])
        .with_row_shares([3.0, 3.0, 2.0])
        .into()
    };
    Blueprint::new(Horizontal::new([column(runs[0]), column(runs[1])]))
        .with_time_panel(TimePanel::new().with_timeline(paths::TIMELINE_ACTION))
}

/// A recording of two runs side by side written to a file, laid out by
/// [`two_runs_blueprint`]; one [`Recorder::under`] per run logs into it.
pub struct SharedRecording(RecordingStream);

impl SharedRecording {
    /// The recording of `runs` at `path`.
    pub fn two_runs(runs: [&str; 2], path: &Path) -> crate::error::Result<Self> {
        RecordingStreamBuilder::new(APPLICATION_ID)
            .with_blueprint(two_runs_blueprint(runs))
            .save(path)
            .recording(|| format!("cannot create the recording {}", path.display()))
            .map(Self)
    }

    /// Writes what the runs logged to the file.
    pub fn flush(&self) -> crate::error::Result<()> {
        self.0
            .flush_blocking()
            .recording(|| "cannot finish the recording".into())
    }
}

/// A recording kept in memory, for a download.
pub struct MemoryRecording(rerun::sink::MemorySinkStorage);

impl MemoryRecording {
    /// The `.rrd` bytes of everything logged (drop the recorder first).
    pub fn into_bytes(self) -> crate::error::Result<Vec<u8>> {
        self.0
            .drain_as_bytes()
            .recording(|| "cannot encode the recording".into())
    }
}

/// The stream of a recording, laid out for the shipped policies of fold
/// `task` until [`Recorder::send_blueprint`] names others.
fn builder(task: TaskId) -> RecordingStreamBuilder {
    let names: Vec<String> = TaskId::ALL
        .into_iter()
        .filter(|t| *t != task)
        .map(|t| t.as_str().to_string())
        .collect();
    RecordingStreamBuilder::new(APPLICATION_ID).with_blueprint(blueprint(&names))
}

impl Recorder {
    /// A recording written to `path` (the `.rrd` footer is written when the
    /// recorder is dropped).
    pub fn to_file(task: TaskId, path: &Path) -> crate::error::Result<Self> {
        let rec = builder(task)
            .save(path)
            .recording(|| format!("cannot create the recording {}", path.display()))?;
        Ok(Self::from_stream(rec, Some(path.to_owned())))
    }

    /// A recording served over gRPC on `bind:grpc_port` (for the web viewer),
    /// and also written to `save` when given.
    pub fn serve(
        task: TaskId,
        bind: &str,
        grpc_port: u16,
        save: Option<&Path>,
    ) -> crate::error::Result<Self> {
        let mut sinks: Vec<Box<dyn rerun::sink::LogSink>> = Vec::new();
        let options = rerun::ServerOptions {
            memory_limit: rerun::MemoryLimit::from_bytes(512 * 1024 * 1024),
            ..Default::default()
        };
        let grpc = rerun::grpc_server::GrpcServerSink::new(bind, grpc_port, options)
            .recording(|| format!("bad gRPC address {bind}:{grpc_port}"))?;
        sinks.push(Box::new(grpc));
        if let Some(path) = save {
            let file = rerun::sink::FileSink::new(path)
                .recording(|| format!("cannot create the recording {}", path.display()))?;
            sinks.push(Box::new(file));
        }
        let rec = builder(task)
            .set_sinks(sinks)
            .recording(|| "cannot start the rerun recording stream".into())?;
        Ok(Self::from_stream(rec, save.map(Path::to_owned)))
    }

    /// An in-memory recording (tests and benchmarks).
    pub fn memory(task: TaskId) -> crate::error::Result<(Self, MemoryRecording)> {
        let (rec, storage) = builder(task)
            .memory()
            .recording(|| "cannot start an in-memory recording".into())?;
        Ok((Self::from_stream(rec, None), MemoryRecording(storage)))
    }

    fn from_stream(rec: RecordingStream, save_path: Option<PathBuf>) -> Self {
        Self::with_prefix(rec, save_path, String::new())
    }

    /// A recorder on `rec` whose entity paths all lie under `prefix` (one of
    /// [`paths::run`]), for several runs in one recording.
    pub fn under(shared: &SharedRecording, prefix: String) -> Self {
        Self::with_prefix(shared.0.clone(), None, prefix)
    }

    fn with_prefix(rec: RecordingStream, save_path: Option<PathBuf>, prefix: String) -> Self {
        let recorder = Self {
            rec,
            phase_tick: 0,
            trial_index: 0,
            trials: 0,
            successes: 0,
            progress_sum: 0.0,
            save_path,
            prefix,
        };
        recorder.log_static();
        recorder
    }

    /// `path` under this recorder's prefix.
    fn at(&self, path: impl AsRef<str>) -> String {
        if self.prefix.is_empty() {
            path.as_ref().to_owned()
        } else {
            format!("{}/{}", self.prefix, path.as_ref())
        }
    }

    /// Sends the layout of a decider whose embedding models are `policies`
    /// (its pair tabs name them) and makes it active.
    pub fn send_blueprint(&self, policies: &[String]) {
        let activation = rerun::blueprint::BlueprintActivation {
            make_active: true,
            make_default: true,
        };
        self.warn(blueprint(policies).send(&self.rec, activation));
    }

    /// Where the recording is being written, if anywhere.
    pub fn save_path(&self) -> Option<&Path> {
        self.save_path.as_deref()
    }

    /// Flushes pending data to the sinks.
    pub fn flush(&self) {
        if let Err(e) = self.rec.flush_blocking() {
            eprintln!("warning: flushing the recording failed: {e}");
        }
    }

    fn log_static(&self) {
        let half = seespot_sim::workspace::WORKSPACE_SIZE / 2.0;
        let table = rerun::Boxes3D::from_centers_and_half_sizes(
            [(0.0, 0.0, -0.002)],
            [(half, half, 0.002)],
        )
        .with_colors([rerun::Color::from_rgb(200, 200, 206)])
        .with_fill_mode(rerun::FillMode::Solid);
        self.warn(self.rec.log_static(self.at(paths::WORLD_TABLE), &table));
        self.warn(self.rec.log_static(
            self.at(paths::WORLD),
            &rerun::ViewCoordinates::RIGHT_HAND_Z_UP(),
        ));
    }

    fn warn(&self, r: rerun::RecordingStreamResult<()>) {
        if let Err(e) = r {
            eprintln!("warning: rerun logging failed: {e}");
        }
    }

    fn tick(&mut self, action: usize) {
        self.phase_tick += 1;
        self.rec
            .set_time_sequence(paths::TIMELINE_TRIAL, self.trial_index as i64);
        self.rec
            .set_time_sequence(paths::TIMELINE_ACTION, action as i64);
        self.rec
            .set_time_sequence(paths::TIMELINE_PHASE, self.phase_tick);
    }

    /// Logs a trial's start: the scene and the live heightmaps.
    pub fn begin_trial(&mut self, trial_index: u64, trial: &Trial, decider: &str) {
        self.trial_index = trial_index;
        self.tick(0);
        self.log_scene(trial);
        let hm = trial.world().render();
        self.log_test(&hm);
        self.log_progress(trial);
        let note = format!(
            "## Trial {trial_index}: {} (seed {})\n\nDecider: {decider}\n\nStart progress {} / 4.",
            trial.task().as_str(),
            trial.seed(),
            trial.progress()
        );
        self.warn(self.rec.log(
            self.at(paths::STATUS),
            &rerun::TextDocument::from_markdown(note),
        ));
    }

    /// Logs one phase of the decision for action `action` (0-based) of `trial`
    /// (the trial of the last [`Recorder::begin_trial`]). `hm` is the scene the
    /// decision was made on. The `action` timeline counts from 1 as the page
    /// and the viser view do (0 is the trial's start). `truth`: the
    /// simulator's verdict on each pair's F, when the session worked it out.
    #[allow(clippy::too_many_arguments)]
    pub fn log_phase(
        &mut self,
        trial: &Trial,
        action: usize,
        phase: Phase,
        hm: &Heightmaps,
        decision: Option<&Decision>,
        truth: Option<&[Truth]>,
        demos: &[Demo],
    ) {
        self.tick(action + 1);
        match phase {
            Phase::Embed => {
                self.log_test(hm);
                if let Some(d) = decision {
                    self.log_demos(d, demos);
                }
            }
            Phase::Match => {
                if let Some(d) = decision {
                    self.log_match(d, hm);
                }
            }
            Phase::Verify => {
                if let Some(d) = decision {
                    self.log_verify(d);
                }
            }
            Phase::Act => {
                if let Some(d) = decision {
                    self.log_chosen(d);
                }
                self.log_scene(trial);
                self.log_progress(trial);
            }
        }
        self.log_status(trial, action, phase, decision, truth);
    }

    /// Logs what `policy` sees in the chosen pair (with demo `demo`): its live
    /// and demo embeddings as RGB of their joint first three principal
    /// components, `n x n` each (from [`crate::Decider::embedding_rgb`]).
    pub fn log_embedding_rgb(
        &self,
        policy: &str,
        demo: usize,
        live: &[u8],
        demo_rgb: &[u8],
        n: usize,
    ) {
        let image = |rgb: &[u8]| rerun::Image::from_rgb24(rgb.to_vec(), [n as u32, n as u32]);
        self.warn(
            self.rec
                .log(self.at(paths::corr_pca_live(policy, demo)), &image(live)),
        );
        self.warn(self.rec.log(
            self.at(paths::corr_pca_demo(policy, demo)),
            &image(demo_rgb),
        ));
    }

    /// Logs a finished trial into the running metrics.
    pub fn end_trial(&mut self, trial: &Trial) {
        self.trials += 1;
        self.successes += u64::from(trial.succeeded());
        self.progress_sum += f64::from(trial.max_progress()) / 4.0;
        self.log_scalar(
            paths::METRICS_SUCCESS_RATE,
            self.successes as f64 / self.trials as f64,
        );
        self.log_scalar(
            paths::METRICS_MEAN_PROGRESS,
            self.progress_sum / self.trials as f64,
        );
    }

    fn log_scalar(&self, path: &str, v: f64) {
        self.warn(self.rec.log(self.at(path), &rerun::Scalars::single(v)));
    }

    fn log_progress(&self, trial: &Trial) {
        self.log_scalar(paths::METRICS_PROGRESS, f64::from(trial.progress()));
        self.log_scalar(paths::METRICS_MAX_PROGRESS, f64::from(trial.max_progress()));
        self.log_scalar(paths::METRICS_ACTIONS, trial.actions() as f64);
    }

    fn log_scene(&self, trial: &Trial) {
        let world = trial.world();
        let poses = world.block_poses();
        let h = BLOCK_SIZE / 2.0;
        let boxes = rerun::Boxes3D::from_centers_and_half_sizes(
            poses
                .iter()
                .map(|p| (p.position[0], p.position[1], p.position[2])),
            poses.iter().map(|_| (h, h, h)),
        )
        .with_quaternions(
            poses
                .iter()
                .map(|p| rerun::Quaternion::from_xyzw(p.rotation)),
        )
        .with_colors(
            BLOCK_COLORS
                .iter()
                .map(|c| rerun::Color::from_rgb(c[0], c[1], c[2])),
        )
        .with_labels(["red", "blue", "green", "yellow"])
        .with_fill_mode(rerun::FillMode::Solid);
        self.warn(self.rec.log(self.at(paths::WORLD_BLOCKS), &boxes));
        if let Some([x, y, z, yaw]) = world.last_action_pose() {
            let (s, c) = yaw.sin_cos();
            // Two fingers along the jaw axis (yaw from +x) and a palm above them.
            let jaw = 0.045;
            let centers = [
                (x + c * jaw, y + s * jaw, z + 0.03),
                (x - c * jaw, y - s * jaw, z + 0.03),
                (x, y, z + 0.075),
            ];
            let half = [
                (0.006, 0.012, 0.03),
                (0.006, 0.012, 0.03),
                (0.055, 0.014, 0.012),
            ];
            let q = rerun::Quaternion::from_xyzw([0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()]);
            let held = if world.held_block().is_some() {
                "gripper (holding)"
            } else {
                "gripper"
            };
            let gripper = rerun::Boxes3D::from_centers_and_half_sizes(centers, half)
                .with_quaternions([q, q, q])
                .with_colors([rerun::Color::from_rgb(90, 90, 100); 3])
                .with_labels(["", "", held])
                .with_fill_mode(rerun::FillMode::Solid);
            self.warn(self.rec.log(self.at(paths::WORLD_GRIPPER), &gripper));
            let arrow = rerun::Arrows3D::from_vectors([(0.0, 0.0, -0.12)])
                .with_origins([(x, y, z + 0.12)])
                .with_colors([rerun::Color::from_rgb(CHOSEN[0], CHOSEN[1], CHOSEN[2])]);
            self.warn(self.rec.log(self.at(paths::WORLD_ACTION), &arrow));
        }
    }

    fn log_test(&self, hm: &Heightmaps) {
        let (color, depth) = images(hm);
        self.warn(self.rec.log(self.at(paths::TEST_COLOR), &color));
        self.warn(self.rec.log(self.at(paths::TEST_DEPTH), &depth));
    }

    fn log_demos(&self, d: &Decision, demos: &[Demo]) {
        let mut done = Vec::new();
        for p in &d.pairs {
            if done.contains(&p.demo) {
                continue;
            }
            done.push(p.demo);
            let Some(step) = demos
                .get(p.demo)
                .and_then(|demo| demo.steps.get(p.demo_step))
            else {
                continue;
            };
            let (color, depth) = images(&step.heightmaps);
            self.warn(self.rec.log(self.at(paths::demo_color(p.demo)), &color));
            self.warn(self.rec.log(self.at(paths::demo_depth(p.demo)), &depth));
            let a = p.demo_action;
            let pt = rerun::Points2D::new([(a.x as f32 + 0.5, a.y as f32 + 0.5)])
                .with_radii([3.0])
                .with_colors([rerun::Color::from_rgb(
                    ARROW_MATCH[0],
                    ARROW_MATCH[1],
                    ARROW_MATCH[2],
                )])
                .with_labels([format!("demo {} step {}: {a}", p.demo, p.demo_step)]);
            self.warn(self.rec.log(self.at(paths::demo_action(p.demo)), &pt));
        }
    }

    fn log_match(&self, d: &Decision, _hm: &Heightmaps) {
        let n = d.resolution;
        for p in &d.pairs {
            self.warn(self.rec.log(
                self.at(paths::corr_match(&p.policy, p.demo)),
                &heat_image(&p.match_map, n),
            ));
            let arrows = rerun::Arrows2D::from_vectors([(
                p.matched.x as f32 - p.demo_action.x as f32,
                p.matched.y as f32 - p.demo_action.y as f32,
            )])
            .with_origins([(p.demo_action.x as f32 + 0.5, p.demo_action.y as f32 + 0.5)])
            .with_colors([rerun::Color::from_rgb(
                ARROW_MATCH[0],
                ARROW_MATCH[1],
                ARROW_MATCH[2],
            )])
            .with_labels([format!("demo -> F, L = {:.3}", p.l)]);
            self.warn(
                self.rec
                    .log(self.at(paths::corr_arrows(&p.policy, p.demo)), &arrows),
            );
            self.log_scalar(&paths::corr_l(&p.policy, p.demo), f64::from(p.l));
        }
    }

    fn log_verify(&self, d: &Decision) {
        let n = d.resolution;
        for p in &d.pairs {
            self.warn(self.rec.log(
                self.at(paths::corr_rematch(&p.policy, p.demo)),
                &heat_image(&p.rematch_map, n),
            ));
            self.warn(self.rec.log(
                self.at(paths::corr_arrows(&p.policy, p.demo)),
                &pair_arrows(p, false),
            ));
            self.log_scalar(&paths::corr_c(&p.policy, p.demo), f64::from(p.c));
        }
    }

    fn log_chosen(&self, d: &Decision) {
        if let Some(p) = d.pairs.get(d.chosen) {
            self.warn(self.rec.log(
                self.at(paths::corr_arrows(&p.policy, p.demo)),
                &pair_arrows(p, true),
            ));
            let a = d.action;
            let pt = rerun::Points2D::new([(a.x as f32 + 0.5, a.y as f32 + 0.5)])
                .with_radii([4.0])
                .with_colors([rerun::Color::from_rgb(CHOSEN[0], CHOSEN[1], CHOSEN[2])])
                .with_labels([format!(
                    "act: {a} ({} / demo {})",
                    p.policy.as_str(),
                    p.demo
                )]);
            self.warn(self.rec.log(self.at(paths::TEST_ACTION), &pt));
        }
    }

    /// The status panel ([`super::status_markdown`]).
    fn log_status(
        &self,
        trial: &Trial,
        action: usize,
        phase: Phase,
        d: Option<&Decision>,
        truth: Option<&[Truth]>,
    ) {
        let s = super::status_markdown(self.trial_index, trial, action, phase, d, truth);
        self.warn(self.rec.log(
            self.at(paths::STATUS),
            &rerun::TextDocument::from_markdown(s),
        ));
    }
}

fn pair_arrows(p: &seespot_ssr::PairExplanation, chosen: bool) -> rerun::Arrows2D {
    let c1 = if chosen { CHOSEN } else { ARROW_MATCH };
    rerun::Arrows2D::from_vectors([
        (
            p.matched.x as f32 - p.demo_action.x as f32,
            p.matched.y as f32 - p.demo_action.y as f32,
        ),
        (
            p.rematch.x as f32 - p.matched.x as f32,
            p.rematch.y as f32 - p.matched.y as f32,
        ),
    ])
    .with_origins([
        (p.demo_action.x as f32 + 0.5, p.demo_action.y as f32 + 0.5),
        (p.matched.x as f32 + 0.5, p.matched.y as f32 + 0.5),
    ])
    .with_colors([
        rerun::Color::from_rgb(c1[0], c1[1], c1[2]),
        rerun::Color::from_rgb(ARROW_REMATCH[0], ARROW_REMATCH[1], ARROW_REMATCH[2]),
    ])
    .with_labels([
        format!(
            "{}demo -> F, L = {:.3}",
            if chosen { "CHOSEN " } else { "" },
            p.l
        ),
        format!("F -> rematch, C = {:.1}", p.c),
    ])
}

/// The colour image and the `u16` depth image (0.1 mm units) of `hm`.
fn images(hm: &Heightmaps) -> (rerun::Image, rerun::DepthImage) {
    let n = hm.grid.resolution as u32;
    let color = rerun::Image::from_rgb24(hm.color.clone(), [n, n]);
    let depth_u16: Vec<u8> = hm
        .depth
        .iter()
        .flat_map(|&d| {
            ((d.max(0.0) * DEPTH_UNITS_PER_METRE).round().min(65_535.0) as u16).to_le_bytes()
        })
        .collect();
    let depth =
        rerun::DepthImage::from_data_type_and_bytes(depth_u16, [n, n], rerun::ChannelDatatype::U16)
            .with_meter(DEPTH_UNITS_PER_METRE)
            .with_colormap(rerun::components::Colormap::Viridis);
    (color, depth)
}

/// A distance heatmap as a colour-mapped `u16` depth image: value
/// `1 + d / d_max * 65000` with `meter = 65000 / d_max`, so the viewer shows
/// distances; masked (infinite) entries are 0, i.e. not drawn.
fn heat_image(map: &[f32], n: usize) -> rerun::DepthImage {
    let max = map
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0f32, f32::max)
        .max(1e-6);
    let scale = HEAT_LEVELS / max;
    let bytes: Vec<u8> = map
        .iter()
        .flat_map(|&d| {
            let v = if d.is_finite() {
                1 + (d * scale).round() as u16
            } else {
                0
            };
            v.to_le_bytes()
        })
        .collect();
    rerun::DepthImage::from_data_type_and_bytes(
        bytes,
        [n as u32, n as u32],
        rerun::ChannelDatatype::U16,
    )
    .with_meter(scale)
    .with_colormap(rerun::components::Colormap::Turbo)
    .with_draw_order(10.0)
}

/// `rerun+http://…` as a query-string value.
pub(super) fn percent_encode(s: &str) -> String {
    s.bytes()
        .map(|b| {
            if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
                (b as char).to_string()
            } else {
                format!("%{b:02X}")
            }
        })
        .collect()
}
