//! PyTorch's exports load (issue 58): three small vision networks, each
//! exported by the TorchScript exporter (`dynamo=False`) and by the default
//! exporter with its weights in a `.onnx.data` file and inline (at operator
//! sets 18, 20 and 21), give
//! onnxruntime's features; hostile external data is refused, naming the
//! tensor and the file. The fixtures are made by `python
//! scripts/pytorch-fixtures.py` (their manifest.json says with which
//! versions), so these tests need no PyTorch.

use std::path::{Path, PathBuf};

use prost::Message;
use seespot_policy::{OnnxEmbedder, PolicyError};
use seespot_sim::Primitive;
use tract_onnx::pb;

const NETWORKS: [&str; 3] = ["resnet", "vit", "upsample"];
const KINDS: [&str; 5] = [
    "legacy",
    "dynamo-external",
    "dynamo-inline",
    "dynamo-opset18",
    "dynamo-opset21",
];
/// The fixtures' input batch.
const BATCH: usize = 2;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pytorch")
}

/// `x[i] = 0.5 sin(0.001 i)` over `[2, 4, 112, 112]`, as the script computes
/// it (in float64, then rounded).
fn input() -> Vec<f32> {
    (0..BATCH * 4 * 112 * 112)
        .map(|i| (0.5 * (0.001 * i as f64).sin()) as f32)
        .collect()
}

/// onnxruntime's output `[2, D, S, S]` of `net`.
fn expected(net: &str) -> Vec<f32> {
    let bytes =
        std::fs::read(fixtures().join(format!("{net}.expected.bin"))).expect("expected output");
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn every_export_of_every_network_gives_onnxruntime_features() {
    let x = input();
    for net in NETWORKS {
        let want = expected(net);
        let scale = want.iter().fold(0f32, |a, v| a.max(v.abs()));
        for kind in KINDS {
            let path = fixtures().join(format!("{net}-{kind}.onnx"));
            let model = OnnxEmbedder::load(&path)
                .unwrap_or_else(|e| panic!("{net} {kind} does not load: {e}"));
            assert_eq!(
                model.data_files().len(),
                usize::from(kind == "dynamo-external"),
                "{net} {kind}"
            );
            let (d, s) = (model.dim, model.cells);
            assert_eq!(
                want.len(),
                BATCH * d * s * s,
                "{net} {kind}: D = {d}, S = {s}"
            );
            for p in Primitive::ALL {
                // Channels last, batch x S x S x D.
                let got = model.features(&x, BATCH, p).expect("features");
                let mut worst = 0f32;
                for b in 0..BATCH {
                    for c in 0..d {
                        for k in 0..s * s {
                            let e = want[(b * d + c) * s * s + k];
                            let g = got[(b * s * s + k) * d + c];
                            worst = worst.max((e - g).abs());
                        }
                    }
                }
                // The bound: 1e-5 of the largest feature (two engines sum
                // the same products in other orders; measured 1e-7 to 1e-6).
                assert!(
                    worst <= 1e-5 * scale.max(1.0),
                    "{net} {kind} {p}: off by {worst} (features up to {scale})"
                );
            }
        }
    }
}

/// A copy of the external-data fixture in a new folder, with its model's
/// external entries edited by `edit` (the model is re-saved there).
fn external_copy(edit: impl Fn(&mut pb::StringStringEntryProto)) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("temp dir");
    let name = "resnet-dynamo-external.onnx";
    let bytes = std::fs::read(fixtures().join(name)).expect("fixture");
    let mut m = pb::ModelProto::decode(bytes.as_slice()).expect("decodes");
    for t in &mut m.graph.as_mut().expect("graph").initializer {
        for kv in &mut t.external_data {
            edit(kv);
        }
    }
    let model = dir.path().join("model").join(name);
    std::fs::create_dir_all(model.parent().expect("parent")).expect("folder");
    std::fs::write(&model, m.encode_to_vec()).expect("write");
    std::fs::copy(
        fixtures().join(format!("{name}.data")),
        dir.path().join("model").join(format!("{name}.data")),
    )
    .expect("copy data");
    (dir, model)
}

fn refusal(path: &Path) -> String {
    match OnnxEmbedder::load(path) {
        Err(e @ PolicyError::Onnx { .. }) => e.to_string(),
        Err(e) => panic!("refused for another reason: {e}"),
        Ok(_) => panic!("{} loaded", path.display()),
    }
}

#[test]
fn external_data_out_of_the_folder_is_refused_naming_tensor_and_file() {
    // The untouched copy loads, and names its data file.
    let (_keep, ok) = external_copy(|_| {});
    let m = OnnxEmbedder::load(&ok).expect("the copy loads");
    assert_eq!(
        m.data_files(),
        [ok.with_file_name("resnet-dynamo-external.onnx.data")]
    );
    assert_eq!(
        seespot_policy::onnx::data_files(&ok).expect("listed"),
        m.data_files()
    );

    let relocate = |to: &'static str| {
        move |kv: &mut pb::StringStringEntryProto| {
            if kv.key == "location" {
                kv.value = to.into();
            }
        }
    };
    // `..`: a file that exists one folder up is still refused.
    let (dir, parent) = external_copy(relocate("../resnet-dynamo-external.onnx.data"));
    std::fs::copy(
        fixtures().join("resnet-dynamo-external.onnx.data"),
        dir.path().join("resnet-dynamo-external.onnx.data"),
    )
    .expect("copy up");
    let e = refusal(&parent);
    assert!(e.contains("`..`") && e.contains("initializer `"), "{e}");
    assert!(e.starts_with(&parent.display().to_string()), "{e}");

    // An absolute path.
    let (_d, absolute) = external_copy(relocate("/etc/passwd"));
    let e = refusal(&absolute);
    assert!(
        e.contains("absolute path") && e.contains("/etc/passwd"),
        "{e}"
    );

    // A link that leaves the folder.
    let (dir, linked) = external_copy(relocate("linked.data"));
    let outside = dir.path().join("outside.data");
    std::fs::copy(
        fixtures().join("resnet-dynamo-external.onnx.data"),
        &outside,
    )
    .expect("copy outside");
    std::os::unix::fs::symlink(&outside, linked.with_file_name("linked.data")).expect("link");
    let e = refusal(&linked);
    assert!(
        e.contains("outside the model's folder") && e.contains("linked.data"),
        "{e}"
    );

    // A length past the data file's end (the file cut short).
    let (_d, short) = external_copy(|_| {});
    let data = short.with_file_name("resnet-dynamo-external.onnx.data");
    let len = std::fs::metadata(&data).expect("data").len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&data)
        .expect("open")
        .set_len(len - 100)
        .expect("cut");
    let e = refusal(&short);
    assert!(
        e.contains("past the end") && e.contains("resnet-dynamo-external.onnx.data"),
        "{e}"
    );

    // An offset past the end.
    let (_d, far) = external_copy(|kv| {
        if kv.key == "offset" {
            kv.value = "99999999".into();
        }
    });
    let e = refusal(&far);
    assert!(e.contains("offset") && e.contains("past the end"), "{e}");

    // A missing data file.
    let (_d, missing) = external_copy(|_| {});
    std::fs::remove_file(missing.with_file_name("resnet-dynamo-external.onnx.data"))
        .expect("remove");
    let e = refusal(&missing);
    assert!(
        e.contains("is missing") && e.contains("external_data=False"),
        "{e}"
    );
}

#[test]
fn stale_intermediate_shapes_do_not_fix_the_batch() {
    // Some exports state their example's batch (16) for intermediate values
    // while the input's batch is named (seen with PyTorch 2.9's default
    // exporter). Made here from the inline export: every named batch of its
    // value_info and output replaced by 16. seespot derives the shapes from
    // the input instead, and runs it at 1 rotation and at 16.
    use pb::tensor_shape_proto::dimension::Value as Dim;
    let bytes = std::fs::read(fixtures().join("vit-dynamo-inline.onnx")).expect("fixture");
    let mut m = pb::ModelProto::decode(bytes.as_slice()).expect("decodes");
    let graph = m.graph.as_mut().expect("graph");
    let mut fixed = 0;
    for v in graph.value_info.iter_mut().chain(graph.output.iter_mut()) {
        if let Some(pb::type_proto::Value::TensorType(t)) =
            v.r#type.as_mut().and_then(|t| t.value.as_mut())
            && let Some(d) = t.shape.as_mut().and_then(|s| s.dim.first_mut())
            && matches!(d.value, Some(Dim::DimParam(_)))
        {
            d.value = Some(Dim::DimValue(16));
            fixed += 1;
        }
    }
    assert!(fixed > 10, "only {fixed} shapes named the batch");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("stale.onnx");
    std::fs::write(&path, m.encode_to_vec()).expect("write");
    let model = OnnxEmbedder::load(&path).expect("loads");
    let x = input();
    let one = model
        .features(&x[..4 * 112 * 112], 1, Primitive::Place)
        .expect("one rotation");
    let two = model.features(&x, BATCH, Primitive::Place).expect("two");
    assert_eq!(one, two[..one.len()]);
}
