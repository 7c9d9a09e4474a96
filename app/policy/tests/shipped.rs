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

#[test]
fn shipped_weights_load_and_differ_between_tasks() {
    let (_, hm) = scene(112, 9);
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
