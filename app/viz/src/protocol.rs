//! The WebSocket messages between the page (`web/app.js`) and the server, as
//! serde types: one JSON text message each, tagged by its `type` field.
//!
//! Client -> server ([`ClientMessage`]):
//! `{"type": "next_phase"}`, `{"type": "next_action"}`, `{"type": "run"}`,
//! `{"type": "stop"}`, `{"type": "state"}`, `{"type": "ping"}`,
//! `{"type": "reset", "task": "row", "seed": 3}` (both optional: the current
//! trial's), `{"type": "goto", "index": 5}` (time travel: show phase 5 of the
//! trial's history as it was shown live), `{"type": "live"}` (back to the live
//! trial), `{"type": "replay", "method": "ssr-ccd", "task": "row", "seed": 5}`
//! (replay a trial of the reviewed evaluation), `{"type": "query", "pair": 0, "policy": 1, "y": 40, "x": 60}`
//! (pixel `(y, x)` of the demo heightmap of pair `pair`, under policy index
//! `policy`).
//! Demonstrate mode: `{"type": "demonstrate", "task": "custom:l-shape",
//! "seed": 0, "colours_matter": false}` (seed and colours optional), then
//! `{"type": "demo_act", "action": {"primitive": "grasp", "rotation": 3, "y":
//! 50, "x": 61}}` per click, `{"type": "demo_undo"}`, `{"type": "demo_save",
//! "overwrite": false}` (answered with `{"type": "demo_saved", "dir": ...}`)
//! and `{"type": "demo_stop"}`.
//!
//! Server -> client ([`ServerMessage`], plus the documents of
//! [`crate::documents`]: `state`, `frame`, `query`, `embedding`):
//! `{"type": "info", "info": {...}}` once on connect, `{"type": "pong"}`,
//! `{"type": "replay", "method": ..., "task": ..., "seed": ...}` when a replay
//! is loaded, `{"type": "busy", "what": ..., "why": ..., "seconds": 12}` to
//! every tab each second while a replay is being prepared, and `{"type": "error", "message": "...", "request": "reset"}`
//! naming the request type that failed (or null).

use seespot_sim::TaskId;
use serde::{Deserialize, Serialize};

/// A request from a tab.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ClientMessage {
    Ping,
    /// Send the current state to this tab only.
    State,
    /// Advance one phase (embed, match, verify, act).
    NextPhase,
    /// Advance to the end of the current action.
    NextAction,
    /// Run actions until the trial ends or `stop` arrives.
    Run,
    Stop,
    /// Start a new trial; missing fields keep the current trial's.
    Reset {
        #[serde(default)]
        task: Option<TaskId>,
        #[serde(default)]
        seed: Option<u64>,
    },
    /// Time travel: show phase `index` of the trial's history (the state's
    /// `history.phases`) as it was shown live.
    Goto {
        index: usize,
    },
    /// Back to the live trial.
    Live,
    /// "What if": start a new trial (same task and seed) from these four block
    /// poses, settled by the physics, and make its first decision.
    SetBlocks {
        blocks: Vec<seespot_sim::BlockPose>,
    },
    /// Replay trial `seed` of `method` on `task` from the reviewed evaluation
    /// (the page's `/review`); answered with `{"type": "replay", ...}`.
    Replay {
        method: String,
        task: TaskId,
        seed: u64,
    },
    /// Click-to-query: the distance map of one demo pixel's ASE over the live scene.
    Query {
        pair: usize,
        policy: usize,
        y: usize,
        x: usize,
    },
    /// Demonstrate mode: start a demonstration of `task` (built-in or
    /// `custom:NAME`) from `seed`'s start (default: the current trial's).
    Demonstrate {
        task: TaskId,
        #[serde(default)]
        seed: Option<u64>,
        #[serde(default)]
        colours_matter: bool,
    },
    /// One demonstrated action (a click on the live heightmap).
    DemoAct {
        action: seespot_sim::Action,
    },
    /// Take back the last demonstrated action.
    DemoUndo,
    /// Save the demonstration (a built-in task's folder is replaced only with
    /// `overwrite`).
    DemoSave {
        #[serde(default)]
        overwrite: bool,
    },
    /// Leave Demonstrate mode without saving.
    DemoStop,
}

impl ClientMessage {
    /// The message's `type`, as sent.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Ping => "ping",
            Self::State => "state",
            Self::NextPhase => "next_phase",
            Self::NextAction => "next_action",
            Self::Run => "run",
            Self::Stop => "stop",
            Self::Reset { .. } => "reset",
            Self::Goto { .. } => "goto",
            Self::Live => "live",
            Self::SetBlocks { .. } => "set_blocks",
            Self::Replay { .. } => "replay",
            Self::Query { .. } => "query",
            Self::Demonstrate { .. } => "demonstrate",
            Self::DemoAct { .. } => "demo_act",
            Self::DemoUndo => "demo_undo",
            Self::DemoSave { .. } => "demo_save",
            Self::DemoStop => "demo_stop",
        }
    }

    /// Parses one text message; the error says what was wrong and carries the
    /// request's `type` when it had one.
    pub fn parse(text: &str) -> Result<Self, (String, Option<String>)> {
        let v: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| (format!("malformed message (not JSON): {e}"), None))?;
        let kind = v.get("type").and_then(|t| t.as_str()).map(str::to_owned);
        if kind.is_none() {
            return Err(("message has no string field `type`".to_owned(), None));
        }
        serde_json::from_value(v).map_err(|e| {
            (
                format!("bad `{}` message: {e}", kind.as_deref().unwrap_or_default()),
                kind,
            )
        })
    }
}

/// A message the server builds itself.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ServerMessage<'a> {
    /// Sent once on connect: what the server runs (see `live::serve_view`).
    Info {
        info: &'a serde_json::Value,
    },
    Pong,
    /// A replay of an evaluation's trial was loaded (the state follows).
    Replay {
        method: String,
        task: TaskId,
        seed: u64,
    },
    /// Long work the server is doing for a request (preparing a replay
    /// whose models are finetuned first), sent to every tab once a second
    /// while it lasts: what, why it is slow, and for how long so far;
    /// `what: null` when it is over. Other requests are served meanwhile.
    Busy {
        what: Option<&'a str>,
        why: Option<&'a str>,
        seconds: u64,
    },
    /// A demonstration was saved in `dir` (the state follows).
    DemoSaved {
        dir: String,
    },
    Error {
        message: String,
        /// The `type` of the request that failed, if known.
        request: Option<&'a str>,
        /// What kind of failure ([`crate::error::VizError::kind`]): `request`
        /// (not possible in this state, or malformed), `files`, `decide` or
        /// `recording`; the page words it.
        kind: &'a str,
    },
}

impl ServerMessage<'_> {
    /// The message as JSON text.
    pub fn to_text(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| {
            format!("{{\"type\":\"error\",\"message\":\"cannot serialize a reply: {e}\"}}")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_parse_and_bad_ones_are_named() {
        assert_eq!(
            ClientMessage::parse(r#"{"type":"reset","task":"row"}"#),
            Ok(ClientMessage::Reset {
                task: Some(TaskId::Row),
                seed: None
            })
        );
        assert_eq!(
            ClientMessage::parse(r#"{"type":"next_phase"}"#),
            Ok(ClientMessage::NextPhase)
        );
        let (msg, kind) =
            ClientMessage::parse(r#"{"type":"reset","task":"juggle"}"#).expect_err("unknown task");
        assert!(msg.contains("juggle"), "{msg}");
        assert_eq!(kind.as_deref(), Some("reset"));
        let (msg, kind) = ClientMessage::parse(r#"{"type":"fly"}"#).expect_err("unknown type");
        assert!(msg.contains("fly"), "{msg}");
        assert_eq!(kind.as_deref(), Some("fly"));
        assert!(ClientMessage::parse("[1,2]").is_err());
        assert!(ClientMessage::parse(r#"{"type":"query","pair":"x"}"#).is_err());
    }
}
