//! ONNX files that follow seespot's embedding contract ([`super`]):
//! a SPOT-Q policy's two trunks (`seespot export onnx`) and the raw
//! heightmap-patch control, which learns nothing.

use std::path::Path;

use prost::Message;
use tract_onnx::pb;
use tract_onnx::pb::tensor_shape_proto::{Dimension, dimension::Value as Dim};

use super::{GRASP, GRASP_Q, PLACE, PLACE_Q};
use crate::error::PolicyError;
use crate::input::{INPUT_CHANNELS, NET_RESOLUTION};
use crate::net::{KERNEL, param_shapes};
use crate::policy::PolicyNet;
use seespot_sim::Primitive;

/// The input's name and its named batch dimension.
pub const INPUT: &str = "scene";
pub const BATCH: &str = "rotations";
/// The operator set the files declare.
const OPSET: i64 = 17;
/// ONNX IR version 8 (operator sets up to 17).
const IR_VERSION: i64 = 8;

/// The raw-patch control's cell (input pixels averaged into one value per
/// channel) and neighbourhood (cells on a side): 16 mm cells, the trunk's
/// stride, and 5 x 5 of them (8 cm, about two block widths).
pub const PATCH_CELL: usize = 4;
pub const PATCH_SIDE: usize = 5;

/// A policy's trunks as one model: outputs `grasp` and `place`
/// (`[R, 64, 28, 28]`, the trunk's cells) and `grasp_q`, `place_q` (its 1x1
/// head on them), so the file is both an embedding model and a SPOT-Q policy.
pub fn policy_model(policy: &PolicyNet) -> Result<pb::ModelProto, PolicyError> {
    let mut g = Graph::default();
    let specs = policy.trunk().specs();
    let shapes = param_shapes();
    for p in Primitive::ALL {
        let prefix = p.as_str();
        let params = policy.net(p).to_vecs()?;
        let mut h = INPUT.to_string();
        for (k, spec) in specs.iter().enumerate() {
            let w = g.constant(
                &format!("{prefix}.{}.weight", spec.name),
                &shapes[2 * k].1,
                &params[2 * k],
            );
            let b = g.constant(
                &format!("{prefix}.{}.bias", spec.name),
                &shapes[2 * k + 1].1,
                &params[2 * k + 1],
            );
            let d = spec.dilation as i64;
            let conv = g.node(
                "Conv",
                &[&h, &w, &b],
                &format!("{prefix}.{}", spec.name),
                vec![
                    ints("kernel_shape", &[KERNEL as i64, KERNEL as i64]),
                    ints("strides", &[spec.stride as i64, spec.stride as i64]),
                    ints("dilations", &[d, d]),
                    ints("pads", &[d, d, d, d]),
                ],
            );
            let out = if k + 1 == specs.len() {
                prefix.to_string()
            } else {
                format!("{prefix}.{}.relu", spec.name)
            };
            h = g.node_named("Relu", &[&conv], &out, vec![]);
        }
        let n = params.len();
        let dim = params[n - 2].len();
        let w = g.constant(
            &format!("{prefix}.head.weight"),
            &[1, dim, 1, 1],
            &params[n - 2],
        );
        let b = g.constant(&format!("{prefix}.head.bias"), &[1], &params[n - 1]);
        let q = if p == Primitive::Grasp {
            GRASP_Q
        } else {
            PLACE_Q
        };
        g.node_named(
            "Conv",
            &[&h, &w, &b],
            q,
            vec![ints("kernel_shape", &[1, 1])],
        );
    }
    let cells = NET_RESOLUTION / crate::net::TRUNK_STRIDE;
    let dim = crate::EMBEDDING_DIM;
    let outputs = [(GRASP, dim), (PLACE, dim), (GRASP_Q, 1), (PLACE_Q, 1)];
    let doc = format!(
        "seespot's SPOT-Q policy for `{}` ({}), exported by `seespot export onnx`",
        policy.meta.task,
        policy.trunk().architecture()
    );
    Ok(g.model(&outputs, cells, &doc))
}

/// The raw heightmap-patch control: every `16 mm` cell's feature is the
/// `5 x 5` cells around it (8 cm) of the four input channels, each cell the
/// mean of the `5 x 5` input pixels around its centre: an average pool and a fixed one-hot
/// convolution, D = 4 x 25 = 100, one output shared by both primitives.
pub fn raw_patches_model() -> pb::ModelProto {
    let mut g = Graph::default();
    // Cell k is centred on input pixel 4k, as the contract places it: a
    // 5-pixel window (pixels 4k - 2 to 4k + 2) every 4 pixels, the border's
    // windows averaging the pixels inside the image.
    let k = PATCH_CELL as i64;
    let pooled = g.node(
        "AveragePool",
        &[INPUT],
        "cells",
        vec![
            ints("kernel_shape", &[k + 1, k + 1]),
            ints("strides", &[k, k]),
            ints("pads", &[k / 2, k / 2, k / 2, k / 2]),
        ],
    );
    let side = PATCH_SIDE;
    let dim = INPUT_CHANNELS * side * side;
    // Output channel (c, dy, dx) copies channel c at offset (dy, dx).
    let mut w = vec![0.0f32; dim * INPUT_CHANNELS * side * side];
    for c in 0..INPUT_CHANNELS {
        for t in 0..side * side {
            let o = c * side * side + t;
            w[(o * INPUT_CHANNELS + c) * side * side + t] = 1.0;
        }
    }
    let weight = g.constant("patch.weight", &[dim, INPUT_CHANNELS, side, side], &w);
    let half = (side / 2) as i64;
    g.node_named(
        "Conv",
        &[&pooled, &weight],
        "patches",
        vec![
            ints("kernel_shape", &[side as i64, side as i64]),
            ints("pads", &[half, half, half, half]),
        ],
    );
    let cells = NET_RESOLUTION / PATCH_CELL;
    let doc = "raw heightmap patches: the 5 x 5 neighbourhood of 16 mm cells of colour and depth \
               (no learning), made by `seespot export onnx --raw-patches`";
    g.model(&[("patches", dim)], cells, doc)
}

/// Writes `model` to `path`.
pub fn write(model: &pb::ModelProto, path: &Path) -> Result<(), PolicyError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| PolicyError::io(dir, e))?;
    }
    std::fs::write(path, model.encode_to_vec()).map_err(|e| PolicyError::io(path, e))
}

/// A graph under construction: nodes in order and their constants.
#[derive(Default)]
struct Graph {
    nodes: Vec<pb::NodeProto>,
    initializers: Vec<pb::TensorProto>,
}

impl Graph {
    /// A float32 constant; returns its name.
    fn constant(&mut self, name: &str, shape: &[usize], data: &[f32]) -> String {
        assert_eq!(shape.iter().product::<usize>(), data.len(), "{name}");
        self.initializers.push(pb::TensorProto {
            name: name.to_string(),
            dims: shape.iter().map(|&d| d as i64).collect(),
            data_type: pb::tensor_proto::DataType::Float as i32,
            raw_data: data.iter().flat_map(|v| v.to_le_bytes()).collect(),
            ..Default::default()
        });
        name.to_string()
    }

    /// A node whose output is named after it (`name.out`).
    fn node(
        &mut self,
        op: &str,
        inputs: &[&str],
        name: &str,
        attrs: Vec<pb::AttributeProto>,
    ) -> String {
        let out = format!("{name}.out");
        self.push(op, inputs, name, &out, attrs);
        out
    }

    /// A node whose output is `out` (a graph output's name, or a readable one).
    fn node_named(
        &mut self,
        op: &str,
        inputs: &[&str],
        out: &str,
        attrs: Vec<pb::AttributeProto>,
    ) -> String {
        self.push(op, inputs, out, out, attrs);
        out.to_string()
    }

    fn push(
        &mut self,
        op: &str,
        inputs: &[&str],
        name: &str,
        out: &str,
        attribute: Vec<pb::AttributeProto>,
    ) {
        self.nodes.push(pb::NodeProto {
            name: name.to_string(),
            op_type: op.to_string(),
            input: inputs.iter().map(|s| s.to_string()).collect(),
            output: vec![out.to_string()],
            attribute,
            ..Default::default()
        });
    }

    /// The model with the contract's input and `outputs` (`(name, depth)`,
    /// each `[R, depth, cells, cells]`).
    fn model(self, outputs: &[(&str, usize)], cells: usize, doc: &str) -> pb::ModelProto {
        let n = NET_RESOLUTION;
        let input = value(INPUT, &[None, Some(INPUT_CHANNELS), Some(n), Some(n)]);
        let outputs = outputs
            .iter()
            .map(|(name, d)| value(name, &[None, Some(*d), Some(cells), Some(cells)]))
            .collect();
        pb::ModelProto {
            ir_version: IR_VERSION,
            producer_name: "seespot".into(),
            producer_version: seespot_sim::VERSION.into(),
            doc_string: doc.into(),
            opset_import: vec![pb::OperatorSetIdProto {
                domain: String::new(),
                version: OPSET,
            }],
            graph: Some(pb::GraphProto {
                name: "seespot-embedding".into(),
                node: self.nodes,
                initializer: self.initializers,
                input: vec![input],
                output: outputs,
                ..Default::default()
            }),
            ..Default::default()
        }
    }
}

/// A float32 tensor value whose `None` dimensions are the named batch.
fn value(name: &str, dims: &[Option<usize>]) -> pb::ValueInfoProto {
    let dim = dims
        .iter()
        .map(|d| Dimension {
            value: Some(match d {
                Some(v) => Dim::DimValue(*v as i64),
                None => Dim::DimParam(BATCH.into()),
            }),
            ..Default::default()
        })
        .collect();
    pb::ValueInfoProto {
        name: name.into(),
        r#type: Some(pb::TypeProto {
            value: Some(pb::type_proto::Value::TensorType(pb::type_proto::Tensor {
                elem_type: pb::tensor_proto::DataType::Float as i32,
                shape: Some(pb::TensorShapeProto { dim }),
            })),
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn ints(name: &str, v: &[i64]) -> pb::AttributeProto {
    pb::AttributeProto {
        name: name.into(),
        r#type: pb::attribute_proto::AttributeType::Ints as i32,
        ints: v.to_vec(),
        ..Default::default()
    }
}
