//! The shipped TransporterNets under models/transporter/ load, plan a grasp and
//! a place on a real scene, and damaged files give the documented errors.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use seespot_policy::bench::scene;
use seespot_policy::{PolicyError, TransporterNet};
use seespot_sim::{Primitive, TaskId};

fn model(task: TaskId) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models/transporter")
        .join(format!("{task}.safetensors"))
}

#[test]
fn shipped_transporters_load_and_plan() {
    let (_, hm) = scene(224, 9);
    for task in TaskId::ALL {
        let net = TransporterNet::load(&model(task)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(net.meta.task, task.as_str());
        let iterations: usize = net.meta.extra["iterations"].parse().unwrap();
        assert!(iterations >= 1000, "{task}: {iterations} iterations");
        let (grasp, place, maps) = net.plan(&hm).unwrap();
        assert_eq!(grasp.primitive, Primitive::Grasp);
        assert_eq!(place.primitive, Primitive::Place);
        assert!(
            maps.attention
                .iter()
                .chain(&maps.transport)
                .all(|v| v.is_finite())
        );
        let g = seespot_policy::transporter::GRID;
        assert_eq!(maps.attention.len(), 16 * g * g);
    }
}

#[test]
fn damaged_transporter_files_name_the_fault() {
    let dir = tempfile::tempdir().unwrap();
    let good = TransporterNet::new(TaskId::Row, 5).unwrap();
    let path = dir.path().join("row.safetensors");
    good.save(&path).unwrap();
    let back = TransporterNet::load(&path).unwrap();
    assert_eq!(back.meta.task, "row");

    // One flipped byte in the last tensor's data: a checksum error naming it.
    let mut bytes = std::fs::read(&path).unwrap();
    let last = bytes.len() - 3;
    bytes[last] ^= 0x40;
    let damaged = dir.path().join("damaged.safetensors");
    std::fs::write(&damaged, &bytes).unwrap();
    match TransporterNet::load(&damaged) {
        Err(PolicyError::Tensor { tensor, reason, .. }) => {
            assert!(reason.contains("checksum"), "{reason}");
            assert!(tensor.contains('.'), "{tensor}");
        }
        other => panic!("expected a tensor error, got {other:?}"),
    }

    // A SPOT-Q policy file is not a TransporterNet: the format field says so.
    let policy = seespot_policy::PolicyNet::new(TaskId::Row, 112, 1).unwrap();
    let wrong = dir.path().join("policy.safetensors");
    policy.save(&wrong).unwrap();
    let err = TransporterNet::load(&wrong).unwrap_err().to_string();
    assert!(
        err.contains("policy.safetensors") && err.contains("`format`"),
        "{err}"
    );

    // Truncated: the file and the fault are named.
    std::fs::write(&damaged, &bytes[..bytes.len() / 2]).unwrap();
    let err = TransporterNet::load(&damaged).unwrap_err().to_string();
    assert!(
        err.contains("damaged.safetensors") && err.contains("damaged"),
        "{err}"
    );
}
