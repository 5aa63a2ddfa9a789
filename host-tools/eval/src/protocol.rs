//! The proactive-warning protocol: which frames count, when a sequence is warned, and its lead time.
//!
//! A sequence is scored frame by frame. Its *alert window* is every frame up to and including its
//! endpoint (impact or safety-critical moment) for conflict sequences, and every frame for safe ones.
//! At threshold `T` a sequence is warned at the first frame of the window with `R >= T`
//! ([`scorer_core::warning::FirstThreshold`], the rule the ECU runs). Because a warning at `T` happens
//! exactly when the running maximum of `R` first reaches `T`, a sequence is summarised without loss by
//! the frames where its running maximum rises ([`AlertProfile`]): that summary answers "warned? when?"
//! for every threshold at once, and is what the metrics consume.
use scorer_core::warning::FirstThreshold;
use serde::{Deserialize, Serialize};

pub use riskscore_data::events::EventKind;

/// Frames whose time exceeds the endpoint by at most this much still belong to the alert window.
pub use riskscore_data::events::TIME_TOLERANCE_S;

/// One sequence scored by one method, frame by frame, in time order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScoredSequence {
    pub event_id: String,
    #[serde(rename = "class")]
    pub kind: EventKind,
    /// The end of the alert window (inclusive): `t_impact` for conflict sequences. `None` for safe
    /// sequences, whose window is every frame (an endpoint given for a safe sequence is honoured).
    pub endpoint: Option<f64>,
    pub frames: Vec<ScoredFrame>,
}

/// One scored frame: its time (s, the event table's clock) and the method's risk `R`.
///
/// A NaN score means "no score at this frame": it can never reach a threshold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScoredFrame {
    pub time: f64,
    pub score: f32,
}

/// Bad input to the protocol. Each names the event.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProtocolError {
    #[error("event {event_id}: a {kind} sequence needs an endpoint (t_impact)")]
    MissingEndpoint {
        event_id: String,
        kind: &'static str,
    },
    #[error("event {event_id}: endpoint {endpoint} is not finite")]
    NonFiniteEndpoint { event_id: String, endpoint: f64 },
    #[error("event {event_id}: frame {index} has non-finite time {time}")]
    NonFiniteTime {
        event_id: String,
        index: usize,
        time: f64,
    },
    #[error("event {event_id}: frame {index} at t={time} s is not after the previous frame (t={previous} s)")]
    UnsortedTime {
        event_id: String,
        index: usize,
        time: f64,
        previous: f64,
    },
}

/// A point where the running maximum of `R` rises inside the alert window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunningMaxRecord {
    /// Frame time (s).
    pub time: f64,
    /// `R` at that frame, greater than every earlier score of the window.
    pub level: f32,
}

/// Everything the metrics need from one sequence: its kind, endpoint and running-maximum records.
///
/// For any threshold `T`, the sequence is warned at the time of the first record with
/// `level >= T`, and not at all when `T` exceeds the last (largest) level. This is the per-sequence
/// alert data the CAN bridge can build from its own per-frame scores ([`AlertProfileBuilder`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlertProfile {
    pub event_id: String,
    #[serde(rename = "class")]
    pub kind: EventKind,
    pub endpoint: Option<f64>,
    /// Strictly increasing in time and in level.
    pub records: Vec<RunningMaxRecord>,
}

impl AlertProfile {
    /// Summarise a scored sequence (frames after the endpoint are ignored).
    pub fn from_sequence(sequence: &ScoredSequence) -> Result<Self, ProtocolError> {
        let mut builder =
            AlertProfileBuilder::new(&sequence.event_id, sequence.kind, sequence.endpoint)?;
        for frame in &sequence.frames {
            builder.push(frame.time, frame.score)?;
        }
        Ok(builder.finish())
    }

    /// The sequence maximum of `R` over the alert window; `None` when no frame has a score.
    pub fn max(&self) -> Option<f32> {
        self.records.last().map(|r| r.level)
    }

    /// When the sequence is first warned at `threshold`, if at all.
    pub fn alert_time(&self, threshold: f32) -> Option<f64> {
        self.records
            .iter()
            .find(|r| r.level >= threshold)
            .map(|r| r.time)
    }

    /// Lead time (s) of the warning at `threshold`: `endpoint - alert time`, for conflict sequences
    /// that are warned. Never negative (an alert inside the endpoint tolerance counts as 0 s).
    pub fn lead_time(&self, threshold: f32) -> Option<f64> {
        let endpoint = self.endpoint?;
        if !self.kind.is_conflict() {
            return None;
        }
        self.alert_time(threshold).map(|t| lead_time(endpoint, t))
    }
}

/// `endpoint - alert_time`, clamped at zero (see [`TIME_TOLERANCE_S`]).
pub fn lead_time(endpoint: f64, alert_time: f64) -> f64 {
    (endpoint - alert_time).max(0.0)
}

/// Builds an [`AlertProfile`] from frames pushed one at a time (streaming, e.g. from a CAN log).
#[derive(Clone, Debug)]
pub struct AlertProfileBuilder {
    profile: AlertProfile,
    frames_seen: usize,
    last_time: Option<f64>,
}

impl AlertProfileBuilder {
    /// Conflict sequences need a finite endpoint; safe ones may have none.
    pub fn new(
        event_id: &str,
        kind: EventKind,
        endpoint: Option<f64>,
    ) -> Result<Self, ProtocolError> {
        match endpoint {
            None if kind.is_conflict() => {
                return Err(ProtocolError::MissingEndpoint {
                    event_id: event_id.to_owned(),
                    kind: kind.as_str(),
                })
            }
            Some(e) if !e.is_finite() => {
                return Err(ProtocolError::NonFiniteEndpoint {
                    event_id: event_id.to_owned(),
                    endpoint: e,
                })
            }
            _ => {}
        }
        Ok(Self {
            profile: AlertProfile {
                event_id: event_id.to_owned(),
                kind,
                endpoint,
                records: Vec::new(),
            },
            frames_seen: 0,
            last_time: None,
        })
    }

    /// Add the next frame. Times must be finite and strictly increasing; frames after the endpoint
    /// are checked for order and otherwise ignored.
    pub fn push(&mut self, time: f64, score: f32) -> Result<(), ProtocolError> {
        let index = self.frames_seen;
        self.frames_seen += 1;
        if !time.is_finite() {
            return Err(ProtocolError::NonFiniteTime {
                event_id: self.profile.event_id.clone(),
                index,
                time,
            });
        }
        if let Some(previous) = self.last_time {
            if time <= previous {
                return Err(ProtocolError::UnsortedTime {
                    event_id: self.profile.event_id.clone(),
                    index,
                    time,
                    previous,
                });
            }
        }
        self.last_time = Some(time);
        if !in_alert_window(self.profile.endpoint, time) {
            return Ok(());
        }
        // NaN never compares greater, so it never becomes a record.
        let rises = match self.profile.records.last() {
            None => !score.is_nan(),
            Some(r) => score > r.level,
        };
        if rises {
            self.profile
                .records
                .push(RunningMaxRecord { time, level: score });
        }
        Ok(())
    }

    pub fn finish(self) -> AlertProfile {
        self.profile
    }
}

/// True when a frame at `time` is inside the alert window ending at `endpoint` (inclusive).
pub fn in_alert_window(endpoint: Option<f64>, time: f64) -> bool {
    endpoint.is_none_or(|e| time <= e + TIME_TOLERANCE_S)
}

/// The first frame of the alert window at which the sequence is warned at `threshold`, by the
/// core's first-threshold rule applied frame by frame (the reference for [`AlertProfile`]).
pub fn first_alert(sequence: &ScoredSequence, threshold: f32) -> Option<f64> {
    let window: Vec<&ScoredFrame> = sequence
        .frames
        .iter()
        .take_while(|f| in_alert_window(sequence.endpoint, f.time))
        .collect();
    let mut rule = FirstThreshold::new(threshold);
    for f in &window {
        if rule.update(f.score) {
            break;
        }
    }
    let index = usize::try_from(rule.first_warning()?).ok()?;
    window.get(index).map(|f| f.time)
}

/// Whether and when one sequence is warned at one threshold, with the lead time for conflicts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    pub event_id: String,
    #[serde(rename = "class")]
    pub kind: EventKind,
    pub alert_time: Option<f64>,
    pub lead_time: Option<f64>,
}

/// Per-sequence decisions at one threshold (what an ECU configured with `threshold` would do).
pub fn decisions(sequences: &[ScoredSequence], threshold: f32) -> Vec<Decision> {
    sequences
        .iter()
        .map(|s| {
            let alert_time = first_alert(s, threshold);
            let lead = match (s.kind.is_conflict(), s.endpoint, alert_time) {
                (true, Some(e), Some(t)) => Some(lead_time(e, t)),
                _ => None,
            };
            Decision {
                event_id: s.event_id.clone(),
                kind: s.kind,
                alert_time,
                lead_time: lead,
            }
        })
        .collect()
}

/// Summarise every sequence of one method.
pub fn alert_profiles(sequences: &[ScoredSequence]) -> Result<Vec<AlertProfile>, ProtocolError> {
    sequences.iter().map(AlertProfile::from_sequence).collect()
}

/// Score used for "no conflict" surrogate values (TTC2D/TAdv = +inf, EI = -inf): the least risky
/// finite score. Finite so that every sequence has a maximum and ties among conflict-free sequences
/// are ordinary ties at the lowest threshold.
pub const NO_CONFLICT_RISK: f32 = -1e9;

/// The surrogate baselines, scored in their risk direction (larger `R` = riskier).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Baseline {
    /// `R = -TTC2D` (smaller time to collision is riskier).
    Ttc2d,
    /// `R = -TAdv` (smaller time advantage is riskier).
    Tadv,
    /// `R = EI` (larger evasion intensity is riskier).
    Ei,
    /// `R = -TAdv-corridor` (TAdv under the corridor rule; not a published measure, reported
    /// where a model reads it: [`Baseline::read_by`]).
    TadvCorridor,
}

impl Baseline {
    /// The published baselines every report carries and DRL must beat, in table order.
    pub const ALL: [Baseline; 3] = [Baseline::Ttc2d, Baseline::Tadv, Baseline::Ei];

    /// The core surrogate the baseline reads.
    pub const fn surrogate(self) -> scorer_core::SurrogateKind {
        match self {
            Baseline::Ttc2d => scorer_core::SurrogateKind::Ttc2d,
            Baseline::Tadv => scorer_core::SurrogateKind::Tadv,
            Baseline::Ei => scorer_core::SurrogateKind::Ei,
            Baseline::TadvCorridor => scorer_core::SurrogateKind::TadvCorridor,
        }
    }

    /// The baseline of a kinematic surrogate; `None` for GSSM (a model, not a measure).
    pub const fn of_surrogate(kind: scorer_core::SurrogateKind) -> Option<Baseline> {
        match kind {
            scorer_core::SurrogateKind::Ttc2d => Some(Baseline::Ttc2d),
            scorer_core::SurrogateKind::Tadv => Some(Baseline::Tadv),
            scorer_core::SurrogateKind::Ei => Some(Baseline::Ei),
            scorer_core::SurrogateKind::TadvCorridor => Some(Baseline::TadvCorridor),
            scorer_core::SurrogateKind::Gssm => None,
        }
    }

    /// Every baseline: [`Baseline::ALL`] and those reported only where a model reads them.
    pub const EVERY: [Baseline; 4] = [
        Baseline::Ttc2d,
        Baseline::Tadv,
        Baseline::Ei,
        Baseline::TadvCorridor,
    ];

    /// The baseline whose row is named `name` (exactly, as reports name it).
    pub fn named(name: &str) -> Option<Baseline> {
        Baseline::EVERY.into_iter().find(|b| b.name() == name)
    }

    /// [`Baseline::ALL`], then the baseline of every other kinematic surrogate in `read` (the
    /// surrogates the report's models read), once each, in order: a model is reported next to
    /// each of its inputs.
    pub fn read_by(read: impl IntoIterator<Item = scorer_core::SurrogateKind>) -> Vec<Baseline> {
        let mut all = Baseline::ALL.to_vec();
        for b in read.into_iter().filter_map(Baseline::of_surrogate) {
            if !all.contains(&b) {
                all.push(b);
            }
        }
        all
    }

    /// Row name in tables and JSON (the surrogate's own name).
    pub const fn name(self) -> &'static str {
        self.surrogate().name()
    }

    /// The baseline's risk for one pair, from the core's surrogates, in the surrogate's risk
    /// direction.
    pub fn risk(self, s: &scorer_core::Surrogates) -> f32 {
        let kind = self.surrogate();
        let value = kind.value_in(s);
        if kind.larger_is_riskier() {
            intensity_surrogate_risk(value)
        } else {
            time_surrogate_risk(value)
        }
    }
}

/// `R = -value` for a time-type surrogate; `+inf` (no conflict) and anything less risky than
/// [`NO_CONFLICT_RISK`] map to it; NaN stays NaN (no score).
pub fn time_surrogate_risk(value: f32) -> f32 {
    if value.is_nan() {
        return f32::NAN;
    }
    (-value).max(NO_CONFLICT_RISK)
}

/// `R = value` for an intensity-type surrogate; `-inf` (no conflict) maps to [`NO_CONFLICT_RISK`].
pub fn intensity_surrogate_risk(value: f32) -> f32 {
    if value.is_nan() {
        return f32::NAN;
    }
    value.max(NO_CONFLICT_RISK)
}

/// An alert profile of `kind` with these running-maximum `records` `(time, level)` (unit tests of
/// the modules that read profiles).
#[cfg(test)]
pub(crate) fn test_profile(
    kind: EventKind,
    endpoint: Option<f64>,
    records: &[(f64, f32)],
) -> AlertProfile {
    AlertProfile {
        event_id: String::new(),
        kind,
        endpoint,
        records: records
            .iter()
            .map(|&(time, level)| RunningMaxRecord { time, level })
            .collect(),
    }
}

/// A scored sequence with frames at 0, 1, 2, ... s carrying `scores` (unit tests of the modules
/// that read scored sequences).
#[cfg(test)]
pub(crate) fn test_sequence(
    id: &str,
    kind: EventKind,
    endpoint: Option<f64>,
    scores: &[f32],
) -> ScoredSequence {
    ScoredSequence {
        event_id: id.into(),
        kind,
        endpoint,
        frames: scores
            .iter()
            .enumerate()
            .map(|(i, &score)| ScoredFrame {
                time: i as f64,
                score,
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seq(kind: EventKind, endpoint: Option<f64>, frames: &[(f64, f32)]) -> ScoredSequence {
        ScoredSequence {
            event_id: "e".into(),
            kind,
            endpoint,
            frames: frames
                .iter()
                .map(|&(time, score)| ScoredFrame { time, score })
                .collect(),
        }
    }

    #[test]
    fn records_are_the_running_max_rises_inside_the_window() {
        let s = seq(
            EventKind::Crash,
            Some(0.3),
            &[(0.0, 0.2), (0.1, 0.1), (0.2, 0.5), (0.3, 0.5), (0.4, 9.0)],
        );
        let p = AlertProfile::from_sequence(&s).unwrap();
        assert_eq!(
            p.records,
            vec![
                RunningMaxRecord {
                    time: 0.0,
                    level: 0.2
                },
                RunningMaxRecord {
                    time: 0.2,
                    level: 0.5
                }
            ]
        );
        assert_eq!(p.max(), Some(0.5));
        assert_eq!(p.alert_time(0.3), Some(0.2));
        assert_eq!(p.alert_time(0.6), None);
        assert!((p.lead_time(0.15).unwrap() - 0.3).abs() < 1e-12);
    }

    #[test]
    fn nan_scores_never_warn() {
        let s = seq(EventKind::Safe, None, &[(0.0, f32::NAN), (0.1, 1.0)]);
        let p = AlertProfile::from_sequence(&s).unwrap();
        assert_eq!(p.records.len(), 1);
        assert_eq!(p.alert_time(0.0), Some(0.1));
        let all_nan = seq(EventKind::Safe, None, &[(0.0, f32::NAN)]);
        assert_eq!(AlertProfile::from_sequence(&all_nan).unwrap().max(), None);
    }

    #[test]
    fn bad_input_is_named() {
        let missing = seq(EventKind::NearCrash, None, &[(0.0, 1.0)]);
        assert!(matches!(
            AlertProfile::from_sequence(&missing),
            Err(ProtocolError::MissingEndpoint { .. })
        ));
        let unsorted = seq(EventKind::Safe, None, &[(0.1, 1.0), (0.1, 2.0)]);
        let err = AlertProfile::from_sequence(&unsorted).unwrap_err();
        assert!(err.to_string().contains("frame 1"), "{err}");
    }

    #[test]
    fn baseline_directions() {
        assert_eq!(time_surrogate_risk(2.0), -2.0);
        assert_eq!(time_surrogate_risk(f32::INFINITY), NO_CONFLICT_RISK);
        assert_eq!(
            intensity_surrogate_risk(f32::NEG_INFINITY),
            NO_CONFLICT_RISK
        );
        assert_eq!(intensity_surrogate_risk(3.5), 3.5);
        assert!(time_surrogate_risk(f32::NAN).is_nan());
        // Smaller TTC is riskier.
        assert!(time_surrogate_risk(1.0) > time_surrogate_risk(2.0));
    }
}
