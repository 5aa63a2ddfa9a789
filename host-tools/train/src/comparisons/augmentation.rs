//! Simulation augmentation: the temporal, cross-sequence and physics constructions applied to a
//! second event folder (typically simulated), all tagged [`Source::Simulation`] so the objective can
//! weight them with their own `beta`.
//!
//! The source's pair budget is split over the three constructions in the proportions of the primary
//! targets (equal thirds when all primary targets are zero). Within-source weights keep the meaning of
//! each construction (mean 1 per construction).
use rand_chacha::ChaCha8Rng;

use super::config::ComparisonConfig;
use super::draw::{Draw, Origin, TableBuilder};
use riskscore_data::events::Sequence;

use super::types::{Pair, Source, SourceStats};
use super::{cross_sequence, physics, temporal};

pub(crate) fn build(
    seqs: &[Sequence],
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
    fn draw<'a>(
        seqs: &'a [Sequence],
        target: usize,
        tb: &'a mut TableBuilder,
        rng: &'a mut ChaCha8Rng,
    ) -> Draw<'a> {
        Draw::new(
            seqs,
            Origin::Augmentation,
            target,
            Source::Simulation,
            tb,
            rng,
        )
    }
    let (mut pairs, s1) = temporal::build(draw(seqs, split[0], tb, rng), &config.temporal);
    let (mut p2, s2) = cross_sequence::build(draw(seqs, split[1], tb, rng), &config.cross_sequence);
    let (mut p3, s3) = physics::build(draw(seqs, split[2], tb, rng), &config.physics);
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
