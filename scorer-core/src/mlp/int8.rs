//! The int8 forward pass: inputs quantised with the folded standardisation, layers in packed
//! fixed-point arithmetic ([`super::kernel`]), the last accumulator dequantised.
use super::kernel::{dot2, pack, requantize_centred, PackedInput};
use super::{bound, i32s, select, Outputs, QuantMlp, MAX_OUTPUTS, MAX_WIDTH};
use crate::features::Features;
use crate::quant;

impl QuantMlp<'_> {
    /// Number of outputs (the last layer's width), 0 for a network without layers.
    pub fn n_outputs(&self) -> usize {
        self.layers.last().map_or(0, |l| usize::from(l.out_dim))
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
    /// Same integer arithmetic as the definition in the module docs, bit for bit, arranged for a
    /// 32-bit MCU: activations are kept *centred* (`q - zero_point`, in `[-255, 255]`) and packed
    /// two per word (see `kernel::pack`), so the zero point is subtracted once per activation
    /// instead of once per multiply-accumulate and a word load feeds two products; output rows are
    /// computed in pairs that share those loads, and each pair is requantised as soon as its dot
    /// products are done. Only two `MAX_WIDTH / 2`-word buffers live on the stack.
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
