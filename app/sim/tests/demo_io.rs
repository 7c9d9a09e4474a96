//! Demonstrations written and read back, and damaged ones refused.

use seespot_sim::{Demo, TaskId, WorldConfig};

fn record(task: TaskId, seed: u64) -> Demo {
    Demo::record(task, seed, WorldConfig::default()).expect("the oracle finishes")
}

#[test]
fn demo_round_trip_is_equal() {
    let dir = tempfile::tempdir().expect("tempdir");
    let demo = record(TaskId::Row, 0);
    demo.write(dir.path()).expect("write");
    let back = Demo::read(dir.path()).expect("read");
    assert_eq!(back, demo);
    assert!(
        back.step_at(
            demo.steps[0].meta.progress_before,
            seespot_sim::Primitive::Grasp
        )
        .is_some()
    );
}

#[test]
fn damaged_demos_are_refused_with_the_file_named() {
    let dir = tempfile::tempdir().expect("tempdir");
    let demo = record(TaskId::Stack, 2);
    demo.write(dir.path()).expect("write");
    let meta_path = dir.path().join("meta.json");
    let good = std::fs::read_to_string(&meta_path).expect("meta");

    // Progress out of order.
    let mut meta: serde_json::Value = serde_json::from_str(&good).expect("json");
    meta["steps"][1]["progress_before"] = serde_json::json!(3);
    std::fs::write(&meta_path, meta.to_string()).expect("write");
    let err = Demo::read(dir.path())
        .expect_err("bad progress")
        .to_string();
    assert!(
        err.contains("meta.json") && err.contains("steps[1].progress"),
        "{err}"
    );

    // A pixel outside the grid.
    let mut meta: serde_json::Value = serde_json::from_str(&good).expect("json");
    meta["steps"][0]["action"]["x"] = serde_json::json!(500);
    std::fs::write(&meta_path, meta.to_string()).expect("write");
    let err = Demo::read(dir.path()).expect_err("bad pixel").to_string();
    assert!(err.contains("steps[0].action"), "{err}");

    // Issue 10: damaged block poses and workspace bounds, each named.
    for (field, value, expect) in [
        ("blocks_before/0/0", serde_json::json!(99), "block id 99"),
        ("blocks_before/1/0", serde_json::json!(0), "repeats"),
        (
            "blocks_before/0/1/position",
            serde_json::json!([50.0, 0.0, 0.0]),
            "position",
        ),
        (
            "blocks_before/0/1/rotation",
            serde_json::json!([0.0, 0.0, 0.0, 0.0]),
            "unit quaternion",
        ),
    ] {
        let mut meta: serde_json::Value = serde_json::from_str(&good).expect("json");
        let pointer = format!("/steps/0/{field}");
        *meta.pointer_mut(&pointer).expect("field exists") = value;
        std::fs::write(&meta_path, meta.to_string()).expect("write");
        let err = Demo::read(dir.path()).expect_err(field).to_string();
        assert!(
            err.contains("meta.json")
                && err.contains("steps[0].blocks_before")
                && err.contains(expect),
            "{field}: {err}"
        );
    }
    // Issue 27: a gripper pose that is not the action's (1e39 was accepted).
    for bad in [
        serde_json::json!([1e39, 0.0, 0.0, 0.0]),
        serde_json::json!([0.2, -0.2, 0.0, 0.0]),
    ] {
        let mut meta: serde_json::Value = serde_json::from_str(&good).expect("json");
        meta["steps"][0]["world_pose"] = bad.clone();
        std::fs::write(&meta_path, meta.to_string()).expect("write");
        let err = Demo::read(dir.path())
            .expect_err("bad world_pose")
            .to_string();
        assert!(
            err.contains("meta.json") && err.contains("steps[0].world_pose"),
            "{bad}: {err}"
        );
    }
    let mut meta: serde_json::Value = serde_json::from_str(&good).expect("json");
    meta["workspace"] = serde_json::json!([[1.0, -1.0], [-0.224, 0.224]]);
    std::fs::write(&meta_path, meta.to_string()).expect("write");
    let err = Demo::read(dir.path()).expect_err("workspace").to_string();
    assert!(err.contains("field `workspace`"), "{err}");

    // Truncated PNG.
    std::fs::write(&meta_path, &good).expect("write");
    let png = dir.path().join("001_depth.png");
    let bytes = std::fs::read(&png).expect("png");
    std::fs::write(&png, &bytes[..bytes.len() / 2]).expect("truncate");
    let err = Demo::read(dir.path()).expect_err("bad png").to_string();
    assert!(err.contains("001_depth.png"), "{err}");

    // Missing file.
    std::fs::remove_file(&png).expect("rm");
    let err = Demo::read(dir.path()).expect_err("missing").to_string();
    assert!(err.contains("001_depth.png"), "{err}");

    // Not JSON.
    std::fs::write(&meta_path, "{not json").expect("write");
    let err = Demo::read(dir.path()).expect_err("bad json").to_string();
    assert!(err.contains("meta.json"), "{err}");
}

/// CRC-32 (IEEE) of PNG chunk type + data.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

fn chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let mut out = (data.len() as u32).to_be_bytes().to_vec();
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
    out
}

/// Issue 10: a tiny PNG whose header claims 65535 x 65535 RGBA16 (34 GB
/// decoded) is refused from its header, before any allocation.
#[test]
fn issue_10_png_header_claiming_a_huge_image_is_refused_before_allocating() {
    let dir = tempfile::tempdir().expect("tempdir");
    let demo = record(TaskId::Stack, 2);
    demo.write(dir.path()).expect("write");
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&65535u32.to_be_bytes());
    ihdr.extend_from_slice(&65535u32.to_be_bytes());
    ihdr.extend_from_slice(&[16, 6, 0, 0, 0]); // 16-bit RGBA
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    ));
    png.extend(chunk(b"IEND", &[]));
    let bad = dir.path().join("000_color.png");
    std::fs::write(&bad, &png).expect("write");
    let msg = Demo::read(dir.path())
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        msg.contains("000_color.png") && msg.contains("65535x65535"),
        "{msg}"
    );
}
