//! Transporter Networks (Zeng et al., CoRL 2020), the paper's few-shot
//! baseline: trained by imitation on the test task's two demonstrations, with
//! no reinforcement learning and no other task's policy.
//!
//! Two modules act on the same colour and depth heightmaps as the SPOT-Q
//! policies ([`crate::input`]'s normalised 4 x 112 x 112 input, area-averaged
//! to a [`GRID`] x [`GRID`] grid of 8 mm cells to fit a 2-core CPU) and score
//! the same 16 rotations; each grid cell's score covers the heightmap pixels
//! it averages, so actions land on seespot's usual action grid:
//!
//! - **attention** (pick): an FCN scores every `(rotation, pixel)` grasp; its
//!   16 output channels are the 16 gripper rotations;
//! - **transport** (place): a *query* FCN embeds a patch of the input centred on
//!   the pick, rotated to each of the 16 relative rotations; the central
//!   [`CROP`] x [`CROP`] of each is cross-correlated with the *key* FCN's
//!   features of the whole input, giving a score for every (relative rotation,
//!   pixel) place. The place's gripper rotation is the pick's plus the relative
//!   one.
//!
//! Both pick and place are chosen from the observation before the grasp, as in
//! the original (one pick-and-place per observation); the place is executed
//! when the trial asks for it.
//!
//! Every FCN ([`FCN`]), on an `n x n` input (n divisible by 4):
//!
//! | layer | kernel | stride | dilation | channels | output |
//! |---|---|---|---|---|---|
//! | c1 | 3x3 | 1 | 1 | 4 -> 16 | n |
//! | c2 | 3x3 | 2 | 1 | 16 -> 32 | n/2 |
//! | c3 | 3x3 | 2 | 1 | 32 -> 32 | n/4 |
//! | c4 | 3x3 | 1 | 2 | 32 -> 32 | n/4 |
//! | c5 | 3x3 | 1 | 1 | (32 up x2) + 32 from c2 -> 16 | n/2 |
//! | c6 | 3x3 | 1 | 1 | (16 up x2) + 16 from c1 -> 16 | n |
//! | head | 1x1 | 1 | 1 | 16 -> out | n |
//!
//! ReLU after every layer but the head. The original uses 43-layer ResNets on
//! 320 x 160 images at 3.125 mm and a GPU; these are sized for a 2-core CPU.
//! The transport features have [`TRANSPORT_DIM`] = 3 channels, as in the
//! original.

pub mod actor;
pub mod train;

use std::collections::BTreeMap;
use std::path::Path;

use candle_core::{D, Device, Tensor, Var};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use seespot_sim::action::rotation_angle;
use seespot_sim::{Action, Heightmaps, NUM_ROTATIONS, Primitive, TaskId};

use crate::error::PolicyError;
use crate::input::{INPUT_CHANNELS, NET_RESOLUTION, NetInput, fill_values};
use crate::rotation::sample_fill;
use crate::tensor_file::{self, F32Tensor};

pub use actor::TransporterActor;
pub use train::{
    CurvePoint, TransporterTrainConfig, TransporterTrainOutcome, finetune_transporter,
    train_transporter,
};

/// `format` metadata value of a TransporterNet file.
pub const FORMAT: &str = "seespot-transporter";
/// `architecture` metadata value: the FCNs of this module.
pub const ARCHITECTURE: &str = "transporter-fcn6-g56-d3-crop12";
/// Version of the weights file layout.
pub const FORMAT_VERSION: u32 = 1;
/// Channels of the key and query features.
pub const TRANSPORT_DIM: usize = 3;
/// Side of the grid the TransporterNet sees and scores (8 mm cells).
pub const GRID: usize = NET_RESOLUTION / 2;
/// Side of the query crop cross-correlated with the key features, grid cells
/// (12 x 8 mm = 9.6 cm: a 5 cm block and a margin around it).
pub const CROP: usize = 12;
/// Context around the crop that the query FCN sees, cells per side.
pub const PATCH_MARGIN: usize = 4;
/// Side of the rotated input patch the query FCN runs on.
pub const PATCH: usize = CROP + 2 * PATCH_MARGIN;

/// One convolution of an FCN.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layer {
    pub name: &'static str,
    pub in_channels: usize,
    pub out_channels: usize,
    pub kernel: usize,
    pub stride: usize,
    pub dilation: usize,
}

const fn layer(
    name: &'static str,
    in_channels: usize,
    out_channels: usize,
    stride: usize,
    dilation: usize,
) -> Layer {
    Layer {
        name,
        in_channels,
        out_channels,
        kernel: 3,
        stride,
        dilation,
    }
}

/// The FCN's six 3x3 layers, in order (the 1x1 head follows).
pub const FCN: [Layer; 6] = [
    layer("c1", INPUT_CHANNELS, 16, 1, 1),
    layer("c2", 16, 32, 2, 1),
    layer("c3", 32, 32, 2, 1),
    layer("c4", 32, 32, 1, 2),
    layer("c5", 32 + 32, 16, 1, 1),
    layer("c6", 16 + 16, 16, 1, 1),
];

/// The three FCNs of a TransporterNet, with their output channels.
pub const MODULES: [(&str, usize); 3] = [
    ("attention", NUM_ROTATIONS),
    ("key", TRANSPORT_DIM),
    ("query", TRANSPORT_DIM),
];

/// Parameter names and shapes of one FCN with `out` output channels.
pub fn fcn_shapes(out: usize) -> Vec<(String, Vec<usize>)> {
    let mut v = Vec::new();
    for l in FCN {
        v.push((
            format!("{}.weight", l.name),
            vec![l.out_channels, l.in_channels, l.kernel, l.kernel],
        ));
        v.push((format!("{}.bias", l.name), vec![l.out_channels]));
    }
    v.push(("head.weight".into(), vec![out, 16, 1, 1]));
    v.push(("head.bias".into(), vec![out]));
    v
}

/// Every parameter of a TransporterNet: `<module>.<layer>.<weight|bias>`.
pub fn param_shapes() -> Vec<(String, Vec<usize>)> {
    MODULES
        .iter()
        .flat_map(|(m, out)| {
            fcn_shapes(*out)
                .into_iter()
                .map(move |(n, s)| (format!("{m}.{n}"), s))
        })
        .collect()
}

/// One fully convolutional network; parameters in [`fcn_shapes`] order.
#[derive(Clone, Debug)]
pub struct Fcn {
    pub params: Vec<Var>,
    pub out: usize,
}

fn conv(x: &Tensor, w: &Tensor, b: &Tensor, l: &Layer) -> candle_core::Result<Tensor> {
    let pad = l.dilation * (l.kernel / 2);
    gemm_conv(x, w, pad, l.stride, l.dilation)?.broadcast_add(&b.reshape((
        1,
        l.out_channels,
        1,
        1,
    ))?)
}

/// Gather indices, cached per shape (building one costs about as much as the
/// convolution).
type IndexCache = std::sync::Mutex<std::collections::HashMap<[usize; 8], Tensor>>;

fn cached_index(key: [usize; 8], build: impl FnOnce() -> Vec<u32>) -> candle_core::Result<Tensor> {
    static CACHE: std::sync::OnceLock<IndexCache> = std::sync::OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    if let Some(t) = cache
        .lock()
        .map_err(|_| candle_core::Error::Msg("index cache poisoned".into()))?
        .get(&key)
    {
        return Ok(t.clone());
    }
    let idx = build();
    let n = idx.len();
    let t = Tensor::from_vec(idx, n, &Device::Cpu)?;
    cache
        .lock()
        .map_err(|_| candle_core::Error::Msg("index cache poisoned".into()))?
        .insert(key, t.clone());
    Ok(t)
}

/// A 2-D convolution (cross-correlation, zero padding) written as a gather of
/// the input patches (im2col) and one matrix product: the same values as
/// `conv2d`, but its backward pass is a scatter-add and two matrix products,
/// where candle's CPU backward of `conv2d` runs a direct, scalar transposed
/// convolution (about 10x slower here). `x` `(B, C, H, W)`, `w` `(O, C, k, k)`.
pub fn gemm_conv(
    x: &Tensor,
    w: &Tensor,
    pad: usize,
    stride: usize,
    dilation: usize,
) -> candle_core::Result<Tensor> {
    let (b, c, h, wd) = x.dims4()?;
    let (o, _, k, _) = w.dims4()?;
    let (hp, wp) = (h + 2 * pad, wd + 2 * pad);
    let span = dilation * (k - 1) + 1;
    let ho = (hp - span) / stride + 1;
    let wo = (wp - span) / stride + 1;
    let xp = if pad > 0 {
        x.pad_with_zeros(2, pad, pad)?.pad_with_zeros(3, pad, pad)?
    } else {
        x.clone()
    };
    let idx = cached_index([b, c, h, wd, k, pad, stride, dilation], || {
        let mut idx = Vec::with_capacity(b * c * k * k * ho * wo);
        for bi in 0..b {
            for ci in 0..c {
                let base = (bi * c + ci) * hp * wp;
                for ky in 0..k {
                    for kx in 0..k {
                        for oy in 0..ho {
                            let row = base + (oy * stride + ky * dilation) * wp + kx * dilation;
                            for ox in 0..wo {
                                idx.push((row + ox * stride) as u32);
                            }
                        }
                    }
                }
            }
        }
        idx
    })?;
    let cols = xp
        .flatten_all()?
        .index_select(&idx, 0)?
        .reshape((b, c * k * k, ho * wo))?;
    w.reshape((o, c * k * k))?
        .broadcast_left(b)?
        .matmul(&cols)?
        .reshape((b, o, ho, wo))
}

/// Nearest-neighbour upsampling by 2 as a gather (its backward is a
/// scatter-add). `(B, C, n, n)` to `(B, C, 2n, 2n)`.
fn upsample2(x: &Tensor) -> candle_core::Result<Tensor> {
    let (b, c, h, w) = x.dims4()?;
    let idx = cached_index([b, c, h, w, 2, 0, 0, 0], || {
        let mut idx = Vec::with_capacity(b * c * 4 * h * w);
        for plane in 0..b * c {
            for y in 0..2 * h {
                for xx in 0..2 * w {
                    idx.push((plane * h * w + (y / 2) * w + xx / 2) as u32);
                }
            }
        }
        idx
    })?;
    x.flatten_all()?
        .index_select(&idx, 0)?
        .reshape((b, c, 2 * h, 2 * w))
}

impl Fcn {
    /// Kaiming-uniform weights (the head scaled by 0.1), zero biases.
    pub fn new(out: usize, rng: &mut ChaCha8Rng) -> candle_core::Result<Self> {
        let mut params = Vec::new();
        for (name, shape) in fcn_shapes(out) {
            params.push(crate::net::init_param(&name, shape, rng)?);
        }
        Ok(Self { params, out })
    }

    /// `(B, 4, n, n)` to `(B, out, n, n)`; `n` must be divisible by 4.
    pub fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let p = |i: usize| self.params[i].as_tensor();
        let layer = |h: &Tensor, i: usize| -> candle_core::Result<Tensor> {
            conv(h, p(2 * i), p(2 * i + 1), &FCN[i])?.relu()
        };
        let h1 = layer(x, 0)?;
        let h2 = layer(&h1, 1)?;
        let h3 = layer(&h2, 2)?;
        let h4 = layer(&h3, 3)?;
        let u5 = Tensor::cat(&[&upsample2(&h4)?, &h2], 1)?;
        let h5 = layer(&u5, 4)?;
        let u6 = Tensor::cat(&[&upsample2(&h5)?, &h1], 1)?;
        let h6 = layer(&u6, 5)?;
        let head = Layer {
            name: "head",
            in_channels: 16,
            out_channels: self.out,
            kernel: 1,
            stride: 1,
            dilation: 1,
        };
        conv(&h6, p(12), p(13), &head)
    }
}

/// What a TransporterNet file says about its training.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TransporterMeta {
    /// The task whose demonstrations it was trained on (kebab-case id).
    pub task: String,
    /// seespot version that wrote it.
    pub seespot_version: String,
    /// Free-form training facts (iterations, seed, wall time, demo checksums).
    pub extra: BTreeMap<String, String>,
}

/// A TransporterNet: attention, key and query FCNs.
#[derive(Clone, Debug)]
pub struct TransporterNet {
    pub meta: TransporterMeta,
    pub attention: Fcn,
    pub key: Fcn,
    pub query: Fcn,
}

/// Pick and place scores of one observation (for the debugger): the attention
/// logits of every grasp and the transport logits of every place given the
/// chosen pick, both `R x GRID x GRID`.
#[derive(Clone, Debug)]
pub struct TransporterMaps {
    pub attention: Vec<f32>,
    pub transport: Vec<f32>,
    /// The grid's side.
    pub n: usize,
    /// The pick and place chosen on the grid: (rotation, y, x) and (rotation
    /// relative to the pick, y, x).
    pub pick: (usize, usize, usize),
    pub place: (usize, usize, usize),
}

/// A network-grid pixel `(y, x)` as a `u32` flat index into `R x n x n`.
fn flat(r: usize, y: usize, x: usize, n: usize) -> usize {
    (r * n + y) * n + x
}

/// The input patch of side [`PATCH`] centred on network pixel `(y, x)`, rotated
/// for each relative rotation `k`: its content is turned by `+k x 22.5` degrees
/// (as the held block turns when the gripper does), read with bilinear
/// sampling; outside the image reads the bare table. `R x 4 x PATCH x PATCH`.
pub fn rotated_patches(input: &[f32], n: usize, y: usize, x: usize) -> Vec<f32> {
    let fill = fill_values();
    let c = (PATCH / 2) as f32;
    let plane = PATCH * PATCH;
    let mut out = vec![0.0f32; NUM_ROTATIONS * INPUT_CHANNELS * plane];
    for k in 0..NUM_ROTATIONS {
        // Output pixel p reads the image at pick + R(-angle)(p - c): content
        // turned by +angle.
        let (s, co) = (-rotation_angle(k)).sin_cos();
        for v in 0..PATCH {
            let dv = v as f32 - c;
            for u in 0..PATCH {
                let du = u as f32 - c;
                let fx = x as f32 + co * du - s * dv;
                let fy = y as f32 + s * du + co * dv;
                for ch in 0..INPUT_CHANNELS {
                    out[((k * INPUT_CHANNELS + ch) * PATCH + v) * PATCH + u] =
                        sample_fill(&input[ch * n * n..(ch + 1) * n * n], n, fx, fy, fill[ch]);
                }
            }
        }
    }
    out
}

/// Grid cell of heightmap pixel `p` at resolution `h` (nearest).
pub fn to_grid(p: usize, h: usize) -> usize {
    nearest(p, h, GRID)
}

/// Heightmap pixel (resolution `h`) of grid cell `k` (nearest).
pub fn from_grid(k: usize, h: usize) -> usize {
    nearest(k, GRID, h)
}

/// The index at resolution `to` nearest to index `p` at resolution `from`
/// (pixel centres aligned).
fn nearest(p: usize, from: usize, to: usize) -> usize {
    (((p as f32 + 0.5) * to as f32 / from as f32 - 0.5)
        .round()
        .max(0.0) as usize)
        .min(to - 1)
}

/// The 4 x [`GRID`] x [`GRID`] input of a TransporterNet: the network input
/// averaged over 2 x 2 pixels.
pub fn grid_input(input: &NetInput) -> Vec<f32> {
    let (n, g) = (input.n, GRID);
    let mut out = vec![0.0f32; INPUT_CHANNELS * g * g];
    crate::input::area_average(
        INPUT_CHANNELS,
        g,
        n / g,
        |c, y, x| input.data[(c * n + y) * n + x],
        &mut out,
    );
    out
}

impl TransporterNet {
    /// A freshly initialised net for `task`, deterministic in `seed`.
    pub fn new(task: TaskId, seed: u64) -> Result<Self, PolicyError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        Ok(Self {
            meta: TransporterMeta {
                task: task.as_str().to_string(),
                seespot_version: seespot_sim::VERSION.to_string(),
                extra: BTreeMap::new(),
            },
            attention: Fcn::new(NUM_ROTATIONS, &mut rng)?,
            key: Fcn::new(TRANSPORT_DIM, &mut rng)?,
            query: Fcn::new(TRANSPORT_DIM, &mut rng)?,
        })
    }

    /// Every parameter, in [`param_shapes`] order.
    pub fn vars(&self) -> Vec<&Var> {
        self.attention
            .params
            .iter()
            .chain(&self.key.params)
            .chain(&self.query.params)
            .collect()
    }

    /// Attention logits `(1, R * n * n)` (flat index = rotation, y, x) of the
    /// network input `x` (`(1, 4, n, n)`).
    pub fn attention_logits(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        self.attention.forward(x)?.flatten_from(1)
    }

    /// Transport logits `(1, R * n * n)` (flat index = relative rotation, y, x)
    /// of the network input `x` for the pick whose [`rotated_patches`] are
    /// `patches` (`(R, 4, PATCH, PATCH)`).
    pub fn transport_logits(&self, x: &Tensor, patches: &Tensor) -> candle_core::Result<Tensor> {
        let (_, _, n, _) = x.dims4()?;
        let key = self.key.forward(x)?; // (1, d, n, n)
        let kernels = self
            .query
            .forward(patches)?
            .narrow(2, PATCH_MARGIN, CROP)?
            .narrow(3, PATCH_MARGIN, CROP)?
            .contiguous()?; // (R, d, CROP, CROP)
        correlate(&key, &kernels, n)?.flatten_from(1)
    }

    /// Pick and place on the grid for grid input `input` ([`grid_input`]),
    /// with both score maps.
    pub fn maps(&self, input: &[f32]) -> Result<TransporterMaps, PolicyError> {
        let n = GRID;
        let x = Tensor::from_vec(input.to_vec(), (1, INPUT_CHANNELS, n, n), &Device::Cpu)?;
        let attention = self.attention_logits(&x)?.flatten_all()?.to_vec1::<f32>()?;
        let best = argmax(&attention);
        let pick = (best / (n * n), (best / n) % n, best % n);
        let patches = Tensor::from_vec(
            rotated_patches(input, n, pick.1, pick.2),
            (NUM_ROTATIONS, INPUT_CHANNELS, PATCH, PATCH),
            &Device::Cpu,
        )?;
        let transport = self
            .transport_logits(&x, &patches)?
            .flatten_all()?
            .to_vec1::<f32>()?;
        let best = argmax(&transport);
        let place = (best / (n * n), (best / n) % n, best % n);
        Ok(TransporterMaps {
            attention,
            transport,
            n,
            pick,
            place,
        })
    }

    /// The grasp and the place this net chooses in `hm` (actions at `hm`'s
    /// resolution), with the score maps.
    pub fn plan(&self, hm: &Heightmaps) -> Result<(Action, Action, TransporterMaps), PolicyError> {
        let maps = self.maps(&grid_input(&NetInput::from_heightmaps(hm)))?;
        let h = hm.resolution();
        let (r, y, x) = maps.pick;
        let grasp = Action::new(Primitive::Grasp, r, from_grid(y, h), from_grid(x, h));
        let (k, y, x) = maps.place;
        let place = Action::new(
            Primitive::Place,
            (r + k) % NUM_ROTATIONS,
            from_grid(y, h),
            from_grid(x, h),
        );
        Ok((grasp, place, maps))
    }

    /// Writes the weights and metadata as safetensors.
    pub fn save(&self, path: &Path) -> Result<(), PolicyError> {
        let mut tensors = BTreeMap::new();
        for ((name, shape), var) in param_shapes().into_iter().zip(self.vars()) {
            let data = var.as_tensor().flatten_all()?.to_vec1::<f32>()?;
            tensors.insert(name, F32Tensor { shape, data });
        }
        tensor_file::write(path, &tensors, &self.metadata())
    }

    /// The file metadata of this net.
    pub fn metadata(&self) -> BTreeMap<String, String> {
        let mut meta = tensor_file::header(
            FORMAT,
            ARCHITECTURE,
            FORMAT_VERSION,
            &self.meta.seespot_version,
            &self.meta.task,
            &self.meta.extra,
        );
        meta.insert("rotations".into(), NUM_ROTATIONS.to_string());
        meta
    }

    /// Loads a net written by [`TransporterNet::save`] (or the weights of a
    /// training checkpoint), checking format, architecture, version and every
    /// tensor's presence, shape and checksum; errors name the file and, where
    /// one is at fault, the tensor.
    pub fn load(path: &Path) -> Result<Self, PolicyError> {
        let file = tensor_file::read(path)?;
        Self::from_file(path, &file)
    }

    pub(crate) fn from_file(
        path: &Path,
        file: &tensor_file::TensorFile,
    ) -> Result<Self, PolicyError> {
        let format = |reason: String| PolicyError::Format {
            path: path.to_path_buf(),
            reason,
        };
        let get = |k: &str| file.field(path, k);
        for (k, want) in [
            ("format", FORMAT.to_string()),
            ("architecture", ARCHITECTURE.to_string()),
            ("format_version", FORMAT_VERSION.to_string()),
            ("rotations", NUM_ROTATIONS.to_string()),
        ] {
            let got = get(k)?;
            if *got != want {
                return Err(format(format!(
                    "metadata field `{k}` is `{got}`, expected `{want}`"
                )));
            }
        }
        let task = get("task")?.clone();
        if let Err(e) = task.parse::<TaskId>() {
            return Err(format(format!("metadata field `task`: {e}")));
        }
        let mut vars = Vec::new();
        let mut expected = std::collections::BTreeSet::new();
        for (name, shape) in param_shapes() {
            let t = file.tensor(path, &name, &shape)?;
            vars.push(Var::from_tensor(&Tensor::from_vec(
                t.data.clone(),
                shape,
                &Device::Cpu,
            )?)?);
            expected.insert(name);
        }
        if let Some(extra) = file
            .tensors
            .keys()
            .find(|k| !expected.contains(*k) && !k.starts_with("adam."))
        {
            return Err(PolicyError::Tensor {
                path: path.to_path_buf(),
                tensor: extra.clone(),
                reason: "unexpected tensor for this architecture".into(),
            });
        }
        let per = fcn_shapes(1).len();
        let mut take = |out: usize| Fcn {
            params: vars.drain(..per).collect(),
            out,
        };
        let attention = take(NUM_ROTATIONS);
        let key = take(TRANSPORT_DIM);
        let query = take(TRANSPORT_DIM);
        let extra = file.extra();
        Ok(Self {
            meta: TransporterMeta {
                task,
                seespot_version: get("seespot_version")?.clone(),
                extra,
            },
            attention,
            key,
            query,
        })
    }

    /// Deep copy (new Vars): a net to finetune without touching the original.
    pub fn deep_clone(&self) -> candle_core::Result<Self> {
        let copy = |f: &Fcn| -> candle_core::Result<Fcn> {
            Ok(Fcn {
                params: f
                    .params
                    .iter()
                    .map(|v| Var::from_tensor(&v.as_tensor().copy()?))
                    .collect::<Result<_, _>>()?,
                out: f.out,
            })
        };
        Ok(Self {
            meta: self.meta.clone(),
            attention: copy(&self.attention)?,
            key: copy(&self.key)?,
            query: copy(&self.query)?,
        })
    }
}

/// The transport's cross-correlation: `key` `(1, d, n, n)` features against
/// `kernels` `(R, d, CROP, CROP)` crops gives `(1, R, n, n)`, where
/// `out[r, o] = sum_i key[o + i - CROP/2] . kernels[r, i]`: each crop's centre
/// (the pick) is laid on pixel `o`. Outside the image counts as zero.
pub fn correlate(key: &Tensor, kernels: &Tensor, n: usize) -> candle_core::Result<Tensor> {
    gemm_conv(key, kernels, CROP / 2, 1, 1)?
        .narrow(2, 0, n)?
        .narrow(3, 0, n)?
        .contiguous()
}

/// Index of the largest value (the first on ties).
pub fn argmax(v: &[f32]) -> usize {
    let mut best = (f32::NEG_INFINITY, 0usize);
    for (i, &x) in v.iter().enumerate() {
        if x > best.0 {
            best = (x, i);
        }
    }
    best.1
}

/// Cross-entropy of the flat logits `(1, K)` against class `label`.
pub fn cross_entropy(logits: &Tensor, label: usize) -> candle_core::Result<Tensor> {
    let logp = candle_nn::ops::log_softmax(logits, D::Minus1)?;
    logp.narrow(1, label, 1)?.neg()?.sum_all()
}

/// The flat index of `(rotation, y, x)` on an `n x n` grid (as the logits).
pub fn label(rotation: usize, y: usize, x: usize, n: usize) -> usize {
    flat(rotation, y, x, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn shapes_and_pixel_maps() {
        let net = TransporterNet::new(TaskId::Stack, 1).expect("net");
        assert_eq!(net.vars().len(), param_shapes().len());
        for h in [112, 224, 160] {
            for p in [0, h / 3, h - 1] {
                let back = from_grid(to_grid(p, h), h);
                assert!(back.abs_diff(p) <= h / GRID, "{p} at {h}: {back}");
            }
        }
        assert_eq!(to_grid(57, 112), 28);
        assert_eq!(from_grid(28, 112), 57);
    }

    /// An L-shaped block (depth channel) at `(y, x)`, turned by `k` quarter turns.
    fn l_shape(n: usize, y: usize, x: usize, quarter_turns: usize) -> Vec<f32> {
        let mut data = vec![0.0f32; INPUT_CHANNELS * n * n];
        let cells: Vec<(i64, i64)> = (-4..=4)
            .map(|d| (d, -4))
            .chain((-3..=4).map(|d| (4, d)))
            .collect();
        for (mut dy, mut dx) in cells {
            for _ in 0..quarter_turns {
                // (dx, dy) -> R(90 deg) (dx, dy) = (-dy, dx)
                (dx, dy) = (-dy, dx);
            }
            let (yy, xx) = (y as i64 + dy, x as i64 + dx);
            data[3 * n * n + yy as usize * n + xx as usize] = 1.0;
        }
        data
    }

    #[test]
    fn transport_finds_the_turned_copy() {
        // The crop around the pick (an L at (15, 15)) is correlated with a scene
        // holding only a copy turned by a quarter turn (k = 4) at (40, 30): the
        // best place is that copy, at relative rotation 4.
        let n = GRID;
        let pick_scene = l_shape(n, 15, 15, 0);
        let place_scene = l_shape(n, 40, 30, 1);
        let depth_only = |v: Vec<f32>, c: usize, side: usize| -> Vec<f32> {
            (0..v.len() / (INPUT_CHANNELS * side * side))
                .flat_map(|b| {
                    let start = (b * INPUT_CHANNELS + c) * side * side;
                    v[start..start + side * side].to_vec()
                })
                .collect()
        };
        let patches = depth_only(rotated_patches(&pick_scene, n, 15, 15), 3, PATCH);
        let kernels = Tensor::from_vec(patches, (NUM_ROTATIONS, 1, PATCH, PATCH), &Device::Cpu)
            .expect("tensor")
            .narrow(2, PATCH_MARGIN, CROP)
            .and_then(|t| t.narrow(3, PATCH_MARGIN, CROP))
            .and_then(|t| t.contiguous())
            .expect("crop");
        let key = Tensor::from_vec(depth_only(place_scene, 3, n), (1, 1, n, n), &Device::Cpu)
            .expect("tensor");
        let out = correlate(&key, &kernels, n)
            .and_then(|t| t.flatten_all())
            .and_then(|t| t.to_vec1::<f32>())
            .expect("correlate");
        let best = argmax(&out);
        assert_eq!(
            (best / (n * n), (best / n) % n, best % n),
            (4, 40, 30),
            "score there {}, best {}",
            out[flat(4, 40, 30, n)],
            out[best]
        );
    }

    #[test]
    fn gemm_conv_equals_conv2d() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut t = |shape: &[usize]| {
            let n: usize = shape.iter().product();
            let v: Vec<f32> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            Tensor::from_vec(v, shape, &Device::Cpu).expect("tensor")
        };
        for (x, w, pad, stride, dil) in [
            (t(&[2, 3, 12, 12]), t(&[5, 3, 3, 3]), 1, 1, 1),
            (t(&[1, 4, 12, 12]), t(&[2, 4, 3, 3]), 1, 2, 1),
            (t(&[1, 2, 10, 10]), t(&[3, 2, 3, 3]), 2, 1, 2),
            (t(&[1, 3, 16, 16]), t(&[4, 3, 6, 6]), 3, 1, 1),
        ] {
            let a = gemm_conv(&x, &w, pad, stride, dil).expect("gemm");
            let b = x.conv2d(&w, pad, stride, dil, 1).expect("conv2d");
            assert_eq!(a.dims(), b.dims());
            let d = (a - b)
                .and_then(|d| d.abs())
                .and_then(|d| d.max_all())
                .and_then(|d| d.to_scalar::<f32>())
                .expect("diff");
            assert!(d < 1e-4, "max difference {d}");
        }
    }

    #[test]
    fn patch_rotation_turns_content() {
        // One bright pixel 5 px to the right (+x) of the pick: a quarter turn
        // (k = 4) puts it 5 px along +y.
        let n = 32;
        let mut input = vec![0.0f32; INPUT_CHANNELS * n * n];
        input[3 * n * n + 16 * n + 21] = 1.0;
        let p = rotated_patches(&input, n, 16, 16);
        let c = PATCH / 2;
        let depth =
            |k: usize, v: usize, u: usize| p[((k * INPUT_CHANNELS + 3) * PATCH + v) * PATCH + u];
        assert!((depth(0, c, c + 5) - 1.0).abs() < 1e-5);
        assert!(
            (depth(4, c + 5, c) - 1.0).abs() < 1e-4,
            "{}",
            depth(4, c + 5, c)
        );
    }
}
