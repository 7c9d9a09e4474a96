//! External data, as the ONNX format defines it: a tensor whose
//! `data_location` is `EXTERNAL` keeps its bytes in another file, named by
//! the tensor's `external_data` entries `location` (a path relative to the
//! model's folder), `offset` and `length` (bytes; `offset` 0 and `length` the
//! rest of the file when absent). PyTorch's default exporter (`dynamo=True`,
//! since 2.9) writes every weight this way, into `<model>.onnx.data`.
//!
//! seespot reads such tensors into the model before any check, so that they
//! pass the same bounds as tensors stored inline, and refuses, naming the
//! tensor and the file:
//! - a location that is absolute, holds `..`, or leads (through a link) out
//!   of the model's folder;
//! - a data file that is missing, not a regular file, or larger than
//!   [`super::MAX_FILE_BYTES`];
//! - an offset or length past the data file's end, or a length other than the
//!   tensor's dimensions need.

use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};

use tract_onnx::pb;

use super::MAX_FILE_BYTES;

/// `EXTERNAL` of ONNX's `DataLocation`.
const EXTERNAL: i32 = pb::tensor_proto::DataLocation::External as i32;

/// Whether `t` keeps its data in another file.
pub(super) fn is_external(t: &pb::TensorProto) -> bool {
    t.data_location == Some(EXTERNAL)
}

/// The external data files `proto`'s initializers name, each checked to be
/// a regular file inside `folder` (the model's folder), in the order they
/// are first named.
pub(super) fn data_files(proto: &pb::ModelProto, folder: &Path) -> Result<Vec<PathBuf>, String> {
    let mut out: Vec<PathBuf> = Vec::new();
    for t in external_tensors(proto) {
        let entry = Entry::of(t)?;
        let path = resolve(folder, &entry.location, &t.name)?;
        if !out.contains(&path) {
            out.push(path);
        }
    }
    Ok(out)
}

/// Reads every external tensor of `proto` into it (as `raw_data`), from files
/// in `folder`. Returns the data files read, in the order first named.
pub(super) fn inline(proto: &mut pb::ModelProto, folder: &Path) -> Result<Vec<PathBuf>, String> {
    let Some(graph) = proto.graph.as_mut() else {
        return Ok(Vec::new());
    };
    // Constants inside nodes are small; the exporters keep them inline.
    for n in &graph.node {
        for a in &n.attribute {
            if a.t.as_ref().is_some_and(is_external) {
                return Err(format!(
                    "node `{}` ({}) attribute `{}` keeps its tensor in an external file; seespot reads external data for initializers only",
                    n.name, n.op_type, a.name
                ));
            }
        }
    }
    let mut files: BTreeMap<PathBuf, Vec<u8>> = BTreeMap::new();
    let mut order: Vec<PathBuf> = Vec::new();
    for t in graph.initializer.iter_mut().filter(|t| is_external(t)) {
        let entry = Entry::of(t)?;
        let path = resolve(folder, &entry.location, &t.name)?;
        if !files.contains_key(&path) {
            let bytes = seespot_sim::bounds::read_file(&path, MAX_FILE_BYTES).map_err(|e| {
                format!(
                    "initializer `{}`: its external data file {} cannot be read: {e}",
                    t.name,
                    path.display()
                )
            })?;
            files.insert(path.clone(), bytes);
            order.push(path.clone());
        }
        let data = &files[&path];
        let file_len = data.len() as u64;
        let start = entry.offset.unwrap_or(0);
        let past = |what: &str, v: u64| {
            format!(
                "initializer `{}`: its {what} ({v} bytes) lies past the end of {} ({file_len} bytes); the data file does not belong to this model, or was cut short",
                t.name,
                path.display()
            )
        };
        if start > file_len {
            return Err(past("offset", start));
        }
        let length = entry.length.unwrap_or(file_len - start);
        let end = start
            .checked_add(length)
            .filter(|e| *e <= file_len)
            .ok_or_else(|| past("offset plus length", start.saturating_add(length)))?;
        if let Some(want) = byte_len(t)
            && want != length
        {
            return Err(format!(
                "initializer `{}`: its external data is {length} bytes in {} but its dimensions {:?} need {want}",
                t.name,
                path.display(),
                t.dims
            ));
        }
        // Offsets fit in memory: `end` is at most the file's length.
        let (s, e) = (start as usize, end as usize);
        t.raw_data = data[s..e].to_vec();
        t.data_location = None;
        t.external_data.clear();
    }
    Ok(order)
}

/// The initializers of `proto` stored externally.
fn external_tensors(proto: &pb::ModelProto) -> impl Iterator<Item = &pb::TensorProto> {
    proto
        .graph
        .iter()
        .flat_map(|g| g.initializer.iter())
        .filter(|t| is_external(t))
}

/// A tensor's `external_data` entries.
struct Entry {
    location: String,
    offset: Option<u64>,
    length: Option<u64>,
}

impl Entry {
    fn of(t: &pb::TensorProto) -> Result<Self, String> {
        let mut location = None;
        let (mut offset, mut length) = (None, None);
        for kv in &t.external_data {
            let number = |v: &str| {
                v.parse::<u64>().map_err(|_| {
                    format!(
                        "initializer `{}`: its external data's `{}` is `{v}`, not a byte count",
                        t.name, kv.key
                    )
                })
            };
            match kv.key.as_str() {
                "location" => location = Some(kv.value.clone()),
                "offset" => offset = Some(number(&kv.value)?),
                "length" => length = Some(number(&kv.value)?),
                // `checksum` (SHA-1) and unknown keys are not needed to read it.
                _ => {}
            }
        }
        let location = location.filter(|l| !l.is_empty()).ok_or_else(|| {
            format!(
                "initializer `{}` is stored externally but names no `location`",
                t.name
            )
        })?;
        Ok(Self {
            location,
            offset,
            length,
        })
    }
}

/// The bytes a tensor's dimensions need, for the element types whose width
/// is fixed.
fn byte_len(t: &pb::TensorProto) -> Option<u64> {
    use pb::tensor_proto::DataType as T;
    let width: u64 = match T::try_from(t.data_type) {
        Ok(T::Float | T::Int32 | T::Uint32) => 4,
        Ok(T::Double | T::Int64 | T::Uint64) => 8,
        Ok(T::Float16 | T::Bfloat16 | T::Int16 | T::Uint16) => 2,
        Ok(T::Int8 | T::Uint8 | T::Bool) => 1,
        _ => return None,
    };
    let mut n: u64 = width;
    for &d in &t.dims {
        n = n.checked_mul(u64::try_from(d).ok()?)?;
    }
    Some(n)
}

/// The data file `location` names, relative to `folder`, checked: relative,
/// no `..`, a regular file, and inside `folder` once links are followed.
fn resolve(folder: &Path, location: &str, tensor: &str) -> Result<PathBuf, String> {
    let refuse = |why: &str| {
        Err(format!(
            "initializer `{tensor}`: its external data location `{location}` {why}; ONNX data files lie in the model's folder ({}), named relative to it",
            shown(folder)
        ))
    };
    let rel = Path::new(location);
    // `\` separators and drive letters are Windows paths: absolute there.
    if rel.is_absolute() || location.starts_with(['/', '\\']) || location.contains(':') {
        return refuse("is an absolute path");
    }
    if location.contains('\\') || rel.components().any(|c| matches!(c, Component::ParentDir)) {
        return refuse("leads out of the folder (`..`)");
    }
    let path = folder.join(rel);
    let meta = match std::fs::metadata(&path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(format!(
                "initializer `{tensor}`: its external data file {} is missing (keep the `.data` file the exporter wrote beside the model, or export with `external_data=False`)",
                path.display()
            ));
        }
        Err(e) => {
            return Err(format!(
                "initializer `{tensor}`: its external data file {} cannot be read: {e}",
                path.display()
            ));
        }
    };
    if !meta.is_file() {
        return Err(format!(
            "initializer `{tensor}`: its external data location {} is not a regular file",
            path.display()
        ));
    }
    let (Ok(real), Ok(root)) = (path.canonicalize(), folder_root(folder)) else {
        return refuse("cannot be resolved");
    };
    if !real.starts_with(&root) {
        return Err(format!(
            "initializer `{tensor}`: its external data file {} is a link to {}, outside the model's folder ({}); copy the data file next to the model",
            path.display(),
            real.display(),
            shown(folder)
        ));
    }
    Ok(path)
}

fn folder_root(folder: &Path) -> std::io::Result<PathBuf> {
    if folder.as_os_str().is_empty() {
        Path::new(".").canonicalize()
    } else {
        folder.canonicalize()
    }
}

fn shown(folder: &Path) -> String {
    if folder.as_os_str().is_empty() {
        ".".into()
    } else {
        folder.display().to_string()
    }
}
