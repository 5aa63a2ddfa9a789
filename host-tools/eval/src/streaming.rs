//! Evaluating an event folder one event at a time, in memory bounded by the largest event.
//!
//! The metrics need, per sequence and method, only its kind, endpoint and running-maximum records
//! ([`AlertProfile`](super::AlertProfile)): the warning time at any threshold is read off those
//! records, and the thresholds are the sequence maxima. So each event is prepared, observed and
//! scored through the same path as [`evaluate_methods`](super::evaluate_methods) (scorer-core for
//! every number), its profiles kept and its frames dropped. Profiles are put back in `events.csv`
//! order before the curves are swept, so the report is bit for bit the one of the in-memory path.
//!
//! The trajectory plot of `riskctl evaluate --out` needs two more things, gathered in the same
//! pass when asked for ([`TrajectoryRequest`]): the scored frames of the few events drawn (the
//! first crashes by `events.csv` position, or named ones), and per method the distribution of all
//! its alert-window scores, which places each drawn frame at its percentile. That distribution is
//! a [`ScoreSketch`]: exact up to its capacity (65,536 scores by default, more than the default
//! 310-event folder has), within a stated, small rank error beyond.
//!
//! Memory: one event's frames at a time plus, per conflict sequence and method, its records
//! (a conflict sequence's risk usually rises on most frames towards its endpoint), and one record
//! per safe sequence and method (its maximum: all the metrics read of it); with trajectories, a
//! few megabytes of sketches and the drawn events. A folder whose `frames.csv` cannot be streamed
//! (an event's frames split into several runs) is read whole instead, with the old memory and an
//! exact percentile scale: see [`stream_events`](riskscore_data::events::stream_events).
use std::path::Path;

use super::domain_share::DomainShare;
use super::protocol::{
    in_alert_window, AlertProfileBuilder, EventKind, ProtocolError, ScoredFrame, ScoredSequence,
};
use super::report::{EvaluationReport, EventCounts};
use super::scoring::{observe_frames, report_of, Method};
use super::sketch::ScoreSketch;
use super::staircase::{classes_in_order, warning_curve_of, Staircases};
use super::threshold::{ThresholdCollector, ThresholdReport};
use super::trajectory::{trajectory_panels_ranked, TrajectoryPanel};
use super::WarningCurve;
use riskscore_data::events::{
    load_events, prepare_owned_event, stream_events, Event, EventsError, LoadIssue, PrepareConfig,
    PrepareIssue,
};

/// Frames observed at once (features and surrogates of every method's input).
const OBSERVED_SLICE: usize = 4096;

/// Why a folder could not be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum FolderEvaluationError {
    #[error(transparent)]
    Events(#[from] EventsError),
    #[error(transparent)]
    Protocol(#[from] ProtocolError),
}

/// The per-sequence alert data of every method, built one event at a time.
pub struct ProfileAccumulator<'a, 'm> {
    methods: &'a [Method<'m>],
    config: PrepareConfig,
    events: usize,
    /// Per method: the packed profiles, one block per accumulator merged in.
    profiles: Vec<Vec<Staircases>>,
    prepare_issues: Vec<(usize, PrepareIssue)>,
    trajectories: Option<TrajectoryCollector>,
    /// Per method: its outcomes at the threshold asked for, if any.
    thresholds: Vec<Option<ThresholdCollector>>,
    /// Per method with a training domain: its frames outside (`None`: an unguarded method).
    domain: Vec<Option<DomainShare>>,
}

/// The conflict events whose risk trajectories are drawn: the first crash sequences, or crash or
/// near-crash sequences named by id.
#[derive(Clone, Debug, PartialEq)]
pub enum TrajectoryEvents {
    /// The first `n` crash sequences in `events.csv` order.
    FirstCrashes(usize),
    /// These events (each must be a crash or near-crash sequence with an endpoint), in this order.
    Named(Vec<String>),
}

/// What the trajectory plot needs gathered while the folder streams by.
#[derive(Clone, Debug, PartialEq)]
pub struct TrajectoryRequest {
    pub events: TrajectoryEvents,
    /// Scores per level of each method's [`ScoreSketch`]: the percentile scale is exact up to this
    /// many alert-window frames, within the sketch's stated error beyond.
    pub sketch_capacity: usize,
}

/// Per method, a summary of all alert-window scores, plus the scored frames of the events drawn.
#[derive(Debug)]
struct TrajectoryCollector {
    events: TrajectoryEvents,
    scores: Vec<ScoreSketch>,
    /// `(events.csv position, one scored sequence per method)` of the events kept so far.
    kept: Vec<(usize, Vec<ScoredSequence>)>,
}

impl TrajectoryCollector {
    fn new(request: &TrajectoryRequest, methods: usize) -> Self {
        Self {
            events: request.events.clone(),
            scores: (0..methods)
                .map(|_| ScoreSketch::new(request.sketch_capacity))
                .collect(),
            kept: Vec::new(),
        }
    }

    /// Whether the sequence at `position` may be drawn (given what is kept so far).
    fn wants(
        &self,
        position: usize,
        event_id: &str,
        kind: EventKind,
        endpoint: Option<f64>,
    ) -> bool {
        if endpoint.is_none() {
            return false;
        }
        match &self.events {
            TrajectoryEvents::FirstCrashes(n) => {
                kind == EventKind::Crash
                    && (self.kept.len() < *n || self.kept.iter().any(|(p, _)| *p > position))
            }
            TrajectoryEvents::Named(ids) => ids.iter().any(|id| id == event_id),
        }
    }

    /// Keeps `sequences` (one per method); of the first crashes only the `n` earliest stay.
    fn keep(&mut self, position: usize, sequences: Vec<ScoredSequence>) {
        self.kept.push((position, sequences));
        self.kept.sort_by_key(|(p, _)| *p);
        if let TrajectoryEvents::FirstCrashes(n) = self.events {
            self.kept.truncate(n);
        }
    }

    fn merge(&mut self, other: Self) {
        for (mine, theirs) in self.scores.iter_mut().zip(other.scores) {
            mine.merge(theirs);
        }
        for (position, sequences) in other.kept {
            self.keep(position, sequences);
        }
    }

    fn finish(self, methods: &[Method<'_>]) -> Trajectories {
        let event_ids: Vec<String> = match &self.events {
            TrajectoryEvents::FirstCrashes(_) => self
                .kept
                .iter()
                .filter_map(|(_, s)| s.first().map(|s| s.event_id.clone()))
                .collect(),
            TrajectoryEvents::Named(ids) => ids.clone(),
        };
        let unknown = event_ids
            .iter()
            .filter(|id| {
                !self
                    .kept
                    .iter()
                    .any(|(_, s)| s.first().is_some_and(|s| &s.event_id == *id))
            })
            .cloned()
            .collect();
        let mut sequences: Vec<(String, Vec<ScoredSequence>)> = methods
            .iter()
            .map(|m| (m.name.clone(), Vec::new()))
            .collect();
        for (_, kept) in self.kept {
            for ((_, mine), s) in sequences.iter_mut().zip(kept) {
                mine.push(s);
            }
        }
        Trajectories {
            event_ids,
            unknown,
            sequences,
            scores: self.scores,
        }
    }
}

/// What the trajectory plot of a streamed folder needs: the events drawn, their scored frames, and
/// each method's percentile scale over all its alert-window frames.
#[derive(Debug)]
pub struct Trajectories {
    /// The events to draw, in panel order.
    pub event_ids: Vec<String>,
    /// Named events that are not a crash or near-crash sequence of the folder.
    pub unknown: Vec<String>,
    /// Per method (in `methods` order), the scored sequences of the events drawn.
    pub sequences: Vec<(String, Vec<ScoredSequence>)>,
    /// Per method, its alert-window scores over all sequences.
    pub scores: Vec<ScoreSketch>,
}

impl Trajectories {
    /// One panel per event drawn ([`trajectory_panels_ranked`]).
    pub fn panels(&mut self) -> Vec<TrajectoryPanel> {
        trajectory_panels_ranked(&self.sequences, &mut self.scores, &self.event_ids)
    }

    /// The largest error of any plotted percentile (0 to 1 scale; 0: exact), over all methods.
    pub fn percentile_error(&self) -> f64 {
        self.scores
            .iter()
            .filter(|s| s.count() > 0)
            .map(|s| s.rank_error() as f64 / s.count() as f64)
            .fold(0.0, f64::max)
    }
}

impl<'a, 'm> ProfileAccumulator<'a, 'm> {
    pub fn new(methods: &'a [Method<'m>], config: PrepareConfig) -> Self {
        Self {
            methods,
            config,
            events: 0,
            profiles: methods
                .iter()
                .map(|_| vec![Staircases::default()])
                .collect(),
            prepare_issues: Vec::new(),
            trajectories: None,
            thresholds: methods.iter().map(|_| None).collect(),
            domain: methods
                .iter()
                .map(|m| {
                    let kind = m.scorer.model_kind().filter(|_| m.scorer.has_domain());
                    kind.map(|kind| DomainShare::new(&m.name, kind))
                })
                .collect(),
        }
    }

    /// Also tallies each method at its threshold (`None`: not that method), in `methods` order
    /// ([`FolderEvaluation::thresholds`]).
    pub fn with_thresholds(mut self, thresholds: &[Option<f32>]) -> Self {
        for (slot, t) in self.thresholds.iter_mut().zip(thresholds) {
            *slot = t.map(ThresholdCollector::new);
        }
        self
    }

    /// Also gathers what the trajectory plot needs ([`FolderEvaluation::trajectories`]).
    pub fn with_trajectories(mut self, request: &TrajectoryRequest) -> Self {
        self.trajectories = Some(TrajectoryCollector::new(request, self.methods.len()));
        self
    }

    /// Prepares, observes and scores one event (at `position` in `events.csv`) with every method
    /// and keeps only its profiles. Frames are observed a slice at a time, so the event itself is
    /// the only per-frame memory.
    pub fn add(&mut self, position: usize, event: Event) -> Result<(), ProtocolError> {
        self.events += 1;
        let sequence = match prepare_owned_event(event, &self.config) {
            Ok(s) => s,
            Err(issue) => {
                self.prepare_issues.push((position, issue));
                return Ok(());
            }
        };
        let kind = sequence.kind;
        let mut builders = self
            .methods
            .iter()
            .map(|_| AlertProfileBuilder::new(&sequence.event_id, kind, sequence.endpoint))
            .collect::<Result<Vec<_>, _>>()?;
        let keep = self
            .trajectories
            .as_ref()
            .is_some_and(|t| t.wants(position, &sequence.event_id, kind, sequence.endpoint));
        let mut kept_frames: Vec<Vec<ScoredFrame>> = self
            .methods
            .iter()
            .map(|_| Vec::with_capacity(if keep { sequence.frames.len() } else { 0 }))
            .collect();
        for frames in sequence.frames.chunks(OBSERVED_SLICE) {
            let observed = observe_frames(frames);
            for (m, (method, builder)) in self.methods.iter().zip(&mut builders).enumerate() {
                let mut domain = self.domain.get_mut(m).and_then(Option::as_mut);
                for frame in &observed {
                    let score = match (&mut domain, method.scorer.score_guarded(&frame.observation))
                    {
                        (Some(tally), Some(guarded)) => {
                            tally.add(&guarded);
                            guarded.score
                        }
                        _ => method.scorer.score(&frame.observation),
                    };
                    builder.push(frame.time, score)?;
                    if let Some(t) = &mut self.trajectories {
                        if in_alert_window(sequence.endpoint, frame.time) {
                            t.scores[m].push(score);
                        }
                        if keep {
                            kept_frames[m].push(ScoredFrame {
                                time: frame.time,
                                score,
                            });
                        }
                    }
                }
            }
        }
        if let (true, Some(t)) = (keep, &mut self.trajectories) {
            let sequences = kept_frames
                .into_iter()
                .map(|frames| ScoredSequence {
                    event_id: sequence.event_id.clone(),
                    kind,
                    endpoint: sequence.endpoint,
                    frames,
                })
                .collect();
            t.keep(position, sequences);
        }
        let seconds = alert_window_seconds(&sequence.frames, sequence.endpoint);
        for ((builder, blocks), at_threshold) in builders
            .into_iter()
            .zip(&mut self.profiles)
            .zip(&mut self.thresholds)
        {
            let mut profile = builder.finish();
            if let Some(collector) = at_threshold {
                collector.add(position, &profile, seconds);
            }
            if !kind.is_conflict() {
                // A safe sequence only counts as a false alarm at every threshold up to its
                // maximum: the metrics read nothing else of it (see `warning_curve`).
                let max = profile.records.pop();
                profile.records.clear();
                profile.records.extend(max);
            }
            if let Some(block) = blocks.first_mut() {
                block.push(position, &profile);
            }
        }
        Ok(())
    }

    /// Takes over what another accumulator (of the same methods) has gathered.
    pub fn merge(&mut self, other: Self) {
        self.events += other.events;
        for (mine, theirs) in self.profiles.iter_mut().zip(other.profiles) {
            mine.extend(theirs);
        }
        self.prepare_issues.extend(other.prepare_issues);
        for (mine, theirs) in self.domain.iter_mut().zip(&other.domain) {
            if let (Some(mine), Some(theirs)) = (mine, theirs) {
                mine.merge(theirs);
            }
        }
        for (mine, theirs) in self.thresholds.iter_mut().zip(other.thresholds) {
            match (mine, theirs) {
                (Some(mine), Some(theirs)) => mine.merge(theirs),
                (mine @ None, theirs) => *mine = theirs,
                (Some(_), None) => {}
            }
        }
        match (&mut self.trajectories, other.trajectories) {
            (Some(mine), Some(theirs)) => mine.merge(theirs),
            (None, theirs) => self.trajectories = theirs,
            (Some(_), None) => {}
        }
    }

    /// Everything in `events.csv` order.
    pub fn finish(self) -> FolderEvaluation {
        let classes = self
            .profiles
            .first()
            .map(|blocks| classes_in_order(blocks))
            .unwrap_or_default();
        let sequences = classes.len();
        let events = EventCounts::from_classes(classes);
        // One method's profiles unpacked at a time.
        let curves: Vec<(String, WarningCurve)> = self
            .methods
            .iter()
            .zip(self.profiles)
            .map(|(m, blocks)| (m.name.clone(), warning_curve_of(blocks)))
            .collect();
        let report = report_of(events, curves.iter().map(|(name, curve)| (name, curve)));
        let thresholds = self
            .methods
            .iter()
            .zip(self.thresholds)
            .filter_map(|(m, c)| c.map(|c| c.finish(&m.name)))
            .collect();
        FolderEvaluation {
            load_issues: Vec::new(),
            streamed: true,
            events: self.events,
            sequences,
            prepare_issues: in_order(self.prepare_issues),
            report,
            curves,
            trajectories: self.trajectories.map(|t| t.finish(self.methods)),
            thresholds,
            domain: self.domain.into_iter().flatten().collect(),
        }
    }
}

/// The span (s) of a sequence's alert window: first frame to the last frame at or before the
/// endpoint.
fn alert_window_seconds(frames: &[riskscore_data::events::Frame], endpoint: Option<f64>) -> f64 {
    let mut times = frames
        .iter()
        .map(|f| f.time)
        .filter(|&t| in_alert_window(endpoint, t));
    let first = times.next();
    match (first, times.next_back()) {
        (Some(a), Some(b)) => (b - a).max(0.0),
        _ => 0.0,
    }
}

/// The items in `events.csv` order (positions are distinct: one sequence or issue per event).
fn in_order<T>(mut v: Vec<(usize, T)>) -> Vec<T> {
    v.sort_by_key(|(position, _)| *position);
    v.into_iter().map(|(_, x)| x).collect()
}

/// The evaluation of an event folder.
#[derive(Debug)]
pub struct FolderEvaluation {
    /// Problems and notes in the folder, as [`load_events`] lists them: a problem skips its event,
    /// except frames of an event id that events.csv lacks (only those rows are dropped); a note
    /// leaves nothing out.
    pub load_issues: Vec<LoadIssue>,
    /// True when the folder was streamed event by event (false: read whole, see module docs).
    pub streamed: bool,
    /// Valid events.
    pub events: usize,
    /// Events that yield a sequence (the rest are in `prepare_issues`, in `events.csv` order).
    pub sequences: usize,
    pub prepare_issues: Vec<PrepareIssue>,
    /// The metrics; `events` counts the sequences' classes, as [`evaluate_methods`](super::evaluate_methods) does.
    pub report: EvaluationReport,
    /// Each method's operating points, in `methods` order.
    pub curves: Vec<(String, WarningCurve)>,
    /// What the trajectory plot needs, when asked for ([`evaluate_folder_with_trajectories`]).
    pub trajectories: Option<Trajectories>,
    /// Each method asked for at a threshold, at that threshold ([`Gather::thresholds`]).
    pub thresholds: Vec<ThresholdReport>,
    /// Each model with a training-domain record, in `methods` order: its frames outside.
    pub domain: Vec<DomainShare>,
}

/// Why a folder's metrics would not describe the folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FolderRefusal {
    #[error("no valid events to evaluate")]
    NoValidEvents,
    /// Load problems leave events out of the metrics, or drop frame rows unscored (allowed with
    /// `skip_bad_events`). Its message is `riskctl evaluate`'s
    /// ([`BadRowsWording::RISKCTL_EVALUATE`]); elsewhere [`FolderRefusal::bad_rows_message`]
    /// words it for the caller.
    #[error("{}", FolderRefusal::bad_rows_message(*.valid_events, BadRowsWording::RISKCTL_EVALUATE))]
    BadRows { valid_events: ValidEvents },
    #[error("none of its {events} events yields a sequence to evaluate")]
    NoSequences { events: usize },
}

/// The valid events of a folder refused for its load problems ([`FolderRefusal::BadRows`]), and
/// what those problems leave out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ValidEvents {
    pub count: usize,
    pub left_out: LeftOut,
}

/// What the load problems of a refused folder leave out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeftOut {
    /// Events: each problem skips the event it names, or drops a row whose event cannot be told.
    Events,
    /// Only frame rows of event ids that events.csv lacks
    /// ([`IssueProblem::UnknownEvent`](riskscore_data::events::IssueProblem::UnknownEvent)):
    /// every event of events.csv is evaluated, those rows are dropped unscored.
    UnknownIdRows,
    /// Both: events, and frame rows of event ids that events.csv lacks.
    EventsAndUnknownIdRows,
}

impl LeftOut {
    /// What the problems (not notes) among `issues` leave out; `None` when there is none.
    pub fn of(issues: &[LoadIssue]) -> Option<LeftOut> {
        let problems = issues.iter().filter(|i| !i.problem.is_note());
        let (mut events, mut rows) = (false, false);
        for issue in problems {
            if issue.problem.drops_only_its_rows() {
                rows = true;
            } else {
                events = true;
            }
        }
        match (events, rows) {
            (false, false) => None,
            (true, false) => Some(LeftOut::Events),
            (false, true) => Some(LeftOut::UnknownIdRows),
            (true, true) => Some(LeftOut::EventsAndUnknownIdRows),
        }
    }
}

/// The parts of a [`FolderRefusal::BadRows`] message that depend on where it is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadRowsWording<'a> {
    /// Where the problems are listed relative to the message: `"above"` (riskctl prints them
    /// first) or `"below"` (they follow the message).
    pub listed: &'a str,
    /// What the events would be left out of: `"metrics"`, `"calibration"`.
    pub left_out_of: &'a str,
    /// The flag or argument that evaluates the valid events anyway (`--skip-bad-events`,
    /// `skip_bad_events=True`), or `None` where there is none: the valid events can then be
    /// written to a folder of their own.
    pub skip: Option<&'a str>,
}

impl BadRowsWording<'static> {
    /// `riskctl evaluate`: problems printed before the message, `--skip-bad-events`.
    pub const RISKCTL_EVALUATE: Self = BadRowsWording {
        listed: "above",
        left_out_of: "metrics",
        skip: Some("--skip-bad-events"),
    };
}

impl FolderRefusal {
    /// The one text of the [`FolderRefusal::BadRows`] refusal of a folder with `valid_events`,
    /// worded for where it is shown. It says what the problems leave out: their events, or (frame
    /// rows of event ids that events.csv lacks) no event but those rows.
    pub fn bad_rows_message(valid_events: ValidEvents, wording: BadRowsWording<'_>) -> String {
        let BadRowsWording {
            listed,
            left_out_of,
            skip,
        } = wording;
        let ValidEvents { count, left_out } = valid_events;
        if left_out == LeftOut::UnknownIdRows {
            let instead = match skip {
                Some(skip) => {
                    format!(", or pass {skip} to evaluate the {count} events without them")
                }
                None => String::new(),
            };
            return format!(
                "the problems listed {listed} are frame rows of event ids that events.csv lacks: \
                 no event would be left out of the {left_out_of}, but those rows would be dropped; \
                 add their events to events.csv or remove those rows{instead}"
            );
        }
        let instead = match skip {
            Some(skip) => format!(", or pass {skip} to evaluate the {count} valid events"),
            None => format!(" (or write the {count} valid events to a folder of their own)"),
        };
        let rows_too = match left_out {
            LeftOut::EventsAndUnknownIdRows => {
                " (except the frame rows of event ids that events.csv lacks: only those rows are dropped)"
            }
            _ => "",
        };
        format!(
            "the problems listed {listed} would leave their events out of the {left_out_of}\
             {rows_too}; fix those rows{instead}"
        )
    }
}

impl FolderEvaluation {
    /// What `riskctl evaluate --json` prints (and `riskscore.evaluate` returns): the report's
    /// JSON with the operating points under `"operating_points"` and the guarded models' frames
    /// outside their training domain under `"domain"` (one object per model with a domain
    /// record; `[]` when none has one).
    pub fn to_json_text(&self) -> Result<String, serde_json::Error> {
        let mut json: serde_json::Value = serde_json::from_str(&self.report.to_json_string())?;
        if let Some(object) = json.as_object_mut() {
            let points = self.thresholds.iter().map(|t| t.to_json()).collect();
            object.insert(
                "operating_points".to_owned(),
                serde_json::Value::Array(points),
            );
            let domain = self.domain.iter().map(|d| d.to_json()).collect();
            object.insert("domain".to_owned(), serde_json::Value::Array(domain));
        }
        serde_json::to_string_pretty(&json)
    }

    /// The Markdown `riskctl evaluate` prints (and writes as results.md): the metrics table, the
    /// frames outside the training domain and the operating points.
    pub fn to_markdown(&self) -> String {
        let mut text = self.report.to_markdown();
        text.push_str(&crate::domain_share::markdown(&self.domain));
        if !self.thresholds.is_empty() {
            text.push_str(&crate::threshold::markdown(&self.thresholds));
        }
        text
    }

    /// `Err` when the metrics would leave events or frame rows out, or have nothing to measure: no
    /// valid event, load problems other than notes (unless `skip_bad_events`; frame rows of event
    /// ids that events.csv lacks leave no event out but are refused too, as their frames would go
    /// unscored: they may be an event's whose id a spreadsheet changed), or no event that yields
    /// a sequence.
    pub fn check(&self, skip_bad_events: bool) -> Result<(), FolderRefusal> {
        if self.events == 0 {
            Err(FolderRefusal::NoValidEvents)
        } else if let Some(left_out) = LeftOut::of(&self.load_issues).filter(|_| !skip_bad_events) {
            Err(FolderRefusal::BadRows {
                valid_events: ValidEvents {
                    count: self.events,
                    left_out,
                },
            })
        } else if self.sequences == 0 {
            Err(FolderRefusal::NoSequences {
                events: self.events,
            })
        } else {
            Ok(())
        }
    }
}

/// Evaluates the event folder `dir` with `methods`, one event at a time (see the module docs):
/// the calling thread reads and validates `frames.csv`, `workers` threads (at least one) score
/// the events it hands over. Falls back to reading the folder whole when its frames are not
/// grouped by event.
pub fn evaluate_folder(
    dir: &Path,
    methods: &[Method<'_>],
    config: PrepareConfig,
    workers: usize,
) -> Result<FolderEvaluation, FolderEvaluationError> {
    evaluate_folder_with_trajectories(dir, methods, config, workers, None)
}

/// [`evaluate_folder`], also gathering what the trajectory plot needs when `trajectories` is
/// given ([`FolderEvaluation::trajectories`]). When the folder has to be read whole, the
/// percentile scales are exact (the frames are in memory anyway).
pub fn evaluate_folder_with_trajectories(
    dir: &Path,
    methods: &[Method<'_>],
    config: PrepareConfig,
    workers: usize,
    trajectories: Option<&TrajectoryRequest>,
) -> Result<FolderEvaluation, FolderEvaluationError> {
    let gather = Gather {
        trajectories,
        thresholds: &[],
    };
    evaluate_folder_gathering(dir, methods, config, workers, gather)
}

/// What an evaluation gathers beside the metrics.
#[derive(Clone, Copy, Debug, Default)]
pub struct Gather<'r> {
    /// The trajectory plot's data ([`FolderEvaluation::trajectories`]).
    pub trajectories: Option<&'r TrajectoryRequest>,
    /// Per method, in `methods` order, a threshold to tally it at ([`FolderEvaluation::thresholds`]).
    pub thresholds: &'r [Option<f32>],
}

/// [`evaluate_folder`], also gathering what `gather` asks for.
pub fn evaluate_folder_gathering(
    dir: &Path,
    methods: &[Method<'_>],
    config: PrepareConfig,
    workers: usize,
    gather: Gather<'_>,
) -> Result<FolderEvaluation, FolderEvaluationError> {
    let trajectories = gather.trajectories;
    let accumulator = |request: Option<&TrajectoryRequest>| {
        let acc = ProfileAccumulator::new(methods, config).with_thresholds(gather.thresholds);
        match request {
            Some(r) => acc.with_trajectories(r),
            None => acc,
        }
    };
    let workers = workers.max(1);
    // A few events in flight per worker: memory stays a handful of events.
    let (send, receive) = std::sync::mpsc::sync_channel::<(usize, Event)>(2 * workers);
    let receive = std::sync::Mutex::new(receive);
    let streamed = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                let receive = &receive;
                scope.spawn(move || {
                    let mut acc = accumulator(trajectories);
                    let mut failure = None;
                    loop {
                        // The guard is dropped before scoring, so workers score concurrently.
                        let next = receive.lock().map_or(None, |r| r.recv().ok());
                        let Some((position, event)) = next else { break };
                        // After a failure keep draining, so the reader never blocks on a full channel.
                        if failure.is_none() {
                            failure = acc.add(position, event).err();
                        }
                    }
                    (acc, failure)
                })
            })
            .collect();
        let read = stream_events(dir, false, |position, event| {
            // A closed channel means every worker is gone; their result tells why.
            let _ = send.send((position, event));
            Ok::<(), EventsError>(())
        });
        drop(send);
        let mut merged = accumulator(trajectories);
        let mut failure = None;
        for handle in handles {
            let (acc, f) = handle
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
            merged.merge(acc);
            failure = failure.or(f);
        }
        match (read, failure) {
            (Err(e), _) => Err(FolderEvaluationError::from(e)),
            (Ok(_), Some(f)) => Err(f.into()),
            (Ok(load_issues), None) => Ok(FolderEvaluation {
                load_issues,
                ..merged.finish()
            }),
        }
    });
    match streamed {
        Ok(evaluation) => Ok(evaluation),
        Err(FolderEvaluationError::Events(EventsError::NotStreamable { .. })) => {
            let (set, load_issues) = load_events(dir)?;
            let exact = trajectories.map(|r| TrajectoryRequest {
                sketch_capacity: usize::MAX,
                ..r.clone()
            });
            let mut acc = accumulator(exact.as_ref());
            for (position, event) in set.events.into_iter().enumerate() {
                acc.add(position, event)?;
            }
            Ok(FolderEvaluation {
                load_issues,
                streamed: false,
                ..acc.finish()
            })
        }
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::{BadRowsWording, FolderRefusal, LeftOut, ValidEvents};

    fn valid(count: usize) -> ValidEvents {
        ValidEvents {
            count,
            left_out: LeftOut::Events,
        }
    }

    #[test]
    fn the_bad_rows_refusal_is_one_text_worded_for_where_it_is_shown() {
        assert_eq!(
            FolderRefusal::BadRows {
                valid_events: valid(17)
            }
            .to_string(),
            "the problems listed above would leave their events out of the metrics; fix those \
             rows, or pass --skip-bad-events to evaluate the 17 valid events"
        );
        let python = BadRowsWording {
            listed: "below",
            left_out_of: "metrics",
            skip: Some("skip_bad_events=True"),
        };
        assert_eq!(
            FolderRefusal::bad_rows_message(valid(3), python),
            "the problems listed below would leave their events out of the metrics; fix those \
             rows, or pass skip_bad_events=True to evaluate the 3 valid events"
        );
        let calibrate = BadRowsWording {
            listed: "above",
            left_out_of: "calibration",
            skip: None,
        };
        assert_eq!(
            FolderRefusal::bad_rows_message(valid(3), calibrate),
            "the problems listed above would leave their events out of the calibration; fix \
             those rows (or write the 3 valid events to a folder of their own)"
        );
    }
}
