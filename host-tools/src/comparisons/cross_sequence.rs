//! Cross-sequence comparisons: a state of a conflict sequence is riskier than a state of a safe one.
//!
//! Draws a conflict sequence and a safe sequence uniformly over events, then a frame of each
//! uniformly over time (conflict frames at or before the endpoint, i.e. inside the alert window).
//! Every pair has weight `a_i = 1`.
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::{Origin, Pair, Source, SourceStats, TableBuilder, TrainingSequence};

pub(crate) fn build(
    seqs: &[TrainingSequence],
    origin: Origin,
    target: usize,
    tag: Source,
    tb: &mut TableBuilder,
    rng: &mut ChaCha8Rng,
) -> (Vec<Pair>, SourceStats) {
    let mut stats = SourceStats {
        requested: target,
        ..SourceStats::default()
    };
    if target == 0 {
        return (Vec::new(), stats);
    }
    let conflicts: Vec<(usize, usize)> = seqs
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_conflict())
        .map(|(i, s)| (i, s.frames_up_to_endpoint()))
        .filter(|&(_, n)| n > 0)
        .collect();
    let safes: Vec<(usize, usize)> = seqs
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.is_conflict() && !s.is_empty())
        .map(|(i, s)| (i, s.len()))
        .collect();
    if conflicts.is_empty() || safes.is_empty() {
        stats.rejected = target;
        return (Vec::new(), stats);
    }
    let mut pairs = Vec::with_capacity(target);
    for _ in 0..target {
        let (ci, cn) = conflicts[rng.random_range(0..conflicts.len())];
        let (si, sn) = safes[rng.random_range(0..safes.len())];
        let cf = rng.random_range(0..cn);
        let sf = rng.random_range(0..sn);
        let winner = tb.frame(origin, seqs, ci, cf);
        let loser = tb.frame(origin, seqs, si, sf);
        pairs.push(Pair {
            winner,
            loser,
            source: tag,
            weight: 1.0,
        });
    }
    stats.built = pairs.len();
    (pairs, stats)
}
