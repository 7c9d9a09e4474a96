//! An ONNX file's 3 x 3 convolutions through seespot's own kernels, the ones
//! the native trunk runs, in place of the engine's: the stride-1 layers of 32
//! input channels (32 or 64 out) in Winograd form ([`crate::winograd`], 4
//! times fewer multiplies than a direct convolution, where most of a
//! convolutional network's time goes), and the stride-2 layers of the trunk's
//! shapes (4 in and 16 out, 16 in and 32 out) followed by a ReLU through its
//! blocked direct kernels ([`crate::infer`]). docs/embeddings.md, "The
//! engine", gives what it saves.
//!
//! [`use_native_kernels`] rewrites a typed model before the engine optimises
//! it: each `Conv` with constant weights and bias, a 3 x 3 kernel, one group,
//! the same dilation along both axes and the padding `dilation` on every side
//! (for stride 1, the size-keeping one), on square float maps, whose shape
//! one of the kernels covers, becomes a [`NativeConv`], the ReLU that alone
//! reads it (`max(x, 0)`) folded in. Every other convolution is left to the
//! engine. The outputs agree with the engine's convolution to float rounding
//! (the sums run in another order); the tests bound it.

use std::sync::Arc;

use tract_onnx::tract_core::internal::*;
use tract_onnx::tract_core::ops::binary::TypedBinOp;
use tract_onnx::tract_core::ops::cnn::{Conv, KernelFormat, PaddingSpec};
use tract_onnx::tract_core::ops::nn::DataFormat;

use crate::infer::Layer;
use crate::net::{ConvSpec, KERNEL};
use crate::winograd::Winograd;

/// The kernel a [`NativeConv`] runs.
#[derive(Clone, Debug)]
enum Kernel {
    /// Stride 1, in Winograd form, with or without the ReLU.
    Winograd(Arc<Winograd>),
    /// Stride 2, direct, with the ReLU.
    Strided(Arc<Layer>),
}

/// One convolution through seespot's kernels, channels last: input
/// `[N, H, W, C]`, output `[N, H', W', out]`.
#[derive(Clone, Debug)]
pub(super) struct NativeConv {
    kernel: Kernel,
    in_channels: usize,
}

impl PartialEq for NativeConv {
    fn eq(&self, other: &Self) -> bool {
        match (&self.kernel, &other.kernel) {
            (Kernel::Winograd(a), Kernel::Winograd(b)) => Arc::ptr_eq(a, b),
            (Kernel::Strided(a), Kernel::Strided(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

impl Eq for NativeConv {}

/// A convolution the kernels may cover: its layer, weights `[ky][kx][in][out]`
/// and bias, and whether its maps are channels first.
struct Candidate {
    spec: ConvSpec,
    weights: Vec<f32>,
    bias: Vec<f32>,
    nchw: bool,
}

impl Candidate {
    /// `conv` at `node` of `model`, where its form is one the kernels take
    /// (module docs), whatever its channels.
    fn of(model: &TypedModel, node: &TypedNode, conv: &Conv) -> TractResult<Option<Self>> {
        let spec = &conv.pool_spec;
        let format = spec.data_format;
        if conv.group != 1
            || conv.q_params.is_some()
            || node.inputs.len() != 3
            || !matches!(format, DataFormat::NCHW | DataFormat::NHWC)
            || spec.kernel_shape.as_slice() != [KERNEL, KERNEL]
        {
            return Ok(None);
        }
        let stride = match spec.strides.as_deref() {
            None => 1,
            Some([a, b]) if a == b => *a,
            Some(_) => return Ok(None),
        };
        let d = match spec.dilations.as_deref() {
            None => 1,
            Some([a, b]) if a == b => *a,
            Some(_) => return Ok(None),
        };
        // The padding `d` on every side (for stride 1, the one that keeps
        // the size).
        let padded = match &spec.padding {
            PaddingSpec::Explicit(b, a) => b.iter().chain(a.iter()).all(|&p| p == d),
            // Rounding the output size up changes it where the stride is 2.
            PaddingSpec::ExplicitOnnxPool(b, a, ceil) => {
                b.iter().chain(a.iter()).all(|&p| p == d) && (!ceil || stride == 1)
            }
            PaddingSpec::SameUpper | PaddingSpec::SameLower => stride == 1,
            PaddingSpec::Valid => false,
        };
        if !padded {
            return Ok(None);
        }
        let input = model.outlet_fact(node.inputs[0])?;
        let dims: Option<Vec<usize>> = input.shape.as_concrete().map(<[usize]>::to_vec);
        let Some(dims) = dims.filter(|d| d.len() == 4) else {
            return Ok(None);
        };
        let (h, w) = match format {
            DataFormat::NCHW => (dims[2], dims[3]),
            _ => (dims[1], dims[2]),
        };
        if input.datum_type != f32::datum_type() || h != w {
            return Ok(None);
        }
        let (Some(kernel), Some(bias)) = (
            model.outlet_fact(node.inputs[1])?.konst.clone(),
            model.outlet_fact(node.inputs[2])?.konst.clone(),
        ) else {
            return Ok(None);
        };
        let (ci, co) = (spec.input_channels, spec.output_channels);
        if kernel.datum_type() != f32::datum_type()
            || kernel.len() != KERNEL * KERNEL * ci * co
            || bias.datum_type() != f32::datum_type()
        {
            return Ok(None);
        }
        let k = kernel.try_as_plain_ram()?;
        let k = k.as_slice::<f32>()?;
        let at = |ky: usize, kx: usize, c: usize, o: usize| match conv.kernel_fmt {
            KernelFormat::OIHW => k[((o * ci + c) * KERNEL + ky) * KERNEL + kx],
            KernelFormat::HWIO => k[((ky * KERNEL + kx) * ci + c) * co + o],
            KernelFormat::OHWI => k[((o * KERNEL + ky) * KERNEL + kx) * ci + c],
        };
        let mut weights = Vec::with_capacity(k.len());
        for ky in 0..KERNEL {
            for kx in 0..KERNEL {
                for c in 0..ci {
                    for o in 0..co {
                        weights.push(at(ky, kx, c, o));
                    }
                }
            }
        }
        let b = bias.try_as_plain_ram()?;
        let b = b.as_slice::<f32>()?;
        let bias: Vec<f32> = match b.len() {
            1 => vec![b[0]; co],
            n if n == co => b.to_vec(),
            _ => return Ok(None),
        };
        Ok(Some(Self {
            spec: ConvSpec {
                name: "onnx",
                in_channels: ci,
                out_channels: co,
                stride,
                dilation: d,
            },
            weights,
            bias,
            nchw: format == DataFormat::NCHW,
        }))
    }

    /// The op that runs it, with the ReLU (`relu`) or without, or `None`
    /// where no kernel covers it.
    fn op(self, relu: bool) -> Option<NativeConv> {
        let kernel = if self.spec.stride == 1 {
            let w = Winograd::new(&self.spec, &self.weights, &self.bias)?;
            Kernel::Winograd(Arc::new(if relu { w } else { w.without_relu() }))
        } else if relu {
            Kernel::Strided(Arc::new(Layer::strided(
                self.spec,
                self.weights,
                self.bias,
            )?))
        } else {
            return None;
        };
        Some(NativeConv {
            kernel,
            in_channels: self.spec.in_channels,
        })
    }
}

impl NativeConv {
    fn out_channels(&self) -> usize {
        match &self.kernel {
            Kernel::Winograd(w) => w.out_channels(),
            Kernel::Strided(l) => l.out_channels(),
        }
    }

    fn out_side(&self, n: usize) -> usize {
        match &self.kernel {
            Kernel::Winograd(_) => n,
            Kernel::Strided(l) => l.out_side(n),
        }
    }
}

impl Op for NativeConv {
    fn name(&self) -> StaticName {
        "SeespotConv".into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        let how = match &self.kernel {
            Kernel::Winograd(_) => "Winograd",
            Kernel::Strided(_) => "direct, stride 2, ReLU",
        };
        Ok(vec![format!(
            "{} -> {} channels, channels last, {how}",
            self.in_channels,
            self.out_channels(),
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for NativeConv {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let shape = input.shape().to_vec();
        ensure!(shape.len() == 4, "SeespotConv takes 4-d maps");
        let (batch, n, co) = (shape[0], shape[1], self.out_channels());
        let x = input.try_as_plain_ram()?;
        let x = x.as_slice::<f32>()?;
        ensure!(
            shape[2] == n && x.len() == batch * n * n * self.in_channels,
            "SeespotConv takes square maps of {} channels",
            self.in_channels
        );
        let m = self.out_side(n);
        let out = match &self.kernel {
            Kernel::Winograd(w) => {
                let mut out = vec![0.0f32; batch * m * m * co];
                w.forward_into(x, batch, n, &mut out);
                out
            }
            Kernel::Strided(l) => {
                let mut out = Vec::new();
                l.forward_into(x, batch, n, &mut out);
                out
            }
        };
        let out = tract_ndarray::Array4::from_shape_vec((batch, m, m, co), out)?;
        Ok(tvec![out.into_tensor().into_tvalue()])
    }
}

impl TypedOp for NativeConv {
    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let shape = &inputs[0].shape;
        let n = shape[1].to_usize()?;
        let m = self.out_side(n);
        Ok(tvec![f32::fact([
            shape[0].clone(),
            m.to_dim(),
            m.to_dim(),
            self.out_channels().to_dim()
        ])])
    }

    as_op!();
}

/// Replaces every convolution of `model` seespot's kernels cover (module
/// docs) with a [`NativeConv`], the ReLU that alone reads it folded in;
/// returns how many.
pub(super) fn use_native_kernels(model: &mut TypedModel) -> TractResult<usize> {
    let mut found = Vec::new();
    for id in model.eval_order()? {
        let node = &model.nodes[id];
        if let Some(conv) = node.op_as::<Conv>()
            && let Some(candidate) = Candidate::of(model, node, conv)?
        {
            let relu = relu_of(model, id)?;
            let nchw = candidate.nchw;
            if let Some(op) = candidate.op(relu.is_some()) {
                found.push((id, op, nchw, relu));
            }
        }
    }
    let count = found.len();
    for (id, op, nchw, relu) in found {
        let node = &model.nodes[id];
        // Channels-first maps are moved to the kernels' channels last and
        // back; the engine cancels the moves between two such layers.
        let mut patch = TypedModelPatch::default();
        let mut wire = patch.tap_model(model, node.inputs[0])?;
        if nchw {
            wire = patch.wire_node(
                format!("{}.to_nhwc", node.name),
                AxisOp::Move(1, 3),
                &[wire],
            )?[0];
        }
        wire = patch.wire_node(&node.name, op, &[wire])?[0];
        if nchw {
            wire = patch.wire_node(
                format!("{}.to_nchw", node.name),
                AxisOp::Move(3, 1),
                &[wire],
            )?[0];
        }
        patch.shunt_outside(model, OutletId::new(relu.unwrap_or(id), 0), wire)?;
        patch.apply(model)?;
    }
    Ok(count)
}

/// The node that alone reads node `id`'s output, if it is a ReLU: `max` of
/// it and a constant zero.
fn relu_of(model: &TypedModel, id: usize) -> TractResult<Option<usize>> {
    if model.output_outlets()?.contains(&OutletId::new(id, 0)) {
        return Ok(None);
    }
    let Some(succ) = model.single_succ(id)? else {
        return Ok(None);
    };
    let Some(bin) = succ.op_as::<TypedBinOp>() else {
        return Ok(None);
    };
    if bin.0.name() != "Max" || succ.inputs.len() != 2 {
        return Ok(None);
    }
    let other = succ.inputs.iter().find(|o| o.node != id);
    let zero = match other {
        Some(o) => model.outlet_fact(*o)?.konst.clone(),
        None => None,
    };
    Ok(match zero {
        Some(z) if z.len() == 1 && z.datum_type() == f32::datum_type() && z.is_all_zero()? => {
            Some(succ.id)
        }
        _ => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PolicyNet;
    use tract_onnx::prelude::{Framework, InferenceModelExt};

    /// The shipped stack policy's trunks exported, typed at one rotation.
    fn exported_trunks() -> TypedModel {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/stack.safetensors");
        let proto = crate::onnx::export::policy_model(&PolicyNet::load(&path).expect("test setup"))
            .expect("test setup");
        tract_onnx::onnx()
            .model_for_proto_model(&proto)
            .and_then(|m| m.with_input_fact(0, f32::fact([1, 4, 112, 112]).into()))
            .and_then(|m| m.into_typed())
            .and_then(|m| m.into_decluttered())
            .expect("test setup")
    }

    fn count(model: &TypedModel, f: impl Fn(&TypedNode) -> bool) -> usize {
        model.nodes.iter().filter(|n| f(n)).count()
    }

    fn is_max(n: &TypedNode) -> bool {
        n.op_as::<TypedBinOp>().is_some_and(|b| b.0.name() == "Max")
    }

    #[test]
    fn the_trunks_layers_run_through_seespots_kernels_with_their_relu() {
        let plain = exported_trunks();
        let mut fast = plain.clone();
        // All five layers of both primitives' trunks: conv1 and conv2
        // (stride 2) direct, conv3, conv4 (dilated 2) and conv5 (dilated 8)
        // in Winograd form.
        assert_eq!(use_native_kernels(&mut fast).expect("test setup"), 10);
        // Their ReLUs are folded in: 10 in the plain model, none left.
        fast.compact().expect("test setup");
        assert_eq!(count(&plain, is_max), 10);
        assert_eq!(count(&fast, is_max), 0);
        let fast = fast.into_optimized().expect("test setup");
        assert_eq!(count(&fast, |n| n.op_is::<NativeConv>()), 10);
        assert_eq!(count(&fast, |n| n.op_is::<Conv>()), 0);
        let input: Vec<f32> = (0..4 * 112 * 112)
            .map(|i| 0.5 * (0.001 * i as f32).sin())
            .collect();
        let input = Tensor::from_shape(&[1, 4, 112, 112], &input).expect("test setup");
        let run = |m: TypedModel| {
            m.into_runnable()
                .expect("test setup")
                .run(tvec![input.clone().into_tvalue()])
                .expect("test setup")
        };
        let (a, b) = (run(plain), run(fast));
        assert_eq!(a.len(), b.len());
        for (a, b) in a.iter().zip(&b) {
            assert_eq!(a.shape(), b.shape());
            let (a, b) = (
                a.try_as_plain_ram().expect("test setup"),
                b.try_as_plain_ram().expect("test setup"),
            );
            let (a, b) = (
                a.as_slice::<f32>().expect("test setup"),
                b.as_slice::<f32>().expect("test setup"),
            );
            let scale = a.iter().fold(0f32, |m, v| m.max(v.abs()));
            let worst = a.iter().zip(b).fold(0f32, |m, (x, y)| m.max((x - y).abs()));
            // Winograd's sums run in another order than the direct kernel's.
            assert!(worst <= 1e-4 * scale.max(1.0), "{worst} of {scale}");
            assert!(scale > 0.0);
        }
    }
}
