//! The dense ReLU network DRL and the GSSM train: `candle_nn::Linear` layers whose parameters live
//! in a `candle_nn::VarMap`, started from our own seeded values.
//!
//! `Linear::forward` on a `[n, in]` batch is `x.matmul(w.t()) + b` with `w` stored `[out, in]`, the
//! op order the hand-built layers used before, so trained parameters are bit-identical. Candle's
//! `Init` draws from an unseeded RNG, so the initial values are drawn here (He-uniform from a
//! `ChaCha8Rng`) and put into the `VarMap` before `candle_nn::linear` looks the names up.
use candle_core::{DType, Device, Module, Tensor, Var};
use candle_nn::{Linear, VarBuilder, VarMap};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// One dense layer's float parameters, `weight` row-major `[outputs][inputs]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DenseLayer {
    pub inputs: usize,
    pub outputs: usize,
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
}

/// How to draw a fresh network's parameters.
#[derive(Clone, Copy, Debug)]
pub struct Init<'a> {
    /// Factor on the He-uniform bound `sqrt(6 / fan_in)` of the last layer (1 = plain He-uniform).
    pub last_weight_scale: f32,
    /// Biases of the last layer (`None`: zeros, like every hidden layer).
    pub last_bias: Option<&'a [f32]>,
}

impl Default for Init<'_> {
    fn default() -> Self {
        Init {
            last_weight_scale: 1.0,
            last_bias: None,
        }
    }
}

/// Fresh layers of widths `sizes` (`[inputs, hidden.., outputs]`): weights uniform in
/// `+-sqrt(6 / fan_in)` (times `init.last_weight_scale` on the last layer) drawn from `rng` layer
/// by layer in row-major order, biases zero (or `init.last_bias` on the last layer).
pub fn init_layers(sizes: &[usize], rng: &mut ChaCha8Rng, init: Init<'_>) -> Vec<DenseLayer> {
    let n = sizes.len().saturating_sub(1);
    let mut layers = Vec::with_capacity(n);
    for (i, w) in sizes.windows(2).enumerate() {
        let (fan_in, fan_out) = (w[0], w[1]);
        let last = i + 1 == n;
        let scale = if last { init.last_weight_scale } else { 1.0 };
        let bound = (6.0 / fan_in as f32).sqrt() * scale;
        let weight: Vec<f32> = (0..fan_in * fan_out)
            .map(|_| rng.random_range(-bound..bound))
            .collect();
        let bias = match init.last_bias {
            Some(b) if last => b.to_vec(),
            _ => vec![0.0; fan_out],
        };
        layers.push(DenseLayer {
            inputs: fan_in,
            outputs: fan_out,
            weight,
            bias,
        });
    }
    layers
}

/// A trainable dense network: ReLU after every layer but the last, which is linear.
pub struct Mlp {
    varmap: VarMap,
    layers: Vec<Linear>,
    /// The variables in layer order (weight, bias, weight, ...): the `VarMap` itself is unordered.
    vars: Vec<Var>,
}

fn layer_name(i: usize) -> String {
    format!("layer{i}")
}

impl Mlp {
    /// A network holding the given parameters (fresh ones from [`init_layers`], or a checkpoint's).
    pub fn from_layers(params: &[DenseLayer]) -> candle_core::Result<Mlp> {
        let dev = Device::Cpu;
        let varmap = VarMap::new();
        let mut vars = Vec::with_capacity(2 * params.len());
        {
            let mut data = varmap
                .data()
                .lock()
                .map_err(|_| candle_core::Error::Msg("VarMap lock poisoned".into()))?;
            for (i, l) in params.iter().enumerate() {
                let weight = Var::from_vec(l.weight.clone(), (l.outputs, l.inputs), &dev)?;
                let bias = Var::from_vec(l.bias.clone(), l.outputs, &dev)?;
                data.insert(format!("{}.weight", layer_name(i)), weight.clone());
                data.insert(format!("{}.bias", layer_name(i)), bias.clone());
                vars.push(weight);
                vars.push(bias);
            }
        }
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &dev);
        let layers = params
            .iter()
            .enumerate()
            .map(|(i, l)| candle_nn::linear(l.inputs, l.outputs, vb.pp(layer_name(i))))
            .collect::<candle_core::Result<Vec<_>>>()?;
        Ok(Mlp {
            varmap,
            layers,
            vars,
        })
    }

    /// The current parameters, layer by layer.
    pub fn layers(&self) -> candle_core::Result<Vec<DenseLayer>> {
        self.layers
            .iter()
            .map(|l| {
                let (outputs, inputs) = l.weight().dims2()?;
                let bias = match l.bias() {
                    Some(b) => b.to_vec1::<f32>()?,
                    None => vec![0.0; outputs],
                };
                Ok(DenseLayer {
                    inputs,
                    outputs,
                    weight: l.weight().flatten_all()?.to_vec1::<f32>()?,
                    bias,
                })
            })
            .collect()
    }

    /// The trainable variables, in layer order.
    pub fn vars(&self) -> Vec<Var> {
        self.vars.clone()
    }

    /// The `VarMap` holding the variables (`layer{i}.weight`, `layer{i}.bias`).
    pub fn varmap(&self) -> &VarMap {
        &self.varmap
    }

    /// The output of every layer (after ReLU for hidden layers) for a batch `[n, inputs]`, in
    /// order; the last entry is the network output.
    pub fn layer_outputs(&self, inputs: &Tensor) -> candle_core::Result<Vec<Tensor>> {
        let mut x = inputs.clone();
        let mut out = Vec::with_capacity(self.layers.len());
        let last = self.layers.len().saturating_sub(1);
        for (i, layer) in self.layers.iter().enumerate() {
            x = layer.forward(&x)?;
            if i < last {
                x = x.relu()?;
            }
            out.push(x.clone());
        }
        Ok(out)
    }

    /// The network output `[n, outputs]` for a batch `[n, inputs]`.
    pub fn forward(&self, inputs: &Tensor) -> candle_core::Result<Tensor> {
        match self.layer_outputs(inputs)?.pop() {
            Some(out) => Ok(out),
            None => Err(candle_core::Error::Msg("network without layers".into())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn params_round_trip_through_the_varmap() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let bias = [0.5f32, -2.0];
        let init = Init {
            last_weight_scale: 0.1,
            last_bias: Some(&bias),
        };
        let layers = init_layers(&[5, 4, 2], &mut rng, init);
        assert_eq!(layers[1].bias, bias);
        assert!(layers[0].bias.iter().all(|&b| b == 0.0));
        let bound = (6.0f32 / 4.0).sqrt() * 0.1;
        assert!(layers[1].weight.iter().all(|w| w.abs() <= bound));
        let mlp = Mlp::from_layers(&layers).unwrap();
        assert_eq!(mlp.layers().unwrap(), layers);
        assert_eq!(mlp.vars().len(), 4);
        assert_eq!(mlp.varmap().all_vars().len(), 4);
    }

    #[test]
    fn forward_is_the_hand_written_dense_relu_network() {
        let layers = vec![
            DenseLayer {
                inputs: 2,
                outputs: 2,
                weight: vec![1.0, -1.0, 0.5, 2.0],
                bias: vec![0.0, -1.0],
            },
            DenseLayer {
                inputs: 2,
                outputs: 1,
                weight: vec![3.0, -1.0],
                bias: vec![0.25],
            },
        ];
        let mlp = Mlp::from_layers(&layers).unwrap();
        let x = Tensor::from_vec(vec![1.0f32, 2.0, -1.0, 0.0], (2, 2), &Device::Cpu).unwrap();
        let out: Vec<f32> = mlp
            .forward(&x)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        // Row 1: hidden relu(-1, 3.5) = (0, 3.5) -> -3.5 + 0.25. Row 2: relu(-1, -1.5) = 0 -> 0.25.
        assert_eq!(out, vec![-3.25, 0.25]);
    }

    #[test]
    fn training_updates_are_seen_by_the_layers() {
        let mlp = Mlp::from_layers(&[DenseLayer {
            inputs: 1,
            outputs: 1,
            weight: vec![1.0],
            bias: vec![0.0],
        }])
        .unwrap();
        let vars = mlp.vars();
        vars[0]
            .set(&Tensor::from_vec(vec![4.0f32], (1, 1), &Device::Cpu).unwrap())
            .unwrap();
        assert_eq!(mlp.layers().unwrap()[0].weight, vec![4.0]);
    }
}
