//! Your network (issue 43): the shipped SPOT-Q policies exported to ONNX
//! (`seespot export onnx`) give the native path's SSR decisions, and a run on
//! an embedding set is named after it, carries its files' checksums, and
//! refuses a bad model before any trial.

#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use seespot_eval::run_task;
use seespot_eval::runner::world_config;
use seespot_eval::{EvalConfig, EvalMethod};
use seespot_policy::finetune::FinetuneProcedure;
use seespot_policy::onnx::export;
use seespot_sim::{Actor, Seeds, TaskId, Trial};
use seespot_ssr::correspond::CorrespondOptions;
use seespot_ssr::layout::Embeddings;
use seespot_ssr::{Layout, SsrConfig, SsrPolicy};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shipped policies as ONNX files in `dir` (`<task>.onnx`).
fn export_shipped(dir: &Path) {
    for t in TaskId::ALL {
        let file = Layout::new(root().join("models"), "").model(t);
        let policy = seespot_policy::PolicyNet::load(&file).expect("shipped policy");
        let model = export::policy_model(&policy).expect("export");
        export::write(&model, &dir.join(format!("{}.onnx", t.as_str()))).expect("write");
    }
}

/// The rounding bound of a decision's distances: the two engines sum the
/// same products in other orders, so a squared feature distance of 64
/// float32 terms differs by a few units in its last places. A relative 1e-4
/// covers that with room (float32's epsilon is 1.2e-7; features that agree
/// to 1e-5 of their scale, as `policy/tests/onnx.rs` checks, move a squared
/// distance by about twice that).
const NEAR_TIE: f32 = 1e-4;

#[test]
fn exported_shipped_policies_decide_as_the_native_ones() {
    let dir = tempfile::tempdir().expect("tempdir");
    export_shipped(dir.path());
    let native_layout = Layout::new(root().join("models"), root().join("demos"));
    let onnx_layout = native_layout
        .clone()
        .with_embeddings(Some(Embeddings::Folder(dir.path().to_path_buf())));
    let world = world_config(224);
    let (mut decisions, mut same) = (0usize, 0usize);
    for task in TaskId::ALL {
        let mut native =
            SsrPolicy::load(task, &native_layout, SsrConfig::default()).expect("native");
        let mut onnx = SsrPolicy::load(task, &onnx_layout, SsrConfig::default()).expect("onnx");
        assert_eq!(native.policy_names(), onnx.policy_names());
        for seed in [1u64, 3, 5, 7, 9] {
            // Both decide in every state of the native path's trial.
            let mut trial = Trial::new(world, task, seed);
            native.begin_trial(&trial);
            onnx.begin_trial(&trial);
            while trial.end().is_none() {
                let hm = trial.world_mut().observe();
                let a = native.act(&trial, &hm).expect("native decision");
                let b = onnx.act(&trial, &hm).expect("onnx decision");
                decisions += 1;
                if a.action == b.action {
                    same += 1;
                } else {
                    // A different action must be a near-tie: the distance
                    // each path decided on (C of the chosen pair, then its L)
                    // agrees within the rounding bound.
                    let (da, db) = (
                        native.last_decision().expect("a"),
                        onnx.last_decision().expect("b"),
                    );
                    let (pa, pb) = (&da.pairs[da.chosen], &db.pairs[db.chosen]);
                    let close =
                        |x: f32, y: f32| (x - y).abs() <= NEAR_TIE * x.abs().max(y.abs()).max(1.0);
                    assert!(
                        close(pa.c, pb.c) && close(pa.l, pb.l),
                        "{task} seed {seed}: native {:?} (C {}, L {}) vs ONNX {:?} (C {}, L {})",
                        a.action,
                        pa.c,
                        pa.l,
                        b.action,
                        pb.c,
                        pb.l
                    );
                }
                trial.step(a.action);
            }
        }
    }
    eprintln!("{same} of {decisions} decisions identical");
    assert!(decisions >= 4 * 5 * 2);
    assert!(same * 100 >= decisions * 95, "{same} of {decisions}");
}

fn config(out: &Path, embeddings: Option<Embeddings>) -> EvalConfig {
    EvalConfig {
        method: EvalMethod::SsrCcd,
        seeds: Seeds::new(1, 2).expect("seeds"),
        out_dir: out.to_path_buf(),
        layout: Layout::new(root().join("models"), root().join("demos"))
            .with_embeddings(embeddings),
        world: world_config(224),
        correspond: CorrespondOptions::default(),
        finetune_steps: 0,
        finetune_procedure: FinetuneProcedure::Reference,
        truth: false,
    }
}

#[test]
fn a_run_on_an_embedding_set_is_named_after_it_and_checksums_its_files() {
    let models = tempfile::tempdir().expect("tempdir");
    let patches = models.path().join("raw-patches.onnx");
    export::write(&export::raw_patches_model(), &patches).expect("write");
    let out = tempfile::tempdir().expect("tempdir");
    let c = config(out.path(), Some(Embeddings::Files(vec![patches.clone()])));
    assert_eq!(c.spec().to_string(), "ssr-ccd@raw-patches");
    assert_eq!(c.spec().display_name(), "SSR CCD, embeddings: raw-patches");
    let records = run_task(&c, TaskId::Stack, &mut |_| {}).expect("run");
    assert_eq!(records.len(), 2);
    let file = seespot_ssr::layout::records_path(out.path(), "ssr-ccd@raw-patches", TaskId::Stack);
    assert!(file.is_file(), "{}", file.display());
    let prov = records[0].provenance.as_ref().expect("provenance");
    let sha = seespot_eval::config::sha256_file(&patches).expect("sha");
    assert_eq!(prov.files.get(&patches.display().to_string()), Some(&sha));
    assert!(
        prov.settings["embeddings"]["files"].is_array(),
        "{}",
        prov.settings
    );
    // The pairs name the model.
    assert!(
        records[0]
            .actions_log
            .iter()
            .all(|a| a.chosen_policy.as_deref() == Some("raw-patches"))
    );
    // The shipped policies' run of the same folder never shares its file.
    let shipped = config(out.path(), None);
    assert_eq!(shipped.spec().to_string(), "ssr-ccd");
    // A replay rebuilds the set from the record.
    let again = seespot_eval::runner::replay_config(
        &records[1],
        &Layout::new(root().join("models"), root().join("demos")),
        out.path(),
    )
    .expect("replay config");
    assert_eq!(again.layout.embeddings, c.layout.embeddings);
}

#[test]
fn a_bad_model_is_refused_before_any_trial() {
    let models = tempfile::tempdir().expect("tempdir");
    let bad = models.path().join("broken.onnx");
    std::fs::write(&bad, b"this is not a protobuf").expect("write");
    let out = tempfile::tempdir().expect("tempdir");
    let c = config(out.path(), Some(Embeddings::Files(vec![bad.clone()])));
    let e = c
        .check_embeddings(&TaskId::ALL)
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("broken.onnx") && e.contains("not an ONNX model"),
        "{e}"
    );
    let e = run_task(&c, TaskId::Stack, &mut |_| {})
        .expect_err("refused")
        .to_string();
    assert!(e.contains("broken.onnx"), "{e}");
    assert!(
        !out.path().join("trials").exists(),
        "no records folder for a refused run"
    );
    // A folder that lacks a fold's model names the file.
    let folder = tempfile::tempdir().expect("tempdir");
    let c = config(
        out.path(),
        Some(Embeddings::Folder(folder.path().to_path_buf())),
    );
    let e = c
        .check_embeddings(&[TaskId::Row])
        .expect_err("refused")
        .to_string();
    assert!(e.contains("stack.onnx"), "{e}");
    // Methods that run no network of the set, SPOT-Q with a list of files
    // (no task's own), and finetuning refuse a set.
    let mut random = config(
        out.path(),
        Some(Embeddings::Folder(folder.path().to_path_buf())),
    );
    random.method = EvalMethod::Random;
    assert!(random.check_embeddings(&[]).is_err());
    let mut spot = config(out.path(), Some(Embeddings::Files(vec![bad.clone()])));
    spot.method = EvalMethod::SpotQ;
    let e = spot
        .check_embeddings(&[TaskId::Row])
        .unwrap_err()
        .to_string();
    assert!(e.contains("folder"), "{e}");
    let mut tuned = config(
        out.path(),
        Some(Embeddings::Folder(folder.path().to_path_buf())),
    );
    tuned.finetune_steps = 10;
    assert!(
        tuned
            .check_embeddings(&[])
            .unwrap_err()
            .to_string()
            .contains("finetuning")
    );
}

#[test]
fn exported_policies_act_as_spot_q_through_their_q_outputs() {
    let dir = tempfile::tempdir().expect("tempdir");
    export_shipped(dir.path());
    let (native_out, onnx_out) = (
        tempfile::tempdir().expect("tmp"),
        tempfile::tempdir().expect("tmp"),
    );
    for task in [TaskId::Stack, TaskId::Row] {
        let mut native = config(native_out.path(), None);
        native.method = EvalMethod::SpotQ;
        let mut onnx = config(
            onnx_out.path(),
            Some(Embeddings::Folder(dir.path().to_path_buf())),
        );
        onnx.method = EvalMethod::SpotQ;
        onnx.check_embeddings(&[task])
            .expect("the exported files have Q outputs");
        assert_eq!(
            onnx.spec().to_string(),
            format!(
                "spot-q@{}",
                dir.path()
                    .file_name()
                    .unwrap()
                    .to_string_lossy()
                    .to_lowercase()
                    .replace(|c: char| !c.is_ascii_alphanumeric() && c != '+', "-")
            )
        );
        let a = run_task(&native, task, &mut |_| {}).expect("native");
        let b = run_task(&onnx, task, &mut |_| {}).expect("onnx");
        for (ra, rb) in a.iter().zip(&b) {
            let acts = |r: &seespot_sim::TrialRecord| {
                r.actions_log.iter().map(|l| l.action).collect::<Vec<_>>()
            };
            assert_eq!(acts(ra), acts(rb), "{task} seed {}", ra.seed);
        }
    }
}
