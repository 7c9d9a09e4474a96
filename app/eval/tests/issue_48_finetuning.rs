//! The finetuned rows as the reference finetuned (issue 48): each finetuned
//! model is a file made once from its inputs, the same bytes every time, and
//! reused while its inputs stay the same; the annotated actions are counted
//! from the demonstrations.

use std::path::{Path, PathBuf};

use seespot_eval::finetuned::{INPUTS_KEY, good_robot_base, model_paths, prepare_models};
use seespot_eval::runner::world_config;
use seespot_eval::{EvalConfig, EvalMethod};
use seespot_policy::finetune::FinetuneProcedure;
use seespot_sim::{Seeds, TaskId};
use seespot_ssr::Layout;
use seespot_ssr::correspond::CorrespondOptions;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn config(method: EvalMethod, out: &Path, steps: usize) -> EvalConfig {
    EvalConfig {
        method,
        seeds: Seeds::new(1, 1).expect("seeds"),
        out_dir: out.to_path_buf(),
        layout: Layout::new(root().join("models"), root().join("demos")),
        world: world_config(224),
        correspond: CorrespondOptions::default(),
        finetune_steps: steps,
        finetune_procedure: FinetuneProcedure::Reference,
        truth: false,
    }
}

/// "Good Robot" finetuned on unstack starts from the stacking policy, whose
/// labels are the SPOT trial reward; on row from vertical square, whose
/// labels are bootstrapped from its own Q (the slower path). Both are made
/// twice in two folders: the same bytes; a third call in the first folder
/// finetunes nothing and leaves the file as it was.
#[test]
fn a_finetuned_model_is_the_same_bytes_from_the_same_inputs() {
    // 26 steps: one snapshot (after 25) to choose, as the reference's 333
    // choose among 13.
    let steps = 26;
    for fold in [TaskId::Unstack, TaskId::Row] {
        let a = tempfile::tempdir().expect("tempdir");
        let b = tempfile::tempdir().expect("tempdir");
        let mut made = Vec::new();
        let ca = config(EvalMethod::SpotQ, a.path(), steps);
        let models = prepare_models(&ca, fold, &mut |t| made.push(t)).expect("finetune");
        assert_eq!(made, vec![good_robot_base(fold)]);
        assert_eq!(models.len(), 1);
        let cb = config(EvalMethod::SpotQ, b.path(), steps);
        prepare_models(&cb, fold, &mut |_| {}).expect("finetune again");
        let (pa, pb) = (&model_paths(&ca, fold)[0], &model_paths(&cb, fold)[0]);
        let bytes = std::fs::read(pa).expect("first file");
        assert_eq!(bytes, std::fs::read(pb).expect("second file"), "{fold}");
        // The file differs from its base: finetuning moved the weights.
        let base = std::fs::read(
            root()
                .join("models")
                .join(format!("{}.safetensors", good_robot_base(fold).as_str())),
        )
        .expect("base");
        assert_ne!(bytes.len(), 0);
        assert_ne!(bytes, base);
        let meta = &models[0].1.meta.extra;
        assert!(meta.contains_key(INPUTS_KEY), "{meta:?}");
        assert_eq!(
            meta.get("finetune_kept_step").map(String::as_str),
            Some("25")
        );
        // Reused: nothing finetuned, the same file.
        let mut again = Vec::new();
        prepare_models(&ca, fold, &mut |t| again.push(t)).expect("reuse");
        assert!(again.is_empty(), "{fold}: refinetuned {again:?}");
        assert_eq!(std::fs::read(pa).expect("file"), bytes);
    }
}

/// A file made from other inputs (here: other steps under the same name) is
/// not reused: it is made again.
#[test]
fn a_stale_finetuned_model_is_made_again() {
    let dir = tempfile::tempdir().expect("tempdir");
    let c = config(EvalMethod::SpotQ, dir.path(), 2);
    prepare_models(&c, TaskId::Unstack, &mut |_| {}).expect("finetune");
    let path = model_paths(&c, TaskId::Unstack)[0].clone();
    // Another file's bytes under this name: its inputs are not today's.
    let other = config(EvalMethod::SpotQ, dir.path(), 3);
    prepare_models(&other, TaskId::Unstack, &mut |_| {}).expect("finetune");
    std::fs::copy(&model_paths(&other, TaskId::Unstack)[0], &path).expect("copy");
    let mut made = Vec::new();
    prepare_models(&c, TaskId::Unstack, &mut |t| made.push(t)).expect("again");
    assert_eq!(made, vec![TaskId::Stack]);
}

/// The annotated actions are the demonstrations' own: 6 + 6 for stack and
/// unstack, 4 + 4 for row and vertical square with the shipped demos, and
/// one demonstration fewer counts its actions fewer.
#[test]
fn annotated_actions_follow_the_demonstrations() {
    let layout = Layout::new(root().join("models"), root().join("demos"));
    let count = |l: &Layout, t| seespot_eval::metrics::demo_actions(l, t).expect("count");
    for task in TaskId::ALL {
        let by_hand: usize = layout
            .demo_dirs(task)
            .iter()
            .map(|d| seespot_sim::Demo::read(d).expect("demo").steps.len())
            .sum();
        assert_eq!(count(&layout, task), by_hand, "{task}");
    }
    assert_eq!(count(&layout, TaskId::Row), 8);
    assert_eq!(count(&layout, TaskId::Stack), 12);
    // Only the first row demonstration: its 4 actions.
    let dir = tempfile::tempdir().expect("tempdir");
    let first = &layout.demo_dirs(TaskId::Row)[0];
    let copy = dir
        .path()
        .join("row")
        .join(first.file_name().expect("seed folder"));
    std::fs::create_dir_all(&copy).expect("mkdir");
    for e in std::fs::read_dir(first).expect("read") {
        let e = e.expect("entry");
        std::fs::copy(e.path(), copy.join(e.file_name())).expect("copy");
    }
    let one = Layout::new(root().join("models"), dir.path());
    assert_eq!(count(&one, TaskId::Row), 4);
}
