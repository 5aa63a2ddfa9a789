//! SSRA: the GSSM aligned with comparisons. Every GSSM parameter is fine-tuned under the shared
//! comparison objective ([`crate::train::objective`]: source-weighted Bradley-Terry plus impact
//! anchoring and the upper bound, the latter two with SSRA's weights and targets, see
//! [`SsraConfig`]), with the risk `R = logit(clip(F_S))` (or `F_S`) computed through
//! the CDF in the training graph ([`GssmNet::score`]). No parameter is added: the exported model is
//! the same GSSM network with the SSRA score mode.
//!
//! The generic trainer ([`crate::train::train_with`]) runs the optimisation (mini-batch AdamW, early
//! stopping on the validation comparisons, best epoch restored). Because alignment starts from a
//! trained model, the starting point competes too: if the best fine-tuned parameters have a higher
//! validation objective than the GSSM itself, the GSSM's parameters are kept (`kept_initial`).
use candle_core::{Device, Tensor, Var};

use super::config::{SsraConfig, SsraScore};
use super::net::{core_score, GssmNet, GssmParams, ROW_WIDTH};
use super::GssmError;
use crate::comparisons::{ComparisonSet, ObservationTable};
use crate::train::config::ObjectiveConfig;
use crate::train::{
    self, objective, LossParts, PreparedComparisons, Progress, RiskModel, TrainConfig, TrainReport,
    TrainSettings,
};

/// The SSRA parameterisation: a GSSM network scored through its CDF.
pub struct Ssra {
    net: GssmNet,
    mode: SsraScore,
}

impl Ssra {
    pub fn new(params: &GssmParams, mode: SsraScore) -> candle_core::Result<Ssra> {
        Ok(Ssra {
            net: GssmNet::from_params(params)?,
            mode,
        })
    }

    pub fn params(&self) -> candle_core::Result<GssmParams> {
        self.net.params()
    }

    pub fn net(&self) -> &GssmNet {
        &self.net
    }
}

impl RiskModel for Ssra {
    fn name(&self) -> &str {
        "SSRA"
    }

    fn input_width(&self) -> usize {
        ROW_WIDTH
    }

    fn encode(&self, table: &ObservationTable) -> Vec<f32> {
        self.net.encode_rows(&table.features)
    }

    fn forward(&self, inputs: &Tensor) -> candle_core::Result<Tensor> {
        self.net.score(inputs, self.mode)
    }

    fn vars(&self) -> Vec<Var> {
        self.net.vars()
    }
}

/// The objective of `model` over a whole comparison set (all pairs and anchors at once).
pub fn set_objective<M: RiskModel>(
    model: &M,
    set: &ComparisonSet,
    config: &ObjectiveConfig,
) -> candle_core::Result<LossParts> {
    let scores = Tensor::from_vec(
        train::score_table(model, &set.table)?,
        set.table.len(),
        &Device::Cpu,
    )?;
    let pick = |rows: Vec<u32>| -> candle_core::Result<Tensor> {
        let n = rows.len();
        scores.index_select(&Tensor::from_vec(rows, n, &Device::Cpu)?, 0)
    };
    let w = pick(set.pairs.iter().map(|p| p.winner).collect())?;
    let l = pick(set.pairs.iter().map(|p| p.loser).collect())?;
    let pw: Vec<f32> = set
        .pairs
        .iter()
        .map(|p| set.beta[p.source.index()] * p.weight)
        .collect();
    let n = pw.len();
    let pw = Tensor::from_vec(pw, n, &Device::Cpu)?;
    let i = pick(set.anchors.impact.clone())?;
    let u = pick(set.anchors.upper.clone())?;
    Ok(objective::objective(&w, &l, &pw, &i, &u, config)?.1)
}

/// An aligned GSSM.
#[derive(Clone, Debug)]
pub struct TrainedSsra {
    pub params: GssmParams,
    pub score: SsraScore,
    pub report: TrainReport,
    /// Validation objective of the GSSM before alignment (`None` without validation pairs).
    pub initial_validation: Option<LossParts>,
    /// Validation objective of the parameters kept.
    pub final_validation: Option<LossParts>,
    /// True when no fine-tuned epoch beat the starting GSSM on validation.
    pub kept_initial: bool,
}

impl TrainedSsra {
    /// The GSSM-kind blob with the SSRA score mode.
    pub fn blob(&self) -> Result<Vec<u8>, GssmError> {
        self.params.gssm_blob(core_score(self.score))
    }
}

/// Fine-tune `gssm` on prepared comparisons (the shared trainer, objective and early stopping;
/// learning rate, epochs and patience from `ssra`).
pub fn align_ssra(
    gssm: &GssmParams,
    prepared: &PreparedComparisons,
    config: &TrainConfig,
    ssra: &SsraConfig,
    progress: Progress,
) -> Result<TrainedSsra, GssmError> {
    let model = Ssra::new(gssm, ssra.score)?;
    let objective = ssra.objective();
    let has_val = !prepared.validation.pairs.is_empty();
    let initial_validation = if has_val {
        Some(set_objective(&model, &prepared.validation, &objective)?)
    } else {
        None
    };
    let mut optimiser = config.optimiser.clone();
    optimiser.max_epochs = ssra.max_epochs;
    optimiser.patience = ssra.patience;
    optimiser.weight_decay = ssra.weight_decay;
    let settings = TrainSettings {
        objective: &objective,
        optimiser: &optimiser,
        learning_rate: ssra.learning_rate,
        seed: config.seed,
        progress,
        beta: None,
    };
    let report = train::train_with(
        &model,
        &prepared.fit,
        has_val.then_some(&prepared.validation),
        &settings,
    )?;
    let mut params = model.params()?;
    let mut final_validation = if has_val {
        Some(set_objective(&model, &prepared.validation, &objective)?)
    } else {
        None
    };
    let mut kept_initial = false;
    if let (Some(a), Some(b)) = (initial_validation, final_validation) {
        if a.total <= b.total {
            params = gssm.clone();
            final_validation = Some(a);
            kept_initial = true;
        }
    }
    Ok(TrainedSsra {
        params,
        score: ssra.score,
        report,
        initial_validation,
        final_validation,
        kept_initial,
    })
}
