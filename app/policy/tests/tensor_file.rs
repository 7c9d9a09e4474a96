//! Weights files whose header lies about a tensor's size (issue 10's fuzzing).

use seespot_policy::tensor_file::{fnv1a, read};
use serde_json::json;

/// A safetensors file of one tensor `t` with this header entry and no data.
fn file_with(entry: serde_json::Value) -> tempfile::NamedTempFile {
    let header = json!({
        "t": entry,
        "__metadata__": {"checksum:t": format!("{:016x}", fnv1a(&[]))},
    });
    let h = serde_json::to_vec(&header).expect("json");
    let mut bytes = (h.len() as u64).to_le_bytes().to_vec();
    bytes.extend_from_slice(&h);
    let f = tempfile::NamedTempFile::new().expect("temp file");
    std::fs::write(f.path(), bytes).expect("write");
    f
}

#[test]
fn issue_10_tensor_shape_whose_byte_size_overflows_is_refused() {
    // 2^62 floats are 2^64 bytes: an unchecked product wrapped to 0 and the
    // tensor was read back with shape [2^62] and no data.
    for shape in [
        json!([1u64 << 62]),
        json!([1u64 << 31, 1u64 << 31]),
        json!([u64::MAX, 4]),
    ] {
        let f = file_with(json!({"dtype": "F32", "shape": shape, "data_offsets": [0, 0]}));
        let e = read(f.path()).expect_err(&shape.to_string());
        assert!(e.to_string().contains("tensor `t`"), "{e}");
    }
}

#[test]
fn issue_10_tensor_shape_with_a_negative_or_non_numeric_entry_is_refused() {
    // Non-integer entries were skipped: [-1] read as [], a scalar of 4 bytes.
    for shape in [json!([-1]), json!(["x"]), json!([0.5, 2])] {
        let f = file_with(json!({"dtype": "F32", "shape": shape, "data_offsets": [0, 0]}));
        assert!(read(f.path()).is_err(), "{shape}");
    }
    let f = file_with(json!({"dtype": "F32", "shape": [0], "data_offsets": [0, 0]}));
    assert_eq!(
        read(f.path()).expect("an empty tensor is valid").tensors["t"].shape,
        vec![0]
    );
}

/// The same tensors and metadata always give the same bytes (the
/// safetensors crate writes metadata in a hash map's order, which differs
/// from one map to the next), and the file reads back.
#[test]
fn the_same_tensors_give_the_same_bytes() {
    use seespot_policy::tensor_file::{F32Tensor, write};
    use std::collections::BTreeMap;
    let tensors: BTreeMap<String, F32Tensor> = (0..6)
        .map(|i| {
            let t = F32Tensor {
                shape: vec![2, i + 1],
                data: (0..2 * (i + 1))
                    .map(|k| k as f32 * 0.5 - i as f32)
                    .collect(),
            };
            (format!("t{i}"), t)
        })
        .collect();
    let meta: BTreeMap<String, String> = (0..12)
        .map(|i| (format!("key{i}"), format!("value {i}")))
        .collect();
    let dir = tempfile::tempdir().expect("dir");
    let files: Vec<Vec<u8>> = (0..8)
        .map(|i| {
            let p = dir.path().join(format!("{i}.safetensors"));
            write(&p, &tensors, &meta).expect("write");
            std::fs::read(&p).expect("read")
        })
        .collect();
    assert!(files.iter().all(|f| f == &files[0]));
    let back = read(&dir.path().join("0.safetensors")).expect("read back");
    assert_eq!(
        back.metadata.get("key3").map(String::as_str),
        Some("value 3")
    );
    assert_eq!(back.tensors["t2"].data, tensors["t2"].data);
    assert_eq!(files[0].len() % 8, 0);
}
