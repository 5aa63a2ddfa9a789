//! Training configuration (`configs/train.toml`): every hyper-parameter with a documented default.
//!
//! A missing key takes its default, an unknown key is an error (typos must not silently fall back).
use std::path::Path;

use scorer_core::SurrogateKind;
use serde::{Deserialize, Serialize};

use crate::comparisons::ComparisonConfig;

/// Weights and targets of the objective `L = L_pair + lambda_impact L_impact + lambda_upper L_upper`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObjectiveConfig {
    /// Weight of the impact anchoring term.
    pub lambda_impact: f32,
    /// Weight of the upper-bound term.
    pub lambda_upper: f32,
    /// Target risk `r*` of impact-window states.
    pub r_star: f32,
    /// Bound `u < r*` that earlier conflict states should stay under.
    pub u: f32,
}

impl Default for ObjectiveConfig {
    fn default() -> Self {
        ObjectiveConfig {
            lambda_impact: 0.1,
            lambda_upper: 0.0,
            r_star: 4.0,
            u: 3.0,
        }
    }
}

impl ObjectiveConfig {
    // `!(x > y)` on purpose: NaN must fail every check.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn validate(&self, table: &'static str) -> Result<(), InvalidConfig> {
        if !(self.lambda_impact >= 0.0
            && self.lambda_upper >= 0.0
            && self.lambda_impact.is_finite()
            && self.lambda_upper.is_finite())
        {
            return Err(InvalidConfig::NegativeLambda { table });
        }
        if !(self.u < self.r_star && self.u.is_finite() && self.r_star.is_finite()) {
            return Err(InvalidConfig::AnchorOrder {
                table,
                u: self.u,
                r_star: self.r_star,
            });
        }
        Ok(())
    }
}

/// Optimiser, batching and early stopping shared by all parameterisations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OptimiserConfig {
    /// AdamW learning rate.
    pub learning_rate: f64,
    /// AdamW decoupled weight decay: DRL's, and any model without its own (MSRA and MSRA over
    /// GSSM take `msra.weight_decay`, SSRA `[ssra] weight_decay` of the GSSM configuration).
    pub weight_decay: f64,
    /// Pairs per mini-batch (anchors are batched in the same proportion).
    pub batch_pairs: usize,
    /// Upper bound on epochs (passes over the pairs).
    pub max_epochs: usize,
    /// Stop after this many epochs without a validation improvement larger than `min_delta`.
    pub patience: usize,
    pub min_delta: f64,
    /// Fraction of the training EVENTS held out (stratified by kind) for early stopping.
    pub validation_fraction: f64,
}

impl Default for OptimiserConfig {
    fn default() -> Self {
        OptimiserConfig {
            learning_rate: 3e-3,
            weight_decay: 0.5,
            batch_pairs: 512,
            max_epochs: 60,
            patience: 8,
            min_delta: 1e-4,
            validation_fraction: 0.2,
        }
    }
}

/// DRL: the MLP over the 13 standardised features.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DrlConfig {
    /// Hidden layer widths (ReLU); the output layer (width 1, linear) is implicit. The core runs up
    /// to 4 layers of width <= 64.
    pub hidden: Vec<usize>,
    /// Overrides `optimiser.learning_rate` when set.
    pub learning_rate: Option<f64>,
}

impl Default for DrlConfig {
    fn default() -> Self {
        DrlConfig {
            hidden: vec![32, 16],
            learning_rate: None,
        }
    }
}

/// MSRA: `R = sum_k w_k sigmoid(a_k g_k(f_k) + b_k)` over the listed surrogates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MsraConfig {
    /// Surrogates combined, by name: `ttc2d`, `tadv`, `ei`, `tadv_corridor`.
    pub surrogates: Vec<String>,
    /// Overrides `optimiser.learning_rate` when set (MSRA has few parameters and tolerates more).
    pub learning_rate: Option<f64>,
    /// Overrides `optimiser.weight_decay` for MSRA and MSRA over GSSM (1e-4 by default, so a file
    /// cannot unset it; `None` through the Rust API trains with `optimiser.weight_decay`): a decay strong
    /// enough to tame the network flattens MSRA's few sigmoid terms and costs its lead time
    /// (docs/training.md, "Weight decay").
    pub weight_decay: Option<f64>,
    /// Upper clip (s) of TTC2D and TAdv in the transform: longer times count as no conflict.
    pub time_clip: f32,
    /// Overrides the comparison sources' weights `beta` for MSRA when set: `[temporal,
    /// cross_sequence, physics, simulation]`.
    pub beta: Option<[f32; 4]>,
    /// Overrides `[objective]` for MSRA when set (a table with the same keys; missing keys take
    /// the built-in defaults, not the `[objective]` values).
    pub objective: Option<ObjectiveConfig>,
}

impl Default for MsraConfig {
    fn default() -> Self {
        MsraConfig {
            // TAdv under the corridor rule: a standing road user beside the path is no conflict
            // (docs/training.md, "TAdv-corridor").
            surrogates: vec![
                SurrogateKind::TadvCorridor.key().into(),
                SurrogateKind::Ei.key().into(),
            ],
            learning_rate: Some(3e-2),
            weight_decay: Some(1e-4),
            time_clip: 5.0,
            beta: Some([0.3, 1.0, 1.0, 0.5]),
            objective: Some(ObjectiveConfig {
                lambda_impact: 0.0,
                ..ObjectiveConfig::default()
            }),
        }
    }
}

impl MsraConfig {
    /// Display names of the surrogates MSRA combines (`TAdv`, `EI`): its inputs, the baselines
    /// it must beat (`riskscore_eval::claims`).
    pub fn input_names(&self) -> Vec<String> {
        self.surrogates
            .iter()
            .filter_map(|n| super::msra::parse_surrogate(n))
            .map(|k| k.name().to_string())
            .collect()
    }

    /// Clip range `[lo, hi]` of surrogate `kind`'s transform under this configuration.
    pub fn range(&self, kind: SurrogateKind) -> (f32, f32) {
        use scorer_core::SurrogateKind::{Tadv, TadvCorridor, Ttc2d};
        match kind {
            Ttc2d | Tadv | TadvCorridor => (0.0, self.time_clip),
            other => super::msra::default_range(other),
        }
    }
}

/// Post-training int8 quantisation of DRL.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QuantisationConfig {
    /// Fraction of values clipped at each end of every tensor's calibration distribution
    /// (0 = plain min/max).
    pub clip_fraction: f64,
    /// At most this many training observations are used for calibration (evenly strided).
    pub max_observations: usize,
}

impl Default for QuantisationConfig {
    fn default() -> Self {
        QuantisationConfig {
            clip_fraction: 0.0,
            max_observations: 50_000,
        }
    }
}

/// The training-domain record training attaches to every model it exports (final models and the
/// fold models of cross-validation and the benchmarks): `docs/domain-guard.md`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GuardConfig {
    pub policy: GuardPolicy,
    /// Under `blend`: the network's share of a DRL's score inside its domain (the kinematic
    /// fallback has the rest), strictly between 0 and 1.
    pub blend_weight: f32,
    /// Under `fallback` and `blend`, opt-in: the weight decay of an MSRA trained for the DRL
    /// alone, on the DRL's training data, whose kinematic terms become the DRL's fallback; the
    /// MSRA that ships is trained as without it. `None` (the default, a file without the key):
    /// no decayed MSRA (docs/training.md, "A decayed fallback", measured and not the default).
    pub fallback_weight_decay: Option<f64>,
    /// Under `fallback` and `blend`: the surrogates (as `msra.surrogates`) of an MSRA whose
    /// kinematic terms become the DRL's fallback, trained on the shipped MSRA's data with its
    /// settings (or, with `fallback_weight_decay`, on the DRL's); the MSRA that ships keeps
    /// `msra.surrogates`. The default `["tadv", "ei"]` keeps the reference TAdv in the DRL's
    /// blend while MSRA reads `tadv_corridor`; the same list as `msra.surrogates` (or `None`
    /// through the Rust API) makes the fallback the shipped MSRA's terms.
    pub fallback_surrogates: Option<Vec<String>>,
}

/// An MSRA's surrogate list: 1 to 4 names (`count` otherwise), each a geometric surrogate
/// (`unknown` with the first that is not).
fn check_surrogates(
    names: &[String],
    count: InvalidConfig,
    unknown: fn(String) -> InvalidConfig,
) -> Result<(), InvalidConfig> {
    if names.is_empty() || names.len() > 4 {
        return Err(count);
    }
    match names
        .iter()
        .find(|s| super::msra::parse_surrogate(s).is_none())
    {
        Some(s) => Err(unknown(s.clone())),
        None => Ok(()),
    }
}

/// The sequences and comparisons a DRL's own fallback MSRA trains on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FallbackData {
    /// The DRL's (with its own extra folders).
    Drl,
    /// The shipped MSRA's.
    Msra,
}

/// The network's share under `blend` by default: measured on the held-out rounds against 0.5
/// (`docs/domain-guard.md`, "Blend").
pub const DEFAULT_BLEND_WEIGHT: f32 = 0.7;

impl Default for GuardConfig {
    fn default() -> Self {
        GuardConfig {
            policy: GuardPolicy::default(),
            blend_weight: DEFAULT_BLEND_WEIGHT,
            fallback_weight_decay: None,
            // The reference TAdv in the DRL's blend: the corridor rule there cost DRL on unseen
            // draws (docs/training.md, "TAdv-corridor").
            fallback_surrogates: Some(vec![
                SurrogateKind::Tadv.key().into(),
                SurrogateKind::Ei.key().into(),
            ]),
        }
    }
}

impl GuardConfig {
    /// The record's policy and, under `blend`, its blend record (`None`: no record).
    pub fn record(
        &self,
    ) -> Option<(
        scorer_core::model::OutsidePolicy,
        Option<scorer_core::model::Blend>,
    )> {
        let policy = self.policy.outside_policy()?;
        let blend = (self.policy == GuardPolicy::Blend).then_some(scorer_core::model::Blend {
            network_weight: self.blend_weight,
        });
        Some((policy, blend))
    }
}

/// What a model does outside its training domain, as `[guard] policy` names it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GuardPolicy {
    /// No record: the blob says nothing about its domain.
    None,
    /// A record under `flag-only`: scores as unguarded, every consumer sees the flag.
    FlagOnly,
    /// A record under `clamp`: inputs outside are moved to the edge of their trained range.
    Clamp,
    /// A record under `fallback`: outside, a DRL (or a GSSM, SSRA) scores the kinematic terms of
    /// the MSRA trained beside it, aligned to its scale on its training frames (MSRA blobs:
    /// `flag-only`).
    Fallback,
    /// `fallback` outside; inside, a DRL scores `blend_weight` of its network plus the rest of
    /// that kinematic fallback. The default: measured best on the held-out slices, and better in
    /// distribution and in transfer too (`docs/domain-guard.md`, "Blend"). A GSSM or SSRA stays
    /// under `fallback`: inside its domain it is the model of normal driving it was fitted as.
    #[default]
    Blend,
}

impl GuardPolicy {
    /// The policy written into the record (`None`: no record).
    pub fn outside_policy(self) -> Option<scorer_core::model::OutsidePolicy> {
        use scorer_core::model::OutsidePolicy;
        match self {
            GuardPolicy::None => None,
            GuardPolicy::FlagOnly => Some(OutsidePolicy::FlagOnly),
            GuardPolicy::Clamp => Some(OutsidePolicy::Clamp),
            GuardPolicy::Fallback => Some(OutsidePolicy::Fallback),
            GuardPolicy::Blend => Some(OutsidePolicy::Blend),
        }
    }

    /// True for the policies that fit a kinematic fallback (`fallback`, `blend`).
    pub fn uses_fallback(self) -> bool {
        self.outside_policy()
            .is_some_and(scorer_core::model::OutsidePolicy::uses_fallback)
    }
}

/// The whole training configuration.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// Seed of every random choice (splits, comparisons, initialisation, batch order).
    pub seed: u64,
    pub comparisons: ComparisonConfig,
    pub objective: ObjectiveConfig,
    pub optimiser: OptimiserConfig,
    pub drl: DrlConfig,
    pub msra: MsraConfig,
    pub quantisation: QuantisationConfig,
    pub guard: GuardConfig,
}

/// What is wrong with a training configuration's values.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InvalidConfig {
    #[error(transparent)]
    Comparisons(#[from] crate::comparisons::ComparisonConfigError),
    #[error("{table}: lambda_impact and lambda_upper must be finite and >= 0")]
    NegativeLambda { table: &'static str },
    #[error("{table}: need u < r_star, got u = {u}, r_star = {r_star}")]
    AnchorOrder {
        table: &'static str,
        u: f32,
        r_star: f32,
    },
    #[error("optimiser: learning_rate (finite), batch_pairs and max_epochs must be > 0")]
    Optimiser,
    #[error("{key} = {value}: must be finite and >= 0")]
    Negative { key: &'static str, value: f64 },
    #[error("{key} = {value}: must be finite and > 0")]
    NotPositive { key: &'static str, value: f64 },
    #[error("{key} = {value}: at most {max} ({why})")]
    AboveCap {
        key: &'static str,
        value: usize,
        max: usize,
        why: &'static str,
    },
    #[error(transparent)]
    Limit(Box<riskscore_data::limits::LimitError>),
    #[error("optimiser.validation_fraction must be in [0, 0.9)")]
    ValidationFraction,
    #[error(transparent)]
    Hidden(#[from] HiddenLayersError),
    #[error("quantisation: clip_fraction in [0, 0.1) and max_observations > 0 required")]
    Quantisation,
    #[error("msra.time_clip must be in (0, 1000] s, got {0}")]
    TimeClip(f32),
    #[error("msra.beta: four finite weights >= 0")]
    Beta,
    #[error("msra.surrogates: 1 to 4 names")]
    SurrogateCount,
    #[error(
        "msra.surrogates: unknown surrogate {0:?} (expected ttc2d, tadv, ei or tadv_corridor)"
    )]
    UnknownSurrogate(String),
    #[error("guard.fallback_surrogates: 1 to 4 names")]
    FallbackSurrogateCount,
    #[error(
        "guard.fallback_surrogates: unknown surrogate {0:?} (expected ttc2d, tadv, ei or \
         tadv_corridor)"
    )]
    UnknownFallbackSurrogate(String),
    #[error("guard.blend_weight = {0}: must lie strictly between 0 and 1")]
    BlendWeight(f32),
}

/// The most epochs a configuration may ask for: far beyond where early stopping ends any run, but
/// a count that still finishes.
pub const MAX_EPOCHS: usize = 100_000;

/// The largest `quantisation.max_observations`: calibration holds each in memory.
pub const MAX_CALIBRATION_OBSERVATIONS: usize = 10_000_000;

/// `key = value` is a finite rate > 0.
pub(crate) fn check_positive(key: &'static str, value: f64) -> Result<(), InvalidConfig> {
    if value > 0.0 && value.is_finite() {
        return Ok(());
    }
    Err(InvalidConfig::NotPositive { key, value })
}

/// `key = value` is finite and >= 0 (weight decay, tolerances, weights).
pub(crate) fn check_non_negative(key: &'static str, value: f64) -> Result<(), InvalidConfig> {
    if value >= 0.0 && value.is_finite() {
        return Ok(());
    }
    Err(InvalidConfig::Negative { key, value })
}

/// `key = value` is at most `max`.
pub(crate) fn check_at_most(
    key: &'static str,
    value: usize,
    max: usize,
    why: &'static str,
) -> Result<(), InvalidConfig> {
    if value <= max {
        return Ok(());
    }
    Err(InvalidConfig::AboveCap {
        key,
        value,
        max,
        why,
    })
}

/// Hidden layer widths the core cannot run (it runs at most 4 layers of width <= 64).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{table}.hidden: 1 to 3 hidden layers of width 1..=64 (the core runs at most 4 layers)")]
pub struct HiddenLayersError {
    /// The TOML table, e.g. `drl` or `fit`.
    pub table: &'static str,
}

/// The check every network configuration (DRL, GSSM) shares: 1 to 3 hidden layers of width
/// 1..=64, so that with the output layer the core's at most 4 layers of width <= 64 hold.
pub fn check_hidden(table: &'static str, hidden: &[usize]) -> Result<(), HiddenLayersError> {
    if hidden.is_empty() || hidden.len() > 3 || hidden.iter().any(|&w| w == 0 || w > 64) {
        return Err(HiddenLayersError { table });
    }
    Ok(())
}

/// A configuration file that cannot be used; `E` says what is wrong with its values.
#[derive(Debug, thiserror::Error)]
pub enum ConfigFileError<E> {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Parse {
        path: String,
        source: Box<toml::de::Error>,
    },
    #[error("{path}: {source}")]
    Invalid { path: String, source: E },
}

/// A training configuration file that cannot be used.
pub type ConfigError = ConfigFileError<InvalidConfig>;

/// Parse TOML text into a configuration and check it; `origin` names the file in errors.
pub fn parse_toml<T, E>(
    text: &str,
    origin: &str,
    validate: impl FnOnce(&T) -> Result<(), E>,
) -> Result<T, ConfigFileError<E>>
where
    T: serde::de::DeserializeOwned,
{
    let cfg: T = toml::from_str(text).map_err(|source| ConfigFileError::Parse {
        path: origin.to_string(),
        source: Box::new(source),
    })?;
    validate(&cfg).map_err(|source| ConfigFileError::Invalid {
        path: origin.to_string(),
        source,
    })?;
    Ok(cfg)
}

/// Read, parse and check a TOML configuration file.
pub fn read_toml<T, E>(
    path: &Path,
    validate: impl FnOnce(&T) -> Result<(), E>,
) -> Result<T, ConfigFileError<E>>
where
    T: serde::de::DeserializeOwned,
{
    let text = std::fs::read_to_string(path).map_err(|source| ConfigFileError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_toml(&text, &path.display().to_string(), validate)
}

impl TrainConfig {
    /// The optimiser MSRA and MSRA over GSSM train with: `[optimiser]` with `msra.weight_decay`
    /// in place of its decay when set.
    pub fn msra_optimiser(&self) -> OptimiserConfig {
        let mut optimiser = self.optimiser.clone();
        if let Some(decay) = self.msra.weight_decay {
            optimiser.weight_decay = decay;
        }
        optimiser
    }

    /// The configuration a DRL's own fallback MSRA trains with, and on whose data, when `[guard]
    /// fallback_weight_decay` or `fallback_surrogates` asks for one and the policy falls back:
    /// this configuration with that decay as `msra.weight_decay` (on the DRL's data) and those
    /// surrogates as `msra.surrogates` (on the shipped MSRA's data unless a decay is set too).
    /// `None` when the DRL takes the shipped MSRA's terms.
    pub fn fallback_msra_config(&self) -> Option<(TrainConfig, FallbackData)> {
        if !self.guard.policy.uses_fallback() {
            return None;
        }
        let mut config = self.clone();
        // Other surrogates than the shipped MSRA's (the same kinds, however spelt, train the
        // same MSRA).
        let kinds = |names: &[String]| -> Vec<_> {
            names
                .iter()
                .map(|n| super::msra::parse_surrogate(n))
                .collect()
        };
        let other = self
            .guard
            .fallback_surrogates
            .as_ref()
            .filter(|s| kinds(s) != kinds(&self.msra.surrogates));
        if let Some(surrogates) = other {
            config.msra.surrogates = surrogates.clone();
        }
        match self.guard.fallback_weight_decay {
            Some(decay) => {
                config.msra.weight_decay = Some(decay);
                Some((config, FallbackData::Drl))
            }
            None if other.is_some() => Some((config, FallbackData::Msra)),
            None => None,
        }
    }

    /// Parse TOML text; `origin` names the file in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<TrainConfig, ConfigError> {
        parse_toml(text, origin, TrainConfig::validate)
    }

    pub fn load(path: &Path) -> Result<TrainConfig, ConfigError> {
        read_toml(path, TrainConfig::validate)
    }

    /// The configuration in `path` when given, else the defaults; `seed` (when given) replaces
    /// its seed. What every command's `--config FILE` / `--seed N` pair means.
    pub fn load_or_default(path: Option<&Path>, seed: Option<u64>) -> Result<Self, ConfigError> {
        let mut config = match path {
            Some(p) => Self::load(p)?,
            None => Self::default(),
        };
        if let Some(seed) = seed {
            config.seed = seed;
        }
        config
            .check_memory()
            .map_err(|source| ConfigFileError::Invalid {
                path: path.map_or_else(|| "built-in defaults".into(), |p| p.display().to_string()),
                source,
            })?;
        Ok(config)
    }

    /// Refuse comparison counts whose pairs alone would not fit in the memory available now.
    pub fn check_memory(&self) -> Result<(), InvalidConfig> {
        let c = &self.comparisons;
        let pairs = [
            c.temporal.pairs,
            c.cross_sequence.pairs,
            c.physics.pairs,
            c.simulation.pairs,
        ]
        .iter()
        .map(|&n| n as u128)
        .sum();
        riskscore_data::limits::check_memory("comparisons.*.pairs", pairs, c.memory_estimate())
            .map_err(|e| InvalidConfig::Limit(Box::new(e)))
    }

    // `!(x > y)` on purpose: NaN must fail every check.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn validate(&self) -> Result<(), InvalidConfig> {
        self.comparisons.validate()?;
        self.objective.validate("objective")?;
        if let Some(o) = &self.msra.objective {
            o.validate("msra.objective")?;
        }
        let p = &self.optimiser;
        if !(p.learning_rate > 0.0 && p.learning_rate.is_finite())
            || p.batch_pairs == 0
            || p.max_epochs == 0
        {
            return Err(InvalidConfig::Optimiser);
        }
        check_non_negative("optimiser.weight_decay", p.weight_decay)?;
        check_non_negative("optimiser.min_delta", p.min_delta)?;
        check_at_most(
            "optimiser.max_epochs",
            p.max_epochs,
            MAX_EPOCHS,
            "early stopping ends real runs long before",
        )?;
        check_at_most(
            "optimiser.batch_pairs",
            p.batch_pairs,
            crate::comparisons::MAX_PAIRS,
            "no source draws more pairs",
        )?;
        if let Some(rate) = self.drl.learning_rate {
            check_positive("drl.learning_rate", rate)?;
        }
        if let Some(rate) = self.msra.learning_rate {
            check_positive("msra.learning_rate", rate)?;
        }
        if let Some(decay) = self.msra.weight_decay {
            check_non_negative("msra.weight_decay", decay)?;
        }
        if let Some(decay) = self.guard.fallback_weight_decay {
            check_non_negative("guard.fallback_weight_decay", decay)?;
        }
        if !(0.0..0.9).contains(&p.validation_fraction) {
            return Err(InvalidConfig::ValidationFraction);
        }
        check_hidden("drl", &self.drl.hidden)?;
        let q = &self.quantisation;
        if !(0.0..0.1).contains(&q.clip_fraction) || q.max_observations == 0 {
            return Err(InvalidConfig::Quantisation);
        }
        check_at_most(
            "quantisation.max_observations",
            q.max_observations,
            MAX_CALIBRATION_OBSERVATIONS,
            "calibration holds each one in memory",
        )?;
        if !(self.msra.time_clip > 0.0 && self.msra.time_clip <= 1e3) {
            return Err(InvalidConfig::TimeClip(self.msra.time_clip));
        }
        if let Some(b) = &self.msra.beta {
            if b.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(InvalidConfig::Beta);
            }
        }
        check_surrogates(
            &self.msra.surrogates,
            InvalidConfig::SurrogateCount,
            InvalidConfig::UnknownSurrogate,
        )?;
        if let Some(surrogates) = &self.guard.fallback_surrogates {
            check_surrogates(
                surrogates,
                InvalidConfig::FallbackSurrogateCount,
                InvalidConfig::UnknownFallbackSurrogate,
            )?;
        }
        let w = self.guard.blend_weight;
        // The blob's own rule (0 < w < 1), checked even when another policy leaves it unused: a
        // bad value in a configuration file is an error wherever it sits.
        let blend = scorer_core::model::Blend { network_weight: w };
        if blend.validate().is_err() {
            return Err(InvalidConfig::BlendWeight(w));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn invalid(toml: &str) -> String {
        match TrainConfig::from_toml(toml, "t.toml") {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{toml} was accepted"),
        }
    }

    #[test]
    fn every_float_is_checked_for_sign_and_finiteness() {
        assert_eq!(
            invalid("[optimiser]\nweight_decay = -1.0"),
            "t.toml: optimiser.weight_decay = -1: must be finite and >= 0"
        );
        assert!(invalid("[optimiser]\nweight_decay = nan").contains("weight_decay = NaN"));
        assert!(invalid("[optimiser]\nmin_delta = -0.5").contains("optimiser.min_delta"));
        assert!(invalid("[optimiser]\nlearning_rate = inf").contains("learning_rate (finite)"));
        assert!(invalid("[drl]\nlearning_rate = -1.0").contains("drl.learning_rate = -1"));
        assert!(invalid("[msra]\nlearning_rate = 0.0").contains("msra.learning_rate = 0"));
        assert!(invalid("[msra]\nweight_decay = -1.0").contains("msra.weight_decay = -1"));
        assert!(invalid("[guard]\nfallback_weight_decay = -0.5")
            .contains("guard.fallback_weight_decay = -0.5"));
        assert!(invalid("[objective]\nlambda_upper = inf").contains("finite and >= 0"));
        assert!(invalid("[comparisons.physics]\nclosing_horizon = inf").contains("closing_horizon"));
        assert!(
            invalid("[comparisons.anchors]\nimpact_tolerance = inf").contains("impact_tolerance")
        );
        assert!(invalid("[comparisons.physics]\nlane_shift = [0.0, 3.0]")
            .contains("comparisons.physics.lane_shift: need 0 < lo <= hi, got [0, 3]"));
        assert!(invalid("[comparisons.physics]\nlane_shift = [3.0, 2.0]").contains("lane_shift"));
        let lane = "[comparisons.physics]\nlane_shift = [2.5, 4.0]";
        let config = TrainConfig::from_toml(lane, "t.toml").unwrap();
        assert_eq!(config.comparisons.physics.lane_shift, Some([2.5, 4.0]));
        assert_eq!(TrainConfig::default().comparisons.physics.lane_shift, None);
    }

    #[test]
    fn counts_are_capped_before_anything_is_allocated() {
        assert!(invalid("[comparisons.physics]\npairs = 10000001")
            .contains("comparisons.physics.pairs = 10000001: at most 10000000"));
        assert!(invalid("[comparisons.anchors]\nmax_upper = 99999999999")
            .contains("comparisons.anchors.max_upper"));
        assert!(invalid("[optimiser]\nmax_epochs = 100001").contains("at most 100000"));
        assert!(invalid("[optimiser]\nbatch_pairs = 20000000").contains("optimiser.batch_pairs"));
        assert!(invalid("[quantisation]\nmax_observations = 20000000")
            .contains("quantisation.max_observations"));
        let at_caps = "[comparisons.temporal]\npairs = 10000000\n[optimiser]\nmax_epochs = 100000";
        assert!(TrainConfig::from_toml(at_caps, "t.toml").is_ok());
    }

    #[test]
    fn the_guard_policy_parses_by_name_and_defaults_to_blend() {
        let guard = TrainConfig::default().guard;
        assert_eq!(guard.policy, GuardPolicy::Blend);
        assert_eq!(guard.blend_weight, DEFAULT_BLEND_WEIGHT);
        for (name, policy) in [
            ("none", GuardPolicy::None),
            ("flag-only", GuardPolicy::FlagOnly),
            ("clamp", GuardPolicy::Clamp),
            ("fallback", GuardPolicy::Fallback),
            ("blend", GuardPolicy::Blend),
        ] {
            let text = format!("[guard]\npolicy = \"{name}\"");
            let config = TrainConfig::from_toml(&text, "t.toml").unwrap();
            assert_eq!(config.guard.policy, policy);
        }
        let err = invalid("[guard]\npolicy = \"fall-back\"");
        assert!(err.contains("t.toml") && err.contains("fall-back"), "{err}");
        for weight in ["0", "1", "1.5", "-0.2", "nan"] {
            let err = invalid(&format!("[guard]\nblend_weight = {weight}"));
            assert!(err.contains("guard.blend_weight"), "{weight}: {err}");
        }
        let half = TrainConfig::from_toml("[guard]\nblend_weight = 0.5", "t.toml").unwrap();
        let (policy, blend) = half.guard.record().unwrap();
        assert_eq!(policy, scorer_core::model::OutsidePolicy::Blend);
        assert_eq!(blend.unwrap().network_weight, 0.5);
        let fallback = GuardConfig {
            policy: GuardPolicy::Fallback,
            ..half.guard
        };
        assert_eq!(fallback.record().unwrap().1, None);
    }

    #[test]
    fn the_memory_estimate_grows_with_the_pairs() {
        let mut config = TrainConfig::default();
        let base = config.comparisons.memory_estimate();
        config.comparisons.physics.pairs += 1_000_000;
        // A physics pair holds at least its pair, weight and one observation row.
        assert!(config.comparisons.memory_estimate() >= base + 1_000_000 * 100);
        assert!(TrainConfig::default().check_memory().is_ok());
    }

    #[test]
    fn msra_trains_with_its_own_weight_decay_and_drl_with_the_optimiser_s() {
        let config = TrainConfig::from_toml(
            "[optimiser]\nweight_decay = 0.7\n[msra]\nweight_decay = 0.02",
            "t.toml",
        )
        .unwrap();
        assert_eq!(config.optimiser.weight_decay, 0.7);
        assert_eq!(config.msra_optimiser().weight_decay, 0.02);
        // Everything else of the optimiser is shared.
        assert_eq!(
            OptimiserConfig {
                weight_decay: 0.7,
                ..config.msra_optimiser()
            },
            config.optimiser
        );
        let mut without = config.clone();
        without.msra.weight_decay = None;
        assert_eq!(without.msra_optimiser().weight_decay, 0.7);
    }

    #[test]
    fn a_fallback_weight_decay_trains_a_fallback_msra_under_a_falling_back_policy() {
        let config =
            TrainConfig::from_toml("[guard]\nfallback_weight_decay = 0.3", "t.toml").unwrap();
        let (fallback, data) = config.fallback_msra_config().expect("a fallback MSRA");
        assert_eq!(data, FallbackData::Drl);
        assert_eq!(fallback.msra_optimiser().weight_decay, 0.3);
        // Only MSRA's decay differs from the run's configuration.
        assert_eq!(
            TrainConfig {
                msra: config.msra.clone(),
                ..fallback
            },
            config
        );
        // The decay MSRA has still asks for a second MSRA (it trains on the DRL's data), over the
        // default fallback surrogates.
        let same =
            TrainConfig::from_toml("[guard]\nfallback_weight_decay = 0.0001", "t.toml").unwrap();
        let (fallback, _) = same.fallback_msra_config().unwrap();
        assert_eq!(fallback.msra.surrogates, ["tadv", "ei"]);
        assert_eq!(
            (fallback.msra.weight_decay, fallback.msra.learning_rate),
            (same.msra.weight_decay, same.msra.learning_rate)
        );
        // Without a decay and with the fallback's surrogates those of the shipped MSRA, or under
        // a policy without a fallback: no second MSRA.
        let mut none = config.clone();
        none.guard.fallback_weight_decay = None;
        none.guard.fallback_surrogates = Some(none.msra.surrogates.clone());
        assert_eq!(none.fallback_msra_config(), None);
        none.guard.fallback_surrogates = None;
        assert_eq!(none.fallback_msra_config(), None);
        let mut clamp = config.clone();
        clamp.guard.policy = GuardPolicy::Clamp;
        assert_eq!(clamp.fallback_msra_config(), None);
    }

    #[test]
    fn the_default_msra_reads_tadv_corridor_and_the_drls_fallback_the_reference() {
        let config = TrainConfig::default();
        assert_eq!(config.msra.surrogates, ["tadv_corridor", "ei"]);
        let (fallback, data) = config.fallback_msra_config().expect("a fallback MSRA");
        assert_eq!(fallback.msra.surrogates, ["tadv", "ei"]);
        assert_eq!(data, FallbackData::Msra);
        // configs/train.toml says the same.
        let file =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/train.toml");
        let shipped = TrainConfig::load(&file).unwrap();
        assert_eq!(shipped.msra.surrogates, config.msra.surrogates);
        assert_eq!(
            shipped.guard.fallback_surrogates,
            config.guard.fallback_surrogates
        );
    }

    #[test]
    fn fallback_surrogates_train_a_fallback_msra_on_the_shipped_msras_data() {
        let config = TrainConfig::from_toml(
            "[msra]\nsurrogates = [\"tadv_corridor\", \"ei\"]\n[guard]\nfallback_surrogates = [\"tadv\", \"ei\"]",
            "t.toml",
        )
        .unwrap();
        let (fallback, data) = config.fallback_msra_config().expect("a fallback MSRA");
        assert_eq!(data, FallbackData::Msra);
        assert_eq!(fallback.msra.surrogates, ["tadv", "ei"]);
        // Only the surrogates differ; the shipped MSRA keeps its own.
        assert_eq!(
            TrainConfig {
                msra: config.msra.clone(),
                ..fallback.clone()
            },
            config
        );
        assert_eq!(config.msra.input_names(), ["TAdv-corridor", "EI"]);
        // With a decay too, the DRL's data.
        let mut decayed = config.clone();
        decayed.guard.fallback_weight_decay = Some(0.3);
        let (both, data) = decayed.fallback_msra_config().unwrap();
        assert_eq!(data, FallbackData::Drl);
        assert_eq!(both.msra.surrogates, ["tadv", "ei"]);
        assert_eq!(both.msra.weight_decay, Some(0.3));
        // Bad lists are refused with the key.
        for (text, expected) in [
            (
                "fallback_surrogates = []",
                "guard.fallback_surrogates: 1 to 4 names",
            ),
            (
                "fallback_surrogates = [\"tadv\", \"ttc3d\"]",
                "unknown surrogate \"ttc3d\"",
            ),
            (
                "fallback_surrogates = [\"gssm\"]",
                "unknown surrogate \"gssm\"",
            ),
        ] {
            let err = TrainConfig::from_toml(&format!("[guard]\n{text}"), "t.toml")
                .unwrap_err()
                .to_string();
            assert!(err.contains(expected), "{err}");
        }
    }
}
