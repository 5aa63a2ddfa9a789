//! The DRL risk network: an int8 path (deployed) and an f32 path (parity, GSSM) over one structure.
//!
//! Structure (both paths): a *feature selection* (which of the 13 features feed the input, in which
//! order), a per-input standardisation, up to [`MAX_LAYERS`] dense layers of width at most
//! [`MAX_WIDTH`], each optionally followed by ReLU, and 1 or [`MAX_OUTPUTS`] outputs. Only stack
//! buffers of `MAX_WIDTH` activations are used. Parameters are borrowed little-endian byte slices
//! (`&'a [u8]`) straight out of the model blob, read with `chunks_exact`/`get`, never indexed.
//!
//! Weight layout: row-major `[out_dim][in_dim]`, where `in_dim` is the previous layer's `out_dim`
//! (the number of selected inputs for the first layer). Sums run over inputs in index order, so the
//! f32 path gives the same bits on every IEEE-754 target (Rust never contracts `a * b + c` to FMA).
//!
//! Float path ([`FloatMlp`]): `z_i = x_i * input_scale_i + input_offset_i` (i.e. `(x - mean)/std`),
//! `NaN -> 0` (the training mean), then every activation (including `z`) is clamped to
//! `+-ACTIVATION_LIMIT`. With every parameter bounded by [`MAX_ABS_PARAM`] (checked at decode) the
//! output is always finite.
//!
//! Int8 path ([`QuantMlp`], conventions in [`crate::quant`]): `q_i = quantize_input(x_i, input_mul_i,
//! input_add_i, input_zero_point)`; each layer computes `acc_j = bias_j + sum_i w_ji * (q_i - zp_in)`
//! in `i32`; hidden layers requantise with their per-channel `(multiplier_j, shift_j)` and output
//! zero point (fused ReLU clamps at the zero point); the last layer is not requantised: its
//! accumulator is dequantised to `f32` as `acc_j * output_scales_j` (`= input_scale * weight_scale_j`),
//! then ReLU if flagged. The output is finite for every input.

use serde::{Deserialize, Serialize};

use crate::features::{Features, FEATURE_COUNT};
use crate::model::{BoundedVec, ModelError};
use crate::quant;

/// Maximum number of dense layers.
pub const MAX_LAYERS: usize = 4;
/// Maximum width of any layer (and of the input).
pub const MAX_WIDTH: usize = 64;
/// Maximum number of network outputs (DRL uses 1; GSSM uses 2: `mu`, `log sigma^2`).
pub const MAX_OUTPUTS: usize = 2;
/// Maximum number of selected input features.
pub const MAX_INPUTS: usize = FEATURE_COUNT;
/// Largest magnitude accepted for any float parameter (weights, biases, standardisation, scales).
pub const MAX_ABS_PARAM: f32 = 1.0e9;
/// Every f32 activation (standardised inputs included) is clamped to `+-ACTIVATION_LIMIT`, which with
/// [`MAX_ABS_PARAM`] keeps every sum of [`MAX_WIDTH`] products far below `f32::MAX`.
pub const ACTIVATION_LIMIT: f32 = 1.0e18;

/// Network outputs; entries past [`FloatMlp::n_outputs`] / [`QuantMlp::n_outputs`] are 0.
pub type Outputs = [f32; MAX_OUTPUTS];

/// One dense f32 layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FloatLayer<'a> {
    /// Number of outputs of this layer (1..=MAX_WIDTH).
    pub out_dim: u16,
    /// Apply ReLU after the affine map.
    pub relu: bool,
    /// `out_dim * in_dim` little-endian `f32`, row-major `[out][in]`.
    #[serde(borrow)]
    pub weights: &'a [u8],
    /// `out_dim` little-endian `f32`.
    #[serde(borrow)]
    pub bias: &'a [u8],
}

/// The f32 network: standardisation then dense layers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FloatMlp<'a> {
    /// Feature indices (into the 13 features) feeding the input, in input order.
    pub inputs: BoundedVec<u8, MAX_INPUTS>,
    /// Per input: `1 / std` of the feature (must be > 0).
    pub input_scale: BoundedVec<f32, MAX_INPUTS>,
    /// Per input: `-mean / std` of the feature.
    pub input_offset: BoundedVec<f32, MAX_INPUTS>,
    /// The dense layers, first to last.
    #[serde(borrow)]
    pub layers: BoundedVec<FloatLayer<'a>, MAX_LAYERS>,
}

/// One dense int8 layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuantLayer<'a> {
    /// Number of outputs of this layer (1..=MAX_WIDTH).
    pub out_dim: u16,
    /// Fused ReLU (hidden: clamp at the output zero point; last: `max(0, y)` after dequantisation).
    pub relu: bool,
    /// `out_dim * in_dim` `i8`, row-major `[out][in]`, symmetric per output channel.
    #[serde(borrow)]
    pub weights: &'a [u8],
    /// `out_dim` little-endian `i32`, in the accumulator scale.
    #[serde(borrow)]
    pub bias: &'a [u8],
    /// Hidden layers: `out_dim` little-endian `i32` Q31 multipliers. Last layer: empty.
    #[serde(borrow)]
    pub multipliers: &'a [u8],
    /// Hidden layers: `out_dim` `i8` right shifts. Last layer: empty.
    #[serde(borrow)]
    pub shifts: &'a [u8],
    /// Hidden layers: zero point of the int8 output activations. Last layer: unused (write 0).
    pub output_zero_point: i8,
}

/// The deployed int8 network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuantMlp<'a> {
    /// Feature indices (into the 13 features) feeding the input, in input order.
    pub inputs: BoundedVec<u8, MAX_INPUTS>,
    /// Per input: folded standardisation + quantisation multiplier (see
    /// [`quant::fold_standardisation`]); must be > 0.
    pub input_mul: BoundedVec<f32, MAX_INPUTS>,
    /// Per input: folded offset (includes the input zero point).
    pub input_add: BoundedVec<f32, MAX_INPUTS>,
    /// Zero point of the int8 input tensor.
    pub input_zero_point: i8,
    /// The dense layers, first to last.
    #[serde(borrow)]
    pub layers: BoundedVec<QuantLayer<'a>, MAX_LAYERS>,
    /// Per output: dequantisation scale of the last accumulator (must be > 0).
    pub output_scales: BoundedVec<f32, MAX_OUTPUTS>,
}

// ---------------------------------------------------------------------------------------------
// Little-endian readers (never panic: a short slice yields fewer values).

fn f32s(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes
        .chunks_exact(4)
        .map(|c| c.try_into().map_or(0.0, f32::from_le_bytes))
}

fn i32s(bytes: &[u8]) -> impl Iterator<Item = i32> + '_ {
    bytes
        .chunks_exact(4)
        .map(|c| c.try_into().map_or(0, i32::from_le_bytes))
}

/// Clamps an activation into `+-ACTIVATION_LIMIT`; NaN (impossible for a validated model) becomes 0.
fn bound(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-ACTIVATION_LIMIT, ACTIVATION_LIMIT)
    }
}

/// Standardises one raw feature for the f32 path: `x * scale + offset`, NaN -> 0, bounded.
pub fn standardise(x: f32, scale: f32, offset: f32) -> f32 {
    if x.is_nan() {
        return 0.0;
    }
    bound(x * scale + offset)
}

// ---------------------------------------------------------------------------------------------
// Validation helpers shared by both paths.

fn check_param(v: f32, field: &'static str, index: usize) -> Result<(), ModelError> {
    if v.is_finite() && v.abs() <= MAX_ABS_PARAM {
        Ok(())
    } else {
        Err(ModelError::NonFinite { field, index })
    }
}

fn check_scale(v: f32, field: &'static str, index: usize) -> Result<(), ModelError> {
    check_param(v, field, index)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(ModelError::NonPositiveScale { field, index })
    }
}

fn check_len(
    field: &'static str,
    index: usize,
    expected: usize,
    found: usize,
) -> Result<(), ModelError> {
    if expected == found {
        Ok(())
    } else {
        Err(ModelError::DimensionMismatch {
            field,
            index,
            expected,
            found,
        })
    }
}

fn check_inputs(inputs: &BoundedVec<u8, MAX_INPUTS>) -> Result<(), ModelError> {
    inputs.check_capacity("inputs")?;
    if inputs.is_empty() {
        return Err(ModelError::Empty { field: "inputs" });
    }
    for (index, &feature) in inputs.iter().enumerate() {
        if usize::from(feature) >= FEATURE_COUNT {
            return Err(ModelError::BadFeatureIndex { index, feature });
        }
    }
    Ok(())
}

fn check_out_dim(field: &'static str, out_dim: u16, last: bool) -> Result<usize, ModelError> {
    let out = usize::from(out_dim);
    let max = if last { MAX_OUTPUTS } else { MAX_WIDTH };
    if out == 0 {
        return Err(ModelError::Empty { field });
    }
    if out > max {
        return Err(ModelError::CapacityExceeded {
            field,
            len: out,
            max,
        });
    }
    Ok(out)
}

fn select(features: &Features, feature: u8) -> f32 {
    features
        .get(usize::from(feature))
        .copied()
        .unwrap_or(f32::NAN)
}

// ---------------------------------------------------------------------------------------------

impl FloatMlp<'_> {
    /// Number of outputs (the last layer's width), 0 for a network without layers.
    pub fn n_outputs(&self) -> usize {
        self.layers.last().map_or(0, |l| usize::from(l.out_dim))
    }

    /// Checks every invariant `forward` relies on for a finite result: capacities, dimensions,
    /// finite bounded parameters, positive input scales.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_inputs(&self.inputs)?;
        self.input_scale.check_capacity("input_scale")?;
        self.input_offset.check_capacity("input_offset")?;
        self.layers.check_capacity("layers")?;
        check_len("input_scale", 0, self.inputs.len(), self.input_scale.len())?;
        check_len(
            "input_offset",
            0,
            self.inputs.len(),
            self.input_offset.len(),
        )?;
        for (i, &s) in self.input_scale.iter().enumerate() {
            check_scale(s, "input_scale", i)?;
        }
        for (i, &o) in self.input_offset.iter().enumerate() {
            check_param(o, "input_offset", i)?;
        }
        if self.layers.is_empty() {
            return Err(ModelError::Empty { field: "layers" });
        }
        let mut in_dim = self.inputs.len();
        let n_layers = self.layers.len();
        for (l, layer) in self.layers.iter().enumerate() {
            let out = check_out_dim("layers.out_dim", layer.out_dim, l + 1 == n_layers)?;
            check_len("layers.weights", l, out * in_dim * 4, layer.weights.len())?;
            check_len("layers.bias", l, out * 4, layer.bias.len())?;
            for (i, w) in f32s(layer.weights).enumerate() {
                check_param(w, "layers.weights", i)?;
            }
            for (i, b) in f32s(layer.bias).enumerate() {
                check_param(b, "layers.bias", i)?;
            }
            in_dim = out;
        }
        Ok(())
    }

    /// Standardised network input for `features` (selection, standardisation, NaN -> 0, bounded).
    pub fn standardised_inputs(&self, features: &Features) -> [f32; MAX_WIDTH] {
        let mut z = [0.0f32; MAX_WIDTH];
        let params = self
            .inputs
            .iter()
            .zip(self.input_scale.iter().zip(self.input_offset.iter()));
        for (slot, (&feature, (&scale, &offset))) in z.iter_mut().zip(params) {
            *slot = standardise(select(features, feature), scale, offset);
        }
        z
    }

    /// Runs the network on the 13 features. Finite for every input when the model validates.
    pub fn forward(&self, features: &Features) -> Outputs {
        let mut a = self.standardised_inputs(features);
        let mut b = [0.0f32; MAX_WIDTH];
        let mut width = self.inputs.len().min(MAX_WIDTH);
        for layer in self.layers.iter() {
            let out_dim = usize::from(layer.out_dim).min(MAX_WIDTH);
            let input = a.get(..width).unwrap_or(&[]);
            let rows = layer.weights.chunks_exact((width * 4).max(1));
            let mut biases = f32s(layer.bias);
            for (out, row) in b.iter_mut().take(out_dim).zip(rows) {
                let mut sum = biases.next().unwrap_or(0.0);
                for (w, x) in f32s(row).zip(input) {
                    sum += w * x;
                }
                if layer.relu && sum < 0.0 {
                    sum = 0.0;
                }
                *out = bound(sum);
            }
            core::mem::swap(&mut a, &mut b);
            width = out_dim;
        }
        let mut y = [0.0f32; MAX_OUTPUTS];
        for (o, v) in y.iter_mut().zip(a.iter().take(width)) {
            *o = *v;
        }
        y
    }
}

impl QuantMlp<'_> {
    /// Number of outputs (the last layer's width), 0 for a network without layers.
    pub fn n_outputs(&self) -> usize {
        self.layers.last().map_or(0, |l| usize::from(l.out_dim))
    }

    /// Checks capacities, dimensions, finite bounded float parameters, positive scales and canonical
    /// requantisation pairs.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_inputs(&self.inputs)?;
        self.input_mul.check_capacity("input_mul")?;
        self.input_add.check_capacity("input_add")?;
        self.layers.check_capacity("layers")?;
        self.output_scales.check_capacity("output_scales")?;
        check_len("input_mul", 0, self.inputs.len(), self.input_mul.len())?;
        check_len("input_add", 0, self.inputs.len(), self.input_add.len())?;
        for (i, &s) in self.input_mul.iter().enumerate() {
            check_scale(s, "input_mul", i)?;
        }
        for (i, &o) in self.input_add.iter().enumerate() {
            check_param(o, "input_add", i)?;
        }
        if self.layers.is_empty() {
            return Err(ModelError::Empty { field: "layers" });
        }
        let mut in_dim = self.inputs.len();
        let n_layers = self.layers.len();
        for (l, layer) in self.layers.iter().enumerate() {
            let last = l + 1 == n_layers;
            let out = check_out_dim("layers.out_dim", layer.out_dim, last)?;
            check_len("layers.weights", l, out * in_dim, layer.weights.len())?;
            check_len("layers.bias", l, out * 4, layer.bias.len())?;
            if last {
                check_len("layers.multipliers", l, 0, layer.multipliers.len())?;
                check_len("layers.shifts", l, 0, layer.shifts.len())?;
                check_len("output_scales", 0, out, self.output_scales.len())?;
            } else {
                check_len("layers.multipliers", l, out * 4, layer.multipliers.len())?;
                check_len("layers.shifts", l, out, layer.shifts.len())?;
                for (channel, (m, &s)) in i32s(layer.multipliers).zip(layer.shifts).enumerate() {
                    let shift = s as i8;
                    if !quant::is_valid_multiplier(m, shift) {
                        return Err(ModelError::BadMultiplier {
                            layer: l,
                            channel,
                            multiplier: m,
                            shift,
                        });
                    }
                }
            }
            in_dim = out;
        }
        for (i, &s) in self.output_scales.iter().enumerate() {
            check_scale(s, "output_scales", i)?;
        }
        Ok(())
    }

    /// The int8 input codes for `features` (selection, folded standardisation, rounding, clamping).
    pub fn quantize_inputs(&self, features: &Features) -> [i8; MAX_WIDTH] {
        let mut q = [self.input_zero_point; MAX_WIDTH];
        let params = self
            .inputs
            .iter()
            .zip(self.input_mul.iter().zip(self.input_add.iter()));
        for (slot, (&feature, (&mul, &add))) in q.iter_mut().zip(params) {
            *slot =
                quant::quantize_input(select(features, feature), mul, add, self.input_zero_point);
        }
        q
    }

    /// Runs the int8 network on the 13 features; the outputs are dequantised `f32`, always finite.
    pub fn forward(&self, features: &Features) -> Outputs {
        let mut a = self.quantize_inputs(features);
        let mut b = [0i8; MAX_WIDTH];
        let mut zp_in = i32::from(self.input_zero_point);
        let mut width = self.inputs.len().min(MAX_WIDTH);
        let mut y = [0.0f32; MAX_OUTPUTS];
        let n_layers = self.layers.len();
        for (l, layer) in self.layers.iter().enumerate() {
            let out_dim = usize::from(layer.out_dim).min(MAX_WIDTH);
            // Centre the inputs once per layer: q - zp_in in [-255, 255].
            let mut centred = [0i32; MAX_WIDTH];
            for (c, &q) in centred.iter_mut().zip(a.iter()).take(width) {
                *c = i32::from(q) - zp_in;
            }
            let input = centred.get(..width).unwrap_or(&[]);
            let rows = layer.weights.chunks_exact(width.max(1));
            let mut biases = i32s(layer.bias);
            let mut accumulators = [0i32; MAX_WIDTH];
            for (acc, row) in accumulators.iter_mut().take(out_dim).zip(rows) {
                // |w| <= 128, |q - zp| <= 255, width <= 64: the dot product fits i32 easily.
                let mut dot: i32 = 0;
                for (&w, &c) in row.iter().zip(input) {
                    dot += i32::from(w as i8) * c;
                }
                *acc = dot.saturating_add(biases.next().unwrap_or(0));
            }
            if l + 1 == n_layers {
                for ((o, &acc), &scale) in y
                    .iter_mut()
                    .zip(accumulators.iter())
                    .zip(self.output_scales.iter())
                {
                    let mut v = acc as f32 * scale;
                    if layer.relu && v < 0.0 {
                        v = 0.0;
                    }
                    *o = bound(v);
                }
            } else {
                let requant = i32s(layer.multipliers).zip(layer.shifts.iter());
                for ((out, &acc), (m, &s)) in b
                    .iter_mut()
                    .zip(accumulators.iter())
                    .take(out_dim)
                    .zip(requant)
                {
                    *out = quant::requantize_to_i8(
                        acc,
                        m,
                        s as i8,
                        layer.output_zero_point,
                        layer.relu,
                    );
                }
                core::mem::swap(&mut a, &mut b);
                zp_in = i32::from(layer.output_zero_point);
                width = out_dim;
            }
        }
        y
    }
}
