//! Source ablation: cross-validated metrics when training on each comparison source alone and on
//! every combination of sources, over fractions of the training events.
//!
//! Each (source set, fraction) cell runs the same event-level CV as the demo (same folds, same
//! seeds), with the other sources' pair targets set to zero, and keeps each fold's training events
//! down to `fraction` (stratified by kind). Baselines are evaluated once per fraction-free run since
//! they do not train.
use serde::Serialize;

use super::cv::{self, CvOptions, Models};
use super::{Progress, TrainConfig};
use crate::comparisons::{Source, TrainingSequence};
use crate::eval::{self, CvReport, EventCounts};
use crate::events::Sequence;

/// Ablation settings.
#[derive(Clone, Debug)]
pub struct AblationOptions {
    /// Source sets to train on (each non-empty).
    pub source_sets: Vec<Vec<Source>>,
    /// Fractions of each fold's training events.
    pub fractions: Vec<f64>,
    pub folds: usize,
    pub models: Models,
    pub progress: Progress,
}

/// Every non-empty subset of `sources`, singletons first, then pairs, ... (stable order).
pub fn all_combinations(sources: &[Source]) -> Vec<Vec<Source>> {
    let n = sources.len();
    let mut sets: Vec<Vec<Source>> = (1u32..(1 << n))
        .map(|mask| {
            (0..n)
                .filter(|i| mask & (1 << i) != 0)
                .map(|i| sources[i])
                .collect()
        })
        .collect();
    sets.sort_by_key(|s| s.len());
    sets
}

/// Display name of a source set (`temporal+physics`).
pub fn set_name(set: &[Source]) -> String {
    set.iter().map(|s| s.name()).collect::<Vec<_>>().join("+")
}

/// One cell of the ablation: the CV report of one source set at one fraction.
#[derive(Clone, Debug, Serialize)]
pub struct AblationCell {
    pub sources: String,
    pub fraction: f64,
    pub report: CvReport,
    pub seconds: f64,
}

/// Run the ablation; `on_cell` is called after each cell (for incremental output).
pub fn run(
    seqs: &[Sequence],
    augmentation: Option<&[TrainingSequence]>,
    config: &TrainConfig,
    opts: &AblationOptions,
    mut on_cell: impl FnMut(&AblationCell),
) -> Result<Vec<AblationCell>, cv::CvError> {
    let events = EventCounts::from_classes(seqs.iter().map(|s| s.kind.into()));
    let mut cells = Vec::new();
    for &fraction in &opts.fractions {
        for set in &opts.source_sets {
            let started = std::time::Instant::now();
            let mut cfg = config.clone();
            cfg.comparisons = config.comparisons.restricted_to(set);
            let cv_opts = CvOptions {
                folds: opts.folds,
                seed: config.seed,
                train_fraction: fraction,
                models: Models {
                    drl_f32: false,
                    ..opts.models
                },
                baselines: false,
                progress: opts.progress,
            };
            let folds = cv::cross_validate(seqs, augmentation, &cfg, &cv_opts)?;
            let results: Vec<_> = folds.into_iter().map(|f| f.result).collect();
            let cell = AblationCell {
                sources: set_name(set),
                fraction,
                report: eval::aggregate(events, &results),
                seconds: started.elapsed().as_secs_f64(),
            };
            on_cell(&cell);
            cells.push(cell);
        }
    }
    Ok(cells)
}

/// Baseline rows (no training) under the same folds, for reference.
pub fn baselines(seqs: &[Sequence], folds: usize, seed: u64) -> Result<CvReport, cv::CvError> {
    let events = EventCounts::from_classes(seqs.iter().map(|s| s.kind.into()));
    let split = crate::events::kfold_by_event(seqs, folds, seed);
    let mut results = Vec::new();
    for fold in 0..split.k() {
        let test: Vec<Sequence> = split
            .test(fold)
            .into_iter()
            .map(|i| seqs[i].clone())
            .collect();
        let observed = eval::observe(&test);
        let (report, _) = eval::evaluate_methods(&observed, &eval::Method::baselines())
            .map_err(|source| cv::CvError::Eval { fold, source })?;
        results.push(eval::FoldResult {
            seed,
            fold,
            methods: report.methods,
        });
    }
    Ok(eval::aggregate(events, &results))
}
