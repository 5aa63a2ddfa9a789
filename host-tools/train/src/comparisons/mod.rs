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
pub mod cross_sequence;
pub mod physics;
pub mod temporal;

use std::collections::HashMap;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use riskscore_data::events::EventKind;
use scorer_core::{DrlInputs, Features, Observation, Surrogates, VehicleState};
use serde::{Deserialize, Serialize};

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
    fn rng(self, seed: u64) -> ChaCha8Rng {
        let tag = 0x9E37_79B9_7F4A_7C15u64.wrapping_mul(self.index() as u64 + 1);
        ChaCha8Rng::seed_from_u64(seed ^ tag)
    }
}

/// One prepared sequence of an ego/partner pair, the unit comparisons are drawn from.
///
/// Times are strictly increasing; `ego`, `partner` and `times` have equal lengths.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainingSequence {
    pub event_id: String,
    pub kind: EventKind,
    /// `t_impact` of the event (seconds, same clock as the frame times); only a conflict kind's
    /// endpoint counts (see [`TrainingSequence::endpoint`]).
    pub endpoint: Option<f64>,
    pub times: Vec<f64>,
    pub ego: Vec<VehicleState>,
    pub partner: Vec<VehicleState>,
}

impl TrainingSequence {
    /// An empty sequence of `kind` (frames are pushed afterwards); `endpoint` is `t_impact`.
    pub fn empty(event_id: impl Into<String>, kind: EventKind, endpoint: Option<f64>) -> Self {
        TrainingSequence {
            event_id: event_id.into(),
            kind,
            endpoint,
            times: Vec::new(),
            ego: Vec::new(),
            partner: Vec::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.times.len()
    }

    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// The conflict endpoint: `None` for a safe sequence, and for a conflict kind without one.
    pub fn endpoint(&self) -> Option<f64> {
        self.endpoint.filter(|_| self.kind.is_conflict())
    }

    pub fn is_conflict(&self) -> bool {
        self.endpoint().is_some()
    }

    /// Indices of frames at or before the endpoint (the alert window of a conflict sequence).
    pub fn frames_up_to_endpoint(&self) -> usize {
        match self.endpoint() {
            Some(t) => self.times.iter().take_while(|&&x| x <= t + 1e-9).count(),
            None => self.len(),
        }
    }
}

impl From<&riskscore_data::events::Sequence> for TrainingSequence {
    fn from(s: &riskscore_data::events::Sequence) -> Self {
        TrainingSequence {
            event_id: s.event_id.clone(),
            kind: s.kind,
            endpoint: s.endpoint,
            times: s.frames.iter().map(|f| f.time).collect(),
            ego: s.frames.iter().map(|f| f.ego).collect(),
            partner: s.frames.iter().map(|f| f.sur).collect(),
        }
    }
}

/// Convert prepared sequences (see [`riskscore_data::events::prepare_sequences`]).
pub fn from_sequences(seqs: &[riskscore_data::events::Sequence]) -> Vec<TrainingSequence> {
    seqs.iter().map(TrainingSequence::from).collect()
}

/// Where a row of the observation table comes from (for audits and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowOrigin {
    /// Frame `frame` of sequence `sequence` of the training (or, with `augmentation`, the
    /// augmentation) sequences passed to [`build`].
    Frame {
        augmentation: bool,
        sequence: u32,
        frame: u32,
    },
    /// A physics counterfactual of the row `of`.
    Counterfactual { of: u32 },
    /// Added directly (tests, external tables).
    External,
}

/// Every observation used by pairs or anchors, computed by scorer-core once per row
/// ([`Observation::of`]) and stored by column (features, surrogates, DRL inputs), so each model
/// reads the part it needs as a slice.
#[derive(Clone, Debug, Default)]
pub struct ObservationTable {
    pub features: Vec<Features>,
    pub surrogates: Vec<Surrogates>,
    pub drl_inputs: Vec<DrlInputs>,
    pub origins: Vec<RowOrigin>,
}

impl ObservationTable {
    pub fn len(&self) -> usize {
        self.features.len()
    }

    pub fn is_empty(&self) -> bool {
        self.features.is_empty()
    }

    /// Compute and append one observation; returns its row.
    pub fn push(&mut self, ego: &VehicleState, partner: &VehicleState, origin: RowOrigin) -> u32 {
        self.push_computed(Observation::of(ego, partner), origin)
    }

    /// Append an observation that is already computed.
    pub fn push_computed(&mut self, observation: Observation, origin: RowOrigin) -> u32 {
        self.features.push(observation.features);
        self.surrogates.push(observation.surrogates);
        self.drl_inputs.push(observation.drl_inputs);
        self.origins.push(origin);
        (self.features.len() - 1) as u32
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

    // `!(x > y)` on purpose: NaN must fail every check.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn validate(&self) -> Result<(), String> {
        let t = &self.temporal;
        if !(t.dmin > 0.0 && t.dmax >= t.dmin && t.dmax.is_finite()) {
            return Err(format!(
                "comparisons.temporal: need 0 < dmin <= dmax, got dmin = {}, dmax = {}",
                t.dmin, t.dmax
            ));
        }
        let c = self.cross_sequence.closest_fraction;
        if !(0.0..=1.0).contains(&c) {
            return Err(format!(
                "comparisons.cross_sequence.closest_fraction: need 0 <= x <= 1, got {c}"
            ));
        }
        let w = self.cross_sequence.closest_window;
        if !(w >= 0.0 && w.is_finite()) {
            return Err(format!(
                "comparisons.cross_sequence.closest_window: need a finite x >= 0 (s), got {w}"
            ));
        }
        let p = &self.physics;
        for (name, r) in [
            ("gap_fraction", p.gap_fraction),
            ("closing_speed", p.closing_speed),
            ("lateral_fraction", p.lateral_fraction),
            ("size_growth", p.size_growth),
        ] {
            if !(r[0] > 0.0 && r[1] >= r[0] && r[1].is_finite()) {
                return Err(format!(
                    "comparisons.physics.{name}: need 0 < lo <= hi, got [{}, {}]",
                    r[0], r[1]
                ));
            }
        }
        for (name, r) in [
            ("gap_fraction", p.gap_fraction),
            ("lateral_fraction", p.lateral_fraction),
        ] {
            if r[1] >= 1.0 {
                return Err(format!(
                    "comparisons.physics.{name}: hi must be < 1 (got {})",
                    r[1]
                ));
            }
        }
        if !(p.closing_horizon > 0.0) {
            return Err("comparisons.physics.closing_horizon must be > 0".into());
        }
        for (name, b) in [
            ("temporal", self.temporal.beta),
            ("cross_sequence", self.cross_sequence.beta),
            ("physics", self.physics.beta),
            ("simulation", self.simulation.beta),
        ] {
            if !(b >= 0.0 && b.is_finite()) {
                return Err(format!("comparisons.{name}.beta must be finite and >= 0"));
            }
        }
        if !(self.anchors.impact_tolerance >= 0.0) {
            return Err("comparisons.anchors.impact_tolerance must be >= 0".into());
        }
        Ok(())
    }
}

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
    fn new() -> Self {
        TableBuilder {
            table: ObservationTable::default(),
            frame_rows: HashMap::new(),
        }
    }

    /// Row of frame `frame` of sequence `seq` (computed on first use).
    pub fn frame(
        &mut self,
        origin: Origin,
        seqs: &[TrainingSequence],
        seq: usize,
        frame: usize,
    ) -> u32 {
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
        let row = self.table.push(&s.ego[frame], &s.partner[frame], origin);
        self.frame_rows.insert(key, row);
        row
    }

    /// Row of a counterfactual state of row `of`.
    pub fn counterfactual(&mut self, ego: &VehicleState, partner: &VehicleState, of: u32) -> u32 {
        self.table
            .push(ego, partner, RowOrigin::Counterfactual { of })
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

/// Build all comparisons and anchors from the training sequences (and, optionally, the sequences of
/// an augmentation folder). Deterministic in `seed`.
///
/// Only the sequences passed in are read, so passing the training partition guarantees that no
/// validation or test event leaks into the comparisons.
pub fn build(
    train: &[TrainingSequence],
    augmentation: Option<&[TrainingSequence]>,
    config: &ComparisonConfig,
    seed: u64,
) -> ComparisonSet {
    let started = Instant::now();
    let mut tb = TableBuilder::new();
    let mut pairs = Vec::new();
    let mut per_source = Vec::new();

    let t0 = Instant::now();
    let mut rng = Source::Temporal.rng(seed);
    let (mut p, mut stats) = temporal::build(
        train,
        Origin::Primary,
        &config.temporal,
        config.temporal.pairs,
        Source::Temporal,
        &mut tb,
        &mut rng,
    );
    stats.seconds = t0.elapsed().as_secs_f64();
    pairs.append(&mut p);
    per_source.push((Source::Temporal, stats));

    let t0 = Instant::now();
    let mut rng = Source::CrossSequence.rng(seed);
    let (mut p, mut stats) = cross_sequence::build(
        train,
        Origin::Primary,
        &config.cross_sequence,
        config.cross_sequence.pairs,
        Source::CrossSequence,
        &mut tb,
        &mut rng,
    );
    stats.seconds = t0.elapsed().as_secs_f64();
    pairs.append(&mut p);
    per_source.push((Source::CrossSequence, stats));

    let t0 = Instant::now();
    let mut rng = Source::Physics.rng(seed);
    let (mut p, mut stats) = physics::build(
        train,
        Origin::Primary,
        &config.physics,
        config.physics.pairs,
        Source::Physics,
        &mut tb,
        &mut rng,
    );
    stats.seconds = t0.elapsed().as_secs_f64();
    pairs.append(&mut p);
    per_source.push((Source::Physics, stats));

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
    train: &[TrainingSequence],
    config: &AnchorConfig,
    tb: &mut TableBuilder,
    seed: u64,
) -> Anchors {
    use rand::seq::SliceRandom;
    let mut impact = Vec::new();
    let mut upper = Vec::new();
    for (si, s) in train.iter().enumerate() {
        let Some(endpoint) = s.endpoint() else {
            continue;
        };
        for (fi, &t) in s.times.iter().enumerate() {
            if t > endpoint + riskscore_data::events::TIME_TOLERANCE_S {
                continue;
            }
            if endpoint - t <= config.impact_tolerance + 1e-9 {
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
