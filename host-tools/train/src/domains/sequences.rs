//! Per-sequence results of the domain benchmark (`riskctl benchmark domains --sequences-out`):
//! one row per round, seed, fold, method and test sequence, with the sequence maximum the metrics
//! rank, the method's 90 %-recall threshold of that run, and what the scorer saw at the peak frame
//! (the guard's verdict and its two parts, the surrogates, the speeds).
//!
//! Nothing here scores anew: the maximum and its frame are read off the run's scored sequences
//! ([`AlertProfile`], the metrics' own summary), the threshold is the one the real-safe share uses
//! ([`ShareRun::threshold`]), and the peak frame's guard parts come from scorer-core on the run's
//! own blobs ([`ModelBlob::score_guarded`], [`Model::score_observation`],
//! [`KinematicFallback::score`](scorer_core::model::kinematic_fallback::KinematicFallback::score)).
use std::io::{self, Write};

use super::rounds::RoundSplit;
use super::share::ShareRun;
use super::slice::Domain;
use riskscore_data::events::{EventKind, Sequence};
use riskscore_eval::protocol::{AlertProfile, ScoredSequence};
use riskscore_eval::MethodRun;
use scorer_core::model::{decode_blob, ModelBlob};
use scorer_core::{Model, Observation, Surrogates};

/// The columns of the table, in order.
pub const COLUMNS: [&str; 21] = [
    "round",
    "seed",
    "fold",
    "method",
    "event_id",
    "class",
    "source",
    "speed_band",
    "geometry",
    "max",
    "peak_time",
    "t90",
    "above_t90",
    "in_domain",
    "network",
    "fallback",
    "ttc2d",
    "tadv",
    "ei",
    "v_ego",
    "v_partner",
];

/// What a guarded model's blob says at one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuardParts {
    /// Every bounded input inside the blob's training domain.
    pub in_domain: bool,
    /// The model's own score, unguarded ([`Model::score_observation`]).
    pub network: f32,
    /// The blob's kinematic fallback on the frame's surrogates; `None` without a fallback record.
    pub fallback: Option<f32>,
}

/// The frame where a sequence's running maximum reached its maximum (the first such frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    /// Event clock time (s).
    pub time: f64,
    /// `None` for a method without a training-domain record (unguarded models, the baselines).
    pub guard: Option<GuardParts>,
    pub surrogates: Surrogates,
    /// Speeds `|(vx, vy)|` (m/s).
    pub v_ego: f32,
    pub v_partner: f32,
}

/// One method on one test sequence of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct SequenceRow {
    pub seed: u64,
    pub fold: usize,
    pub method: String,
    pub event_id: String,
    pub kind: EventKind,
    pub domain: Domain,
    /// The sequence maximum over its alert window, as the metrics rank it; `None` when no frame
    /// of the window has a score.
    pub max: Option<f32>,
    /// The method's 90 %-recall threshold in this run ([`ShareRun::threshold`]).
    pub t90: Option<f32>,
    /// `max >= t90`: the sequence is warned at that threshold.
    pub above_t90: bool,
    /// `None` when the sequence has no maximum.
    pub peak: Option<Peak>,
}

/// Where the rows of each run go, in round, seed and fold order.
pub trait SequenceSink: Send {
    fn write(&mut self, round: &str, rows: &[SequenceRow]) -> io::Result<()>;
}

/// The rows of one run: every method of `runs` (with its real-safe share run in `shares`, the
/// same order) on every test sequence of `split`, in method then test order. `blobs` are the
/// run's model blobs by row name; a method without one (a baseline) has no guard parts.
pub fn rows_of(
    split: &RoundSplit,
    runs: &[MethodRun],
    shares: &[ShareRun],
    blobs: &[(String, Vec<u8>)],
) -> Vec<SequenceRow> {
    let mut rows = Vec::with_capacity(runs.len() * split.test.len());
    for (run, share) in runs.iter().zip(shares) {
        debug_assert_eq!(run.name, share.method);
        // A blob that does not decode cannot have been scored: the run would have failed.
        let blob = blobs
            .iter()
            .find(|(name, _)| *name == run.name)
            .and_then(|(_, bytes)| decode_blob(bytes).ok());
        for ((sequence, domain), scored) in
            split.test.iter().zip(&split.test_domains).zip(&run.scored)
        {
            rows.push(row_of(sequence, domain, scored, share, blob.as_ref()));
        }
    }
    rows
}

fn row_of(
    sequence: &Sequence,
    domain: &Domain,
    scored: &ScoredSequence,
    share: &ShareRun,
    blob: Option<&ModelBlob<'_>>,
) -> SequenceRow {
    debug_assert_eq!(sequence.event_id, scored.event_id, "test order");
    // The profile of a scored sequence the run already evaluated: it cannot fail.
    let last = AlertProfile::from_sequence(scored)
        .ok()
        .and_then(|p| p.records.last().copied());
    let max = last.map(|r| r.level);
    let peak = last.and_then(|r| {
        // Scored frames are the sequence's frames, one for one.
        let k = scored.frames.iter().position(|f| f.time == r.time)?;
        let frame = sequence.frames.get(k)?;
        let observation = Observation::of(&frame.ego, &frame.partner);
        Some(Peak {
            time: r.time,
            guard: blob.and_then(|b| guard_parts(b, &observation, r.level)),
            surrogates: observation.surrogates,
            v_ego: frame.ego.vx.hypot(frame.ego.vy),
            v_partner: frame.partner.vx.hypot(frame.partner.vy),
        })
    });
    SequenceRow {
        seed: share.seed,
        fold: share.fold,
        method: share.method.clone(),
        event_id: sequence.event_id.clone(),
        kind: sequence.kind,
        domain: domain.clone(),
        max,
        t90: share.threshold,
        above_t90: matches!((max, share.threshold), (Some(m), Some(t)) if m >= t),
        peak,
    }
}

/// The guard's verdict and parts at one observation, for a blob with a training domain. `score`
/// is what the run scored there (checked in debug builds: the same bits).
fn guard_parts(blob: &ModelBlob<'_>, observation: &Observation, score: f32) -> Option<GuardParts> {
    blob.meta.training_domain.as_ref()?;
    let guarded = blob.score_guarded(observation);
    debug_assert_eq!(guarded.score.to_bits(), score.to_bits(), "peak rescored");
    let model: &Model<'_> = &blob.model;
    Some(GuardParts {
        in_domain: guarded.in_domain,
        network: model.score_observation(observation),
        fallback: blob
            .meta
            .kinematic_fallback
            .as_ref()
            .map(|f| f.score(&observation.surrogates)),
    })
}

/// The rows as CSV ([`COLUMNS`]): numbers as Rust's `Display` writes them (`inf` for a surrogate
/// without conflict), booleans 1/0, an absent value empty.
pub struct SequencesCsv<W: Write> {
    out: csv::Writer<W>,
    rows: usize,
}

fn cell<T: ToString>(v: Option<T>) -> String {
    v.map_or_else(String::new, |v| v.to_string())
}

fn flag(b: bool) -> &'static str {
    if b {
        "1"
    } else {
        "0"
    }
}

impl<W: Write> SequencesCsv<W> {
    /// Writes the header.
    pub fn new(out: W) -> io::Result<Self> {
        let mut out = csv::Writer::from_writer(out);
        out.write_record(COLUMNS)?;
        Ok(Self { out, rows: 0 })
    }

    /// Rows written so far (the header not counted).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Flushes and hands back the output.
    pub fn finish(self) -> io::Result<W> {
        self.out
            .into_inner()
            .map_err(|e| io::Error::new(e.error().kind(), e.error().to_string()))
    }

    fn record(&mut self, round: &str, r: &SequenceRow) -> io::Result<()> {
        let peak = r.peak.as_ref();
        let guard = peak.and_then(|p| p.guard);
        let s = peak.map(|p| p.surrogates);
        self.out.write_record([
            round,
            &r.seed.to_string(),
            &r.fold.to_string(),
            &r.method,
            &r.event_id,
            r.kind.as_str(),
            &r.domain.source.label(),
            &cell(r.domain.band.map(|b| b.label())),
            r.domain.geometry.map_or("", |g| g.as_str()),
            &cell(r.max),
            &cell(peak.map(|p| p.time)),
            &cell(r.t90),
            flag(r.above_t90),
            guard.map_or("", |g| flag(g.in_domain)),
            &cell(guard.map(|g| g.network)),
            &cell(guard.and_then(|g| g.fallback)),
            &cell(s.map(|s| s.ttc2d)),
            &cell(s.map(|s| s.tadv)),
            &cell(s.map(|s| s.ei)),
            &cell(peak.map(|p| p.v_ego)),
            &cell(peak.map(|p| p.v_partner)),
        ])?;
        self.rows += 1;
        Ok(())
    }
}

impl<W: Write + Send> SequenceSink for SequencesCsv<W> {
    fn write(&mut self, round: &str, rows: &[SequenceRow]) -> io::Result<()> {
        rows.iter().try_for_each(|r| self.record(round, r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domains::share::share_of;
    use crate::domains::slice::{domain_of, SpeedBand};
    use crate::domains::source::Source;
    use riskscore_data::events::Frame;
    use riskscore_eval::protocol::Baseline;
    use riskscore_eval::{evaluate_methods, observe, Method};
    use scorer_core::VehicleState;

    fn car(x: f32, vx: f32) -> VehicleState {
        VehicleState {
            x,
            vx,
            hx: 1.0,
            length: 4.5,
            width: 1.8,
            ..Default::default()
        }
    }

    /// The ego at 10 m/s closing on a partner at `partner_v`, `gap` m ahead at t = 0.
    fn seq(id: &str, kind: EventKind, partner_v: f32, gap: f32) -> Sequence {
        let endpoint = kind.is_conflict().then_some(1.0);
        let mut s = Sequence::new(id, kind, endpoint);
        for i in 0..15 {
            let t = i as f64 * 0.1;
            let x = 10.0 * t as f32;
            s.frames.push(Frame {
                time: t,
                ego: car(x, 10.0),
                partner: car(4.5 + gap + partner_v * t as f32, partner_v),
            });
        }
        s
    }

    #[test]
    fn rows_read_the_maximum_its_frame_and_the_threshold_of_each_method() {
        let test = vec![
            seq("c1", EventKind::Crash, 2.0, 8.0),
            seq("c2", EventKind::NearCrash, 6.0, 12.0),
            seq("s1", EventKind::Safe, 10.0, 20.0),
        ];
        let split = RoundSplit {
            train: Vec::new(),
            test_domains: test.iter().map(|s| domain_of(s, Source::Sim)).collect(),
            test: test.clone(),
            real_from: 3,
        };
        let (_, runs) = evaluate_methods(&observe(&test), &Method::baselines()).unwrap();
        let shares: Vec<ShareRun> = runs.iter().map(|r| share_of(r, 0..3, 7, 1)).collect();
        let rows = rows_of(&split, &runs, &shares, &[]);
        assert_eq!(rows.len(), 9);
        for ((baseline, run), share) in Baseline::ALL.into_iter().zip(&runs).zip(&shares) {
            let mine: Vec<&SequenceRow> = rows.iter().filter(|r| r.method == run.name).collect();
            assert_eq!(mine.len(), 3);
            for (row, scored) in mine.iter().zip(&run.scored) {
                let window: Vec<_> = scored
                    .frames
                    .iter()
                    .filter(|f| f.time <= scored.endpoint.unwrap_or(f64::MAX) + 1e-3)
                    .collect();
                let max = window.iter().map(|f| f.score).fold(f32::MIN, f32::max);
                assert_eq!(row.max, Some(max), "{}", row.event_id);
                let peak = row.peak.unwrap();
                let first = window.iter().find(|f| f.score == max).unwrap();
                assert_eq!(peak.time, first.time);
                // The baseline's score at the peak frame is its surrogate there.
                assert_eq!(baseline.risk(&peak.surrogates), max);
                assert_eq!((peak.v_ego, peak.guard), (10.0, None));
                assert_eq!((row.seed, row.fold), (7, 1));
                assert_eq!(row.domain.band, Some(SpeedBand::Urban));
                assert_eq!(row.t90, share.threshold);
                assert_eq!(
                    row.above_t90,
                    share.threshold.is_some_and(|t| max >= t),
                    "{}",
                    row.event_id
                );
            }
        }
        let ttc: Vec<&SequenceRow> = rows.iter().filter(|r| r.method == "TTC2D").collect();
        assert!(ttc[0].peak.unwrap().surrogates.ttc2d.is_finite());
        // The safe sequence never closes in: no conflict, the baselines' floor.
        assert_eq!(ttc[2].peak.unwrap().surrogates.ttc2d, f32::INFINITY);
        let mut csv = SequencesCsv::new(Vec::new()).unwrap();
        csv.write("speed-5-15", &rows).unwrap();
        let text = String::from_utf8(csv.finish().unwrap()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], COLUMNS.join(","));
        assert_eq!(lines.len(), 10);
        let safe = lines[3].split(',').collect::<Vec<_>>();
        assert_eq!(
            safe[..9],
            [
                "speed-5-15",
                "7",
                "1",
                "TTC2D",
                "s1",
                "safe",
                "sim",
                "5-15",
                "following"
            ]
        );
        // No guard: in_domain, network and fallback empty; TTC2D without conflict is `inf`.
        assert_eq!(safe[13..17], ["", "", "", "inf"]);
    }
}
