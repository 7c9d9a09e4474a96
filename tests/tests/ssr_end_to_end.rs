//! SSR end to end on small inputs: identity scenes, tie order, resumable evaluation.

use seespot_eval::EvalMethod;
use seespot_eval::RunSpec;
use seespot_eval::run::CorrespondName;
use seespot_eval::run_task;
use seespot_eval::runner::{EvalConfig, world_config};
use seespot_policy::PolicyNet;
use seespot_sim::{Demo, Primitive, Seeds, TaskId, TrialRecord};
use seespot_ssr::correspond::Correspondence;
use seespot_ssr::layout::records_path;
use seespot_ssr::policy::{DemoQuery, SsrConfig, SsrPolicy, choose, chosen_pair};
use seespot_ssr::{CorrespondOptions, Layout, Method};

/// The 112 px set's demonstrations, the quick world of these tests (the
/// shipped 224 px set's are in `demos/`).
fn demos_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../demos/112px")
}

fn demos(task: TaskId) -> Vec<Demo> {
    Layout::new("models", demos_dir())
        .demo_dirs(task)
        .iter()
        .map(|d| Demo::read(d).expect("shipped demo"))
        .collect()
}

/// Every shipped demonstration action lies inside the test-time mask of its
/// own state (the reference zeroed the embeddings outside it, so the rematch
/// could not return to an action outside). Row's places need the oracle's
/// mask-aware search (`Oracle::act_within`): its 5 cm dilation reaches 24 mm
/// past a block's pixels, less than half a block.
#[test]
fn shipped_demo_actions_lie_inside_their_test_time_masks() {
    use seespot_ssr::correspond::reference::ssr_mask;
    let (mut steps, mut outside) = (0, Vec::new());
    for task in TaskId::ALL {
        for (d, demo) in demos(task).iter().enumerate() {
            for (i, step) in demo.steps.iter().enumerate() {
                let a = step.meta.action;
                let n = step.heightmaps.resolution();
                let mask = ssr_mask(&step.heightmaps, a.primitive, task);
                steps += 1;
                if !mask[a.y * n + a.x] {
                    outside.push((task, d, i, a.primitive));
                }
            }
        }
    }
    // Stack and unstack take 6 actions, row and vertical square 4 from their starts.
    assert_eq!(steps, 2 * (6 + 6 + 4 + 4), "shipped demo steps");
    assert!(outside.is_empty(), "outside their masks: {outside:?}");
}

/// The oracle keeps row's places inside the test-time mask from other
/// starts too, one more block in the row with every place.
#[test]
fn row_demos_recorded_from_other_starts_keep_their_places_inside_the_mask() {
    use seespot_ssr::correspond::reference::{record_demo, ssr_mask};
    for seed in (4..=24).step_by(4) {
        let demo = record_demo(TaskId::Row, seed, seespot_sim::WorldConfig::default())
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        for (i, step) in demo.steps.iter().enumerate() {
            let a = step.meta.action;
            let n = step.heightmaps.resolution();
            assert!(
                ssr_mask(&step.heightmaps, a.primitive, TaskId::Row)[a.y * n + a.x],
                "seed {seed} step {i}: {a:?} outside its mask"
            );
            if a.primitive == Primitive::Place {
                assert_eq!(
                    step.meta.progress_after,
                    step.meta.progress_before + 1,
                    "seed {seed} step {i}"
                );
            }
        }
    }
}

fn untrained_policies(task: TaskId) -> Vec<(String, seespot_policy::Embedder)> {
    TaskId::ALL
        .into_iter()
        .filter(|t| *t != task)
        .enumerate()
        .map(|(i, t)| {
            let net = PolicyNet::new(t, 112, 10 + i as u64).expect("net");
            (t.as_str().to_string(), net.into())
        })
        .collect()
}

#[test]
fn live_scene_identical_to_the_demo_scene_reproduces_the_demo_action() {
    let task = TaskId::Stack;
    let demos = demos(task);
    for method in [Method::SsrCcd, Method::SsrL2cd] {
        let config = SsrConfig {
            rule: method,
            correspond: CorrespondOptions::default(),
            ..SsrConfig::default()
        };
        let mut ssr =
            SsrPolicy::new(task, untrained_policies(task), demos.clone(), config).expect("ssr");
        for step in [0usize, 1, 2] {
            let s = &demos[0].steps[step];
            let d = ssr
                .decide(
                    &s.heightmaps,
                    s.meta.progress_before,
                    s.meta.action.primitive,
                )
                .expect("decide");
            let chosen = &d.pairs[d.chosen];
            assert_eq!(
                chosen.demo, 0,
                "{method:?} step {step}: the identical demo should win"
            );
            assert_eq!(d.action, s.meta.action, "{method:?} step {step}");
            assert_eq!(chosen.c, 0.0);
            assert!(chosen.l < 1e-3, "L = {}", chosen.l);
            // The explanation carries full-size heatmaps.
            assert_eq!(chosen.match_map.len(), 112 * 112);
            assert_eq!(d.pairs.len(), 3 * 2);
        }
    }
}

/// `--rematch global` (the reference trial runner's pair): every pair's C is
/// the squared 2 mm pixel distance from its live match to its rematch, which
/// may lie anywhere in the demo action's rotation plane; on the demo scene
/// itself the identical demo's pairs match the demo action with C = 0.
#[test]
fn global_rematch_measures_c_from_the_live_match() {
    use seespot_ssr::correspond::{Rematch, reference::ccd_reference};
    let task = TaskId::Stack;
    let demos = demos(task);
    let config = SsrConfig {
        rule: Method::SsrCcd,
        correspond: CorrespondOptions::Reference {
            demo_features: Default::default(),
            smoothing: Default::default(),
            rematch: Rematch::Global,
        },
        ..SsrConfig::default()
    };
    let mut ssr =
        SsrPolicy::new(task, untrained_policies(task), demos.clone(), config).expect("ssr");
    for step in [0usize, 1] {
        for (d, demo) in demos.iter().enumerate() {
            let s = &demo.steps[step];
            let dec = ssr
                .decide(
                    &s.heightmaps,
                    s.meta.progress_before,
                    s.meta.action.primitive,
                )
                .expect("decide");
            // The identical demo's pairs come back to where they started.
            let own = dec
                .pairs
                .iter()
                .find(|p| p.demo == d)
                .expect("a pair of this demo");
            assert_eq!(own.matched, s.meta.action, "demo {d} step {step}");
            assert_eq!(own.c, 0.0);
            assert_eq!(dec.pairs[dec.chosen].c, 0.0);
        }
    }
    // On fresh starts: the matches are those of the default (the option
    // changes only the rematch and C), and C is measured from each match.
    let mut window = SsrPolicy::new(
        task,
        untrained_policies(task),
        demos.clone(),
        SsrConfig {
            rule: Method::SsrCcd,
            ..SsrConfig::default()
        },
    )
    .expect("ssr");
    for seed in [1, 3, 5, 7] {
        let hm = seespot_sim::Trial::new(world_config(112), task, seed)
            .world()
            .render();
        let dec = ssr.decide(&hm, 1, Primitive::Grasp).expect("decide");
        let def = window.decide(&hm, 1, Primitive::Grasp).expect("decide");
        let pixel = hm.grid.pixel_size();
        for (p, q) in dec.pairs.iter().zip(&def.pairs) {
            assert_eq!((p.matched, p.l), (q.matched, q.l));
            assert_eq!(p.c, ccd_reference(&p.matched, &p.rematch, pixel));
            assert_eq!(p.rematch.rotation, p.demo_action.rotation);
        }
    }
    assert_eq!(
        RunSpec::new(EvalMethod::SsrCcd)
            .with_correspond(CorrespondName::of(&config.correspond))
            .expect("ssr")
            .to_string(),
        "ssr-ccd-global-rematch"
    );
}

#[test]
fn click_to_query_at_the_demo_action_is_zero_at_the_same_pixel() {
    let task = TaskId::Row;
    let demos = demos(task);
    let mut ssr = SsrPolicy::new(
        task,
        untrained_policies(task),
        demos.clone(),
        SsrConfig::default(),
    )
    .expect("ssr");
    let s = &demos[1].steps[0];
    ssr.decide(&s.heightmaps, s.meta.progress_before, Primitive::Grasp)
        .expect("decide");
    let a = s.meta.action;
    let q = DemoQuery {
        policy: 0,
        demo: 1,
        step: 0,
        y: a.y,
        x: a.x,
    };
    let map = ssr.query(q).expect("query");
    assert_eq!(map.len(), 112 * 112);
    assert!(map[a.y * 112 + a.x] < 1e-3);
    assert!(ssr.query(DemoQuery { y: 500, x: 0, ..q }).is_err());
}

#[test]
fn ties_are_broken_in_the_documented_order() {
    use seespot_sim::Action;
    use seespot_ssr::PairExplanation;
    let pair = |l: f32, c: f32| PairExplanation {
        policy: TaskId::Row.as_str().to_string(),
        demo: 0,
        demo_step: 0,
        demo_action: Action::new(Primitive::Grasp, 0, 0, 0),
        l,
        matched: Action::new(Primitive::Grasp, 0, 0, 0),
        rematch: Action::new(Primitive::Grasp, 0, 0, 0),
        rematch_l: 0.0,
        c,
        c_unit: seespot_ssr::correspond::CUnit::SquaredReferencePixels,
        match_map: vec![],
        rematch_map: vec![],
    };
    let pairs = vec![
        pair(3.0, 2.0),
        pair(1.0, 2.0),
        pair(1.0, 5.0),
        pair(1.0, 2.0),
    ];
    let plain = Correspondence::Plain;
    // Plain, CCD: smallest C (2.0, pairs 0, 1, 3), then smallest L (pairs 1, 3), then first.
    assert_eq!(choose(&pairs, Method::SsrCcd, plain), 1);
    // Plain, L2CD: smallest L (1, 2, 3), then smallest C (1, 3), then first.
    assert_eq!(choose(&pairs, Method::SsrL2cd, plain), 1);
    // Reference: the smallest C (or L), ties to the first pair (numpy argmin).
    let reference = Correspondence::Reference;
    assert_eq!(choose(&pairs, Method::SsrCcd, reference), 0);
    assert_eq!(choose(&pairs, Method::SsrL2cd, reference), 1);
    let mut pairs = vec![pair(2.0, 0.0), pair(1.0, 4.0)];
    for mode in [plain, reference] {
        assert_eq!(choose(&pairs, Method::SsrCcd, mode), 0);
        assert_eq!(choose(&pairs, Method::SsrL2cd, mode), 1);
    }
    // The record of the chosen pair names what the other distance would do.
    pairs[1].matched = Action::new(Primitive::Grasp, 3, 7, 9);
    let ccd = chosen_pair(&pairs, 0, Method::SsrCcd, reference);
    assert_eq!(ccd.other_method_action, Some(pairs[1].matched));
    let l2cd = chosen_pair(&pairs, 1, Method::SsrL2cd, reference);
    assert_eq!(l2cd.other_method_action, Some(pairs[0].matched));
}

/// Stack seed 3: the faithful SSR CCD repeats one failed grasp until the
/// 30-action limit with the 112 px set (`models/oracle-guided/`). The loop-breaking
/// extension never executes an action inside the masked neighbourhood of an
/// action that left the scene unchanged.
#[test]
fn loop_breaking_never_repeats_an_action_that_changed_nothing() {
    use seespot_sim::actor::run_trial;
    use seespot_ssr::policy::LOOP_BREAK_RADIUS;
    let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/oracle-guided");
    let config = SsrConfig {
        extensions: seespot_ssr::extension::Extensions::named(&["loop-break"]).expect("valid"),
        ..SsrConfig::default()
    };
    let mut ssr =
        SsrPolicy::load(TaskId::Stack, &Layout::new(&models, demos_dir()), config).expect("ssr");
    let world = world_config(112);
    let mut trial = seespot_sim::Trial::new(world, TaskId::Stack, 3);
    let mut observed = Vec::new();
    let record = run_trial(&mut trial, &mut ssr, "ssr-ccd-loopbreak", 0, &mut |a| {
        observed.push(a.action)
    })
    .expect("trial");
    let r = (LOOP_BREAK_RADIUS / world.grid.pixel_size()).round() as usize;
    let mut repeats = 0;
    for w in record.actions_log.windows(2) {
        let (a, b) = (w[0].action, w[1].action);
        // A failed grasp leaves the scene as it was: the next grasp keeps away.
        if w[0].primitive_success == Some(false) && a.primitive == Primitive::Grasp {
            repeats += 1;
            assert!(
                b.y.abs_diff(a.y) > r || b.x.abs_diff(a.x) > r || b.primitive != a.primitive,
                "{b:?} repeats the failed {a:?}"
            );
        }
    }
    assert_eq!(observed.len(), record.actions_log.len());
    assert!(
        record.success || repeats > 0,
        "the trial neither succeeded nor met a failed grasp to test"
    );
}

/// Regrasp and replacing (`ssr-ccd-replace`): after a failed grasp, the
/// next grasp in the same scene is never on the failed grasp's axis within
/// its neighbourhood, and never anywhere within it when the grasp came down
/// on the bare table; each such mask is a departure the record names.
#[test]
fn regrasp_keeps_away_from_a_failed_grasp_axis_and_says_so() {
    use seespot_sim::actor::run_trial;
    use seespot_ssr::explain::{LEFT_UNCHANGED, REGRASP};
    use seespot_ssr::policy::{LOOP_BREAK_RADIUS, regrasp_rotations};
    let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/oracle-guided");
    let config = EvalMethod::SsrCcdReplace.ssr_config(Default::default());
    assert_eq!(
        config.extensions.names(),
        ["loop-break", "regrasp", "replace", "reversal-guard"]
    );
    let world = world_config(112);
    let r = (LOOP_BREAK_RADIUS / world.grid.pixel_size()).round() as usize;
    let (mut tested, mut on_something) = (0, 0);
    for (task, seed) in [
        (TaskId::Stack, 3),
        (TaskId::Row, 3),
        (TaskId::VerticalSquare, 5),
    ] {
        let mut ssr =
            SsrPolicy::load(task, &Layout::new(&models, demos_dir()), config).expect("ssr");
        let mut trial = seespot_sim::Trial::new(world, task, seed);
        let record =
            run_trial(&mut trial, &mut ssr, "ssr-ccd-replace", 0, &mut |_| {}).expect("trial");
        for w in record.actions_log.windows(2) {
            let (a, b) = (w[0].action, w[1].action);
            if w[0].primitive_success != Some(false) || a.primitive != Primitive::Grasp {
                continue;
            }
            tested += 1;
            let said = w[1]
                .departures
                .iter()
                .find(|d| d.action == a)
                .unwrap_or_else(|| panic!("{task} seed {seed}: no departure names {a:?}"));
            let near = b.y.abs_diff(a.y) <= r && b.x.abs_diff(a.x) <= r;
            if said.why == REGRASP {
                on_something += 1;
                assert!(
                    !near || !regrasp_rotations(a.rotation, 16).contains(&b.rotation),
                    "{task} seed {seed}: {b:?} is on the axis of the failed {a:?}"
                );
            } else {
                assert_eq!(said.why, LEFT_UNCHANGED);
                assert!(!near, "{task} seed {seed}: {b:?} repeats the failed {a:?}");
            }
        }
    }
    eprintln!("{tested} failed grasps, {on_something} on something");
    assert!(
        tested > 0 && on_something > 0,
        "{tested} failed grasps, {on_something} on something"
    );
}

/// The record name of a configuration, as `seespot eval` names its records.
fn name_of(
    method: EvalMethod,
    finetune_steps: usize,
    correspond: CorrespondOptions,
    noisy: bool,
) -> String {
    let mut config = EvalConfig {
        method,
        seeds: Seeds::new(1, 1).expect("seeds"),
        out_dir: Default::default(),
        layout: Layout::default(),
        world: world_config(112),
        correspond,
        finetune_steps,
        finetune_procedure: seespot_policy::finetune::FinetuneProcedure::Reference,
        truth: false,
    };
    if noisy {
        config.world.noise = seespot_sim::noise::SensorNoise {
            depth_std: 0.002,
            color_jitter: 8,
        };
    }
    let spec = config.spec();
    assert_eq!(spec.to_string().parse::<RunSpec>(), Ok(spec));
    spec.to_string()
}

#[test]
fn noisy_and_extension_runs_have_their_own_record_names() {
    let plain = CorrespondOptions::of_mode(Correspondence::Plain);
    let reference = CorrespondOptions::default();
    assert_eq!(name_of(EvalMethod::SsrCcd, 0, reference, false), "ssr-ccd");
    assert_eq!(
        name_of(EvalMethod::SsrCcd, 0, reference, true),
        "ssr-ccd-noisy"
    );
    assert_eq!(
        name_of(EvalMethod::SsrL2cd, 0, plain, false),
        "ssr-l2cd-plain"
    );
    assert_eq!(
        name_of(EvalMethod::SsrCcdLoopBreak, 0, reference, false),
        "ssr-ccd-loopbreak"
    );
    assert_eq!(
        name_of(EvalMethod::SsrCcd, 333, reference, false),
        "ssr-ccd-finetuned"
    );
    assert_eq!(
        name_of(EvalMethod::SpotQ, 333, reference, false),
        "good-robot-finetuned"
    );
    assert_eq!(
        EvalMethod::parse("ssr-ccd-loopbreak"),
        Some(EvalMethod::SsrCcdLoopBreak)
    );
    // The named departures of the reference Correspond.
    use seespot_ssr::correspond::{DemoFeatures, Rematch, Smoothing};
    let departing = |demo_features, smoothing, rematch| CorrespondOptions::Reference {
        demo_features,
        smoothing,
        rematch,
    };
    let normalized = departing(DemoFeatures::Zeroed, Smoothing::Normalized, Rematch::Window);
    assert_eq!(
        name_of(EvalMethod::SsrL2cd, 0, normalized, false),
        "ssr-l2cd-normalized"
    );
    let demo_real = departing(DemoFeatures::Real, Smoothing::Reference, Rematch::Window);
    assert_eq!(
        name_of(EvalMethod::SsrCcd, 0, demo_real, true),
        "ssr-ccd-demo-real-noisy"
    );
    assert_eq!(name_of(EvalMethod::Oracle, 0, normalized, false), "oracle");
    // Combined departures keep every one in the name, so no two settings
    // share a record file.
    let both = departing(DemoFeatures::Real, Smoothing::Normalized, Rematch::Window);
    assert_eq!(
        name_of(EvalMethod::SsrCcd, 0, both, false),
        "ssr-ccd-normalized-demo-real"
    );
    let all = departing(DemoFeatures::Real, Smoothing::Normalized, Rematch::Global);
    assert_eq!(
        name_of(EvalMethod::SsrCcd, 333, all, true),
        "ssr-ccd-normalized-demo-real-global-rematch-finetuned-noisy"
    );
}

#[test]
fn evaluation_writes_records_and_resumes_after_interruption() {
    let out = tempfile::tempdir().expect("tempdir");
    let config = EvalConfig {
        method: EvalMethod::Oracle,
        seeds: Seeds::new(1, 3).expect("test seeds"),
        out_dir: out.path().to_owned(),
        layout: Layout::new("models", demos_dir()),
        world: world_config(112),
        correspond: CorrespondOptions::default(),
        finetune_steps: 0,
        finetune_procedure: seespot_policy::finetune::FinetuneProcedure::Reference,
        truth: false,
    };
    let first = run_task(&config, TaskId::Row, &mut |_| {}).expect("eval");
    assert_eq!(first.len(), 3);
    let path = records_path(out.path(), "oracle", TaskId::Row);
    let text = seespot_eval::records::read_text(&path).expect("records");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3);
    for (i, line) in lines.iter().enumerate() {
        let v: serde_json::Value = serde_json::from_str(line).expect("json line");
        assert_eq!(v["trial"], i);
        assert_eq!(v["seed"], 1 + 2 * i as u64);
        assert_eq!(
            v["actions"].as_u64().expect("actions") as usize,
            v["actions_log"].as_array().expect("log").len()
        );
    }
    // Interrupt: keep one full record and half of the next.
    let member = |i: usize| seespot_eval::records::record_member(&first[i]).expect("member");
    let (one, two) = (member(0), member(1));
    std::fs::write(&path, [&one[..], &two[..two.len() / 2]].concat()).expect("truncate");
    let mut seen_new = 0;
    let resumed = run_task(&config, TaskId::Row, &mut |_| seen_new += 1).expect("resume");
    assert_eq!(resumed.len(), 3);
    // Same seeds, same trials (decision times aside).
    let untimed = |rs: &[TrialRecord]| {
        let mut rs = rs.to_vec();
        rs.iter_mut()
            .flat_map(|r| r.actions_log.iter_mut())
            .for_each(|a| a.decide_ms = 0.0);
        rs
    };
    assert_eq!(untimed(&resumed), untimed(&first));
    assert_eq!(
        seespot_eval::records::read_text(&path)
            .expect("records")
            .lines()
            .count(),
        3
    );
    assert_eq!(seen_new, 3);

    // Another seed range into the same file: records count for the seed they
    // name, never for their position (seeds 1, 3, 5 are not reused as 101-105).
    let later = EvalConfig {
        seeds: Seeds::new(101, 3).expect("test seeds"),
        ..config.clone()
    };
    let other = run_task(&later, TaskId::Row, &mut |_| {}).expect("other seeds");
    assert_eq!(
        other.iter().map(|r| r.seed).collect::<Vec<_>>(),
        vec![101, 103, 105]
    );
    // Every record names what it was made with, and a run with other settings
    // is refused instead of mixed into the same file.
    assert!(other.iter().all(|r| {
        r.provenance
            .as_ref()
            .is_some_and(|p| p.settings["correspond"] == "reference" && p.settings.is_object())
    }));
    // (The oracle does not correspond: its records name no Correspond
    // options, so another resolution stands for other settings here.)
    let mixed = EvalConfig {
        world: world_config(224),
        ..config.clone()
    };
    let refused = run_task(&mixed, TaskId::Row, &mut |_| {})
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(refused.contains("another --out"), "{refused}");
    // And a longer run reuses the three recorded seeds and adds the rest.
    let longer = EvalConfig {
        seeds: Seeds::new(1, 4).expect("test seeds"),
        ..config
    };
    let mut ran = 0;
    let four = run_task(&longer, TaskId::Row, &mut |_| ran += 1).expect("longer");
    assert_eq!(
        four.iter().map(|r| r.seed).collect::<Vec<_>>(),
        vec![1, 3, 5, 7]
    );
    assert_eq!(untimed(&four[..3]), untimed(&first));
    assert_eq!(ran, 4);
}

/// `seespot view --replay` rebuilds a record's run from its provenance: the
/// same trial again, and a refusal once a demonstration file has changed.
#[test]
fn a_record_replays_exactly_and_is_refused_after_its_files_change() {
    use seespot_eval::runner::replay_config;
    let tmp = tempfile::tempdir().expect("tempdir");
    let demos = tmp.path().join("demos");
    for dir in Layout::new("models", demos_dir()).demo_dirs(TaskId::Unstack) {
        let to = demos
            .join("unstack")
            .join(dir.file_name().expect("seed folder"));
        std::fs::create_dir_all(&to).expect("mkdir");
        for f in std::fs::read_dir(&dir).expect("demo folder") {
            let f = f.expect("entry").path();
            std::fs::copy(&f, to.join(f.file_name().expect("name"))).expect("copy");
        }
    }
    let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/oracle-guided");
    let config = EvalConfig {
        method: EvalMethod::SsrL2cd,
        seeds: Seeds::new(5, 1).expect("test seed"),
        out_dir: tmp.path().join("out"),
        layout: Layout::new(&models, &demos),
        world: world_config(112),
        correspond: CorrespondOptions::default(),
        finetune_steps: 0,
        finetune_procedure: seespot_policy::finetune::FinetuneProcedure::Reference,
        truth: false,
    };
    let record = run_task(&config, TaskId::Unstack, &mut |_| {})
        .expect("eval")
        .remove(0);
    let again =
        replay_config(&record, &Layout::new(&models, &demos), &config.out_dir).expect("replayable");
    assert_eq!(again.method, EvalMethod::SsrL2cd);
    assert_eq!(again.world.grid.resolution, 112);
    let mut ssr = SsrPolicy::load(
        TaskId::Unstack,
        &Layout::new(&models, &demos),
        SsrConfig {
            rule: Method::SsrL2cd,
            ..SsrConfig::default()
        },
    )
    .expect("ssr");
    let mut trial = seespot_sim::Trial::new(again.world, TaskId::Unstack, record.seed);
    let replayed =
        seespot_sim::run_trial(&mut trial, &mut ssr, "ssr-l2cd", 0, &mut |_| {}).expect("replay");
    let actions = |r: &TrialRecord| r.actions_log.iter().map(|a| a.action).collect::<Vec<_>>();
    assert_eq!(actions(&replayed), actions(&record));
    assert_eq!(replayed.success, record.success);
    // One demonstration file changes: the replay is refused, naming it.
    let meta = demos.join("unstack").join("0").join("meta.json");
    let mut text = std::fs::read_to_string(&meta).expect("meta");
    text.push('\n');
    std::fs::write(&meta, text).expect("write");
    let err = replay_config(&record, &Layout::new(&models, &demos), &config.out_dir)
        .expect_err("changed demo")
        .to_string();
    assert!(err.contains("meta.json"), "{err}");
}

/// `seespot review` counts every committed record once, and every failure
/// gets a kind.
#[test]
fn the_review_of_the_committed_results_counts_every_record() {
    use seespot_eval::review::{counts, review_dir};
    let results = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../results");
    let trials = review_dir(&results).expect("review");
    let mut lines = 0;
    for m in std::fs::read_dir(results.join("trials")).expect("trials") {
        for f in std::fs::read_dir(m.expect("method").path()).expect("method dir") {
            let f = f.expect("file").path();
            if f.extension().is_some_and(|e| e == "gz") {
                lines += seespot_eval::records::read_text(&f)
                    .expect("records")
                    .lines()
                    .filter(|l| l.trim_end().ends_with('}'))
                    .count();
            }
        }
    }
    assert_eq!(trials.len(), lines);
    for (method, task, n, ok, kinds) in counts(&trials) {
        assert_eq!(ok + kinds.iter().sum::<usize>(), n, "{method} {task}");
    }
    assert!(trials.iter().all(|t| t.success == t.failure.is_none()));
}

/// Every committed trial record (the shipped set's in `results/trials/` and
/// `results/validation/` and `results/custom/`)
/// names the model and demonstration files it was made with by checksums
/// that match the shipped files, and records of one file agree on them.
#[test]
fn committed_records_carry_the_checksums_of_the_shipped_files() {
    use seespot_eval::runner::sha256_file;
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut known = std::collections::BTreeMap::<String, String>::new();
    let (mut records, mut files_checked) = (0, 0);
    for dir in ["results", "results/validation", "results/custom"] {
        use seespot_eval::records::{custom_records_files, records_files};
        let out = root.join(dir);
        let files = records_files(&out).expect("records files");
        let custom = custom_records_files(&out).expect("custom records files");
        assert!(!files.is_empty() || !custom.is_empty(), "{dir}: no records");
        for path in files.into_iter().chain(custom) {
            for r in seespot_eval::records::read_records(&path).expect("records") {
                records += 1;
                let p = r
                    .provenance
                    .unwrap_or_else(|| panic!("{}: a record without provenance", path.display()));
                for (file, sum) in p.files {
                    let want = known.entry(file.clone()).or_insert_with(|| {
                        files_checked += 1;
                        sha256_file(&root.join(&file))
                            .unwrap_or_else(|e| panic!("{}: {file}: {e}", path.display()))
                    });
                    assert_eq!(&sum, want, "{}: {file}", path.display());
                }
            }
        }
    }
    // Twelve runs of 200 trials at least.
    assert!(records >= 12 * 200, "{records} records");
    assert!(files_checked > 0);
}

/// Re-recording every shipped demonstration (`demos/` and `demos/112px/`)
/// from its seed gives exactly the shipped bytes: the
/// oracle, the physics and the PNG encoding are all deterministic, so the
/// README's re-record commands leave `git status` clean.
#[test]
fn every_shipped_demo_re_records_to_the_same_bytes() {
    use seespot_ssr::correspond::reference::record_demo;
    let mut checked = 0;
    let all = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../demos");
    for root in [all.clone(), demos_dir()] {
        for task in TaskId::ALL {
            for dir in Layout::new("models", &root).demo_dirs(task) {
                let shipped = Demo::read(&dir).expect("shipped demo");
                let config = seespot_sim::WorldConfig {
                    grid: seespot_sim::Grid::new(shipped.meta.resolution),
                    ..Default::default()
                };
                let again = record_demo(task, shipped.meta.seed, config).expect("record");
                let files = again.files(&dir).expect("encode");
                let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
                    .expect("demo dir")
                    .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                    .collect();
                on_disk.sort();
                let mut names: Vec<String> = files.iter().map(|(n, _)| n.clone()).collect();
                names.sort();
                assert_eq!(names, on_disk, "{}: the files", dir.display());
                for (name, bytes) in &files {
                    let there = std::fs::read(dir.join(name)).expect("shipped file");
                    assert!(&there == bytes, "{}: {name} has other bytes", dir.display());
                }
                checked += 1;
            }
        }
    }
    assert_eq!(
        checked, 16,
        "two demonstrations per task, at 224 px and 112 px"
    );
}

/// A custom task's goal is its demonstrations' final layout, so even a method
/// that reads no demonstration (random) records their checksums: records
/// scored against another definition of the task never mix with these.
#[test]
fn a_custom_task_records_the_demonstrations_that_define_it() {
    let layout = Layout::new("models", demos_dir());
    let task: TaskId = "custom:l-shape".parse().expect("custom task");
    layout.load_task(task).expect("shipped custom demos");
    let config = |method| EvalConfig {
        method,
        seeds: Seeds::new(1, 1).expect("test seeds"),
        out_dir: std::env::temp_dir(),
        layout: layout.clone(),
        world: world_config(112),
        correspond: CorrespondOptions::default(),
        finetune_steps: 0,
        finetune_procedure: seespot_policy::finetune::FinetuneProcedure::Reference,
        truth: false,
    };
    let prov =
        seespot_eval::runner::provenance(&config(EvalMethod::Random), task).expect("provenance");
    for n in 0..2 {
        let meta = format!("custom/l-shape/{n}/meta.json");
        assert!(
            prov.files.keys().any(|k| k.ends_with(&meta)),
            "no {meta} in {:?}",
            prov.files.keys().collect::<Vec<_>>()
        );
    }
    let builtin = seespot_eval::runner::provenance(&config(EvalMethod::Random), TaskId::Stack)
        .expect("provenance");
    assert!(
        builtin.files.is_empty(),
        "random on a built-in task reads no file"
    );
}
