//! The SPOT-Q learner: a [`PolicyNet`], its optimiser and the training step
//! (Huber loss at the executed action only), plus its checkpoint file.
//!
//! Only the executed action needs a forward/backward pass: the stored state is
//! rendered, rotated by the executed rotation, run through the trunk, the feature
//! is sampled bilinearly at the executed pixel's location in the rotated feature
//! map and the 1x1 head gives its Q. The trunk runs over that feature's
//! receptive field alone, forward and backward ([`crate::cone`]), in plain
//! loops; [`Learner::train_step_candle`] is the same step through candle's
//! autograd on the whole trunk, kept as the reference the tests compare with.

use std::collections::BTreeMap;
use std::path::Path;

use candle_core::{Device, Tensor, Var};
use rayon::prelude::*;
use seespot_sim::Primitive;
use seespot_sim::action::rotation_angle;

use crate::cone::{ConeGrad, q_and_grad};
use crate::error::PolicyError;
use crate::input::{INPUT_CHANNELS, NET_RESOLUTION, NetInput};
use crate::net::{FEATURE_RESOLUTION, TRUNK_STRIDE, Trunk, param_shapes};
use crate::optim::{Adam, AdamConfig, FlatAdam};
use crate::policy::PolicyNet;
use crate::replay::Experience;
use crate::rotation::{BackMap, bilinear_taps, rotate_input};
use crate::tensor_file::{self, F32Tensor};

/// Huber loss threshold.
pub const HUBER_DELTA: f32 = 1.0;

/// A policy being trained and its optimiser.
#[derive(Debug)]
pub struct Learner {
    pub policy: PolicyNet,
    pub adam: FlatAdam,
}

/// What one training step measured (before the update).
#[derive(Clone, Debug)]
pub struct StepStats {
    /// Mean Huber loss over the batch.
    pub loss: f32,
    /// Predicted Q of each experience, in batch order.
    pub predictions: Vec<f32>,
}

impl StepStats {
    /// The stats of a step that learned nothing from a batch of `n` (no loss,
    /// every prediction 0).
    fn nothing(n: usize) -> Self {
        Self {
            loss: 0.0,
            predictions: vec![0.0; n],
        }
    }
}

/// What [`Learner::gradients`] computed for one batch.
#[derive(Debug)]
pub struct Gradients {
    /// The batch's loss and predictions.
    pub stats: StepStats,
    /// Both nets' parameters the gradients were taken at, grasp then place,
    /// one vector per tensor in [`param_shapes`] order.
    pub params: Vec<Vec<Vec<f32>>>,
    /// The gradients of the mean loss, per net ([`Primitive::index`]); `None`
    /// for a net no experience of the batch used.
    pub grads: [Option<Vec<Vec<f32>>>; 2],
}

/// An experience made ready for the net: rotated input and bilinear taps.
struct Prepared {
    input: Vec<f32>,
    taps: [usize; 4],
    weights: [f32; 4],
}

fn prepare(e: &Experience) -> Prepared {
    let hm = e.heightmaps();
    let input = NetInput::from_heightmaps(&hm);
    let rotated = rotate_input(&input, e.action.rotation);
    let map = BackMap::new(&input, e.resolution, TRUNK_STRIDE);
    let (fx, fy) = map.locate(
        rotation_angle(e.action.rotation).sin_cos(),
        e.action.y,
        e.action.x,
    );
    let (taps, weights) = bilinear_taps(FEATURE_RESOLUTION, fx, fy);
    Prepared {
        input: rotated,
        taps,
        weights,
    }
}

/// Huber loss of `d`: `0.5 q^2 + delta (|d| - q)`, `q = min(|d|, delta)`.
fn huber(d: f32) -> f32 {
    let q = d.abs().min(HUBER_DELTA);
    0.5 * q * q + HUBER_DELTA * (d.abs() - q)
}

/// [`huber`] elementwise, differentiably (candle).
fn huber_tensor(d: &Tensor) -> candle_core::Result<Tensor> {
    let a = d.abs()?;
    let q = a.minimum(HUBER_DELTA)?;
    let lin = (&a - &q)?;
    (q.sqr()? * 0.5)? + (lin * HUBER_DELTA as f64)?
}

impl Learner {
    pub fn new(policy: PolicyNet, config: AdamConfig) -> Result<Self, PolicyError> {
        let sizes: Vec<usize> = names().iter().map(|(_, s)| s.iter().product()).collect();
        Ok(Self {
            policy,
            adam: FlatAdam::new(&sizes, config),
        })
    }

    /// One step on `batch`: Huber loss between each experience's target and the
    /// Q of its executed action, averaged, backpropagated through the cone of
    /// the action's receptive field ([`crate::cone`]), one Adam update of the
    /// nets of the primitives in the batch.
    pub fn train_step(&mut self, batch: &[Experience]) -> Result<StepStats, PolicyError> {
        let Some(step) = self.gradients(batch)? else {
            return Ok(StepStats::nothing(0));
        };
        self.adam.t += 1;
        let per = param_shapes().len();
        for (k, g) in step.grads.iter().enumerate() {
            let Some(g) = g else { continue };
            let mut p = step.params[k].clone();
            for (i, (p, g)) in p.iter_mut().zip(g).enumerate() {
                self.adam.update(k * per + i, p, g);
            }
            self.set_params(k, p)?;
        }
        Ok(step.stats)
    }

    /// The loss of `batch` and its gradients, without an update: the mean
    /// Huber loss between each experience's target and the Q of its executed
    /// action, differentiated through the cone of the action's receptive
    /// field ([`crate::cone`]). `None` for an empty batch.
    pub fn gradients(&self, batch: &[Experience]) -> Result<Option<Gradients>, PolicyError> {
        if batch.is_empty() {
            return Ok(None);
        }
        let params: Vec<Vec<Vec<f32>>> = self
            .policy
            .nets
            .iter()
            .map(|n| n.to_vecs())
            .collect::<Result<_, _>>()?;
        let cones: Vec<ConeGrad> = batch
            .par_iter()
            .map(|e| {
                let p = prepare(e);
                q_and_grad(
                    self.policy.net(e.action.primitive).trunk,
                    &params[e.action.primitive.index()],
                    &p.input,
                    NET_RESOLUTION,
                    p.taps,
                    p.weights,
                )
            })
            .collect();
        let scale = 1.0 / batch.len() as f32;
        let mut loss = 0.0f32;
        let mut grads: [Option<Vec<Vec<f32>>>; 2] = [None, None];
        for (e, c) in batch.iter().zip(&cones) {
            let d = c.q - e.target;
            loss += huber(d);
            let dq = d.clamp(-HUBER_DELTA, HUBER_DELTA) * scale;
            let acc = grads[e.action.primitive.index()]
                .get_or_insert_with(|| c.grads.iter().map(|g| vec![0.0; g.len()]).collect());
            for (a, g) in acc.iter_mut().zip(&c.grads) {
                for (x, y) in a.iter_mut().zip(g) {
                    *x += dq * y;
                }
            }
        }
        Ok(Some(Gradients {
            stats: StepStats {
                loss: loss * scale,
                predictions: cones.iter().map(|c| c.q).collect(),
            },
            params,
            grads,
        }))
    }

    /// Replaces the parameters of net `k` ([`Primitive::index`]) with
    /// `params`, one vector per tensor in [`param_shapes`] order.
    pub fn set_params(&mut self, k: usize, params: Vec<Vec<f32>>) -> Result<(), PolicyError> {
        let net = &self.policy.nets[k];
        for (var, (data, (_, shape))) in net
            .params
            .iter()
            .zip(params.into_iter().zip(param_shapes()))
        {
            var.set(&Tensor::from_vec(data, shape, &Device::Cpu)?)?;
        }
        Ok(())
    }

    /// [`Self::train_step`] through candle (the whole trunk, its autograd and
    /// transposed convolutions): the reference the cone's gradients are
    /// tested against. Same loss, same Adam update.
    pub fn train_step_candle(&mut self, batch: &[Experience]) -> Result<StepStats, PolicyError> {
        let Some((total, groups)) = candle_loss(&self.policy, batch)? else {
            return Ok(StepStats::nothing(batch.len()));
        };
        let grads = total.backward()?;
        self.adam.t += 1;
        let per = param_shapes().len();
        for (p, _, _) in &groups {
            let k = p.index();
            for (i, var) in self.policy.nets[k].params.iter().enumerate() {
                let Some(g) = grads.get(var.as_tensor()) else {
                    continue;
                };
                let g = g.flatten_all()?.to_vec1::<f32>()?;
                let mut data = var.as_tensor().flatten_all()?.to_vec1::<f32>()?;
                self.adam.update(k * per + i, &mut data, &g);
                var.set(&Tensor::from_vec(
                    data,
                    var.as_tensor().shape(),
                    &Device::Cpu,
                )?)?;
            }
        }
        step_stats(&total, groups, batch.len())
    }

    /// Mean Huber loss on `batch` without updating (for tests and logs).
    pub fn eval_loss(&self, batch: &[Experience]) -> Result<f32, PolicyError> {
        let prepared: Vec<Prepared> = batch.par_iter().map(prepare).collect();
        let n = NET_RESOLUTION;
        let mut sum = 0.0;
        for (e, p) in batch.iter().zip(&prepared) {
            let dev = Device::Cpu;
            let x = Tensor::from_vec(p.input.clone(), (1, INPUT_CHANNELS, n, n), &dev)?;
            let taps = Tensor::from_vec(
                p.taps.iter().map(|&c| c as u32).collect::<Vec<_>>(),
                4,
                &dev,
            )?;
            let w = Tensor::from_vec(p.weights.to_vec(), (1, 4), &dev)?;
            let q = self.policy.net(e.action.primitive).q_at(&x, &taps, &w)?;
            let t = Tensor::from_vec(vec![e.target], 1, &dev)?;
            sum += huber_tensor(&(&q - &t)?)?.sum_all()?.to_scalar::<f32>()?;
        }
        Ok(sum / batch.len().max(1) as f32)
    }

    /// Writes weights, Adam moments and step count (safetensors, checksummed).
    pub fn save_checkpoint(&self, path: &Path) -> Result<(), PolicyError> {
        let mut tensors = BTreeMap::new();
        let names = names();
        let params = vars(&self.policy);
        for (i, (name, shape)) in names.iter().enumerate() {
            let vec = |t: &Tensor| t.flatten_all().and_then(|t| t.to_vec1::<f32>());
            let f = |data| F32Tensor {
                shape: shape.clone(),
                data,
            };
            tensors.insert(name.clone(), f(vec(params[i].as_tensor())?));
            tensors.insert(format!("adam.m.{name}"), f(self.adam.m[i].clone()));
            tensors.insert(format!("adam.v.{name}"), f(self.adam.v[i].clone()));
        }
        let mut meta = BTreeMap::new();
        meta.insert("format".into(), "seespot-checkpoint".into());
        meta.insert("adam_t".into(), self.adam.t.to_string());
        meta.insert("architecture".into(), self.policy.trunk().architecture());
        meta.insert(
            "adam_config".into(),
            serde_json::to_string(&self.adam.config).unwrap_or_default(),
        );
        meta.insert(
            "policy_meta".into(),
            serde_json::to_string(&self.policy.meta).unwrap_or_default(),
        );
        tensor_file::write(path, &tensors, &meta)
    }

    /// Reads a checkpoint written by [`Learner::save_checkpoint`]; its trunk
    /// is the one its `architecture` field names, or `unnamed` in a
    /// checkpoint without one (written before trunks had names).
    pub fn load_checkpoint(path: &Path, unnamed: Trunk) -> Result<Self, PolicyError> {
        let file = tensor_file::read(path)?;
        let bad = |reason: String| PolicyError::Checkpoint {
            path: path.to_path_buf(),
            reason,
        };
        if file.metadata.get("format").map(String::as_str) != Some("seespot-checkpoint") {
            return Err(bad("not a seespot checkpoint".into()));
        }
        let meta = serde_json::from_str(file.metadata.get("policy_meta").map_or("", |s| s))
            .map_err(|e| bad(format!("policy_meta: {e}")))?;
        let config: AdamConfig =
            serde_json::from_str(file.metadata.get("adam_config").map_or("", |s| s))
                .map_err(|e| bad(format!("adam_config: {e}")))?;
        let trunk = match file.metadata.get("architecture") {
            None => unnamed,
            Some(a) => Trunk::from_architecture(a)
                .ok_or_else(|| bad(format!("architecture `{a}` is not a SPOT-Q network")))?,
        };
        let t: u64 = file
            .metadata
            .get("adam_t")
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| bad("adam_t missing".into()))?;
        let get = |name: &str, shape: &[usize]| -> Result<Tensor, PolicyError> {
            let ft = file.tensors.get(name).ok_or_else(|| PolicyError::Tensor {
                path: path.to_path_buf(),
                tensor: name.into(),
                reason: "missing".into(),
            })?;
            if ft.shape != shape {
                return Err(PolicyError::Tensor {
                    path: path.to_path_buf(),
                    tensor: name.into(),
                    reason: format!("shape {:?}, expected {shape:?}", ft.shape),
                });
            }
            Ok(Tensor::from_vec(ft.data.clone(), shape, &Device::Cpu)?)
        };
        let names = names();
        let per = param_shapes().len();
        let mut params = Vec::new();
        let (mut m, mut v) = (Vec::new(), Vec::new());
        for (name, shape) in &names {
            params.push(get(name, shape)?);
            m.push(
                get(&format!("adam.m.{name}"), shape)?
                    .flatten_all()?
                    .to_vec1::<f32>()?,
            );
            v.push(
                get(&format!("adam.v.{name}"), shape)?
                    .flatten_all()?
                    .to_vec1::<f32>()?,
            );
        }
        let place = params.split_off(per);
        let policy = PolicyNet {
            meta,
            nets: [
                crate::net::QNet::from_tensors(params, trunk)?,
                crate::net::QNet::from_tensors(place, trunk)?,
            ],
        };
        Ok(Self {
            policy,
            adam: FlatAdam { config, m, v, t },
        })
    }
}

/// Per primitive in the batch: the batch positions of its experiences and
/// their Q (a candle graph).
type Groups = Vec<(Primitive, Vec<usize>, Tensor)>;

/// The mean Huber loss of `batch` as a candle graph through the whole trunk
/// of each primitive's net, and the groups it was computed in; `None` for an
/// empty batch.
fn candle_loss(
    policy: &PolicyNet,
    batch: &[Experience],
) -> Result<Option<(Tensor, Groups)>, PolicyError> {
    let prepared: Vec<Prepared> = batch.par_iter().map(prepare).collect();
    let mut losses = Vec::new();
    let n = NET_RESOLUTION;
    let cells = FEATURE_RESOLUTION * FEATURE_RESOLUTION;
    let mut groups = Vec::new();
    for p in Primitive::ALL {
        let idx: Vec<usize> = (0..batch.len())
            .filter(|&i| batch[i].action.primitive == p)
            .collect();
        if idx.is_empty() {
            continue;
        }
        let b = idx.len();
        let mut x = Vec::with_capacity(b * INPUT_CHANNELS * n * n);
        let mut taps = Vec::with_capacity(4 * b);
        let mut w = Vec::with_capacity(4 * b);
        let mut t = Vec::with_capacity(b);
        for (k, &i) in idx.iter().enumerate() {
            x.extend_from_slice(&prepared[i].input);
            taps.extend(prepared[i].taps.iter().map(|&c| (k * cells + c) as u32));
            w.extend_from_slice(&prepared[i].weights);
            t.push(batch[i].target);
        }
        let dev = Device::Cpu;
        let x = Tensor::from_vec(x, (b, INPUT_CHANNELS, n, n), &dev)?;
        let taps = Tensor::from_vec(taps, 4 * b, &dev)?;
        let w = Tensor::from_vec(w, (b, 4), &dev)?;
        let t = Tensor::from_vec(t, b, &dev)?;
        let q = policy.net(p).q_at(&x, &taps, &w)?;
        losses.push(huber_tensor(&(&q - &t)?)?.sum_all()?);
        groups.push((p, idx, q));
    }
    let Some(first) = losses.first() else {
        return Ok(None);
    };
    let mut total = first.clone();
    for l in &losses[1..] {
        total = (total + l)?;
    }
    Ok(Some(((total / batch.len() as f64)?, groups)))
}

/// The loss and predictions of a step through [`candle_loss`].
fn step_stats(total: &Tensor, groups: Groups, len: usize) -> Result<StepStats, PolicyError> {
    let mut predictions = vec![0.0f32; len];
    for (_, idx, q) in groups {
        for (k, v) in q.to_vec1::<f32>()?.into_iter().enumerate() {
            predictions[idx[k]] = v;
        }
    }
    Ok(StepStats {
        loss: total.to_scalar::<f32>()?,
        predictions,
    })
}

/// SPOT-Q steps through candle, the whole trunk and candle's Adam: the
/// step finetuning on demonstrations takes ([`crate::finetune()`]), unchanged
/// since the committed finetuned records were made, so that they remake bit
/// for bit (the cone's step gives the same gradients up to rounding, and
/// rounding changes actions).
#[derive(Debug)]
pub struct CandleLearner {
    pub policy: PolicyNet,
    adam: Adam,
}

impl CandleLearner {
    pub fn new(policy: PolicyNet, config: AdamConfig) -> Result<Self, PolicyError> {
        let adam = Adam::new(&vars(&policy), config)?;
        Ok(Self { policy, adam })
    }

    /// One step on `batch`: the mean Huber loss through candle's autograd,
    /// one update of candle's Adam (parameters without a gradient left alone).
    pub fn train_step(&mut self, batch: &[Experience]) -> Result<StepStats, PolicyError> {
        let Some((total, groups)) = candle_loss(&self.policy, batch)? else {
            return Ok(StepStats::nothing(batch.len()));
        };
        let grads = total.backward()?;
        self.adam.step(&vars(&self.policy), &grads)?;
        step_stats(&total, groups, batch.len())
    }
}

/// Names and shapes of all parameters: grasp net then place net.
fn names() -> Vec<(String, Vec<usize>)> {
    Primitive::ALL
        .iter()
        .flat_map(|p| {
            param_shapes()
                .into_iter()
                .map(move |(n, s)| (format!("{}.{n}", p.as_str()), s))
        })
        .collect()
}

/// All parameters of both nets, grasp then place.
fn vars(policy: &PolicyNet) -> Vec<&Var> {
    policy.nets.iter().flat_map(|n| n.params.iter()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::TaskId;

    /// A step through the cone gives candle's loss and predictions to 1e-5,
    /// and moves the parameters the way candle's step moves them: Adam's first
    /// step is about `lr * sign(gradient)`, so the two agree to 1% of `lr`
    /// wherever the gradient is not vanishingly small (nine in ten
    /// parameters at least), and no parameter differs by more than 2 `lr`.
    #[test]
    fn cone_step_equals_candles_step() {
        let policy = PolicyNet::new(TaskId::Stack, 112, 9).expect("policy");
        let batch = crate::bench::fixed_batch(4);
        // Deep copies: a candle `Var` shares its storage with its clones.
        let copy = PolicyNet {
            meta: policy.meta.clone(),
            nets: [
                policy.nets[0].deep_clone().expect("copy"),
                policy.nets[1].deep_clone().expect("copy"),
            ],
        };
        let mut fast = Learner::new(copy, AdamConfig::default()).expect("learner");
        let mut slow = Learner::new(policy, AdamConfig::default()).expect("learner");
        let a = fast.train_step(&batch).expect("cone step");
        let b = slow.train_step_candle(&batch).expect("candle step");
        assert!(
            (a.loss - b.loss).abs() <= 1e-5 * b.loss.abs().max(1.0),
            "loss {} vs {}; predictions {:?} vs {:?}",
            a.loss,
            b.loss,
            a.predictions,
            b.predictions
        );
        for (p, q) in a.predictions.iter().zip(&b.predictions) {
            assert!((p - q).abs() <= 1e-5 * q.abs().max(1.0), "{p} vs {q}");
        }
        let lr = AdamConfig::default().lr as f32;
        let mut moved = 0;
        for (nf, ns) in fast.policy.nets.iter().zip(&slow.policy.nets) {
            for (pf, ps) in nf
                .to_vecs()
                .expect("f")
                .iter()
                .zip(ns.to_vecs().expect("s"))
            {
                for (x, y) in pf.iter().zip(&ps) {
                    assert!((x - y).abs() <= 2.02 * lr, "{x} vs {y}");
                    moved += usize::from((x - y).abs() <= 0.01 * lr);
                }
            }
        }
        let total: usize = names()
            .iter()
            .map(|(_, s)| s.iter().product::<usize>())
            .sum();
        assert!(moved * 10 >= total * 9, "{moved} of {total} agree");
        assert_eq!(fast.adam.t, slow.adam.t);
    }
}
