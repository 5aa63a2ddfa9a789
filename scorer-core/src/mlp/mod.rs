//! The DRL risk network: an int8 path (deployed) and an f32 path (parity, GSSM) over one structure.
//!
//! Structure (both paths): an *input selection* (which entries of the 13-wide input vector feed the
//! network, in which order: for DRL the [`crate::encoding`] inputs, for GSSM the features), a per-input standardisation, up to [`MAX_LAYERS`] dense layers of width at most
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

use crate::bounded::BoundedVec;
use crate::features::{Features, FEATURE_COUNT};
use crate::model_error::ModelError;
use crate::quant;

/// Maximum number of dense layers.
pub const MAX_LAYERS: usize = 4;
/// Maximum width of any layer (and of the input).
pub const MAX_WIDTH: usize = 64;
/// Maximum number of network outputs (DRL uses 1; GSSM uses 2: `mu`, `log sigma^2`).
pub const MAX_OUTPUTS: usize = 2;
/// Maximum number of selected inputs (the input vector's width: the 13 features for GSSM, the 13
/// DRL inputs of [`crate::encoding`] for DRL).
pub const MAX_INPUTS: usize = FEATURE_COUNT;
const _: () = assert!(crate::encoding::DRL_INPUT_COUNT == FEATURE_COUNT);
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
            // Rows split off a slice of 4-byte words: no runtime chunk size, so no panic path
            // (`chunks_exact(width * 4)` keeps its non-zero assertion at opt-level 3).
            let (mut rest, _) = layer.weights.as_chunks::<4>();
            let mut biases = f32s(layer.bias);
            for out in b.iter_mut().take(out_dim) {
                let Some((row, tail)) = rest.split_at_checked(width) else {
                    break;
                };
                rest = tail;
                let mut sum = biases.next().unwrap_or(0.0);
                for (w, x) in row.iter().zip(input) {
                    sum += f32::from_le_bytes(*w) * x;
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
    ///
    /// Same integer arithmetic as the definition above, bit for bit, arranged for a 32-bit MCU:
    /// activations are kept *centred* (`q - zero_point`, in `[-255, 255]`) and packed two per
    /// word (see [`pack`]), so the zero point is subtracted once per activation instead of once
    /// per multiply-accumulate and a word load feeds two products; output rows are computed in
    /// pairs that share those loads, and each pair is requantised as soon as its dot products are
    /// done. Only two `MAX_WIDTH / 2`-word buffers live on the stack.
    pub fn forward(&self, features: &Features) -> Outputs {
        let codes = self.quantize_inputs(features);
        let zp_in = i32::from(self.input_zero_point);
        let mut width = self.inputs.len().min(MAX_WIDTH);
        let mut even = [0u32; MAX_WIDTH / 2];
        let (code_pairs, _) = codes.as_chunks::<2>();
        for (word, &[q0, q1]) in even.iter_mut().zip(code_pairs).take(width.div_ceil(2)) {
            // Codes past `width` are the zero point (see `quantize_inputs`): centred 0.
            *word = pack(i32::from(q0) - zp_in, i32::from(q1) - zp_in);
        }
        let mut odd = [0u32; MAX_WIDTH / 2];
        let mut y = [0.0f32; MAX_OUTPUTS];
        let n_layers = self.layers.len();
        for (l, layer) in self.layers.iter().enumerate() {
            // Ping-pong between the two buffers (no copy between layers).
            let (input, output) = if l % 2 == 0 {
                (&even, &mut odd)
            } else {
                (&odd, &mut even)
            };
            let input = PackedInput::new(input.get(..width.div_ceil(2)).unwrap_or(&[]), width);
            // Rows of `width` weights. (Not pairs of rows: `chunks_exact(2 * width)` would keep a
            // panic path at opt-level 3, LLVM cannot rule out that the product wraps to 0.)
            let mut rows = layer.weights.chunks_exact(width.max(1));
            if l + 1 == n_layers {
                let outputs = y.iter_mut().zip(self.output_scales.iter());
                for ((o, &scale), (row, bias)) in outputs.zip(rows.zip(i32s(layer.bias))) {
                    let acc = dot2(row, row, &input).0.saturating_add(bias);
                    let mut v = acc as f32 * scale;
                    if layer.relu && v < 0.0 {
                        v = 0.0;
                    }
                    *o = bound(v);
                }
            } else {
                let zp = layer.output_zero_point;
                let zp32 = i32::from(zp);
                let bounds = (if layer.relu { 0 } else { -128 - zp32 }, 127 - zp32);
                let centred = |acc: i32, bias: i32, m: i32, s: i8| {
                    requantize_centred(acc.saturating_add(bias), m, s, zp, layer.relu, bounds)
                };
                let out_dim = usize::from(layer.out_dim).min(MAX_WIDTH);
                // Output channels in pairs (2j, 2j + 1): one packed output word per pair.
                let (bias_pairs, _) = layer.bias.as_chunks::<4>().0.as_chunks::<2>();
                let (multiplier_pairs, _) = layer.multipliers.as_chunks::<4>().0.as_chunks::<2>();
                let (shift_pairs, _) = layer.shifts.as_chunks::<2>();
                let params = bias_pairs.iter().zip(multiplier_pairs).zip(shift_pairs);
                for (word, ((bias, mult), &[s_a, s_b])) in output.iter_mut().zip(params) {
                    let (Some(row_a), Some(row_b)) = (rows.next(), rows.next()) else {
                        break;
                    };
                    let (a, b) = dot2(row_a, row_b, &input);
                    let [bias_a, bias_b] = bias.map(i32::from_le_bytes);
                    let [m_a, m_b] = mult.map(i32::from_le_bytes);
                    let a = centred(a, bias_a, m_a, s_a as i8);
                    let b = centred(b, bias_b, m_b, s_b as i8);
                    *word = pack(a.into(), b.into());
                }
                if out_dim % 2 == 1 {
                    // The unpaired last channel (its word's high half is padding: 0).
                    let j = out_dim - 1;
                    let row = layer.weights.get(j * width..(j + 1) * width).unwrap_or(&[]);
                    let bias = i32s(layer.bias.get(4 * j..).unwrap_or(&[])).next();
                    let m = i32s(layer.multipliers.get(4 * j..).unwrap_or(&[])).next();
                    let s = layer.shifts.get(j).copied();
                    if let (Some(word), Some(bias), Some(m), Some(s)) =
                        (output.get_mut(j / 2), bias, m, s)
                    {
                        *word = pack(
                            centred(dot2(row, row, &input).0, bias, m, s as i8).into(),
                            0,
                        );
                    }
                }
                width = out_dim;
            }
        }
        y
    }
}

/// Two centred activations (each in `[-32768, 32767]`) in one word: `a` in the low half, `b` in the
/// high half, each as 16-bit two's complement.
fn pack(a: i32, b: i32) -> u32 {
    (a as u32 & 0xffff) | ((b as u32) << 16)
}

/// The low half of a [`pack`]ed word, sign-extended (the M4 multiplies it in place: `SMLABB`).
#[inline(always)]
fn low(word: u32) -> i32 {
    ((word as i32) << 16) >> 16
}

/// The high half of a [`pack`]ed word, sign-extended (`SMLABT`).
#[inline(always)]
fn high(word: u32) -> i32 {
    (word as i32) >> 16
}

/// Four products: the bytes of `w` (little-endian `i8` weights, sign-extended by shifts) with the
/// activations packed in `x01`, `x23`.
#[inline(always)]
fn dot4(w: i32, x01: u32, x23: u32) -> i32 {
    ((w << 24) >> 24) * low(x01)
        + ((w << 16) >> 24) * high(x01)
        + ((w << 8) >> 24) * low(x23)
        + (w >> 24) * high(x23)
}

/// One layer's input activations as [`dot2`] consumes them: the [`pack`]ed words in steps of
/// four activations, then the (at most 3) activations left over, unpacked.
struct PackedInput<'a> {
    steps: &'a [[u32; 2]],
    tail: [i32; 3],
}

impl<'a> PackedInput<'a> {
    /// `words` holds `width` packed activations (`width.div_ceil(2)` words).
    fn new(words: &'a [u32], width: usize) -> Self {
        let (steps, rest) = words
            .split_at_checked(width / 4 * 2)
            .unwrap_or((words, &[]));
        let x01 = rest.first().copied().unwrap_or(0);
        let x23 = rest.get(1).copied().unwrap_or(0);
        Self {
            steps: steps.as_chunks::<2>().0,
            tail: [low(x01), high(x01), low(x23)],
        }
    }
}

/// The dot products of two weight rows (`i8`, as stored, `width` each) with the input; four
/// weights per row and step (one word load each).
///
/// `|w| <= 128`, `|x| <= 255` and at most [`MAX_WIDTH`] terms: `|sum| < 2^22`, no overflow.
#[inline(always)]
fn dot2(row_a: &[u8], row_b: &[u8], input: &PackedInput<'_>) -> (i32, i32) {
    let (a4, a_rest) = row_a.as_chunks::<4>();
    let (b4, b_rest) = row_b.as_chunks::<4>();
    let (mut sum_a, mut sum_b) = (0i32, 0i32);
    for ((wa, wb), &[x01, x23]) in a4.iter().zip(b4).zip(input.steps) {
        sum_a += dot4(i32::from_le_bytes(*wa), x01, x23);
        sum_b += dot4(i32::from_le_bytes(*wb), x01, x23);
    }
    for ((&wa, &wb), &x) in a_rest.iter().zip(b_rest).zip(&input.tail) {
        sum_a += i32::from(wa as i8) * x;
        sum_b += i32::from(wb as i8) * x;
    }
    (sum_a, sum_b)
}

/// `quant::requantize_to_i8(acc, multiplier, shift, zero_point, relu) - zero_point`, with a fast
/// path for the pairs a trained model holds.
///
/// Fast path (`multiplier >= 0` and `t = 31 + shift` in `33..=63`, i.e. a real multiplier below
/// 1/2): the half-away-from-zero rounding of `|acc| * multiplier / 2^t` is
/// `((magnitude >> (t - 1)) + 1) >> 1`, and as `t - 1 >= 32` the shift only sees the high word of
/// the 64-bit product (< 2^30, so nothing below overflows). Clamping the signed result to the
/// centred output range `bounds = (relu ? 0 : -128 - zp, 127 - zp)` equals the definition's
/// `clamp(saturate_i32(r) + zp, low, 127) - zp`: any result the `i32` saturation would touch is far
/// outside the `i8` range anyway.
/// Every other pair takes the definition itself.
#[inline(always)]
fn requantize_centred(
    acc: i32,
    multiplier: i32,
    shift: i8,
    zero_point: i8,
    relu: bool,
    bounds: (i32, i32),
) -> i16 {
    let high_shift = i32::from(shift) - 2; // t - 33
    if multiplier >= 0 && (0..=30).contains(&high_shift) {
        let product = u64::from(acc.unsigned_abs()) * u64::from(multiplier.unsigned_abs());
        let high = (product >> 32) as u32;
        let halves = (high >> high_shift.unsigned_abs()) as i32; // < 2^30: no overflow below
        let rounded = (halves + 1) >> 1;
        let signed = if acc < 0 { -rounded } else { rounded };
        return signed.max(bounds.0).min(bounds.1) as i16;
    }
    let q = quant::requantize_to_i8(acc, multiplier, shift, zero_point, relu);
    i16::from(q) - i16::from(zero_point)
}

#[cfg(test)]
// The reference is written with plain indices on purpose: it is the definition, not the kernel.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    #[test]
    fn centred_requantisation_matches_the_definition() {
        let accs = [
            i32::MIN,
            i32::MIN + 1,
            -1 << 30,
            -4_000_001,
            -65_536,
            -1_000,
            -3,
            -1,
            0,
            1,
            2,
            777,
            65_535,
            4_000_000,
            1 << 30,
            i32::MAX,
        ];
        let multipliers = [i32::MIN, -5, 0, 1, 1 << 30, (1 << 30) + 12_345, i32::MAX];
        let mut checked = 0u32;
        for shift in -40i8..=40 {
            for &m in &multipliers {
                for &zp in &[-128i8, -100, -1, 0, 5, 127] {
                    for relu in [false, true] {
                        let zp32 = i32::from(zp);
                        let bounds = (if relu { 0 } else { -128 - zp32 }, 127 - zp32);
                        let mut check = |acc: i32| {
                            let want = i16::from(quant::requantize_to_i8(acc, m, shift, zp, relu))
                                - i16::from(zp);
                            let got = requantize_centred(acc, m, shift, zp, relu, bounds);
                            assert_eq!(got, want, "acc {acc} m {m} shift {shift} zp {zp} {relu}");
                            checked += 1;
                        };
                        for &acc in &accs {
                            check(acc);
                        }
                        // Around every rounding tie of this (m, shift) near the clip at 256.
                        if m > 0 && (2..=32).contains(&shift) {
                            let t = 31 + u32::from(shift.unsigned_abs());
                            for k in [1i128, 3, 255, 511, 513] {
                                let tie = (k << (t - 1)) / i128::from(m);
                                for d in -2..=2 {
                                    if let Ok(acc) = i32::try_from(tie + d) {
                                        check(acc);
                                        check(acc.saturating_neg());
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 50_000);
    }

    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
        fn i32(&mut self) -> i32 {
            self.next() as i32
        }
    }

    /// The int8 forward pass written as plainly as its definition (module docs).
    fn reference_forward(m: &QuantMlp<'_>, features: &Features) -> Outputs {
        let mut act = m.quantize_inputs(features);
        let mut zp = i32::from(m.input_zero_point);
        let mut width = m.inputs.len();
        let mut y = [0.0f32; MAX_OUTPUTS];
        let word = |b: &[u8], j: usize| i32::from_le_bytes(b[4 * j..4 * j + 4].try_into().unwrap());
        for (l, layer) in m.layers.iter().enumerate() {
            let out = usize::from(layer.out_dim);
            let mut next = [0i8; MAX_WIDTH];
            for j in 0..out {
                let mut acc = 0i32;
                for i in 0..width {
                    acc += i32::from(layer.weights[j * width + i] as i8) * (i32::from(act[i]) - zp);
                }
                let acc = acc.saturating_add(word(layer.bias, j));
                if l + 1 == m.layers.len() {
                    let mut v = acc as f32 * m.output_scales[j];
                    if layer.relu && v < 0.0 {
                        v = 0.0;
                    }
                    y[j] = bound(v);
                } else {
                    next[j] = quant::requantize_to_i8(
                        acc,
                        word(layer.multipliers, j),
                        layer.shifts[j] as i8,
                        layer.output_zero_point,
                        layer.relu,
                    );
                }
            }
            act = next;
            zp = i32::from(layer.output_zero_point);
            width = out;
        }
        y
    }

    #[test]
    fn int8_forward_matches_the_plain_definition_for_any_shape() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut weights = [[0u8; MAX_WIDTH * MAX_WIDTH]; MAX_LAYERS];
        let mut biases = [[0u8; 4 * MAX_WIDTH]; MAX_LAYERS];
        let mut multipliers = [[0u8; 4 * MAX_WIDTH]; MAX_LAYERS];
        let mut shifts = [[0u8; MAX_WIDTH]; MAX_LAYERS];
        for case in 0..400 {
            let n_inputs = 1 + rng.below(MAX_INPUTS);
            let n_layers = 1 + rng.below(MAX_LAYERS);
            let mut dims = [0usize; MAX_LAYERS];
            for (l, d) in dims.iter_mut().enumerate().take(n_layers) {
                *d = if l + 1 == n_layers {
                    1 + rng.below(MAX_OUTPUTS)
                } else if case % 2 == 0 {
                    1 + rng.below(MAX_WIDTH)
                } else {
                    1 + rng.below(9)
                };
            }
            let mut inputs = [0u8; MAX_INPUTS];
            let mut input_mul = [0f32; MAX_INPUTS];
            let mut input_add = [0f32; MAX_INPUTS];
            for k in 0..n_inputs {
                inputs[k] = rng.below(FEATURE_COUNT) as u8;
                input_mul[k] = 0.01 + rng.below(1000) as f32 * 0.1;
                input_add[k] = rng.below(200) as f32 - 100.0;
            }
            let mut in_dim = n_inputs;
            let mut layers = BoundedVec::<QuantLayer<'_>, MAX_LAYERS>::new();
            for l in 0..n_layers {
                let out = dims[l];
                for b in weights[l].iter_mut().take(out * in_dim) {
                    *b = rng.next() as u8;
                }
                for j in 0..out {
                    let bias = match rng.below(8) {
                        0 => i32::MAX - rng.below(100) as i32,
                        1 => i32::MIN + rng.below(100) as i32,
                        _ => rng.i32() >> (8 + rng.below(20)),
                    };
                    biases[l][4 * j..4 * j + 4].copy_from_slice(&bias.to_le_bytes());
                    let (m, s) = match rng.below(10) {
                        0 => (rng.i32(), rng.i32() as i8),
                        1 => (rng.i32(), -32 + rng.below(4) as i8),
                        _ => (
                            quant::MULTIPLIER_MIN + rng.below(1 << 30) as i32,
                            rng.below(40) as i8 - 4,
                        ),
                    };
                    multipliers[l][4 * j..4 * j + 4].copy_from_slice(&m.to_le_bytes());
                    shifts[l][j] = s as u8;
                }
                in_dim = out;
            }
            for l in 0..n_layers {
                let in_dim = if l == 0 { n_inputs } else { dims[l - 1] };
                let out = dims[l];
                let last = l + 1 == n_layers;
                let layer = QuantLayer {
                    out_dim: out as u16,
                    relu: rng.below(2) == 0,
                    weights: &weights[l][..out * in_dim],
                    bias: &biases[l][..4 * out],
                    multipliers: if last {
                        &[]
                    } else {
                        &multipliers[l][..4 * out]
                    },
                    shifts: if last { &[] } else { &shifts[l][..out] },
                    output_zero_point: if last { 0 } else { rng.next() as i8 },
                };
                assert!(layers.push(layer).is_ok());
            }
            let scales = [0.001f32, 0.5];
            let mlp = QuantMlp {
                inputs: BoundedVec::from_slice(&inputs[..n_inputs]).unwrap(),
                input_mul: BoundedVec::from_slice(&input_mul[..n_inputs]).unwrap(),
                input_add: BoundedVec::from_slice(&input_add[..n_inputs]).unwrap(),
                input_zero_point: rng.next() as i8,
                layers,
                output_scales: BoundedVec::from_slice(&scales[..dims[n_layers - 1]]).unwrap(),
            };
            for _ in 0..20 {
                let mut features = [0f32; FEATURE_COUNT];
                for f in features.iter_mut() {
                    *f = match rng.below(20) {
                        0 => f32::NAN,
                        1 => f32::INFINITY,
                        _ => (rng.below(4000) as f32 - 2000.0) * 0.05,
                    };
                }
                let (got, want) = (mlp.forward(&features), reference_forward(&mlp, &features));
                assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "case {case}");
            }
        }
    }
}
