//! Recorded moments that an earlier scenario file already holds.
//!
//! Benchmark collections cut one long recording into scenario files whose time windows can
//! overlap: the same vehicles, with the same obstacle ids, on a shifted step clock, and possibly
//! in a shifted coordinate origin (NGSIM US-101 `10_1`/`10_4` share coordinates; Peachtree
//! `4_2` starts 20 steps into `4_1`, its positions those of `4_1` plus (0.25, 4.88) m).
//! Imported twice, one real interaction becomes two events under two scenario ids, which a split
//! by scenario file puts on both sides.
//!
//! A track *repeats* an earlier file's track with the same obstacle id when they line up: on one
//! step offset and one translation, at least [`MIN_MATCHING_STATES`] states have the same speed
//! and positions within [`POSITION_TOLERANCE_M`] of each other after the translation. Each such
//! state records the earlier file and offset; a pair-step repeats when both of its states repeat
//! the same file on the same offset (the same two vehicles at the same moment).
use std::collections::{BTreeMap, HashMap};

use super::xml::{Scenario, Track};

/// Largest distance between two recorded positions that are the same recorded position, after
/// the translation between the files (m): far below a car's travel in one 0.1 s step at walking
/// pace, far above conversion rounding.
pub const POSITION_TOLERANCE_M: f64 = 0.05;

/// States that must line up before two tracks with one id count as one recording (a chance
/// match of a few states by two different vehicles with a reused id is not enough).
pub const MIN_MATCHING_STATES: usize = 5;

/// Tracks of one earlier file that must line up on one offset and translation before the file
/// counts as an overlapping window of the same recording.
pub const MIN_ALIGNED_TRACKS: usize = 3;

/// Speeds equal to this many decimals count as the same recorded speed (m/s).
const SPEED_KEY_SCALE: f64 = 1e4;

/// Where a state was recorded before: the earlier file (its index in import order) and the
/// step offset (earlier step = this step + offset).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Earlier {
    pub file: usize,
    pub offset: i64,
}

/// For each track of a scenario (in its order), for each of its states, the earlier recording
/// of that state, if any.
pub type Repeats = Vec<Vec<Option<Earlier>>>;

/// The tracks of the files imported so far, by obstacle id.
#[derive(Default)]
pub struct EarlierTracks {
    by_id: HashMap<String, Vec<IndexedTrack>>,
}

/// One earlier track: its positions by step, and its steps by recorded speed.
struct IndexedTrack {
    file: usize,
    positions: HashMap<i64, (f64, f64)>,
    steps_by_speed: HashMap<i64, Vec<i64>>,
}

fn speed_key(speed: f64) -> i64 {
    (speed * SPEED_KEY_SCALE).round() as i64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// How a later track lines up with an earlier one.
#[derive(Clone, Copy, Debug)]
struct Alignment {
    offset: i64,
    /// Earlier position minus later position.
    shift: (f64, f64),
}

impl IndexedTrack {
    fn new(file: usize, track: &Track) -> Self {
        let mut positions = HashMap::with_capacity(track.states.len());
        let mut steps_by_speed: HashMap<i64, Vec<i64>> = HashMap::new();
        for s in &track.states {
            positions.insert(s.step, (s.x, s.y));
            steps_by_speed
                .entry(speed_key(s.speed))
                .or_default()
                .push(s.step);
        }
        Self {
            file,
            positions,
            steps_by_speed,
        }
    }

    /// The step offset most same-speed states agree on, and the translation (the median of the
    /// position differences on it), if at least [`MIN_MATCHING_STATES`] states then line up.
    fn align(&self, track: &Track) -> Option<Alignment> {
        let mut votes: HashMap<i64, usize> = HashMap::new();
        for s in &track.states {
            for earlier_step in self
                .steps_by_speed
                .get(&speed_key(s.speed))
                .into_iter()
                .flatten()
            {
                *votes.entry(earlier_step - s.step).or_default() += 1;
            }
        }
        let (offset, _) = votes
            .into_iter()
            .filter(|&(_, n)| n >= MIN_MATCHING_STATES)
            .max_by_key(|&(offset, n)| (n, std::cmp::Reverse(offset)))?;
        let (dx, dy): (Vec<f64>, Vec<f64>) = track
            .states
            .iter()
            .filter_map(|s| {
                let p = self.positions.get(&(s.step + offset))?;
                Some((p.0 - s.x, p.1 - s.y))
            })
            .unzip();
        if dx.is_empty() {
            return None;
        }
        let alignment = Alignment {
            offset,
            shift: (median(dx), median(dy)),
        };
        let matching = track
            .states
            .iter()
            .filter(|s| self.repeats(&alignment, s.step, s.x, s.y))
            .count();
        (matching >= MIN_MATCHING_STATES).then_some(alignment)
    }

    fn repeats(&self, alignment: &Alignment, step: i64, x: f64, y: f64) -> bool {
        self.positions
            .get(&(step + alignment.offset))
            .is_some_and(|p| {
                (p.0 - x - alignment.shift.0).hypot(p.1 - y - alignment.shift.1)
                    <= POSITION_TOLERANCE_M
            })
    }
}

impl EarlierTracks {
    /// Which states of `scenario` repeat a file added before.
    ///
    /// Each earlier file that shares obstacle ids gets one alignment (a file is one time window
    /// in one coordinate frame): the step offset and translation on which the most of the shared
    /// tracks line up, at least [`MIN_ALIGNED_TRACKS`] of them. A standing car lines up on any
    /// offset and two different cars with a reused id can line up by chance for a moment; the
    /// file-wide vote settles both.
    pub fn repeats(&self, scenario: &Scenario) -> Repeats {
        let mut found: Repeats = scenario
            .tracks
            .iter()
            .map(|t| vec![None; t.states.len()])
            .collect();
        // Per earlier file: (track index here, its earlier track, their own alignment).
        let mut by_file: BTreeMap<usize, Vec<(usize, &IndexedTrack, Alignment)>> = BTreeMap::new();
        for (i, track) in scenario.tracks.iter().enumerate() {
            for earlier in self.by_id.get(&track.id).into_iter().flatten() {
                if let Some(alignment) = earlier.align(track) {
                    by_file
                        .entry(earlier.file)
                        .or_default()
                        .push((i, earlier, alignment));
                }
            }
        }
        for (file, shared) in by_file {
            let Some(alignment) = file_alignment(&shared) else {
                continue;
            };
            for (i, earlier, _) in shared {
                let states = &scenario.tracks[i].states;
                for (slot, s) in found[i].iter_mut().zip(states) {
                    if slot.is_none() && earlier.repeats(&alignment, s.step, s.x, s.y) {
                        *slot = Some(Earlier {
                            file,
                            offset: alignment.offset,
                        });
                    }
                }
            }
        }
        found
    }

    /// Adds the tracks of `scenario`, imported as file number `file`.
    pub fn add(&mut self, file: usize, scenario: &Scenario) {
        for track in &scenario.tracks {
            self.by_id
                .entry(track.id.clone())
                .or_default()
                .push(IndexedTrack::new(file, track));
        }
    }
}

/// The alignment most tracks agree on (same offset, translations within
/// [`POSITION_TOLERANCE_M`] of each other), if at least [`MIN_ALIGNED_TRACKS`] do; ties go to the
/// first track's.
fn file_alignment(shared: &[(usize, &IndexedTrack, Alignment)]) -> Option<Alignment> {
    let agrees = |a: &Alignment, b: &Alignment| {
        a.offset == b.offset
            && (a.shift.0 - b.shift.0).hypot(a.shift.1 - b.shift.1) <= POSITION_TOLERANCE_M
    };
    let mut best: Option<(&Alignment, usize)> = None;
    for (_, _, candidate) in shared {
        let support = shared
            .iter()
            .filter(|(_, _, a)| agrees(candidate, a))
            .count();
        if best.is_none_or(|(_, n)| support > n) {
            best = Some((candidate, support));
        }
    }
    let (alignment, support) = best?;
    (support >= MIN_ALIGNED_TRACKS).then_some(*alignment)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::commonroad::{safe_interactions, safe_interactions_except};
    use crate::import::commonroad::{InteractionRules, TrackState};

    /// A car on the x axis (lane `lane` at y = 3.6 lane) with speed `5 + 0.1 lane + 0.01 step`
    /// (every car and step a distinct speed), steps `from..to`, in a frame moved by `origin` and a
    /// clock shifted by `clock` steps.
    fn car(id: &str, lane: i64, from: i64, to: i64, origin: (f64, f64), clock: i64) -> Track {
        let states = (from..to)
            .map(|step| {
                let (lane_f, step_f) = (lane as f64, step as f64);
                let speed = 5.0 + 0.1 * lane_f + 0.01 * step_f;
                // The distance the speeds above cover, whatever the first recorded step.
                let x =
                    10.0 * lane_f + 0.1 * ((5.0 + 0.1 * lane_f) * step_f + 0.005 * step_f * step_f);
                TrackState {
                    step: step - clock,
                    x: x - origin.0,
                    y: 3.6 * lane as f64 - origin.1,
                    orientation: 0.0,
                    speed,
                    acc: 0.1,
                }
            })
            .collect();
        Track {
            id: id.into(),
            kind: "car".into(),
            length: 4.5,
            width: 1.8,
            states,
        }
    }

    fn scenario(id: &str, tracks: Vec<Track>) -> Scenario {
        Scenario {
            id: id.into(),
            version: "2020a".into(),
            dt: 0.1,
            origin: (0.0, 0.0),
            tracks,
            ignored: Vec::new(),
            issues: Vec::new(),
        }
    }

    /// Steps 0..60 of three cars in file A; file B holds steps 20..90 of the same cars, its clock
    /// starting at step 20 and its origin moved by (0.25, 4.88) m (Peachtree 4_1/4_2).
    fn overlapping(ids_b: [&str; 3]) -> (Scenario, Scenario) {
        let a = scenario(
            "A",
            (0..3)
                .map(|l| car(["1", "2", "3"][l], l as i64, 0, 60, (0.0, 0.0), 0))
                .collect(),
        );
        let b = scenario(
            "B",
            (0..3)
                .map(|l| car(ids_b[l], l as i64, 20, 90, (0.25, 4.88), 20))
                .collect(),
        );
        (a, b)
    }

    #[test]
    fn an_overlapping_window_in_another_frame_is_found_and_only_the_overlap_repeats() {
        let (a, b) = overlapping(["1", "2", "3"]);
        let mut earlier = EarlierTracks::default();
        earlier.add(0, &a);
        let repeats = earlier.repeats(&b);
        for track in &repeats {
            // B's steps 0..40 are A's 20..60; B's 40..70 are new.
            assert!(track[..40].iter().all(|r| *r
                == Some(Earlier {
                    file: 0,
                    offset: 20
                })));
            assert!(track[40..].iter().all(Option::is_none), "{track:?}");
        }
        // The 3 pairs of B (two of them adjacent lanes, 3.6 m apart, calm): the overlap is
        // dropped, what B adds is kept.
        let rules = InteractionRules::default();
        let (all, _) = safe_interactions(&b, &rules);
        let (fresh, counts) = safe_interactions_except(&b, &rules, &repeats);
        assert_eq!(counts.repeated_frames, 3 * 40, "{counts:?}");
        let frames = |found: &[crate::import::commonroad::SafeInteraction]| -> usize {
            found.iter().map(|s| s.event.frames.len()).sum()
        };
        // 2 adjacent pairs x 2 ego orders, 70 steps each before, the last 30 after.
        assert_eq!((frames(&all), frames(&fresh)), (4 * 70, 4 * 30));
        for s in &fresh {
            assert!(s.event.t_start >= 4.0, "{}", s.event.id);
        }
    }

    #[test]
    fn reused_ids_on_other_cars_and_too_few_aligned_tracks_are_not_repeats() {
        // Same ids, other motion (lanes swapped: other speeds and positions).
        let (a, _) = overlapping(["1", "2", "3"]);
        let b = scenario(
            "B",
            vec![
                car("1", 2, 20, 90, (0.0, 0.0), 20),
                car("2", 0, 20, 90, (0.0, 0.0), 20),
                car("3", 1, 20, 90, (0.0, 0.0), 20),
            ],
        );
        let mut earlier = EarlierTracks::default();
        earlier.add(0, &a);
        assert!(earlier.repeats(&b).iter().flatten().all(Option::is_none));
        // Only two of the three cars keep their ids: two aligned tracks do not make a file
        // overlap.
        let (_, b) = overlapping(["1", "2", "99"]);
        assert!(earlier.repeats(&b).iter().flatten().all(Option::is_none));
    }
}
