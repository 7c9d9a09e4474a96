//! The fuzz suite (issue 10): every reader of outside data gets arbitrary and
//! mutated-valid inputs, and must neither panic nor allocate more than
//! [`BOUND`] bytes at a time for one input.
//!
//! Targets: the scene parser (`Scene::parse`, TOML text), the demonstration
//! reader (`Demo::read`: `meta.json` and the PNGs of a 32 px demo in a temp
//! folder), the weights reader (`PolicyNet::load`: a safetensors file with
//! checksums), the ONNX embedding-model loader (`OnnxEmbedder::from_bytes`:
//! the raw-patch control's file and an exported policy's) and the WebSocket
//! message decoder (`ClientMessage::parse`).
//! Mutations: byte edits (set, insert, delete, truncate), numbers swapped for
//! extreme ones, and, for JSON, any node of the document replaced by an
//! extreme value.
//!
//! Cases per target: `PROPTEST_CASES` (default 256, a few seconds in
//! release). `scripts/fuzz` runs 10 000 per target. Allocation is counted by
//! this binary's global allocator, per thread: the peak of live bytes while
//! one input is read must stay under [`BOUND`], and any single request above
//! it is refused (the process then aborts, naming the size), so a reader that
//! tries to allocate gigabytes fails the run instead of the machine.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use prost::Message;
use seespot_policy::PolicyNet;
use seespot_sim::{Demo, Grid, Scene, TaskId, WorldConfig};
use seespot_viz::protocol::ClientMessage;
use serde_json::{Value, json};

/// Most bytes one input may hold live at once while it is read.
const BOUND: usize = 64 << 20;

// ---------------------------------------------------------------- allocation

struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
    static ARMED: Cell<bool> = const { Cell::new(false) };
}

fn armed() -> bool {
    ARMED.try_with(Cell::get).unwrap_or(false)
}

fn count(delta: isize) {
    let _ = LIVE.try_with(|l| {
        let v = l.get() + delta;
        l.set(v);
        let _ = PEAK.try_with(|p| p.set(p.get().max(v)));
    });
}

// SAFETY: every call is forwarded to `System` with the caller's layout; the
// wrapper only counts sizes in thread-locals that need no allocation, and
// refuses (null, as allowed) requests over the bound while a fuzz input runs.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if armed() && layout.size() > BOUND {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if armed() && layout.size() > BOUND {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        count(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if armed() && new_size > BOUND {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            count(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` with the bound armed; returns its result and the peak of bytes
/// it held live at once on this thread.
fn measured<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let base = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(base));
    ARMED.with(|a| a.set(true));
    let r = f();
    ARMED.with(|a| a.set(false));
    let peak = PEAK.with(Cell::get) - base;
    (r, peak.max(0) as usize)
}

// ---------------------------------------------------------------- mutations

/// Numbers and tokens that break careless readers.
const TOKENS: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "4",
    "99",
    "255",
    "256",
    "65535",
    "4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775808",
    "4611686018427387904",
    "1e39",
    "-1e39",
    "1e309",
    "1e-45",
    "NaN",
    "nan",
    "inf",
    "-0.0",
    "0.5",
    "\"\"",
    "null",
    "true",
    "[]",
    "{}",
    "[[]]",
    "\"stack\"",
    "\"row\"",
    "\"F32\"",
];

/// One edit of a byte string; positions are taken modulo its length.
#[derive(Clone, Debug)]
enum Edit {
    Set(usize, u8),
    Insert(usize, Vec<u8>),
    Delete(usize, usize),
    Truncate(usize),
    /// Replace the number at or after a position by `TOKENS[i]`.
    Number(usize, usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Edit::Set(p, b)),
        (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(p, b)| Edit::Insert(p, b)),
        (any::<usize>(), 1usize..32).prop_map(|(p, n)| Edit::Delete(p, n)),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(p, t)| Edit::Number(p, t)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(p, t)| Edit::Number(p, t)),
    ]
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    proptest::collection::vec(edit(), 1..5)
}

fn apply(bytes: &mut Vec<u8>, edits: &[Edit]) {
    for e in edits {
        let n = bytes.len().max(1);
        match e {
            Edit::Set(p, b) => {
                if !bytes.is_empty() {
                    bytes[p % n] = *b;
                }
            }
            Edit::Insert(p, b) => {
                let at = p % (bytes.len() + 1);
                bytes.splice(at..at, b.iter().copied());
            }
            Edit::Delete(p, len) => {
                let at = p % n;
                let end = (at + len).min(bytes.len());
                if at < end {
                    bytes.drain(at..end);
                }
            }
            Edit::Truncate(p) => bytes.truncate(p % n),
            Edit::Number(p, t) => {
                let numeric = |b: u8| b.is_ascii_digit() || b"-+.eE".contains(&b);
                let start = (p % n..bytes.len()).find(|&i| bytes[i].is_ascii_digit());
                if let Some(mut s) = start {
                    while s > 0 && numeric(bytes[s - 1]) {
                        s -= 1;
                    }
                    let mut end = s;
                    while end < bytes.len() && numeric(bytes[end]) {
                        end += 1;
                    }
                    bytes.splice(s..end, TOKENS[*t].bytes());
                }
            }
        }
    }
}

/// Extreme JSON values for [`replace_node`].
fn extreme_values() -> Vec<Value> {
    vec![
        json!(0),
        json!(-1),
        json!(1),
        json!(99),
        json!(u32::MAX),
        json!(u64::MAX),
        json!(i64::MIN),
        json!(1u64 << 62),
        json!(1e39),
        json!(-1e39),
        json!(1e-39),
        json!(0.5),
        json!(""),
        json!("x".repeat(1000)),
        json!("stack"),
        json!("F64"),
        json!(null),
        json!(true),
        json!([]),
        json!({}),
        json!([0, 0]),
        json!([u64::MAX, 4]),
        json!([1u64 << 62]),
        json!([1u64 << 62, 4]),
        json!([65535, 65535, 65535]),
        json!([[0, {"position": [0, 0, 0], "rotation": [0, 0, 0, 0]}]]),
        json!([[99, {"position": [0, 0, 0.025], "rotation": [0, 0, 0, 1]}]]),
    ]
}

/// Replaces node number `index` (pre-order, modulo the node count) by `with`;
/// `dup` duplicates an array's element or removes an object's key instead.
fn replace_node(v: &mut Value, index: usize, with: &Value, dup: bool) {
    fn nodes(v: &Value) -> usize {
        1 + match v {
            Value::Array(a) => a.iter().map(nodes).sum(),
            Value::Object(o) => o.values().map(nodes).sum(),
            _ => 0,
        }
    }
    fn walk(v: &mut Value, k: &mut usize, with: &Value, dup: bool) -> bool {
        if *k == 0 {
            match (dup, &mut *v) {
                (true, Value::Array(a)) if !a.is_empty() => a.push(a[0].clone()),
                (true, Value::Object(o)) if !o.is_empty() => {
                    let key = o.keys().next().cloned().unwrap_or_default();
                    o.remove(&key);
                }
                _ => *v = with.clone(),
            }
            return true;
        }
        *k -= 1;
        match v {
            Value::Array(a) => a.iter_mut().any(|c| walk(c, k, with, dup)),
            Value::Object(o) => o.values_mut().any(|c| walk(c, k, with, dup)),
            _ => false,
        }
    }
    let mut k = index % nodes(v);
    walk(v, &mut k, with, dup);
}

/// A JSON mutation: (node index, extreme value index, duplicate/remove instead).
fn json_edits() -> impl Strategy<Value = Vec<(usize, usize, bool)>> {
    proptest::collection::vec((any::<usize>(), any::<usize>(), any::<bool>()), 1..4)
}

fn apply_json(v: &mut Value, edits: &[(usize, usize, bool)]) {
    let values = extreme_values();
    for (node, value, dup) in edits {
        replace_node(v, *node, &values[value % values.len()], *dup);
    }
}

// ---------------------------------------------------------------- harness

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(256)
}

/// Runs `case` on `cases()` inputs of `strategy`; fails on a panic or a peak
/// over [`BOUND`]; prints the count and the largest peak seen.
fn fuzz<S: Strategy>(target: &str, strategy: S, case: impl Fn(S::Value) -> usize)
where
    S::Value: std::fmt::Debug,
{
    let config = Config {
        cases: cases(),
        // Failures are printed (with the shrunk input), not written into the tree.
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner = TestRunner::new(config);
    let max_peak = Cell::new(0usize);
    let t = std::time::Instant::now();
    let result = runner.run(&strategy, |input| {
        let peak = case(input);
        max_peak.set(max_peak.get().max(peak));
        prop_assert!(
            peak < BOUND,
            "{target}: one input held {peak} bytes at once (bound {BOUND})"
        );
        Ok(())
    });
    println!(
        "fuzz {target}: {} cases in {:.1} s, largest allocation peak {:.2} MB (bound {} MB)",
        cases(),
        t.elapsed().as_secs_f64(),
        max_peak.get() as f64 / 1e6,
        BOUND >> 20
    );
    if let Err(e) = result {
        panic!("fuzz {target}: {e}");
    }
}

// ---------------------------------------------------------------- targets

const VALID_SCENE: &str = "task = \"stack\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 50\n[noise]\ndepth_std = 0.001\ncolor_jitter = 4\n";

#[test]
fn fuzz_scene_parser() {
    let arbitrary = proptest::collection::vec(any::<u8>(), 0..512).prop_map(|b| (b, vec![]));
    let mutated = edits().prop_map(|e| (VALID_SCENE.as_bytes().to_vec(), e));
    fuzz(
        "scene",
        prop_oneof![arbitrary, mutated],
        |(mut bytes, e)| {
            apply(&mut bytes, &e);
            let text = String::from_utf8_lossy(&bytes);
            measured(|| {
                let _ = Scene::parse(&text, Path::new("fuzz.toml"));
            })
            .1
        },
    );
}

/// A 32 px oracle demonstration of `stack` written into a temp folder.
fn demo_dir() -> (tempfile::TempDir, Vec<(PathBuf, Vec<u8>)>) {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = WorldConfig {
        grid: Grid::new(32),
        ..WorldConfig::default()
    };
    Demo::record(TaskId::Stack, 0, config)
        .expect("record")
        .write(dir.path())
        .expect("write");
    Demo::read(dir.path()).expect("the valid demo reads back");
    let mut files: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir.path())
        .expect("read_dir")
        .map(|e| {
            let p = e.expect("entry").path();
            let b = std::fs::read(&p).expect("read");
            (p, b)
        })
        .collect();
    files.sort();
    (dir, files)
}

#[test]
fn fuzz_demo_reader() {
    let (dir, files) = demo_dir();
    let meta_index = files
        .iter()
        .position(|(p, _)| p.ends_with("meta.json"))
        .expect("meta.json");
    let meta: Value = serde_json::from_slice(&files[meta_index].1).expect("meta json");
    // (file index, byte edits, JSON edits of meta.json instead, remove the file)
    let strategy = (any::<usize>(), edits(), json_edits(), 0u8..10);
    fuzz("demo", strategy, |(file, e, je, how)| {
        let (path, original) = if how < 5 {
            &files[meta_index]
        } else {
            &files[file % files.len()]
        };
        let bytes = match how {
            0..=2 => {
                let mut m = meta.clone();
                apply_json(&mut m, &je);
                serde_json::to_vec_pretty(&m).expect("json")
            }
            9 => Vec::new(),
            _ => {
                let mut b = original.clone();
                apply(&mut b, &e);
                b
            }
        };
        std::fs::write(path, &bytes).expect("write");
        let peak = measured(|| {
            let _ = Demo::read(dir.path());
        })
        .1;
        std::fs::write(path, original).expect("restore");
        peak
    });
}

/// The bytes of a freshly initialised 32 px policy's weights file.
fn weights() -> Vec<u8> {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("stack.safetensors");
    PolicyNet::new(TaskId::Stack, 32, 1)
        .expect("policy")
        .save(&path)
        .expect("save");
    PolicyNet::load(&path).expect("the valid weights load back");
    std::fs::read(&path).expect("read")
}

/// Splits a safetensors file into its JSON header and the rest.
fn split_header(bytes: &[u8]) -> (Value, &[u8]) {
    let n = u64::from_le_bytes(bytes[..8].try_into().expect("8 bytes")) as usize;
    let header = serde_json::from_slice(&bytes[8..8 + n]).expect("header json");
    (header, &bytes[8 + n..])
}

fn join_header(header: &Value, data: &[u8]) -> Vec<u8> {
    let h = serde_json::to_vec(header).expect("json");
    let mut out = (h.len() as u64).to_le_bytes().to_vec();
    out.extend_from_slice(&h);
    out.extend_from_slice(data);
    out
}

#[test]
fn fuzz_weights_reader() {
    let valid = weights();
    let (header, data) = split_header(&valid);
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("fuzz.safetensors");
    let header_len = 8 + (valid.len() - data.len() - 8);
    // (byte edits, in the header only, JSON edits of the header instead, arbitrary)
    let strategy = (
        edits(),
        any::<bool>(),
        json_edits(),
        0u8..8,
        proptest::collection::vec(any::<u8>(), 0..256),
    );
    fuzz(
        "weights",
        strategy,
        |(mut e, header_only, je, how, arbitrary)| {
            let bytes = match how {
                0..=3 => {
                    let mut h = header.clone();
                    apply_json(&mut h, &je);
                    join_header(&h, data)
                }
                4 => arbitrary,
                _ => {
                    if header_only {
                        for ed in &mut e {
                            match ed {
                                Edit::Set(p, _)
                                | Edit::Insert(p, _)
                                | Edit::Delete(p, _)
                                | Edit::Number(p, _) => *p %= header_len,
                                Edit::Truncate(_) => {}
                            }
                        }
                    }
                    let mut b = valid.clone();
                    apply(&mut b, &e);
                    b
                }
            };
            std::fs::write(&path, &bytes).expect("write");
            measured(|| {
                let _ = PolicyNet::load(&path);
            })
            .1
        },
    );
}

#[test]
fn fuzz_websocket_message_decoder() {
    let valid = [
        r#"{"type": "ping"}"#,
        r#"{"type": "next_phase"}"#,
        r#"{"type": "reset", "task": "row", "seed": 3}"#,
        r#"{"type": "query", "pair": 0, "policy": 1, "y": 40, "x": 60}"#,
    ];
    let arbitrary =
        proptest::collection::vec(any::<u8>(), 0..256).prop_map(|b| (b, vec![], vec![], false));
    let mutated = (0..valid.len(), edits(), json_edits(), any::<bool>())
        .prop_map(move |(i, e, je, js)| (valid[i].as_bytes().to_vec(), e, je, js));
    fuzz(
        "websocket",
        prop_oneof![arbitrary, mutated],
        |(bytes, e, je, js)| {
            let text = if js {
                let mut v: Value = serde_json::from_slice(&bytes).expect("valid json");
                apply_json(&mut v, &je);
                v.to_string()
            } else {
                let mut b = bytes;
                apply(&mut b, &e);
                String::from_utf8_lossy(&b).into_owned()
            };
            measured(|| {
                let _ = ClientMessage::parse(&text);
            })
            .1
        },
    );
}

/// A custom task's demonstrations (`demos/custom/l-shape/`, whose
/// `meta.json` holds the goal layout) copied into a temp folder laid out as
/// `custom/l-shape/<n>/`: every file of each demonstration, and the folder.
fn custom_task_dir() -> (tempfile::TempDir, PathBuf, Vec<(PathBuf, Vec<u8>)>) {
    let dir = tempfile::tempdir().expect("tempdir");
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../demos/custom/l-shape");
    let task_dir = dir.path().join("custom/l-shape");
    let mut files = Vec::new();
    for demo in std::fs::read_dir(&src).expect("l-shape demos") {
        let demo = demo.expect("entry").path();
        let to = task_dir.join(demo.file_name().expect("name"));
        std::fs::create_dir_all(&to).expect("mkdir");
        for f in std::fs::read_dir(&demo).expect("demo files") {
            let f = f.expect("entry").path();
            let bytes = std::fs::read(&f).expect("read");
            let dst = to.join(f.file_name().expect("name"));
            std::fs::write(&dst, &bytes).expect("write");
            files.push((dst, bytes));
        }
    }
    files.sort();
    (dir, task_dir, files)
}

/// Custom-task demonstrations and their goal layouts: a damaged `meta.json`
/// (its `goal` included) or image is refused with an error, never a panic,
/// when the task is defined from them.
#[test]
fn fuzz_custom_task_goals() {
    let (_dir, task_dir, files) = custom_task_dir();
    let task = "custom:l-shape"
        .parse::<TaskId>()
        .expect("task")
        .custom()
        .expect("custom");
    seespot_sim::custom::load(&task_dir, task).expect("the valid task loads");
    let metas: Vec<usize> = (0..files.len())
        .filter(|&i| files[i].0.ends_with("meta.json"))
        .collect();
    let strategy = (any::<usize>(), edits(), json_edits(), 0u8..10);
    fuzz("custom", strategy, |(file, e, je, how)| {
        let (path, original) = if how < 6 {
            &files[metas[file % metas.len()]]
        } else {
            &files[file % files.len()]
        };
        let bytes = match how {
            0..=3 => {
                let mut m: Value = serde_json::from_slice(original).expect("meta json");
                // Half the JSON edits land in the goal.
                let target = if how < 2 { &mut m["goal"] } else { &mut m };
                apply_json(target, &je);
                serde_json::to_vec_pretty(&m).expect("json")
            }
            9 => Vec::new(),
            _ => {
                let mut b = original.clone();
                apply(&mut b, &e);
                b
            }
        };
        std::fs::write(path, &bytes).expect("write");
        let peak = measured(|| {
            let _ = seespot_sim::custom::load(&task_dir, task);
        })
        .1;
        std::fs::write(path, original).expect("restore");
        peak
    });
}

/// The valid ONNX files the loader fuzz mutates: the raw-patch control and
/// a freshly initialised policy exported.
fn onnx_files() -> Vec<Vec<u8>> {
    use seespot_policy::onnx::export;
    let policy = PolicyNet::new(TaskId::Stack, 112, 1).expect("policy");
    let files = vec![
        export::raw_patches_model().encode_to_vec(),
        export::policy_model(&policy)
            .expect("export")
            .encode_to_vec(),
    ];
    for f in &files {
        seespot_policy::OnnxEmbedder::from_bytes(Path::new("valid.onnx"), f)
            .expect("the valid files load");
    }
    files
}

#[test]
fn fuzz_onnx_loader() {
    let valid = onnx_files();
    let strategy = (
        0usize..2,
        edits(),
        0u8..6,
        proptest::collection::vec(any::<u8>(), 0..512),
    );
    fuzz("onnx", strategy, |(which, e, how, arbitrary)| {
        let bytes = match how {
            0 => arbitrary,
            _ => {
                let mut b = valid[which].clone();
                apply(&mut b, &e);
                b
            }
        };
        measured(|| {
            let _ = seespot_policy::OnnxEmbedder::from_bytes(Path::new("fuzz.onnx"), &bytes);
            // A file that decodes is also handed to the loader re-encoded
            // after a field-level mutation: a dimension or an attribute
            // value set to an extreme.
            if let Ok(mut m) = seespot_policy::onnx::ModelProto::decode(bytes.as_slice())
                && let Some(g) = m.graph.as_mut()
            {
                let k = e.len();
                let nodes = g.node.len().max(1);
                if let Some(n) = g.node.get_mut(k % nodes)
                    && let attributes = n.attribute.len().max(1)
                    && let Some(a) = n.attribute.get_mut(k % attributes)
                    && let Some(v) = a.ints.first_mut()
                {
                    *v = [i64::MAX, -1, 0, 1 << 40][k % 4];
                }
                let _ = seespot_policy::OnnxEmbedder::from_bytes(
                    Path::new("fuzz.onnx"),
                    &m.encode_to_vec(),
                );
            }
        })
        .1
    });
}
