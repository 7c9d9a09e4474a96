//! Trials as rerun recordings (`.rrd` files, a live gRPC stream for rerun's
//! web viewer, or bytes in memory for a download).
//!
//! rerun is the `rerun` feature of this crate (and of the `seespot` binary):
//! the heaviest part of a build, so the default binary leaves it out and
//! serves the page alone. Built without it, the types below keep their names
//! and every constructor refuses with the command that builds them
//! ([`MISSING`]); nothing else of the debugger changes.

#[cfg(not(feature = "rerun"))]
mod absent;
#[cfg(feature = "rerun")]
mod rerun_log;
#[cfg(feature = "rerun")]
mod web_viewer;

#[cfg(not(feature = "rerun"))]
pub use absent::{MemoryRecording, Recorder, SharedRecording, WebViewer};
#[cfg(feature = "rerun")]
pub use rerun_log::{MemoryRecording, Recorder, SharedRecording, blueprint, two_runs_blueprint};
#[cfg(feature = "rerun")]
pub use web_viewer::WebViewer;

/// Whether this build writes rerun recordings.
pub const AVAILABLE: bool = cfg!(feature = "rerun");

/// What a recording asked of a build without rerun answers.
pub const MISSING: &str = "this seespot was built without rerun recordings; build it with `cargo build --release -p seespot --features rerun`";

/// rerun application id of every seespot recording.
pub const APPLICATION_ID: &str = "seespot";

/// Depth heightmaps are logged as `u16` in these units per metre (0.1 mm).
pub const DEPTH_UNITS_PER_METRE: f32 = 10_000.0;

/// The recording's status panel as Markdown: the trial, the phase and the
/// pairs table, with the simulator's truth about each F when the session
/// worked it out (a column of verdicts and why), the extension's
/// departures, and the end.
pub fn status_markdown(
    trial_index: u64,
    trial: &seespot_sim::Trial,
    action: usize,
    phase: crate::phase::Phase,
    d: Option<&seespot_ssr::Decision>,
    truth: Option<&[seespot_sim::truth::Truth]>,
) -> String {
    use crate::phase::Phase;
    let mut s = format!(
        "## Trial {trial_index} · {} · seed {}\n\nAction **{}** · phase **{}** · progress **{} / 4**\n\n",
        trial.task().as_str(),
        trial.seed(),
        action + 1,
        phase.as_str(),
        trial.progress()
    );
    if let Some(d) = d {
        s.push_str("| policy | demo | L | C | F | truth | |\n|---|---|---|---|---|---|---|\n");
        for (i, p) in d.pairs.iter().enumerate() {
            let show_l = phase >= Phase::Match;
            let show_c = phase >= Phase::Verify;
            let mark = if phase >= Phase::Act && i == d.chosen {
                "**chosen**"
            } else {
                ""
            };
            let verdict = match truth.and_then(|t| t.get(i)) {
                Some(t) if show_l => format!("{} ({})", verdict_words(t.verdict), t.why),
                _ => "…".into(),
            };
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {verdict} | {mark} |\n",
                p.policy.as_str(),
                p.demo,
                if show_l {
                    format!("{:.3}", p.l)
                } else {
                    "…".into()
                },
                if show_c {
                    format!("{:.1}", p.c)
                } else {
                    "…".into()
                },
                if show_l {
                    p.matched.to_string()
                } else {
                    "…".into()
                },
            ));
        }
        // Where an extension departed from SSR CCD, as the page says it.
        for departure in &d.departures {
            s.push_str(&format!("\nExtension: {departure}.\n"));
        }
    }
    if let Some(end) = trial.end() {
        s.push_str(&format!(
            "\nTrial ended: **{end:?}** after {} actions.\n",
            trial.actions()
        ));
    }
    s
}

/// A verdict as the page's tooltips say it.
fn verdict_words(v: seespot_sim::truth::Verdict) -> &'static str {
    use seespot_sim::truth::Verdict;
    match v {
        Verdict::Right => "✓ right",
        Verdict::WrongBlock => "✗ wrong block",
        Verdict::Miss => "✗ miss",
        Verdict::NoProgress => "✗ no progress",
        Verdict::Reversal => "✗ reversal",
        Verdict::Out => "✗ out",
    }
}
