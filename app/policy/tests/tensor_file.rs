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
