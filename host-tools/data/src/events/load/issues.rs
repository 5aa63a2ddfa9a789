//! What can be wrong with an event folder: the fatal [`EventsError`]s, the per-row [`LoadIssue`]s,
//! the validation limits they refer to, and the bounded list that keeps them.
use std::collections::HashMap;
use std::path::PathBuf;

/// A heading whose norm is within this distance of 1 is normalised silently; further off is an
/// issue (it is then not a heading but a data error, e.g. swapped columns).
pub const HEADING_TOLERANCE: f64 = 0.02;
/// Physical range of a box length (m), inclusive: a pedestrian's box (0.5 m) to a long truck or
/// articulated bus (25.25 m in the EU) with margin; the same range as the CAN signals
/// (`EgoLength`, `ObjLength`), so every loadable event can be sent over the bus.
pub const LENGTH_RANGE_M: (f32, f32) = (0.5, 30.0);
/// Physical range of a box width (m), inclusive: a pedestrian or cyclist (0.3 m) to an oversize
/// load (5 m); the CAN signals' range too.
pub const WIDTH_RANGE_M: (f32, f32) = (0.3, 5.0);
/// Largest speed (m/s, magnitude of the velocity) of any road user: 360 km/h.
pub const MAX_SPEED_M_S: f32 = 100.0;
/// Largest magnitude of a position coordinate (m, `x_*`/`y_*`): 100,000 km, more than twice
/// round the Earth, so no fixed world frame (local ENU, UTM, even Earth-centred) comes near it;
/// beyond it a value is a broken export (`1e30`), not a place.
pub const MAX_POSITION_M: f32 = 1.0e8;
/// Largest magnitude of a position coordinate (m) that the loader's `f32` still resolves to
/// better than 1 cm (7.8 mm at 100 km, 0.5 m at a UTM northing of 5,400 km): an event whose
/// positions reach beyond it gets an [`IssueProblem::CoarsePositions`] note.
pub const COARSE_POSITION_M: f32 = 1.0e5;
/// Problems kept per kind (and file); the rest are counted in one [`IssueProblem::MoreOfKind`].
pub const KEPT_PER_KIND: usize = 20;
/// Largest ratio of a road user's speeds integrated over time to the path its positions cover
/// before the event gets an [`IssueProblem::SpeedsExceedPath`] note (km/h read as m/s: 3.6).
pub const SPEED_PATH_RATIO_MAX: f64 = 1.5;
/// Shortest distance (m) the speeds must cover for that check (a standing road user is skipped).
pub const SPEED_CHECK_MIN_PATH_M: f64 = 10.0;
/// Frames where a road user moves at least this fast (m/s) are those whose heading is compared
/// with the velocity ([`IssueProblem::HeadingAcrossVelocity`]).
pub const HEADING_CHECK_MIN_SPEED_M_S: f32 = 3.0;
/// An interval between frames longer than this many times the event's median interval is a hole
/// ([`IssueProblem::FrameGap`]).
pub const GAP_FACTOR: f64 = 3.0;
/// Two frames further apart than this (s) are an event with frames missing
/// ([`IssueProblem::TwoFramesApart`]): every data source here samples at 10 Hz or faster.
pub const TWO_FRAMES_MAX_INTERVAL_S: f64 = 1.0;

/// A problem that stops a folder from being read at all.
#[derive(Debug, thiserror::Error)]
pub enum EventsError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: line {line}: {source}", path.display())]
    Csv {
        path: PathBuf,
        line: u64,
        #[source]
        source: csv::Error,
    },
    /// `hint` (empty or starting with a space) says what the header holds instead when that
    /// explains it: another separator, the name in other case.
    #[error("{}: line 1: missing required column `{column}`{hint}", path.display())]
    MissingColumn {
        path: PathBuf,
        column: &'static str,
        hint: String,
    },
    /// A column the loader reads appears more than once in the header: which one is meant cannot
    /// be told (the first used to win without a word).
    #[error("{}: line 1: column `{column}` appears twice in the header (columns {first} and {second}): which one holds the data cannot be told", path.display())]
    DuplicateColumn {
        path: PathBuf,
        column: &'static str,
        /// 1-based column numbers.
        first: usize,
        second: usize,
    },
    /// An optional column the loader reads (`acc_sur`) is in the header in other case: read as an
    /// extra column, its data would be dropped without a word.
    #[error("{}: line 1: column `{found}` is `{column}` in other case: column names are lower case, spelled exactly", path.display())]
    MiscasedColumn {
        path: PathBuf,
        column: &'static str,
        found: String,
    },
    /// The file holds no header line (0 bytes, or only blank lines).
    #[error("{}: the file is empty (no header line)", path.display())]
    EmptyFile { path: PathBuf },
    /// [`stream_events`] only: the folder is valid but cannot be read one event at a time; the
    /// caller reads it whole with [`load_events`] instead.
    #[error("{}: line {line}: event `{}`: {reason}; it cannot be streamed event by event", path.display(), ShortId(event_id))]
    NotStreamable {
        path: PathBuf,
        line: u64,
        event_id: String,
        reason: &'static str,
    },
    /// [`load_prepared`](super::load_prepared) only: no event of the folder yields a sequence.
    #[error("{}: contains no usable sequences", path.display())]
    NoSequences { path: PathBuf },
    /// The folder given is a file (often its own `events.csv` or `frames.csv`).
    #[error("{}: a file, not an event folder: give the folder that holds events.csv and frames.csv{}", path.display(), path.parent().filter(|p| !p.as_os_str().is_empty()).map(|p| format!(" ({})", p.display())).unwrap_or_default())]
    NotAFolder { path: PathBuf },
}

/// Longest event id shown in a message, in characters; longer ones end in `…`.
const SHOWN_ID_CHARS: usize = 40;

/// An event id as shown in a message: at most [`SHOWN_ID_CHARS`] characters, control characters
/// escaped (an id read from a broken row can be any text).
struct ShortId<'a>(&'a str);

impl std::fmt::Display for ShortId<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (n, c) in self.0.chars().enumerate() {
            if n == SHOWN_ID_CHARS {
                return f.write_str("…");
            }
            if c.is_control() {
                write!(f, "{}", c.escape_default())?;
            } else {
                write!(f, "{c}")?;
            }
        }
        Ok(())
    }
}

/// One validation problem. Display: `file:line: column `c`: event `id`: problem`.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadIssue {
    pub file: PathBuf,
    /// 1-based line in `file` (the header is line 1).
    pub line: u64,
    /// The offending column, when the problem is about one field.
    pub column: Option<String>,
    /// The event concerned (dropped as a whole), when known.
    pub event_id: Option<String>,
    pub problem: IssueProblem,
}

impl std::fmt::Display for LoadIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:", self.file.display(), self.line)?;
        if let Some(c) = &self.column {
            write!(f, " column `{c}`:")?;
        }
        if let Some(id) = &self.event_id {
            write!(f, " event `{}`:", ShortId(id))?;
        }
        write!(f, " {}", self.problem)
    }
}

/// What is wrong. Every variant except [`IssueProblem::UnknownEvent`] and the notes
/// ([`IssueProblem::is_note`]) drops the named event.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IssueProblem {
    #[error("row has {found} fields, the header has {expected}")]
    RowLength { found: usize, expected: usize },
    #[error("row is not valid CSV/UTF-8: {0}")]
    BadRow(String),
    #[error("empty event_id")]
    EmptyEventId,
    #[error("not valid UTF-8: the file is in another encoding (Windows-1252 or Latin-1, as Excel's \"CSV\" writes on Windows?); event folders are UTF-8 CSV: save it as \"CSV UTF-8\" or convert it (iconv -f WINDOWS-1252 -t UTF-8)")]
    NotUtf8,
    #[error("event_id already used on line {first_line}; both rows are dropped")]
    DuplicateEventId { first_line: u64 },
    #[error("unknown kind `{0}` (expected crash, near_crash or safe)")]
    UnknownKind(String),
    #[error("{}", bad_number_text(.0))]
    BadNumber(String),
    #[error("`{0}` is not finite")]
    NonFinite(String),
    #[error("conflict event without t_impact")]
    MissingImpactTime,
    #[error("safe event with a t_impact")]
    ImpactTimeOnSafe,
    #[error("t_end {t_end} is not after t_start {t_start}")]
    EmptyInterval { t_start: f64, t_end: f64 },
    #[error("t_impact {t_impact} outside [t_start {t_start}, t_end {t_end}]")]
    ImpactOutsideEvent {
        t_impact: f64,
        t_start: f64,
        t_end: f64,
    },
    #[error("dimension {0} is not positive")]
    NonPositiveDimension(f32),
    #[error("dimension {value} m is outside the physical range [{min}, {max}] m")]
    ImplausibleDimension { value: f32, min: f32, max: f32 },
    #[error("speed {speed} m/s is above the physical limit {MAX_SPEED_M_S} m/s")]
    ImplausibleSpeed { speed: f32 },
    #[error("position {value:e} m is beyond {MAX_POSITION_M:e} m from the world frame's origin (more than twice round the Earth): a broken export or a wrong unit?")]
    ImplausiblePosition { value: f32 },
    #[error("... and {more} more `{kind}` {} in this file (not listed)", if is_note_kind(kind) { "notes" } else { "problems" })]
    MoreOfKind { kind: &'static str, more: u64 },
    /// `similar`: an id of events.csv that differs from this one only in leading zeros or case.
    #[error("{frames} frame(s) for an event that is not in events.csv{}{}", similar.as_ref().map(|s| format!(" (events.csv has `{s}`: leading zeros or case lost, e.g. by a spreadsheet?)")).unwrap_or_default(), if *not_utf8 { " (the id is not valid UTF-8: frames.csv is in another encoding, Windows-1252 or Latin-1 as Excel's \"CSV\" writes on Windows?; save it as \"CSV UTF-8\" or convert it: iconv -f WINDOWS-1252 -t UTF-8)" } else { "" })]
    UnknownEvent {
        frames: usize,
        similar: Option<String>,
        /// The id's bytes are not UTF-8: the file, not the id, is what is wrong.
        not_utf8: bool,
    },
    #[error("time {time} repeats the frame on line {previous_line}")]
    DuplicateTime { time: f64, previous_line: u64 },
    #[error("time {time} is before the previous frame's {previous} (line {previous_line})")]
    UnsortedTime {
        time: f64,
        previous: f64,
        previous_line: u64,
    },
    #[error("heading norm {norm} is not 1 (tolerance {HEADING_TOLERANCE})")]
    HeadingNotUnit { norm: f64 },
    #[error("frame time {time} outside [t_start {t_start}, t_end {t_end}]")]
    FrameOutsideEvent { time: f64, t_start: f64, t_end: f64 },
    #[error("event has no frames")]
    NoFrames,
    #[error("t_impact {t_impact} is before the first frame ({first})")]
    ImpactBeforeFrames { t_impact: f64, first: f64 },
    /// A note, not an error: the file's last line has no line end. Many writers leave it out, but
    /// so does a copy cut short, whose last number may have lost digits and still parse
    /// (`12.3456` read as `12.3`). The row is kept.
    #[error("no newline at the end of the file: this last row may have been cut short (a truncated copy?); it is read as it stands, check its last values")]
    NoFinalNewline,
    #[error("frames.csv `vx_{vehicle}`, `vy_{vehicle}`: the speeds add up to {speed_path:.1} m over the event, {:.1} times the {path:.1} m its positions `x_{vehicle}`, `y_{vehicle}` cover: speeds in km/h (3.6 times) or mph (2.24 times), times in ms (1000 times), or positions that do not follow the road user? Speeds must be m/s, times s, positions in one fixed world frame. The event is kept; check its units", speed_path / path.max(1e-9))]
    SpeedsExceedPath {
        vehicle: &'static str,
        speed_path: f64,
        path: f64,
    },
    #[error("frames.csv `x_{vehicle}`, `y_{vehicle}`: the positions carry it {displacement:.1} m from its first frame to its last, but its speeds `vx_{vehicle}`, `vy_{vehicle}` add up to only {speed_path:.1} m: positions in cm (100 times the speeds' path) or feet (3.28 times, as NGSIM's raw files), or speeds that are not the road user's (zeros for missing values)? Speeds must be m/s, times s, positions in one fixed world frame in m. The event is kept; check its units")]
    PathExceedsSpeeds {
        vehicle: &'static str,
        speed_path: f64,
        displacement: f64,
    },
    #[error("frames.csv `hx_{vehicle}`, `hy_{vehicle}`: the heading is more than 45° off the direction of travel (`vx_{vehicle}`, `vy_{vehicle}`) on {off} of the {moving} frames moving at 3 m/s or more: an angle in degrees taken as radians, measured from north, or hx and hy swapped? The heading must be the unit vector of the box's forward axis in the world frame. The event is kept; check its headings")]
    HeadingAcrossVelocity {
        vehicle: &'static str,
        off: usize,
        moving: usize,
    },
    #[error("t_impact {t_impact} is {:.3} s after the last frame ({last}): lead times are measured to t_impact, so each warning would count that stretch without frames; is t_impact on the frames' clock, or are the last frames missing? The event is kept", t_impact - last)]
    ImpactAfterFrames { t_impact: f64, last: f64 },
    #[error("frames.csv `time`: the event has only two frames, at {from} and {to} s ({:.3} s apart): its sequence spans that time as if it were data; frames missing? The event is kept", to - from)]
    TwoFramesApart { from: f64, to: f64 },
    #[error("frames.csv `time`: the event ({t_start} to {t_end} s) has one frame, at {time} s: its sequence is that one frame, with no history to warn from; frames missing? The event is kept")]
    OneFrame { time: f64, t_start: f64, t_end: f64 },
    #[error("frames.csv `time`: the frames jump from {from} to {to} s, where they are {typical:.3} s apart ({holes} such hole(s)): frames missing? Sequence lengths, derived accelerations and lead times span a hole as if it were data. The event is kept")]
    FrameGap {
        from: f64,
        to: f64,
        typical: f64,
        holes: usize,
    },
    #[error("the header line again (two files joined, each with its header?): the row is skipped, nothing else is dropped")]
    RepeatedHeader,
    #[error("frames.csv `x_*`, `y_*`: positions reach {largest} m from the world frame's origin, where a position (read as f32) is resolved to only {spacing} m: every box gap and offset of the event is rounded to that (UTM or Earth-centred coordinates?). Subtract a local origin (e.g. the event's first ego position) before writing the folder. The event is kept")]
    CoarsePositions { largest: f32, spacing: f32 },
}

/// `BadNumber`'s message: an empty field (a gap in the data, pandas' default for NaN in a column
/// that should have a value) says so rather than "`` is not a number".
fn bad_number_text(field: &str) -> String {
    if field.is_empty() {
        "the field is empty (a missing value?): a number is required here".to_owned()
    } else {
        format!("`{field}` is not a number")
    }
}

impl IssueProblem {
    /// A stable name of the kind of problem (the variant).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::RowLength { .. } => "RowLength",
            Self::BadRow(_) => "BadRow",
            Self::EmptyEventId => "EmptyEventId",
            Self::DuplicateEventId { .. } => "DuplicateEventId",
            Self::NotUtf8 => "NotUtf8",
            Self::UnknownKind(_) => "UnknownKind",
            Self::BadNumber(_) => "BadNumber",
            Self::NonFinite(_) => "NonFinite",
            Self::MissingImpactTime => "MissingImpactTime",
            Self::ImpactTimeOnSafe => "ImpactTimeOnSafe",
            Self::EmptyInterval { .. } => "EmptyInterval",
            Self::ImpactOutsideEvent { .. } => "ImpactOutsideEvent",
            Self::NonPositiveDimension(_) => "NonPositiveDimension",
            Self::ImplausibleDimension { .. } => "ImplausibleDimension",
            Self::ImplausibleSpeed { .. } => "ImplausibleSpeed",
            Self::ImplausiblePosition { .. } => "ImplausiblePosition",
            Self::MoreOfKind { .. } => "MoreOfKind",
            Self::UnknownEvent { .. } => "UnknownEvent",
            Self::DuplicateTime { .. } => "DuplicateTime",
            Self::UnsortedTime { .. } => "UnsortedTime",
            Self::HeadingNotUnit { .. } => "HeadingNotUnit",
            Self::FrameOutsideEvent { .. } => "FrameOutsideEvent",
            Self::NoFrames => "NoFrames",
            Self::ImpactBeforeFrames { .. } => "ImpactBeforeFrames",
            Self::NoFinalNewline => "NoFinalNewline",
            Self::SpeedsExceedPath { .. } => "SpeedsExceedPath",
            Self::PathExceedsSpeeds { .. } => "PathExceedsSpeeds",
            Self::HeadingAcrossVelocity { .. } => "HeadingAcrossVelocity",
            Self::ImpactAfterFrames { .. } => "ImpactAfterFrames",
            Self::FrameGap { .. } => "FrameGap",
            Self::TwoFramesApart { .. } => "TwoFramesApart",
            Self::OneFrame { .. } => "OneFrame",
            Self::RepeatedHeader => "RepeatedHeader",
            Self::CoarsePositions { .. } => "CoarsePositions",
        }
    }

    /// A note: worth telling the user, but no row or event is left out because of it (so it does
    /// not count among the problems that make `evaluate` refuse a folder).
    pub fn is_note(&self) -> bool {
        match self {
            // The notes beyond the first of their kind are notes too.
            Self::MoreOfKind { kind, .. } => is_note_kind(kind),
            other => is_note_kind(other.kind()),
        }
    }

    /// Frames of an event id that events.csv lacks ([`IssueProblem::UnknownEvent`], and the count
    /// of more of them): only those rows are dropped, as there is no event to skip. Every other
    /// problem (not a note) skips the event it names, or its row when no event can be named.
    pub fn drops_only_its_rows(&self) -> bool {
        match self {
            Self::MoreOfKind { kind, .. } => *kind == "UnknownEvent",
            other => matches!(other, Self::UnknownEvent { .. }),
        }
    }
}

/// True for the [`IssueProblem::kind`] of a note ([`IssueProblem::is_note`]): the one list of
/// the note kinds.
fn is_note_kind(kind: &str) -> bool {
    matches!(
        kind,
        "NoFinalNewline"
            | "SpeedsExceedPath"
            | "PathExceedsSpeeds"
            | "HeadingAcrossVelocity"
            | "ImpactAfterFrames"
            | "FrameGap"
            | "TwoFramesApart"
            | "OneFrame"
            | "RepeatedHeader"
            | "CoarsePositions"
    )
}

impl LoadIssue {
    /// How many problems this issue stands for (more than 1 for [`IssueProblem::MoreOfKind`]).
    pub fn count(&self) -> u64 {
        match self.problem {
            IssueProblem::MoreOfKind { more, .. } => more,
            _ => 1,
        }
    }
}

/// A kind of problem in one file.
type KindKey = (PathBuf, &'static str);

/// The issues of one load, bounded: the first [`KEPT_PER_KIND`] of each kind per file are kept,
/// the others counted, so millions of bad rows cost a counter, not memory.
#[derive(Default)]
pub(super) struct Issues {
    kept: Vec<LoadIssue>,
    /// (file, kind) -> (problems not kept, first line not kept).
    more: Vec<(KindKey, (u64, u64))>,
    per_kind: HashMap<KindKey, usize>,
}

impl Issues {
    pub(super) fn push(&mut self, issue: LoadIssue) {
        let key = (issue.file.clone(), issue.problem.kind());
        let n = self.per_kind.entry(key.clone()).or_insert(0);
        *n += 1;
        if *n <= KEPT_PER_KIND {
            self.kept.push(issue);
        } else if let Some(m) = self.more.iter_mut().find(|m| m.0 == key) {
            m.1 .0 += 1;
        } else {
            self.more.push((key, (1, issue.line)));
        }
    }

    pub(super) fn extend(&mut self, issues: impl IntoIterator<Item = LoadIssue>) {
        for i in issues {
            self.push(i);
        }
    }

    pub(super) fn finish(mut self) -> Vec<LoadIssue> {
        for ((file, kind), (more, line)) in self.more {
            self.kept.push(LoadIssue {
                file,
                line,
                column: None,
                event_id: None,
                problem: IssueProblem::MoreOfKind { kind, more },
            });
        }
        self.kept
    }
}
