//! The per-primitive Q-network: a small strided fully convolutional trunk
//! (the embedding function E_m, docs/design.md §3) and a final 1x1 linear layer `w_m`.
//!
//! Trunk, on the 4 x 112 x 112 network input (4 mm/px):
//!
//! | layer | kernel | stride | dilation | channels | output |
//! |---|---|---|---|---|---|
//! | conv1 | 3x3 | 2 | 1 | 4 -> 16 | 56 x 56 (8 mm) |
//! | conv2 | 3x3 | 2 | 1 | 16 -> 32 | 28 x 28 (16 mm) |
//! | conv3 | 3x3 | 1 | 1 | 32 -> 32 | 28 x 28 |
//! | conv4 | 3x3 | 1 | 2 | 32 -> 32 | 28 x 28 |
//! | conv5 | 3x3 | 1 | 1, or N in a [`Trunk`] dilated N | 32 -> 64 | 28 x 28 |
//!
//! (32 channels in the 28 x 28 layers keep the forward of 2 primitives x 16
//! rotations near 150 ms on 2 cores; 64 there measured about 2x slower.)
//! Every conv is followed by a ReLU; there is no normalisation. The receptive
//! field is 39 network pixels (15.6 cm); conv5 dilated 8 (the shipped `models/`)
//! makes it 95 (38 cm, [`Trunk::receptive_field`]). With padding `dilation` every output
//! cell `k` is centred on input pixel `4k` ([`TRUNK_STRIDE`]).

use candle_core::{DType, Device, Tensor, Var};
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::embedding::EMBEDDING_DIM;
use crate::input::{INPUT_CHANNELS, NET_RESOLUTION};
use seespot_sim::workspace::WORKSPACE_SIZE;

/// Total stride of the trunk: feature cell `k` is centred on input pixel `4k`.
pub const TRUNK_STRIDE: usize = 4;
/// Side of the trunk's output map, cells.
pub const FEATURE_RESOLUTION: usize = NET_RESOLUTION / TRUNK_STRIDE;

/// One convolution of the trunk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConvSpec {
    pub name: &'static str,
    pub in_channels: usize,
    pub out_channels: usize,
    pub stride: usize,
    pub dilation: usize,
}

/// Which trunk a Q-network has: the five convolutions above, conv5 dilated
/// by `conv5_dilation` (8 in the shipped policies, 1 in the earlier sets,
/// such as `models/oracle-guided/`). A policy file names it in its `architecture`
/// field ([`Trunk::architecture`]); the wider the dilation, the more of the
/// scene one Q-value sees ([`Trunk::receptive_field`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Trunk {
    pub conv5_dilation: usize,
}

impl Default for Trunk {
    fn default() -> Self {
        Self::STANDARD
    }
}

/// The `architecture` name of the standard trunk; a dilated one adds `-d<N>`.
const ARCHITECTURE_BASE: &str = "spotq-fcn-s4-c64";

impl Trunk {
    /// conv5 undilated: a Q-value sees 39 network pixels (15.6 cm).
    pub const STANDARD: Self = Self { conv5_dilation: 1 };
    /// The largest conv5 dilation accepted (its receptive field spans the
    /// 28-cell feature map's width once).
    pub const MAX_DILATION: usize = 12;

    /// A trunk with conv5 dilated `d`, or why not.
    pub fn with_conv5_dilation(d: usize) -> Result<Self, String> {
        if (1..=Self::MAX_DILATION).contains(&d) {
            Ok(Self { conv5_dilation: d })
        } else {
            Err(format!(
                "conv5 dilation {d}: expected 1 to {}",
                Self::MAX_DILATION
            ))
        }
    }

    /// The `architecture` metadata value of a policy file with this trunk:
    /// `spotq-fcn-s4-c64`, or `spotq-fcn-s4-c64-d<N>` with conv5 dilated N.
    pub fn architecture(&self) -> String {
        match self.conv5_dilation {
            1 => ARCHITECTURE_BASE.to_string(),
            d => format!("{ARCHITECTURE_BASE}-d{d}"),
        }
    }

    /// The trunk an `architecture` value names, if it names one.
    pub fn from_architecture(name: &str) -> Option<Self> {
        let rest = name.strip_prefix(ARCHITECTURE_BASE)?;
        if rest.is_empty() {
            return Some(Self::STANDARD);
        }
        let d: usize = rest.strip_prefix("-d")?.parse().ok()?;
        (d != 1).then_some(())?;
        Self::with_conv5_dilation(d).ok()
    }

    /// The five convolutions, in order.
    pub const fn specs(&self) -> [ConvSpec; 5] {
        let mut t = TRUNK;
        t[4].dilation = self.conv5_dilation;
        t
    }

    /// Receptive field of one feature cell, network pixels (4 mm each).
    pub fn receptive_field(&self) -> usize {
        let (mut rf, mut jump) = (1, 1);
        for s in self.specs() {
            rf += (KERNEL - 1) * s.dilation * jump;
            jump *= s.stride;
        }
        rf
    }

    /// [`Self::receptive_field`] in metres of the workspace.
    pub fn receptive_field_m(&self) -> f32 {
        self.receptive_field() as f32 * WORKSPACE_SIZE / NET_RESOLUTION as f32
    }
}

/// The standard trunk, in order ([`Trunk::specs`] dilates its conv5).
pub const TRUNK: [ConvSpec; 5] = [
    ConvSpec {
        name: "conv1",
        in_channels: INPUT_CHANNELS,
        out_channels: 16,
        stride: 2,
        dilation: 1,
    },
    ConvSpec {
        name: "conv2",
        in_channels: 16,
        out_channels: 32,
        stride: 2,
        dilation: 1,
    },
    ConvSpec {
        name: "conv3",
        in_channels: 32,
        out_channels: 32,
        stride: 1,
        dilation: 1,
    },
    ConvSpec {
        name: "conv4",
        in_channels: 32,
        out_channels: 32,
        stride: 1,
        dilation: 2,
    },
    ConvSpec {
        name: "conv5",
        in_channels: 32,
        out_channels: EMBEDDING_DIM,
        stride: 1,
        dilation: 1,
    },
];

/// Kernel side of every trunk conv.
pub const KERNEL: usize = 3;

/// A named parameter: its tensor name inside a primitive's net and its shape.
pub fn param_shapes() -> Vec<(String, Vec<usize>)> {
    let mut v = Vec::new();
    for c in TRUNK {
        v.push((
            format!("{}.weight", c.name),
            vec![c.out_channels, c.in_channels, KERNEL, KERNEL],
        ));
        v.push((format!("{}.bias", c.name), vec![c.out_channels]));
    }
    v.push(("head.weight".into(), vec![1, EMBEDDING_DIM]));
    v.push(("head.bias".into(), vec![1]));
    v
}

/// A freshly initialised parameter: zero for a `.bias`, else Kaiming-uniform
/// over its fan-in (scaled by 0.1 for a `head`), drawn from `rng`.
pub(crate) fn init_param(
    name: &str,
    shape: Vec<usize>,
    rng: &mut ChaCha8Rng,
) -> candle_core::Result<Var> {
    let n: usize = shape.iter().product();
    let data: Vec<f32> = if name.ends_with(".bias") {
        vec![0.0; n]
    } else {
        let fan_in: usize = shape[1..].iter().product();
        let bound = (6.0 / fan_in as f32).sqrt() * if name.starts_with("head") { 0.1 } else { 1.0 };
        (0..n).map(|_| rng.random_range(-bound..bound)).collect()
    };
    Var::from_tensor(&Tensor::from_vec(data, shape, &Device::Cpu)?)
}

/// One primitive's Q-network. Parameters are candle [`Var`]s, in the order of
/// [`param_shapes`] (the same for every [`Trunk`]).
#[derive(Clone, Debug)]
pub struct QNet {
    pub params: Vec<Var>,
    pub trunk: Trunk,
}

impl QNet {
    /// A freshly initialised network with the standard trunk
    /// (Kaiming-uniform weights, zero biases), deterministic in `seed`.
    pub fn new(seed: u64) -> candle_core::Result<Self> {
        Self::with_trunk(seed, Trunk::STANDARD)
    }

    /// [`Self::new`] with `trunk` (the weights drawn do not depend on it).
    pub fn with_trunk(seed: u64, trunk: Trunk) -> candle_core::Result<Self> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut params = Vec::new();
        for (name, shape) in param_shapes() {
            params.push(init_param(&name, shape, &mut rng)?);
        }
        Ok(Self { params, trunk })
    }

    /// Builds a net with `trunk` from tensors in [`param_shapes`] order
    /// (shapes not checked here).
    pub fn from_tensors(tensors: Vec<Tensor>, trunk: Trunk) -> candle_core::Result<Self> {
        Ok(Self {
            params: tensors
                .iter()
                .map(Var::from_tensor)
                .collect::<Result<_, _>>()?,
            trunk,
        })
    }

    /// The trunk E_m: `(B, 4, 112, 112)` network inputs to `(B, 64, 28, 28)` features.
    pub fn trunk(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let mut h = x.clone();
        for (i, c) in self.trunk.specs().iter().enumerate() {
            let w = self.params[2 * i].as_tensor();
            let b = self.params[2 * i + 1].as_tensor();
            h = h.conv2d(w, c.dilation, c.stride, c.dilation, 1)?;
            h = h
                .broadcast_add(&b.reshape((1, c.out_channels, 1, 1))?)?
                .relu()?;
        }
        Ok(h)
    }

    /// The 1x1 head `w` (64 values) and bias `b`, as plain floats.
    pub fn head(&self) -> candle_core::Result<(Vec<f32>, f32)> {
        let n = self.params.len();
        let w = self.params[n - 2]
            .as_tensor()
            .flatten_all()?
            .to_vec1::<f32>()?;
        let b = self.params[n - 1]
            .as_tensor()
            .flatten_all()?
            .to_vec1::<f32>()?;
        Ok((w, b[0]))
    }

    /// Q at given feature-map locations, differentiably.
    ///
    /// `x`: `(B, 4, 112, 112)` rotated inputs; `taps`: `4 B` flat cell indices
    /// (u32, `b * 28 * 28 + cell`); `weights`: `(B, 4)` bilinear weights. Returns `(B,)`.
    pub fn q_at(&self, x: &Tensor, taps: &Tensor, weights: &Tensor) -> candle_core::Result<Tensor> {
        let b = x.dim(0)?;
        let f = self.trunk(x)?; // (B, D, n, n)
        let n = f.dim(2)?;
        let rows = f
            .permute((0, 2, 3, 1))?
            .reshape((b * n * n, EMBEDDING_DIM))?
            .index_select(taps, 0)?
            .reshape((b, 4, EMBEDDING_DIM))?;
        let feat = rows.broadcast_mul(&weights.unsqueeze(2)?)?.sum(1)?; // (B, D)
        let np = self.params.len();
        let w = self.params[np - 2].as_tensor(); // (1, D)
        let bias = self.params[np - 1].as_tensor(); // (1,)
        feat.matmul(&w.t()?)?.broadcast_add(bias)?.squeeze(1)
    }

    /// Deep copy (new Vars).
    pub fn deep_clone(&self) -> candle_core::Result<Self> {
        Ok(Self {
            params: self
                .params
                .iter()
                .map(|v| Var::from_tensor(&v.as_tensor().copy()?))
                .collect::<Result<_, _>>()?,
            trunk: self.trunk,
        })
    }

    /// All parameters as flat f32 vectors (for checkpoints and comparisons).
    pub fn to_vecs(&self) -> candle_core::Result<Vec<Vec<f32>>> {
        self.params
            .iter()
            .map(|v| {
                v.as_tensor()
                    .flatten_all()?
                    .to_dtype(DType::F32)?
                    .to_vec1::<f32>()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trunks_name_themselves_and_see_what_their_dilation_says() {
        assert_eq!(Trunk::STANDARD.architecture(), "spotq-fcn-s4-c64");
        assert_eq!(Trunk::STANDARD.receptive_field(), 39);
        let d4 = Trunk::with_conv5_dilation(4).expect("d4");
        assert_eq!(d4.receptive_field(), 63);
        let d8 = Trunk::with_conv5_dilation(8).expect("d8");
        assert_eq!(d8.architecture(), "spotq-fcn-s4-c64-d8");
        assert_eq!(d8.receptive_field(), 95);
        assert!((d8.receptive_field_m() - 0.38).abs() < 1e-6);
        assert_eq!(d8.specs()[4].dilation, 8);
        for t in [Trunk::STANDARD, d4, d8] {
            assert_eq!(Trunk::from_architecture(&t.architecture()), Some(t));
        }
        for bad in [
            "spotq-fcn-s4-c64-d1",
            "spotq-fcn-s4-c64-d0",
            "spotq-fcn-s4-c64-d13",
            "spotq-fcn",
            "x",
        ] {
            assert_eq!(Trunk::from_architecture(bad), None, "{bad}");
        }
        assert!(Trunk::with_conv5_dilation(0).is_err());
    }
}
