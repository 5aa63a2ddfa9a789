//! Evaluating an event folder one event at a time, in memory bounded by the largest event.
//!
//! The metrics need, per sequence and method, only its class, endpoint and running-maximum records
//! ([`AlertProfile`]): the warning time at any threshold is read off those records, and the
//! thresholds are the sequence maxima. So each event is prepared, observed and scored through the
//! same path as [`evaluate_methods`](super::evaluate_methods) (scorer-core for every number), its
//! profiles kept and its frames dropped. Profiles are put back in `events.csv` order before the
//! curves are swept, so the report is bit for bit the one of the in-memory path.
//!
//! Memory: one event's frames at a time plus, per conflict sequence and method, its records
//! (16 bytes each; a conflict sequence's risk usually rises on most frames towards its endpoint),
//! and one record per safe sequence and method (its maximum: all the metrics read of it). A folder
//! whose `frames.csv` cannot be streamed (an event's frames split into several runs) is read whole
//! instead, with the old memory: see [`stream_events`](riskscore_data::events::stream_events).
use std::path::Path;

use super::protocol::{AlertProfile, AlertProfileBuilder, ProtocolError, SequenceClass};
use super::report::{EvaluationReport, EventCounts};
use super::scoring::{observe_frames, report_of, Method};
use super::{metrics::warning_curve, WarningCurve};
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
    /// Per method: (events.csv position, profile), in arrival order until [`Self::finish`].
    profiles: Vec<Vec<(usize, AlertProfile)>>,
    prepare_issues: Vec<(usize, PrepareIssue)>,
}

impl<'a, 'm> ProfileAccumulator<'a, 'm> {
    pub fn new(methods: &'a [Method<'m>], config: PrepareConfig) -> Self {
        Self {
            methods,
            config,
            events: 0,
            profiles: methods.iter().map(|_| Vec::new()).collect(),
            prepare_issues: Vec::new(),
        }
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
        let class = SequenceClass::from(sequence.kind);
        let mut builders = self
            .methods
            .iter()
            .map(|_| AlertProfileBuilder::new(&sequence.event_id, class, sequence.endpoint))
            .collect::<Result<Vec<_>, _>>()?;
        for frames in sequence.frames.chunks(OBSERVED_SLICE) {
            let observed = observe_frames(frames);
            for (method, builder) in self.methods.iter().zip(&mut builders) {
                for frame in &observed {
                    builder.push(frame.time, method.scorer.score(&frame.observation))?;
                }
            }
        }
        for (builder, profiles) in builders.into_iter().zip(&mut self.profiles) {
            let mut profile = builder.finish();
            // The metrics never read the id (errors above have named it): sequences x methods
            // copies would cost more than the records.
            profile.event_id = String::new();
            if !class.is_conflict() {
                // A safe sequence only counts as a false alarm at every threshold up to its
                // maximum: the metrics read nothing else of it (see `warning_curve`).
                let max = profile.records.pop();
                profile.records.clear();
                profile.records.extend(max);
            }
            profile.records.shrink_to_fit();
            profiles.push((position, profile));
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
    }

    /// Everything in `events.csv` order.
    pub fn finish(self) -> FolderEvaluation {
        let profiles: Vec<Vec<AlertProfile>> = self.profiles.into_iter().map(in_order).collect();
        let sequences = profiles.first().map_or(0, Vec::len);
        let curves: Vec<(String, WarningCurve)> = self
            .methods
            .iter()
            .zip(&profiles)
            .map(|(m, p)| (m.name.clone(), warning_curve(p)))
            .collect();
        let events = profiles
            .first()
            .map(|p| EventCounts::from_classes(p.iter().map(|p| p.class)))
            .unwrap_or_default();
        let report = report_of(events, curves.iter().map(|(name, curve)| (name, curve)));
        FolderEvaluation {
            load_issues: Vec::new(),
            streamed: true,
            events: self.events,
            sequences,
            prepare_issues: in_order(self.prepare_issues),
            report,
            curves,
        }
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
    /// Problems in the folder (their events are skipped), as [`load_events`] lists them.
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
    let workers = workers.max(1);
    // A few events in flight per worker: memory stays a handful of events.
    let (send, receive) = std::sync::mpsc::sync_channel::<(usize, Event)>(2 * workers);
    let receive = std::sync::Mutex::new(receive);
    let streamed = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                let receive = &receive;
                scope.spawn(move || {
                    let mut acc = ProfileAccumulator::new(methods, config);
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
        let mut merged = ProfileAccumulator::new(methods, config);
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
            let mut acc = ProfileAccumulator::new(methods, config);
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
