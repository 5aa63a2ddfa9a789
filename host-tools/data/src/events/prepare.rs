//! Sequence preparation as the method prescribes: the conflict window around the endpoint, the
//! safe-sequence rules, and cutting safe sequences out of long recordings.
use super::{Event, EventKind, EventSet, Frame};

/// The preparation rules. [`Default`] is the method's setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrepareConfig {
    /// A conflict sequence starts this long before its endpoint (s); default 4.5.
    pub before_endpoint: f64,
    /// A conflict sequence ends this long after its endpoint (s); default 0.5.
    pub after_endpoint: f64,
    /// Minimum duration of a safe sequence, last minus first frame time (s); default 2.0.
    pub safe_min_duration: f64,
    /// Maximum |longitudinal acceleration| of both vehicles in a safe sequence (m/s^2); default 1.5.
    pub safe_max_abs_acc: f32,
    /// Minimum time gap between a safe sequence cut from a long recording and any event (s);
    /// default 3.0.
    pub event_gap: f64,
    /// Longest safe sequence [`cut_safe_sequences`] produces (s); longer clean stretches are split.
    /// Default 10.
    pub safe_max_duration: f64,
}

impl Default for PrepareConfig {
    fn default() -> Self {
        Self {
            before_endpoint: 4.5,
            after_endpoint: 0.5,
            safe_min_duration: 2.0,
            safe_max_abs_acc: 1.5,
            event_gap: 3.0,
            safe_max_duration: 10.0,
        }
    }
}

const EPS: f64 = super::TIME_TOLERANCE_S;

/// A prepared sequence: what training and evaluation consume.
#[derive(Clone, Debug, PartialEq)]
pub struct Sequence {
    pub event_id: String,
    pub kind: EventKind,
    /// Frames of the sequence, strictly increasing in time.
    pub frames: Vec<Frame>,
    /// The endpoint (impact / safety-critical moment) of a conflict sequence; `None` for safe.
    /// The alert window ends here, inclusive.
    pub endpoint: Option<f64>,
}

impl Sequence {
    /// A sequence without frames yet (frames are pushed in time order).
    pub fn new(event_id: impl Into<String>, kind: EventKind, endpoint: Option<f64>) -> Self {
        Sequence {
            event_id: event_id.into(),
            kind,
            frames: Vec::new(),
            endpoint,
        }
    }

    /// The frames a warning may be raised on: up to and including the endpoint (all for safe).
    pub fn alert_frames(&self) -> &[Frame] {
        match self.endpoint {
            None => &self.frames,
            Some(t) => {
                let n = self.frames.partition_point(|f| f.time <= t + EPS);
                &self.frames[..n]
            }
        }
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The endpoint of a crash or near-crash sequence; `None` for a safe one.
    pub fn conflict_endpoint(&self) -> Option<f64> {
        self.endpoint.filter(|_| self.kind.is_conflict())
    }

    /// True for a crash or near-crash sequence with its endpoint.
    pub fn is_conflict(&self) -> bool {
        self.conflict_endpoint().is_some()
    }

    /// Last minus first frame time (s); 0 for fewer than two frames.
    pub fn duration(&self) -> f64 {
        match (self.frames.first(), self.frames.last()) {
            (Some(a), Some(b)) => b.time - a.time,
            _ => 0.0,
        }
    }
}

/// Why an event yields no sequence.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PrepareIssue {
    #[error("event `{0}`: no frame at or before the endpoint inside the conflict window")]
    NoAlertFrames(String),
    /// `why` says what cut the stretch short: the event's own length, or which vehicle's
    /// acceleration on how many frames.
    #[error("event `{id}`: longest stretch with |acc| <= {max_acc} m/s^2 lasts {duration:.2} s < {min} s ({why})")]
    SafeTooShort {
        id: String,
        duration: f64,
        max_acc: f32,
        min: f64,
        why: String,
    },
}

/// True when `frames` satisfy the safe-sequence rules: span >= `safe_min_duration` and both
/// vehicles' |longitudinal acceleration| <= `safe_max_abs_acc` on every frame.
pub fn safe_rules_hold(frames: &[Frame], cfg: &PrepareConfig) -> bool {
    let span = match (frames.first(), frames.last()) {
        (Some(a), Some(b)) => b.time - a.time,
        _ => return false,
    };
    span + EPS >= cfg.safe_min_duration && frames.iter().all(|f| calm(f, cfg))
}

fn calm(f: &Frame, cfg: &PrepareConfig) -> bool {
    f.ego.acc.abs() <= cfg.safe_max_abs_acc && f.partner.acc.abs() <= cfg.safe_max_abs_acc
}

/// Prepares one event.
///
/// - Crash / near-crash: frames in `[max(t_start, t_impact - 4.5), min(t_end, t_impact + 0.5)]`,
///   endpoint `t_impact`; rejected when no frame lies at or before the endpoint in that window.
/// - Safe: the longest run of consecutive frames on which both vehicles satisfy
///   |acc| <= 1.5 m/s^2 (the whole event when it is calm throughout), kept when it lasts >= 2 s.
pub fn prepare_event(ev: &Event, cfg: &PrepareConfig) -> Result<Sequence, PrepareIssue> {
    let (range, endpoint) = sequence_window(ev, cfg)?;
    Ok(Sequence {
        event_id: ev.id.clone(),
        kind: ev.kind,
        frames: ev.frames[range].to_vec(),
        endpoint,
    })
}

/// [`prepare_event`] for an event that is no longer needed: the sequence takes over its frames
/// instead of copying them (what a long event streamed through evaluation wants).
pub fn prepare_owned_event(mut ev: Event, cfg: &PrepareConfig) -> Result<Sequence, PrepareIssue> {
    let (range, endpoint) = sequence_window(&ev, cfg)?;
    ev.frames.truncate(range.end);
    ev.frames.drain(..range.start);
    Ok(Sequence {
        event_id: ev.id,
        kind: ev.kind,
        frames: ev.frames,
        endpoint,
    })
}

/// The frames of the event's sequence (an index range) and its endpoint, by the rules of
/// [`prepare_event`].
fn sequence_window(
    ev: &Event,
    cfg: &PrepareConfig,
) -> Result<(std::ops::Range<usize>, Option<f64>), PrepareIssue> {
    match ev.t_impact.filter(|_| ev.kind.is_conflict()) {
        Some(t) => {
            let lo = ev.t_start.max(t - cfg.before_endpoint) - EPS;
            let hi = ev.t_end.min(t + cfg.after_endpoint) + EPS;
            let a = ev.frames.partition_point(|f| f.time < lo);
            let b = ev.frames.partition_point(|f| f.time <= hi);
            let range = a..b.max(a);
            if ev.frames[range.clone()]
                .first()
                .is_none_or(|f| f.time > t + EPS)
            {
                return Err(PrepareIssue::NoAlertFrames(ev.id.clone()));
            }
            Ok((range, Some(t)))
        }
        None => {
            let (a, b) = longest_calm_run(&ev.frames, cfg);
            let duration = if b > a {
                ev.frames[b - 1].time - ev.frames[a].time
            } else {
                0.0
            };
            if duration + EPS < cfg.safe_min_duration {
                return Err(PrepareIssue::SafeTooShort {
                    id: ev.id.clone(),
                    duration,
                    max_acc: cfg.safe_max_abs_acc,
                    min: cfg.safe_min_duration,
                    why: why_not_calm(&ev.frames, cfg),
                });
            }
            Ok((a..b, None))
        }
    }
}

/// What keeps an event from a calm stretch long enough: its own length, or the frames where each
/// vehicle's |acc| is above the limit (the partner's is derived from its velocity when the folder
/// has no `acc_sur`, so noise in the velocities shows there).
fn why_not_calm(frames: &[Frame], cfg: &PrepareConfig) -> String {
    let span = match (frames.first(), frames.last()) {
        (Some(a), Some(b)) => b.time - a.time,
        _ => 0.0,
    };
    let whole = || {
        format!(
            "the event itself lasts {span:.2} s over {} frames",
            frames.len()
        )
    };
    if span + EPS < cfg.safe_min_duration {
        return whole();
    }
    // Frames not calm by the rule's own test (a NaN acceleration is not calm), and the largest.
    let over = |acc: &dyn Fn(&Frame) -> f32| {
        frames
            .iter()
            .map(|f| acc(f).abs())
            .filter(|a| a.is_nan() || *a > cfg.safe_max_abs_acc)
            .fold((0usize, 0.0f32), |(n, max), a| (n + 1, max.max(a)))
    };
    let (ego, ego_max) = over(&|f| f.ego.acc);
    let (partner, partner_max) = over(&|f| f.partner.acc);
    let vehicle = |name: &str, n: usize, max: f32| {
        (n > 0).then(|| {
            format!(
                "{n} of {} frames for the {name} (up to {max:.2} m/s^2)",
                frames.len()
            )
        })
    };
    let parts: Vec<String> = [
        vehicle("ego", ego, ego_max),
        vehicle("partner", partner, partner_max),
    ]
    .into_iter()
    .flatten()
    .collect();
    if parts.is_empty() {
        return whole();
    }
    let source = if partner > 0 {
        "; the partner's is acc_sur, or derived from its velocity when frames.csv has no acc_sur"
    } else {
        ""
    };
    format!("|acc| above the limit on {}{source}", parts.join(" and "))
}

/// Half-open index range of the longest run of calm frames (first one on ties).
fn longest_calm_run(frames: &[Frame], cfg: &PrepareConfig) -> (usize, usize) {
    let (mut best, mut start) = ((0, 0), None);
    for (i, f) in frames.iter().enumerate() {
        match (calm(f, cfg), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                if frames[i - 1].time - frames[s].time > span(frames, best) {
                    best = (s, i);
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        let n = frames.len();
        if frames[n - 1].time - frames[s].time > span(frames, best) {
            best = (s, n);
        }
    }
    best
}

fn span(frames: &[Frame], (a, b): (usize, usize)) -> f64 {
    if b > a {
        frames[b - 1].time - frames[a].time
    } else {
        -1.0
    }
}

/// Prepares every event of `set`; returns the sequences (in event order) and one issue per
/// event that yields none.
pub fn prepare_sequences(
    set: &EventSet,
    cfg: &PrepareConfig,
) -> (Vec<Sequence>, Vec<PrepareIssue>) {
    let mut seqs = Vec::with_capacity(set.len());
    let mut issues = Vec::new();
    for ev in set {
        match prepare_event(ev, cfg) {
            Ok(s) => seqs.push(s),
            Err(e) => issues.push(e),
        }
    }
    (seqs, issues)
}

/// Cuts safe sequences out of a long recording (e.g. a naturalistic-driving trip with the same
/// ego/partner pair), for users whose safe data is not already event-shaped.
///
/// `events` are the `(start, end)` intervals of every crash/near-crash/other event on the
/// recording's clock. Frames closer than `event_gap` (3 s) to any interval are excluded, as are
/// frames where either vehicle's |acc| exceeds `safe_max_abs_acc`; each remaining run of
/// consecutive frames is split into pieces of at most `safe_max_duration` and every piece lasting
/// at least `safe_min_duration` becomes a sequence with id `"{recording_id}#{n}"` (n from 0).
pub fn cut_safe_sequences(
    recording_id: &str,
    frames: &[Frame],
    events: &[(f64, f64)],
    cfg: &PrepareConfig,
) -> Vec<Sequence> {
    let usable = |f: &Frame| {
        calm(f, cfg)
            && events
                .iter()
                .all(|&(a, b)| f.time < a - cfg.event_gap - EPS || f.time > b + cfg.event_gap + EPS)
    };
    let mut out = Vec::new();
    let mut run: Vec<Frame> = Vec::new();
    let flush = |run: &mut Vec<Frame>, out: &mut Vec<Sequence>| {
        let mut piece: Vec<Frame> = Vec::new();
        for f in run.drain(..) {
            if piece
                .first()
                .is_some_and(|p| f.time - p.time > cfg.safe_max_duration + EPS)
            {
                emit(recording_id, std::mem::take(&mut piece), cfg, out);
            }
            piece.push(f);
        }
        emit(recording_id, piece, cfg, out);
    };
    for f in frames {
        if usable(f) {
            run.push(*f);
        } else {
            flush(&mut run, &mut out);
        }
    }
    flush(&mut run, &mut out);
    out
}

fn emit(recording_id: &str, piece: Vec<Frame>, cfg: &PrepareConfig, out: &mut Vec<Sequence>) {
    if safe_rules_hold(&piece, cfg) {
        out.push(Sequence {
            event_id: format!("{recording_id}#{}", out.len()),
            kind: EventKind::Safe,
            frames: piece,
            endpoint: None,
        });
    }
}
