//! `can-bridge check`: score a candump log made by `riskctl events-to-candump` and compare the
//! bridge with the offline evaluation.
//!
//! How exact agreement with `riskctl evaluate` is achieved: the bridge scores the states it
//! *decoded* from the CAN frames (DBC resolution: 1 mm, 1 mm/s, 0.4 mrad), which are not bit-equal
//! to the event tables' floats. So `check` evaluates the bridge on its decoded states: it traces
//! every scored track update back to its event frame (the exporter's [`Layout`]), rebuilds the
//! event set as the bridge saw it (same event metadata, frames = decoded ego/partner states),
//! prepares sequences from it with riskscore-data's own preparation, and computes the metrics with
//! riskscore-eval's own evaluation from the bridge's scores. `--decoded-events-out DIR` writes that event
//! set as an event folder (with an `acc_sur` column); `riskctl evaluate --events DIR` on it
//! recomputes the scores from the same states through the same `scorer-core` calls, so the table
//! and JSON are identical, number for number.
use crate::engine::{Engine, Output};
use crate::logfile::{for_each_frame, LogReport};
use crate::losses::FrameLosses;
use crate::map::{CompiledMap, PartnerField, PositionKind};
use crate::offline::LogFeed;
use can_codec::ValueKind;
use riskscore_data::candump_export::{to_ego_frame, ExportOptions, Layout, TRIGGER_OFFSET_US};
use riskscore_data::events::{
    prepare_sequences, Event, EventKind, EventSet, EventWriter, EventsError, Frame as EventFrame,
    PrepareConfig,
};
use riskscore_eval::scoring::evaluate_scored;
use riskscore_eval::{EvaluationReport, ScoredFrame, ScoredSequence};
use std::collections::HashMap;
use std::path::Path;

/// Per-event result of the bridge's live warning logic.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EventVerdict {
    pub event_id: String,
    pub kind: &'static str,
    pub track: u32,
    /// Frames in the event table / frames the bridge scored.
    pub frames: usize,
    pub scored: usize,
    /// Event frames the bridge has no scored update for (the sensor did not report the partner,
    /// the frame was lost, or its track was not yet scorable).
    pub not_reported: usize,
    pub max_score: Option<f32>,
    pub endpoint: Option<f64>,
    /// Event time of the bridge's first warning onset for this event.
    pub warned_at: Option<f64>,
    /// `endpoint - warned_at` when the warning came at or before the endpoint.
    pub lead_time: Option<f64>,
    /// Warned only after the endpoint.
    pub late: bool,
}

/// Everything `check` found.
#[derive(Debug)]
pub struct CheckReport {
    pub threshold: f32,
    pub verdicts: Vec<EventVerdict>,
    pub report: EvaluationReport,
    /// The event set as the bridge decoded it.
    pub decoded: EventSet,
    /// Bridge outputs that did not trace back to an event frame.
    pub untraced: usize,
    pub log: LogReport,
    /// Frames read but lost (late, off the timeline, not decodable), by line.
    pub losses: FrameLosses,
    pub stats: crate::engine::Stats,
    /// The run-end sanity report over the scored states.
    pub sanity: crate::sanity::Sanity,
}

/// Errors of `check`.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error("reading the log: {0}")]
    Io(#[from] std::io::Error),
    #[error("the log holds no frames: {}", if *unreadable > 0 { format!("{unreadable} unreadable lines (listed above)") } else { "it is empty".to_string() })]
    EmptyLog { unreadable: usize },
    #[error("{0}")]
    StuckTimestamps(String),
    #[error("the bridge scored no track update in the log, so it cannot be matched to the event folder (is this a log written by `riskctl events-to-candump`?)")]
    NothingScored,
    #[error("the log and the event folder do not belong together: {0}")]
    Mismatch(String),
    #[error("the log and the event folder do not belong together, or the map decodes the positions differently: {0}")]
    ContentMismatch(String),
    #[error("evaluation: {0}")]
    Protocol(#[from] riskscore_eval::ProtocolError),
}

/// Scored updates sampled when testing a candidate alignment.
const ALIGNMENT_SAMPLE: usize = 512;
/// Scored updates whose timestamps propose candidate alignments.
const ALIGNMENT_SEEDS: usize = 16;
/// The smallest position tolerance (m): float rounding of the exporter and the engine stays well
/// inside it; coarser sensors get their own resolution ([`PositionTolerance`]).
const CONTENT_TOLERANCE_M: f64 = 0.01;

/// How far a traced update's decoded partner position may lie from its event frame's and still
/// show that frame: one resolution step of the mapped position signals (DBC factor times map
/// factor; polar maps add the azimuth step times the distance), or `--tolerance`.
#[derive(Clone, Debug, PartialEq)]
pub struct PositionTolerance {
    base_m: f64,
    per_metre: f64,
    /// Where the figure comes from, for messages.
    pub source: String,
}

impl PositionTolerance {
    /// From the resolution of `map`'s position signals.
    pub fn from_map(map: &CompiledMap) -> Self {
        let step = |field: PartnerField| {
            map.inputs
                .iter()
                .flat_map(|m| {
                    m.partner
                        .iter()
                        .filter(move |f| f.field == field)
                        .map(move |f| (&m.spec.signals[f.signal], f.factor))
                })
                .map(|(signal, factor)| match signal.kind {
                    ValueKind::Float32 | ValueKind::Float64 => 0.0,
                    ValueKind::Signed | ValueKind::Unsigned => (signal.factor * factor).abs(),
                })
                .fold(0.0, f64::max)
        };
        let (base_m, per_metre, source) = match map.position {
            PositionKind::Cartesian => {
                let (x, y) = (step(PartnerField::PosX), step(PartnerField::PosY));
                (
                    x.hypot(y),
                    0.0,
                    format!("resolution of object.pos_x {x} m and object.pos_y {y} m"),
                )
            }
            PositionKind::Polar => {
                let (r, az) = (step(PartnerField::Range), step(PartnerField::Azimuth));
                (
                    r,
                    az,
                    format!("resolution of object.range {r} m and object.azimuth {az} rad"),
                )
            }
        };
        Self {
            base_m,
            per_metre,
            source,
        }
    }

    /// A fixed tolerance (`--tolerance`).
    pub fn fixed(metres: f64) -> Self {
        Self {
            base_m: metres,
            per_metre: 0.0,
            source: "--tolerance".into(),
        }
    }

    /// The tolerance at `distance` m from the ego.
    pub fn at(&self, distance: f64) -> f64 {
        let derived = self.base_m + self.per_metre * distance;
        if self.source == "--tolerance" {
            derived
        } else {
            derived.max(CONTENT_TOLERANCE_M)
        }
    }
}

/// The log's time offset: `log time = offset + exporter time from 0`. Found from the content (the
/// track ids and trigger timestamps of the scored updates), not from the first line, so missing,
/// corrupt or unrelated frames at the start do not shift the timeline. Returns the offset and how
/// many of `scored` it traces.
fn align(
    scored: &[(u32, u64)],
    layout: &Layout,
    index: &HashMap<(u32, u64), (usize, usize)>,
) -> Option<(u64, usize)> {
    let step = (scored.len() / ALIGNMENT_SAMPLE).max(1);
    let sample: Vec<(u32, u64)> = scored.iter().step_by(step).copied().collect();
    let mut candidates: Vec<u64> = Vec::new();
    for &(track, t) in scored.iter().take(ALIGNMENT_SEEDS) {
        for p in layout.placements.iter().filter(|p| p.track_id == track) {
            for c in &p.cycle_us {
                if let Some(off) = t.checked_sub(c + TRIGGER_OFFSET_US) {
                    candidates.push(off);
                }
            }
        }
    }
    candidates.sort_unstable();
    candidates.dedup();
    let hits = |off: u64, obs: &[(u32, u64)]| {
        obs.iter()
            .filter(|(track, t)| {
                t.checked_sub(off)
                    .is_some_and(|rel| index.contains_key(&(*track, rel)))
            })
            .count()
    };
    let best = candidates
        .into_iter()
        .map(|off| (hits(off, &sample), off))
        .max_by_key(|(n, off)| (*n, std::cmp::Reverse(*off)))?;
    Some((best.1, hits(best.1, scored)))
}

/// The exporter's `--gap` that places the scored updates `keys` (track, trigger time) on the
/// folder's timeline, if one does: event `k` starts `k` gaps later than with no gap, so the first
/// update of each of the first tracks proposes a gap (the median is taken, to the millisecond),
/// which is then checked by aligning the whole log.
fn infer_gap(keys: &[(u32, u64)], set: &EventSet) -> Option<u64> {
    let opts = |gap_us| ExportOptions {
        iface: String::new(),
        start_us: 0,
        gap_us,
    };
    let tight = Layout::new(set, &opts(0));
    let tracks = tight.placements.len().min(256);
    let mut first: Vec<Option<u64>> = vec![None; tracks];
    for &(track, t) in keys {
        if let Some(slot) = first.get_mut(track as usize) {
            slot.get_or_insert(t);
        }
    }
    let start = |k: usize| tight.placements[k].cycle_us.first().copied();
    let (t0, s0) = (first.first().copied()??, start(0)?);
    let mut gaps: Vec<i64> = (1..tracks)
        .filter_map(|k| {
            let d = first[k]? as i64 - t0 as i64 - (start(k)? as i64 - s0 as i64);
            Some(d / k as i64)
        })
        .filter(|g| *g >= 0)
        .collect();
    if gaps.is_empty() {
        return None;
    }
    gaps.sort_unstable();
    let gap = ((gaps[gaps.len() / 2] as f64 / 1000.0).round() * 1000.0) as u64;
    let layout = Layout::new(set, &opts(gap));
    let (_, traced) = align(keys, &layout, &layout.trigger_index())?;
    (traced * 2 >= keys.len()).then_some(gap)
}

/// Runs the bridge over `log` and evaluates it against `set`. `gap_us` must be the exporter's
/// pause between events; the log's timeline is aligned on its content ([`align`]). `row_name` is
/// the model's row in the table (`riskscore_eval::scoring::model_row_name`, as `riskctl
/// evaluate`). A log that does not trace to the folder is an error, not empty metrics.
/// `reorder_ms`: the reorder window of a log with several interfaces ([`crate::offline`]).
pub fn check(
    log: &Path,
    set: &EventSet,
    engine: &mut Engine<'_>,
    row_name: &str,
    gap_us: u64,
    tolerance: Option<f64>,
    reorder_ms: u64,
) -> Result<CheckReport, CheckError> {
    let tolerance = tolerance.map_or_else(
        || PositionTolerance::from_map(engine.map()),
        PositionTolerance::fixed,
    );
    let layout = Layout::new(
        set,
        &ExportOptions {
            iface: String::new(),
            start_us: 0,
            gap_us,
        },
    );
    let index = layout.trigger_index();
    let mut scored_updates: Vec<crate::engine::ScoredUpdate> = Vec::new();
    let mut onsets: Vec<(u32, u64)> = Vec::new();
    let mut losses = FrameLosses::default();
    let mut sanity = crate::sanity::Sanity::default();
    let mut collect = |o: Output| match o {
        Output::Scored(obs) => {
            sanity.observe(&obs);
            scored_updates.push(obs)
        }
        Output::WarningOn { t_us, track, .. } => onsets.push((track, t_us)),
        other => losses.handle(&other),
    };
    let mut feed = LogFeed::new(reorder_ms);
    let log_report = for_each_frame(log, |line_no, rec| {
        feed.push(engine, line_no as u64, rec, &mut collect);
    })?;
    feed.finish(engine, &mut collect);
    if log_report.frames == 0 || scored_updates.is_empty() {
        // Why, line by line, before the verdict.
        crate::losses::print_lost(log, &log_report, &losses);
        return Err(if log_report.frames == 0 {
            CheckError::EmptyLog {
                unreadable: log_report.bad_lines(),
            }
        } else {
            CheckError::NothingScored
        });
    }
    if let Some(m) = log_report.stuck_timestamps(engine.stats().duplicates, engine.stats().scored) {
        return Err(CheckError::StuckTimestamps(m));
    }
    let keys: Vec<(u32, u64)> = scored_updates.iter().map(|o| (o.track, o.t_us)).collect();
    let (offset, traced) = align(&keys, &layout, &index).unwrap_or((0, 0));
    if traced * 2 < scored_updates.len() {
        let hint = match infer_gap(&keys, set) {
            Some(g) if g != gap_us => format!(
                "; the log fits the folder with --gap {}: pass the --gap events-to-candump was run with",
                g as f64 / 1e6
            ),
            _ => "; if events-to-candump was run with another --gap, pass that --gap here".into(),
        };
        return Err(CheckError::Mismatch(format!(
            "at best {traced} of the {} scored track updates fall on an event frame of the folder's timeline (--gap {} s){hint}",
            scored_updates.len(),
            gap_us as f64 / 1e6
        )));
    }
    let trace = |track: u32, t_us: u64| {
        t_us.checked_sub(offset)
            .and_then(|rel| index.get(&(track, rel)).copied())
    };
    // Per event: decoded frames with the bridge's score, first onset time.
    let mut decoded: Vec<Vec<(EventFrame, f32)>> = vec![Vec::new(); set.events.len()];
    let mut onset: Vec<Option<f64>> = vec![None; set.events.len()];
    let mut untraced = 0usize;
    let mut off = ContentOff::default();
    for obs in &scored_updates {
        let Some((k, i)) = trace(obs.track, obs.t_us) else {
            untraced += 1;
            continue;
        };
        let frame = &set.events[k].frames[i];
        let expected = to_ego_frame(frame);
        let dx = (f64::from(obs.partner.x) - expected.pos_x).abs();
        let dy = (f64::from(obs.partner.y) - expected.pos_y).abs();
        let allowed = tolerance.at(expected.pos_x.hypot(expected.pos_y));
        if dx > allowed || dy > allowed {
            off.add(dx, dy, &set.events[k].id, frame.time, obs.track);
        }
        decoded[k].push((
            EventFrame {
                time: frame.time,
                ego: obs.ego,
                partner: obs.partner,
            },
            obs.score,
        ));
    }
    if off.count * 100 > traced {
        return Err(CheckError::ContentMismatch(
            off.describe(traced, &tolerance),
        ));
    }
    for (track, t_us) in onsets {
        if let Some((k, i)) = trace(track, t_us) {
            onset[k].get_or_insert(set.events[k].frames[i].time);
        }
    }

    let mut verdicts = Vec::with_capacity(set.events.len());
    let mut decoded_events = Vec::new();
    let mut scores: HashMap<String, HashMap<u64, f32>> = HashMap::new();
    for (k, ev) in set.events.iter().enumerate() {
        let frames = &decoded[k];
        let max_score = frames.iter().map(|(_, s)| *s).reduce(f32::max);
        let endpoint = ev.t_impact;
        let warned_at = onset[k];
        let (lead_time, late) = match (warned_at, endpoint) {
            (Some(w), Some(e)) if w <= e + riskscore_data::events::TIME_TOLERANCE_S => {
                (Some(riskscore_eval::protocol::lead_time(e, w)), false)
            }
            (Some(_), Some(_)) => (None, true),
            _ => (None, false),
        };
        verdicts.push(EventVerdict {
            event_id: ev.id.clone(),
            kind: ev.kind.as_str(),
            track: layout.placements[k].track_id,
            frames: ev.frames.len(),
            scored: frames.len(),
            not_reported: ev.frames.len().saturating_sub(frames.len()),
            max_score,
            endpoint,
            warned_at,
            lead_time,
            late,
        });
        if let Some((first, _)) = frames.first() {
            let dims = riskscore_data::events::Dims {
                length_ego: first.ego.length,
                width_ego: first.ego.width,
                length_partner: first.partner.length,
                width_partner: first.partner.width,
            };
            decoded_events.push(Event {
                id: ev.id.clone(),
                kind: ev.kind,
                t_start: ev.t_start,
                t_end: ev.t_end,
                t_impact: ev.t_impact,
                dims,
                frames: frames.iter().map(|(f, _)| *f).collect(),
            });
            scores.insert(
                ev.id.clone(),
                frames.iter().map(|(f, s)| (f.time.to_bits(), *s)).collect(),
            );
        }
    }
    let decoded_set = EventSet {
        events: decoded_events,
    };
    let (sequences, _issues) = prepare_sequences(&decoded_set, &PrepareConfig::default());
    let scored: Vec<ScoredSequence> = sequences
        .iter()
        .map(|s| ScoredSequence {
            event_id: s.event_id.clone(),
            kind: s.kind,
            endpoint: s.endpoint,
            frames: s
                .frames
                .iter()
                .map(|f| ScoredFrame {
                    time: f.time,
                    score: scores
                        .get(&s.event_id)
                        .and_then(|m| m.get(&f.time.to_bits()))
                        .copied()
                        .unwrap_or(f32::NAN),
                })
                .collect(),
        })
        .collect();
    let (report, _runs) = evaluate_scored(vec![(row_name.to_string(), scored)])?;
    Ok(CheckReport {
        threshold: engine.config().threshold,
        verdicts,
        report,
        decoded: decoded_set,
        untraced,
        log: log_report,
        losses,
        stats: *engine.stats(),
        sanity,
    })
}

/// The traced updates whose position is off by more than the tolerance: how many, and by how much
/// in x and in y at worst.
#[derive(Default)]
struct ContentOff {
    count: usize,
    max_dx: f64,
    max_dy: f64,
    /// (event, time, track) of the update furthest off.
    worst: Option<(String, f64, u32)>,
    worst_off: f64,
}

impl ContentOff {
    fn add(&mut self, dx: f64, dy: f64, event: &str, time: f64, track: u32) {
        self.count += 1;
        self.max_dx = self.max_dx.max(dx);
        self.max_dy = self.max_dy.max(dy);
        if dx.max(dy) > self.worst_off {
            self.worst_off = dx.max(dy);
            self.worst = Some((event.to_string(), time, track));
        }
    }

    fn describe(&self, traced: usize, tolerance: &PositionTolerance) -> String {
        let worst = self
            .worst
            .as_ref()
            .map(|(e, t, k)| format!(" (furthest: event {e} at {t:.2} s, track {k})"))
            .unwrap_or_default();
        format!(
            "{} of {traced} traced track updates are off by more than the tolerance ({:.4} m at the origin, from the {}): object x up to {:.3} m off, object y up to {:.3} m off{worst}; a wrong map offset, factor or sign usually causes this, a sensor coarser than its DBC says can be checked with --tolerance METRES",
            self.count,
            tolerance.at(0.0),
            tolerance.source,
            self.max_dx,
            self.max_dy
        )
    }
}

/// Writes an event set as an event folder, with the partner acceleration in an `acc_sur` column so
/// the loader uses exactly the value the bridge scored with (the folder reads back bit-exactly).
pub fn write_decoded_events(dir: &Path, set: &EventSet) -> Result<(), EventsError> {
    write_decoded_events_with(dir, set, Vec::new())
}

/// Like [`write_decoded_events`], with other outputs of the run already written to their
/// temporaries (`check --per-event-out`): every file is synced before any is renamed into place,
/// so a failure leaves all of them as they were.
pub fn write_decoded_events_with(
    dir: &Path,
    set: &EventSet,
    others: Vec<riskscore_output::AtomicFile>,
) -> Result<(), EventsError> {
    let mut w = EventWriter::create_with_partner_acceleration(dir)?;
    for event in set {
        w.write_event(event)?;
    }
    w.finish_with(others)
}

impl CheckReport {
    /// The per-event table (Markdown).
    pub fn verdict_table(&self) -> String {
        let mut s = String::from(
            "| Event | Kind | Track | Scored/frames | Not reported | Max score | Warned at (s) | Endpoint (s) | Lead time (s) |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for v in &self.verdicts {
            let opt = |x: Option<f64>, d: usize| x.map_or("-".to_string(), |x| format!("{x:.d$}"));
            s.push_str(&format!(
                "| {} | {} | {} | {}/{} | {} | {} | {} | {} | {} |\n",
                v.event_id,
                v.kind,
                v.track,
                v.scored,
                v.frames,
                v.not_reported,
                v.max_score.map_or("-".to_string(), |x| format!("{x:.4}")),
                opt(v.warned_at, 2),
                opt(v.endpoint, 2),
                if v.late {
                    "late".to_string()
                } else {
                    opt(v.lead_time, 2)
                },
            ));
        }
        s
    }

    /// Counts for the summary line: (conflict events warned in time, conflicts, safe warned, safe).
    pub fn warning_counts(&self) -> (usize, usize, usize, usize) {
        let mut c = (0, 0, 0, 0);
        for v in &self.verdicts {
            if v.kind == EventKind::Safe.as_str() {
                c.3 += 1;
                if v.warned_at.is_some() {
                    c.2 += 1;
                }
            } else {
                c.1 += 1;
                if v.lead_time.is_some() {
                    c.0 += 1;
                }
            }
        }
        c
    }
}
