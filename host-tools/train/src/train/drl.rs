//! DRL: the risk score is an MLP over the core's DRL input encoding (`scorer_core::encoding`: the
//! 13 inputs computed from the two states), standardised with the mean and standard deviation of
//! the training frames.
//!
//! Default shape 13-32-16-1 (ReLU hidden layers, linear output): 944 multiply-accumulates, which the
//! core's int8 network runs in well under 20k Cortex-M4 instructions per partner. The same structure
//! (standardisation folded into the input quantisation) is what scorer-core deploys.
use candle_core::{Device, Tensor, Var};
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use scorer_core::{drl_inputs, DrlInputs, DRL_INPUT_COUNT as FEATURE_COUNT};
use serde::{Deserialize, Serialize};

use super::RiskModel;
use crate::comparisons::{ObservationTable, TrainingSequence};

/// Standardisation of the DRL inputs, `z = (x - mean) / std`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureScaler {
    pub mean: Vec<f32>,
    pub std: Vec<f32>,
}

impl FeatureScaler {
    /// Mean and standard deviation of every finite DRL input over all frames of the sequences
    /// (inputs computed by scorer-core). Degenerate inputs get `std = 1`.
    pub fn fit(seqs: &[TrainingSequence]) -> FeatureScaler {
        let mut sum = [0f64; FEATURE_COUNT];
        let mut sq = [0f64; FEATURE_COUNT];
        let mut n = [0usize; FEATURE_COUNT];
        for s in seqs {
            for (e, p) in s.ego.iter().zip(&s.partner) {
                let f = drl_inputs(e, p);
                for k in 0..FEATURE_COUNT {
                    if f[k].is_finite() {
                        sum[k] += f[k] as f64;
                        sq[k] += (f[k] as f64) * (f[k] as f64);
                        n[k] += 1;
                    }
                }
            }
        }
        let mut mean = vec![0f32; FEATURE_COUNT];
        let mut std = vec![1f32; FEATURE_COUNT];
        for k in 0..FEATURE_COUNT {
            if n[k] > 0 {
                let m = sum[k] / n[k] as f64;
                let var = (sq[k] / n[k] as f64 - m * m).max(0.0);
                mean[k] = m as f32;
                let sd = var.sqrt() as f32;
                std[k] = if sd > 1e-6 { sd } else { 1.0 };
            }
        }
        FeatureScaler { mean, std }
    }

    /// `1 / std` of feature `k`: the core's `input_scale`.
    pub fn scale(&self, k: usize) -> f32 {
        1.0 / self.std[k]
    }

    /// `-mean / std` of feature `k`: the core's `input_offset`.
    pub fn offset(&self, k: usize) -> f32 {
        -self.mean[k] / self.std[k]
    }

    /// Standardised inputs, through the core's own `standardise` (NaN maps to the mean, 0).
    pub fn apply(&self, f: &DrlInputs) -> [f32; FEATURE_COUNT] {
        let mut z = [0f32; FEATURE_COUNT];
        for k in 0..FEATURE_COUNT {
            z[k] = scorer_core::mlp::standardise(f[k], self.scale(k), self.offset(k));
        }
        z
    }
}

/// One dense layer's float parameters, `weight` row-major `[outputs][inputs]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DenseLayer {
    pub inputs: usize,
    pub outputs: usize,
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
}

/// Float DRL parameters (the checkpoint content).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DrlParams {
    pub scaler: FeatureScaler,
    /// Hidden layers use ReLU, the last layer is linear with one output.
    pub layers: Vec<DenseLayer>,
}

/// The trainable DRL network.
pub struct Drl {
    pub scaler: FeatureScaler,
    layers: Vec<(Var, Var)>,
}

impl Drl {
    /// A freshly initialised network (He-uniform weights, zero biases) seeded by `seed`.
    pub fn new(scaler: FeatureScaler, hidden: &[usize], seed: u64) -> candle_core::Result<Drl> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xD41_0000);
        let mut sizes = vec![FEATURE_COUNT];
        sizes.extend_from_slice(hidden);
        sizes.push(1);
        let mut layers = Vec::new();
        for w in sizes.windows(2) {
            let (fan_in, fan_out) = (w[0], w[1]);
            let bound = (6.0 / fan_in as f32).sqrt();
            let weight: Vec<f32> = (0..fan_in * fan_out)
                .map(|_| rng.random_range(-bound..bound))
                .collect();
            let weight = Var::from_vec(weight, (fan_out, fan_in), &Device::Cpu)?;
            let bias = Var::zeros(fan_out, candle_core::DType::F32, &Device::Cpu)?;
            layers.push((weight, bias));
        }
        Ok(Drl { scaler, layers })
    }

    /// A network holding the given parameters (to continue training or to evaluate a checkpoint).
    pub fn from_params(p: &DrlParams) -> candle_core::Result<Drl> {
        let mut layers = Vec::new();
        for l in &p.layers {
            let weight = Var::from_vec(l.weight.clone(), (l.outputs, l.inputs), &Device::Cpu)?;
            let bias = Var::from_vec(l.bias.clone(), l.outputs, &Device::Cpu)?;
            layers.push((weight, bias));
        }
        Ok(Drl {
            scaler: p.scaler.clone(),
            layers,
        })
    }

    pub fn params(&self) -> candle_core::Result<DrlParams> {
        let mut layers = Vec::new();
        for (w, b) in &self.layers {
            let (outputs, inputs) = w.as_tensor().dims2()?;
            layers.push(DenseLayer {
                inputs,
                outputs,
                weight: w.as_tensor().flatten_all()?.to_vec1::<f32>()?,
                bias: b.as_tensor().to_vec1::<f32>()?,
            });
        }
        Ok(DrlParams {
            scaler: self.scaler.clone(),
            layers,
        })
    }

    /// The output of every layer (after ReLU for hidden layers) for a batch of standardised inputs,
    /// in order; the last entry is the score `[n, 1]`. Used for activation calibration.
    pub fn layer_outputs(&self, inputs: &Tensor) -> candle_core::Result<Vec<Tensor>> {
        let mut x = inputs.clone();
        let mut out = Vec::with_capacity(self.layers.len());
        let last = self.layers.len() - 1;
        for (i, (w, b)) in self.layers.iter().enumerate() {
            x = x
                .matmul(&w.as_tensor().t()?)?
                .broadcast_add(b.as_tensor())?;
            if i < last {
                x = x.relu()?;
            }
            out.push(x.clone());
        }
        Ok(out)
    }
}

impl RiskModel for Drl {
    fn name(&self) -> &str {
        "DRL"
    }

    fn input_width(&self) -> usize {
        FEATURE_COUNT
    }

    fn encode(&self, table: &ObservationTable) -> Vec<f32> {
        let mut rows = Vec::with_capacity(table.len() * FEATURE_COUNT);
        for x in &table.drl_inputs {
            rows.extend_from_slice(&self.scaler.apply(x));
        }
        rows
    }

    fn forward(&self, inputs: &Tensor) -> candle_core::Result<Tensor> {
        let outs = self.layer_outputs(inputs)?;
        match outs.last() {
            Some(score) => score.squeeze(1),
            None => Err(candle_core::Error::Msg("DRL network without layers".into())),
        }
    }

    fn vars(&self) -> Vec<Var> {
        self.layers
            .iter()
            .flat_map(|(w, b)| [w.clone(), b.clone()])
            .collect()
    }
}
