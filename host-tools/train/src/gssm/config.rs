//! GSSM / SSRA / MSRA-with-GSSM hyper-parameters (TOML; every key optional with the documented
//! default, unknown keys rejected). The comparison objective, comparisons and the validation split
//! are the shared ones of [`crate::train::TrainConfig`].
use std::path::Path;

use scorer_core::SurrogateKind;
use serde::{Deserialize, Serialize};

use crate::train::config::{
    check_at_most, check_hidden, check_non_negative, parse_toml, read_toml, ConfigFileError,
    HiddenLayersError, InvalidConfig, MAX_EPOCHS,
};

/// Lognormal NLL training of the GSSM on safe-driving observations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitConfig {
    /// Hidden widths of the context encoder (ReLU). The output layer has the 2 heads `mu`,
    /// `log sigma^2`. The core runs at most 4 layers of width <= 64, so at most 3 hidden layers.
    pub hidden: Vec<usize>,
    pub learning_rate: f64,
    pub weight_decay: f64,
    /// Observations per mini-batch.
    pub batch: usize,
    pub max_epochs: usize,
    /// Early stopping on the validation NLL (safe frames of the held-out training events).
    pub patience: usize,
    pub min_delta: f64,
    /// Weight of the smoothness regulariser (0 = off): KL divergence between the predicted
    /// lognormals at `x` and at `x + noise`.
    pub smoothness: f32,
    /// Standard deviation of the perturbation, in standardised feature units.
    pub smoothness_noise: f32,
}

impl Default for FitConfig {
    fn default() -> Self {
        FitConfig {
            hidden: vec![16, 16],
            learning_rate: 3e-3,
            weight_decay: 1e-4,
            batch: 512,
            max_epochs: 80,
            patience: 10,
            min_delta: 1e-4,
            smoothness: 1.0,
            smoothness_noise: 0.05,
        }
    }
}

/// Which GSSM score SSRA reports (and exports).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SsraScore {
    /// `ln(F / (1 - F))` of the clipped `F_S` (default: keeps resolution near `F_S = 1`).
    #[default]
    Logit,
    /// `F_S` itself.
    Cdf,
}

/// SSRA: fine-tuning every GSSM parameter under the comparison objective.
///
/// The pair term is the shared source-weighted Bradley-Terry loss. The anchoring terms are the
/// shared ones too, but with SSRA's own weights and targets, on SSRA's training scale (the
/// log-compressed logit of `F_S`, see `GssmNet::score`): the shared targets are set for DRL's
/// unbounded scale, and a GSSM fitted on safe driving starts with late conflict frames at training
/// scores of 50 or more, whose squared anchoring errors would swamp the pair term at the shared
/// weights. With small weights (0.05) they do what matters for deployment: they draw conflict
/// states from the saturated tail back inside the range the deployed logit resolves
/// (`|logit| <= 13.8`, i.e. training scores <= 9.1), with `r* = 6` (`F_S ~ 0.9997`) and `u = 4`
/// (`F_S ~ 0.993`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SsraConfig {
    pub score: SsraScore,
    /// Small: alignment should move the distribution, not forget it.
    pub learning_rate: f64,
    /// SSRA's own AdamW weight decay, in place of `optimiser.weight_decay`: decoupled decay pulls
    /// every parameter towards 0, which for a fine-tune is towards forgetting the fitted GSSM.
    pub weight_decay: f64,
    pub max_epochs: usize,
    pub patience: usize,
    /// Weight of the impact anchoring term for SSRA.
    pub lambda_impact: f32,
    /// Weight of the upper-bound term for SSRA.
    pub lambda_upper: f32,
    /// Impact target on the training scale (6.0 ~ `F_S = 0.9999`).
    pub r_star: f32,
    /// Upper bound for earlier conflict states on the training scale (4.0 ~ `F_S = 0.99`).
    pub u: f32,
}

impl Default for SsraConfig {
    fn default() -> Self {
        SsraConfig {
            score: SsraScore::Logit,
            learning_rate: 1e-3,
            weight_decay: 1e-4,
            max_epochs: 30,
            patience: 6,
            lambda_impact: 0.05,
            lambda_upper: 0.05,
            r_star: 6.0,
            u: 4.0,
        }
    }
}

impl SsraConfig {
    /// The shared objective with SSRA's anchoring weights and targets.
    pub fn objective(&self) -> crate::train::config::ObjectiveConfig {
        crate::train::config::ObjectiveConfig {
            lambda_impact: self.lambda_impact,
            lambda_upper: self.lambda_upper,
            r_star: self.r_star,
            u: self.u,
        }
    }
}

/// MSRA over surrogates that include the GSSM (frozen; its intensity is the term's input).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MsraGssmConfig {
    /// Configurations, each a `+`-separated list of `ttc2d`, `tadv`, `ei`, `tadv_corridor`,
    /// `gssm` (at most 4).
    pub configurations: Vec<String>,
    /// The configuration exported as `msra-gssm.rsk` by `riskctl gssm ship`.
    pub shipped: String,
    pub learning_rate: f64,
}

impl Default for MsraGssmConfig {
    fn default() -> Self {
        MsraGssmConfig {
            configurations: vec![
                "ei+gssm".into(),
                "tadv_corridor+ei+gssm".into(),
                "ttc2d+gssm".into(),
                "ttc2d+ei+gssm".into(),
            ],
            shipped: "tadv_corridor+ei+gssm".into(),
            learning_rate: 3e-2,
        }
    }
}

/// The whole GSSM configuration (`configs/gssm.toml` layout, see docs/gssm.md).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GssmConfig {
    pub fit: FitConfig,
    pub ssra: SsraConfig,
    pub msra: MsraGssmConfig,
}

/// A finite, strictly positive rate.
fn positive(x: f64) -> bool {
    x > 0.0 && x.is_finite()
}

/// What is wrong with a GSSM configuration's values.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InvalidGssmConfig {
    #[error(transparent)]
    Hidden(#[from] HiddenLayersError),
    #[error("fit: learning_rate, batch and max_epochs must be > 0")]
    FitRates,
    #[error("fit: smoothness >= 0 and smoothness_noise > 0 required")]
    Smoothness,
    #[error("ssra: learning_rate and max_epochs must be > 0")]
    SsraRates,
    #[error("ssra: lambda_impact, lambda_upper >= 0 and finite u < r_star required")]
    SsraAnchors,
    #[error("msra.learning_rate must be > 0")]
    MsraRate,
    #[error(transparent)]
    Configuration(#[from] ConfigurationError),
    #[error(transparent)]
    Value(#[from] InvalidConfig),
}

/// The largest `fit.batch`: a mini-batch's activations are held whole.
pub const MAX_FIT_BATCH: usize = 1_000_000;

/// An MSRA-over-GSSM configuration name that does not parse.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigurationError {
    #[error("configuration {text:?}: unknown surrogate {part:?} (expected ttc2d, tadv, ei, tadv_corridor, gssm)")]
    UnknownSurrogate { text: String, part: String },
    #[error("configuration {text:?}: {part:?} appears twice")]
    Repeated { text: String, part: String },
    #[error("configuration {text:?}: at most 4 surrogates")]
    TooMany { text: String },
}

/// A GSSM configuration file that cannot be used.
pub type GssmConfigError = ConfigFileError<InvalidGssmConfig>;

impl GssmConfig {
    pub fn from_toml(text: &str, origin: &str) -> Result<GssmConfig, GssmConfigError> {
        parse_toml(text, origin, GssmConfig::validate)
    }

    pub fn load(path: &Path) -> Result<GssmConfig, GssmConfigError> {
        read_toml(path, GssmConfig::validate)
    }

    /// The configuration in `path` when given, else the defaults (`--gssm-config FILE`).
    pub fn load_or_default(path: Option<&Path>) -> Result<Self, GssmConfigError> {
        path.map_or_else(|| Ok(Self::default()), Self::load)
    }

    pub fn validate(&self) -> Result<(), InvalidGssmConfig> {
        let f = &self.fit;
        check_hidden("fit", &f.hidden)?;
        if !positive(f.learning_rate) || f.batch == 0 || f.max_epochs == 0 {
            return Err(InvalidGssmConfig::FitRates);
        }
        check_non_negative("fit.weight_decay", f.weight_decay)?;
        check_non_negative("ssra.weight_decay", self.ssra.weight_decay)?;
        check_non_negative("fit.min_delta", f.min_delta)?;
        let epochs_why = "early stopping ends real runs long before";
        check_at_most("fit.max_epochs", f.max_epochs, MAX_EPOCHS, epochs_why)?;
        check_at_most(
            "ssra.max_epochs",
            self.ssra.max_epochs,
            MAX_EPOCHS,
            epochs_why,
        )?;
        check_at_most(
            "fit.batch",
            f.batch,
            MAX_FIT_BATCH,
            "a mini-batch is held in memory whole",
        )?;
        if !(f.smoothness >= 0.0
            && f.smoothness.is_finite()
            && f.smoothness_noise > 0.0
            && f.smoothness_noise.is_finite())
        {
            return Err(InvalidGssmConfig::Smoothness);
        }
        let r = &self.ssra;
        if !positive(r.learning_rate) || r.max_epochs == 0 {
            return Err(InvalidGssmConfig::SsraRates);
        }
        if !(r.lambda_impact >= 0.0
            && r.lambda_upper >= 0.0
            && r.lambda_impact.is_finite()
            && r.lambda_upper.is_finite()
            && r.u < r.r_star
            && r.u.is_finite()
            && r.r_star.is_finite())
        {
            return Err(InvalidGssmConfig::SsraAnchors);
        }
        if !positive(self.msra.learning_rate) {
            return Err(InvalidGssmConfig::MsraRate);
        }
        for c in self.msra.configurations.iter().chain([&self.msra.shipped]) {
            parse_configuration(c)?;
        }
        Ok(())
    }
}

/// Parse a configuration such as `tadv+ei+gssm` (1 to 4 distinct surrogates).
pub fn parse_configuration(text: &str) -> Result<Vec<SurrogateKind>, ConfigurationError> {
    let mut kinds = Vec::new();
    for part in text.split('+') {
        let kind =
            SurrogateKind::parse(part).ok_or_else(|| ConfigurationError::UnknownSurrogate {
                text: text.to_string(),
                part: part.to_string(),
            })?;
        if kinds.contains(&kind) {
            return Err(ConfigurationError::Repeated {
                text: text.to_string(),
                part: part.to_string(),
            });
        }
        kinds.push(kind);
    }
    if kinds.len() > scorer_core::msra::MAX_TERMS {
        return Err(ConfigurationError::TooMany {
            text: text.to_string(),
        });
    }
    Ok(kinds)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn invalid(toml: &str) -> String {
        match GssmConfig::from_toml(toml, "g.toml") {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{toml} was accepted"),
        }
    }

    #[test]
    fn signs_finiteness_and_counts_are_checked() {
        assert_eq!(
            invalid("[fit]\nweight_decay = -1.0"),
            "g.toml: fit.weight_decay = -1: must be finite and >= 0"
        );
        assert_eq!(
            invalid("[ssra]\nweight_decay = -1.0"),
            "g.toml: ssra.weight_decay = -1: must be finite and >= 0"
        );
        assert!(invalid("[fit]\nmin_delta = nan").contains("fit.min_delta"));
        assert!(invalid("[fit]\nmax_epochs = 100001").contains("fit.max_epochs"));
        assert!(invalid("[ssra]\nmax_epochs = 100001").contains("ssra.max_epochs"));
        assert!(invalid("[fit]\nbatch = 1000001").contains("fit.batch = 1000001"));
        assert!(invalid("[ssra]\nlambda_upper = inf").contains("ssra:"));
        assert!(invalid("[ssra]\nu = -inf").contains("ssra:"));
        assert!(GssmConfig::from_toml("", "g.toml").is_ok());
    }
}
