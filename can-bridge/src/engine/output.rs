//! What the engine produces: scored tracks, warning frames and transitions, problems, counters.
use super::{InputFlags, Problem};
use can_codec::Frame;
use scorer_core::VehicleState;

/// Counters over everything the engine has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Stats {
    pub frames: u64,
    /// Frames of an input message that decoded cleanly.
    pub decoded: u64,
    pub scored: u64,
    pub unknown_ids: u64,
    /// Of `unknown_ids`: frames whose id is a message the map reads on another bus and no DBC
    /// file of their own bus defines (the log's interface names do not match the bus bindings).
    pub unknown_other_bus: u64,
    pub remote_frames: u64,
    pub decode_errors: u64,
    pub stale_drops: u64,
    pub invalid_objects: u64,
    pub reordered: u64,
    /// Frames dropped because their timestamp was far off the log's timeline (a glitch).
    pub out_of_window: u64,
    /// New log segments started (timestamp jumps confirmed by the following frames).
    pub segments: u64,
    pub duplicates: u64,
    pub error_frames: u64,
    pub bus_off: u64,
    pub warning_frames: u64,
    /// Warning frames due but not sent (the track id does not fit the warning message, or the
    /// frame could not be encoded).
    pub warning_frames_unsent: u64,
    /// Tracks whose id does not fit the warning message's track-id signal.
    pub tracks_unsent: u64,
    pub tracks_dropped: u64,
    pub table_full: u64,
    /// Updates not scored because a velocity derived from the track's motion is not yet known.
    pub motion_pending: u64,
    /// Slots whose `new_track` flag started a fresh track.
    pub new_objects: u64,
    /// Updates not scored because the object is outside the map's field of view.
    pub outside_view: u64,
    /// Scored updates outside the model's training domain (0 for a model without the record).
    pub out_of_domain: u64,
}

impl Stats {
    /// Bus errors as the status line reports them.
    pub fn bus_errors(&self) -> u64 {
        self.error_frames
    }
}

/// One scored track update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScoredUpdate {
    pub t_us: u64,
    pub track: u32,
    pub ego: VehicleState,
    pub partner: VehicleState,
    /// Which of these inputs were derived or defaulted instead of sent.
    pub flags: InputFlags,
    pub score: f32,
    pub warning: bool,
    pub level: u8,
}

/// Why a warning turned off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReleaseReason {
    /// The score fell below the release level.
    Score,
    /// The track stopped updating.
    Stale,
    /// The sensor flagged the object invalid.
    Invalid,
    /// The sensor reported a new object in the track's slot.
    NewObject,
    /// The object left the map's field of view (`[sensor] fov_deg`, `max_range`).
    OutsideView,
}

impl ReleaseReason {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Score => "score",
            Self::Stale => "stale",
            Self::Invalid => "invalid",
            Self::NewObject => "new_object",
            Self::OutsideView => "outside_view",
        }
    }
}

/// What the engine produces.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// A track was scored.
    Scored(ScoredUpdate),
    /// A protected warning frame to send.
    WarningFrame { t_us: u64, track: u32, frame: Frame },
    /// A track's warning turned on.
    WarningOn {
        t_us: u64,
        track: u32,
        score: f32,
        level: u8,
    },
    /// A track's warning turned off.
    WarningOff {
        t_us: u64,
        track: u32,
        score: f32,
        reason: ReleaseReason,
    },
    /// Something went wrong; `reason` says what (its text is the diagnostic; the caller
    /// rate-limits printing).
    /// `lost` is set when the frame `source` names was dropped and its content lost.
    Problem {
        t_us: u64,
        /// The source (log line) of the frame being processed when it happened, as given to
        /// [`Engine::process_from`]; 0 from [`Engine::process`] (live).
        source: u64,
        reason: Problem,
        lost: Option<LossKind>,
    },
}

/// Why a frame of the input was lost. Frames the map does not use (unknown ids, remote frames)
/// and updates that are not scored for a data-quality reason (stale or invalid objects) are not
/// losses: nothing the bridge needs was in them, or it was used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum LossKind {
    /// Up to 1 s older than the newest frame ([`crate::timeline`]).
    Late,
    /// Far off the timeline and not confirmed as a new segment ([`crate::timeline`]).
    OffTimeline,
    /// A frame of a mapped message that does not decode (wrong length, a signal out of its DBC
    /// range or not finite), or a track update whose decoded state cannot be scored.
    Decode,
}

impl LossKind {
    /// The kind as counted in summaries (plural: "3 late frames").
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Late => "late frames",
            Self::OffTimeline => "frames off the timeline",
            Self::Decode => "frames not decodable",
        }
    }
}
