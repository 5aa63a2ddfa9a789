//! The `[comparisons]` settings: one table per source, the anchors, and their validation.
use serde::{Deserialize, Serialize};

use super::types::Source;

/// A `[comparisons]` setting out of its range; the message names the key and the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ComparisonConfigError(pub String);

/// The most pairs one source draws, and the most anchors of each kind: 2,500 times the default,
/// about 600 MB of comparisons in all.
pub const MAX_PAIRS: usize = 10_000_000;

/// Temporal-source settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TemporalConfig {
    pub pairs: usize,
    pub beta: f32,
    /// Minimum time between the two states (s).
    pub dmin: f64,
    /// Maximum time between the two states (s).
    pub dmax: f64,
}

impl Default for TemporalConfig {
    fn default() -> Self {
        TemporalConfig {
            pairs: 4000,
            beta: 0.2,
            dmin: 0.3,
            dmax: 1.5,
        }
    }
}

/// Cross-sequence-source settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CrossSequenceConfig {
    pub pairs: usize,
    pub beta: f32,
    /// Fraction of pairs whose safe frame is the safe sequence's closest approach (smallest box
    /// gap) instead of a uniform frame.
    pub closest_fraction: f64,
    /// Those safe frames are drawn uniformly from the `closest_window` seconds ending at the
    /// closest approach (0: the closest frame itself).
    pub closest_window: f64,
}

impl Default for CrossSequenceConfig {
    fn default() -> Self {
        CrossSequenceConfig {
            pairs: 4000,
            beta: 1.0,
            closest_fraction: 1.0,
            closest_window: 1.5,
        }
    }
}

/// Physics-counterfactual settings. Magnitudes are drawn uniformly from each `[lo, hi]` range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhysicsConfig {
    pub pairs: usize,
    pub beta: f32,
    /// Gap shortening along the line of sight, as a fraction of the current box distance.
    pub gap_fraction: [f32; 2],
    /// Closing-speed increase along the line of sight (m/s).
    pub closing_speed: [f32; 2],
    /// Lateral-offset reduction (in the ego frame), as a fraction of the current offset.
    pub lateral_fraction: [f32; 2],
    /// Partner size growth factor minus one (length and width scaled by `1 + x`).
    pub size_growth: [f32; 2],
    /// Opt-in lane-shift counterfactuals: the partner moved this far (m, ego frame) away from the
    /// ego's axis, the safer state of its pair. `None` (the default): the four kinds only.
    pub lane_shift: Option<[f32; 2]>,
    /// Horizon (s) over which a closing-speed counterfactual must bring the boxes closer.
    pub closing_horizon: f32,
    /// Also require that no surrogate (TTC2D, TAdv, EI) calls the counterfactual safer.
    pub require_surrogate_agreement: bool,
}

impl Default for PhysicsConfig {
    fn default() -> Self {
        PhysicsConfig {
            pairs: 2000,
            beta: 1.0,
            gap_fraction: [0.1, 0.5],
            closing_speed: [0.5, 3.0],
            lateral_fraction: [0.1, 0.5],
            size_growth: [0.1, 0.5],
            lane_shift: None,
            closing_horizon: 1.0,
            require_surrogate_agreement: true,
        }
    }
}

/// Simulation-augmentation settings (used only when a second event folder is given).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimulationConfig {
    /// Total pairs, split over temporal / cross-sequence / physics like the primary targets.
    pub pairs: usize,
    pub beta: f32,
}

impl Default for SimulationConfig {
    fn default() -> Self {
        SimulationConfig {
            pairs: 4000,
            beta: 0.5,
        }
    }
}

/// Which conflict states feed the anchoring terms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnchorConfig {
    /// Half-width (s) of the impact window around the endpoint: `|t - t_impact| <= tol`.
    pub impact_tolerance: f64,
    /// At most this many impact-window states (sampled deterministically when more exist).
    pub max_impact: usize,
    /// At most this many earlier conflict states for the upper-bound term.
    pub max_upper: usize,
}

impl Default for AnchorConfig {
    fn default() -> Self {
        AnchorConfig {
            impact_tolerance: 0.2,
            max_impact: 2000,
            max_upper: 4000,
        }
    }
}

/// All comparison settings (`[comparisons]` in the training TOML).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ComparisonConfig {
    pub temporal: TemporalConfig,
    pub cross_sequence: CrossSequenceConfig,
    pub physics: PhysicsConfig,
    pub simulation: SimulationConfig,
    pub anchors: AnchorConfig,
}

impl ComparisonConfig {
    pub fn beta(&self) -> [f32; 4] {
        [
            self.temporal.beta,
            self.cross_sequence.beta,
            self.physics.beta,
            self.simulation.beta,
        ]
    }

    /// Keep only the listed sources (others get zero pairs). Used by ablations.
    pub fn restricted_to(&self, sources: &[Source]) -> ComparisonConfig {
        let mut c = self.clone();
        if !sources.contains(&Source::Temporal) {
            c.temporal.pairs = 0;
        }
        if !sources.contains(&Source::CrossSequence) {
            c.cross_sequence.pairs = 0;
        }
        if !sources.contains(&Source::Physics) {
            c.physics.pairs = 0;
        }
        if !sources.contains(&Source::Simulation) {
            c.simulation.pairs = 0;
        }
        c
    }

    /// Scale every pair target by `factor` (validation sets use a fraction of the targets).
    pub fn scaled(&self, factor: f64) -> ComparisonConfig {
        let s = |n: usize| ((n as f64) * factor).round() as usize;
        let mut c = self.clone();
        c.temporal.pairs = s(c.temporal.pairs);
        c.cross_sequence.pairs = s(c.cross_sequence.pairs);
        c.physics.pairs = s(c.physics.pairs);
        c.simulation.pairs = s(c.simulation.pairs);
        c.anchors.max_impact = s(c.anchors.max_impact);
        c.anchors.max_upper = s(c.anchors.max_upper);
        c
    }

    /// Bytes the configured comparisons take at least while they are built and trained on: per
    /// pair the pair and its weight, and for a physics pair its counterfactual observation row;
    /// per anchor its row index. Sequences and the frames' own rows come on top.
    pub fn memory_estimate(&self) -> u64 {
        use std::mem::size_of;
        let row = (size_of::<scorer_core::Features>()
            + size_of::<scorer_core::Surrogates>()
            + size_of::<scorer_core::DrlInputs>()
            + size_of::<super::RowOrigin>()) as u64;
        let pair = (size_of::<super::Pair>() + size_of::<f32>()) as u64;
        let pairs = self.temporal.pairs as u64
            + self.cross_sequence.pairs as u64
            + self.physics.pairs as u64
            + self.simulation.pairs as u64;
        let anchors = self.anchors.max_impact as u64 + self.anchors.max_upper as u64;
        pairs
            .saturating_mul(pair)
            .saturating_add((self.physics.pairs as u64).saturating_mul(row))
            .saturating_add(anchors.saturating_mul(size_of::<u32>() as u64))
    }

    // `!(x > y)` on purpose: NaN must fail every check.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn validate(&self) -> Result<(), ComparisonConfigError> {
        for (key, n) in [
            ("temporal.pairs", self.temporal.pairs),
            ("cross_sequence.pairs", self.cross_sequence.pairs),
            ("physics.pairs", self.physics.pairs),
            ("simulation.pairs", self.simulation.pairs),
            ("anchors.max_impact", self.anchors.max_impact),
            ("anchors.max_upper", self.anchors.max_upper),
        ] {
            if n > MAX_PAIRS {
                return Err(ComparisonConfigError(format!(
                    "comparisons.{key} = {n}: at most {MAX_PAIRS} (the observation table is \
                     indexed by u32, and training passes over every pair each epoch)"
                )));
            }
        }
        let t = &self.temporal;
        if !(t.dmin > 0.0 && t.dmax >= t.dmin && t.dmax.is_finite()) {
            return Err(ComparisonConfigError(format!(
                "comparisons.temporal: need 0 < dmin <= dmax, got dmin = {}, dmax = {}",
                t.dmin, t.dmax
            )));
        }
        let c = self.cross_sequence.closest_fraction;
        if !(0.0..=1.0).contains(&c) {
            return Err(ComparisonConfigError(format!(
                "comparisons.cross_sequence.closest_fraction: need 0 <= x <= 1, got {c}"
            )));
        }
        let w = self.cross_sequence.closest_window;
        if !(w >= 0.0 && w.is_finite()) {
            return Err(ComparisonConfigError(format!(
                "comparisons.cross_sequence.closest_window: need a finite x >= 0 (s), got {w}"
            )));
        }
        let p = &self.physics;
        for (name, r) in [
            ("gap_fraction", p.gap_fraction),
            ("closing_speed", p.closing_speed),
            ("lateral_fraction", p.lateral_fraction),
            ("size_growth", p.size_growth),
        ]
        .into_iter()
        .chain(p.lane_shift.map(|r| ("lane_shift", r)))
        {
            if !(r[0] > 0.0 && r[1] >= r[0] && r[1].is_finite()) {
                return Err(ComparisonConfigError(format!(
                    "comparisons.physics.{name}: need 0 < lo <= hi, got [{}, {}]",
                    r[0], r[1]
                )));
            }
        }
        for (name, r) in [
            ("gap_fraction", p.gap_fraction),
            ("lateral_fraction", p.lateral_fraction),
        ] {
            if r[1] >= 1.0 {
                return Err(ComparisonConfigError(format!(
                    "comparisons.physics.{name}: hi must be < 1 (got {})",
                    r[1]
                )));
            }
        }
        if !(p.closing_horizon > 0.0 && p.closing_horizon.is_finite()) {
            return Err(ComparisonConfigError(
                "comparisons.physics.closing_horizon must be finite and > 0".into(),
            ));
        }
        for (name, b) in [
            ("temporal", self.temporal.beta),
            ("cross_sequence", self.cross_sequence.beta),
            ("physics", self.physics.beta),
            ("simulation", self.simulation.beta),
        ] {
            if !(b >= 0.0 && b.is_finite()) {
                return Err(ComparisonConfigError(format!(
                    "comparisons.{name}.beta must be finite and >= 0"
                )));
            }
        }
        if !(self.anchors.impact_tolerance >= 0.0 && self.anchors.impact_tolerance.is_finite()) {
            return Err(ComparisonConfigError(
                "comparisons.anchors.impact_tolerance must be finite and >= 0".into(),
            ));
        }
        Ok(())
    }
}
