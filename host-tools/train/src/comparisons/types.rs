//! The comparison vocabulary: sources, the sequences pairs are drawn from, pairs, anchors and what
//! a build produced.
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::table::ObservationTable;

/// Where a comparison came from. Each source has its own weight `beta` in the pair loss.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    Temporal,
    CrossSequence,
    Physics,
    Simulation,
}

impl Source {
    pub const ALL: [Source; 4] = [
        Source::Temporal,
        Source::CrossSequence,
        Source::Physics,
        Source::Simulation,
    ];

    /// Stable name used in configs, reports and CLI flags.
    pub fn name(self) -> &'static str {
        match self {
            Source::Temporal => "temporal",
            Source::CrossSequence => "cross_sequence",
            Source::Physics => "physics",
            Source::Simulation => "simulation",
        }
    }

    pub fn index(self) -> usize {
        self as usize
    }

    /// Parse a source name as written by [`Source::name`] (also accepts `cross` and `sim`).
    pub fn parse(name: &str) -> Option<Source> {
        match name.trim().to_ascii_lowercase().as_str() {
            "temporal" => Some(Source::Temporal),
            "cross_sequence" | "cross-sequence" | "cross" => Some(Source::CrossSequence),
            "physics" => Some(Source::Physics),
            "simulation" | "sim" | "augmentation" => Some(Source::Simulation),
            _ => None,
        }
    }

    /// Per-source seed stream: the run seed mixed with a fixed tag of the source.
    pub(super) fn rng(self, seed: u64) -> ChaCha8Rng {
        let tag = 0x9E37_79B9_7F4A_7C15u64.wrapping_mul(self.index() as u64 + 1);
        ChaCha8Rng::seed_from_u64(seed ^ tag)
    }
}

/// One comparison: `winner` is riskier than `loser` (rows of the observation table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    pub winner: u32,
    pub loser: u32,
    pub source: Source,
    /// Within-source weight `a_i` (mean 1 over the source).
    pub weight: f32,
}

/// Observations for the endpoint anchoring terms of the objective.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Anchors {
    /// Conflict states within the tolerance window around the endpoint (pulled to `r*`).
    pub impact: Vec<u32>,
    /// Earlier conflict states (before the window), held under `u`.
    pub upper: Vec<u32>,
}

/// Counts of one source's construction.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SourceStats {
    pub requested: usize,
    pub built: usize,
    /// Candidates rejected (no valid partner frame, or a counterfactual that was not riskier).
    pub rejected: usize,
    pub seconds: f64,
}

/// What a build produced and how fast.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BuildStats {
    pub per_source: Vec<(Source, SourceStats)>,
    pub observations: usize,
    pub seconds: f64,
}

impl BuildStats {
    pub fn pairs(&self) -> usize {
        self.per_source.iter().map(|(_, s)| s.built).sum()
    }

    /// Pairs built per second (observation computation included).
    pub fn pairs_per_second(&self) -> f64 {
        if self.seconds > 0.0 {
            self.pairs() as f64 / self.seconds
        } else {
            0.0
        }
    }
}

/// Comparisons, anchors and the observations they refer to.
#[derive(Clone, Debug, Default)]
pub struct ComparisonSet {
    pub table: ObservationTable,
    pub pairs: Vec<Pair>,
    pub anchors: Anchors,
    /// Source weights `beta`, indexed by [`Source::index`].
    pub beta: [f32; 4],
    pub stats: BuildStats,
}

impl ComparisonSet {
    pub fn pairs_of(&self, source: Source) -> usize {
        self.pairs.iter().filter(|p| p.source == source).count()
    }
}
