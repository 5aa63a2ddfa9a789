//! Several simulator draws in one benchmark: a round runs on each draw's data and its runs are
//! pooled, so a claim is judged over draws × seeds × folds and not on one test simulation.
//!
//! Why: on one draw the folds and training seeds vary but the test simulation does not, and
//! another (training, test) seed pair moves DRL and TAdv by as much as the claims' margins
//! (docs/benchmarks.md, "Another simulator draw"). A verdict on one draw says little about the
//! next one.
//!
//! Draw `k` (0-based) trains with the training seeds `config.seed + k * seeds` onwards, so every
//! run of a pooled round has a seed of its own and stays keyed by `(seed, fold)` in every report
//! file, as in a single draw. Each draw keeps its own counts and its claims on its own means.
use super::claims::round_claims;
use super::rounds::{slice_counts, DomainData, Round, SliceCounts};
use super::run::{merge_shares, run_round, DomainsError, DrawResult, RoundResult};
use super::sequences::SequenceSink;
use crate::gssm::GssmConfig;
use crate::train::TrainConfig;
use crate::transfer::{draw_config, draw_first_seed, prefix_warnings, TransferOptions};
use riskscore_eval::{self as eval, EventCounts};

/// One simulator draw: the benchmark's data with one (training, test) simulation pair.
#[derive(Clone, Copy, Debug)]
pub struct Draw<'d> {
    /// How the report names the draw, e.g. `sim seeds 101/102`.
    pub label: &'d str,
    pub data: &'d DomainData,
}

/// The round's counts on every draw, in draw order.
pub fn draw_counts(round: &Round, draws: &[Draw<'_>]) -> Vec<SliceCounts> {
    draws.iter().map(|d| slice_counts(round, d.data)).collect()
}

/// Counts added up over draws (every draw tests the real sequences again, so they count once per
/// draw).
pub fn sum_counts(counts: &[SliceCounts]) -> SliceCounts {
    let mut total = SliceCounts::default();
    for c in counts {
        total += *c;
    }
    total
}

/// Run `round` on every draw and pool the runs: the report and the claims over every draw's
/// folds and seeds, the counts added up, each draw's own counts and claims kept. With one draw,
/// this is [`run_round`] on its data.
pub fn run_round_over_draws(
    round: &Round,
    draws: &[Draw<'_>],
    config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &TransferOptions,
    mut sequences: Option<&mut dyn SequenceSink>,
) -> Result<RoundResult, DomainsError> {
    let mut per_draw = Vec::new();
    for (k, draw) in draws.iter().enumerate() {
        let result = run_round(
            round,
            draw.data,
            &draw_config(config, k, options),
            gssm_config,
            options,
            sequences
                .as_mut()
                .map(|s| &mut **s as &mut dyn SequenceSink),
        )?;
        per_draw.push(result);
    }
    pool(draws, per_draw, config, options, &config.msra.input_names()).ok_or(DomainsError::NoDraws)
}

/// The draws' results of one round as one result; `None` without a draw.
fn pool(
    draws: &[Draw<'_>],
    per_draw: Vec<RoundResult>,
    config: &TrainConfig,
    options: &TransferOptions,
    msra_inputs: &[String],
) -> Option<RoundResult> {
    let single = per_draw.len() == 1;
    let mut events = EventCounts::default();
    let mut pooled: Option<RoundResult> = None;
    let mut summaries = Vec::new();
    for (k, (mut result, draw)) in per_draw.into_iter().zip(draws).enumerate() {
        events += result.report.events;
        summaries.push(DrawResult {
            draw: k + 1,
            label: draw.label.to_owned(),
            counts: result.counts,
            first_seed: draw_first_seed(config, k, options),
            claims: result.claims.clone(),
        });
        for split in &mut result.splits {
            split.draw = k + 1;
        }
        if !single {
            prefix_warnings(
                &mut result.warnings,
                &format!("draw {} ({})", k + 1, draw.label),
            );
        }
        match &mut pooled {
            None => pooled = Some(result),
            Some(p) => {
                p.folds.extend(result.folds);
                p.shares.extend(result.shares);
                p.splits.extend(result.splits);
                p.warnings.extend(result.warnings);
                merge_shares(&mut p.domain, &result.domain);
            }
        }
    }
    let mut pooled = pooled?;
    if !single {
        pooled.counts = sum_counts(&summaries.iter().map(|d| d.counts).collect::<Vec<_>>());
        pooled.report = eval::aggregate(events, &pooled.folds);
        pooled.claims = round_claims(&pooled.report, &pooled.folds, &pooled.shares, msra_inputs);
    }
    pooled.draws = summaries;
    Some(pooled)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domains::rounds::KindCounts;
    use crate::train::Progress;

    fn counts(test: (usize, usize), real_safe: usize, train: (usize, usize)) -> SliceCounts {
        SliceCounts {
            test: KindCounts {
                conflicts: test.0,
                safe: test.1,
            },
            real_safe,
            train: KindCounts {
                conflicts: train.0,
                safe: train.1,
            },
        }
    }

    #[test]
    fn each_draw_trains_with_the_seeds_after_the_previous_draws() {
        let options = TransferOptions {
            folds: 5,
            seeds: 3,
            progress: Progress::Hidden,
        };
        let config = TrainConfig {
            seed: 7,
            ..TrainConfig::default()
        };
        let seeds: Vec<u64> = (0..3)
            .map(|k| draw_config(&config, k, &options).seed)
            .collect();
        assert_eq!(seeds, [7, 10, 13]);
        // Nothing else of the configuration moves.
        let mut second = draw_config(&config, 1, &options);
        second.seed = config.seed;
        assert_eq!(second, config);
    }

    #[test]
    fn counts_add_up_field_by_field() {
        let total = sum_counts(&[counts((3, 40), 30, (100, 200)), counts((31, 5), 2, (7, 9))]);
        assert_eq!(total, counts((34, 45), 32, (107, 209)));
        assert_eq!(sum_counts(&[]), SliceCounts::default());
    }

    #[test]
    fn no_draw_is_an_error_not_a_panic() {
        let options = TransferOptions {
            folds: 2,
            seeds: 1,
            progress: Progress::Hidden,
        };
        let round = Round::parse_list("speed-5-15").unwrap().remove(0);
        let err = run_round_over_draws(
            &round,
            &[],
            &TrainConfig::default(),
            &GssmConfig::default(),
            &options,
            None,
        )
        .unwrap_err();
        assert!(matches!(err, DomainsError::NoDraws));
    }
}
