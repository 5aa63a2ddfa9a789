//! Which recorded road users interact, and the safe sequences their interactions yield.
//!
//! Rules (docs/real-data.md, "Interaction rules"):
//! 1. Two road users are *near* at a time step when both are recorded at it, their boxes do not
//!    overlap (an overlap is a recording artefact, not a crash: that frame is dropped and the
//!    interaction is split there), the gap between the boxes is at most `max_gap`, and, by their
//!    geometry (`scorer_core::interaction::geometry`, the one shared definition):
//!    - travelling the same way (following, adjacent): the lateral centre offset measured across
//!      either one's heading is at most `max_lateral`;
//!    - crossing or oncoming: their predicted closest approach (constant velocities, within
//!      `horizon` s from now, now included) brings the centres within `max_approach`.
//! 2. An *interaction* is a maximal run of consecutive time steps (no missing step) on which the
//!    pair is near.
//! 3. The ego of an interaction is chosen by [`EgoChoice`]; the other road user is the partner.
//! 4. Each interaction is cut with [`cut_safe_sequences`] (the library's safe-sequence rules:
//!    both |acc| <= `safe_max_abs_acc`, pieces of `safe_min_duration` to `safe_max_duration`).
//! 5. Each sequence's geometry is the one at its closest approach ([`ClosestApproach`]); only
//!    sequences of a geometry in `geometries` are kept.
use scorer_core::geometry::{box_distance, boxes_overlap, position, velocity};
use scorer_core::interaction::{geometry, Geometry};
use scorer_core::VehicleState;

use super::repeats::Earlier;
use super::smoothing::smooth_acceleration;
use super::xml::{Scenario, Track, TrackState};
use crate::events::{cut_safe_sequences, Dims, Event, EventKind, Frame, PrepareConfig};

/// Who is the ego of an interaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EgoChoice {
    /// The road user behind: the partner's centre lies ahead along the ego's heading, averaged
    /// over the interaction (a forward-warning system's view of its leader, cut-in or merging
    /// neighbour). One event per interaction.
    Follower,
    /// Both orders: two events per interaction, mirror images of each other.
    Both,
}

impl EgoChoice {
    /// The CLI spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            EgoChoice::Follower => "follower",
            EgoChoice::Both => "both",
        }
    }
}

/// A set of [`Geometry`] values (which interactions an import keeps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeometrySet {
    /// Indexed like [`Geometry::ALL`].
    members: [bool; 4],
}

impl GeometrySet {
    /// Every geometry.
    pub const ALL: GeometrySet = GeometrySet { members: [true; 4] };

    /// Exactly the geometries in `list`.
    pub fn of(list: &[Geometry]) -> GeometrySet {
        let mut members = [false; 4];
        for g in list {
            members[geometry_index(*g)] = true;
        }
        GeometrySet { members }
    }

    pub fn contains(&self, g: Geometry) -> bool {
        self.members[geometry_index(g)]
    }

    /// The members in [`Geometry::ALL`] order.
    pub fn iter(&self) -> impl Iterator<Item = Geometry> + '_ {
        Geometry::ALL.into_iter().filter(|g| self.contains(*g))
    }

    /// Parses a comma-separated list of geometry names (`following,crossing`); `all` is every one.
    pub fn parse(text: &str) -> Result<GeometrySet, String> {
        if text.trim() == "all" {
            return Ok(GeometrySet::ALL);
        }
        let mut list = Vec::new();
        for name in text.split(',').map(str::trim) {
            let g = Geometry::from_name(name).ok_or_else(|| {
                format!(
                    "`{name}` is not a geometry (one or more of following, adjacent, crossing, oncoming, comma-separated, or all)"
                )
            })?;
            list.push(g);
        }
        Ok(GeometrySet::of(&list))
    }
}

impl std::fmt::Display for GeometrySet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = self.iter().map(Geometry::as_str).collect();
        f.write_str(&names.join(","))
    }
}

/// Position of `g` in [`Geometry::ALL`] (and in the per-geometry counts).
pub fn geometry_index(g: Geometry) -> usize {
    match g {
        Geometry::Following => 0,
        Geometry::Adjacent => 1,
        Geometry::Crossing => 2,
        Geometry::Oncoming => 3,
    }
}

/// The interaction rules; [`Default`] gives the documented defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InteractionRules {
    /// Largest gap between the two boxes (m); default 30.
    pub max_gap: f32,
    /// Road users travelling the same way (following, adjacent): largest lateral offset of the
    /// centres across either heading (m); default 5 (same or adjacent lane on 3.7 m lanes).
    pub max_lateral: f32,
    /// Crossing and oncoming road users: largest centre distance of their predicted closest
    /// approach (m); default 10.
    pub max_approach: f32,
    /// Crossing and oncoming road users: how far ahead the closest approach is predicted, at
    /// constant velocities (s); default 3.
    pub horizon: f32,
    /// The geometries (at each sequence's closest approach) kept; default all.
    pub geometries: GeometrySet,
    /// Seconds of the centred moving average of the speed that the acceleration is derived
    /// from ([`super::smoothing::smooth_acceleration`]); default 0: the recorded acceleration.
    pub speed_smoothing: f64,
    /// Across the files of one import ([`super::import_to_dir`]): drop the pair-steps an earlier
    /// file already holds (the same two vehicles at the same moment, [`super::repeats`]), so
    /// overlapping scenario files do not yield one interaction twice; default false.
    pub skip_repeats: bool,
    /// Default [`EgoChoice::Both`]: the scorer rates every surrounding road user, so the
    /// partner-behind view is as real an observation as the follower's.
    pub ego: EgoChoice,
    /// The safe-sequence rules (`safe_min_duration`, `safe_max_duration`, `safe_max_abs_acc`).
    pub safe: PrepareConfig,
}

impl Default for InteractionRules {
    fn default() -> Self {
        Self {
            max_gap: 30.0,
            max_lateral: 5.0,
            max_approach: 10.0,
            horizon: 3.0,
            geometries: GeometrySet::ALL,
            speed_smoothing: 0.0,
            skip_repeats: false,
            ego: EgoChoice::Both,
            safe: PrepareConfig::default(),
        }
    }
}

/// Counts of one scenario's (or a whole import's) pair extraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PairCounts {
    /// Pairs of imported road users recorded at a common time step.
    pub pairs_overlapping_in_time: usize,
    /// Pairs with at least one interaction.
    pub pairs_interacting: usize,
    /// Interactions (runs of near time steps).
    pub interactions: usize,
    /// Time steps (per pair) on which the two boxes overlap: dropped, interaction split there.
    pub overlap_frames: usize,
    /// Time steps (per pair) an earlier file already holds (`skip_repeats`): dropped,
    /// interaction split there.
    pub repeated_frames: usize,
    /// Time steps (per pair) with the boxes apart and at most `max_gap` between them, by the
    /// geometry of the second road user seen from the first (indexed like [`Geometry::ALL`]).
    pub within_gap_frames: [usize; 4],
    /// Of those, the near ones (the lateral or the closest-approach rule holds).
    pub near_frames: [usize; 4],
    /// Frames of all interactions, per ego order.
    pub interaction_frames: usize,
    /// Safe sequences written, and their frames.
    pub sequences: usize,
    pub frames: usize,
    /// Safe sequences by their geometry at closest approach, before the `geometries` filter
    /// (indexed like [`Geometry::ALL`]); the ones outside it are not in `sequences`.
    pub sequences_by_geometry: [usize; 4],
    pub frames_by_geometry: [usize; 4],
}

impl PairCounts {
    pub fn add(&mut self, o: &PairCounts) {
        self.pairs_overlapping_in_time += o.pairs_overlapping_in_time;
        self.pairs_interacting += o.pairs_interacting;
        self.interactions += o.interactions;
        self.overlap_frames += o.overlap_frames;
        self.repeated_frames += o.repeated_frames;
        for g in 0..4 {
            self.within_gap_frames[g] += o.within_gap_frames[g];
            self.near_frames[g] += o.near_frames[g];
            self.sequences_by_geometry[g] += o.sequences_by_geometry[g];
            self.frames_by_geometry[g] += o.frames_by_geometry[g];
        }
        self.interaction_frames += o.interaction_frames;
        self.sequences += o.sequences;
        self.frames += o.frames;
    }
}

/// A safe event and how close its two road users came.
#[derive(Clone, Debug, PartialEq)]
pub struct SafeInteraction {
    pub event: Event,
    /// Smallest box gap over the event's frames (m).
    pub min_gap: f32,
    /// Smallest centre distance over the event's frames (m).
    pub min_centre_distance: f32,
    /// The frame of the smallest box gap and the geometry there.
    pub closest: ClosestApproach,
}

/// Where an event's two road users come closest: the frame of the smallest box gap (the first
/// one on a tie) and the pair's geometry there, seen from the ego.
///
/// This is the geometry an event is filed under: an interaction can change geometry as it goes
/// (a left turn is oncoming, then crossing, then following), and the moment of closest approach
/// is the one a risk score is judged at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestApproach {
    /// Index into the event's frames.
    pub frame: usize,
    pub time: f64,
    /// Box gap there (m).
    pub gap: f32,
    /// `None` when the ego has no heading or a position is not finite there.
    pub geometry: Option<Geometry>,
}

/// The closest approach of `frames`, `None` when there are none.
pub fn closest_approach(frames: &[Frame]) -> Option<ClosestApproach> {
    let mut best: Option<ClosestApproach> = None;
    for (i, f) in frames.iter().enumerate() {
        let gap = box_distance(&f.ego, &f.partner);
        if best.is_none_or(|b| gap < b.gap) {
            best = Some(ClosestApproach {
                frame: i,
                time: f.time,
                gap,
                geometry: geometry(&f.ego, &f.partner),
            });
        }
    }
    best
}

/// Smallest centre distance of `a` and `b` over the next `horizon` seconds (now included), both
/// moving on at their present velocities (m).
pub fn predicted_closest_distance(a: &VehicleState, b: &VehicleState, horizon: f32) -> f32 {
    let offset = position(b) - position(a);
    let closing = velocity(b) - velocity(a);
    let speed2 = closing.norm2();
    let t = if speed2 > 0.0 {
        (-offset.dot(closing) / speed2).clamp(0.0, horizon)
    } else {
        0.0
    };
    (offset + closing.scale(t)).norm()
}

/// The event id of a sequence: `{scenario}/{ego}-{partner}@{first step}#{piece}`.
///
/// The part before the first `/` is the scenario id (the file stem), so data can be split by
/// scenario file ([`super::scenario_of_event_id`]).
pub fn interaction_id(scenario: &str, ego: &str, partner: &str, first_step: i64) -> String {
    format!("{scenario}/{ego}-{partner}@{first_step}")
}

/// The road-user state at one recorded state (velocity and heading from the recorded heading).
pub fn vehicle_state(s: &TrackState, length: f32, width: f32) -> VehicleState {
    let (sin, cos) = s.orientation.sin_cos();
    VehicleState {
        x: s.x as f32,
        y: s.y as f32,
        vx: (s.speed * cos) as f32,
        vy: (s.speed * sin) as f32,
        hx: cos as f32,
        hy: sin as f32,
        acc: s.acc as f32,
        length,
        width,
    }
}

/// Seconds of a time step: `step x dt`, rounded to 1 us so that e.g. step 30 at 0.1 s is 3 s,
/// not 3.0000000000000004 (exact, short numbers in `frames.csv`).
pub fn step_time(step: i64, dt: f64) -> f64 {
    (step as f64 * dt * 1e6).round() / 1e6
}

/// Lateral offset of `b`'s centre across `a`'s heading (m).
fn lateral_offset(a: &VehicleState, b: &VehicleState) -> f32 {
    ((b.x - a.x) * -a.hy + (b.y - a.y) * a.hx).abs()
}

/// Offset of `b`'s centre along `a`'s heading (m), positive ahead.
fn longitudinal_offset(a: &VehicleState, b: &VehicleState) -> f32 {
    (b.x - a.x) * a.hx + (b.y - a.y) * a.hy
}

/// The safe interactions of one scenario, in a stable order (tracks in file order, pairs by
/// first track, interactions in time).
pub fn safe_interactions(
    scenario: &Scenario,
    rules: &InteractionRules,
) -> (Vec<SafeInteraction>, PairCounts) {
    safe_interactions_except(scenario, rules, &[])
}

/// Like [`safe_interactions`], without the pair-steps whose two states repeat one earlier
/// recording (`repeats`, indexed like the scenario's tracks; empty: none repeat).
pub fn safe_interactions_except(
    scenario: &Scenario,
    rules: &InteractionRules,
    repeats: &[Vec<Option<Earlier>>],
) -> (Vec<SafeInteraction>, PairCounts) {
    let mut out = Vec::new();
    let mut counts = PairCounts::default();
    let smoothed;
    let tracks = if rules.speed_smoothing > 0.0 {
        let mut copy = scenario.tracks.clone();
        for t in &mut copy {
            smooth_acceleration(t, rules.speed_smoothing, scenario.dt);
        }
        smoothed = copy;
        &smoothed
    } else {
        &scenario.tracks
    };
    let repeated = |i: usize| repeats.get(i).map_or(&[][..], Vec::as_slice);
    for (i, a) in tracks.iter().enumerate() {
        for (j, b) in tracks.iter().enumerate().skip(i + 1) {
            let pair = Pair {
                a,
                b,
                a_repeats: repeated(i),
                b_repeats: repeated(j),
            };
            pair_interactions(scenario, &pair, rules, &mut out, &mut counts);
        }
    }
    (out, counts)
}

/// One recorded time step of a pair: both states, on the scenario clock.
struct PairStep {
    step: i64,
    a: VehicleState,
    b: VehicleState,
}

/// Two tracks and where their states were recorded before (empty: nowhere).
struct Pair<'a> {
    a: &'a Track,
    b: &'a Track,
    a_repeats: &'a [Option<Earlier>],
    b_repeats: &'a [Option<Earlier>],
}

impl Pair<'_> {
    /// Whether state `i` of `a` and state `j` of `b` are the same moment of one earlier file.
    fn repeated(&self, i: usize, j: usize) -> bool {
        match (self.a_repeats.get(i), self.b_repeats.get(j)) {
            (Some(Some(ea)), Some(Some(eb))) => ea == eb,
            _ => false,
        }
    }
}

fn pair_interactions(
    scenario: &Scenario,
    pair: &Pair,
    rules: &InteractionRules,
    out: &mut Vec<SafeInteraction>,
    counts: &mut PairCounts,
) {
    let (a, b) = (pair.a, pair.b);
    let (first, last) = match (
        a.states.first(),
        a.states.last(),
        b.states.first(),
        b.states.last(),
    ) {
        (Some(a0), Some(a1), Some(b0), Some(b1)) => (a0.step.max(b0.step), a1.step.min(b1.step)),
        _ => return,
    };
    if first > last {
        return;
    }
    counts.pairs_overlapping_in_time += 1;
    let mut run: Vec<PairStep> = Vec::new();
    let mut interacting = false;
    let (mut i, mut j) = (0, 0);
    while i < a.states.len() && j < b.states.len() {
        let (sa, sb) = (&a.states[i], &b.states[j]);
        if sa.step < sb.step {
            i += 1;
            continue;
        }
        if sb.step < sa.step {
            j += 1;
            continue;
        }
        let (va, vb) = (
            vehicle_state(sa, a.length, a.width),
            vehicle_state(sb, b.length, b.width),
        );
        let repeated = pair.repeated(i, j);
        counts.repeated_frames += usize::from(repeated);
        let near = !repeated && near(&va, &vb, rules, counts);
        let contiguous = run.last().is_none_or(|p| p.step + 1 == sa.step);
        if !near || !contiguous {
            interacting |= emit(scenario, a, b, &run, rules, out, counts);
            run.clear();
        }
        if near {
            run.push(PairStep {
                step: sa.step,
                a: va,
                b: vb,
            });
        }
        i += 1;
        j += 1;
    }
    interacting |= emit(scenario, a, b, &run, rules, out, counts);
    counts.pairs_interacting += usize::from(interacting);
}

/// Whether a pair is near at one step (rule 1 of the module), counted in `counts`.
fn near(
    a: &VehicleState,
    b: &VehicleState,
    rules: &InteractionRules,
    counts: &mut PairCounts,
) -> bool {
    if boxes_overlap(a, b) {
        counts.overlap_frames += 1;
        return false;
    }
    if box_distance(a, b) > rules.max_gap {
        return false;
    }
    let Some(g) = geometry(a, b) else {
        return false;
    };
    counts.within_gap_frames[geometry_index(g)] += 1;
    let near = match g {
        Geometry::Following | Geometry::Adjacent => {
            lateral_offset(a, b).max(lateral_offset(b, a)) <= rules.max_lateral
        }
        Geometry::Crossing | Geometry::Oncoming => {
            predicted_closest_distance(a, b, rules.horizon) <= rules.max_approach
        }
    };
    counts.near_frames[geometry_index(g)] += usize::from(near);
    near
}

/// Cuts one interaction (a run of near steps) into safe sequences for the chosen ego order(s).
/// Returns whether the run was an interaction at all (non-empty).
fn emit(
    scenario: &Scenario,
    a: &Track,
    b: &Track,
    run: &[PairStep],
    rules: &InteractionRules,
    out: &mut Vec<SafeInteraction>,
    counts: &mut PairCounts,
) -> bool {
    let Some(first) = run.first() else {
        return false;
    };
    counts.interactions += 1;
    let a_follows = || {
        let ahead: f64 = run
            .iter()
            .map(|p| f64::from(longitudinal_offset(&p.a, &p.b)))
            .sum();
        ahead >= 0.0
    };
    let orders: &[bool] = match rules.ego {
        EgoChoice::Both => &[true, false],
        EgoChoice::Follower if a_follows() => &[true],
        EgoChoice::Follower => &[false],
    };
    for &a_is_ego in orders {
        let (ego, partner) = if a_is_ego { (a, b) } else { (b, a) };
        let frames: Vec<Frame> = run
            .iter()
            .map(|p| {
                let (e, s) = if a_is_ego { (p.a, p.b) } else { (p.b, p.a) };
                Frame {
                    time: step_time(p.step, scenario.dt),
                    ego: e,
                    partner: s,
                }
            })
            .collect();
        counts.interaction_frames += frames.len();
        let id = interaction_id(&scenario.id, &ego.id, &partner.id, first.step);
        for seq in cut_safe_sequences(&id, &frames, &[], &rules.safe) {
            let (Some(f0), Some(f1)) = (seq.frames.first(), seq.frames.last()) else {
                continue;
            };
            let (t_start, t_end) = (f0.time, f1.time);
            let Some(closest) = closest_approach(&seq.frames) else {
                continue;
            };
            // Recorded road users always have a heading (from `orientation`); a geometry-less
            // sequence could not be filed under any slice.
            let Some(g) = closest.geometry else {
                continue;
            };
            counts.sequences_by_geometry[geometry_index(g)] += 1;
            counts.frames_by_geometry[geometry_index(g)] += seq.frames.len();
            if !rules.geometries.contains(g) {
                continue;
            }
            let min_centre = seq
                .frames
                .iter()
                .map(|f| (f.partner.x - f.ego.x).hypot(f.partner.y - f.ego.y))
                .fold(f32::INFINITY, f32::min);
            counts.sequences += 1;
            counts.frames += seq.frames.len();
            out.push(SafeInteraction {
                event: Event {
                    id: seq.event_id,
                    kind: EventKind::Safe,
                    t_start,
                    t_end,
                    t_impact: None,
                    dims: Dims {
                        length_ego: ego.length,
                        width_ego: ego.width,
                        length_partner: partner.length,
                        width_partner: partner.width,
                    },
                    frames: seq.frames,
                },
                min_gap: closest.gap,
                min_centre_distance: min_centre,
                closest,
            });
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A car moving in a straight line at constant speed: `steps` states from step 0.
    fn car(id: &str, x0: f64, y0: f64, heading_deg: f64, speed: f64, steps: i64) -> Track {
        let (sin, cos) = heading_deg.to_radians().sin_cos();
        Track {
            id: id.into(),
            kind: "car".into(),
            length: 4.5,
            width: 1.8,
            states: (0..steps)
                .map(|step| {
                    let t = step as f64 * 0.1;
                    TrackState {
                        step,
                        x: x0 + speed * cos * t,
                        y: y0 + speed * sin * t,
                        orientation: heading_deg.to_radians(),
                        speed,
                        acc: 0.0,
                    }
                })
                .collect(),
        }
    }

    fn scenario(tracks: Vec<Track>) -> Scenario {
        Scenario {
            id: "ZAM_Rules-1_1_T-1".into(),
            version: "2020a".into(),
            dt: 0.1,
            origin: (0.0, 0.0),
            tracks,
            ignored: Vec::new(),
            issues: Vec::new(),
        }
    }

    fn geometries(found: &[SafeInteraction]) -> Vec<(String, Option<Geometry>)> {
        found
            .iter()
            .map(|s| (s.event.id.clone(), s.closest.geometry))
            .collect()
    }

    /// The ego drives east at 5 m/s from x = -10 for 4 s; a car waits at the stop line of the
    /// crossing street, facing north, `offset` m south of the ego's path at x = 10.
    fn crossing(offset: f64) -> Scenario {
        scenario(vec![
            car("1", -10.0, 0.0, 0.0, 5.0, 41),
            car("2", 10.0, -offset, 90.0, 0.0, 41),
        ])
    }

    #[test]
    fn a_crossing_pair_whose_paths_come_close_is_kept() {
        // Closest predicted approach 8 m (the stop line) from the first step: near throughout.
        let (found, c) = safe_interactions(&crossing(8.0), &InteractionRules::default());
        assert_eq!(c.within_gap_frames[2], 41, "{c:?}");
        assert_eq!(c.near_frames[2], 41);
        assert_eq!(
            geometries(&found),
            [
                (
                    "ZAM_Rules-1_1_T-1/1-2@0#0".to_string(),
                    Some(Geometry::Crossing)
                ),
                (
                    "ZAM_Rules-1_1_T-1/2-1@0#0".to_string(),
                    Some(Geometry::Crossing)
                ),
            ]
        );
        let ego_view = &found[0];
        // The box gap reaches its smallest value, 8 m minus the partner's half length and the
        // ego's half width, once the ego's front passes the partner's near side (x = 6.85 m,
        // t = 3.37 s): the first frame of the tie is 3.4 s.
        assert_eq!(ego_view.closest.time, 3.4);
        assert!((ego_view.min_gap - (8.0 - 2.25 - 0.9)).abs() < 1e-4);
        assert_eq!(c.sequences_by_geometry[2], 2);
    }

    #[test]
    fn a_far_crossing_pair_within_the_gap_is_dropped() {
        // 25 m south of the path: within the 30 m gap, but the paths never come within 10 m.
        let (found, c) = safe_interactions(&crossing(25.0), &InteractionRules::default());
        assert!(c.within_gap_frames[2] > 0, "{c:?}");
        assert_eq!((c.near_frames[2], c.interactions), (0, 0));
        assert!(found.is_empty());
        // A wider approach distance takes it.
        let wide = InteractionRules {
            max_approach: 26.0,
            ..InteractionRules::default()
        };
        assert_eq!(safe_interactions(&crossing(25.0), &wide).0.len(), 2);
    }

    #[test]
    fn an_oncoming_pair_two_lanes_over_is_kept_where_the_lateral_rule_dropped_it() {
        // Opposite directions 7 m apart (beyond --max-lateral 5), passing after 3 s.
        let s = scenario(vec![
            car("1", -15.0, 0.0, 0.0, 5.0, 31),
            car("2", 15.0, 7.0, 180.0, 5.0, 31),
        ]);
        let (found, c) = safe_interactions(&s, &InteractionRules::default());
        assert_eq!(c.near_frames[3], 31, "{c:?}");
        assert_eq!(found.len(), 2);
        assert!(found
            .iter()
            .all(|f| f.closest.geometry == Some(Geometry::Oncoming)));
        // Predicted closest approach 7 m: a 6 m limit drops it.
        let tight = InteractionRules {
            max_approach: 6.0,
            ..InteractionRules::default()
        };
        assert!(safe_interactions(&s, &tight).0.is_empty());
    }

    #[test]
    fn same_way_pairs_keep_the_lateral_rule() {
        // Following 10 m ahead in the lane; adjacent at 4 m (kept) and at 6 m (dropped); a
        // partner 20 degrees off the ego's heading still travels the same way.
        let s = scenario(vec![
            car("1", 0.0, 0.0, 0.0, 10.0, 31),
            car("2", 15.0, 0.0, 0.0, 10.0, 31),
        ]);
        let (found, c) = safe_interactions(&s, &InteractionRules::default());
        assert_eq!(c.near_frames[0], 31);
        assert_eq!(found[0].closest.geometry, Some(Geometry::Following));
        let side = |lateral: f64| {
            let s = scenario(vec![
                car("1", 0.0, 0.0, 0.0, 10.0, 31),
                car("2", 5.0, lateral, 0.0, 10.0, 31),
            ]);
            safe_interactions(&s, &InteractionRules::default())
        };
        let (found, _) = side(4.0);
        assert_eq!(found[0].closest.geometry, Some(Geometry::Adjacent));
        let (found, c) = side(6.0);
        assert!(found.is_empty());
        assert_eq!((c.within_gap_frames[1], c.near_frames[1]), (31, 0));
        // Heading 20 degrees left, starting 3 m to the side and 8 m ahead: lateral offset across
        // its own heading grows past 5 m after about 1.5 s, so only the first piece is near.
        let s = scenario(vec![
            car("1", 0.0, 0.0, 0.0, 10.0, 31),
            car("2", 8.0, 3.0, 20.0, 10.0, 31),
        ]);
        let (_, c) = safe_interactions(&s, &InteractionRules::default());
        assert_eq!(c.within_gap_frames[2] + c.within_gap_frames[3], 0);
        assert!(c.near_frames[1] > 0 && c.near_frames[1] < 31, "{c:?}");
    }

    #[test]
    fn the_geometry_filter_drops_sequences_but_counts_them() {
        let only_same_way = InteractionRules {
            geometries: GeometrySet::of(&[Geometry::Following, Geometry::Adjacent]),
            ..InteractionRules::default()
        };
        let (found, c) = safe_interactions(&crossing(8.0), &only_same_way);
        assert!(found.is_empty());
        assert_eq!((c.sequences, c.sequences_by_geometry[2]), (0, 2));
    }

    #[test]
    fn geometry_lists_parse_and_print() {
        let set = GeometrySet::parse("oncoming, crossing").unwrap();
        assert_eq!(set.to_string(), "crossing,oncoming");
        assert_eq!(GeometrySet::parse("all").unwrap(), GeometrySet::ALL);
        let err = GeometrySet::parse("following,merging").unwrap_err();
        assert!(err.contains("`merging` is not a geometry"), "{err}");
    }

    #[test]
    fn predicted_closest_distance_looks_ahead_only_within_the_horizon() {
        let s = |x: f64, y: f64, vx: f64| {
            vehicle_state(
                &TrackState {
                    step: 0,
                    x,
                    y,
                    orientation: 0.0,
                    speed: vx,
                    acc: 0.0,
                },
                4.5,
                1.8,
            )
        };
        // Closing at 10 m/s from 40 m with a 3 m offset: closest (3 m) after 4 s.
        let (a, b) = (s(0.0, 0.0, 10.0), s(40.0, 3.0, 0.0));
        assert!((predicted_closest_distance(&a, &b, 5.0) - 3.0).abs() < 1e-4);
        assert!((predicted_closest_distance(&a, &b, 3.0) - 10.0f32.hypot(3.0)).abs() < 1e-4);
        // Moving apart: now is the closest.
        let (a, b) = (s(0.0, 0.0, 0.0), s(20.0, 0.0, 5.0));
        assert_eq!(predicted_closest_distance(&a, &b, 3.0), 20.0);
    }
}
