//! The shipped policies under models/ load, say which task they were trained
//! on, and embed the same scene differently.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use seespot_policy::PolicyNet;
use seespot_policy::bench::scene;
use seespot_sim::{Primitive, TaskId};

fn model(task: TaskId) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(format!("{task}.safetensors"))
}

/// The shipped set is the paper's: 224 px, the trunk with conv5 dilated 8,
/// trained by reinforcement learning alone (no oracle action) for at least
/// 40 000 actions; the weights kept are the run's best snapshot, and the file
/// names both the snapshot's point and the whole run.
#[test]
fn shipped_weights_were_trained_as_the_paper_trained_them() {
    for task in TaskId::ALL {
        let path = model(task);
        let policy = PolicyNet::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let meta = &policy.meta;
        let fact = |k: &str| {
            meta.extra
                .get(k)
                .unwrap_or_else(|| panic!("{}: no {k}", path.display()))
                .clone()
        };
        assert_eq!(meta.resolution, 224, "{}", path.display());
        assert_eq!(
            policy.trunk().architecture(),
            "spotq-fcn-s4-c64-d8",
            "{}",
            path.display()
        );
        let run_actions: usize = fact("run_actions").parse().unwrap();
        assert!(run_actions >= 40_000, "{}: {run_actions}", path.display());
        let kept: usize = fact("train_actions").parse().unwrap();
        assert!(kept <= run_actions, "{}", path.display());
        for k in ["exploration", "run_exploration"] {
            let label = fact(k);
            assert!(
                label.starts_with("epsilon-greedy, RL alone: oracle 0,"),
                "{}: {k} = {label}",
                path.display()
            );
        }
    }
}

#[test]
fn shipped_weights_load_and_differ_between_tasks() {
    let (_, hm) = scene(224, 9);
    let mut embeddings = Vec::new();
    for task in TaskId::ALL {
        let path = model(task);
        let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        assert!(
            size > 0 && size <= 20 << 20,
            "{}: {size} bytes",
            path.display()
        );
        let policy = PolicyNet::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(policy.meta.task, task.as_str());
        assert!(policy.meta.extra.contains_key("train_actions"));
        let ase = policy.embed(&hm, Primitive::Grasp).unwrap();
        assert!(ase.features.iter().all(|v| v.is_finite()));
        embeddings.push((task, ase));
    }
    for i in 0..embeddings.len() {
        for j in i + 1..embeddings.len() {
            let (a, b) = (&embeddings[i].1, &embeddings[j].1);
            let diff: f32 = a
                .features
                .iter()
                .zip(&b.features)
                .map(|(x, y)| (x - y).abs())
                .sum::<f32>()
                / a.features.len() as f32;
            assert!(
                diff > 1e-3,
                "{} and {} embed alike ({diff})",
                embeddings[i].0,
                embeddings[j].0
            );
        }
    }
}

/// A map embedded at one rotation keeps that rotation's cells and nothing
/// else: it reads as the all-rotation map there (embeddings, norms, mask) and
/// as zeros, all masked, at every other rotation.
#[test]
fn one_rotation_maps_read_as_the_all_rotation_map_at_their_rotation() {
    let (_, hm) = scene(224, 5);
    let policy = PolicyNet::load(&model(TaskId::Stack)).unwrap();
    for (primitive, r) in [(Primitive::Grasp, 3), (Primitive::Place, 12)] {
        let all = policy.embed_cells(&hm, primitive).unwrap();
        let one = policy.embed_cells_rotation(&hm, primitive, r).unwrap();
        assert_eq!(one.len(), all.len());
        let plane = one.resolution * one.resolution;
        for q in 0..one.rotations {
            if q == r {
                assert_eq!(one.plane_cells(q), all.plane_cells(q));
                assert_eq!(
                    one.mask[q * plane..][..plane],
                    all.mask[q * plane..][..plane]
                );
            } else {
                assert!(one.plane_cells(q).iter().all(|v| *v == 0.0), "rotation {q}");
                assert!(one.mask[q * plane..][..plane].iter().all(|m| !m));
            }
        }
        for i in (r * plane..(r + 1) * plane).step_by(37) {
            assert_eq!(one.feature(i), all.feature(i), "action {i}");
            assert_eq!(one.norm_sq(i), all.norm_sq(i), "action {i}");
        }
        assert_eq!(one.norm_sq(((r + 1) % one.rotations) * plane), 0.0);
    }
}
