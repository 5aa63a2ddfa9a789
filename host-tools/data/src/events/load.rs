//! Loading an event folder with full validation: every problem becomes a [`LoadIssue`] naming file,
//! line and column, and every event without a problem is kept.
//!
//! Policy: an event with any problem (in its `events.csv` row or in any of its frames) is dropped
//! as a whole, because a trajectory with a hole or a wrong sample would silently distort features,
//! sequences and lead times. All of its problems are still reported, not just the first.
use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use super::{derive_partner_acceleration, FRAME_COLUMNS, TIME_TOLERANCE_S};
use super::{Dims, Event, EventKind, EventSet, Frame, EVENTS_FILE, EVENT_COLUMNS, FRAMES_FILE};
use scorer_core::VehicleState;

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
/// Problems kept per kind (and file); the rest are counted in one [`IssueProblem::MoreOfKind`].
pub const KEPT_PER_KIND: usize = 20;

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
    #[error("{}: line 1: missing required column `{column}`", path.display())]
    MissingColumn { path: PathBuf, column: &'static str },
    /// [`stream_events`] only: the folder is valid but cannot be read one event at a time; the
    /// caller reads it whole with [`load_events`] instead.
    #[error("{}: line {line}: event `{event_id}`: {reason}; it cannot be streamed event by event", path.display())]
    NotStreamable {
        path: PathBuf,
        line: u64,
        event_id: String,
        reason: &'static str,
    },
    /// [`load_prepared`](super::load_prepared) only: no event of the folder yields a sequence.
    #[error("{}: contains no usable sequences", path.display())]
    NoSequences { path: PathBuf },
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
            write!(f, " event `{id}`:")?;
        }
        write!(f, " {}", self.problem)
    }
}

/// What is wrong. Every variant except [`IssueProblem::UnknownEvent`] drops the named event.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IssueProblem {
    #[error("row has {found} fields, the header has {expected}")]
    RowLength { found: usize, expected: usize },
    #[error("row is not valid CSV/UTF-8: {0}")]
    BadRow(String),
    #[error("empty event_id")]
    EmptyEventId,
    #[error("event_id already used on line {first_line}; both rows are dropped")]
    DuplicateEventId { first_line: u64 },
    #[error("unknown kind `{0}` (expected crash, near_crash or safe)")]
    UnknownKind(String),
    #[error("`{0}` is not a number")]
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
    #[error("... and {more} more `{kind}` problems in this file (not listed)")]
    MoreOfKind { kind: &'static str, more: u64 },
    #[error("{frames} frame(s) for an event that is not in events.csv")]
    UnknownEvent { frames: usize },
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
}

impl IssueProblem {
    /// A stable name of the kind of problem (the variant).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::RowLength { .. } => "RowLength",
            Self::BadRow(_) => "BadRow",
            Self::EmptyEventId => "EmptyEventId",
            Self::DuplicateEventId { .. } => "DuplicateEventId",
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
            Self::MoreOfKind { .. } => "MoreOfKind",
            Self::UnknownEvent { .. } => "UnknownEvent",
            Self::DuplicateTime { .. } => "DuplicateTime",
            Self::UnsortedTime { .. } => "UnsortedTime",
            Self::HeadingNotUnit { .. } => "HeadingNotUnit",
            Self::FrameOutsideEvent { .. } => "FrameOutsideEvent",
            Self::NoFrames => "NoFrames",
            Self::ImpactBeforeFrames { .. } => "ImpactBeforeFrames",
        }
    }
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
struct Issues {
    kept: Vec<LoadIssue>,
    /// (file, kind) -> (problems not kept, first line not kept).
    more: Vec<(KindKey, (u64, u64))>,
    per_kind: HashMap<KindKey, usize>,
}

impl Issues {
    fn push(&mut self, issue: LoadIssue) {
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

    fn extend(&mut self, issues: impl IntoIterator<Item = LoadIssue>) {
        for i in issues {
            self.push(i);
        }
    }

    fn finish(mut self) -> Vec<LoadIssue> {
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

struct Pending {
    event: Event,
    line: u64,
    ok: bool,
    last_frame_line: u64,
    /// Position among the events of events.csv (0-based).
    position: usize,
}

/// Loads and validates the event folder `dir` (`events.csv` + `frames.csv`).
///
/// Returns the valid events in `events.csv` order and one issue per problem found. Only problems
/// that make a whole file unreadable (missing file, missing column, I/O error) are errors. Rows are
/// streamed, so memory is the kept frames plus one id table; [`stream_events`] keeps only one event.
pub fn load_events(dir: &Path) -> Result<(EventSet, Vec<LoadIssue>), EventsError> {
    let mut folder = Folder::read_events(dir)?;
    read_frames::<EventsError>(
        &folder.frames_path,
        &mut folder.pending,
        &folder.index,
        &folder.rejected,
        &mut folder.issues,
        None,
    )?;
    let mut events = Vec::with_capacity(folder.pending.len());
    for mut p in folder.pending {
        if !p.ok {
            continue;
        }
        match finish_event(&mut p, &folder.events_path) {
            Some(issue) => folder.issues.push(issue),
            None => events.push(p.event),
        }
    }
    Ok((EventSet { events }, folder.issues.finish()))
}

/// Loads and validates the event folder `dir` like [`load_events`], but hands each valid event to
/// `on_event` as soon as its last frame is read and keeps none: memory is one event's frames plus
/// the `events.csv` table, however large `frames.csv` is. `on_event` gets the event's position in
/// `events.csv` (0-based row among the folder's events) so the caller can restore that order.
///
/// The issues returned are exactly those of [`load_events`], in the same order; the events handed
/// on are exactly its events (in `frames.csv` order). Streaming needs each event's frames to form
/// one run of consecutive rows (as `riskctl` writes them) and, with `in_events_order`, the runs to
/// follow `events.csv` order. Otherwise it stops with [`EventsError::NotStreamable`] (converted into
/// `E`), and the caller, having discarded what it received, reads the folder with [`load_events`].
pub fn stream_events<E: From<EventsError>>(
    dir: &Path,
    in_events_order: bool,
    mut on_event: impl FnMut(usize, Event) -> Result<(), E>,
) -> Result<Vec<LoadIssue>, E> {
    let mut folder = Folder::read_events(dir)?;
    let mut stream = Stream {
        in_events_order,
        closed: vec![false; folder.pending.len()],
        last_opened: None,
        deferred: Vec::new(),
        events_path: &folder.events_path,
        on_event: &mut on_event,
    };
    read_frames(
        &folder.frames_path,
        &mut folder.pending,
        &folder.index,
        &folder.rejected,
        &mut folder.issues,
        Some(&mut stream),
    )?;
    // Issues found when an event closes are listed in events.csv order, as load_events does.
    let mut deferred = std::mem::take(&mut stream.deferred);
    deferred.sort_by_key(|(slot, _)| *slot);
    let mut deferred = deferred.into_iter().peekable();
    let closed = stream.closed;
    for (slot, p) in folder.pending.iter_mut().enumerate() {
        if closed[slot] {
            if let Some((_, issue)) = deferred.next_if(|(s, _)| *s == slot) {
                folder.issues.push(issue);
            }
        } else if p.ok {
            // Never opened: no frames at all.
            if let Some(issue) = finish_event(p, &folder.events_path) {
                folder.issues.push(issue);
            } else {
                on_event(p.position, std::mem::replace(&mut p.event, empty_event()))?;
            }
        }
    }
    Ok(folder.issues.finish())
}

/// `events.csv` read and validated, before any frame.
struct Folder {
    events_path: PathBuf,
    frames_path: PathBuf,
    pending: Vec<Pending>,
    index: HashMap<String, usize>,
    /// Ids whose events.csv row was bad: their frames are skipped without further noise.
    rejected: HashMap<String, ()>,
    issues: Issues,
}

impl Folder {
    fn read_events(dir: &Path) -> Result<Self, EventsError> {
        let mut folder = Folder {
            events_path: dir.join(EVENTS_FILE),
            frames_path: dir.join(FRAMES_FILE),
            pending: Vec::new(),
            index: HashMap::new(),
            rejected: HashMap::new(),
            issues: Issues::default(),
        };
        read_events(
            &folder.events_path,
            &mut folder.pending,
            &mut folder.index,
            &mut folder.rejected,
            &mut folder.issues,
        )?;
        Ok(folder)
    }
}

/// The checks that need all of an event's frames, and the derived partner acceleration (already
/// filled in by `read_frames` when the file has no `acc_sur`). `Some(issue)` drops the event.
fn finish_event(p: &mut Pending, events_path: &Path) -> Option<LoadIssue> {
    let ev = &p.event;
    let issue = |problem| LoadIssue {
        file: events_path.to_path_buf(),
        line: p.line,
        column: None,
        event_id: Some(ev.id.clone()),
        problem,
    };
    let problem = match (ev.frames.first(), ev.t_impact) {
        (None, _) => issue(IssueProblem::NoFrames),
        (Some(first), Some(t_impact)) if t_impact < first.time - TIME_TOLERANCE_S => {
            let mut i = issue(IssueProblem::ImpactBeforeFrames {
                t_impact,
                first: first.time,
            });
            i.column = Some("t_impact".into());
            i
        }
        _ => {
            p.event.frames.shrink_to_fit();
            return None;
        }
    };
    p.ok = false;
    Some(problem)
}

fn empty_event() -> Event {
    Event {
        id: String::new(),
        kind: EventKind::Safe,
        t_start: 0.0,
        t_end: 0.0,
        t_impact: None,
        dims: Dims::default(),
        frames: Vec::new(),
    }
}

/// The streaming side of `read_frames`: which events are done, and where they go.
struct Stream<'a, E> {
    in_events_order: bool,
    /// Per `pending` slot: its run of frames has ended (the event was handed on or dropped).
    closed: Vec<bool>,
    last_opened: Option<usize>,
    /// Issues found on closing an event, with its slot (listed at the end, in slot order).
    deferred: Vec<(usize, LoadIssue)>,
    events_path: &'a Path,
    on_event: &'a mut dyn FnMut(usize, Event) -> Result<(), E>,
}

impl<E: From<EventsError>> Stream<'_, E> {
    /// Refuses a row of an event whose run has ended, or a run out of `events.csv` order.
    fn check_open(
        &mut self,
        path: &Path,
        line: u64,
        slot: usize,
        id: &str,
        opens_run: bool,
    ) -> Result<(), E> {
        let reason = if self.closed[slot] {
            "its frames are not one run of consecutive rows"
        } else if opens_run && self.in_events_order && self.last_opened.is_some_and(|l| slot < l) {
            "its frames come before those of an event listed earlier in events.csv"
        } else {
            if opens_run {
                self.last_opened = Some(slot);
            }
            return Ok(());
        };
        Err(EventsError::NotStreamable {
            path: path.to_path_buf(),
            line,
            event_id: id.to_owned(),
            reason,
        }
        .into())
    }

    /// The run of `slot` has ended: hand the event on (or drop it) and free its frames.
    fn close(&mut self, slot: usize, p: &mut Pending, derive_acc: bool) -> Result<(), E> {
        self.closed[slot] = true;
        let frames = std::mem::take(&mut p.event.frames);
        if !p.ok {
            return Ok(());
        }
        let mut event = Event {
            frames,
            id: p.event.id.clone(),
            ..p.event
        };
        if derive_acc {
            derive_partner_acceleration(&mut event.frames);
        }
        let mut finished = Pending {
            event,
            line: p.line,
            ok: true,
            last_frame_line: p.last_frame_line,
            position: p.position,
        };
        match finish_event(&mut finished, self.events_path) {
            Some(issue) => {
                p.ok = false;
                self.deferred.push((slot, issue));
                Ok(())
            }
            None => (self.on_event)(p.position, finished.event),
        }
    }
}

fn open(path: &Path) -> Result<csv::Reader<BufReader<File>>, EventsError> {
    let file = File::open(path).map_err(|source| EventsError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(csv::ReaderBuilder::new()
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(BufReader::with_capacity(1 << 20, file)))
}

fn column_map(
    path: &Path,
    rdr: &mut csv::Reader<BufReader<File>>,
    required: &[&'static str],
) -> Result<(Vec<usize>, csv::StringRecord), EventsError> {
    let headers = rdr
        .headers()
        .map_err(|source| EventsError::Csv {
            path: path.to_path_buf(),
            line: 1,
            source,
        })?
        .clone();
    let cols = required
        .iter()
        .map(|&name| {
            headers
                .iter()
                .position(|h| h == name)
                .ok_or(EventsError::MissingColumn {
                    path: path.to_path_buf(),
                    column: name,
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((cols, headers))
}

/// Reads one record; `Ok(None)` at end of file, `Err(issue)` for a malformed row.
fn next_record(
    path: &Path,
    rdr: &mut csv::Reader<BufReader<File>>,
    rec: &mut csv::ByteRecord,
    expected: usize,
    id_col: usize,
) -> Result<Option<Result<u64, LoadIssue>>, EventsError> {
    let line = rdr.position().line();
    match rdr.read_byte_record(rec) {
        Ok(false) => Ok(None),
        Ok(true) => {
            let line = rec.position().map_or(line, |p| p.line());
            if rec.len() != expected {
                Ok(Some(Err(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: None,
                    event_id: rec
                        .get(id_col)
                        .filter(|s| !s.is_empty())
                        .map(|s| String::from_utf8_lossy(s).into_owned()),
                    problem: IssueProblem::RowLength {
                        found: rec.len(),
                        expected,
                    },
                })))
            } else {
                Ok(Some(Ok(line)))
            }
        }
        Err(e) if matches!(e.kind(), csv::ErrorKind::Io(_)) => Err(EventsError::Csv {
            path: path.to_path_buf(),
            line,
            source: e,
        }),
        Err(e) => {
            let line = e.position().map_or(line, |p| p.line());
            Ok(Some(Err(LoadIssue {
                file: path.to_path_buf(),
                line,
                column: None,
                event_id: None,
                problem: IssueProblem::BadRow(e.to_string()),
            })))
        }
    }
}

fn field_str(b: &[u8]) -> &str {
    std::str::from_utf8(b).unwrap_or("\u{fffd}")
}

/// Field parser that records an issue per bad field.
struct Fields<'a> {
    path: &'a Path,
    line: u64,
    id: &'a str,
    rec: &'a csv::ByteRecord,
    cols: &'a [usize],
    names: &'a [&'static str],
    issues: Vec<LoadIssue>,
}

impl Fields<'_> {
    /// The field as text; invalid UTF-8 becomes U+FFFD and then fails to parse as a number.
    fn raw(&self, i: usize) -> &str {
        field_str(self.rec.get(self.cols[i]).unwrap_or(b""))
    }
    fn push(&mut self, i: usize, problem: IssueProblem) {
        self.issues.push(LoadIssue {
            file: self.path.to_path_buf(),
            line: self.line,
            column: Some(self.names[i].to_owned()),
            event_id: Some(self.id.to_owned()),
            problem,
        });
    }
    fn f64(&mut self, i: usize) -> f64 {
        let s = self.raw(i);
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            Ok(_) => {
                let s = s.to_owned();
                self.push(i, IssueProblem::NonFinite(s));
                f64::NAN
            }
            Err(_) => {
                let s = s.to_owned();
                self.push(i, IssueProblem::BadNumber(s));
                f64::NAN
            }
        }
    }
    fn f32(&mut self, i: usize) -> f32 {
        let s = self.raw(i);
        match s.parse::<f32>() {
            Ok(v) if v.is_finite() => v,
            Ok(_) => {
                let s = s.to_owned();
                self.push(i, IssueProblem::NonFinite(s));
                f32::NAN
            }
            Err(_) => {
                let s = s.to_owned();
                self.push(i, IssueProblem::BadNumber(s));
                f32::NAN
            }
        }
    }
    /// A unit heading from columns `ix`, `iy`: normalised when within tolerance, else an issue.
    fn heading(&mut self, ix: usize, iy: usize) -> (f32, f32) {
        let (hx, hy) = (self.f32(ix), self.f32(iy));
        if !(hx.is_finite() && hy.is_finite()) {
            return (hx, hy);
        }
        let norm = f64::from(hx).hypot(f64::from(hy));
        if (norm - 1.0).abs() > HEADING_TOLERANCE {
            self.push(ix, IssueProblem::HeadingNotUnit { norm });
            (f32::NAN, f32::NAN)
        } else if (norm - 1.0).abs() > 1e-5 {
            ((f64::from(hx) / norm) as f32, (f64::from(hy) / norm) as f32)
        } else {
            // Already unit to f32 precision: keep the exact values (write/load round-trips bit-exactly).
            (hx, hy)
        }
    }
}

fn read_events(
    path: &Path,
    pending: &mut Vec<Pending>,
    index: &mut HashMap<String, usize>,
    rejected: &mut HashMap<String, ()>,
    issues: &mut Issues,
) -> Result<(), EventsError> {
    let mut rdr = open(path)?;
    let (cols, headers) = column_map(path, &mut rdr, &EVENT_COLUMNS)?;
    let mut rec = csv::ByteRecord::new();
    let mut first_line: HashMap<String, u64> = HashMap::new();
    while let Some(r) = next_record(path, &mut rdr, &mut rec, headers.len(), cols[0])? {
        let line = match r {
            Ok(line) => line,
            Err(issue) => {
                if let Some(id) = &issue.event_id {
                    rejected.insert(id.clone(), ());
                }
                issues.push(issue);
                continue;
            }
        };
        let id = String::from_utf8_lossy(rec.get(cols[0]).unwrap_or(b"")).into_owned();
        let mut f = Fields {
            path,
            line,
            id: &id,
            rec: &rec,
            cols: &cols,
            names: &EVENT_COLUMNS,
            issues: Vec::new(),
        };
        if id.is_empty() {
            f.push(0, IssueProblem::EmptyEventId);
        }
        let kind = EventKind::parse(f.raw(1));
        if kind.is_none() {
            let k = f.raw(1).to_owned();
            f.push(1, IssueProblem::UnknownKind(k));
        }
        let t_start = f.f64(2);
        let t_end = f.f64(3);
        let t_impact = if f.raw(4).is_empty() {
            None
        } else {
            Some(f.f64(4))
        };
        let dims = Dims {
            length_ego: f.f32(5),
            width_ego: f.f32(6),
            length_sur: f.f32(7),
            width_sur: f.f32(8),
        };
        for (i, v) in [
            dims.length_ego,
            dims.width_ego,
            dims.length_sur,
            dims.width_sur,
        ]
        .into_iter()
        .enumerate()
        {
            let (min, max) = if i % 2 == 0 {
                LENGTH_RANGE_M
            } else {
                WIDTH_RANGE_M
            };
            if v.is_finite() && v <= 0.0 {
                f.push(5 + i, IssueProblem::NonPositiveDimension(v));
            } else if v.is_finite() && !(min..=max).contains(&v) {
                f.push(
                    5 + i,
                    IssueProblem::ImplausibleDimension { value: v, min, max },
                );
            }
        }
        if t_start.is_finite() && t_end.is_finite() && t_end <= t_start {
            f.push(3, IssueProblem::EmptyInterval { t_start, t_end });
        }
        match (kind, t_impact) {
            (Some(k), None) if k.is_conflict() => f.push(4, IssueProblem::MissingImpactTime),
            (Some(EventKind::Safe), Some(_)) => f.push(4, IssueProblem::ImpactTimeOnSafe),
            (_, Some(t))
                if t.is_finite()
                    && t_start.is_finite()
                    && t_end.is_finite()
                    && (t < t_start - TIME_TOLERANCE_S || t > t_end + TIME_TOLERANCE_S) =>
            {
                f.push(
                    4,
                    IssueProblem::ImpactOutsideEvent {
                        t_impact: t,
                        t_start,
                        t_end,
                    },
                )
            }
            _ => {}
        }
        let row_issues = std::mem::take(&mut f.issues);
        if !id.is_empty() {
            if let Some(&first) = first_line.get(&id) {
                issues.push(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: Some("event_id".into()),
                    event_id: Some(id.clone()),
                    problem: IssueProblem::DuplicateEventId { first_line: first },
                });
                if let Some(i) = index.remove(&id) {
                    pending[i].ok = false;
                }
                rejected.insert(id.clone(), ());
                issues.extend(row_issues);
                continue;
            }
            first_line.insert(id.clone(), line);
        }
        let ok = row_issues.is_empty();
        issues.extend(row_issues);
        match kind {
            Some(kind) if ok => {
                index.insert(id.clone(), pending.len());
                pending.push(Pending {
                    event: Event {
                        id,
                        kind,
                        t_start,
                        t_end,
                        t_impact,
                        dims,
                        frames: Vec::new(),
                    },
                    line,
                    ok: true,
                    last_frame_line: 0,
                    position: pending.len(),
                });
            }
            _ => {
                rejected.insert(id, ());
            }
        }
    }
    // Events removed from the index as duplicates stay in `pending` with ok = false.
    Ok(())
}

fn read_frames<E: From<EventsError>>(
    path: &Path,
    pending: &mut [Pending],
    index: &HashMap<String, usize>,
    rejected: &HashMap<String, ()>,
    issues: &mut Issues,
    mut stream: Option<&mut Stream<'_, E>>,
) -> Result<(), E> {
    let mut rdr = open(path)?;
    let (cols, headers) = column_map(path, &mut rdr, &FRAME_COLUMNS)?;
    let acc_sur_col = headers.iter().position(|h| h == "acc_sur");
    let mut rec = csv::ByteRecord::new();
    // Unknown ids: first line and frame count, reported once each.
    let mut unknown: HashMap<String, (u64, usize)> = HashMap::new();
    let mut current: Option<(String, usize)> = None;
    while let Some(r) = next_record(path, &mut rdr, &mut rec, headers.len(), cols[0])? {
        let line = match r {
            Ok(line) => line,
            Err(issue) => {
                if let Some((id, &i)) = issue
                    .event_id
                    .as_deref()
                    .and_then(|id| Some((id, index.get(id)?)))
                {
                    if let Some(s) = stream.as_deref_mut() {
                        s.check_open(path, issue.line, i, id, false)?;
                    }
                    pending[i].ok = false;
                }
                issues.push(issue);
                continue;
            }
        };
        let id_text = String::from_utf8_lossy(rec.get(cols[0]).unwrap_or(b""));
        let id: &str = &id_text;
        // Frames usually come grouped by event: remember the last lookup.
        let slot = match &current {
            Some((cid, slot)) if cid == id => Some(*slot),
            _ => {
                let slot = index.get(id).copied();
                if let Some(s) = slot {
                    if let Some(stream) = stream.as_deref_mut() {
                        stream.check_open(path, line, s, id, true)?;
                        if let Some((_, previous)) = current {
                            stream.close(
                                previous,
                                &mut pending[previous],
                                acc_sur_col.is_none(),
                            )?;
                        }
                    }
                    current = Some((id.to_owned(), s));
                }
                slot
            }
        };
        let Some(slot) = slot else {
            if !rejected.contains_key(id) {
                unknown
                    .entry(id.to_owned())
                    .and_modify(|e| e.1 += 1)
                    .or_insert((line, 1));
            }
            continue;
        };
        let p = &mut pending[slot];
        let mut f = Fields {
            path,
            line,
            id: &p.event.id,
            rec: &rec,
            cols: &cols,
            names: &FRAME_COLUMNS,
            issues: Vec::new(),
        };
        let time = f.f64(1);
        let (hx_e, hy_e) = f.heading(6, 7);
        let (hx_s, hy_s) = f.heading(13, 14);
        let d = p.event.dims;
        let ego = VehicleState {
            x: f.f32(2),
            y: f.f32(3),
            vx: f.f32(4),
            vy: f.f32(5),
            hx: hx_e,
            hy: hy_e,
            acc: f.f32(8),
            length: d.length_ego,
            width: d.width_ego,
        };
        let mut sur = VehicleState {
            x: f.f32(9),
            y: f.f32(10),
            vx: f.f32(11),
            vy: f.f32(12),
            hx: hx_s,
            hy: hy_s,
            acc: 0.0,
            length: d.length_sur,
            width: d.width_sur,
        };
        for (state, col) in [(&ego, 4), (&sur, 11)] {
            let speed = state.vx.hypot(state.vy);
            if speed.is_finite() && speed > MAX_SPEED_M_S {
                f.push(col, IssueProblem::ImplausibleSpeed { speed });
            }
        }
        if let Some(c) = acc_sur_col {
            let s = field_str(rec.get(c).unwrap_or(b""));
            match s.parse::<f32>() {
                Ok(v) if v.is_finite() => sur.acc = v,
                Ok(_) => f.issues.push(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: Some("acc_sur".into()),
                    event_id: Some(p.event.id.clone()),
                    problem: IssueProblem::NonFinite(s.to_owned()),
                }),
                Err(_) => f.issues.push(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: Some("acc_sur".into()),
                    event_id: Some(p.event.id.clone()),
                    problem: IssueProblem::BadNumber(s.to_owned()),
                }),
            }
        }
        if time.is_finite() {
            if let Some(prev) = p.event.frames.last() {
                if time == prev.time {
                    f.push(
                        1,
                        IssueProblem::DuplicateTime {
                            time,
                            previous_line: p.last_frame_line,
                        },
                    );
                } else if time < prev.time {
                    f.push(
                        1,
                        IssueProblem::UnsortedTime {
                            time,
                            previous: prev.time,
                            previous_line: p.last_frame_line,
                        },
                    );
                }
            }
            let (t0, t1) = (p.event.t_start, p.event.t_end);
            if time < t0 - TIME_TOLERANCE_S || time > t1 + TIME_TOLERANCE_S {
                f.push(
                    1,
                    IssueProblem::FrameOutsideEvent {
                        time,
                        t_start: t0,
                        t_end: t1,
                    },
                );
            }
        }
        if f.issues.is_empty() {
            let newer = p.event.frames.last().is_none_or(|prev| time > prev.time);
            if newer {
                p.event.frames.push(Frame { time, ego, sur });
                p.last_frame_line = line;
            }
        } else {
            p.ok = false;
            issues.extend(f.issues.drain(..));
        }
    }
    if let (Some(stream), Some((_, last))) = (stream, current) {
        stream.close(last, &mut pending[last], acc_sur_col.is_none())?;
    }
    let mut unknown: Vec<_> = unknown.into_iter().collect();
    unknown.sort_by_key(|(_, (line, _))| *line);
    for (id, (line, frames)) in unknown {
        issues.push(LoadIssue {
            file: path.to_path_buf(),
            line,
            column: Some("event_id".into()),
            event_id: Some(id),
            problem: IssueProblem::UnknownEvent { frames },
        });
    }
    if acc_sur_col.is_none() {
        for p in pending.iter_mut().filter(|p| p.ok) {
            derive_partner_acceleration(&mut p.event.frames);
        }
    }
    Ok(())
}
