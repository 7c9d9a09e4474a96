//! ONNX embedding models (docs/embeddings.md): the exported shipped trunk
//! gives the native trunk's features, the raw-patch control computes what it
//! says, and files that break the contract are refused, naming the file and
//! what is wrong.
#![allow(clippy::unwrap_used)]

use std::path::Path;

use prost::Message;
use seespot_policy::bench::scene;
use seespot_policy::onnx::export;
use seespot_policy::{Embedder, OnnxEmbedder, PolicyError, PolicyNet};
use seespot_sim::{Primitive, TaskId};
use tract_onnx::pb;

fn shipped() -> PolicyNet {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/stack.safetensors");
    PolicyNet::load(&root).unwrap()
}

fn graph(m: &mut pb::ModelProto) -> &mut pb::GraphProto {
    m.graph.as_mut().unwrap()
}

fn load(model: &pb::ModelProto) -> Result<OnnxEmbedder, PolicyError> {
    OnnxEmbedder::from_bytes(Path::new("model.onnx"), &model.encode_to_vec())
}

/// The refusal's text, which must name the file.
fn refused(model: &pb::ModelProto) -> String {
    let e = load(model).unwrap_err().to_string();
    assert!(e.starts_with("model.onnx: "), "{e}");
    e
}

#[test]
fn exported_trunk_gives_the_native_features() {
    let policy = shipped();
    let onnx = Embedder::Onnx(load(&export::policy_model(&policy).unwrap()).unwrap());
    let native = Embedder::Spot(policy);
    for res in [112, 224] {
        let (_, hm) = scene(res, 7);
        for p in Primitive::ALL {
            let a = native.embed_cells(&hm, p).unwrap();
            let b = onnx.embed_cells(&hm, p).unwrap();
            assert_eq!(
                (a.dim, a.cells, a.resolution),
                (b.dim, b.cells, b.resolution)
            );
            assert_eq!(a.mask, b.mask);
            let (mut worst, mut scale) = (0f32, 0f32);
            for i in (0..a.len()).step_by(13) {
                for (x, y) in a.feature(i).iter().zip(b.feature(i)) {
                    worst = worst.max((x - y).abs());
                    scale = scale.max(x.abs());
                }
            }
            // Two engines sum the same convolutions in other orders.
            assert!(
                worst <= 1e-4 * scale.max(1.0),
                "{p} at {res}: {worst} of {scale}"
            );
            // One rotation alone (a demonstration step) is that rotation of all.
            let r = 5;
            let one = onnx.embed_cells_rotation(&hm, p, r).unwrap();
            let plane = res * res;
            for i in (r * plane..(r + 1) * plane).step_by(101) {
                assert_eq!(one.feature(i), b.feature(i));
            }
        }
    }
}

#[test]
fn raw_patches_are_the_cells_around_each_cell() {
    let model = load(&export::raw_patches_model()).unwrap();
    assert_eq!((model.dim, model.cells, model.stride), (100, 28, 4));
    assert!(!model.has_q());
    // A scene whose colour channels are constant and whose depth is one
    // bump: every feature's depth part is the pooled depth at its offsets.
    let (_, hm) = scene(112, 3);
    let input = seespot_policy::input::NetInput::from_heightmaps(&hm);
    let x = seespot_policy::rotation::rotate_input_batch(&input, &[0]);
    let f = model.features(&x, 1, Primitive::Grasp).unwrap();
    let n = 112;
    let depth = &x[3 * n * n..4 * n * n];
    // Cell (y, x) = mean of pixels 4y-2..=4y+2 (inside the image).
    let cell = |cy: i64, cx: i64| -> f32 {
        if !(0..28).contains(&cy) || !(0..28).contains(&cx) {
            return 0.0;
        }
        let (mut s, mut k) = (0.0, 0.0);
        for py in (4 * cy - 2)..=(4 * cy + 2) {
            for px in (4 * cx - 2)..=(4 * cx + 2) {
                if (0..n as i64).contains(&py) && (0..n as i64).contains(&px) {
                    s += depth[py as usize * n + px as usize];
                    k += 1.0;
                }
            }
        }
        s / k
    };
    for (cy, cx) in [(0, 0), (10, 14), (27, 3), (20, 20)] {
        let feat = &f[(cy * 28 + cx) * 100..(cy * 28 + cx + 1) * 100];
        for dy in -2i64..=2 {
            for dx in -2i64..=2 {
                let t = ((dy + 2) * 5 + dx + 2) as usize;
                let want = cell(cy as i64 + dy, cx as i64 + dx);
                let got = feat[3 * 25 + t];
                assert!(
                    (got - want).abs() < 1e-5,
                    "cell {cy},{cx} offset {dy},{dx}: {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn a_fixed_batch_of_16_gives_the_named_batchs_features() {
    use pb::tensor_shape_proto::dimension::Value as Dim;
    let named = export::raw_patches_model();
    let mut fixed = named.clone();
    let g = graph(&mut fixed);
    for v in g.input.iter_mut().chain(g.output.iter_mut()) {
        let Some(pb::type_proto::Value::TensorType(t)) = v.r#type.as_mut().unwrap().value.as_mut()
        else {
            unreachable!()
        };
        t.shape.as_mut().unwrap().dim[0].value = Some(Dim::DimValue(16));
    }
    let (a, b) = (
        Embedder::Onnx(load(&named).unwrap()),
        Embedder::Onnx(load(&fixed).unwrap()),
    );
    let (_, hm) = scene(112, 4);
    for p in Primitive::ALL {
        let (x, y) = (
            a.embed_cells(&hm, p).unwrap(),
            b.embed_cells(&hm, p).unwrap(),
        );
        // One rotation alone: the fixed batch runs it among 15 bare tables.
        let (x1, y1) = (
            a.embed_cells_rotation(&hm, p, 7).unwrap(),
            b.embed_cells_rotation(&hm, p, 7).unwrap(),
        );
        for i in (0..x.len()).step_by(37) {
            assert_eq!(x.feature(i), y.feature(i), "{p} action {i}");
            assert_eq!(
                x1.feature(i),
                y1.feature(i),
                "{p} action {i}, rotation 7 alone"
            );
        }
    }
}

#[test]
fn bad_models_are_refused_naming_the_file_and_the_fault() {
    // Not ONNX at all.
    let e = OnnxEmbedder::from_bytes(Path::new("model.onnx"), b"\x08\x07not a protobuf\xff\xff")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("model.onnx") && e.contains("not an ONNX model"),
        "{e}"
    );
    let good = export::raw_patches_model();
    let dims = |m: &mut pb::ModelProto| -> Vec<pb::tensor_shape_proto::Dimension> {
        let g = m.graph.as_mut().unwrap();
        let Some(pb::type_proto::Value::TensorType(t)) =
            g.input[0].r#type.as_mut().unwrap().value.as_mut()
        else {
            unreachable!()
        };
        t.shape.as_ref().unwrap().dim.clone()
    };
    let set_dims = |m: &mut pb::ModelProto, d: Vec<pb::tensor_shape_proto::Dimension>| {
        let g = m.graph.as_mut().unwrap();
        let Some(pb::type_proto::Value::TensorType(t)) =
            g.input[0].r#type.as_mut().unwrap().value.as_mut()
        else {
            unreachable!()
        };
        t.shape.as_mut().unwrap().dim = d;
    };
    use pb::tensor_shape_proto::dimension::Value as Dim;
    // Wrong rank.
    let mut m = good.clone();
    let mut d = dims(&mut m);
    d.pop();
    set_dims(&mut m, d);
    assert!(refused(&m).contains("rank 3"));
    // Wrong channels.
    let mut m = good.clone();
    let mut d = dims(&mut m);
    d[1].value = Some(Dim::DimValue(3));
    set_dims(&mut m, d);
    assert!(refused(&m).contains("dimension 1 is 3"));
    // An unresolved dynamic dimension.
    let mut m = good.clone();
    let mut d = dims(&mut m);
    d[2].value = Some(Dim::DimParam("height".into()));
    set_dims(&mut m, d);
    assert!(refused(&m).contains("unresolved dynamic dimension `height`"));
    // Wrong input type.
    let mut m = good.clone();
    if let Some(pb::type_proto::Value::TensorType(t)) = graph(&mut m).input[0]
        .r#type
        .as_mut()
        .unwrap()
        .value
        .as_mut()
    {
        t.elem_type = pb::tensor_proto::DataType::Double as i32;
    }
    assert!(refused(&m).contains("element type double"));
    // Two inputs.
    let mut m = good.clone();
    let extra = graph(&mut m).input[0].clone();
    graph(&mut m).input.push(pb::ValueInfoProto {
        name: "mask".into(),
        ..extra
    });
    assert!(refused(&m).contains("2 inputs"));
    // An operator the engine lacks.
    let mut m = good.clone();
    graph(&mut m).node[0].op_type = "FancyPool".into();
    assert!(refused(&m).contains("operator `FancyPool`"));
    // Features whose maps do not divide 112 (a stride-3 pool).
    let mut m = good.clone();
    for a in &mut graph(&mut m).node[0].attribute {
        if a.name == "strides" {
            a.ints = vec![3, 3];
        }
    }
    assert!(refused(&m).contains("side dividing 112"), "{}", refused(&m));
    // A window beyond the input (the engine's planning would not end).
    let mut m = good.clone();
    for a in &mut graph(&mut m).node[1].attribute {
        if a.name == "pads" {
            a.ints[0] = 1 << 40;
        }
    }
    assert!(
        refused(&m).contains("has pads 1099511627776"),
        "{}",
        refused(&m)
    );
    // Only one of the two Q maps.
    let mut m = good.clone();
    graph(&mut m).output[0].name = "grasp_q".into();
    graph(&mut m).node[1].output[0] = "grasp_q".into();
    assert!(refused(&m).contains("Q maps come as a pair"));
    // Non-finite features on the first observation (a bare table): the
    // patches divided by zero.
    let mut m = good.clone();
    let g = graph(&mut m);
    let feats = g.output[0].name.clone();
    g.node.last_mut().unwrap().output[0] = "pre".into();
    g.initializer.push(pb::TensorProto {
        name: "zero".into(),
        dims: vec![],
        data_type: pb::tensor_proto::DataType::Float as i32,
        float_data: vec![0.0],
        ..Default::default()
    });
    g.node.push(pb::NodeProto {
        op_type: "Div".into(),
        input: vec!["pre".into(), "zero".into()],
        output: vec![feats],
        name: "div".into(),
        ..Default::default()
    });
    assert!(refused(&m).contains("non-finite"), "{}", refused(&m));
    // A file too large for the bound is refused before it is read.
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.onnx");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(seespot_policy::onnx::MAX_FILE_BYTES + 1).unwrap();
    let e = OnnxEmbedder::load(&big).unwrap_err().to_string();
    assert!(e.contains("big.onnx"), "{e}");
    // A tensor stored externally that names no file (the hostile locations
    // are in issue_58_pytorch_exports.rs).
    let mut m = good.clone();
    graph(&mut m).initializer[0].data_location =
        Some(pb::tensor_proto::DataLocation::External as i32);
    assert!(refused(&m).contains("names no `location`"));
    // The extension picks the loader: a safetensors policy is not ONNX.
    assert!(matches!(
        Embedder::load(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/row.safetensors").as_path()),
        Ok(Embedder::Spot(p)) if p.meta.task == TaskId::Row.as_str()
    ));
}
