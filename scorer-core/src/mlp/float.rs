//! The f32 forward pass: selection and standardisation of the inputs, then the dense layers.
use super::{bound, f32s, select, standardise, FloatMlp, Outputs, MAX_OUTPUTS, MAX_WIDTH};
use crate::features::Features;

impl FloatMlp<'_> {
    /// Number of outputs (the last layer's width), 0 for a network without layers.
    pub fn n_outputs(&self) -> usize {
        self.layers.last().map_or(0, |l| usize::from(l.out_dim))
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
