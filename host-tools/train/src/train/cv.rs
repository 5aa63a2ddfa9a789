//! Event-level k-fold cross-validation of the learned scores, evaluated through the deployed path.
//!
//! Per fold: the training events' sequences (optionally subsampled to a fraction of the events,
//! stratified by kind, for ablations) are split again for early stopping, comparisons are built from
//! them only, DRL and MSRA are trained, DRL is calibrated and quantised, every model is exported to
//! a blob and decoded by scorer-core, and the test fold is scored by the decoded models (DRL: int8,
//! plus the f32 network as `DRL-f32` for the quantisation comparison) and by the TTC2D/TAdv/EI
//! baselines through `eval`.
use std::collections::BTreeMap;
use std::time::Instant;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::{Progress, TrainConfig, TrainError, TrainReport};
use crate::comparisons::BuildStats;
use crate::export::{self, ExportError};
use crate::quantize::{self, Agreement};
use riskscore_data::events::{kfold_by_event, Sequence};
use riskscore_eval::domain_share::DomainShare;
use riskscore_eval::{self as eval, FoldResult, Method, MethodRun, Scorer};

/// Which learned models a run trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Models {
    pub drl: bool,
    /// Also score the f32 DRL network (row `DRL-f32`) next to the int8 one.
    pub drl_f32: bool,
    pub msra: bool,
}

impl Default for Models {
    fn default() -> Self {
        Models {
            drl: true,
            drl_f32: true,
            msra: true,
        }
    }
}

/// Cross-validation settings.
#[derive(Clone, Debug)]
pub struct CvOptions {
    pub folds: usize,
    /// Seed of the fold assignment (training seeds come from the config).
    pub seed: u64,
    /// Fraction of each fold's training events used (1.0 = all).
    pub train_fraction: f64,
    pub models: Models,
    pub baselines: bool,
    pub progress: Progress,
}

impl Default for CvOptions {
    fn default() -> Self {
        CvOptions {
            folds: 5,
            seed: 0,
            train_fraction: 1.0,
            models: Models::default(),
            baselines: true,
            progress: Progress::Bar,
        }
    }
}

/// Cross-validation failures.
#[derive(Debug, thiserror::Error)]
pub enum CvError {
    #[error("fold {fold}: {source}")]
    Train { fold: usize, source: TrainError },
    #[error("fold {fold}: {source}")]
    Export { fold: usize, source: ExportError },
    #[error("fold {fold}: evaluation failed: {source}")]
    Eval {
        fold: usize,
        source: eval::ProtocolError,
    },
    #[error("fold {fold}: the exported blob does not decode: {source:?}")]
    Decode {
        fold: usize,
        source: scorer_core::model::ModelError,
    },
    #[error("need at least 2 folds and some sequences (got {folds} folds, {sequences} sequences)")]
    TooFew { folds: usize, sequences: usize },
}

/// Timing of one fold's stages (s).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FoldTimes {
    pub comparisons: f64,
    pub drl: f64,
    /// The DRL's own fallback MSRA (`[guard] fallback_weight_decay`; nothing is trained without
    /// it). Not part of `msra`: the MSRA trained beside the DRL, reported and exported, or (when
    /// the MSRA is not reported and the key is off) only the DRL's fallback.
    pub fallback_msra: f64,
    pub msra: f64,
    pub quantise_export: f64,
    pub evaluate: f64,
}

/// Everything one fold produced.
#[derive(Clone, Debug)]
pub struct FoldOutcome {
    pub fold: usize,
    pub result: FoldResult,
    /// Scored test sequences of every method (for pooled curves and trajectories).
    pub runs: Vec<MethodRun>,
    pub comparisons: BuildStats,
    pub drl: Option<TrainReport>,
    pub msra: Option<TrainReport>,
    /// int8 vs f32 agreement of the fold's DRL on its test observations.
    pub agreement: Option<Agreement>,
    /// The fold's learned MSRA parameters (sign/weight inspection).
    pub msra_params: Option<super::msra::MsraParams>,
    /// The fold's exported model blobs by row name, with the training-domain record of
    /// `[guard] policy` (what the benchmark scored).
    pub blobs: Vec<(String, Vec<u8>)>,
    /// Per guarded model: how many of the fold's test frames lie outside its training domain.
    pub domain_shares: Vec<DomainShare>,
    /// What the caller should show its user: a model whose kinematic fallback could not be fitted
    /// (its guard became `flag-only`). Printing is the caller's choice, not the library's.
    pub warnings: Vec<String>,
    pub times: FoldTimes,
}

/// The share of `observed` frames each guarded method sees outside its training domain.
fn domain_shares(observed: &[eval::ObservedSequence], methods: &[Method<'_>]) -> Vec<DomainShare> {
    let mut shares = Vec::new();
    for method in methods {
        let Some(kind) = method
            .scorer
            .model_kind()
            .filter(|_| method.scorer.has_domain())
        else {
            continue;
        };
        let mut share = DomainShare::new(&method.name, kind);
        for frame in observed.iter().flat_map(|s| &s.frames) {
            if let Some(guarded) = method.scorer.score_guarded(&frame.observation) {
                share.add(&guarded);
            }
        }
        shares.push(share);
    }
    shares
}

/// Keep `fraction` of the events of each kind (at least one per kind present), seeded.
pub fn subsample_events(seqs: &[Sequence], fraction: f64, seed: u64) -> Vec<Sequence> {
    if fraction >= 1.0 {
        return seqs.to_vec();
    }
    let mut by_class: BTreeMap<bool, Vec<&str>> = BTreeMap::new();
    let mut seen = std::collections::BTreeSet::new();
    for s in seqs {
        if seen.insert(s.event_id.as_str()) {
            by_class
                .entry(s.is_conflict())
                .or_default()
                .push(s.event_id.as_str());
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xF4AC_7105);
    let mut keep = std::collections::BTreeSet::new();
    for ids in by_class.values_mut() {
        ids.shuffle(&mut rng);
        let n = ((ids.len() as f64) * fraction).round().max(1.0) as usize;
        keep.extend(ids.iter().take(n).copied());
    }
    seqs.iter()
        .filter(|s| keep.contains(s.event_id.as_str()))
        .cloned()
        .collect()
}

/// Run k-fold cross-validation over prepared sequences. `augmentation` (a second, e.g. simulated,
/// folder) only ever feeds the comparisons of the simulation source.
pub fn cross_validate(
    seqs: &[Sequence],
    augmentation: Option<&[Sequence]>,
    config: &TrainConfig,
    opts: &CvOptions,
) -> Result<Vec<FoldOutcome>, CvError> {
    cross_validate_with_extra(seqs, &ExtraTrain::default(), augmentation, config, opts)
}

/// Training-only sequences: they join every fold's training side, never a test fold, so the
/// folds (and the figures) stay those of the tested sequences alone.
#[derive(Clone, Copy, Debug, Default)]
pub struct ExtraTrain<'a> {
    /// Every trained model (DRL and MSRA) trains on these.
    pub all_models: &'a [Sequence],
    /// Only DRL trains on these (its comparisons, standardisation, int8 calibration and domain
    /// record); MSRA never sees them: data that teaches the network a geometry the kinematic
    /// surrogates MSRA combines cannot express (e.g. roadside passes, docs/training.md).
    pub drl_only: &'a [Sequence],
}

/// [`cross_validate`] where `extra_train` joins every fold's training events as they are (the
/// same comparisons, standardisation, int8 calibration and domain record as the folds' own; its
/// `drl_only` part for DRL alone) but never a test fold: the folds, and so the figures, stay
/// those of `seqs` alone.
pub fn cross_validate_with_extra(
    seqs: &[Sequence],
    extra_train: &ExtraTrain<'_>,
    augmentation: Option<&[Sequence]>,
    config: &TrainConfig,
    opts: &CvOptions,
) -> Result<Vec<FoldOutcome>, CvError> {
    if opts.folds < 2 || seqs.is_empty() {
        return Err(CvError::TooFew {
            folds: opts.folds,
            sequences: seqs.len(),
        });
    }
    let folds = kfold_by_event(seqs, opts.folds, opts.seed);
    let threads = crate::parallel::threads_for(folds.k());
    // Side by side, one fold's progress bars would overwrite the other's.
    let fold_opts = CvOptions {
        progress: if threads > 1 {
            Progress::Hidden
        } else {
            opts.progress
        },
        ..opts.clone()
    };
    crate::parallel::map_in_order(folds.k(), threads, |fold| {
        let train_seqs: Vec<Sequence> = folds
            .train(fold)
            .into_iter()
            .map(|i| seqs[i].clone())
            .chain(extra_train.all_models.iter().cloned())
            .collect();
        let test_seqs: Vec<Sequence> = folds
            .test(fold)
            .into_iter()
            .map(|i| seqs[i].clone())
            .collect();
        run_fold(
            fold,
            &train_seqs,
            extra_train.drl_only,
            &test_seqs,
            augmentation,
            config,
            &fold_opts,
        )
    })
}

/// Train on `train` (DRL also on `drl_only`), evaluate on `test` (one fold).
pub fn run_fold(
    fold: usize,
    train: &[Sequence],
    drl_only: &[Sequence],
    test: &[Sequence],
    augmentation: Option<&[Sequence]>,
    config: &TrainConfig,
    opts: &CvOptions,
) -> Result<FoldOutcome, CvError> {
    let mut times = FoldTimes::default();
    let mut cfg = config.clone();
    // Distinct but reproducible training randomness per fold.
    cfg.seed = config.seed.wrapping_add(1000 * fold as u64);
    let train_ts = subsample_events(train, opts.train_fraction, cfg.seed);

    let t0 = Instant::now();
    let prepared = super::prepare_comparisons(&train_ts, augmentation, &cfg);
    let drl_only_ts = subsample_events(drl_only, opts.train_fraction, cfg.seed);
    let drl_own = super::drl_own_side(&train_ts, &drl_only_ts, augmentation, &cfg);
    let (drl_train, drl_comparisons) = match &drl_own {
        Some((sequences, comparisons)) => (sequences.as_slice(), comparisons),
        None => (train_ts.as_slice(), &prepared),
    };
    times.comparisons = t0.elapsed().as_secs_f64();
    let terr = |source| CvError::Train { fold, source };
    let xerr = |source| CvError::Export { fold, source };

    let t0 = Instant::now();
    let drl = if opts.models.drl {
        Some(super::train_drl(drl_train, drl_comparisons, &cfg, opts.progress).map_err(terr)?)
    } else {
        None
    };
    times.drl = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    // The DRL's fallback outside its domain is the kinematic part of the MSRA trained beside it,
    // or, under `[guard] fallback_weight_decay` or `fallback_surrogates`, of one trained for it
    // alone.
    let drl_falls_back = opts.models.drl && cfg.guard.policy.uses_fallback();
    let fallback_msra = if drl_falls_back {
        super::train_fallback_msra(
            (drl_train, drl_comparisons),
            (&train_ts, &prepared),
            &cfg,
            opts.progress,
        )
        .map_err(terr)?
    } else {
        None
    };
    times.fallback_msra = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let msra = if opts.models.msra || (drl_falls_back && fallback_msra.is_none()) {
        Some(super::train_msra(&train_ts, &prepared, &cfg, opts.progress).map_err(terr)?)
    } else {
        None
    };
    times.msra = t0.elapsed().as_secs_f64();

    let t0 = Instant::now();
    let observed = eval::observe(test);
    let mut blobs: Vec<(String, Vec<u8>)> = Vec::new();
    let mut agreement = None;
    if let Some(d) = &drl {
        let q = quantize::quantize(&d.params, &d.calibration)
            .map_err(|e| xerr(ExportError::Quantize(e)))?;
        let test_features: Vec<_> = observed
            .iter()
            .flat_map(|s| s.frames.iter().map(|f| f.observation.drl_inputs))
            .collect();
        agreement = Some(
            quantize::verify(&d.params, &q, &test_features)
                .map_err(|e| xerr(ExportError::Quantize(e)))?,
        );
        blobs.push(("DRL".into(), export::drl_int8_blob(&q).map_err(xerr)?));
        if opts.models.drl_f32 {
            blobs.push((
                "DRL-f32".into(),
                export::drl_f32_blob(&d.params).map_err(xerr)?,
            ));
        }
    }
    let msra_terms = match fallback_msra.as_ref().or(msra.as_ref()) {
        Some(m) => Some(export::msra_terms(&m.params).map_err(xerr)?),
        None => None,
    };
    if let (Some(m), true) = (&msra, opts.models.msra) {
        blobs.push(("MSRA".into(), export::msra_blob(&m.params).map_err(xerr)?));
    }
    // The record the final model would carry, measured on what this fold's models trained on.
    let mut warnings = Vec::new();
    for (name, blob) in &mut blobs {
        let trained_on = if name.starts_with("DRL") {
            drl_train
        } else {
            train_ts.as_slice()
        };
        let guarded = export::with_measured_domain(
            blob,
            trained_on,
            &cfg.guard,
            msra_terms.as_ref().map(|t| t.as_slice()),
        )
        .map_err(xerr)?;
        warnings.extend(guarded.warning(&format!("fold {fold}: {name}")));
        *blob = guarded.bytes;
    }
    times.quantise_export = t0.elapsed().as_secs_f64();

    let t0 = Instant::now();
    let mut methods = Vec::new();
    for (name, blob) in &blobs {
        let blob = scorer_core::model::decode_blob(blob)
            .map_err(|source| CvError::Decode { fold, source })?;
        // Scored as the ECU and `riskctl evaluate` score the exported file.
        methods.push(Method {
            name: name.clone(),
            scorer: Scorer::of_blob(blob),
        });
    }
    if opts.baselines {
        let baselines = Method::baselines_for(&methods);
        methods.extend(baselines);
    }
    let (report, runs) = eval::evaluate_methods(&observed, &methods)
        .map_err(|source| CvError::Eval { fold, source })?;
    times.evaluate = t0.elapsed().as_secs_f64();
    let domain_shares = domain_shares(&observed, &methods);
    // The methods borrow the blobs, which the outcome keeps.
    drop(methods);

    Ok(FoldOutcome {
        fold,
        result: FoldResult {
            seed: opts.seed,
            fold,
            methods: report.methods,
        },
        runs,
        comparisons: prepared.fit.stats.clone(),
        drl: drl.as_ref().map(|d| d.report.clone()),
        msra: msra
            .as_ref()
            .filter(|_| opts.models.msra)
            .map(|m| m.report.clone()),
        agreement,
        msra_params: msra.filter(|_| opts.models.msra).map(|m| m.params),
        blobs,
        domain_shares,
        warnings,
        times,
    })
}
