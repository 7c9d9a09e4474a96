//! Adam with decoupled weight decay, with its state exposed so checkpoints can
//! save and restore it bit for bit (candle-nn's `AdamW` keeps its moments private).

use candle_core::{Tensor, Var, backprop::GradStore};

/// Adam hyper-parameters.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AdamConfig {
    pub lr: f64,
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
    pub weight_decay: f64,
}

impl Default for AdamConfig {
    fn default() -> Self {
        Self {
            lr: 5e-4,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            weight_decay: 1e-5,
        }
    }
}

/// Adam state: first and second moments per parameter, and the step count.
#[derive(Clone, Debug)]
pub struct Adam {
    pub config: AdamConfig,
    pub m: Vec<Tensor>,
    pub v: Vec<Tensor>,
    pub t: u64,
}

impl Adam {
    pub fn new(vars: &[&Var], config: AdamConfig) -> candle_core::Result<Self> {
        let zeros = |v: &&Var| v.as_tensor().zeros_like();
        Ok(Self {
            config,
            m: vars.iter().map(zeros).collect::<Result<_, _>>()?,
            v: vars.iter().map(zeros).collect::<Result<_, _>>()?,
            t: 0,
        })
    }

    /// One update of `vars` (same order as at construction) from `grads`;
    /// parameters without a gradient are left alone.
    pub fn step(&mut self, vars: &[&Var], grads: &GradStore) -> candle_core::Result<()> {
        self.t += 1;
        let c = self.config;
        let bc1 = 1.0 - c.beta1.powi(self.t as i32);
        let bc2 = 1.0 - c.beta2.powi(self.t as i32);
        for (i, var) in vars.iter().enumerate() {
            let Some(g) = grads.get(var.as_tensor()) else {
                continue;
            };
            // Detach: a gradient carries the op graph of the forward pass it came
            // from, and moments built from it would chain every step's graph
            // together (memory grew ~13 MB per training step before this).
            let g = g.detach();
            let g = &g;
            let m = ((&self.m[i] * c.beta1)? + (g * (1.0 - c.beta1))?)?;
            let v = ((&self.v[i] * c.beta2)? + (g.sqr()? * (1.0 - c.beta2))?)?;
            let mhat = (&m / bc1)?;
            let vhat = (&v / bc2)?;
            let update = mhat.div(&(vhat.sqrt()? + c.eps)?)?;
            let p = var.as_tensor();
            let next = ((p * (1.0 - c.lr * c.weight_decay))? - (update * c.lr)?)?;
            var.set(&next.detach())?;
            self.m[i] = m.detach();
            self.v[i] = v.detach();
        }
        Ok(())
    }
}

/// Adam on plain `f32` vectors (the SPOT-Q learner's parameters): the same
/// update as [`Adam`], one parameter tensor at a time, with its moments kept
/// in the order the learner numbers its parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatAdam {
    pub config: AdamConfig,
    pub m: Vec<Vec<f32>>,
    pub v: Vec<Vec<f32>>,
    /// Steps taken; [`Self::update`] reads it for the bias correction, the
    /// caller counts a step once for all its tensors.
    pub t: u64,
}

impl FlatAdam {
    /// Zero moments for tensors of `sizes` elements.
    pub fn new(sizes: &[usize], config: AdamConfig) -> Self {
        Self {
            config,
            m: sizes.iter().map(|&n| vec![0.0; n]).collect(),
            v: sizes.iter().map(|&n| vec![0.0; n]).collect(),
            t: 0,
        }
    }

    /// Updates tensor `i` (`param`) from its gradient `grad` at step `t`.
    ///
    /// # Panics
    /// If `param`, `grad` and the moments of `i` differ in length.
    pub fn update(&mut self, i: usize, param: &mut [f32], grad: &[f32]) {
        let c = self.config;
        let t = self.t.max(1) as i32;
        let bc1 = (1.0 - c.beta1.powi(t)) as f32;
        let bc2 = (1.0 - c.beta2.powi(t)) as f32;
        let (b1, b2) = (c.beta1 as f32, c.beta2 as f32);
        let (lr, eps) = (c.lr as f32, c.eps as f32);
        let decay = (1.0 - c.lr * c.weight_decay) as f32;
        let (m, v) = (&mut self.m[i], &mut self.v[i]);
        assert!(
            m.len() == param.len() && grad.len() == param.len(),
            "tensor {i}: sizes differ"
        );
        for k in 0..param.len() {
            let g = grad[k];
            m[k] = b1 * m[k] + (1.0 - b1) * g;
            v[k] = b2 * v[k] + (1.0 - b2) * g * g;
            let update = (m[k] / bc1) / ((v[k] / bc2).sqrt() + eps);
            param[k] = param[k] * decay - lr * update;
        }
    }
}

/// Stochastic gradient descent with momentum and L2 weight decay, as
/// PyTorch's `torch.optim.SGD` updates (no dampening, no Nesterov): per
/// element `g += weight_decay * p; b = momentum * b + g` (`b = g` on the
/// first step) `; p -= lr * b`. The reference code finetuned with it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SgdConfig {
    pub lr: f64,
    pub momentum: f64,
    pub weight_decay: f64,
}

impl SgdConfig {
    /// The reference's finetuning optimiser (`train_offline.py`'s default
    /// learning rate, `trainer.py`'s momentum and weight decay).
    pub const REFERENCE_FINETUNE: Self = Self {
        lr: 1e-5,
        momentum: 0.9,
        weight_decay: 2e-5,
    };
}

/// [`SgdConfig`]'s update on plain `f32` vectors, with one momentum buffer
/// per parameter tensor (created at the first update of that tensor).
#[derive(Clone, Debug, PartialEq)]
pub struct FlatSgd {
    pub config: SgdConfig,
    pub momentum: Vec<Option<Vec<f32>>>,
}

impl FlatSgd {
    /// An optimiser for `tensors` parameter tensors.
    pub fn new(tensors: usize, config: SgdConfig) -> Self {
        Self {
            config,
            momentum: vec![None; tensors],
        }
    }

    /// Updates tensor `i` (`param`) from its gradient `grad`.
    ///
    /// # Panics
    /// If `param` and `grad` differ in length.
    pub fn update(&mut self, i: usize, param: &mut [f32], grad: &[f32]) {
        assert_eq!(param.len(), grad.len(), "tensor {i}: sizes differ");
        let c = self.config;
        let (lr, mu, wd) = (c.lr as f32, c.momentum as f32, c.weight_decay as f32);
        let first = self.momentum[i].is_none();
        let buf = self.momentum[i].get_or_insert_with(|| vec![0.0; param.len()]);
        for k in 0..param.len() {
            let g = grad[k] + wd * param[k];
            buf[k] = if first { g } else { mu * buf[k] + g };
            param[k] -= lr * buf[k];
        }
    }
}

#[cfg(test)]
mod sgd_tests {
    use super::*;

    /// Two steps by hand: the first sets the buffer to the decayed gradient,
    /// the second adds momentum.
    #[test]
    fn sgd_matches_pytorchs_update() {
        let config = SgdConfig {
            lr: 0.1,
            momentum: 0.5,
            weight_decay: 0.01,
        };
        let mut sgd = FlatSgd::new(1, config);
        let mut p = vec![1.0f32, -2.0];
        sgd.update(0, &mut p, &[0.5, 0.25]);
        let g1 = [0.5 + 0.01 * 1.0, 0.25 + 0.01 * -2.0];
        let p1 = [1.0 - 0.1 * g1[0], -2.0 - 0.1 * g1[1]];
        assert!((p[0] - p1[0]).abs() < 1e-6 && (p[1] - p1[1]).abs() < 1e-6);
        sgd.update(0, &mut p, &[0.0, 0.0]);
        let b2 = [0.5 * g1[0] + 0.01 * p1[0], 0.5 * g1[1] + 0.01 * p1[1]];
        assert!((p[0] - (p1[0] - 0.1 * b2[0])).abs() < 1e-6);
        assert!((p[1] - (p1[1] - 0.1 * b2[1])).abs() < 1e-6);
    }
}
