//! The contract's checks on an ONNX file (module docs of [`super`]): each
//! returns what is wrong in words, and [`super::OnnxEmbedder`] puts the file
//! in front.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use prost::Message;
use tract_onnx::pb;
use tract_onnx::pb::tensor_shape_proto::dimension::Value as Dim;
use tract_onnx::prelude::*;

use super::external;
use super::{GRASP, GRASP_Q, MAX_DIM, PLACE, PLACE_Q, Plan};
use crate::input::{INPUT_CHANNELS, NET_RESOLUTION};

/// ONNX's element type number of `float32`.
const FLOAT: i32 = pb::tensor_proto::DataType::Float as i32;

/// A file that passed the checks that need no engine.
pub(super) struct Checked {
    proto: pb::ModelProto,
    /// The engine's ONNX reader (its operator register is built once).
    engine: tract_onnx::Onnx,
    /// Whether the input's batch is a named dimension (else it is 16).
    pub batch_named: bool,
    /// The outputs' names, in the file's order.
    pub outputs: Vec<String>,
    /// The external data files read into the model (docs of [`external`]).
    pub data_files: Vec<PathBuf>,
    /// Every node's name and operator, to name a node the engine refuses.
    nodes: Vec<(String, String)>,
}

/// Decodes `bytes` and checks the graph's input and outputs as declared, and
/// that every operator is one the engine has.
pub(super) fn check(bytes: &[u8], folder: &Path) -> Result<Checked, String> {
    let mut proto = pb::ModelProto::decode(bytes)
        .map_err(|e| format!("not an ONNX model (the protobuf does not decode: {e})"))?;
    if proto
        .graph
        .as_ref()
        .is_some_and(|g| g.initializer.iter().any(external::is_external))
    {
        // Bounded before the data are read: the tensors' own checks follow.
        let graph = proto
            .graph
            .as_ref()
            .ok_or("not an ONNX model: it holds no graph")?;
        for t in graph
            .initializer
            .iter()
            .filter(|t| external::is_external(t))
        {
            check_dims(t, &format!("initializer `{}`", t.name))?;
        }
    }
    let data_files = external::inline(&mut proto, folder)?;
    let graph = proto
        .graph
        .as_ref()
        .ok_or("not an ONNX model: it holds no graph")?;
    if graph.node.is_empty() {
        return Err("not an ONNX model: its graph has no nodes".into());
    }
    for t in &graph.initializer {
        check_tensor(t, &format!("initializer `{}`", t.name))?;
    }
    for n in &graph.node {
        for a in &n.attribute {
            if let Some(t) = &a.t {
                check_tensor(t, &format!("node `{}` attribute `{}`", n.name, a.name))?;
            }
        }
    }
    for n in &graph.node {
        check_window(n)?;
    }
    let engine = tract_onnx::onnx();
    let register = &engine.op_register;
    for n in &graph.node {
        let standard = n.domain.is_empty() || n.domain == "ai.onnx";
        if !standard || !register.0.contains_key(&n.op_type) {
            let op = if standard {
                n.op_type.clone()
            } else {
                format!("{}.{}", n.domain, n.op_type)
            };
            return Err(format!(
                "node `{}` ({op}): the ONNX engine (tract) does not run operator `{op}`; replace that layer, or try another `opset_version` in `torch.onnx.export`, which may write it as operators the engine runs",
                n.name,
            ));
        }
    }
    let initialised: std::collections::HashSet<&str> =
        graph.initializer.iter().map(|t| t.name.as_str()).collect();
    let inputs: Vec<&pb::ValueInfoProto> = graph
        .input
        .iter()
        .filter(|i| !initialised.contains(i.name.as_str()))
        .collect();
    let [input] = inputs.as_slice() else {
        return Err(format!(
            "the graph has {} inputs ({}); an embedding model has one, the rotated scene [R, 4, 112, 112] (export a forward that takes the scene alone)",
            inputs.len(),
            names(inputs.iter().map(|i| i.name.as_str()))
        ));
    };
    let dims = tensor_dims(input, "input")?;
    let want = [
        None,
        Some(INPUT_CHANNELS),
        Some(NET_RESOLUTION),
        Some(NET_RESOLUTION),
    ];
    if dims.len() != 4 {
        return Err(format!(
            "input `{}` has rank {}; the contract's input is [R, 4, 112, 112]",
            input.name,
            dims.len()
        ));
    }
    let mut batch_named = false;
    for (k, (d, w)) in dims.iter().zip(want).enumerate() {
        match (d, w) {
            (DimOf::Named(_), None) => batch_named = true,
            (DimOf::Value(v), None) if *v == seespot_sim::NUM_ROTATIONS as i64 => {}
            (DimOf::Value(v), None) => {
                return Err(format!(
                    "input `{}` dimension 0 is {v}; the batch of rotations is 16 or a named dimension (export with an example of 16 rotations, `torch.zeros(16, 4, 112, 112)`, or name the batch: `dynamic_shapes=({{0: torch.export.Dim(\"rotations\")}},)`)",
                    input.name
                ));
            }
            (DimOf::Named(s), Some(w)) => {
                return Err(format!(
                    "input `{}` dimension {k} is the unresolved dynamic dimension `{s}`; it must be {w} (name only dimension 0 dynamic in the export call)",
                    input.name
                ));
            }
            (DimOf::Value(v), Some(w)) if *v != w as i64 => {
                return Err(format!(
                    "input `{}` dimension {k} is {v}; the contract's input is [R, 4, 112, 112]",
                    input.name
                ));
            }
            _ => {}
        }
    }
    let mut outputs = Vec::new();
    for o in &graph.output {
        // An output's declared type, when it declares one, must be float32.
        if let Some(pb::type_proto::Value::TensorType(t)) =
            o.r#type.as_ref().and_then(|t| t.value.as_ref())
            && t.elem_type != FLOAT
        {
            return Err(format!(
                "output `{}` has element type {}; features are float32",
                o.name,
                type_name(t.elem_type)
            ));
        }
        outputs.push(o.name.clone());
    }
    let nodes = graph
        .node
        .iter()
        .map(|n| (n.name.clone(), n.op_type.clone()))
        .collect();
    forget_shapes(&mut proto);
    Ok(Checked {
        proto,
        engine,
        batch_named,
        outputs,
        data_files,
        nodes,
    })
}

/// The most elements one tensor of a model may hold (2^25, 128 MiB of
/// float32), constants and every intermediate map at 16 rotations alike.
pub(super) const MAX_ELEMENTS: u64 = 1 << 25;

/// A tensor's element count, refused when a dimension is negative or the
/// count is above [`MAX_ELEMENTS`].
fn check_dims(t: &pb::TensorProto, what: &str) -> Result<u64, String> {
    let mut n: u64 = 1;
    for &d in &t.dims {
        let d = u64::try_from(d).map_err(|_| format!("{what} has the negative dimension {d}"))?;
        n = n.saturating_mul(d);
    }
    if n > MAX_ELEMENTS {
        return Err(format!(
            "{what} holds {n} elements; seespot loads at most {MAX_ELEMENTS} in one tensor"
        ));
    }
    Ok(n)
}

/// Drops the shapes a file states for intermediate values and outputs, so
/// that the engine derives every shape from the input. An exporter may
/// write the shapes of its example (PyTorch's `dynamo=True` exporter writes
/// batch 16 inside a graph whose input batch is named): trusted, they
/// contradict the batch seespot runs. Element types stay.
fn forget_shapes(proto: &mut pb::ModelProto) {
    let Some(graph) = proto.graph.as_mut() else {
        return;
    };
    graph.value_info.clear();
    for o in &mut graph.output {
        if let Some(pb::type_proto::Value::TensorType(t)) =
            o.r#type.as_mut().and_then(|t| t.value.as_mut())
        {
            t.shape = None;
        }
    }
}

/// A constant tensor's dimensions are sane and its data is as long as they
/// say (checked before the engine reads it).
fn check_tensor(t: &pb::TensorProto, what: &str) -> Result<(), String> {
    let n = check_dims(t, what)?;
    use pb::tensor_proto::DataType as T;
    let width: Option<u64> = match T::try_from(t.data_type) {
        Ok(T::Float | T::Int32 | T::Uint32) => Some(4),
        Ok(T::Double | T::Int64 | T::Uint64) => Some(8),
        Ok(T::Float16 | T::Bfloat16 | T::Int16 | T::Uint16) => Some(2),
        Ok(T::Int8 | T::Uint8 | T::Bool) => Some(1),
        _ => None,
    };
    let typed = (t.float_data.len()
        + t.int32_data.len()
        + t.int64_data.len()
        + t.double_data.len()
        + t.uint64_data.len()
        + t.string_data.len()) as u64;
    let ok = match (t.raw_data.is_empty(), width) {
        (false, Some(w)) => t.raw_data.len() as u64 == n.saturating_mul(w),
        (false, None) => true,
        (true, _) => typed == n || (typed == 0 && n == 0),
    };
    if !ok {
        return Err(format!(
            "{what}: its data does not hold the {n} elements its dimensions {:?} declare",
            t.dims
        ));
    }
    Ok(())
}

/// A convolution's or pool's window fits the input: kernel, stride and
/// dilation 1 to 112, pads 0 to 112 (larger values describe no network for
/// a 112-pixel input, and make the engine's planning run for ever).
fn check_window(n: &pb::NodeProto) -> Result<(), String> {
    const WINDOWED: [&str; 5] = ["Conv", "ConvTranspose", "AveragePool", "MaxPool", "LpPool"];
    if !WINDOWED.contains(&n.op_type.as_str()) {
        return Ok(());
    }
    let side = NET_RESOLUTION as i64;
    for a in &n.attribute {
        let range = match a.name.as_str() {
            "kernel_shape" | "strides" | "dilations" => 1..=side,
            "pads" | "output_padding" => 0..=side,
            _ => continue,
        };
        if let Some(v) = a.ints.iter().find(|v| !range.contains(v)) {
            return Err(format!(
                "node `{}` ({}) has {} {v}; seespot takes {} to {} for a 112-pixel input",
                n.name,
                n.op_type,
                a.name,
                range.start(),
                range.end()
            ));
        }
    }
    Ok(())
}

/// Every tensor `plan` computes has a known shape of at most
/// [`MAX_ELEMENTS`] elements.
pub(super) fn check_sizes(plan: &Plan) -> Result<(), String> {
    let model = plan.model();
    for node in model.nodes() {
        for (i, o) in node.outputs.iter().enumerate() {
            let Some(shape) = o.fact.shape.as_concrete() else {
                return Err(format!(
                    "node `{}` output {i} has the unresolved dynamic shape {:?}",
                    node.name, o.fact.shape
                ));
            };
            let n = shape.iter().fold(1u64, |a, &d| a.saturating_mul(d as u64));
            if n > MAX_ELEMENTS {
                return Err(format!(
                    "node `{}` computes {shape:?} ({n} elements) at 16 rotations; seespot allows at most {MAX_ELEMENTS} in one tensor",
                    node.name
                ));
            }
        }
    }
    Ok(())
}

/// One declared dimension.
enum DimOf {
    Value(i64),
    Named(String),
}

/// The declared dimensions of a float32 tensor value (`what` names it).
fn tensor_dims(v: &pb::ValueInfoProto, what: &str) -> Result<Vec<DimOf>, String> {
    let Some(pb::type_proto::Value::TensorType(t)) =
        v.r#type.as_ref().and_then(|t| t.value.as_ref())
    else {
        return Err(format!("{what} `{}` is not a tensor", v.name));
    };
    if t.elem_type != FLOAT {
        return Err(format!(
            "{what} `{}` has element type {}; seespot feeds float32",
            v.name,
            type_name(t.elem_type)
        ));
    }
    let shape = t.shape.as_ref().ok_or_else(|| {
        format!(
            "{what} `{}` declares no shape; it must be [R, 4, 112, 112]",
            v.name
        )
    })?;
    Ok(shape
        .dim
        .iter()
        .map(|d| match &d.value {
            Some(Dim::DimValue(v)) => DimOf::Value(*v),
            Some(Dim::DimParam(s)) => DimOf::Named(s.clone()),
            None => DimOf::Named("?".into()),
        })
        .collect())
}

fn type_name(elem_type: i32) -> String {
    pb::tensor_proto::DataType::try_from(elem_type)
        .map(|t| t.as_str_name().to_lowercase())
        .unwrap_or_else(|_| format!("#{elem_type}"))
}

fn names<'a>(it: impl Iterator<Item = &'a str>) -> String {
    let v: Vec<String> = it.map(|s| format!("`{s}`")).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// The engine's plan of the checked model at `batch` rotations: all its
/// outputs, or output `only` alone (the engine then leaves out what only the
/// others need, e.g. the other primitive's network).
pub(super) fn plan(checked: &Checked, batch: usize, only: Option<usize>) -> Result<Plan, String> {
    let fact = f32::fact([batch, INPUT_CHANNELS, NET_RESOLUTION, NET_RESOLUTION]);
    let plan = checked
        .engine
        .model_for_proto_model(&checked.proto)
        .and_then(|m| match only {
            None => Ok(m),
            Some(i) => {
                let outlet = m.output_outlets()?[i];
                m.with_output_outlets(&[outlet])
            }
        })
        .and_then(|m| m.with_input_fact(0, fact.into()))
        .and_then(|m| m.into_typed())
        .and_then(|m| m.into_decluttered())
        .and_then(|mut m| {
            super::native_conv::use_native_kernels(&mut m)?;
            m.into_optimized()
        })
        .and_then(|m| m.into_runnable())
        .map_err(|e| engine_refusal(checked, batch, &format!("{e:#}")))?;
    Ok(Arc::clone(&plan))
}

/// The engine's refusal of `checked` at `batch` rotations in a user's words:
/// the node it stopped at (its name and operator), the fault, what to change
/// in the export call where that is the fix, and last the engine's own text.
pub(super) fn engine_refusal(checked: &Checked, batch: usize, engine: &str) -> String {
    // The engine names a node as `#7 "node_Conv_89"`: the earliest name of
    // the file's nodes quoted in its text.
    let node = checked
        .nodes
        .iter()
        .filter(|(name, _)| !name.is_empty())
        .filter_map(|(name, op)| engine.find(&format!("\"{name}\"")).map(|at| (at, name, op)))
        .min_by_key(|(at, _, _)| *at);
    let (fault, hint) = fault_of(engine);
    let at = match node {
        Some((_, name, op)) => format!("node `{name}` ({op})"),
        None => "the model".to_owned(),
    };
    let rotations = if batch == 1 { "rotation" } else { "rotations" };
    format!(
        "{at} cannot be run on a batch of {batch} {rotations}: {fault}.{hint} (The ONNX engine, tract, said: {engine})"
    )
}

/// The fault the engine's text describes, and the change to the export call
/// that fixes it, if one does.
fn fault_of(engine: &str) -> (&'static str, &'static str) {
    // A shape the file fixed to the example's batch meets another batch:
    // two shapes that do not unify, or a reshape whose sizes disagree.
    if engine.contains("unify") || engine.contains("volume mismatch") {
        (
            "its shapes fix the batch to a number where seespot runs another",
            " Export the batch as a named dimension and compute nothing from the example's batch: \
             `dynamic_axes={\"scene\": {0: \"rotations\"}}` with `dynamo=False`, or \
             `dynamic_shapes=({0: torch.export.Dim(\"rotations\")},)` with the default exporter; \
             a reshape to the example's numbers (`x.view(16, -1)`) fixes the batch where `x.flatten(1)` does not.",
        )
    } else if engine.contains("not implemented")
        || engine.contains("Unimplemented")
        || engine.contains("unimplemented")
        || engine.contains("not supported")
        || engine.contains("Unsupported")
    {
        (
            "it uses a form of its operator that the engine does not run",
            " Try another `opset_version` in `torch.onnx.export` (seespot reads opsets 9 to 21).",
        )
    } else {
        ("the engine could not work out what it computes", "")
    }
}

/// Each output's concrete shape in `plan` (run at `batch` rotations).
pub(super) fn output_shapes(plan: &Plan, batch: usize) -> Result<Vec<Vec<usize>>, String> {
    let model = plan.model();
    let mut out = Vec::new();
    for (i, o) in model
        .output_outlets()
        .map_err(|e| e.to_string())?
        .iter()
        .enumerate()
    {
        let fact = model.outlet_fact(*o).map_err(|e| e.to_string())?;
        if fact.datum_type != f32::datum_type() {
            return Err(format!(
                "output {i} has element type {:?}; features are float32",
                fact.datum_type
            ));
        }
        let shape = fact.shape.as_concrete().ok_or_else(|| {
            format!(
                "output {i} has the unresolved dynamic shape {:?} at batch {batch}",
                fact.shape
            )
        })?;
        out.push(shape.to_vec());
    }
    Ok(out)
}

/// Which output holds each primitive's features and Q map.
pub(super) fn roles(outputs: &[String]) -> Result<([usize; 2], Option<[usize; 2]>), String> {
    let find = |name: &str| outputs.iter().position(|o| o == name);
    let q = match (find(GRASP_Q), find(PLACE_Q)) {
        (Some(g), Some(p)) => Some([g, p]),
        (None, None) => None,
        _ => {
            return Err(format!(
                "outputs {}: Q maps come as a pair, `{GRASP_Q}` and `{PLACE_Q}`",
                names(outputs.iter().map(String::as_str))
            ));
        }
    };
    let features = match (find(GRASP), find(PLACE)) {
        (Some(g), Some(p)) => [g, p],
        _ => {
            let shared: Vec<usize> = (0..outputs.len())
                .filter(|i| !q.is_some_and(|q| q.contains(i)))
                .collect();
            match shared.as_slice() {
                [one] => [*one, *one],
                _ => {
                    return Err(format!(
                        "outputs {}: the features are two outputs named `{GRASP}` and `{PLACE}` (`output_names=[\"{GRASP}\", \"{PLACE}\"]`), or one output shared by both primitives",
                        names(outputs.iter().map(String::as_str))
                    ));
                }
            }
        }
    };
    Ok((features, q))
}

/// D and S of the feature outputs, checked against the contract.
pub(super) fn feature_shape(
    outputs: &[String],
    shapes: &[Vec<usize>],
    features: [usize; 2],
    q: Option<[usize; 2]>,
    batch: usize,
) -> Result<(usize, usize), String> {
    let check = |i: usize, depth: Option<usize>| -> Result<(usize, usize), String> {
        let s = &shapes[i];
        let name = &outputs[i];
        let bad = |why: &str| {
            Err(format!(
                "output `{name}` has shape {s:?}; {why} (the contract: [R, D, S, S] with S dividing 112)"
            ))
        };
        if s.len() != 4 {
            return bad("its rank is not 4");
        }
        if s[0] != batch {
            return bad("its first dimension is not the input's batch of rotations");
        }
        if s[2] != s[3] || s[2] == 0 || !NET_RESOLUTION.is_multiple_of(s[2]) {
            return bad("its maps are not square with a side dividing 112");
        }
        if s[1] == 0 || s[1] > MAX_DIM {
            return bad(&format!("its depth is not 1 to {MAX_DIM}"));
        }
        if let Some(d) = depth
            && s[1] != d
        {
            return bad(&format!("a Q map has depth {d}"));
        }
        Ok((s[1], s[2]))
    };
    let grasp = check(features[0], None)?;
    let place = check(features[1], None)?;
    if grasp != place {
        return Err(format!(
            "outputs `{GRASP}` {:?} and `{PLACE}` {:?} differ in depth or side; both primitives' features must have one shape",
            shapes[features[0]], shapes[features[1]]
        ));
    }
    if let Some(q) = q {
        for i in q {
            let (_, side) = check(i, Some(1))?;
            if side != grasp.1 {
                return Err(format!(
                    "output `{}` is {side} x {side} but the features are {} x {}",
                    outputs[i], grasp.1, grasp.1
                ));
            }
        }
    }
    Ok(grasp)
}
