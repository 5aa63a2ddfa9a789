//! Simulation augmentation: the temporal, cross-sequence and physics constructions applied to a
//! second event folder (typically simulated), all tagged [`Source::Simulation`] so the objective can
//! weight them with their own `beta`.
//!
//! The source's pair budget is split over the three constructions in the proportions of the primary
//! targets (equal thirds when all primary targets are zero). Within-source weights keep the meaning of
//! each construction (mean 1 per construction).
use rand_chacha::ChaCha8Rng;

use super::{
    cross_sequence, physics, temporal, ComparisonConfig, Origin, Pair, Source, SourceStats,
    TableBuilder, TrainingSequence,
};

pub(crate) fn build(
    seqs: &[TrainingSequence],
    config: &ComparisonConfig,
    tb: &mut TableBuilder,
    rng: &mut ChaCha8Rng,
) -> (Vec<Pair>, SourceStats) {
    let total = config.simulation.pairs;
    let shares = [
        config.temporal.pairs,
        config.cross_sequence.pairs,
        config.physics.pairs,
    ];
    let sum: usize = shares.iter().sum();
    let split: [usize; 3] = match (total * shares[0]).checked_div(sum) {
        None => [total / 3, total / 3, total - 2 * (total / 3)],
        Some(a) => {
            let b = total * shares[1] / sum;
            [a, b, total - a - b]
        }
    };
    let origin = Origin::Augmentation;
    let tag = Source::Simulation;
    let (mut pairs, s1) = temporal::build(seqs, origin, &config.temporal, split[0], tag, tb, rng);
    let (mut p2, s2) =
        cross_sequence::build(seqs, origin, &config.cross_sequence, split[1], tag, tb, rng);
    let (mut p3, s3) = physics::build(seqs, origin, &config.physics, split[2], tag, tb, rng);
    pairs.append(&mut p2);
    pairs.append(&mut p3);
    let stats = SourceStats {
        requested: total,
        built: pairs.len(),
        rejected: s1.rejected + s2.rejected + s3.rejected,
        seconds: 0.0,
    };
    (pairs, stats)
}
