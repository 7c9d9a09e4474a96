//! Shapes, consistency, training, checkpoints and bad weights files.
#![allow(clippy::unwrap_used)]

use std::path::Path;

use seespot_policy::bench::{fixed_batch, scene};
use seespot_policy::net::Trunk;
use seespot_policy::tensor_file;
use seespot_policy::trainer::{Learner, LearnerConfig};
use seespot_policy::{EMBEDDING_DIM, PolicyError, PolicyNet, common_sense_mask, greedy_action};
use seespot_sim::{NUM_ROTATIONS, Primitive, TaskId};

#[test]
fn q_and_ase_shapes_at_two_resolutions() {
    let policy = PolicyNet::new(TaskId::Stack, 112, 3).unwrap();
    for res in [224usize, 112] {
        let (_, hm) = scene(res, 5);
        for p in Primitive::ALL {
            let (ase, q) = policy.embed_with_q(&hm, p).unwrap();
            let n = NUM_ROTATIONS * res * res;
            assert_eq!(q.q.len(), n);
            assert_eq!((q.resolution, q.rotations), (res, NUM_ROTATIONS));
            assert_eq!(ase.features.len(), n * EMBEDDING_DIM);
            assert_eq!(ase.mask.len(), n);
            assert_eq!(ase.len(), n);
            assert_eq!((ase.resolution, ase.dim), (res, EMBEDDING_DIM));
            // Masked actions never match; allowed ones have finite norms.
            let allowed = ase.mask.iter().filter(|&&b| b).count();
            assert!(
                allowed > 0 && allowed < n,
                "{p} at {res}: {allowed} allowed"
            );
            for (i, &ok) in ase.mask.iter().enumerate().step_by(97) {
                assert_eq!(ase.norms_sq[i].is_finite(), ok);
            }
            // Q is the 1x1 head applied to the embedding (the head commutes with
            // the bilinear rotate-back).
            let (w, b) = policy.net(p).head().unwrap();
            for i in (0..n).step_by(7919) {
                let f = ase.feature(i);
                let expect: f32 = f.iter().zip(&w).map(|(a, c)| a * c).sum::<f32>() + b;
                assert!(
                    (expect - q.q[i]).abs() < 1e-4,
                    "{i}: {expect} vs {}",
                    q.q[i]
                );
            }
            assert_eq!(policy.q_values(&hm, p).unwrap().q, q.q);
        }
    }
}

#[test]
fn greedy_action_respects_the_mask() {
    let policy = PolicyNet::new(TaskId::Row, 112, 1).unwrap();
    let (_, hm) = scene(112, 7);
    for p in Primitive::ALL {
        let a = greedy_action(&policy, &hm, p).unwrap();
        assert_eq!(a.primitive, p);
        assert!(a.rotation < NUM_ROTATIONS);
        assert!(common_sense_mask(&hm, p)[a.y * 112 + a.x]);
    }
}

#[test]
fn training_steps_on_a_fixed_batch_lower_the_loss() {
    let policy = PolicyNet::new(TaskId::Stack, 112, 11).unwrap();
    let mut learner = Learner::new(
        policy,
        LearnerConfig {
            lr: 1e-3,
            ..Default::default()
        },
    )
    .unwrap();
    let batch = fixed_batch(8);
    let before = learner.eval_loss(&batch).unwrap();
    for _ in 0..15 {
        learner.train_step(&batch).unwrap();
    }
    let after = learner.eval_loss(&batch).unwrap();
    assert!(after < 0.5 * before, "loss {before} -> {after}");
}

#[test]
fn checkpoint_round_trip_is_bit_identical() {
    let dir = tempfile::tempdir().unwrap();
    let policy = PolicyNet::new(TaskId::Unstack, 112, 2).unwrap();
    let mut learner = Learner::new(policy, LearnerConfig::default()).unwrap();
    let batch = fixed_batch(4);
    for _ in 0..2 {
        learner.train_step(&batch).unwrap();
    }
    let path = dir.path().join("ckpt.safetensors");
    learner.save_checkpoint(&path).unwrap();
    let back = Learner::load_checkpoint(&path, Default::default()).unwrap();
    let bits = |v: Vec<Vec<f32>>| -> Vec<Vec<u32>> {
        v.into_iter()
            .map(|t| t.into_iter().map(f32::to_bits).collect())
            .collect()
    };
    for p in 0..2 {
        assert_eq!(
            bits(learner.policy.nets[p].to_vecs().unwrap()),
            bits(back.policy.nets[p].to_vecs().unwrap())
        );
    }
    assert_eq!(learner.adam.t, back.adam.t);
    for (a, b) in learner
        .adam
        .m
        .iter()
        .zip(&back.adam.m)
        .chain(learner.adam.v.iter().zip(&back.adam.v))
    {
        let a: Vec<u32> = a.iter().map(|v| v.to_bits()).collect();
        let b: Vec<u32> = b.iter().map(|v| v.to_bits()).collect();
        assert_eq!(a, b);
    }
    assert_eq!(learner.policy.meta, back.policy.meta);
    // The next step from both gives the same weights, bit for bit.
    let mut a = learner;
    let mut b = back;
    a.train_step(&batch).unwrap();
    b.train_step(&batch).unwrap();
    assert_eq!(
        bits(a.policy.nets[1].to_vecs().unwrap()),
        bits(b.policy.nets[1].to_vecs().unwrap())
    );
}

fn saved(dir: &Path) -> (std::path::PathBuf, Vec<u8>) {
    let path = dir.join("stack.safetensors");
    PolicyNet::new(TaskId::Stack, 112, 4)
        .unwrap()
        .save(&path)
        .unwrap();
    let bytes = std::fs::read(&path).unwrap();
    (path, bytes)
}

/// Byte range of tensor `name`'s data in a safetensors file.
fn data_range(bytes: &[u8], name: &str) -> std::ops::Range<usize> {
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    let offs = header[name]["data_offsets"].as_array().unwrap();
    let (a, b) = (
        offs[0].as_u64().unwrap() as usize,
        offs[1].as_u64().unwrap() as usize,
    );
    8 + n + a..8 + n + b
}

#[test]
fn save_load_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = saved(dir.path());
    let a = PolicyNet::new(TaskId::Stack, 112, 4).unwrap();
    let b = PolicyNet::load(&path).unwrap();
    assert_eq!(a.meta, b.meta);
    for p in 0..2 {
        assert_eq!(a.nets[p].to_vecs().unwrap(), b.nets[p].to_vecs().unwrap());
    }
}

/// A policy with conv5 dilated 8 is saved under its own architecture name
/// and comes back with that trunk, from a policy file and from a training
/// checkpoint; its Q-values differ from the standard trunk's on the same
/// weights (the dilation is used, not just recorded).
#[test]
fn a_dilated_trunk_survives_files_and_changes_q() {
    let dir = tempfile::tempdir().unwrap();
    let d8 = Trunk::with_conv5_dilation(8).unwrap();
    let policy = PolicyNet::with_trunk(TaskId::Row, 112, 5, d8).unwrap();
    let path = dir.path().join("row.safetensors");
    policy.save(&path).unwrap();
    let file = tensor_file::read(&path).unwrap();
    assert_eq!(file.metadata["architecture"], "spotq-fcn-s4-c64-d8");
    let back = PolicyNet::load(&path).unwrap();
    assert_eq!(back.trunk(), d8);
    let learner = Learner::new(back, LearnerConfig::default()).unwrap();
    let ckpt = dir.path().join("ckpt.safetensors");
    learner.save_checkpoint(&ckpt).unwrap();
    // The checkpoint names its trunk, so the fallback for unnamed ones is not used.
    let again = Learner::load_checkpoint(&ckpt, Trunk::STANDARD).unwrap();
    assert_eq!(again.policy.trunk(), d8);
    let standard = PolicyNet::new(TaskId::Row, 112, 5).unwrap();
    let hm = seespot_sim::World::random(
        seespot_sim::WorldConfig {
            grid: seespot_sim::Grid::new(112),
            ..Default::default()
        },
        3,
    )
    .observe();
    let qa = policy.q_values(&hm, Primitive::Grasp).unwrap().q;
    let qb = standard.q_values(&hm, Primitive::Grasp).unwrap().q;
    assert_ne!(qa, qb);
}

#[test]
fn damaged_weights_name_the_file_and_tensor() {
    let dir = tempfile::tempdir().unwrap();
    let (path, bytes) = saved(dir.path());

    // A flipped byte inside one tensor's data.
    let mut bad = bytes.clone();
    let r = data_range(&bad, "place.conv3.weight");
    bad[r.start + 10] ^= 0x5a;
    std::fs::write(&path, &bad).unwrap();
    let err = PolicyNet::load(&path).unwrap_err();
    assert!(
        matches!(&err, PolicyError::Tensor { tensor, .. } if tensor == "place.conv3.weight"),
        "{err}"
    );
    let msg = err.to_string();
    assert!(
        msg.contains("stack.safetensors") && msg.contains("place.conv3.weight"),
        "{msg}"
    );

    // A truncated file names the first tensor whose bytes are missing.
    let r = data_range(&bytes, "grasp.head.weight");
    std::fs::write(&path, &bytes[..r.start + 4]).unwrap();
    let msg = PolicyNet::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("stack.safetensors") && msg.contains("truncated"),
        "{msg}"
    );

    // A garbled header.
    let mut bad = bytes.clone();
    bad[9] = b'#';
    std::fs::write(&path, &bad).unwrap();
    let err = PolicyNet::load(&path).unwrap_err();
    assert!(matches!(err, PolicyError::Format { .. }), "{err}");
    assert!(err.to_string().contains("stack.safetensors"));

    // Issue 27: finite but absurd weights (all 3e38) loaded without a word.
    std::fs::write(&path, &bytes).unwrap();
    let file = tensor_file::read(&path).unwrap();
    let mut tensors = file.tensors.clone();
    let t = tensors.get_mut("grasp.conv2.weight").unwrap();
    t.data.iter_mut().for_each(|v| *v = 3e38);
    tensor_file::write(&path, &tensors, &file.metadata).unwrap();
    let msg = PolicyNet::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("stack.safetensors")
            && msg.contains("grasp.conv2.weight")
            && msg.contains("beyond"),
        "{msg}"
    );

    // Issue 27: two tensors reading the same bytes (place.conv1 pointed at
    // grasp.conv1's, its checksum copied so that only the sharing is wrong).
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let mut header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    header["place.conv1.weight"]["data_offsets"] =
        header["grasp.conv1.weight"]["data_offsets"].clone();
    header["__metadata__"]["checksum:place.conv1.weight"] =
        header["__metadata__"]["checksum:grasp.conv1.weight"].clone();
    let text = serde_json::to_vec(&header).unwrap();
    let mut shared = (text.len() as u64).to_le_bytes().to_vec();
    shared.extend(&text);
    shared.extend(&bytes[8 + n..]);
    std::fs::write(&path, &shared).unwrap();
    let msg = PolicyNet::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("stack.safetensors")
            && msg.contains("overlap")
            && msg.contains("conv1.weight"),
        "{msg}"
    );

    // Not a file at all.
    let err = PolicyNet::load(&dir.path().join("missing.safetensors")).unwrap_err();
    assert!(err.to_string().contains("missing.safetensors"), "{err}");
}

#[test]
fn wrong_shape_dtype_or_architecture_is_refused() {
    use seespot_policy::tensor_file::{self, F32Tensor};
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = saved(dir.path());
    let file = tensor_file::read(&path).unwrap();

    // Wrong shape for one tensor.
    let mut tensors = file.tensors.clone();
    tensors.insert(
        "grasp.conv2.weight".into(),
        F32Tensor {
            shape: vec![2, 2],
            data: vec![0.0; 4],
        },
    );
    tensor_file::write(&path, &tensors, &file.metadata).unwrap();
    let msg = PolicyNet::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("grasp.conv2.weight") && msg.contains("shape"),
        "{msg}"
    );

    // A missing tensor.
    let mut tensors = file.tensors.clone();
    tensors.remove("place.head.bias");
    tensor_file::write(&path, &tensors, &file.metadata).unwrap();
    let msg = PolicyNet::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("place.head.bias") && msg.contains("missing"),
        "{msg}"
    );

    // Another architecture / version.
    // (And issue 10: a resolution the rest of seespot refuses.)
    for (k, v) in [
        ("architecture", "densenet121"),
        ("format_version", "999"),
        ("resolution", "0"),
        ("resolution", "113"),
    ] {
        let mut meta = file.metadata.clone();
        meta.insert(k.into(), v.into());
        tensor_file::write(&path, &file.tensors, &meta).unwrap();
        let msg = PolicyNet::load(&path).unwrap_err().to_string();
        assert!(
            msg.contains(k) && msg.contains("stack.safetensors"),
            "{msg}"
        );
    }

    // An F16 tensor (written with the safetensors crate directly).
    let data = vec![0u8; 2 * 16];
    let view =
        safetensors::tensor::TensorView::new(safetensors::Dtype::F16, vec![16], &data).unwrap();
    safetensors::serialize_to_file(vec![("grasp.conv1.bias", view)], None, &path).unwrap();
    let msg = PolicyNet::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("grasp.conv1.bias") && msg.contains("dtype"),
        "{msg}"
    );
}
