//! The invariants of both networks, checked when a model is decoded: capacities, dimensions,
//! finite bounded parameters, positive scales and canonical requantisation pairs.
use super::{f32s, i32s, FloatMlp, QuantMlp, MAX_ABS_PARAM, MAX_INPUTS, MAX_OUTPUTS, MAX_WIDTH};
use crate::bounded::BoundedVec;
use crate::features::FEATURE_COUNT;
use crate::model_error::ModelError;
use crate::quant;

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

impl FloatMlp<'_> {
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
}

impl QuantMlp<'_> {
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
}
