//! What every source's construction shares: the frame-deduplicating table builder, the draw it
//! samples with (sequences, target, tag, random stream) and the weight normalisation.
use std::collections::HashMap;

use rand_chacha::ChaCha8Rng;
use scorer_core::VehicleState;

use super::table::{ObservationTable, RowOrigin};
use riskscore_data::events::Sequence;

use super::types::{Pair, Source, SourceStats};

/// Which set of sequences a frame belongs to (primary training data or the augmentation folder).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Origin {
    Primary,
    Augmentation,
}

/// Builds the observation table while deduplicating frames, shared by all sources of one build.
pub(crate) struct TableBuilder {
    pub table: ObservationTable,
    frame_rows: HashMap<(Origin, usize, usize), u32>,
}

impl TableBuilder {
    pub(super) fn new() -> Self {
        TableBuilder {
            table: ObservationTable::default(),
            frame_rows: HashMap::new(),
        }
    }

    /// Row of frame `frame` of sequence `seq` (computed on first use).
    pub fn frame(&mut self, origin: Origin, seqs: &[Sequence], seq: usize, frame: usize) -> u32 {
        let key = (origin, seq, frame);
        if let Some(&row) = self.frame_rows.get(&key) {
            return row;
        }
        let s = &seqs[seq];
        let origin = RowOrigin::Frame {
            augmentation: origin == Origin::Augmentation,
            sequence: seq as u32,
            frame: frame as u32,
        };
        let row = self
            .table
            .push(&s.frames[frame].ego, &s.frames[frame].partner, origin);
        self.frame_rows.insert(key, row);
        row
    }

    /// Row of a counterfactual state of row `of`.
    pub fn counterfactual(&mut self, ego: &VehicleState, partner: &VehicleState, of: u32) -> u32 {
        self.table
            .push(ego, partner, RowOrigin::Counterfactual { of })
    }
}

/// One construction's draw: `target` pairs from `seqs` (the `origin` set), tagged `tag`, rows
/// added to `tb`, randomness from the source's own stream `rng`.
pub(crate) struct Draw<'a> {
    pub seqs: &'a [Sequence],
    pub origin: Origin,
    pub target: usize,
    pub tag: Source,
    pub tb: &'a mut TableBuilder,
    pub rng: &'a mut ChaCha8Rng,
}

impl<'a> Draw<'a> {
    pub fn new(
        seqs: &'a [Sequence],
        origin: Origin,
        target: usize,
        tag: Source,
        tb: &'a mut TableBuilder,
        rng: &'a mut ChaCha8Rng,
    ) -> Self {
        Draw {
            seqs,
            origin,
            target,
            tag,
            tb,
            rng,
        }
    }

    /// Runs one construction: records the request, skips the construction when no pair is
    /// requested, and counts the pairs it built (`construct` records its rejections).
    pub fn run(
        self,
        construct: impl FnOnce(Self, &mut SourceStats) -> Vec<Pair>,
    ) -> (Vec<Pair>, SourceStats) {
        let mut stats = SourceStats {
            requested: self.target,
            ..SourceStats::default()
        };
        if self.target == 0 {
            return (Vec::new(), stats);
        }
        let pairs = construct(self, &mut stats);
        stats.built = pairs.len();
        (pairs, stats)
    }
}

/// Normalise within-source weights to mean 1 (all-zero or empty input is left unchanged).
pub(crate) fn normalise_mean_one(weights: &mut [f32]) {
    if weights.is_empty() {
        return;
    }
    let mean = weights.iter().map(|&w| w as f64).sum::<f64>() / weights.len() as f64;
    if mean > 0.0 {
        for w in weights {
            *w = (*w as f64 / mean) as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn draw<'a>(target: usize, tb: &'a mut TableBuilder, rng: &'a mut ChaCha8Rng) -> Draw<'a> {
        Draw::new(&[], Origin::Primary, target, Source::Physics, tb, rng)
    }

    #[test]
    fn a_run_counts_what_it_built_and_skips_an_empty_request() {
        let mut tb = TableBuilder::new();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let (pairs, stats) = draw(0, &mut tb, &mut rng).run(|_, _| unreachable!());
        assert!(pairs.is_empty() && stats == SourceStats::default());
        let (pairs, stats) = draw(5, &mut tb, &mut rng).run(|d, stats| {
            assert_eq!((d.target, d.tag), (5, Source::Physics));
            stats.rejected = 2;
            let pair = Pair {
                winner: 1,
                loser: 0,
                source: d.tag,
                weight: 1.0,
            };
            vec![pair; 3]
        });
        assert_eq!(pairs.len(), 3);
        assert_eq!((stats.requested, stats.built, stats.rejected), (5, 3, 2));
    }

    #[test]
    fn weights_are_normalised_to_mean_one() {
        let mut w = [1.0f32, 2.0, 3.0];
        normalise_mean_one(&mut w);
        assert_eq!(w, [0.5, 1.0, 1.5]);
        let mut zeros = [0.0f32; 3];
        normalise_mean_one(&mut zeros);
        assert_eq!(zeros, [0.0; 3]);
    }
}
