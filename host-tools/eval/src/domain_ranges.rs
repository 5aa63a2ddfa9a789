//! The training-domain record of a model, measured on the observations its training data holds:
//! per input the model reads, the range between two quantiles of those observations.
//!
//! The inputs are computed by scorer-core (`Observation::of`, `Model::domain_inputs`), so the
//! ranges are of exactly the numbers the ECU checks. Which inputs are bounded: every input the
//! model's network reads (DRL: its selected DRL inputs; GSSM/SSRA: its context features), and for
//! MSRA all 13 features (its terms were fitted over that speed and geometry; the features feed
//! its embedded GSSM, if any). Why quantiles and not min/max: `docs/domain-guard.md`.
use scorer_core::model::{InputRange, Model, ModelError, OutsidePolicy, TrainingDomain};
use scorer_core::{Observation, VehicleState, FEATURE_COUNT};

/// Default share of the training observations left outside at each end of each range (0.1 %).
pub const DEFAULT_TAIL: f64 = 0.001;

/// Measuring a training domain failed.
#[derive(Debug, thiserror::Error)]
pub enum DomainRangesError {
    #[error("no observations to measure the training domain on")]
    NoObservations,
    #[error("tail share {0}: must be in [0, 0.5)")]
    BadTail(f64),
    #[error("the measured training domain is not a valid record: {0}")]
    Record(ModelError),
}

/// A measured training domain, owning its ranges' wire bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredDomain {
    pub policy: OutsidePolicy,
    pub range_bytes: Vec<u8>,
}

impl MeasuredDomain {
    /// The record to store in a blob.
    pub fn domain(&self) -> TrainingDomain<'_> {
        TrainingDomain::new(self.policy, &self.range_bytes)
    }
}

/// The inputs (indices into the kind's input vector) the domain of `model` bounds.
pub fn bounded_inputs(model: &Model<'_>) -> Vec<u8> {
    let all = || (0..FEATURE_COUNT as u8).collect();
    let mut inputs: Vec<u8> = match model {
        Model::DrlInt8(m) => m.inputs.to_vec(),
        Model::DrlF32(m) => m.inputs.to_vec(),
        Model::Gssm(m) => m.net.inputs.to_vec(),
        Model::Msra(_) => all(),
    };
    inputs.sort_unstable();
    inputs.dedup();
    inputs
}

/// The domain of `model` over the observations of `pairs` (ego, partner): for each bounded
/// input, `lo` the `tail` quantile and `hi` the `1 - tail` quantile (nearest rank; `tail = 0` is
/// min/max), ranges in input order, under `policy`.
pub fn measure<'p>(
    model: &Model<'_>,
    pairs: impl IntoIterator<Item = (&'p VehicleState, &'p VehicleState)>,
    tail: f64,
    policy: OutsidePolicy,
) -> Result<MeasuredDomain, DomainRangesError> {
    if !(0.0..0.5).contains(&tail) {
        return Err(DomainRangesError::BadTail(tail));
    }
    let inputs = bounded_inputs(model);
    let mut columns: Vec<Vec<f32>> = vec![Vec::new(); inputs.len()];
    for (ego, partner) in pairs {
        let observation = Observation::of(ego, partner);
        let values = model.domain_inputs(&observation);
        for (column, &input) in columns.iter_mut().zip(&inputs) {
            // The core's inputs are finite by construction; a NaN would have no rank.
            if let Some(&x) = values.get(usize::from(input)).filter(|x| !x.is_nan()) {
                column.push(x);
            }
        }
    }
    let mut range_bytes = Vec::with_capacity(inputs.len() * 9);
    for (column, &input) in columns.iter_mut().zip(&inputs) {
        let (lo, hi) = quantile_range(column, tail).ok_or(DomainRangesError::NoObservations)?;
        range_bytes.extend(InputRange { input, lo, hi }.to_bytes());
    }
    let measured = MeasuredDomain {
        policy,
        range_bytes,
    };
    measured
        .domain()
        .validate()
        .map_err(DomainRangesError::Record)?;
    Ok(measured)
}

/// The `tail` and `1 - tail` nearest-rank quantiles of `values` (sorted in place); `None` when
/// empty.
fn quantile_range(values: &mut [f32], tail: f64) -> Option<(f32, f32)> {
    values.sort_unstable_by(f32::total_cmp);
    let last = values.len().checked_sub(1)?;
    let rank = |q: f64| ((q * last as f64).round() as usize).min(last);
    Some((*values.get(rank(tail))?, *values.get(rank(1.0 - tail))?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_leave_the_tails_out_and_zero_is_min_max() {
        let mut v: Vec<f32> = (0..=1000).rev().map(|i| i as f32).collect();
        assert_eq!(quantile_range(&mut v, 0.0), Some((0.0, 1000.0)));
        assert_eq!(quantile_range(&mut v, 0.001), Some((1.0, 999.0)));
        assert_eq!(quantile_range(&mut v, 0.1), Some((100.0, 900.0)));
        assert_eq!(quantile_range(&mut [], 0.1), None);
        assert_eq!(quantile_range(&mut [3.0], 0.1), Some((3.0, 3.0)));
    }
}
