//! Running one round: per seed and fold, split, train and score through the transfer benchmark's
//! fold runner ([`transfer::run_split`]), and read the real-safe share off every method's curve.
use serde::Serialize;

use std::collections::BTreeMap;
use std::sync::Mutex;

use super::claims::round_claims;
use super::rounds::{slice_counts, split_round, DomainData, KindCounts, Round, SliceCounts};
use super::sequences::{rows_of, SequenceRow, SequenceSink};
use super::share::{share_of, ShareRun};
use crate::gssm::GssmConfig;
use crate::train::{Progress, TrainConfig};
use crate::transfer::{self, Split, TransferError, TransferOptions};
use riskscore_eval::claims::Claim;
use riskscore_eval::domain_share::DomainShare;
use riskscore_eval::{self as eval, CvReport, EventCounts, FoldResult};

/// Domain benchmark failures.
#[derive(Debug, thiserror::Error)]
pub enum DomainsError {
    #[error(
        "domain benchmark, round `{round}` ({slice}): nothing to {what}: the held-out slice has \
         {test_conflicts} conflicts and {test_safe} safe sequences to test on ({real_safe} of \
         them real), training keeps {train_conflicts} conflicts and {train_safe} safe sequences; \
         a round needs at least one of each on both sides"
    )]
    EmptySlice {
        round: String,
        slice: String,
        what: &'static str,
        test_conflicts: usize,
        test_safe: usize,
        real_safe: usize,
        train_conflicts: usize,
        train_safe: usize,
    },
    #[error(
        "domain benchmark: need at least 2 folds and as many real scenario files ({scenarios} found for {folds} folds)"
    )]
    TooFewScenarios { folds: usize, scenarios: usize },
    #[error("domain benchmark, round `{round}`: {source}")]
    Round {
        round: String,
        #[source]
        source: Box<TransferError>,
    },
    #[error("domain benchmark: no simulator draw to run on")]
    NoDraws,
    #[error("domain benchmark: writing the per-sequence rows: {0}")]
    Sequences(#[source] std::io::Error),
}

/// The error for a round whose slice (or whose training remainder) cannot be run; `draw` names
/// the simulator draw where it cannot, in a run of several.
pub fn empty_slice(round: &Round, counts: &SliceCounts, draw: Option<&str>) -> DomainsError {
    let what = if counts.test.conflicts == 0 || counts.test.safe == 0 {
        "test"
    } else {
        "train"
    };
    DomainsError::EmptySlice {
        round: round.name.clone(),
        slice: match draw {
            Some(draw) => format!("{round}, {draw}"),
            None => round.to_string(),
        },
        what,
        test_conflicts: counts.test.conflicts,
        test_safe: counts.test.safe,
        real_safe: counts.real_safe,
        train_conflicts: counts.train.conflicts,
        train_safe: counts.train.safe,
    }
}

/// The sets of one fold of one round.
#[derive(Clone, Debug, Serialize)]
pub struct RoundFoldSplit {
    /// The simulator draw (1-based; 1 in a single-draw run).
    pub draw: usize,
    pub seed: u64,
    pub fold: usize,
    /// Real scenario files kept out of training in this fold.
    pub held_scenarios: Vec<String>,
    pub train: KindCounts,
    pub test: KindCounts,
    pub real_test_safe: usize,
}

/// What one draw gave a pooled round.
#[derive(Clone, Debug, Serialize)]
pub struct DrawResult {
    /// 1-based, as the report numbers draws.
    pub draw: usize,
    pub label: String,
    /// The round's counts on this draw's data.
    pub counts: SliceCounts,
    /// The first training seed of this draw's runs (its runs use `seeds` seeds from here).
    pub first_seed: u64,
    /// The round's claims on this draw's own means and runs.
    pub claims: Vec<Claim>,
}

/// One round's result: the metrics row group, the real-safe shares, the sets, the claims.
#[derive(Clone, Debug)]
pub struct RoundResult {
    pub round: Round,
    pub counts: SliceCounts,
    pub report: CvReport,
    pub folds: Vec<FoldResult>,
    pub shares: Vec<ShareRun>,
    pub splits: Vec<RoundFoldSplit>,
    /// Per guarded model, over every fold and seed: the test frames outside the fold model's
    /// training domain (each fold's model measured on its own training data).
    pub domain: Vec<DomainShare>,
    /// Every fold's warnings for the user, in fold order, prefixed with the round.
    pub warnings: Vec<String>,
    /// The acceptance claims on the round's means, each with its run tally ([`round_claims`]).
    pub claims: Vec<Claim>,
    /// Each simulator draw's counts and claims ([`super::draws`]); empty until the round is
    /// pooled over its draws.
    pub draws: Vec<DrawResult>,
}

impl RoundResult {
    /// True when the slice is small ([`SliceCounts::is_small`]) on any draw: a pooled round is
    /// judged per test simulation, as a single draw is.
    pub fn is_small(&self) -> bool {
        if self.draws.is_empty() {
            self.counts.is_small()
        } else {
            self.draws.iter().any(|d| d.counts.is_small())
        }
    }
}

/// Hands each job's rows to the sink in job order, as soon as every earlier job has handed its
/// own: at most the runs finished out of order wait in memory, not the round's.
struct InOrder<'s> {
    sink: &'s mut dyn SequenceSink,
    next: usize,
    waiting: BTreeMap<usize, Vec<SequenceRow>>,
}

impl InOrder<'_> {
    fn push(&mut self, round: &str, job: usize, rows: Vec<SequenceRow>) -> std::io::Result<()> {
        self.waiting.insert(job, rows);
        while let Some(rows) = self.waiting.remove(&self.next) {
            self.sink.write(round, &rows)?;
            self.next += 1;
        }
        Ok(())
    }
}

/// Run one round: `options.seeds` x `options.folds` trainings without the slice, each scored on it.
/// With `sequences`, every run's per-sequence rows ([`super::sequences`]) go there, in seed and
/// fold order; nothing else changes.
pub fn run_round(
    round: &Round,
    data: &DomainData,
    config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &TransferOptions,
    sequences: Option<&mut dyn SequenceSink>,
) -> Result<RoundResult, DomainsError> {
    let counts = slice_counts(round, data);
    if !counts.is_runnable() {
        return Err(empty_slice(round, &counts, None));
    }
    let real: Vec<_> = data.real.iter().map(|l| l.sequence.clone()).collect();
    let scenarios = transfer::sequences_per_scenario(&real).len();
    if options.folds < 2 || scenarios < options.folds {
        return Err(DomainsError::TooFewScenarios {
            folds: options.folds,
            scenarios,
        });
    }
    let round_err = |source| DomainsError::Round {
        round: round.name.clone(),
        source: Box::new(source),
    };
    // Every (seed, fold) of the round, run side by side on the cores, reported in order.
    let jobs = transfer::fold_jobs(&real, options, config.seed);
    let threads = crate::parallel::threads_for(jobs.len());
    let fold_options = options.side_by_side(threads);
    let sequences = sequences.map(|sink| {
        Mutex::new(InOrder {
            sink,
            next: 0,
            waiting: BTreeMap::new(),
        })
    });
    let outcomes = crate::parallel::map_in_order(jobs.len(), threads, |j| {
        let (seed, fold, held) = &jobs[j];
        let split = split_round(round, data, held);
        let outcome = transfer::run_split(
            &Split {
                seed: *seed,
                fold: *fold,
                train: &split.train,
                drl_only: &[],
                test: &split.test,
            },
            config,
            gssm_config,
            &fold_options,
        )
        .map_err(round_err)?;
        let real_range = split.real_from..split.test.len();
        let fold_shares: Vec<ShareRun> = outcome
            .runs
            .iter()
            .map(|run| share_of(run, real_range.clone(), *seed, *fold))
            .collect();
        if let Some(sequences) = &sequences {
            let rows = rows_of(&split, &outcome.runs, &fold_shares, &outcome.blobs);
            sequences
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(&round.name, j, rows)
                .map_err(DomainsError::Sequences)?;
        }
        let real_test = KindCounts::of(&split.test[split.real_from..]);
        let fold_split = RoundFoldSplit {
            draw: 1,
            seed: *seed,
            fold: *fold,
            held_scenarios: held.clone(),
            train: KindCounts::of(&split.train),
            test: KindCounts::of(&split.test),
            real_test_safe: real_test.safe,
        };
        Ok::<_, DomainsError>(RoundFold {
            result: outcome.result,
            domain: outcome.domain_shares,
            warnings: outcome.warnings,
            shares: fold_shares,
            train_len: split.train.len(),
            test_len: split.test.len(),
            split: fold_split,
        })
    })?;
    let mut folds = Vec::new();
    let mut shares = Vec::new();
    let mut splits = Vec::new();
    let mut domain: Vec<DomainShare> = Vec::new();
    let mut warnings = Vec::new();
    for fold in outcomes {
        if options.progress != Progress::Hidden {
            eprintln!(
                "      round {} seed {} fold {}: {} train / {} test sequences",
                round.name, fold.split.seed, fold.split.fold, fold.train_len, fold.test_len
            );
        }
        merge_shares(&mut domain, &fold.domain);
        warnings.extend(
            fold.warnings
                .into_iter()
                .map(|w| format!("round {} {w}", round.name)),
        );
        shares.extend(fold.shares);
        folds.push(fold.result);
        splits.push(fold.split);
    }
    let report = eval::aggregate(slice_event_counts(round, data), &folds);
    let claims = round_claims(&report, &folds, &shares, &config.msra.input_names());
    Ok(RoundResult {
        round: round.clone(),
        counts,
        report,
        folds,
        shares,
        splits,
        domain,
        warnings,
        claims,
        draws: Vec::new(),
    })
}

/// What one (seed, fold) of a round gives.
struct RoundFold {
    result: FoldResult,
    /// Per guarded model, its test frames outside the training domain.
    domain: Vec<DomainShare>,
    /// The fold's warnings for the user.
    warnings: Vec<String>,
    /// The real-safe share at each method's thresholds.
    shares: Vec<ShareRun>,
    split: RoundFoldSplit,
    train_len: usize,
    test_len: usize,
}

/// Adds each of `fold`'s shares to the entry of the same model in `total` (new models appended).
pub(super) fn merge_shares(total: &mut Vec<DomainShare>, fold: &[DomainShare]) {
    for share in fold {
        match total.iter_mut().find(|t| t.name == share.name) {
            Some(t) => t.merge(share),
            None => total.push(share.clone()),
        }
    }
}

/// The event counts of the slice's test sequences over all folds (the table header).
fn slice_event_counts(round: &Round, data: &DomainData) -> EventCounts {
    let sim = data.test_sim_part(round);
    let real = data.real.iter().filter(|l| round.contains(&l.domain));
    EventCounts::from_classes(sim.into_iter().chain(real).map(|l| l.sequence.kind))
}
