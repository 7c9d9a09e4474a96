//! The difference view's requests: the discordant seeds of two runs of the
//! reviewed evaluation, and the two trials of one seed side by side
//! ([`crate::difference`]).

use std::collections::HashMap;
use std::sync::Arc;

use axum::extract::{Query, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};

use super::{AppState, blocking_or_conflict};
use crate::difference::{Difference, Pairing, Side};
use crate::review::ReviewSource;
use seespot_eval::records::records_files;

type Fields = HashMap<String, String>;

/// Query field `k`, or a message naming it.
fn field<'a>(q: &'a Fields, k: &str) -> Result<&'a str, String> {
    q.get(k)
        .map(String::as_str)
        .ok_or_else(|| format!("query field `{k}` is missing"))
}

/// Query field `k` parsed, or a message naming it and what was wrong.
fn parsed<T: std::str::FromStr>(q: &Fields, k: &str) -> Result<T, String>
where
    T::Err: std::fmt::Display,
{
    field(q, k)?
        .parse()
        .map_err(|e| format!("query field `{k}`: {e}"))
}

fn pairing(q: &Fields) -> Result<Pairing, String> {
    Ok(Pairing {
        a: field(q, "a")?.to_owned(),
        b: field(q, "b")?.to_owned(),
        task: parsed(q, "task")?,
        seed: parsed(q, "seed")?,
    })
}

/// The reviewed evaluation and the ones given beside it, if the server
/// reviews one.
fn sources(s: &AppState) -> Option<Vec<ReviewSource>> {
    s.sources()
}

/// The 404 of a server that reviews no evaluation.
fn no_review() -> Response {
    (
        StatusCode::NOT_FOUND,
        "this debugger reviews no evaluation (seespot view --review DIR)",
    )
        .into_response()
}

fn bad_request(message: String) -> Response {
    (StatusCode::BAD_REQUEST, message).into_response()
}

/// `GET /api/divergences?a=RUN&b=RUN`: the seeds where exactly one of the
/// two runs succeeded, where each pair of trials parts, sorted by that action.
pub(super) async fn divergences(
    State(s): State<Arc<AppState>>,
    Query(q): Query<Fields>,
) -> Response {
    let Some(src) = sources(&s) else {
        return no_review();
    };
    let (a, b) = match (field(&q, "a"), field(&q, "b")) {
        (Ok(a), Ok(b)) => (a.to_owned(), b.to_owned()),
        (Err(e), _) | (_, Err(e)) => return bad_request(e),
    };
    blocking_or_conflict(
        move || crate::difference::discordant(&src, &a, &b),
        |list| axum::Json(list).into_response(),
    )
    .await
}

/// Runs `f` on the opened difference of `pairing`, opening it first (both
/// trials replayed up to where they part) when another one, or none, is open.
async fn with_difference<T: Send + 'static>(
    s: Arc<AppState>,
    pairing: Pairing,
    f: impl FnOnce(&mut Difference) -> crate::error::Result<T> + Send + 'static,
    ok: impl FnOnce(T) -> Response,
) -> Response {
    let Some(src) = sources(&s) else {
        return no_review();
    };
    blocking_or_conflict(
        move || {
            let mut open = s
                .difference
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if open.as_ref().is_none_or(|d| *d.pairing() != pairing) {
                *open = None;
                *open = Some(Difference::open(&src, pairing)?);
            }
            let d = open
                .as_mut()
                .ok_or_else(|| crate::error::VizError::request("the difference was not opened"))?;
            f(d)
        },
        ok,
    )
    .await
}

/// `GET /api/difference?a=RUN&b=RUN&task=T&seed=S`: opens the two trials
/// (replayed up to where they part) and answers the view's document.
pub(super) async fn open(State(s): State<Arc<AppState>>, Query(q): Query<Fields>) -> Response {
    let p = match pairing(&q) {
        Ok(p) => p,
        Err(e) => return bad_request(e),
    };
    with_difference(
        s,
        p,
        |d| Ok(d.document()),
        |doc| axum::Json(doc).into_response(),
    )
    .await
}

/// `GET /api/difference/view?a&b&task&seed&side=a|b&action=K[&pair=P]`: one
/// side at action K (its state and frame).
pub(super) async fn view(State(s): State<Arc<AppState>>, Query(q): Query<Fields>) -> Response {
    let request = (|| {
        let side = match field(&q, "side")? {
            "a" => Side::A,
            "b" => Side::B,
            other => return Err(format!("query field `side`: `{other}` is neither a nor b")),
        };
        let action: usize = parsed(&q, "action")?;
        let pair: Option<usize> = match q.get("pair") {
            Some(_) => Some(parsed(&q, "pair")?),
            None => None,
        };
        Ok((pairing(&q)?, side, action, pair))
    })();
    let (p, side, action, pair) = match request {
        Ok(r) => r,
        Err(e) => return bad_request(e),
    };
    with_difference(
        s,
        p,
        move |d| d.view(side, action, pair),
        |v| axum::Json(v).into_response(),
    )
    .await
}

/// `GET /api/runs`: the runs of the reviewed evaluation (folder 0) and of
/// the ones given beside it (`N:RUN`), for the review's two run boxes.
pub(super) async fn runs(State(s): State<Arc<AppState>>) -> Response {
    let Some(src) = sources(&s) else {
        return no_review();
    };
    blocking_or_conflict(
        move || {
            let mut folders = Vec::new();
            for (i, source) in src.iter().enumerate() {
                let mut runs: Vec<String> = records_files(&source.dir)?
                    .into_iter()
                    .chain(seespot_eval::records::custom_records_files(&source.dir)?)
                    .filter_map(|f| run_of(&source.dir, &f))
                    .map(|r| if i == 0 { r } else { format!("{i}:{r}") })
                    .collect();
                runs.sort();
                runs.dedup();
                folders.push(serde_json::json!({
                    "folder": i,
                    "dir": source.dir.display().to_string(),
                    "runs": runs,
                }));
            }
            Ok(folders)
        },
        |v| axum::Json(v).into_response(),
    )
    .await
}

/// The run a records file of `dir` belongs to: the folder under `trials/`.
fn run_of(dir: &std::path::Path, file: &std::path::Path) -> Option<String> {
    let rest = file.strip_prefix(dir.join("trials")).ok()?;
    rest.components()
        .next()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
}
