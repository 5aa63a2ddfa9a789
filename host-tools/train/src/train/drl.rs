//! DRL: the risk score is an MLP over the core's DRL input encoding (`scorer_core::encoding`: the
//! 13 inputs computed from the two states), standardised with the mean and standard deviation of
//! the training frames.
//!
//! Default shape 13-32-16-1 (ReLU hidden layers, linear output): 944 multiply-accumulates, which the
//! core's int8 network runs in well under 20k Cortex-M4 instructions per partner. The same structure
//! (standardisation folded into the input quantisation) is what scorer-core deploys.
use candle_core::{Tensor, Var};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use scorer_core::{drl_inputs, DrlInputs, DRL_INPUT_COUNT as FEATURE_COUNT};
use serde::{Deserialize, Serialize};

use super::model::RiskModel;
use riskscore_data::events::Sequence;

use crate::comparisons::ObservationTable;
use crate::nn::mlp::{init_layers, Init, Mlp};

/// Standardisation of the DRL inputs, `z = (x - mean) / std`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureScaler {
    pub mean: Vec<f32>,
    pub std: Vec<f32>,
}

impl FeatureScaler {
    /// Mean and standard deviation of every finite DRL input over all frames of the sequences
    /// (inputs computed by scorer-core). Degenerate inputs get `std = 1`.
    pub fn fit(seqs: &[Sequence]) -> FeatureScaler {
        let mut sum = [0f64; FEATURE_COUNT];
        let mut sq = [0f64; FEATURE_COUNT];
        let mut n = [0usize; FEATURE_COUNT];
        for s in seqs {
            for (e, p) in s.frames.iter().map(|f| (&f.ego, &f.partner)) {
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

pub use crate::nn::DenseLayer;

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
    mlp: Mlp,
}

impl Drl {
    /// A freshly initialised network (He-uniform weights, zero biases) seeded by `seed`.
    pub fn new(scaler: FeatureScaler, hidden: &[usize], seed: u64) -> candle_core::Result<Drl> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xD41_0000);
        let mut sizes = vec![FEATURE_COUNT];
        sizes.extend_from_slice(hidden);
        sizes.push(1);
        let layers = init_layers(&sizes, &mut rng, Init::default());
        Drl::from_params(&DrlParams { scaler, layers })
    }

    /// A network holding the given parameters (to continue training or to evaluate a checkpoint).
    pub fn from_params(p: &DrlParams) -> candle_core::Result<Drl> {
        Ok(Drl {
            scaler: p.scaler.clone(),
            mlp: Mlp::from_layers(&p.layers)?,
        })
    }

    pub fn params(&self) -> candle_core::Result<DrlParams> {
        Ok(DrlParams {
            scaler: self.scaler.clone(),
            layers: self.mlp.layers()?,
        })
    }

    /// The output of every layer (after ReLU for hidden layers) for a batch of standardised inputs,
    /// in order; the last entry is the score `[n, 1]`. Used for activation calibration.
    pub fn layer_outputs(&self, inputs: &Tensor) -> candle_core::Result<Vec<Tensor>> {
        self.mlp.layer_outputs(inputs)
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
        self.mlp.forward(inputs)?.squeeze(1)
    }

    fn vars(&self) -> Vec<Var> {
        self.mlp.vars()
    }
}
