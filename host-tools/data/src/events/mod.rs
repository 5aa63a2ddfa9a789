//! The event-folder format: types, loading with validation, writing, sequence preparation and
//! event-level cross-validation splits. The format itself is specified in `docs/event-format.md`.
//!
//! Entry points, in the order a pipeline uses them:
//! 1. [`load_events`] reads `events.csv` + `frames.csv`, validates every row and returns the valid
//!    events together with one [`LoadIssue`] per problem (file, line, column).
//! 2. [`prepare_sequences`] turns events into the [`Sequence`]s the method trains and evaluates
//!    on (conflict window around the endpoint, safe-sequence rules); [`cut_safe_sequences`] cuts
//!    safe sequences out of long baseline recordings.
//! 3. [`kfold_by_event`] splits events (or sequences) into seeded, kind-stratified folds; a fold
//!    never separates the frames of one event.
//! 4. [`write_events`] / [`EventWriter`] write an event folder (the simulator streams through
//!    [`EventWriter`]).
//!
//! [`load_prepared`] does steps 1 and 2 for a folder in one call (what training, the demo and the
//! benchmarks read).
use scorer_core::VehicleState;

mod folder;
mod folds;
mod load;
mod prepare;
mod write;

pub use folder::{
    load_and_prepare, load_prepared, PreparedFolder, LISTED_LOAD_ISSUES, LISTED_PREPARE_ISSUES,
};
pub use folds::{fold_group, kfold_by_event, recording_of_event_id, Folds, Labelled};
pub use load::{
    event_kinds, load_events, stream_events, EventsError, IssueProblem, LoadIssue,
    COARSE_POSITION_M, GAP_FACTOR, HEADING_CHECK_MIN_SPEED_M_S, KEPT_PER_KIND, LENGTH_RANGE_M,
    MAX_POSITION_M, MAX_SPEED_M_S, SPEED_CHECK_MIN_PATH_M, SPEED_PATH_RATIO_MAX, WIDTH_RANGE_M,
};
pub(crate) use load::{heading_mostly_off, heading_off};
pub(crate) use load::{open_csv, read_numbered_record};
pub use prepare::{
    cut_safe_sequences, prepare_event, prepare_owned_event, prepare_sequences, safe_rules_hold,
    PrepareConfig, PrepareIssue, Sequence,
};
pub use write::{write_events, EventWriter};

/// Slack (s) for every comparison of a frame time with another time: an event's bounds and impact
/// time when loading, the alert window's inclusive end, the anchor window and the sequence cuts.
///
/// Times in event tables are decimal strings (`12.3`), often rounded to the millisecond, and a time
/// computed elsewhere may differ from the frame time it names in its last bits. One millisecond
/// absorbs both (it is the loader's slack the event format has always documented) and is still far
/// below any frame period a vehicle sensor has (10 ms at 100 Hz).
pub const TIME_TOLERANCE_S: f64 = 1e-3;

/// File name of the event table inside an event folder.
pub const EVENTS_FILE: &str = "events.csv";
/// File name of the frame table inside an event folder.
pub const FRAMES_FILE: &str = "frames.csv";

/// Column names of `events.csv`, in the order the writer emits them.
pub const EVENT_COLUMNS: [&str; 9] = [
    "event_id",
    "kind",
    "t_start",
    "t_end",
    "t_impact",
    "length_ego",
    "width_ego",
    "length_sur",
    "width_sur",
];

/// Column names of `frames.csv`, in the order the writer emits them. An optional extra column
/// `acc_sur` (partner longitudinal acceleration) is used by the loader when present.
///
/// `_sur` ("surrounding road user") in file columns is the partner of the code: `x_sur` is
/// `Frame::partner.x`, `length_sur` is `Dims::length_partner`. The file names stay for
/// compatibility with existing event folders.
pub const FRAME_COLUMNS: [&str; 15] = [
    "event_id", "time", "x_ego", "y_ego", "vx_ego", "vy_ego", "hx_ego", "hy_ego", "acc_ego",
    "x_sur", "y_sur", "vx_sur", "vy_sur", "hx_sur", "hy_sur",
];

/// What happened in an event: the class of a sequence everywhere (comparisons, the protocol,
/// reports). Serialised as `crash`, `near_crash`, `safe`, the `events.csv` spelling.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    Crash,
    NearCrash,
    Safe,
}

impl EventKind {
    /// All kinds, in the order reports list them.
    pub const ALL: [EventKind; 3] = [EventKind::Crash, EventKind::NearCrash, EventKind::Safe];

    /// The spelling used in `events.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            EventKind::Crash => "crash",
            EventKind::NearCrash => "near_crash",
            EventKind::Safe => "safe",
        }
    }

    /// Parses the `events.csv` spelling (exact, lower case).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "crash" => Some(EventKind::Crash),
            "near_crash" => Some(EventKind::NearCrash),
            "safe" => Some(EventKind::Safe),
            _ => None,
        }
    }

    /// Crash or near-crash: a sequence with an endpoint and an alert window; warning on it is a
    /// true positive.
    pub fn is_conflict(self) -> bool {
        !matches!(self, EventKind::Safe)
    }
}

impl std::fmt::Display for EventKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Box dimensions of the two road users of an event (m), constant over the event.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Dims {
    pub length_ego: f32,
    pub width_ego: f32,
    pub length_partner: f32,
    pub width_partner: f32,
}

/// One sample of an event: ego and partner (the other road user) at `time` (s).
///
/// Both states carry the event's box dimensions. `ego.acc` is the recorded `acc_ego`; `partner.acc` is
/// the `acc_sur` column when the file has one, otherwise it is derived from the partner's
/// velocity (see [`derive_partner_acceleration`]).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Frame {
    pub time: f64,
    pub ego: VehicleState,
    pub partner: VehicleState,
}

/// One recorded interaction between the ego vehicle and one partner (a surrounding road user).
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    pub id: String,
    pub kind: EventKind,
    pub t_start: f64,
    pub t_end: f64,
    /// Impact moment (crash) or safety-critical endpoint (near-crash); `None` for safe events.
    pub t_impact: Option<f64>,
    pub dims: Dims,
    /// Strictly increasing in time.
    pub frames: Vec<Frame>,
}

/// Number of events of each kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct KindCounts {
    pub crash: usize,
    pub near_crash: usize,
    pub safe: usize,
}

impl KindCounts {
    pub fn add(&mut self, kind: EventKind) {
        match kind {
            EventKind::Crash => self.crash += 1,
            EventKind::NearCrash => self.near_crash += 1,
            EventKind::Safe => self.safe += 1,
        }
    }
    pub fn get(&self, kind: EventKind) -> usize {
        match kind {
            EventKind::Crash => self.crash,
            EventKind::NearCrash => self.near_crash,
            EventKind::Safe => self.safe,
        }
    }
    pub fn total(&self) -> usize {
        self.crash + self.near_crash + self.safe
    }
}

impl std::fmt::Display for KindCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} crash, {} near_crash, {} safe",
            self.crash, self.near_crash, self.safe
        )
    }
}

/// The events of one folder, in `events.csv` order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EventSet {
    pub events: Vec<Event>,
}

impl EventSet {
    pub fn len(&self) -> usize {
        self.events.len()
    }
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }
    pub fn iter(&self) -> std::slice::Iter<'_, Event> {
        self.events.iter()
    }
    /// The event with this id, if any.
    pub fn get(&self, id: &str) -> Option<&Event> {
        self.events.iter().find(|e| e.id == id)
    }
    pub fn counts(&self) -> KindCounts {
        let mut c = KindCounts::default();
        for e in &self.events {
            c.add(e.kind);
        }
        c
    }
}

impl<'a> IntoIterator for &'a EventSet {
    type Item = &'a Event;
    type IntoIter = std::slice::Iter<'a, Event>;
    fn into_iter(self) -> Self::IntoIter {
        self.events.iter()
    }
}

/// Fills `partner.acc` of every frame with the partner's longitudinal acceleration, estimated as the
/// time derivative of its velocity projected on its heading: central differences inside the
/// event, one-sided differences at both ends, 0 for a single frame.
///
/// This is what the loader does when `frames.csv` has no `acc_sur` column, and what the simulator
/// applies before labelling, so both see the same numbers.
pub fn derive_partner_acceleration(frames: &mut [Frame]) {
    let n = frames.len();
    if n < 2 {
        if let Some(f) = frames.first_mut() {
            f.partner.acc = 0.0;
        }
        return;
    }
    let along: Vec<f64> = frames
        .iter()
        .map(|f| {
            f64::from(f.partner.vx) * f64::from(f.partner.hx)
                + f64::from(f.partner.vy) * f64::from(f.partner.hy)
        })
        .collect();
    for i in 0..n {
        let (a, b) = match i {
            0 => (0, 1),
            i if i + 1 == n => (i - 1, i),
            i => (i - 1, i + 1),
        };
        let dt = frames[b].time - frames[a].time;
        frames[i].partner.acc = if dt > 0.0 {
            ((along[b] - along[a]) / dt) as f32
        } else {
            0.0
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_round_trip_their_spelling() {
        for k in EventKind::ALL {
            assert_eq!(EventKind::parse(k.as_str()), Some(k));
        }
        assert_eq!(EventKind::parse("Crash"), None);
        assert!(EventKind::NearCrash.is_conflict() && !EventKind::Safe.is_conflict());
    }

    #[test]
    fn kinds_serialise_as_their_events_csv_spelling() {
        for k in EventKind::ALL {
            let json = serde_json::to_string(&k).unwrap();
            assert_eq!(json, format!("\"{}\"", k.as_str()));
            assert_eq!(serde_json::from_str::<EventKind>(&json).unwrap(), k);
        }
        assert!(serde_json::from_str::<EventKind>("\"NearCrash\"").is_err());
    }

    #[test]
    fn partner_acceleration_uses_central_differences() {
        // Partner speed along its heading: 0, 1, 4, 9 (t^2 at 1 s steps): central 2, 4; ends 1, 5.
        let mut frames: Vec<Frame> = (0..4)
            .map(|k| {
                let mut f = Frame {
                    time: k as f64,
                    ..Frame::default()
                };
                f.partner.hx = 0.6;
                f.partner.hy = 0.8;
                let v = (k * k) as f32;
                f.partner.vx = 0.6 * v;
                f.partner.vy = 0.8 * v;
                f
            })
            .collect();
        derive_partner_acceleration(&mut frames);
        let acc: Vec<f32> = frames.iter().map(|f| f.partner.acc).collect();
        for (a, want) in acc.iter().zip([1.0, 2.0, 4.0, 5.0]) {
            assert!((a - want).abs() < 1e-5, "{acc:?}");
        }
        let mut one = vec![Frame::default()];
        one[0].partner.acc = 3.0;
        derive_partner_acceleration(&mut one);
        assert_eq!(one[0].partner.acc, 0.0);
    }
}
