//! Post-training int8 quantisation of a DRL network, through the core's own quantisation functions.
//!
//! Scheme (the one `scorer_core::mlp::QuantMlp` runs, conventions in `scorer_core::quant`):
//! - input tensor: asymmetric int8 per tensor over the calibrated range of the standardised DRL inputs;
//!   the standardisation is folded into the input quantisation (`quant::fold_standardisation`);
//! - weights: symmetric int8 per output channel (`quant::symmetric_scale`, `quant::quantize_weight`);
//! - biases: int32 in the accumulator scale `s_in * s_w[j]` (`quant::quantize_bias`);
//! - hidden activations: asymmetric int8 per tensor over the calibrated post-ReLU range, reached by
//!   `quant::quantize_multiplier(s_in * s_w[j] / s_out)` and the core's `requantize`;
//! - the output layer is not requantised: its accumulator is dequantised by `s_in * s_w[j]`.
//!
//! Calibration ([`calibrate`]) runs the float network on training observations and records, per
//! tensor, the range of its values: the `[p, 1 - p]` quantiles with `p = clip_fraction` (0 = min/max).
//! [`verify`] then runs the resulting core `QuantMlp` on observations and compares it with the float
//! network run by the core's `FloatMlp`.
use candle_core::{Device, Tensor};
use scorer_core::mlp::{FloatLayer, FloatMlp, QuantLayer, QuantMlp};
use scorer_core::model::BoundedVec;
use scorer_core::{quant, DrlInputs, DRL_INPUT_COUNT as FEATURE_COUNT};
use serde::{Deserialize, Serialize};

use crate::train::drl::{DenseLayer, Drl, DrlParams, FeatureScaler};

/// Value range of one tensor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Range {
    pub min: f32,
    pub max: f32,
}

/// Calibrated ranges: the standardised input tensor and each hidden layer's (post-ReLU) output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    pub input: Range,
    pub hidden: Vec<Range>,
    /// Number of observations the ranges were measured on.
    pub observations: usize,
    /// Fraction clipped at each end of every tensor's distribution.
    pub clip_fraction: f64,
}

/// Quantisation failures.
#[derive(Debug, thiserror::Error)]
pub enum QuantizeError {
    #[error("calibration needs at least one observation")]
    NoCalibrationData,
    #[error(
        "the network has {layers} layers but the calibration has ranges for {ranges} hidden layers"
    )]
    CalibrationMismatch { layers: usize, ranges: usize },
    #[error("the network does not fit the core: {0}")]
    Core(scorer_core::model::ModelError),
    #[error("tensor computation failed: {0}")]
    Candle(#[from] candle_core::Error),
}

/// `[p, 1 - p]` quantiles of finite `values` (sorted in place).
fn quantile_range(values: &mut [f32], clip_fraction: f64) -> Range {
    if values.is_empty() {
        return Range { min: 0.0, max: 0.0 };
    }
    values.sort_by(f32::total_cmp);
    let n = values.len();
    let k = ((n as f64) * clip_fraction).floor() as usize;
    let k = k.min((n - 1) / 2);
    Range {
        min: values[k],
        max: values[n - 1 - k],
    }
}

/// Measure activation ranges of `params` on `observations` (DRL inputs computed by scorer-core).
pub fn calibrate(
    params: &DrlParams,
    observations: &[DrlInputs],
    clip_fraction: f64,
) -> Result<Calibration, QuantizeError> {
    if observations.is_empty() {
        return Err(QuantizeError::NoCalibrationData);
    }
    let drl = Drl::from_params(params)?;
    let mut rows = Vec::with_capacity(observations.len() * FEATURE_COUNT);
    for f in observations {
        rows.extend_from_slice(&drl.scaler.apply(f));
    }
    let mut input: Vec<f32> = rows.iter().copied().filter(|v| v.is_finite()).collect();
    let x = Tensor::from_vec(rows, (observations.len(), FEATURE_COUNT), &Device::Cpu)?;
    let outs = drl.layer_outputs(&x)?;
    let mut hidden = Vec::new();
    for t in outs.iter().take(outs.len().saturating_sub(1)) {
        let mut v: Vec<f32> = t
            .flatten_all()?
            .to_vec1::<f32>()?
            .into_iter()
            .filter(|v| v.is_finite())
            .collect();
        hidden.push(quantile_range(&mut v, clip_fraction));
    }
    Ok(Calibration {
        input: quantile_range(&mut input, clip_fraction),
        hidden,
        observations: observations.len(),
        clip_fraction,
    })
}

/// One int8 layer with owned byte buffers in the core's layout.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantisedLayer {
    pub out_dim: u16,
    pub relu: bool,
    /// `out_dim * in_dim` `i8` (as bytes), row-major.
    pub weights: Vec<u8>,
    /// `out_dim` little-endian `i32`.
    pub bias: Vec<u8>,
    /// Hidden layers: `out_dim` little-endian `i32`; last layer: empty.
    pub multipliers: Vec<u8>,
    /// Hidden layers: `out_dim` `i8`; last layer: empty.
    pub shifts: Vec<u8>,
    pub output_zero_point: i8,
}

/// An int8 DRL network with owned buffers; [`QuantisedDrl::as_core`] borrows it as the core's
/// `QuantMlp`.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantisedDrl {
    pub inputs: Vec<u8>,
    pub input_mul: Vec<f32>,
    pub input_add: Vec<f32>,
    pub input_zero_point: i8,
    /// Scale of the int8 input tensor (of the standardised DRL inputs).
    pub input_scale: f32,
    pub layers: Vec<QuantisedLayer>,
    pub output_scales: Vec<f32>,
}

impl QuantisedDrl {
    /// The core's view of this network (validated).
    pub fn as_core(&self) -> Result<QuantMlp<'_>, QuantizeError> {
        let mut layers = Vec::with_capacity(self.layers.len());
        for l in &self.layers {
            layers.push(QuantLayer {
                out_dim: l.out_dim,
                relu: l.relu,
                weights: &l.weights,
                bias: &l.bias,
                multipliers: &l.multipliers,
                shifts: &l.shifts,
                output_zero_point: l.output_zero_point,
            });
        }
        let mlp = QuantMlp {
            inputs: bounded(&self.inputs)?,
            input_mul: bounded(&self.input_mul)?,
            input_add: bounded(&self.input_add)?,
            input_zero_point: self.input_zero_point,
            layers: bounded(&layers)?,
            output_scales: bounded(&self.output_scales)?,
        };
        mlp.validate().map_err(QuantizeError::Core)?;
        Ok(mlp)
    }

    /// Parameter bytes (weights, biases, requantisation) the ECU stores.
    pub fn parameter_bytes(&self) -> usize {
        self.layers
            .iter()
            .map(|l| l.weights.len() + l.bias.len() + l.multipliers.len() + l.shifts.len())
            .sum::<usize>()
            + 8 * self.input_mul.len()
            + 4 * self.output_scales.len()
    }

    /// Multiply-accumulates per scored partner.
    pub fn macs(&self) -> usize {
        self.layers.iter().map(|l| l.weights.len()).sum()
    }
}

fn bounded<T: Clone, const N: usize>(items: &[T]) -> Result<BoundedVec<T, N>, QuantizeError> {
    BoundedVec::from_slice(items).map_err(QuantizeError::Core)
}

/// Owned little-endian buffers of a float network in the core's `FloatMlp` layout.
#[derive(Clone, Debug, PartialEq)]
pub struct FloatBuffers {
    pub inputs: Vec<u8>,
    pub input_scale: Vec<f32>,
    pub input_offset: Vec<f32>,
    /// `(out_dim, relu, weights, bias)` per layer.
    pub layers: Vec<(u16, bool, Vec<u8>, Vec<u8>)>,
}

impl FloatBuffers {
    /// The buffers of a dense network reading the features `inputs` (in network-input order),
    /// standardised by `scaler`, through `layers` (ReLU on all but the last).
    pub fn new(inputs: &[u8], scaler: &FeatureScaler, layers: &[DenseLayer]) -> FloatBuffers {
        let last = layers.len().saturating_sub(1);
        FloatBuffers {
            inputs: inputs.to_vec(),
            input_scale: inputs.iter().map(|&k| scaler.scale(k as usize)).collect(),
            input_offset: inputs.iter().map(|&k| scaler.offset(k as usize)).collect(),
            layers: layers
                .iter()
                .enumerate()
                .map(|(i, l)| {
                    (
                        l.outputs as u16,
                        i < last,
                        l.weight.iter().flat_map(|w| w.to_le_bytes()).collect(),
                        l.bias.iter().flat_map(|b| b.to_le_bytes()).collect(),
                    )
                })
                .collect(),
        }
    }

    /// The buffers of a float DRL network (all DRL inputs in order).
    pub fn from_params(p: &DrlParams) -> FloatBuffers {
        let inputs: Vec<u8> = (0..FEATURE_COUNT as u8).collect();
        FloatBuffers::new(&inputs, &p.scaler, &p.layers)
    }

    /// The core's view (validated).
    pub fn as_core(&self) -> Result<FloatMlp<'_>, QuantizeError> {
        let layers: Vec<FloatLayer<'_>> = self
            .layers
            .iter()
            .map(|(out_dim, relu, w, b)| FloatLayer {
                out_dim: *out_dim,
                relu: *relu,
                weights: w,
                bias: b,
            })
            .collect();
        let mlp = FloatMlp {
            inputs: bounded(&self.inputs)?,
            input_scale: bounded(&self.input_scale)?,
            input_offset: bounded(&self.input_offset)?,
            layers: bounded(&layers)?,
        };
        mlp.validate().map_err(QuantizeError::Core)?;
        Ok(mlp)
    }
}

/// Below this span (in standard deviations) the calibrated range of the standardised inputs is
/// too narrow to quantise over.
///
/// Inputs that do not vary standardise to `x - mean`, which is 0 up to round-off (±2.4e-7 on one
/// safe event followed at constant speed); the range is also this narrow when the few values that
/// do vary fall outside the `[p, 1 - p]` quantiles the calibration keeps (`clip_fraction`).
/// Quantised over such a range, the int8 step (`span / 255`, 1.9e-9) folded into the
/// standardisation gave offsets of 2.4e9, beyond the core's parameter limit, and the export
/// failed (`NonFinite { field: "input_add", index: 0 }`). [`input_range`] widens it.
pub const MIN_INPUT_SPAN: f32 = 1e-3;

/// The range the standardised inputs are quantised over: the calibrated one, or, when that is
/// narrower than [`MIN_INPUT_SPAN`], the calibrated one widened to include `[-1, 1]`, so the
/// folded standardisation stays within the core's limits and no calibrated value is clipped
/// (a narrow range away from zero is kept inside, not replaced).
pub fn input_range(measured: Range) -> Range {
    if measured.max - measured.min < MIN_INPUT_SPAN {
        Range {
            min: measured.min.min(-1.0),
            max: measured.max.max(1.0),
        }
    } else {
        measured
    }
}

/// Quantise a float DRL network with the calibrated ranges.
pub fn quantize(params: &DrlParams, cal: &Calibration) -> Result<QuantisedDrl, QuantizeError> {
    let n_layers = params.layers.len();
    if cal.hidden.len() + 1 != n_layers {
        return Err(QuantizeError::CalibrationMismatch {
            layers: n_layers,
            ranges: cal.hidden.len(),
        });
    }
    let input = input_range(cal.input);
    let (in_scale, in_zp) = quant::asymmetric_params(input.min, input.max);
    let mut input_mul = Vec::with_capacity(FEATURE_COUNT);
    let mut input_add = Vec::with_capacity(FEATURE_COUNT);
    for k in 0..FEATURE_COUNT {
        let (mul, add) = quant::fold_standardisation(
            params.scaler.mean[k],
            params.scaler.std[k],
            in_scale,
            in_zp,
        );
        input_mul.push(mul);
        input_add.push(add);
    }
    let mut layers = Vec::with_capacity(n_layers);
    let mut output_scales = Vec::new();
    let mut s_in = in_scale;
    for (i, l) in params.layers.iter().enumerate() {
        let last = i + 1 == n_layers;
        let mut weights = Vec::with_capacity(l.outputs * l.inputs);
        let mut bias = Vec::with_capacity(4 * l.outputs);
        let mut w_scales = Vec::with_capacity(l.outputs);
        for j in 0..l.outputs {
            let row = &l.weight[j * l.inputs..(j + 1) * l.inputs];
            let max_abs = row.iter().fold(0f32, |m, w| m.max(w.abs()));
            let s_w = quant::symmetric_scale(max_abs);
            w_scales.push(s_w);
            weights.extend(row.iter().map(|&w| quant::quantize_weight(w, s_w) as u8));
            bias.extend_from_slice(&quant::quantize_bias(l.bias[j], s_in * s_w).to_le_bytes());
        }
        if last {
            output_scales = w_scales.iter().map(|&s_w| s_in * s_w).collect();
            layers.push(QuantisedLayer {
                out_dim: l.outputs as u16,
                relu: false,
                weights,
                bias,
                multipliers: Vec::new(),
                shifts: Vec::new(),
                output_zero_point: 0,
            });
        } else {
            let r = cal.hidden[i];
            let (s_out, zp_out) = quant::asymmetric_params(r.min, r.max);
            let mut multipliers = Vec::with_capacity(4 * l.outputs);
            let mut shifts = Vec::with_capacity(l.outputs);
            for &s_w in &w_scales {
                let (m, s) = quant::quantize_multiplier(s_in * s_w / s_out);
                multipliers.extend_from_slice(&m.to_le_bytes());
                shifts.push(s as u8);
            }
            layers.push(QuantisedLayer {
                out_dim: l.outputs as u16,
                relu: true,
                weights,
                bias,
                multipliers,
                shifts,
                output_zero_point: zp_out,
            });
            s_in = s_out;
        }
    }
    let q = QuantisedDrl {
        inputs: (0..FEATURE_COUNT as u8).collect(),
        input_mul,
        input_add,
        input_zero_point: in_zp,
        input_scale: in_scale,
        layers,
        output_scales,
    };
    q.as_core()?;
    Ok(q)
}

/// Agreement of the int8 network with the float one, both run by scorer-core.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Agreement {
    pub observations: usize,
    pub max_abs_error: f32,
    pub mean_abs_error: f32,
    /// Spread (standard deviation) of the float scores, to read the errors against.
    pub float_std: f32,
    /// Pearson correlation between float and int8 scores.
    pub correlation: f64,
}

/// Score `observations` with the core's `FloatMlp` and `QuantMlp` and compare.
pub fn verify(
    params: &DrlParams,
    q: &QuantisedDrl,
    observations: &[DrlInputs],
) -> Result<Agreement, QuantizeError> {
    let fb = FloatBuffers::from_params(params);
    let float = fb.as_core()?;
    let int8 = q.as_core()?;
    let pairs: Vec<(f64, f64)> = observations
        .iter()
        .map(|f| (float.forward(f)[0] as f64, int8.forward(f)[0] as f64))
        .collect();
    let n = pairs.len();
    if n == 0 {
        return Ok(Agreement::default());
    }
    let nf = n as f64;
    let (mut max_abs, mut sum_abs) = (0f64, 0f64);
    let (mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0f64, 0f64, 0f64, 0f64, 0f64);
    for &(x, y) in &pairs {
        let e = (x - y).abs();
        max_abs = max_abs.max(e);
        sum_abs += e;
        sx += x;
        sy += y;
        sxx += x * x;
        syy += y * y;
        sxy += x * y;
    }
    let vx = (sxx / nf - (sx / nf).powi(2)).max(0.0);
    let vy = (syy / nf - (sy / nf).powi(2)).max(0.0);
    let cov = sxy / nf - (sx / nf) * (sy / nf);
    let correlation = if vx > 0.0 && vy > 0.0 {
        cov / (vx.sqrt() * vy.sqrt())
    } else {
        1.0
    };
    Ok(Agreement {
        observations: n,
        max_abs_error: max_abs as f32,
        mean_abs_error: (sum_abs / nf) as f32,
        float_std: vx.sqrt() as f32,
        correlation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_narrow_input_range_is_widened_around_its_values_not_replaced() {
        // Away from zero: [-1, 1] alone would clip every calibrated value to 1.
        let narrow = Range {
            min: 2.0,
            max: 2.0005,
        };
        let widened = input_range(narrow);
        assert_eq!(
            widened,
            Range {
                min: -1.0,
                max: 2.0005
            }
        );
        assert!(widened.min <= narrow.min && narrow.max <= widened.max);
        assert!(widened.max - widened.min >= MIN_INPUT_SPAN);
        // Constant inputs (0 up to round-off) get [-1, 1], as before.
        let constant = Range {
            min: -2.4e-7,
            max: 2.4e-7,
        };
        assert_eq!(
            input_range(constant),
            Range {
                min: -1.0,
                max: 1.0
            }
        );
        // A range that is wide enough is kept as calibrated.
        let wide = Range { min: 2.0, max: 2.5 };
        assert_eq!(input_range(wide), wide);
    }
}
