//! Learning a risk score from comparisons, with candle (CPU), generic over the parameterisation.
//!
//! - [`config`]: the TOML hyper-parameters with documented defaults;
//! - [`objective`]: the source-weighted Bradley-Terry loss plus the endpoint anchoring terms;
//! - [`drl`]: DRL, the MLP over the 13 standardised features (what the core's int8 network runs);
//! - [`model`]: [`RiskModel`], what a parameterisation offers the trainer;
//! - [`msra`]: MSRA, `sum_k w_k sigmoid(a_k g_k(f_k) + b_k)` over the core's surrogate transforms.
//!
//! A parameterisation implements [`RiskModel`]: it turns each row of an [`ObservationTable`] into a
//! fixed-width input once (standardised features, transformed surrogates, ...), and maps a batch of
//! such rows to scores with candle ops. [`train_with`] then does the rest: mini-batch AdamW over
//! the comparisons ([`prepare_comparisons`] builds them on the event-level validation split), and
//! the shared early-stopping loop ([`crate::nn::trainer`]: best parameters restored, progress on
//! stderr).
pub mod ablation;
pub mod config;
pub mod cv;
pub mod drl;
pub mod model;
pub mod msra;
pub mod objective;

use std::collections::BTreeMap;
use std::time::Instant;

use candle_core::{DType, Device, Tensor};
use candle_nn::Optimizer;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use riskscore_data::events::Sequence;

use crate::comparisons::{self, ComparisonSet, ObservationTable};
use crate::nn::trainer::{adamw, EarlyStopping, EpochOutcome};
pub use config::{FallbackData, GuardConfig, GuardPolicy, TrainConfig, DEFAULT_BLEND_WEIGHT};
use config::{ObjectiveConfig, OptimiserConfig};
pub use model::RiskModel;
pub use objective::LossParts;

/// Training failures.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    #[error("no comparisons could be built from the training events (need conflict sequences, and safe sequences for cross-sequence pairs)")]
    NoPairs,
    #[error("training diverged: non-finite loss at epoch {epoch}")]
    Diverged { epoch: usize },
    #[error("tensor computation failed: {0}")]
    Candle(#[from] candle_core::Error),
    #[error("quantisation failed: {0}")]
    Quantize(#[from] crate::quantize::QuantizeError),
}

/// One epoch of the history.
#[derive(Clone, Debug, Serialize)]
pub struct EpochRecord {
    pub epoch: usize,
    pub train: LossParts,
    pub validation: Option<LossParts>,
}

/// What a training run did.
#[derive(Clone, Debug, Serialize)]
pub struct TrainReport {
    pub model: String,
    pub epochs: usize,
    /// Epoch whose parameters were kept (best validation loss, or the last without validation).
    pub best_epoch: usize,
    pub stopped_early: bool,
    pub seconds: f64,
    pub epochs_per_second: f64,
    pub pairs: usize,
    pub validation_pairs: usize,
    pub history: Vec<EpochRecord>,
}

pub use crate::nn::Progress;

/// Split sequences by EVENT into a fit part and a validation part, stratified by class (conflict /
/// safe), deterministically in `seed`. With `fraction == 0` everything is fit data.
pub fn split_validation(
    seqs: &[Sequence],
    fraction: f64,
    seed: u64,
) -> (Vec<Sequence>, Vec<Sequence>) {
    if fraction <= 0.0 {
        return (seqs.to_vec(), Vec::new());
    }
    // Group sequence indices by event, keeping first-appearance order, then per class.
    let mut by_event: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (i, s) in seqs.iter().enumerate() {
        by_event.entry(s.event_id.as_str()).or_default().push(i);
    }
    let mut conflict_events = Vec::new();
    let mut safe_events = Vec::new();
    for (id, idx) in &by_event {
        if idx.iter().any(|&i| seqs[i].is_conflict()) {
            conflict_events.push(*id);
        } else {
            safe_events.push(*id);
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0005_EED0_F5A1);
    let mut held = std::collections::BTreeSet::new();
    for events in [&mut conflict_events, &mut safe_events] {
        events.shuffle(&mut rng);
        let n = ((events.len() as f64) * fraction).round() as usize;
        // Keep at least one event of each class for fitting.
        let n = n.min(events.len().saturating_sub(1));
        held.extend(events.iter().take(n).copied());
    }
    let mut fit = Vec::new();
    let mut val = Vec::new();
    for s in seqs {
        if held.contains(s.event_id.as_str()) {
            val.push(s.clone());
        } else {
            fit.push(s.clone());
        }
    }
    (fit, val)
}

/// Per-row tensors of a comparison set, ready for batching.
struct Encoded {
    inputs: Tensor,
    winners: Vec<u32>,
    losers: Vec<u32>,
    weights: Vec<f32>,
    impact: Vec<u32>,
    upper: Vec<u32>,
}

fn encode_set<M: RiskModel>(
    model: &M,
    set: &ComparisonSet,
    beta: Option<[f32; 4]>,
) -> candle_core::Result<Encoded> {
    let beta = beta.unwrap_or(set.beta);
    let width = model.input_width();
    let rows = model.encode(&set.table);
    let inputs = Tensor::from_vec(rows, (set.table.len(), width), &Device::Cpu)?;
    Ok(Encoded {
        inputs,
        winners: set.pairs.iter().map(|p| p.winner).collect(),
        losers: set.pairs.iter().map(|p| p.loser).collect(),
        weights: set
            .pairs
            .iter()
            .map(|p| beta[p.source.index()] * p.weight)
            .collect(),
        impact: set.anchors.impact.clone(),
        upper: set.anchors.upper.clone(),
    })
}

/// Rows of one mini-batch.
struct Batch<'a> {
    winners: &'a [u32],
    losers: &'a [u32],
    weights: &'a [f32],
    impact: &'a [u32],
    upper: &'a [u32],
}

/// Objective over the given rows (one forward pass over all of them).
fn batch_loss<M: RiskModel>(
    model: &M,
    enc: &Encoded,
    batch: &Batch<'_>,
    objective: &ObjectiveConfig,
) -> candle_core::Result<(Tensor, LossParts)> {
    let dev = Device::Cpu;
    let Batch {
        winners,
        losers,
        weights,
        impact,
        upper,
    } = *batch;
    let (nw, ni, nu) = (winners.len(), impact.len(), upper.len());
    let mut idx = Vec::with_capacity(2 * nw + ni + nu);
    idx.extend_from_slice(winners);
    idx.extend_from_slice(losers);
    idx.extend_from_slice(impact);
    idx.extend_from_slice(upper);
    let n = idx.len();
    let idx = Tensor::from_vec(idx, n, &dev)?;
    let x = enc.inputs.index_select(&idx, 0)?;
    let scores = model.forward(&x)?;
    let w = scores.narrow(0, 0, nw)?;
    let l = scores.narrow(0, nw, nw)?;
    let i = scores.narrow(0, 2 * nw, ni)?;
    let u = scores.narrow(0, 2 * nw + ni, nu)?;
    let pw = Tensor::from_slice(weights, nw, &dev)?;
    objective::objective(&w, &l, &pw, &i, &u, objective)
}

fn full_loss<M: RiskModel>(
    model: &M,
    enc: &Encoded,
    objective: &ObjectiveConfig,
) -> candle_core::Result<LossParts> {
    let batch = Batch {
        winners: &enc.winners,
        losers: &enc.losers,
        weights: &enc.weights,
        impact: &enc.impact,
        upper: &enc.upper,
    };
    let (_, parts) = batch_loss(model, enc, &batch, objective)?;
    Ok(parts)
}

/// How to train: objective, optimiser, learning rate, seed, progress display.
#[derive(Clone, Copy, Debug)]
pub struct TrainSettings<'a> {
    pub objective: &'a ObjectiveConfig,
    pub optimiser: &'a OptimiserConfig,
    pub learning_rate: f64,
    pub seed: u64,
    pub progress: Progress,
    /// Source weights `beta` replacing the comparison sets' own (one model's override).
    pub beta: Option<[f32; 4]>,
}

/// Train `model` on `train` comparisons, early-stopping on `validation` (when it has pairs), and leave
/// the best parameters in the model.
pub fn train_with<M: RiskModel>(
    model: &M,
    train: &ComparisonSet,
    validation: Option<&ComparisonSet>,
    settings: &TrainSettings<'_>,
) -> Result<TrainReport, TrainError> {
    let (objective, optimiser) = (settings.objective, settings.optimiser);
    let (learning_rate, seed, progress) =
        (settings.learning_rate, settings.seed, settings.progress);
    if train.pairs.is_empty() {
        return Err(TrainError::NoPairs);
    }
    let started = Instant::now();
    let enc = encode_set(model, train, settings.beta)?;
    let val_enc = match validation {
        Some(v) if !v.pairs.is_empty() => Some(encode_set(model, v, settings.beta)?),
        _ => None,
    };
    let vars = model.vars();
    let mut opt = adamw(vars.clone(), learning_rate, optimiser.weight_decay)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0BA7_C4E5);
    let n_pairs = enc.winners.len();
    let batches = n_pairs.div_ceil(optimiser.batch_pairs).max(1);
    let mut order: Vec<usize> = (0..n_pairs).collect();
    let mut impact = enc.impact.clone();
    let mut upper = enc.upper.clone();
    let mut history = Vec::new();
    let rule = EarlyStopping {
        max_epochs: optimiser.max_epochs,
        patience: optimiser.patience,
        min_delta: optimiser.min_delta,
    };
    let stop = rule.run(&vars, model.name(), progress, |epoch| {
        order.shuffle(&mut rng);
        impact.shuffle(&mut rng);
        upper.shuffle(&mut rng);
        let (mut sum, mut count) = (LossParts::default(), 0usize);
        for b in 0..batches {
            let lo = b * n_pairs / batches;
            let hi = (b + 1) * n_pairs / batches;
            let sel = &order[lo..hi];
            let w: Vec<u32> = sel.iter().map(|&i| enc.winners[i]).collect();
            let l: Vec<u32> = sel.iter().map(|&i| enc.losers[i]).collect();
            let pw: Vec<f32> = sel.iter().map(|&i| enc.weights[i]).collect();
            let ia = &impact[b * impact.len() / batches..(b + 1) * impact.len() / batches];
            let ua = &upper[b * upper.len() / batches..(b + 1) * upper.len() / batches];
            let batch = Batch {
                winners: &w,
                losers: &l,
                weights: &pw,
                impact: ia,
                upper: ua,
            };
            let (loss, parts) = batch_loss(model, &enc, &batch, objective)?;
            if !parts.total.is_finite() {
                return Err(TrainError::Diverged { epoch });
            }
            opt.backward_step(&loss)?;
            sum.pair += parts.pair;
            sum.impact += parts.impact;
            sum.upper += parts.upper;
            sum.total += parts.total;
            count += 1;
        }
        let c = count.max(1) as f64;
        let train_parts = LossParts {
            pair: sum.pair / c,
            impact: sum.impact / c,
            upper: sum.upper / c,
            total: sum.total / c,
        };
        let val_parts = match &val_enc {
            Some(v) => Some(full_loss(model, v, objective)?),
            None => None,
        };
        history.push(EpochRecord {
            epoch,
            train: train_parts,
            validation: val_parts,
        });
        Ok(EpochOutcome {
            criterion: val_parts.map(|p| p.total).unwrap_or(train_parts.total),
            message: match val_parts {
                Some(v) => format!("loss {:.4} val {:.4}", train_parts.total, v.total),
                None => format!("loss {:.4}", train_parts.total),
            },
        })
    })?;
    let (epoch, best_epoch, stopped_early) = (stop.epochs, stop.best_epoch, stop.stopped_early);
    let seconds = started.elapsed().as_secs_f64();
    Ok(TrainReport {
        model: model.name().to_string(),
        epochs: epoch,
        best_epoch,
        stopped_early,
        seconds,
        epochs_per_second: if seconds > 0.0 {
            epoch as f64 / seconds
        } else {
            0.0
        },
        pairs: n_pairs,
        validation_pairs: val_enc.as_ref().map(|v| v.winners.len()).unwrap_or(0),
        history,
    })
}

/// Comparisons for the fit and validation parts of the training sequences.
pub struct PreparedComparisons {
    pub fit: ComparisonSet,
    pub validation: ComparisonSet,
    pub fit_sequences: Vec<Sequence>,
}

/// DRL's own training side when it has data MSRA must not see (`drl_only`, e.g. the roadside
/// passes): `train` and `drl_only` together with their comparisons; `None` when there is none and
/// DRL trains on MSRA's sequences and comparisons.
pub fn drl_own_side(
    train: &[Sequence],
    drl_only: &[Sequence],
    augmentation: Option<&[Sequence]>,
    config: &TrainConfig,
) -> Option<(Vec<Sequence>, PreparedComparisons)> {
    if drl_only.is_empty() {
        return None;
    }
    let all: Vec<Sequence> = train.iter().chain(drl_only).cloned().collect();
    let prepared = prepare_comparisons(&all, augmentation, config);
    Some((all, prepared))
}

/// Split the training sequences by event and build comparisons on both parts (the validation part
/// gets targets scaled by its share, so its loss is comparable).
pub fn prepare_comparisons(
    train: &[Sequence],
    augmentation: Option<&[Sequence]>,
    config: &TrainConfig,
) -> PreparedComparisons {
    let frac = config.optimiser.validation_fraction;
    let (fit_seqs, val_seqs) = split_validation(train, frac, config.seed);
    let fit = comparisons::build(&fit_seqs, augmentation, &config.comparisons, config.seed);
    let validation = if val_seqs.is_empty() {
        ComparisonSet::default()
    } else {
        let scale = (frac / (1.0 - frac)).clamp(0.05, 1.0);
        // Augmentation data is not validation data: the stopping rule must follow the target domain.
        comparisons::build(
            &val_seqs,
            None,
            &config.comparisons.scaled(scale),
            config.seed.wrapping_add(1),
        )
    };
    PreparedComparisons {
        fit,
        validation,
        fit_sequences: fit_seqs,
    }
}

/// Float scores of every row of a table (for tests and diagnostics; deployment scores go through
/// scorer-core).
pub fn score_table<M: RiskModel>(
    model: &M,
    table: &ObservationTable,
) -> candle_core::Result<Vec<f32>> {
    let rows = model.encode(table);
    let x = Tensor::from_vec(rows, (table.len(), model.input_width()), &Device::Cpu)?;
    model.forward(&x)?.to_dtype(DType::F32)?.to_vec1::<f32>()
}

/// A trained DRL network with its int8 calibration.
#[derive(Clone, Debug)]
pub struct TrainedDrl {
    pub params: drl::DrlParams,
    pub calibration: crate::quantize::Calibration,
    pub report: TrainReport,
}

/// A trained MSRA model.
#[derive(Clone, Debug)]
pub struct TrainedMsra {
    pub params: msra::MsraParams,
    pub report: TrainReport,
}

/// DRL inputs of the frames of `seqs`, evenly strided down to at most `max` observations.
pub fn calibration_observations(seqs: &[Sequence], max: usize) -> Vec<scorer_core::DrlInputs> {
    let total: usize = seqs.iter().map(|s| s.len()).sum();
    let stride = total.div_ceil(max.max(1)).max(1);
    let mut out = Vec::with_capacity(total / stride + 1);
    let mut i = 0usize;
    for s in seqs {
        for (e, p) in s.frames.iter().map(|f| (&f.ego, &f.partner)) {
            if i.is_multiple_of(stride) {
                out.push(scorer_core::drl_inputs(e, p));
            }
            i += 1;
        }
    }
    out
}

/// Train DRL on prepared comparisons; the feature standardisation and the int8 calibration are
/// measured on `train` (the whole training partition).
pub fn train_drl(
    train: &[Sequence],
    prepared: &PreparedComparisons,
    config: &TrainConfig,
    progress: Progress,
) -> Result<TrainedDrl, TrainError> {
    let scaler = drl::FeatureScaler::fit(train);
    let model = drl::Drl::new(scaler, &config.drl.hidden, config.seed)?;
    let lr = config
        .drl
        .learning_rate
        .unwrap_or(config.optimiser.learning_rate);
    let settings = TrainSettings {
        objective: &config.objective,
        optimiser: &config.optimiser,
        learning_rate: lr,
        seed: config.seed,
        progress,
        beta: None,
    };
    let report = train_with(&model, &prepared.fit, Some(&prepared.validation), &settings)?;
    let params = model.params()?;
    let observations = calibration_observations(train, config.quantisation.max_observations);
    let calibration =
        crate::quantize::calibrate(&params, &observations, config.quantisation.clip_fraction)?;
    Ok(TrainedDrl {
        params,
        calibration,
        report,
    })
}

/// The DRL's own fallback MSRA, when `[guard] fallback_weight_decay` or `fallback_surrogates`
/// asks for one (`TrainConfig::fallback_msra_config`), trained on the DRL's sequences and
/// comparisons (`drl`) or on the shipped MSRA's (`msra`) as that says; `None`: the DRL falls back
/// on the kinematic terms of the MSRA that ships.
pub fn train_fallback_msra(
    drl: (&[Sequence], &PreparedComparisons),
    msra: (&[Sequence], &PreparedComparisons),
    config: &TrainConfig,
    progress: Progress,
) -> Result<Option<TrainedMsra>, TrainError> {
    config
        .fallback_msra_config()
        .map(|(c, data)| {
            let (train, comparisons) = match data {
                FallbackData::Drl => drl,
                FallbackData::Msra => msra,
            };
            train_msra(train, comparisons, &c, progress)
        })
        .transpose()
}

/// Train MSRA on prepared comparisons; input normalisation measured on `train`.
pub fn train_msra(
    train: &[Sequence],
    prepared: &PreparedComparisons,
    config: &TrainConfig,
    progress: Progress,
) -> Result<TrainedMsra, TrainError> {
    let terms: Vec<(scorer_core::SurrogateKind, (f32, f32))> = config
        .msra
        .surrogates
        .iter()
        .filter_map(|s| msra::parse_surrogate(s))
        .map(|k| (k, config.msra.range(k)))
        .collect();
    let model = msra::Msra::new(&terms, train)?;
    let lr = config
        .msra
        .learning_rate
        .unwrap_or(config.optimiser.learning_rate);
    let optimiser = config.msra_optimiser();
    let settings = TrainSettings {
        objective: config.msra.objective.as_ref().unwrap_or(&config.objective),
        optimiser: &optimiser,
        learning_rate: lr,
        seed: config.seed,
        progress,
        beta: config.msra.beta,
    };
    let report = train_with(&model, &prepared.fit, Some(&prepared.validation), &settings)?;
    Ok(TrainedMsra {
        params: model.params()?,
        report,
    })
}
