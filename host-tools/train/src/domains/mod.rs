//! The domain benchmark: slice every sequence by where it lies in the operating domain (ego speed
//! band, interaction geometry, source) and hold one slice out per round: train without it, test
//! on it, with the transfer benchmark's fold runner (DRL, MSRA, GSSM/SSRA through their blobs).
//!
//! - [`slice`]: a sequence's speed band and geometry at its reference frame.
//! - [`source`]: simulation, real freeway or real city (and which city).
//! - [`rounds`]: the rounds, what each holds out, and the train/test split of a fold.
//! - [`share`]: real safe sequences above a method's 90 %-recall threshold.
//! - [`run`]: one round over folds x seeds.
//! - [`draws`]: a round over several simulator draws, its runs pooled.
//! - [`claims`]: a round's acceptance claims, on the means and run by run.
//! - [`report`]: the tables, JSON and report folder.
//! - [`sequences`]: the per-sequence rows of every run (`--sequences-out`).
pub mod claims;
pub mod draws;
pub mod report;
pub mod rounds;
pub mod run;
pub mod sequences;
pub mod share;
pub mod slice;
pub mod source;

pub use draws::Draw;
pub use report::{DomainsResult, RoundOutcome};
pub use rounds::{DomainData, EmptyRound, Round};
pub use run::{run_round, DomainsError, DrawResult, RoundResult};
pub use sequences::{SequenceRow, SequenceSink, SequencesCsv};

use crate::gssm::GssmConfig;
use crate::train::TrainConfig;
use crate::transfer::TransferOptions;
use draws::{draw_counts, run_round_over_draws, sum_counts};

/// Run `rounds` in order on one draw's data ([`run_draws`] with a single draw).
pub fn run(
    rounds: &[Round],
    data: &DomainData,
    config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &TransferOptions,
    empty: EmptyRound,
    sequences: Option<&mut dyn SequenceSink>,
) -> Result<DomainsResult, DomainsError> {
    let draws = [Draw {
        label: "the simulator draw",
        data,
    }];
    run_draws(
        rounds,
        &draws,
        config,
        gssm_config,
        options,
        empty,
        sequences,
    )
}

/// Run `rounds` in order, each on every draw, its runs pooled ([`draws`]). Every round's slice is
/// checked on every draw before any training starts, so an empty round named on the command line
/// fails at once; a round runs only where each draw can run it. With `sequences`, every run's
/// per-sequence rows go there as the runs finish, in round, draw, seed and fold order
/// ([`sequences`]).
pub fn run_draws(
    rounds: &[Round],
    draws: &[Draw<'_>],
    config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &TransferOptions,
    empty: EmptyRound,
    mut sequences: Option<&mut dyn SequenceSink>,
) -> Result<DomainsResult, DomainsError> {
    if draws.is_empty() {
        return Err(DomainsError::NoDraws);
    }
    let mut plan = Vec::new();
    for round in rounds {
        let counts = draw_counts(round, draws);
        let blocked = counts.iter().zip(draws).find(|(c, _)| !c.is_runnable());
        if let (Some((c, draw)), EmptyRound::Fail) = (blocked, empty) {
            return Err(run::empty_slice(
                round,
                c,
                (draws.len() > 1).then_some(draw.label),
            ));
        }
        let blocked_by = blocked.map(|(_, draw)| draw.label.to_owned());
        plan.push((round, blocked_by, sum_counts(&counts)));
    }
    let mut outcomes = Vec::new();
    for (round, blocked_by, counts) in plan {
        outcomes.push(if blocked_by.is_none() {
            RoundOutcome::Ran(Box::new(run_round_over_draws(
                round,
                draws,
                config,
                gssm_config,
                options,
                sequences
                    .as_mut()
                    .map(|s| &mut **s as &mut dyn SequenceSink),
            )?))
        } else {
            RoundOutcome::NoData {
                round: round.clone(),
                counts,
                blocked_by: blocked_by.filter(|_| draws.len() > 1),
            }
        });
    }
    Ok(DomainsResult { rounds: outcomes })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::train::Progress;
    use rounds::slice_counts;

    /// Two folds x one seed, quiet: the rounds here are refused or reported before any training.
    fn two_folds() -> TransferOptions {
        TransferOptions {
            folds: 2,
            seeds: 1,
            progress: Progress::Hidden,
        }
    }

    fn run_city(empty: EmptyRound) -> Result<DomainsResult, DomainsError> {
        let rounds = Round::parse_list("city-peachtree").unwrap();
        let data = DomainData::default();
        run(
            &rounds,
            &data,
            &TrainConfig::default(),
            &GssmConfig::default(),
            &two_folds(),
            empty,
            None,
        )
    }

    #[test]
    fn an_empty_round_fails_when_named_and_reads_no_data_by_default() {
        let err = run_city(EmptyRound::Fail).unwrap_err().to_string();
        assert!(err.contains("round `city-peachtree`"), "{err}");
        assert!(err.contains("0 conflicts and 0 safe sequences"), "{err}");
        let result = run_city(EmptyRound::ReportNoData).unwrap();
        assert!(matches!(&result.rounds[..], [RoundOutcome::NoData { .. }]));
        let json = result.to_json();
        assert_eq!(json["rounds"][0]["status"], "no data");
        assert_eq!(json["rounds"][0]["slice"]["real_safe"], 0);
        assert!(result.to_markdown().contains("**No data**"));
    }

    #[test]
    fn a_round_runs_only_where_every_draw_has_data_and_names_the_draw_without() {
        let rounds = Round::parse_list("speed-35-50").unwrap();
        let (full, empty_data) = (rounds::tests::data(), DomainData::default());
        assert!(slice_counts(&rounds[0], &full).is_runnable());
        let draws = [
            Draw {
                label: "sim seeds 1/2",
                data: &full,
            },
            Draw {
                label: "sim seeds 101/102",
                data: &empty_data,
            },
        ];
        let run = |empty| {
            run_draws(
                &rounds,
                &draws,
                &TrainConfig::default(),
                &GssmConfig::default(),
                &two_folds(),
                empty,
                None,
            )
        };
        let err = run(EmptyRound::Fail).unwrap_err().to_string();
        assert!(
            err.contains("ego speed 35-50 m/s, sim seeds 101/102"),
            "{err}"
        );
        let result = run(EmptyRound::ReportNoData).unwrap();
        let [RoundOutcome::NoData {
            counts, blocked_by, ..
        }] = &result.rounds[..]
        else {
            panic!("{:?}", result.rounds);
        };
        assert_eq!(blocked_by.as_deref(), Some("sim seeds 101/102"));
        assert_eq!(
            *counts,
            slice_counts(&rounds[0], &full),
            "the empty draw adds nothing"
        );
        assert_eq!(
            result.to_json()["rounds"][0]["blocked_by"],
            "sim seeds 101/102"
        );
        assert!(result
            .to_markdown()
            .contains("to train with, on the draw sim seeds 101/102)."));
    }
}
