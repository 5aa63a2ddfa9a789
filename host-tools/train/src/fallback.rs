//! Fitting a model's kinematic fallback (record tag 3, `docs/domain-guard.md`): the kinematic
//! terms of an MSRA (TTC2D, TAdv, EI, TAdv-corridor; a GSSM term is dropped: GSSM is learned and has a domain of
//! its own), put on the model's score scale by the affine map `scale * R + offset` that matches
//! the mean and the spread of the model's own scores on the training frames inside its domain
//! (the standardised major axis of the two scores: `scale = sd(model) / sd(R)`, the line through
//! both means; refused when the two are not positively correlated).
//!
//! Inside its domain the model is trusted; that is where the two scores can be compared. The map
//! makes one threshold serve both: a frame outside scores what the kinematic terms say, in the
//! units the model's threshold was set in. Every score comes from scorer-core
//! (`Observation::of`, `Model::score_observation`, `KinematicFallback::msra`).
use scorer_core::model::kinematic_fallback::term_to_bytes;
use scorer_core::model::{KinematicFallback, ModelBlob, TrainingDomain};
use scorer_core::msra::MsraTerm;
use scorer_core::{Observation, SurrogateKind, VehicleState};

/// Fitting a fallback failed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FallbackError {
    #[error("the MSRA has no kinematic term (TTC2D, TAdv or EI) to fall back to")]
    NoKinematicTerm,
    #[error(
        "{inside} training frames inside the domain: at least {MIN_FRAMES} are needed to align the \
         fallback with the model"
    )]
    TooFewFrames { inside: usize },
    #[error(
        "the kinematic score does not vary over the {inside} training frames inside the domain: \
         nothing to align"
    )]
    ConstantKinematicScore { inside: usize },
    #[error(
        "the model's scores fall as the kinematic score rises (slope {slope}) over the {inside} \
         training frames inside the domain: the fallback would invert the ranking"
    )]
    NotIncreasing { slope: f64, inside: usize },
}

/// Fewest in-domain frames an alignment is fitted on.
pub const MIN_FRAMES: usize = 20;

/// A fitted fallback, owning its terms' wire bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct FittedFallback {
    pub scale: f32,
    pub offset: f32,
    pub term_bytes: Vec<u8>,
    /// Training frames inside the domain the map was fitted on.
    pub frames: usize,
    /// Squared correlation of the two scores on those frames (how well a line relates them).
    pub r_squared: f64,
}

impl FittedFallback {
    /// The record to store in a blob.
    pub fn record(&self) -> KinematicFallback<'_> {
        KinematicFallback::new(self.scale, self.offset, &self.term_bytes)
    }
}

/// The kinematic terms of `terms` (GSSM terms dropped), as record bytes.
pub fn kinematic_term_bytes(terms: &[MsraTerm]) -> Result<Vec<u8>, FallbackError> {
    let bytes: Vec<u8> = terms
        .iter()
        .filter(|t| t.kind != SurrogateKind::Gssm)
        .flat_map(term_to_bytes)
        .collect();
    if bytes.is_empty() {
        return Err(FallbackError::NoKinematicTerm);
    }
    Ok(bytes)
}

/// The fallback of `model` over the kinematic `terms`, aligned on the frames of `pairs` that lie
/// inside `domain` (the record the model will carry).
pub fn fit<'p>(
    model: &ModelBlob<'_>,
    domain: &TrainingDomain<'_>,
    terms: &[MsraTerm],
    pairs: impl IntoIterator<Item = (&'p VehicleState, &'p VehicleState)>,
) -> Result<FittedFallback, FallbackError> {
    let term_bytes = kinematic_term_bytes(terms)?;
    let unit = KinematicFallback::new(1.0, 0.0, &term_bytes);
    let mut sums = MeanLine::default();
    for (ego, partner) in pairs {
        let o = Observation::of(ego, partner);
        if domain.first_outside_of(&model.model, &o).is_none() {
            sums.add(
                f64::from(unit.msra(&o.surrogates)),
                f64::from(model.model.score_observation(&o)),
            );
        }
    }
    let inside = sums.n;
    if inside < MIN_FRAMES {
        return Err(FallbackError::TooFewFrames { inside });
    }
    let (slope, intercept, r_squared) = sums
        .solve()
        .ok_or(FallbackError::ConstantKinematicScore { inside })?;
    if slope <= 0.0 {
        return Err(FallbackError::NotIncreasing { slope, inside });
    }
    Ok(FittedFallback {
        scale: slope as f32,
        offset: intercept as f32,
        term_bytes,
        frames: inside,
        r_squared,
    })
}

/// Running sums of a line `y = slope x + intercept` through two samples' means, centred on the
/// first point so that large offsets do not cancel.
#[derive(Default)]
struct MeanLine {
    n: usize,
    origin: (f64, f64),
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
    syy: f64,
}

impl MeanLine {
    fn add(&mut self, x: f64, y: f64) {
        if self.n == 0 {
            self.origin = (x, y);
        }
        let (x, y) = (x - self.origin.0, y - self.origin.1);
        self.n += 1;
        self.sx += x;
        self.sy += y;
        self.sxx += x * x;
        self.sxy += x * y;
        self.syy += y * y;
    }

    /// `(slope, intercept, r^2)`; `None` when `x` does not vary.
    fn solve(&self) -> Option<(f64, f64, f64)> {
        let n = self.n as f64;
        let vxx = self.sxx - self.sx * self.sx / n;
        let vxy = self.sxy - self.sx * self.sy / n;
        let vyy = self.syy - self.sy * self.sy / n;
        if vxx <= 1e-12 * n {
            return None;
        }
        // The standardised major axis: the spread ratio, signed by the correlation. Ordinary
        // least squares (`vxy / vxx`) shrinks the slope by the correlation, so a weakly
        // correlated fallback would be squeezed towards the mean and might never reach the
        // model's threshold (docs/domain-guard.md).
        let slope = vxy.signum() * (vyy / vxx).sqrt();
        let intercept = (self.sy - slope * self.sx) / n + self.origin.1 - slope * self.origin.0;
        let r_squared = if vyy > 0.0 {
            vxy * vxy / (vxx * vyy)
        } else {
            1.0
        };
        Some((slope, intercept, r_squared))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_is_recovered_far_from_the_origin_and_keeps_the_spread() {
        let mut ls = MeanLine::default();
        for i in 0..100 {
            let x = 1000.0 + f64::from(i) * 0.01;
            ls.add(x, 3.0 * x - 2500.0);
        }
        let (slope, intercept, r2) = ls.solve().unwrap();
        assert!((slope - 3.0).abs() < 1e-9, "{slope}");
        assert!((intercept + 2500.0).abs() < 1e-6, "{intercept}");
        assert!((r2 - 1.0).abs() < 1e-9);
        // Noisy y: the slope is the spread ratio signed by the correlation (-0.6 here):
        // -sd(y) / sd(x) = -2, not the shrunk least-squares slope -0.6 * 2 = -1.2.
        let mut noisy = MeanLine::default();
        for i in 0..1000 {
            let x = f64::from(i % 2);
            let y = if (i / 2) % 5 == 0 {
                2.0 * x
            } else {
                2.0 * (1.0 - x)
            };
            noisy.add(x, y);
        }
        let (slope, _, r2) = noisy.solve().unwrap();
        assert!((r2 - 0.36).abs() < 1e-9, "{r2}");
        assert!(slope < 0.0 && (slope + 2.0).abs() < 1e-9, "{slope}");
        let mut flat = MeanLine::default();
        for _ in 0..5 {
            flat.add(2.0, 1.0);
        }
        assert!(flat.solve().is_none());
    }
}
