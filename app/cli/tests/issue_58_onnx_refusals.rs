//! Every refusal docs/embeddings.md lists, tried from the command line
//! (issue 58): `seespot eval --embeddings FILE` stops before any trial with
//! the file's name and the fault in plain words; the ONNX engine's own text
//! appears only after a plain sentence, in brackets.

mod common;

use std::path::{Path, PathBuf};

use prost::Message;
use seespot_policy::onnx::export;
use tract_onnx::pb;

/// Words of the engine's own errors that must never reach a user first.
const ENGINE_WORDS: [&str; 6] = [
    "Failed analyse",
    "Infering facts",
    "Unable to unify",
    "TractError",
    "ConvHir",
    "Sym(",
];
/// Where seespot quotes the engine.
const QUOTE: &str = "(The ONNX engine, tract, said:";

fn fixtures() -> PathBuf {
    common::root().join("app/policy/tests/fixtures/pytorch")
}

/// A model that loads: the raw-patch control (an average pool and a fixed
/// convolution).
fn good() -> pb::ModelProto {
    export::raw_patches_model()
}

fn graph(m: &mut pb::ModelProto) -> &mut pb::GraphProto {
    m.graph.as_mut().expect("graph")
}

fn float_tensor(name: &str, dims: &[i64], values: &[f32]) -> pb::TensorProto {
    pb::TensorProto {
        name: name.into(),
        dims: dims.to_vec(),
        data_type: pb::tensor_proto::DataType::Float as i32,
        float_data: values.to_vec(),
        ..Default::default()
    }
}

/// Puts node `n` (reading the scene, writing `out`) first and makes the
/// former first node read `out`.
fn prepend(m: &mut pb::ModelProto, n: pb::NodeProto, out: &str) {
    let g = graph(m);
    for input in &mut g.node[0].input {
        if input == export::INPUT {
            *input = out.into();
        }
    }
    g.node.insert(0, n);
}

/// Runs eval on `path` and returns stderr, checked: refused, the file named,
/// no engine text before a plain sentence.
fn refusal(path: &Path, out: &Path) -> String {
    let (code, err) = common::run(&[
        "eval",
        "--method",
        "ssr-ccd",
        "--task",
        "row",
        "--trials",
        "1",
        "--embeddings",
        path.to_str().expect("utf-8 path"),
        "--out",
        out.to_str().expect("utf-8 path"),
    ]);
    assert_ne!(code, 0, "{} was not refused: {err}", path.display());
    assert!(
        err.contains(&path.display().to_string()),
        "the refusal does not name {}: {err}",
        path.display()
    );
    let plain = err.split(QUOTE).next().unwrap_or_default();
    for w in ENGINE_WORDS {
        assert!(
            !plain.contains(w),
            "engine text `{w}` before a plain sentence: {err}"
        );
    }
    if err.contains(QUOTE) {
        // A plain sentence (the node and the fault) comes first.
        assert!(plain.contains("node `"), "{err}");
    }
    err
}

#[test]
fn every_listed_refusal_is_in_plain_words_with_the_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out");
    let mut n = 0;
    let mut write = |m: &pb::ModelProto| -> PathBuf {
        n += 1;
        let p = dir.path().join(format!("case{n}.onnx"));
        std::fs::write(&p, m.encode_to_vec()).expect("write");
        p
    };
    let mut cases: Vec<(PathBuf, &str)> = Vec::new();

    // Not ONNX.
    let text = dir.path().join("text.onnx");
    std::fs::write(&text, "this is a note, not a network\n").expect("write");
    cases.push((text, "not an ONNX model"));
    // No nodes.
    let mut m = good();
    graph(&mut m).node.clear();
    cases.push((write(&m), "no nodes"));
    // A tensor above the bound.
    let mut m = good();
    graph(&mut m).initializer[0].dims = vec![1 << 26];
    cases.push((write(&m), "elements"));
    // Two inputs.
    let mut m = good();
    let extra = graph(&mut m).input[0].clone();
    graph(&mut m).input.push(pb::ValueInfoProto {
        name: "second".into(),
        ..extra
    });
    cases.push((write(&m), "2 inputs"));
    // The input not [R, 4, 112, 112].
    let mut m = good();
    if let Some(pb::type_proto::Value::TensorType(t)) = graph(&mut m).input[0]
        .r#type
        .as_mut()
        .and_then(|t| t.value.as_mut())
        && let Some(shape) = t.shape.as_mut()
    {
        shape.dim[1].value = Some(pb::tensor_shape_proto::dimension::Value::DimValue(3));
    }
    cases.push((write(&m), "dimension 1 is 3"));
    // An operator the engine does not run.
    let mut m = good();
    graph(&mut m).node[0].op_type = "FancyPool".into();
    cases.push((write(&m), "`FancyPool`"));
    // A window out of range.
    let mut m = good();
    for a in &mut graph(&mut m).node[0].attribute {
        if a.name == "kernel_shape" {
            a.ints = vec![0, 0];
        }
    }
    cases.push((write(&m), "kernel_shape 0"));
    // A batch fixed to 16 inside the graph: the engine cannot run one
    // rotation; the message names the node and says what to export.
    let mut m = good();
    graph(&mut m).initializer.push(pb::TensorProto {
        name: "batch16".into(),
        dims: vec![4],
        data_type: pb::tensor_proto::DataType::Int64 as i32,
        int64_data: vec![16, 4, 112, 112],
        ..Default::default()
    });
    prepend(
        &mut m,
        pb::NodeProto {
            op_type: "Reshape".into(),
            name: "fix_batch".into(),
            input: vec![export::INPUT.into(), "batch16".into()],
            output: vec!["fixed".into()],
            ..Default::default()
        },
        "fixed",
    );
    cases.push((write(&m), "node `fix_batch` (Reshape)"));
    // NaN features.
    let mut m = good();
    graph(&mut m)
        .initializer
        .push(float_tensor("nan", &[1], &[f32::NAN]));
    prepend(
        &mut m,
        pb::NodeProto {
            op_type: "Mul".into(),
            name: "poison".into(),
            input: vec![export::INPUT.into(), "nan".into()],
            output: vec!["poisoned".into()],
            ..Default::default()
        },
        "poisoned",
    );
    cases.push((write(&m), "non-finite"));

    // External data: the default exporter's file, moved without its data,
    // and with a location outside its folder.
    let name = "resnet-dynamo-external.onnx";
    let lonely = dir.path().join("lonely");
    std::fs::create_dir_all(&lonely).expect("folder");
    std::fs::copy(fixtures().join(name), lonely.join(name)).expect("copy");
    cases.push((lonely.join(name), "is missing"));
    let bytes = std::fs::read(fixtures().join(name)).expect("fixture");
    let mut m = pb::ModelProto::decode(bytes.as_slice()).expect("decodes");
    for t in &mut graph(&mut m).initializer {
        for kv in &mut t.external_data {
            if kv.key == "location" {
                kv.value = "../../secret.data".into();
            }
        }
    }
    cases.push((write(&m), "`..`"));

    for (path, want) in &cases {
        let err = refusal(path, &out);
        assert!(
            err.contains(want),
            "{}: expected `{want}` in: {err}",
            path.display()
        );
    }
    // The engine's case says what to change in the export call.
    let engine = refusal(&cases[7].0, &out);
    assert!(
        engine.contains("dynamic_shapes") && engine.contains(QUOTE),
        "{engine}"
    );
}

#[test]
fn the_default_exporters_files_decide_in_bench_ssr() {
    // Both of the default exporter's forms, and the TorchScript one, load
    // for every fold.
    for kind in ["legacy", "dynamo-external", "dynamo-inline"] {
        let path = fixtures().join(format!("upsample-{kind}.onnx"));
        let (code, err) = common::run(&[
            "bench",
            "ssr",
            "--embeddings",
            path.to_str().expect("utf-8"),
            "--iterations",
            "1",
            "--resolution",
            "112",
        ]);
        assert_eq!(code, 0, "{kind}: {err}");
    }
}
