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
//!
//! Files: this one (the format: limits, layers, networks, and the primitives both paths share),
//! `validate` (the invariants checked at decode), `float` (the f32 forward pass), `int8` (the int8
//! forward pass), `kernel` (its packed fixed-point dot products and requantisation).

use serde::{Deserialize, Serialize};

use crate::bounded::BoundedVec;
use crate::features::{Features, FEATURE_COUNT};

mod float;
mod int8;
mod kernel;
mod validate;

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
    /// Indices into the input vector (the 13 features for GSSM, the 13 DRL inputs for DRL) feeding
    /// the network, in input order.
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
    /// Indices into the input vector (the 13 features for GSSM, the 13 DRL inputs for DRL) feeding
    /// the network, in input order.
    pub inputs: BoundedVec<u8, MAX_INPUTS>,
    /// Per input: folded standardisation + quantisation multiplier (see
    /// [`crate::quant::fold_standardisation`]); must be > 0.
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

fn select(features: &Features, feature: u8) -> f32 {
    features
        .get(usize::from(feature))
        .copied()
        .unwrap_or(f32::NAN)
}
