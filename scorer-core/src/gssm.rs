//! GSSM: a lognormal model of the spacing `s` a normal driver keeps in a given interaction context.
//!
//! An f32 network ([`FloatMlp`], 2 outputs) maps the context features (by convention the 12 features
//! other than `s`; the model's `inputs` list says which) to `(mu, log sigma^2)` of `ln s`. The risk of
//! an observation is the survival probability of the observed spacing,
//!
//! `F_S = 1/2 * (1 - erf((ln s - mu) / sqrt(2 sigma^2)))`,
//!
//! the probability that normal driving in this context keeps a larger spacing (high = unusually
//! tight). It is computed as `1/2 * erfc(...)` (identical in exact arithmetic; `erfc` keeps its
//! precision in the tail where `1 - erf` cancels). GSSM's intensity is `log10(max(n, 1))` with
//! `n = ln 0.5 / ln(clip(F_S, 1e-6, 1 - 1e-6))`, in `[0, log10(ln 0.5 / ln(1 - 1e-6))] ~ [0, 5.84]`.
//!
//! Guards (all results finite):
//! - `s <= 0` (boxes touch or overlap): `F_S = 1`, maximal risk.
//! - `s = +inf` or `s = NaN` (no spacing measurable, e.g. no partner): `F_S = 0`, the "no conflict"
//!   bound, consistent with NaN surrogates in [`crate::msra`].
//! - `mu` is clamped to `+-MU_LIMIT` and `log sigma^2` to `[LOG_VAR_MIN, LOG_VAR_MAX]` (NaN -> 0)
//!   before use; a trained network never reaches these bounds. The host trainer applies the same
//!   clamps.

use serde::{Deserialize, Serialize};

use crate::features::{Features, FEATURE_COUNT};
use crate::mlp::FloatMlp;
use crate::model_error::ModelError;

/// Index of the spacing feature `s` in [`Features`].
pub const S_INDEX: usize = FEATURE_COUNT - 1;
/// Lower clip of `F_S` for the intensity and the logit (upper clip is `1 - CDF_CLIP`).
pub const CDF_CLIP: f32 = 1.0e-6;
/// `mu` (log-metres) is clamped to `+-MU_LIMIT`.
pub const MU_LIMIT: f32 = 50.0;
/// Lower clamp of `log sigma^2`.
pub const LOG_VAR_MIN: f32 = -20.0;
/// Upper clamp of `log sigma^2`.
pub const LOG_VAR_MAX: f32 = 20.0;

/// Which number [`GssmModel::score`] returns (monotone in each other, so first-threshold warnings
/// are identical up to float resolution).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum GssmScore {
    /// `log10(max(n, 1))` in `[0, ~5.84]`: the GSSM baseline's risk intensity.
    Intensity,
    /// `F_S` in `[0, 1]`: the survival probability itself (SSRA's risk).
    Cdf,
    /// `ln(F / (1 - F))` of the clipped `F_S`, in `[~-13.8, ~13.8]`: SSRA's risk with resolution
    /// near 1 preserved (recommended for SSRA: `F_S` saturates at `1 - 6e-8` in f32).
    Logit,
}

impl GssmScore {
    /// The middle of the score's range, the threshold rule of thumb for a blob without a calibrated
    /// one: every mode's midpoint is a different survival probability (0.5 for `Cdf` and `Logit`,
    /// `n` ~ 830 for `Intensity`), so a fixed 0.5 would mean a different risk level per mode.
    pub fn range_midpoint(self) -> f32 {
        match self {
            // Half of `intensity(1.0)` (~5.836, see the tests).
            Self::Intensity => 2.918,
            Self::Cdf => 0.5,
            Self::Logit => 0.0,
        }
    }
}

/// A GSSM network plus the score it reports.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GssmModel<'a> {
    /// Context network with 2 outputs: `(mu, log sigma^2)` of `ln s`.
    #[serde(borrow)]
    pub net: FloatMlp<'a>,
    /// Which score [`GssmModel::score`] returns.
    pub score: GssmScore,
}

/// Clamped lognormal parameters: `mu` to `+-MU_LIMIT`, `log_var` to `[LOG_VAR_MIN, LOG_VAR_MAX]`,
/// NaN to 0.
pub fn clamp_params(mu: f32, log_var: f32) -> (f32, f32) {
    let mu = if mu.is_nan() {
        0.0
    } else {
        mu.clamp(-MU_LIMIT, MU_LIMIT)
    };
    let lv = if log_var.is_nan() {
        0.0
    } else {
        log_var.clamp(LOG_VAR_MIN, LOG_VAR_MAX)
    };
    (mu, lv)
}

/// `F_S = P(S > s)` for `ln S ~ N(mu, exp(log_var))`, with the guards of the module docs.
pub fn survival(s: f32, mu: f32, log_var: f32) -> f32 {
    if s.is_nan() || s == f32::INFINITY {
        return 0.0;
    }
    if s <= 0.0 {
        return 1.0;
    }
    let (mu, lv) = clamp_params(mu, log_var);
    let sigma = libm::expf(0.5 * lv);
    let z = (libm::logf(s) - mu) / (core::f32::consts::SQRT_2 * sigma);
    (0.5 * libm::erfcf(z)).clamp(0.0, 1.0)
}

fn clip_cdf(f_s: f32) -> f32 {
    if f_s.is_nan() {
        CDF_CLIP
    } else {
        f_s.clamp(CDF_CLIP, 1.0 - CDF_CLIP)
    }
}

/// GSSM intensity `log10(max(n, 1))`, `n = ln 0.5 / ln(clip(F_S, 1e-6, 1 - 1e-6))`; NaN -> 0.
pub fn intensity(f_s: f32) -> f32 {
    let f = clip_cdf(f_s);
    let n = -core::f32::consts::LN_2 / libm::logf(f);
    libm::log10f(n.max(1.0))
}

/// `ln(F / (1 - F))` of `clip(F_S, 1e-6, 1 - 1e-6)`; NaN -> the lower bound.
pub fn logit(f_s: f32) -> f32 {
    let f = clip_cdf(f_s);
    libm::logf(f) - libm::logf(1.0 - f)
}

impl GssmModel<'_> {
    /// The network must validate and have exactly 2 outputs.
    pub fn validate(&self) -> Result<(), ModelError> {
        self.net.validate()?;
        let n = self.net.n_outputs();
        if n != 2 {
            return Err(ModelError::DimensionMismatch {
                field: "gssm.outputs",
                index: 0,
                expected: 2,
                found: n,
            });
        }
        Ok(())
    }

    /// Clamped `(mu, log sigma^2)` for this context.
    pub fn params(&self, features: &Features) -> (f32, f32) {
        let [mu, log_var] = self.net.forward(features);
        clamp_params(mu, log_var)
    }

    /// `F_S` of the observation (spacing `features[S_INDEX]`).
    pub fn survival(&self, features: &Features) -> f32 {
        let (mu, lv) = self.params(features);
        let s = features.get(S_INDEX).copied().unwrap_or(f32::NAN);
        survival(s, mu, lv)
    }

    /// The GSSM intensity of the observation.
    pub fn intensity(&self, features: &Features) -> f32 {
        intensity(self.survival(features))
    }

    /// The model's score ([`GssmScore`]); larger is riskier; always finite.
    pub fn score(&self, features: &Features) -> f32 {
        let f = self.survival(features);
        match self.score {
            GssmScore::Intensity => intensity(f),
            GssmScore::Cdf => f,
            GssmScore::Logit => logit(f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bounded::BoundedVec;
    use crate::mlp::{FloatLayer, FloatMlp};

    fn close(a: f32, b: f64, tol: f64) -> bool {
        (f64::from(a) - b).abs() <= tol
    }

    #[test]
    fn survival_matches_hand_values() {
        // ln S ~ N(mu, sigma^2): F_S(s) = P(S > s) = Q((ln s - mu) / sigma).
        let (mu, sigma) = (2.0f32, 0.5f32);
        let lv = 2.0 * libm::logf(sigma);
        // At the median: 1/2.
        assert!(close(survival(libm::expf(mu), mu, lv), 0.5, 1e-6));
        // One sigma above: Q(1) = 0.158655254; one below: 0.841344746; two below: 0.977249868.
        assert!(close(
            survival(libm::expf(mu + sigma), mu, lv),
            0.158_655_254,
            2e-6
        ));
        assert!(close(
            survival(libm::expf(mu - sigma), mu, lv),
            0.841_344_746,
            2e-6
        ));
        assert!(close(
            survival(libm::expf(mu - 2.0 * sigma), mu, lv),
            0.977_249_868,
            2e-6
        ));
        // Deep tail keeps relative precision (erfc, not 1 - erf): Q(6) = 9.8658765e-10.
        let f = survival(libm::expf(mu + 6.0 * sigma), mu, lv);
        assert!((f64::from(f) / 9.865_876_5e-10 - 1.0).abs() < 1e-3, "{f}");
    }

    #[test]
    fn survival_guards() {
        assert_eq!(survival(0.0, 1.0, 0.0), 1.0);
        assert_eq!(survival(-3.0, 1.0, 0.0), 1.0);
        assert_eq!(survival(f32::NEG_INFINITY, 1.0, 0.0), 1.0);
        assert_eq!(survival(f32::INFINITY, 1.0, 0.0), 0.0);
        assert_eq!(survival(f32::NAN, 1.0, 0.0), 0.0);
        // Non-finite parameters are clamped, never NaN.
        for (mu, lv) in [
            (f32::NAN, 0.0),
            (0.0, f32::NAN),
            (f32::INFINITY, f32::INFINITY),
            (-1e30, -1e30),
        ] {
            let f = survival(3.0, mu, lv);
            assert!((0.0..=1.0).contains(&f), "{mu} {lv} -> {f}");
        }
        assert_eq!(clamp_params(1e9, -1e9), (MU_LIMIT, LOG_VAR_MIN));
    }

    #[test]
    fn intensity_matches_hand_values() {
        // F <= 0.5 gives n <= 1, intensity 0.
        assert_eq!(intensity(0.5), 0.0);
        assert_eq!(intensity(0.1), 0.0);
        assert_eq!(intensity(0.0), 0.0);
        // F = 0.9: n = ln 0.5 / ln 0.9 = 6.578813, log10 = 0.818146.
        assert!(close(intensity(0.9), 0.818_146, 1e-5));
        // F = 0.99: n = 68.967563, log10 = 1.838645.
        assert!(close(intensity(0.99), 1.838_645, 1e-4));
        // F = 1 clips to 1 - 1e-6 (f32: 0.99999899): n ~ 686 000, log10 ~ 5.836.
        let top = intensity(1.0);
        assert!(top > 5.8 && top < 5.85, "{top}");
        assert_eq!(intensity(f32::NAN), 0.0);
        assert!((GssmScore::Intensity.range_midpoint() - 0.5 * top).abs() < 1e-3);
        // Monotone.
        let mut prev = -1.0;
        for i in 0..=1000 {
            let v = intensity(i as f32 / 1000.0);
            assert!(v >= prev);
            prev = v;
        }
    }

    #[test]
    fn logit_values() {
        assert!(close(logit(0.5), 0.0, 1e-7));
        assert!(close(logit(0.9), 2.197_224_6, 1e-5));
        assert!(logit(1.0) > 13.0 && logit(1.0) < 13.9);
        assert!(logit(0.0) < -13.0 && logit(0.0) > -13.9);
    }

    #[test]
    fn model_uses_network_outputs_and_spacing() {
        // A network with zero weights: mu = bias0 = ln 10, log_var = bias1 = ln 0.25 (sigma 0.5).
        let w = [0u8; 4 * 2];
        let mut b = [0u8; 8];
        b[..4].copy_from_slice(&libm::logf(10.0).to_le_bytes());
        b[4..].copy_from_slice(&libm::logf(0.25).to_le_bytes());
        let mut layers = BoundedVec::new();
        layers
            .push(FloatLayer {
                out_dim: 2,
                relu: false,
                weights: &w,
                bias: &b,
            })
            .unwrap();
        let net = FloatMlp {
            inputs: BoundedVec::from_slice(&[0]).unwrap(),
            input_scale: BoundedVec::from_slice(&[1.0]).unwrap(),
            input_offset: BoundedVec::from_slice(&[0.0]).unwrap(),
            layers,
        };
        let mut g = GssmModel {
            net,
            score: GssmScore::Cdf,
        };
        g.validate().unwrap();
        let mut f = [0.0f32; FEATURE_COUNT];
        f[S_INDEX] = 10.0;
        assert!(close(g.score(&f), 0.5, 1e-6));
        // s = 10 * e^-0.5 is one sigma tight.
        f[S_INDEX] = 10.0 * libm::expf(-0.5);
        assert!(close(g.score(&f), 0.841_344_746, 2e-6));
        g.score = GssmScore::Intensity;
        // n = ln 0.5 / ln 0.841344746 = 4.0117, log10 = 0.60333
        assert!(close(g.score(&f), 0.603_33, 1e-4));
        g.score = GssmScore::Logit;
        assert!(close(g.score(&f), 1.668_1, 1e-3));
        f[S_INDEX] = 0.0;
        assert_eq!(g.survival(&f), 1.0);
    }
}
