//! The one scheme of rerun entity paths and timelines used by every seespot
//! recording (docs/design.md §6). Everything that logs goes through these names.
//!
//! | path | what |
//! |---|---|
//! | `world/blocks` | the four blocks, `Boxes3D` (world frame, metres, z up) |
//! | `world/gripper` | the gripper at the executed action, `Boxes3D` |
//! | `world/action` | the executed action pose, `Arrows3D` (yaw) |
//! | `test/color`, `test/depth` | the live heightmaps the decision was made on |
//! | `demo/{n}/color`, `demo/{n}/depth` | demo `n`'s heightmaps at the matched step |
//! | `demo/{n}/action` | demo `n`'s action at that step, `Points2D` |
//! | `corr/{policy}/{n}/match` | match distances over the live scene at F's rotation |
//! | `corr/{policy}/{n}/rematch` | rematch distances over the demo scene |
//! | `corr/{policy}/{n}/arrows` | demo action -> F and F -> rematch, `Arrows2D` |
//! | `corr/{policy}/{n}/l`, `.../c` | scalars L and C (Eq. 4, Eq. 7) |
//! | `metrics/...` | progress and running trial metrics |
//! | `status` | a markdown note: phase, action, chosen pair |
//! | `runs/{run}/...` | all of the above for one run, when a recording holds two runs side by side |

/// Timeline: index of the trial within a recording (sequence).
pub const TIMELINE_TRIAL: &str = "trial";
/// Timeline: index of the action within the trial (sequence).
pub const TIMELINE_ACTION: &str = "action";
/// Timeline: a counter that advances once per phase (embed, match, verify, act),
/// monotonic over the whole recording so it can be scrubbed.
pub const TIMELINE_PHASE: &str = "phase";

pub const WORLD: &str = "world";
pub const WORLD_BLOCKS: &str = "world/blocks";
pub const WORLD_GRIPPER: &str = "world/gripper";
pub const WORLD_ACTION: &str = "world/action";
pub const WORLD_TABLE: &str = "world/table";

pub const TEST: &str = "test";
pub const TEST_COLOR: &str = "test/color";
pub const TEST_DEPTH: &str = "test/depth";
pub const TEST_ACTION: &str = "test/action";

pub const STATUS: &str = "status";

pub const METRICS_PROGRESS: &str = "metrics/progress";
pub const METRICS_MAX_PROGRESS: &str = "metrics/max_progress";
pub const METRICS_ACTIONS: &str = "metrics/actions";
pub const METRICS_SUCCESS_RATE: &str = "metrics/success_rate";
pub const METRICS_MEAN_PROGRESS: &str = "metrics/mean_progress";

/// `runs/{run}`: the root of one run's entities in a recording of two runs
/// side by side; characters other than ASCII letters, digits, `-` and `_`
/// become `-` (an embedding set's `@`, for one).
pub fn run(run: &str) -> String {
    let name: String = run
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect();
    format!("runs/{name}")
}

/// `demo/{n}`.
pub fn demo(n: usize) -> String {
    format!("demo/{n}")
}

/// `demo/{n}/color`.
pub fn demo_color(n: usize) -> String {
    format!("demo/{n}/color")
}

/// `demo/{n}/depth`.
pub fn demo_depth(n: usize) -> String {
    format!("demo/{n}/depth")
}

/// `demo/{n}/action`.
pub fn demo_action(n: usize) -> String {
    format!("demo/{n}/action")
}

/// `corr/{policy}/{n}`.
pub fn corr(policy: &str, n: usize) -> String {
    format!("corr/{policy}/{n}")
}

/// `corr/{policy}/{n}/match`.
pub fn corr_match(policy: &str, n: usize) -> String {
    format!("{}/match", corr(policy, n))
}

/// `corr/{policy}/{n}/rematch`.
pub fn corr_rematch(policy: &str, n: usize) -> String {
    format!("{}/rematch", corr(policy, n))
}

/// `corr/{policy}/{n}/arrows`.
pub fn corr_arrows(policy: &str, n: usize) -> String {
    format!("{}/arrows", corr(policy, n))
}

/// `corr/{policy}/{n}/pca_live`: the policy's live embeddings at the
/// matched rotation, as RGB of their first three principal components
/// (computed jointly with [`corr_pca_demo`]).
pub fn corr_pca_live(policy: &str, n: usize) -> String {
    format!("{}/pca_live", corr(policy, n))
}

/// `corr/{policy}/{n}/pca_demo`: the policy's embeddings of demo `n`'s step
/// at the demonstrated rotation, in the same colours as [`corr_pca_live`].
pub fn corr_pca_demo(policy: &str, n: usize) -> String {
    format!("{}/pca_demo", corr(policy, n))
}

/// `corr/{policy}/{n}/l`.
pub fn corr_l(policy: &str, n: usize) -> String {
    format!("{}/l", corr(policy, n))
}

/// `corr/{policy}/{n}/c`.
pub fn corr_c(policy: &str, n: usize) -> String {
    format!("{}/c", corr(policy, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_are_hierarchical() {
        assert_eq!(
            corr_match("vertical-square", 1),
            "corr/vertical-square/1/match"
        );
        assert_eq!(demo_color(0), "demo/0/color");
        assert!(WORLD_BLOCKS.starts_with(WORLD));
        assert!(TEST_COLOR.starts_with(TEST));
        assert_eq!(run("ssr-ccd@raw-patches"), "runs/ssr-ccd-raw-patches");
    }
}
