//! Pairwise comparisons "o_w is riskier than o_l", built from the training partition only.
//!
//! One module per source, each seeded from the run seed and its own source tag, so enabling or
//! resizing one source never changes the pairs of another:
//! - [`temporal`]: later over earlier states inside a conflict sequence (up to its endpoint);
//! - [`cross_sequence`]: a conflict frame over a safe frame (uniform over events, then over time);
//! - [`physics`]: a state over its physically riskier counterfactual (shorter gap, higher closing
//!   speed, less lateral clearance, bigger partner), recomputed and checked through scorer-core;
//! - [`augmentation`]: the same three constructions on a second (simulated) event folder, tagged as
//!   its own source.
//!
//! Every observation (a frame of a sequence, or a counterfactual state) is computed once through
//! `scorer_core::{features, surrogates}` into an [`ObservationTable`]; pairs and anchor sets refer to
//! rows of that table, so any parameterisation can precompute its inputs once per row.
pub mod augmentation;
mod config;
pub mod cross_sequence;
mod draw;
pub mod physics;
mod table;
pub mod temporal;
mod types;

use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use riskscore_data::events::{Sequence, TIME_TOLERANCE_S};

pub use config::{
    AnchorConfig, ComparisonConfig, ComparisonConfigError, CrossSequenceConfig, PhysicsConfig,
    SimulationConfig, TemporalConfig, MAX_PAIRS,
};
use draw::{Draw, Origin, TableBuilder};
pub use table::{ObservationTable, RowOrigin};
pub use types::{Anchors, BuildStats, ComparisonSet, Pair, Source, SourceStats};

/// Build all comparisons and anchors from the training sequences (and, optionally, the sequences of
/// an augmentation folder). Deterministic in `seed`.
///
/// Only the sequences passed in are read, so passing the training partition guarantees that no
/// validation or test event leaks into the comparisons.
pub fn build(
    train: &[Sequence],
    augmentation: Option<&[Sequence]>,
    config: &ComparisonConfig,
    seed: u64,
) -> ComparisonSet {
    let started = Instant::now();
    let mut tb = TableBuilder::new();
    let mut pairs = Vec::new();
    let mut per_source = Vec::new();

    let mut run = |tag: Source, construct: &dyn Fn(Draw<'_>) -> (Vec<Pair>, SourceStats)| {
        let t0 = Instant::now();
        let mut rng = tag.rng(seed);
        let (mut p, mut stats) = construct(Draw {
            seqs: train,
            origin: Origin::Primary,
            target: 0,
            tag,
            tb: &mut tb,
            rng: &mut rng,
        });
        stats.seconds = t0.elapsed().as_secs_f64();
        pairs.append(&mut p);
        per_source.push((tag, stats));
    };
    run(Source::Temporal, &|d| {
        temporal::build(
            Draw {
                target: config.temporal.pairs,
                ..d
            },
            &config.temporal,
        )
    });
    run(Source::CrossSequence, &|d| {
        let target = config.cross_sequence.pairs;
        cross_sequence::build(Draw { target, ..d }, &config.cross_sequence)
    });
    run(Source::Physics, &|d| {
        physics::build(
            Draw {
                target: config.physics.pairs,
                ..d
            },
            &config.physics,
        )
    });

    if let Some(aug) = augmentation {
        let t0 = Instant::now();
        let mut rng = Source::Simulation.rng(seed);
        let (mut p, mut stats) = augmentation::build(aug, config, &mut tb, &mut rng);
        stats.seconds = t0.elapsed().as_secs_f64();
        pairs.append(&mut p);
        per_source.push((Source::Simulation, stats));
    }

    let anchors = collect_anchors(train, &config.anchors, &mut tb, seed);

    let seconds = started.elapsed().as_secs_f64();
    let observations = tb.table.len();
    ComparisonSet {
        table: tb.table,
        pairs,
        anchors,
        beta: config.beta(),
        stats: BuildStats {
            per_source,
            observations,
            seconds,
        },
    }
}

/// Impact-window states (`t_impact - tol <= t <= t_impact`) and earlier conflict states
/// (`t < t_impact - tol`) of the training conflict sequences, each subsampled deterministically to
/// its maximum. Frames after the endpoint are never anchors: a near-crash pair is already opening
/// there, and pulling such states to `r*` teaches the model that separating is dangerous.
fn collect_anchors(
    train: &[Sequence],
    config: &AnchorConfig,
    tb: &mut TableBuilder,
    seed: u64,
) -> Anchors {
    use rand::seq::SliceRandom;
    let mut impact = Vec::new();
    let mut upper = Vec::new();
    for (si, s) in train.iter().enumerate() {
        let Some(endpoint) = s.conflict_endpoint() else {
            continue;
        };
        for (fi, t) in s.frames.iter().map(|f| f.time).enumerate() {
            if t > endpoint + TIME_TOLERANCE_S {
                continue;
            }
            if endpoint - t <= config.impact_tolerance + TIME_TOLERANCE_S {
                impact.push((si, fi));
            } else {
                upper.push((si, fi));
            }
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xA5A5_5A5A_0F0F_F0F0);
    if impact.len() > config.max_impact {
        impact.shuffle(&mut rng);
        impact.truncate(config.max_impact);
        impact.sort_unstable();
    }
    if upper.len() > config.max_upper {
        upper.shuffle(&mut rng);
        upper.truncate(config.max_upper);
        upper.sort_unstable();
    }
    Anchors {
        impact: impact
            .into_iter()
            .map(|(s, f)| tb.frame(Origin::Primary, train, s, f))
            .collect(),
        upper: upper
            .into_iter()
            .map(|(s, f)| tb.frame(Origin::Primary, train, s, f))
            .collect(),
    }
}
