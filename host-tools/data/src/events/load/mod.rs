//! Loading an event folder with full validation: every problem becomes a [`LoadIssue`] naming file,
//! line and column, and every event without a problem is kept.
//!
//! Policy: an event with any problem (in its `events.csv` row or in any of its frames) is dropped
//! as a whole, because a trajectory with a hole or a wrong sample would silently distort features,
//! sequences and lead times. All of its problems are still reported, not just the first.
mod fields;
mod issues;

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

pub use issues::{
    EventsError, IssueProblem, LoadIssue, COARSE_POSITION_M, GAP_FACTOR,
    HEADING_CHECK_MIN_SPEED_M_S, KEPT_PER_KIND, LENGTH_RANGE_M, MAX_POSITION_M, MAX_SPEED_M_S,
    SPEED_CHECK_MIN_PATH_M, SPEED_PATH_RATIO_MAX, TWO_FRAMES_MAX_INTERVAL_S, WIDTH_RANGE_M,
};

use super::{derive_partner_acceleration, FRAME_COLUMNS, TIME_TOLERANCE_S};
use super::{Dims, Event, EventKind, EventSet, Frame, EVENTS_FILE, EVENT_COLUMNS, FRAMES_FILE};
use fields::{column_map, field_str, next_record, no_final_newline, open, Fields};
pub(crate) use fields::{open as open_csv, read_numbered_record};
use issues::Issues;
use scorer_core::VehicleState;

struct Pending {
    event: Event,
    line: u64,
    ok: bool,
    last_frame_line: u64,
    /// Position among the events of events.csv (0-based).
    position: usize,
}

/// The id and kind of every valid row of `dir`'s `events.csv`, in its order, without reading
/// `frames.csv`: what a command checks its event arguments against before a long run. An event
/// listed here can still be dropped later for its frames.
pub fn event_kinds(dir: &Path) -> Result<Vec<(String, EventKind)>, EventsError> {
    let folder = Folder::read_events(dir)?;
    Ok(folder
        .pending
        .into_iter()
        .filter(|p| p.ok)
        .map(|p| (p.event.id, p.event.kind))
        .collect())
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
            None => {
                folder.issues.extend(event_notes(&p, &folder.events_path));
                events.push(p.event);
            }
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
            while let Some((_, issue)) = deferred.next_if(|(s, _)| *s == slot) {
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
        if dir.is_file() {
            return Err(EventsError::NotAFolder {
                path: dir.to_path_buf(),
            });
        }
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

/// The notes a complete event can get (each keeps it), on its `events.csv` line.
fn event_notes<'a>(p: &'a Pending, events_path: &'a Path) -> impl Iterator<Item = LoadIssue> + 'a {
    let intervals = sorted_intervals(&p.event.frames);
    let found = [
        speed_note(p).map(|problem| (None, problem)),
        heading_note(p).map(|problem| (None, problem)),
        impact_note(p, &intervals).map(|problem| (Some("t_impact"), problem)),
        gap_note(p, &intervals).map(|problem| (None, problem)),
        coarse_position_note(p).map(|problem| (None, problem)),
    ];
    found
        .into_iter()
        .flatten()
        .map(move |(column, problem)| LoadIssue {
            file: events_path.to_path_buf(),
            line: p.line,
            column: column.map(Into::into),
            event_id: Some(p.event.id.clone()),
            problem,
        })
}

/// Speeds integrated over time must cover about the distance the positions do: a road user whose
/// speeds add up to more than [`SPEED_PATH_RATIO_MAX`] times its path (of at least
/// [`SPEED_CHECK_MIN_PATH_M`]) has speeds in another unit (km/h: 3.6, mph: 2.24) or positions
/// that are not its own; one whose path is that much longer than its speeds add up to has
/// positions in another unit (cm: 100, feet: 3.28, as NGSIM's raw files) or speeds missing. A note on the event's `events.csv` line (the event is kept), for the
/// ego first; the simulator and the real data shipped stay within 1 % (4 % on city tracks). An
/// ego that never moves is an ego-centred folder (`can-bridge check --decoded-events-out`
/// writes the partner relative to an ego at the origin): no check.
fn speed_note(p: &Pending) -> Option<IssueProblem> {
    let frames = &p.event.frames;
    // (speeds integrated, path, displacement from the first frame to the last)
    let paths = |state: fn(&Frame) -> &VehicleState| {
        let (mut speed_path, mut path) = (0.0f64, 0.0f64);
        for w in frames.windows(2) {
            let (a, b) = (state(&w[0]), state(&w[1]));
            let dt = w[1].time - w[0].time;
            let speed = |s: &VehicleState| f64::from(s.vx).hypot(f64::from(s.vy));
            speed_path += 0.5 * (speed(a) + speed(b)) * dt;
            path += f64::from(b.x - a.x).hypot(f64::from(b.y - a.y));
        }
        let displacement = match (frames.first(), frames.last()) {
            (Some(a), Some(b)) => {
                let (a, b) = (state(a), state(b));
                f64::from(b.x - a.x).hypot(f64::from(b.y - a.y))
            }
            _ => 0.0,
        };
        (speed_path, path, displacement)
    };
    let ego = paths(|f| &f.ego);
    if ego.1 == 0.0 {
        return None;
    }
    // The other way round the displacement, not the path: position noise lengthens the path of a
    // standing road user, but cannot carry it anywhere.
    let check = |vehicle: &'static str, (speed_path, path, displacement): (f64, f64, f64)| {
        if speed_path >= SPEED_CHECK_MIN_PATH_M && speed_path > SPEED_PATH_RATIO_MAX * path {
            Some(IssueProblem::SpeedsExceedPath {
                vehicle,
                speed_path,
                path,
            })
        } else if displacement >= SPEED_CHECK_MIN_PATH_M
            && displacement > SPEED_PATH_RATIO_MAX * speed_path
        {
            Some(IssueProblem::PathExceedsSpeeds {
                vehicle,
                speed_path,
                displacement,
            })
        } else {
            None
        }
    };
    check("ego", ego).or_else(|| check("sur", paths(|f| &f.partner)))
}

/// A moving road user's heading points along its velocity (or against it, reversing) on nearly
/// every frame: one whose heading is more than 45° off that axis on more than half of the frames
/// where it moves at [`HEADING_CHECK_MIN_SPEED_M_S`] or faster (at least 5 of them) has its
/// heading in degrees read as radians, measured from north, or its components swapped. A note on
/// the event's `events.csv` line (the event is kept), for the ego first; the simulator and the
/// real data shipped are within 45° on every such frame.
fn heading_note(p: &Pending) -> Option<IssueProblem> {
    let check = |vehicle: &'static str, state: fn(&Frame) -> &VehicleState| {
        let (mut moving, mut off) = (0usize, 0usize);
        for f in &p.event.frames {
            let s = state(f);
            let speed = s.vx.hypot(s.vy);
            if speed >= HEADING_CHECK_MIN_SPEED_M_S {
                moving += 1;
                let cos = (s.vx * s.hx + s.vy * s.hy) / speed;
                off += usize::from(heading_off(f64::from(cos)));
            }
        }
        heading_mostly_off(off, moving).then_some(IssueProblem::HeadingAcrossVelocity {
            vehicle,
            off,
            moving,
        })
    };
    check("ego", |f| &f.ego).or_else(|| check("sur", |f| &f.partner))
}

/// The rule of [`heading_note`] (and of the CommonRoad importer's check against positions): a
/// heading more than 45° off the direction of travel (`|cos| < 1/sqrt 2`, either way) on more
/// than half of at least 5 moving samples is in the wrong unit or convention.
pub(crate) fn heading_mostly_off(off: usize, moving: usize) -> bool {
    moving >= 5 && 2 * off > moving
}

/// Whether a heading whose cosine with the direction of travel is `cos` is more than 45° off
/// that axis (either way: a road user reversing points against it).
pub(crate) fn heading_off(cos: f64) -> bool {
    // The f32 constant: the loader's cosines are f32, and compared with it as they always were.
    cos.abs() < f64::from(std::f32::consts::FRAC_1_SQRT_2)
}

/// The intervals between an event's frames, sorted: the median is its sampling interval.
fn sorted_intervals(frames: &[Frame]) -> Vec<f64> {
    let mut intervals: Vec<f64> = frames.windows(2).map(|w| w[1].time - w[0].time).collect();
    intervals.sort_by(f64::total_cmp);
    intervals
}

/// A conflict's `t_impact` more than one sampling interval (the event's median, plus
/// [`TIME_TOLERANCE_S`]) after its last frame: lead times are measured to `t_impact`, so every
/// warning would count the stretch without frames as warning time. A note on the `t_impact`
/// field (the event is kept). The simulator ends a crash at its impact frame. The median, not the
/// last interval: a final sample inserted just before the impact must not shrink the limit.
fn impact_note(p: &Pending, sorted_intervals: &[f64]) -> Option<IssueProblem> {
    let t_impact = p.event.t_impact?;
    let last = p.event.frames.last()?;
    // The lower median, as `gap_note` takes it; a single frame has no interval to allow for.
    let interval = sorted_intervals
        .get(sorted_intervals.len().saturating_sub(1) / 2)
        .copied()
        .unwrap_or(0.0);
    (t_impact > last.time + interval + TIME_TOLERANCE_S).then_some(
        IssueProblem::ImpactAfterFrames {
            t_impact,
            last: last.time,
        },
    )
}

/// Frames are sampled at a constant rate: an interval more than [`GAP_FACTOR`] times the
/// event's (lower) median interval is a hole (frames missing), which the preparation and the
/// metrics would span as if it were data (a derived acceleration across the hole, a lead time
/// counted over it). The lower median, so that of two intervals the shorter is the rate. An
/// event of two frames has no rate to compare with: they are a hole when more than
/// [`TWO_FRAMES_MAX_INTERVAL_S`] apart (a 2-frame "safe sequence" across 3 s), and an event of
/// one frame always gets its own note ([`IssueProblem::OneFrame`]). A note with the
/// largest hole on the event's `events.csv` line (the event is kept); the simulator and the real
/// data shipped have none.
fn gap_note(p: &Pending, intervals: &[f64]) -> Option<IssueProblem> {
    let frames = &p.event.frames;
    if let [one] = frames.as_slice() {
        return Some(IssueProblem::OneFrame {
            time: one.time,
            t_start: p.event.t_start,
            t_end: p.event.t_end,
        });
    }
    if let [only] = intervals {
        return (*only > TWO_FRAMES_MAX_INTERVAL_S).then(|| IssueProblem::TwoFramesApart {
            from: frames[0].time,
            to: frames[1].time,
        });
    }
    let typical = *intervals.get(intervals.len().checked_sub(1)? / 2)?;
    let limit = GAP_FACTOR * typical + TIME_TOLERANCE_S;
    let holes = intervals.iter().filter(|&&d| d > limit).count();
    let at = frames
        .windows(2)
        .max_by(|a, b| (a[1].time - a[0].time).total_cmp(&(b[1].time - b[0].time)))?;
    (holes > 0).then_some(IssueProblem::FrameGap {
        from: at[0].time,
        to: at[1].time,
        typical,
        holes,
    })
}

/// Positions are read as `f32`, which resolves a coordinate of 100 km to 7.8 mm but a UTM
/// northing of 5,400 km to 0.5 m: an event whose positions reach beyond [`COARSE_POSITION_M`]
/// has every gap and offset rounded that coarsely (measured: the same 310 events shifted by a
/// UTM origin moved DRL's A^ROC_90 by 0.6 points and TAdv's P^PRC_80 by 2.3). A note with the
/// largest coordinate and its f32 spacing on the event's `events.csv` line (the event is kept);
/// the simulator and the real data shipped stay within a few hundred metres.
fn coarse_position_note(p: &Pending) -> Option<IssueProblem> {
    let largest = p
        .event
        .frames
        .iter()
        .flat_map(|f| [f.ego.x, f.ego.y, f.partner.x, f.partner.y])
        .map(f32::abs)
        .fold(0.0f32, f32::max);
    (largest > COARSE_POSITION_M).then(|| IssueProblem::CoarsePositions {
        largest,
        // The distance to the next f32 above `largest`.
        spacing: f32::from_bits(largest.to_bits() + 1) - largest,
    })
}

/// A row that repeats the header (two files joined with `cat`, each with its header): a note,
/// the row skipped and nothing else touched (it is no frame of the events around it).
fn repeated_header(
    path: &Path,
    line: u64,
    rec: &csv::ByteRecord,
    headers: &csv::StringRecord,
) -> Option<LoadIssue> {
    // The second file of a `cat` keeps its UTF-8 byte-order mark, which the reader strips from
    // the first file's header only.
    let first = rec
        .get(0)
        .map(|f| f.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(f));
    let same = rec.len() == headers.len()
        && first == headers.get(0).map(str::as_bytes)
        && rec
            .iter()
            .zip(headers.iter())
            .skip(1)
            .all(|(r, h)| r == h.as_bytes());
    same.then(|| LoadIssue {
        file: path.to_path_buf(),
        line,
        column: None,
        event_id: None,
        problem: IssueProblem::RepeatedHeader,
    })
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
            "its frames come after those of an event listed later in events.csv"
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
            None => {
                let notes = event_notes(&finished, self.events_path);
                self.deferred.extend(notes.map(|note| (slot, note)));
                (self.on_event)(p.position, finished.event)
            }
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
    let (mut rdr, ends) = open(path)?;
    let (cols, headers) = column_map(path, &mut rdr, &EVENT_COLUMNS)?;
    let mut rec = csv::ByteRecord::new();
    let mut first_line: HashMap<String, u64> = HashMap::new();
    while let Some(r) = next_record(path, &mut rdr, &mut rec, headers.len(), cols[0], ends)? {
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
        if let Some(note) = repeated_header(path, line, &rec, &headers) {
            issues.push(note);
            continue;
        }
        // Escaped, not lossy: two ids a wrong encoding garbles must not merge into one.
        let id_text = field_str(rec.get(cols[0]).unwrap_or(b""));
        // `field_str` owns its text only when it had to escape bytes that are not UTF-8.
        let id_not_utf8 = matches!(id_text, Cow::Owned(_));
        let id = id_text.into_owned();
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
        } else if id_not_utf8 {
            f.push(0, IssueProblem::NotUtf8);
        }
        let kind = EventKind::parse(&f.raw(1));
        if kind.is_none() {
            let k = f.raw(1).into_owned();
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
            length_partner: f.f32(7),
            width_partner: f.f32(8),
        };
        for (i, v) in [
            dims.length_ego,
            dims.width_ego,
            dims.length_partner,
            dims.width_partner,
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
    issues.extend(no_final_newline(path, &rdr)?);
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
    let (mut rdr, ends) = open(path)?;
    let (cols, headers) = column_map(path, &mut rdr, &FRAME_COLUMNS)?;
    let acc_partner_col = fields::optional_column(path, &headers, "acc_sur")?;
    let mut rec = csv::ByteRecord::new();
    // Unknown ids: first line and frame count, reported once each.
    // id -> (first line, frames, the id is not valid UTF-8)
    let mut unknown: HashMap<String, (u64, usize, bool)> = HashMap::new();
    let mut current: Option<(String, usize)> = None;
    // The event of the last good row (`None` when not a loadable event).
    let mut previous_row: Option<usize> = None;
    // A row whose event id cannot be read: its issue, repeated for the event of the next good row.
    let mut unattributed: Option<LoadIssue> = None;
    while let Some(r) = next_record(path, &mut rdr, &mut rec, headers.len(), cols[0], ends)? {
        let line = match r {
            Ok(line) => line,
            Err(mut issue) => {
                let id = issue.event_id.as_deref();
                if let Some((id, &i)) = id.and_then(|id| Some((id, index.get(id)?))) {
                    if let Some(s) = stream.as_deref_mut() {
                        s.check_open(path, issue.line, i, id, false)?;
                    }
                    pending[i].ok = false;
                } else if !id.is_some_and(|id| rejected.contains_key(id)) {
                    // The row's id is unreadable (broken quoting) or no event's: the row may be a
                    // frame of the event before or after it, so both are dropped, never kept partial.
                    issue.event_id = previous_row.map(|i| {
                        pending[i].ok = false;
                        pending[i].event.id.clone()
                    });
                    unattributed = Some(issue.clone());
                }
                issues.push(issue);
                continue;
            }
        };
        if let Some(note) = repeated_header(path, line, &rec, &headers) {
            issues.push(note);
            continue;
        }
        let id_text = field_str(rec.get(cols[0]).unwrap_or(b""));
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
                                acc_partner_col.is_none(),
                            )?;
                        }
                    }
                    current = Some((id.to_owned(), s));
                }
                slot
            }
        };
        if let Some(mut issue) = unattributed.take() {
            if let Some(s) = slot.filter(|&s| Some(s) != previous_row) {
                pending[s].ok = false;
                issue.event_id = Some(pending[s].event.id.clone());
                issues.push(issue);
            }
        }
        previous_row = slot;
        let Some(slot) = slot else {
            if !rejected.contains_key(id) {
                unknown
                    .entry(id.to_owned())
                    .and_modify(|e| e.1 += 1)
                    // Escaped (owned) text: the id's bytes are not UTF-8.
                    .or_insert_with(|| (line, 1, matches!(id_text, Cow::Owned(_))));
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
        let mut partner = VehicleState {
            x: f.f32(9),
            y: f.f32(10),
            vx: f.f32(11),
            vy: f.f32(12),
            hx: hx_s,
            hy: hy_s,
            acc: 0.0,
            length: d.length_partner,
            width: d.width_partner,
        };
        for (state, col) in [(&ego, 4), (&partner, 11)] {
            let speed = state.vx.hypot(state.vy);
            if speed.is_finite() && speed > MAX_SPEED_M_S {
                f.push(col, IssueProblem::ImplausibleSpeed { speed });
            }
        }
        // Finite is not enough: `1e30` (a broken export) read as a place would enter every
        // feature of its frame (a TAdv of 4e28 s) and, in training, the scaler and the domain.
        for (value, col) in [(ego.x, 2), (ego.y, 3), (partner.x, 9), (partner.y, 10)] {
            if value.is_finite() && value.abs() > MAX_POSITION_M {
                f.push(col, IssueProblem::ImplausiblePosition { value });
            }
        }
        if let Some(c) = acc_partner_col {
            let s = field_str(rec.get(c).unwrap_or(b""));
            match s.parse::<f32>() {
                Ok(v) if v.is_finite() => partner.acc = v,
                Ok(_) => f.issues.push(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: Some("acc_sur".into()),
                    event_id: Some(p.event.id.clone()),
                    problem: IssueProblem::NonFinite(s.into_owned()),
                }),
                Err(_) => f.issues.push(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: Some("acc_sur".into()),
                    event_id: Some(p.event.id.clone()),
                    problem: IssueProblem::BadNumber(s.into_owned()),
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
                p.event.frames.push(Frame { time, ego, partner });
                p.last_frame_line = line;
            }
        } else {
            p.ok = false;
            issues.extend(f.issues.drain(..));
        }
    }
    issues.extend(no_final_newline(path, &rdr)?);
    if let (Some(stream), Some((_, last))) = (stream, current) {
        stream.close(last, &mut pending[last], acc_partner_col.is_none())?;
    }
    let mut unknown: Vec<_> = unknown.into_iter().collect();
    unknown.sort_by_key(|(_, (line, _, _))| *line);
    // Ids that differ only in leading zeros or case (a spreadsheet's `000123` -> `123`).
    let loose = |id: &str| {
        let id = id.to_ascii_lowercase();
        let trimmed = id.trim_start_matches('0');
        if trimmed.is_empty() && !id.is_empty() {
            "0".to_owned()
        } else {
            trimmed.to_owned()
        }
    };
    // The smallest of the ids that look alike, so the hint is the same on every run.
    let mut known: BTreeMap<String, &str> = BTreeMap::new();
    if !unknown.is_empty() {
        let mut ids: Vec<&str> = index.keys().map(String::as_str).collect();
        ids.sort_unstable();
        for id in ids {
            known.entry(loose(id)).or_insert(id);
        }
    }
    for (id, (line, frames, not_utf8)) in unknown {
        let similar = known.get(&loose(&id)).map(|s| (*s).to_owned());
        issues.push(LoadIssue {
            file: path.to_path_buf(),
            line,
            column: Some("event_id".into()),
            event_id: Some(id),
            problem: IssueProblem::UnknownEvent {
                frames,
                similar,
                not_utf8,
            },
        });
    }
    if acc_partner_col.is_none() {
        for p in pending.iter_mut().filter(|p| p.ok) {
            derive_partner_acceleration(&mut p.event.frames);
        }
    }
    Ok(())
}
