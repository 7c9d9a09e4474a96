//! Safetensors files with a per-tensor checksum in the metadata, so damage to any
//! tensor's bytes is caught and reported with the tensor's name.
//!
//! Writing uses the `safetensors` crate; reading parses the header itself so that
//! a truncated or damaged file still names the tensor at fault.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use safetensors::tensor::{Dtype, TensorView};

use crate::error::PolicyError;

/// Metadata key prefix of a tensor's checksum (FNV-1a 64 of its bytes, hex).
const CHECKSUM_PREFIX: &str = "checksum:";

/// The largest magnitude a stored value may have. Trained seespot weights stay
/// below 1 (the shipped ones: 0.46-0.77); a value beyond this bound says the
/// file is damaged or is not a network's weights, and would overflow the
/// first convolution's sums.
pub const MAX_WEIGHT: f32 = 1e4;

/// FNV-1a 64 of `bytes`.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// One f32 tensor: shape and row-major values.
#[derive(Clone, Debug, PartialEq)]
pub struct F32Tensor {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

fn to_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Writes `tensors` (name -> tensor) and `metadata` to `path` (atomically: a
/// temporary file renamed into place).
pub fn write(
    path: &Path,
    tensors: &BTreeMap<String, F32Tensor>,
    metadata: &BTreeMap<String, String>,
) -> Result<(), PolicyError> {
    let bytes: Vec<(String, Vec<usize>, Vec<u8>)> = tensors
        .iter()
        .map(|(k, t)| (k.clone(), t.shape.clone(), to_bytes(&t.data)))
        .collect();
    let mut meta: HashMap<String, String> = metadata.clone().into_iter().collect();
    for (k, _, b) in &bytes {
        meta.insert(
            format!("{CHECKSUM_PREFIX}{k}"),
            format!("{:016x}", fnv1a(b)),
        );
    }
    let views = bytes
        .iter()
        .map(|(k, s, b)| {
            TensorView::new(Dtype::F32, s.clone(), b)
                .map(|v| (k.clone(), v))
                .map_err(|e| PolicyError::Tensor {
                    path: path.to_path_buf(),
                    tensor: k.clone(),
                    reason: e.to_string(),
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(|e| PolicyError::io(dir, e))?;
    }
    let bad = |reason: String| PolicyError::Format {
        path: path.to_path_buf(),
        reason,
    };
    let bytes = safetensors::serialize(views, Some(meta))
        .map_err(|e| bad(format!("cannot write safetensors: {e}")))?;
    let bytes = canonical_header(bytes).map_err(bad)?;
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(|e| PolicyError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| PolicyError::io(path, e))
}

/// A safetensors file with its JSON header's keys in sorted order (the
/// crate writes the metadata in a hash map's order, which changes from one
/// process to the next), so the same tensors and metadata always give the
/// same bytes and the same checksum. The header keeps its length: the same
/// keys and values, reordered, padded with spaces to a multiple of 8.
fn canonical_header(bytes: Vec<u8>) -> Result<Vec<u8>, String> {
    fn sorted(v: serde_json::Value) -> serde_json::Value {
        match v {
            serde_json::Value::Object(m) => {
                let mut entries: Vec<(String, serde_json::Value)> = m.into_iter().collect();
                entries.sort_by(|a, b| a.0.cmp(&b.0));
                serde_json::Value::Object(
                    entries.into_iter().map(|(k, v)| (k, sorted(v))).collect(),
                )
            }
            other => other,
        }
    }
    let len = bytes
        .get(..8)
        .and_then(|b| b.try_into().ok())
        .map(u64::from_le_bytes)
        .ok_or("no header length")? as usize;
    let header = bytes.get(8..8 + len).ok_or("header past the end")?;
    let value: serde_json::Value =
        serde_json::from_slice(header).map_err(|e| format!("header: {e}"))?;
    let mut text = serde_json::to_string(&sorted(value)).map_err(|e| e.to_string())?;
    while text.len() % 8 != 0 {
        text.push(' ');
    }
    let mut out = Vec::with_capacity(bytes.len());
    out.extend_from_slice(&(text.len() as u64).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
    out.extend_from_slice(&bytes[8 + len..]);
    Ok(out)
}

/// A file read back: its metadata (checksums removed) and tensors.
#[derive(Clone, Debug)]
pub struct TensorFile {
    pub metadata: BTreeMap<String, String>,
    pub tensors: BTreeMap<String, F32Tensor>,
}

impl TensorFile {
    /// The free-form training facts [`header`] wrote (`extra.<key>`), by key.
    pub fn extra(&self) -> BTreeMap<String, String> {
        self.metadata
            .iter()
            .filter_map(|(k, v)| k.strip_prefix("extra.").map(|k| (k.to_owned(), v.clone())))
            .collect()
    }

    /// The metadata field `key` of the file read from `path`; an error naming
    /// both when it is missing.
    pub fn field(&self, path: &Path, key: &str) -> Result<&String, PolicyError> {
        self.metadata.get(key).ok_or_else(|| PolicyError::Format {
            path: path.to_path_buf(),
            reason: format!("metadata field `{key}` is missing"),
        })
    }

    /// The tensor `name` of the file read from `path`, which must have
    /// `shape`; an error naming the file and the tensor otherwise.
    pub fn tensor(
        &self,
        path: &Path,
        name: &str,
        shape: &[usize],
    ) -> Result<&F32Tensor, PolicyError> {
        let refuse = |reason: String| PolicyError::Tensor {
            path: path.to_path_buf(),
            tensor: name.to_owned(),
            reason,
        };
        let t = self
            .tensors
            .get(name)
            .ok_or_else(|| refuse("missing".into()))?;
        if t.shape != shape {
            return Err(refuse(format!("shape {:?}, expected {shape:?}", t.shape)));
        }
        Ok(t)
    }
}

/// The metadata every weights file holds: its format, architecture and
/// format version, the seespot version that wrote it, its task, and its
/// free-form training facts `extra` (as `extra.<key>`; read back by
/// [`TensorFile::extra`]).
pub fn header(
    format: &str,
    architecture: &str,
    format_version: u32,
    seespot_version: &str,
    task: &str,
    extra: &BTreeMap<String, String>,
) -> BTreeMap<String, String> {
    [
        ("format", format.to_owned()),
        ("architecture", architecture.to_owned()),
        ("format_version", format_version.to_string()),
        ("seespot_version", seespot_version.to_owned()),
        ("task", task.to_owned()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .chain(extra.iter().map(|(k, v)| (format!("extra.{k}"), v.clone())))
    .collect()
}

/// What a file that is not a safetensors file holds, as a user would name
/// it (from its first bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Content {
    Empty,
    /// UTF-8 without control characters other than whitespace.
    Text,
    /// Anything else.
    Other,
}

impl Content {
    /// The content of a file whose first bytes (512 are enough) are `head`.
    pub fn of(head: &[u8]) -> Self {
        let head = &head[..head.len().min(512)];
        let text = match std::str::from_utf8(head) {
            Ok(t) => Some(t),
            // A multi-byte character cut at the end of the head.
            Err(e) if e.error_len().is_none() => std::str::from_utf8(&head[..e.valid_up_to()]).ok(),
            Err(_) => None,
        };
        if head.is_empty() {
            Self::Empty
        } else if text.is_some_and(|t| t.chars().all(|c| !c.is_control() || c.is_whitespace())) {
            Self::Text
        } else {
            Self::Other
        }
    }
}

impl std::fmt::Display for Content {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Empty => "an empty file",
            Self::Text => "a text file",
            Self::Other => "its first bytes are not a safetensors header",
        })
    }
}

/// Reads and verifies a file written by [`write()`]: header, dtypes (F32 only),
/// offsets, checksums and finiteness of every tensor.
pub fn read(path: &Path) -> Result<TensorFile, PolicyError> {
    let buf = seespot_sim::bounds::read_file(path, seespot_sim::bounds::files::WEIGHTS)
        .map_err(|e| PolicyError::io(path, e))?;
    let format = |reason: String| PolicyError::Format {
        path: path.to_path_buf(),
        reason,
    };
    let tensor_err = |tensor: &str, reason: String| PolicyError::Tensor {
        path: path.to_path_buf(),
        tensor: tensor.to_string(),
        reason,
    };
    // A safetensors file opens with its header's length and the header, a
    // JSON object.
    if buf.get(8) != Some(&b'{') {
        return Err(format(format!(
            "not a safetensors model ({}); a seespot policy is a .safetensors file written by `seespot train`",
            Content::of(&buf)
        )));
    }
    let mut len8 = [0u8; 8];
    len8.copy_from_slice(&buf[..8]);
    let n = u64::from_le_bytes(len8) as usize;
    if n > buf.len() - 8 {
        return Err(format(format!(
            "damaged: header length {n} exceeds the file ({} bytes)",
            buf.len()
        )));
    }
    let header: BTreeMap<String, serde_json::Value> = serde_json::from_slice(&buf[8..8 + n])
        .map_err(|e| format(format!("damaged safetensors header: {e}")))?;
    let data = &buf[8 + n..];
    let mut metadata = BTreeMap::new();
    let mut checksums = BTreeMap::new();
    if let Some(m) = header.get("__metadata__").and_then(|m| m.as_object()) {
        for (k, v) in m {
            let v = v.as_str().unwrap_or_default().to_string();
            if let Some(t) = k.strip_prefix(CHECKSUM_PREFIX) {
                checksums.insert(t.to_string(), v);
            } else {
                metadata.insert(k.clone(), v);
            }
        }
    }
    let mut tensors = BTreeMap::new();
    // Each tensor's byte range, to refuse two tensors reading the same bytes.
    let mut ranges: Vec<(usize, usize, &str)> = Vec::new();
    for (name, info) in &header {
        if name == "__metadata__" {
            continue;
        }
        let dtype = info.get("dtype").and_then(|d| d.as_str()).unwrap_or("?");
        if dtype != "F32" {
            return Err(tensor_err(name, format!("dtype {dtype}, expected F32")));
        }
        // Every entry a whole number (a `-1` or `"x"` is not skipped over).
        let whole_numbers = |key: &str| -> Option<Vec<usize>> {
            info.get(key)?
                .as_array()?
                .iter()
                .map(|v| v.as_u64().and_then(|u| usize::try_from(u).ok()))
                .collect()
        };
        let shape = whole_numbers("shape")
            .ok_or_else(|| tensor_err(name, "no shape of whole numbers in the header".into()))?;
        let offs = whole_numbers("data_offsets").unwrap_or_default();
        let [a, b] = offs[..] else {
            return Err(tensor_err(name, "no data offsets in the header".into()));
        };
        // Checked: a shape like [2^62] would wrap to 0 bytes and pass.
        let size = shape
            .iter()
            .try_fold(4usize, |n, &d| n.checked_mul(d))
            .ok_or_else(|| tensor_err(name, format!("shape {shape:?} is too large")))?;
        if b < a || b - a != size {
            return Err(tensor_err(
                name,
                format!("data offsets {a}..{b} do not fit shape {shape:?}"),
            ));
        }
        if b > data.len() {
            return Err(tensor_err(
                name,
                format!(
                    "damaged: data truncated (needs bytes {a}..{b}, the file has {})",
                    data.len()
                ),
            ));
        }
        let bytes = &data[a..b];
        match checksums.get(name) {
            Some(c) if *c == format!("{:016x}", fnv1a(bytes)) => {}
            Some(_) => return Err(tensor_err(name, "damaged: checksum mismatch".into())),
            None => return Err(tensor_err(name, "no checksum in the metadata".into())),
        }
        let values: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if values.iter().any(|v| !v.is_finite()) {
            return Err(tensor_err(name, "damaged: non-finite values".into()));
        }
        if let Some((i, v)) = values
            .iter()
            .enumerate()
            .find(|(_, v)| v.abs() > MAX_WEIGHT)
        {
            return Err(tensor_err(
                name,
                format!(
                    "value {v:e} at index {i} is beyond ±{MAX_WEIGHT:e}, larger than any \
                     trained weight: the file is damaged or holds no network's weights"
                ),
            ));
        }
        if a < b {
            ranges.push((a, b, name));
        }
        tensors.insert(
            name.clone(),
            F32Tensor {
                shape,
                data: values,
            },
        );
    }
    // Sorted by start, any overlap shows between neighbours.
    ranges.sort();
    for pair in ranges.windows(2) {
        let [(a0, b0, first), (a1, b1, second)] = [pair[0], pair[1]];
        if a1 < b0 {
            return Err(tensor_err(
                second,
                format!(
                    "its bytes {a1}..{b1} overlap those of tensor `{first}` ({a0}..{b0}): \
                     each tensor must have bytes of its own"
                ),
            ));
        }
    }
    Ok(TensorFile { metadata, tensors })
}
