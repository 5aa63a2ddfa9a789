//! `can-bridge check`: score a candump log made by `riskctl events-to-candump` and compare the
//! bridge with the offline evaluation.
//!
//! How exact agreement with `riskctl evaluate` is achieved: the bridge scores the states it
//! *decoded* from the CAN frames (DBC resolution: 1 mm, 1 mm/s, 0.4 mrad), which are not bit-equal
//! to the event tables' floats. So `check` evaluates the bridge on its decoded states: it traces
//! every scored track update back to its event frame (the exporter's [`Layout`]), rebuilds the
//! event set as the bridge saw it (same event metadata, frames = decoded ego/partner states),
//! prepares sequences from it with host-tools' own preparation, and computes the metrics with
//! host-tools' own evaluation from the bridge's scores. `--decoded-events-out DIR` writes that event
//! set as an event folder (with an `acc_sur` column); `riskctl evaluate --events DIR` on it
//! recomputes the scores from the same states through the same `scorer-core` calls, so the table
//! and JSON are identical, number for number.
use crate::engine::{Engine, Output};
use crate::logfile::{for_each_frame, LogReport};
use host_tools::candump_export::{ExportOptions, Layout};
use host_tools::eval::scoring::evaluate_scored;
use host_tools::eval::{EvaluationReport, ScoredFrame, ScoredSequence};
use host_tools::events::{
    prepare_sequences, Event, EventKind, EventSet, Frame as EventFrame, PrepareConfig,
};
use std::collections::HashMap;
use std::io::Write;
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
    pub stats: crate::engine::Stats,
}

/// Errors of `check`.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error("reading the log: {0}")]
    Io(#[from] std::io::Error),
    #[error("the log has no frames")]
    EmptyLog,
    #[error("evaluation: {0}")]
    Protocol(#[from] host_tools::eval::ProtocolError),
}

fn first_timestamp(log: &Path) -> Result<Option<u64>, std::io::Error> {
    use std::io::BufRead;
    let reader = std::io::BufReader::new(std::fs::File::open(log)?);
    for line in reader.lines() {
        if let Ok(rec) = can_codec::parse_line(&line?) {
            return Ok(Some(rec.timestamp_us));
        }
    }
    Ok(None)
}

/// Runs the bridge over `log` and evaluates it against `set`. `gap_us` must be the exporter's
/// pause between events; the timeline starts at the log's first frame. `row_name` is the
/// model's row in the table (`host_tools::eval::scoring::model_row_name`, as `riskctl evaluate`).
pub fn check(
    log: &Path,
    set: &EventSet,
    engine: &mut Engine<'_>,
    row_name: &str,
    gap_us: u64,
) -> Result<CheckReport, CheckError> {
    let start_us = first_timestamp(log)?.ok_or(CheckError::EmptyLog)?;
    let layout = Layout::new(
        set,
        &ExportOptions {
            iface: String::new(),
            start_us,
            gap_us,
        },
    );
    let index = layout.trigger_index();
    // Per event: decoded frames with the bridge's score, first onset time.
    let mut decoded: Vec<Vec<(EventFrame, f32)>> = vec![Vec::new(); set.events.len()];
    let mut onset: Vec<Option<f64>> = vec![None; set.events.len()];
    let mut untraced = 0usize;
    let log_report = for_each_frame(log, |_, rec| {
        engine.process(rec.timestamp_us, &rec.frame, &mut |o| match o {
            Output::Scored(obs) => match index.get(&(obs.track, obs.t_us)) {
                Some(&(k, i)) => {
                    let time = set.events[k].frames[i].time;
                    decoded[k].push((
                        EventFrame {
                            time,
                            ego: obs.ego,
                            sur: obs.partner,
                        },
                        obs.score,
                    ));
                }
                None => untraced += 1,
            },
            Output::WarningOn { t_us, track, .. } => {
                if let Some(&(k, i)) = index.get(&(track, t_us)) {
                    onset[k].get_or_insert(set.events[k].frames[i].time);
                }
            }
            _ => {}
        });
    })?;

    let mut verdicts = Vec::with_capacity(set.events.len());
    let mut decoded_events = Vec::new();
    let mut scores: HashMap<String, HashMap<u64, f32>> = HashMap::new();
    for (k, ev) in set.events.iter().enumerate() {
        let frames = &decoded[k];
        let max_score = frames.iter().map(|(_, s)| *s).reduce(f32::max);
        let endpoint = ev.t_impact;
        let warned_at = onset[k];
        let (lead_time, late) = match (warned_at, endpoint) {
            (Some(w), Some(e)) if w <= e + host_tools::eval::protocol::ENDPOINT_TOLERANCE_S => {
                (Some(host_tools::eval::protocol::lead_time(e, w)), false)
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
            max_score,
            endpoint,
            warned_at,
            lead_time,
            late,
        });
        if let Some((first, _)) = frames.first() {
            let dims = host_tools::events::Dims {
                length_ego: first.ego.length,
                width_ego: first.ego.width,
                length_sur: first.sur.length,
                width_sur: first.sur.width,
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
            class: s.kind.into(),
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
        stats: *engine.stats(),
    })
}

/// Writes an event set as an event folder, with the partner acceleration in an `acc_sur` column so
/// the loader uses exactly the value the bridge scored with. Floats are written in Rust's shortest
/// round-trip form, so reading the folder back gives bit-identical states.
pub fn write_decoded_events(dir: &Path, set: &EventSet) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut ev_out = std::io::BufWriter::new(std::fs::File::create(dir.join("events.csv"))?);
    writeln!(ev_out, "{}", host_tools::events::EVENT_COLUMNS.join(","))?;
    for e in &set.events {
        let d = &e.dims;
        writeln!(
            ev_out,
            "{},{},{},{},{},{},{},{},{}",
            e.id,
            e.kind.as_str(),
            e.t_start,
            e.t_end,
            e.t_impact.map(|t| t.to_string()).unwrap_or_default(),
            d.length_ego,
            d.width_ego,
            d.length_sur,
            d.width_sur
        )?;
    }
    ev_out.flush()?;
    let mut fr_out = std::io::BufWriter::new(std::fs::File::create(dir.join("frames.csv"))?);
    writeln!(
        fr_out,
        "{},acc_sur",
        host_tools::events::FRAME_COLUMNS.join(",")
    )?;
    for e in &set.events {
        for f in &e.frames {
            let (a, b) = (&f.ego, &f.sur);
            writeln!(
                fr_out,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                e.id,
                f.time,
                a.x,
                a.y,
                a.vx,
                a.vy,
                a.hx,
                a.hy,
                a.acc,
                b.x,
                b.y,
                b.vx,
                b.vy,
                b.hx,
                b.hy,
                b.acc
            )?;
        }
    }
    fr_out.flush()
}

impl CheckReport {
    /// The per-event table (Markdown).
    pub fn verdict_table(&self) -> String {
        let mut s = String::from(
            "| Event | Kind | Track | Scored/frames | Max score | Warned at (s) | Endpoint (s) | Lead time (s) |\n|---|---|---:|---:|---:|---:|---:|---:|\n",
        );
        for v in &self.verdicts {
            let opt = |x: Option<f64>, d: usize| x.map_or("-".to_string(), |x| format!("{x:.d$}"));
            s.push_str(&format!(
                "| {} | {} | {} | {}/{} | {} | {} | {} | {} |\n",
                v.event_id,
                v.kind,
                v.track,
                v.scored,
                v.frames,
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
