//! The transfer benchmark: train on one simulator seed plus part of the real recordings, test on a
//! folder simulated with another seed and event mix plus the real recordings held out by scenario
//! file, so a score that only learned our simulator (or one recording) shows it.
//!
//! Per seed `k` and fold `f` (the real scenario files are dealt into `folds` groups, shuffled by
//! `seed + k`): train = the training simulation + the real sequences of every other group; test =
//! the test simulation + the real sequences of group `f`. DRL and MSRA are trained exactly as in
//! cross-validation ([`crate::train::cv::run_fold`]); the GSSM is fitted on every safe training
//! sequence (real and simulated normal driving, as the shipped GSSM is), aligned to SSRA on the
//! training comparisons ([`crate::gssm::study::train_fold`]). Every model is scored through its
//! exported blob. The result is the same [`CvReport`] (table, CSV, JSON schema) as `riskctl
//! evaluate` and the demo.
use std::borrow::Cow;
use std::collections::BTreeMap;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::gssm::{self, GssmConfig, GssmError};
use crate::train::cv::{self, CvError, CvOptions};
use crate::train::{Progress, TrainConfig};
use riskscore_data::events::Sequence;
use riskscore_eval::domain_share::DomainShare;
use riskscore_eval::{self as eval, CvReport, EventCounts, FoldResult, MethodRun};

/// What the benchmark trains and tests on.
#[derive(Clone, Debug)]
pub struct TransferData {
    /// Simulated training sequences (one seed and mix).
    pub train_sim: Vec<Sequence>,
    /// Training-only sequences DRL alone trains on in every fold ([`cv::ExtraTrain::drl_only`]).
    pub train_drl_only: Vec<Sequence>,
    /// Simulated test sequences (another seed and mix).
    pub test_sim: Vec<Sequence>,
    /// Real recorded sequences (normal driving), split by scenario file.
    pub real: Vec<Sequence>,
}

/// How the benchmark runs.
#[derive(Clone, Debug)]
pub struct TransferOptions {
    /// Groups of real scenario files (one is held out per fold).
    pub folds: usize,
    /// Repetitions with seeds `config.seed + k` (scenario grouping and training).
    pub seeds: usize,
    pub progress: Progress,
}

impl TransferOptions {
    /// The options of one fold while `threads` folds run side by side: their progress bars would
    /// overwrite each other, so they are hidden (the per-fold lines remain).
    pub fn side_by_side(&self, threads: usize) -> TransferOptions {
        TransferOptions {
            progress: if threads > 1 {
                Progress::Hidden
            } else {
                self.progress
            },
            ..self.clone()
        }
    }
}

/// Every (seed, fold, held-out scenario files) of a benchmark over the real recordings `real`:
/// `options.seeds` seeds from `base_seed`, `options.folds` groups of scenario files each.
pub fn fold_jobs(
    real: &[Sequence],
    options: &TransferOptions,
    base_seed: u64,
) -> Vec<(u64, usize, Vec<String>)> {
    (0..options.seeds.max(1))
        .flat_map(|k| {
            let seed = base_seed.wrapping_add(k as u64);
            scenario_groups(real, options.folds, seed)
                .into_iter()
                .enumerate()
                .map(move |(fold, held_out)| (seed, fold, held_out))
        })
        .collect()
}

/// Benchmark failures.
#[derive(Debug, thiserror::Error)]
pub enum TransferError {
    #[error("transfer benchmark: {0}")]
    Cv(#[from] CvError),
    #[error("transfer benchmark (GSSM/SSRA): {0}")]
    Gssm(#[from] GssmError),
    #[error(
        "transfer benchmark: need at least 2 folds and as many real scenario files ({scenarios} found for {folds} folds)"
    )]
    TooFewScenarios { folds: usize, scenarios: usize },
    #[error("transfer benchmark: the {0} part has no sequences")]
    Empty(&'static str),
}

/// Where the held-out real data of one fold came from.
#[derive(Clone, Debug, Serialize)]
pub struct FoldSplit {
    /// The simulator draw (1-based; 1 unless several draws are pooled, [`pool_draws`]).
    pub draw: usize,
    pub seed: u64,
    pub fold: usize,
    pub test_scenarios: Vec<String>,
    pub train_sequences: usize,
    pub test_sequences: usize,
}

/// The benchmark's result.
#[derive(Clone, Debug)]
pub struct TransferResult {
    pub report: CvReport,
    pub folds: Vec<FoldResult>,
    pub splits: Vec<FoldSplit>,
    /// Every fold's warnings for the user, in fold order ([`SplitOutcome::warnings`]).
    pub warnings: Vec<String>,
}

/// The scenario (recording file) a real sequence came from: [`riskscore_data::events::fold_group`] (the
/// event id up to its first `/`, as `riskctl import` writes it; an id without one is its own
/// scenario).
pub use riskscore_data::events::fold_group as scenario_of;

/// Deal the scenario files of `real` into `folds` groups, shuffled by `seed`.
pub fn scenario_groups(real: &[Sequence], folds: usize, seed: u64) -> Vec<Vec<String>> {
    let mut names: Vec<String> = real
        .iter()
        .map(|s| scenario_of(&s.event_id).to_string())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    names.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ 0x7AA5_5F3E));
    let mut groups = vec![Vec::new(); folds];
    for (i, n) in names.into_iter().enumerate() {
        groups[i % folds].push(n);
    }
    groups
}

/// Run the benchmark.
pub fn run(
    data: &TransferData,
    config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &TransferOptions,
) -> Result<TransferResult, TransferError> {
    if data.train_sim.is_empty() {
        return Err(TransferError::Empty("training simulation"));
    }
    if data.test_sim.is_empty() {
        return Err(TransferError::Empty("test simulation"));
    }
    let scenarios = data
        .real
        .iter()
        .map(|s| scenario_of(&s.event_id))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    if options.folds < 2 || scenarios < options.folds {
        return Err(TransferError::TooFewScenarios {
            folds: options.folds,
            scenarios,
        });
    }
    // Every (seed, fold) of the benchmark, run side by side on the cores, reported in order.
    let jobs = fold_jobs(&data.real, options, config.seed);
    let threads = crate::parallel::threads_for(jobs.len());
    let fold_options = options.side_by_side(threads);
    let outcomes = crate::parallel::map_in_order(jobs.len(), threads, |j| {
        let (seed, fold, held_out) = &jobs[j];
        let is_test = |s: &Sequence| held_out.iter().any(|n| n == scenario_of(&s.event_id));
        let mut train = data.train_sim.clone();
        train.extend(data.real.iter().filter(|s| !is_test(s)).cloned());
        let mut test = data.test_sim.clone();
        test.extend(data.real.iter().filter(|s| is_test(s)).cloned());
        let outcome = run_split(
            &Split {
                seed: *seed,
                fold: *fold,
                train: &train,
                drl_only: &data.train_drl_only,
                test: &test,
            },
            config,
            gssm_config,
            &fold_options,
        )?;
        let split = FoldSplit {
            draw: 1,
            seed: *seed,
            fold: *fold,
            test_scenarios: held_out.clone(),
            train_sequences: train.len(),
            test_sequences: test.len(),
        };
        Ok::<_, TransferError>((outcome.result, split, outcome.warnings))
    })?;
    let mut folds = Vec::new();
    let mut splits = Vec::new();
    let mut warnings = Vec::new();
    for (result, split, fold_warnings) in outcomes {
        if options.progress != Progress::Hidden {
            eprintln!(
                "      transfer seed {} fold {}: {} train / {} test sequences",
                split.seed, split.fold, split.train_sequences, split.test_sequences
            );
        }
        folds.push(result);
        splits.push(split);
        warnings.extend(fold_warnings);
    }
    // Event counts of one test set as the table header reports them (simulated test events plus
    // every real sequence, each held out once per seed).
    let counts = EventCounts::from_classes(data.test_sim.iter().chain(&data.real).map(|s| s.kind));
    let report = eval::aggregate(counts, &folds);
    Ok(TransferResult {
        report,
        folds,
        splits,
        warnings,
    })
}

/// The first training seed of simulator draw `k` (from 0) when several draws are pooled: its
/// seeds follow the previous draws' (`config.seed + k x seeds`), so every pooled run has a seed
/// of its own and stays keyed by `(seed, fold)`.
pub fn draw_first_seed(config: &TrainConfig, k: usize, options: &TransferOptions) -> u64 {
    config.seed.wrapping_add((k * options.seeds.max(1)) as u64)
}

/// The training configuration of draw `k` ([`draw_first_seed`]).
pub fn draw_config(config: &TrainConfig, k: usize, options: &TransferOptions) -> TrainConfig {
    TrainConfig {
        seed: draw_first_seed(config, k, options),
        ..config.clone()
    }
}

/// Puts `draw: ` in front of every warning of a draw pooled with others.
pub fn prefix_warnings(warnings: &mut [String], draw: &str) {
    for w in warnings {
        *w = format!("{draw}: {w}");
    }
}

/// Several simulator draws' results (in draw order, each run with [`draw_config`]) as one: the
/// folds, splits and warnings of every draw, the report over all of them (the table header
/// counting every draw's test set); `None` without a draw. Each split names its draw.
pub fn pool_draws(results: Vec<TransferResult>) -> Option<TransferResult> {
    let single = results.len() == 1;
    let mut events = EventCounts::default();
    let mut pooled: Option<TransferResult> = None;
    for (k, mut result) in results.into_iter().enumerate() {
        events += result.report.events;
        for split in &mut result.splits {
            split.draw = k + 1;
        }
        if !single {
            prefix_warnings(&mut result.warnings, &format!("draw {}", k + 1));
        }
        match &mut pooled {
            None => pooled = Some(result),
            Some(p) => {
                p.folds.extend(result.folds);
                p.splits.extend(result.splits);
                p.warnings.extend(result.warnings);
            }
        }
    }
    let mut pooled = pooled?;
    if !single {
        pooled.report = eval::aggregate(events, &pooled.folds);
    }
    Some(pooled)
}

/// One training/test split of a benchmark: what one fold runner call trains and scores.
#[derive(Clone, Copy, Debug)]
pub struct Split<'a> {
    /// The run's seed (`config.seed + k`); training randomness derives from it and `fold`.
    pub seed: u64,
    pub fold: usize,
    /// Training sequences (simulated and real) for DRL, MSRA and the SSRA/MSRA comparisons.
    pub train: &'a [Sequence],
    /// Training sequences DRL and the GSSM's fit see (not MSRA, not SSRA's alignment).
    pub drl_only: &'a [Sequence],
    pub test: &'a [Sequence],
}

/// What one split produced: the metrics row group and every method's scored test sequences
/// (DRL, DRL-f32, MSRA, the baselines, GSSM, SSRA), e.g. to read a threshold off a curve.
#[derive(Clone, Debug)]
pub struct SplitOutcome {
    pub result: FoldResult,
    pub runs: Vec<MethodRun>,
    /// Per guarded model: how many of the test frames lie outside its training domain.
    pub domain_shares: Vec<DomainShare>,
    /// The fold's warnings for the user ([`cv::FoldOutcome::warnings`]), prefixed with the seed.
    pub warnings: Vec<String>,
    /// Every model's blob by row name (DRL, DRL-f32, MSRA, GSSM, SSRA), exactly as scored (with
    /// its training-domain record when guarded), e.g. to look inside a guarded score.
    pub blobs: Vec<(String, Vec<u8>)>,
}

/// The fold runner every benchmark shares: DRL and MSRA trained exactly as in cross-validation
/// ([`cv::run_fold`]), the GSSM fitted on the safe sequences of `train` and `drl_only` and aligned
/// to SSRA on the training comparisons ([`gssm::study::train_fold`]); every model scored through
/// its exported blob.
pub fn run_split(
    split: &Split<'_>,
    config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &TransferOptions,
) -> Result<SplitOutcome, TransferError> {
    let Split {
        seed,
        fold,
        train,
        drl_only,
        test,
    } = *split;
    let mut cfg = config.clone();
    cfg.seed = seed;
    let cv_opts = CvOptions {
        folds: options.folds,
        seed,
        progress: options.progress,
        ..CvOptions::default()
    };
    let outcome = cv::run_fold(fold, train, drl_only, test, None, &cfg, &cv_opts)?;
    let mut methods = outcome.result.methods;
    let mut runs = outcome.runs;
    let domain_shares = outcome.domain_shares;
    let mut blobs = outcome.blobs;
    let mut warnings: Vec<String> = outcome
        .warnings
        .into_iter()
        .map(|w| format!("seed {seed} {w}"))
        .collect();

    let mut gcfg = cfg.clone();
    gcfg.seed = seed.wrapping_mul(1000).wrapping_add(fold as u64);
    // The GSSM family hands over to the kinematic terms of the fold's MSRA (the DRL too, unless
    // `[guard] fallback_weight_decay` gives it an MSRA of its own).
    let fallback_terms = match &outcome.msra_params {
        Some(p) => Some(
            crate::export::msra_terms(p)
                .map_err(gssm::GssmError::from)?
                .to_vec(),
        ),
        None => None,
    };
    let gssm_options = gssm::study::CvOptions {
        folds: options.folds,
        seeds: Vec::new(),
        configurations: Vec::new(),
        baselines: false,
        fallback_terms,
    };
    let normal = gssm_fit_sequences(train, drl_only);
    let g = gssm::study::train_fold(
        train,
        Some(&normal),
        &eval::observe(test),
        &gcfg,
        gssm_config,
        &gssm_options,
        options.progress,
    )?;
    methods.extend(g.methods);
    runs.extend(g.runs);
    blobs.extend(g.blobs);
    warnings.extend(
        g.warnings
            .into_iter()
            .map(|w| format!("seed {seed} fold {fold}: {w}")),
    );
    Ok(SplitOutcome {
        result: FoldResult {
            seed,
            fold,
            methods,
        },
        runs,
        domain_shares,
        warnings,
        blobs,
    })
}

/// Sequences per scenario file (for the report).
pub fn sequences_per_scenario(real: &[Sequence]) -> BTreeMap<String, usize> {
    let mut m = BTreeMap::new();
    for s in real {
        *m.entry(scenario_of(&s.event_id).to_string()).or_insert(0) += 1;
    }
    m
}

/// What a fold's GSSM is fitted on: every training sequence, the DRL-only ones included (the fit
/// keeps their safe sequences). The GSSM is a model of normal driving, fitted as the shipped one
/// is (models/README.md): on all of it, simulated and real. Fitted on the real part alone, the
/// simulated conflicts' closing speeds and geometries lie where it saw nothing and it ranks them
/// below TTC2D (docs/gssm.md, "Fitted on freeway and city").
fn gssm_fit_sequences<'a>(train: &'a [Sequence], drl_only: &[Sequence]) -> Cow<'a, [Sequence]> {
    if drl_only.is_empty() {
        Cow::Borrowed(train)
    } else {
        Cow::Owned(train.iter().chain(drl_only).cloned().collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use riskscore_data::events::EventKind;

    #[test]
    fn the_gssm_fits_simulated_real_and_drl_only_sequences() {
        let seq =
            |id: &str, kind: EventKind| Sequence::new(id, kind, kind.is_conflict().then_some(0.0));
        let train = [
            seq("000001", EventKind::Safe),
            seq("000002", EventKind::Crash),
            seq("USA_US101-1/1", EventKind::Safe),
        ];
        let passes = [seq("pass-1", EventKind::Safe)];
        let ids = |s: &[Sequence]| s.iter().map(|s| s.event_id.clone()).collect::<Vec<_>>();
        assert_eq!(
            ids(&gssm_fit_sequences(&train, &passes)),
            ["000001", "000002", "USA_US101-1/1", "pass-1"]
        );
        assert!(matches!(gssm_fit_sequences(&train, &[]), Cow::Borrowed(_)));
    }

    #[test]
    fn scenario_is_the_event_id_prefix() {
        assert_eq!(
            scenario_of("USA_US101-3_1_T-1/12-40#2"),
            "USA_US101-3_1_T-1"
        );
        assert_eq!(scenario_of("plain"), "plain");
    }
}
