//! One method at one threshold: per event kind how many sequences warn, the recall, the false
//! alarms per hour of driving and the mean lead time; and the rule that calibrates a model's
//! default threshold on normal driving.
//!
//! Driving time of a sequence is the span of its alert window: from its first frame to its last
//! frame at or before the endpoint (safe sequences: to their last frame). A safe sequence warns at
//! most once (the first-threshold rule), so "false alarms per hour" is the number of warned safe
//! sequences over the hours of safe driving.
use serde::Serialize;

use super::metrics::WarningCurve;
use super::protocol::{AlertProfile, EventKind};
use super::report::format_value;

/// One sequence at one threshold, kept until every worker is done so that sums run in
/// `events.csv` order (the same bits whatever the scheduling).
#[derive(Clone, Copy, Debug)]
struct Outcome {
    position: usize,
    kind: EventKind,
    lead_time: Option<f64>,
    warned: bool,
    seconds: f64,
}

/// Collects one method's outcomes at its threshold.
#[derive(Clone, Debug)]
pub struct ThresholdCollector {
    pub threshold: f32,
    outcomes: Vec<Outcome>,
}

impl ThresholdCollector {
    pub fn new(threshold: f32) -> Self {
        Self {
            threshold,
            outcomes: Vec::new(),
        }
    }

    /// Records the sequence at `position` (its profile before any trimming) and its alert-window
    /// span in seconds.
    pub fn add(&mut self, position: usize, profile: &AlertProfile, seconds: f64) {
        self.outcomes.push(Outcome {
            position,
            kind: profile.kind,
            lead_time: profile.lead_time(self.threshold),
            warned: profile.alert_time(self.threshold).is_some(),
            seconds,
        });
    }

    pub fn merge(&mut self, other: Self) {
        self.outcomes.extend(other.outcomes);
    }

    /// The tallies, summed in `events.csv` order.
    pub fn finish(mut self, name: &str) -> ThresholdReport {
        self.outcomes.sort_by_key(|o| o.position);
        let mut report = ThresholdReport {
            name: name.to_owned(),
            threshold: self.threshold,
            crash: KindTally::default(),
            near_crash: KindTally::default(),
            safe: KindTally::default(),
        };
        for o in &self.outcomes {
            let tally = match o.kind {
                EventKind::Crash => &mut report.crash,
                EventKind::NearCrash => &mut report.near_crash,
                EventKind::Safe => &mut report.safe,
            };
            tally.sequences += 1;
            tally.driving_seconds += o.seconds;
            if o.warned {
                tally.warned += 1;
            }
            if let Some(lead) = o.lead_time {
                tally.lead_time_sum += lead;
            }
        }
        report
    }
}

/// The sequences of one event kind at one threshold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct KindTally {
    pub sequences: usize,
    pub warned: usize,
    /// Sum of the warned conflict sequences' lead times (s).
    #[serde(skip)]
    pub lead_time_sum: f64,
    /// Sum of the alert-window spans (s).
    #[serde(skip)]
    pub driving_seconds: f64,
}

impl KindTally {
    pub fn not_warned(&self) -> usize {
        self.sequences - self.warned
    }

    /// Warned sequences in percent (recall for conflicts, false-alarm rate for safe driving).
    pub fn warned_percent(&self) -> Option<f64> {
        (self.sequences > 0).then(|| 100.0 * self.warned as f64 / self.sequences as f64)
    }

    pub fn driving_hours(&self) -> f64 {
        self.driving_seconds / 3600.0
    }

    /// Warned sequences per hour of driving; `None` without driving time.
    pub fn warned_per_hour(&self) -> Option<f64> {
        (self.driving_seconds > 0.0).then(|| self.warned as f64 / self.driving_hours())
    }

    /// Mean lead time of the warned sequences (s); conflicts only.
    pub fn mean_lead_time(&self) -> Option<f64> {
        (self.warned > 0).then(|| self.lead_time_sum / self.warned as f64)
    }
}

/// One method at one threshold.
#[derive(Clone, Debug, PartialEq)]
pub struct ThresholdReport {
    pub name: String,
    pub threshold: f32,
    pub crash: KindTally,
    pub near_crash: KindTally,
    pub safe: KindTally,
}

impl ThresholdReport {
    /// The stable JSON of `riskctl evaluate --threshold ... --json` (one entry of
    /// `"operating_points"`): per kind `sequences`, `warned`, `not_warned`, `driving_hours`, and
    /// `recall` + `mean_lead_time` (conflict kinds) or `false_alarm_rate` +
    /// `false_alarms_per_hour` (safe); percentages 0-100, null where undefined.
    pub fn to_json(&self) -> serde_json::Value {
        let conflict = |t: &KindTally| {
            serde_json::json!({
                "sequences": t.sequences,
                "warned": t.warned,
                "not_warned": t.not_warned(),
                "driving_hours": t.driving_hours(),
                "recall": t.warned_percent(),
                "mean_lead_time": t.mean_lead_time(),
            })
        };
        serde_json::json!({
            "name": self.name,
            "threshold": self.threshold,
            "crash": conflict(&self.crash),
            "near_crash": conflict(&self.near_crash),
            "safe": {
                "sequences": self.safe.sequences,
                "warned": self.safe.warned,
                "not_warned": self.safe.not_warned(),
                "driving_hours": self.safe.driving_hours(),
                "false_alarm_rate": self.safe.warned_percent(),
                "false_alarms_per_hour": self.safe.warned_per_hour(),
            },
        })
    }
}

/// The Markdown table printed after the metrics: one row per method and event kind.
pub fn markdown(reports: &[ThresholdReport]) -> String {
    let mut out = String::from(
        "\n| Method | threshold | kind | sequences | warned | not warned | recall / false-alarm rate (%) | per hour of driving | mean lead time (s) |\n\
         |---|---:|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in reports {
        let rows = [
            ("crash", &r.crash),
            ("near-crash", &r.near_crash),
            ("safe", &r.safe),
        ];
        for (kind, t) in rows {
            if t.sequences == 0 {
                continue;
            }
            let (per_hour, lead) = if kind == "safe" {
                (format_value(t.warned_per_hour(), 2), "".to_owned())
            } else {
                ("".to_owned(), format_value(t.mean_lead_time(), 2))
            };
            out.push_str(&format!(
                "| {} | {} | {kind} | {} | {} | {} | {} | {per_hour} | {lead} |\n",
                r.name,
                r.threshold,
                t.sequences,
                t.warned,
                t.not_warned(),
                format_value(t.warned_percent(), 1),
            ));
        }
    }
    out
}

/// A threshold chosen by [`calibrate_safe_share`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    pub threshold: f32,
    /// The share of safe sequences that warn at it, in `[0, 1]`.
    pub measured: f64,
    /// The safe sequences it was measured on.
    pub sequences: usize,
}

/// The safe sequences' maxima of a curve (a safe sequence adds one false alarm at every threshold
/// up to its maximum), largest first; a sequence with no score has none.
pub fn safe_maxima(curve: &WarningCurve) -> Vec<f32> {
    let mut maxima = Vec::with_capacity(curve.negatives);
    let mut counted = 0;
    for p in &curve.points {
        maxima.extend(std::iter::repeat_n(
            p.threshold,
            p.false_positives - counted,
        ));
        counted = p.false_positives;
    }
    maxima
}

/// The smallest of the safe sequences' `maxima` at which at most `target` (a fraction in
/// `[0, 1]`) of them warn (`score >= threshold`); `None` without sequences. When even the largest
/// maximum is shared by more sequences than allowed, the threshold is just above it (nothing
/// warns).
pub fn calibrate_safe_share(maxima: &[f32], target: f64) -> Option<Calibration> {
    let sequences = maxima.len();
    if sequences == 0 {
        return None;
    }
    let mut sorted: Vec<f32> = maxima.iter().copied().filter(|m| !m.is_nan()).collect();
    sorted.sort_by(|a, b| b.total_cmp(a));
    // A little room before flooring: 0.29 * 100 is 28.999999999999996 in f64, and 29 of 100
    // sequences are allowed to warn at a 29 % target.
    let allowed = (target.clamp(0.0, 1.0) * sequences as f64 + 1e-9).floor() as usize;
    // Walk the distinct maxima from the largest down; `warned` sequences reach each one.
    let mut chosen: Option<(f32, usize)> = None;
    let mut warned = 0;
    while let Some(&t) = sorted.get(warned) {
        let reach = warned + sorted[warned..].iter().take_while(|&&m| m >= t).count();
        if reach > allowed {
            break;
        }
        chosen = Some((t, reach));
        warned = reach;
    }
    let (threshold, warned) =
        chosen.unwrap_or_else(|| (sorted.first().map_or(f32::INFINITY, |m| m.next_up()), 0));
    Some(Calibration {
        threshold,
        measured: warned as f64 / sequences as f64,
        sequences,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::OperatingPoint;

    fn curve(fp: &[(f32, usize)], negatives: usize) -> WarningCurve {
        WarningCurve {
            positives: 0,
            negatives,
            points: fp
                .iter()
                .map(|&(threshold, false_positives)| OperatingPoint {
                    threshold,
                    true_positives: 0,
                    false_positives,
                    lead_time_sum: 0.0,
                })
                .collect(),
        }
    }

    #[test]
    fn calibration_takes_the_smallest_maximum_within_the_target() {
        // Ten safe maxima 10, 9, ..., 1: at most 20 % may warn, so 9 (two warn).
        let maxima: Vec<f32> = (1..=10).map(|k| k as f32).collect();
        let c = calibrate_safe_share(&maxima, 0.2).unwrap();
        assert_eq!(c.threshold, 9.0);
        assert_eq!(c.measured, 0.2);
        // 25 % still allows only two of ten.
        assert_eq!(calibrate_safe_share(&maxima, 0.25).unwrap().threshold, 9.0);
        // 0 %: nothing may warn, so just above the largest maximum.
        let c = calibrate_safe_share(&maxima, 0.0).unwrap();
        assert!(c.threshold > 10.0 && c.threshold < 10.001);
        assert_eq!(c.measured, 0.0);
        // Ties: three sequences share the top maximum; 20 % of ten allows two, so none warn.
        let tied = [5.0, 5.0, 5.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let c = calibrate_safe_share(&tied, 0.2).unwrap();
        assert!(c.threshold > 5.0 && c.measured == 0.0);
        assert!(calibrate_safe_share(&[], 0.1).is_none());
        // A percentage that is not exact in binary: 29 % of 100 allows 29 (29 / 100 = 0.29 is
        // 0.28999... once multiplied back).
        let hundred: Vec<f32> = (1..=100).map(|k| k as f32).collect();
        for percent in [29.0, 57.0, 58.0] {
            let c = calibrate_safe_share(&hundred, percent / 100.0).unwrap();
            assert_eq!(c.threshold, 101.0 - percent as f32, "{percent} %");
            assert!((c.measured - percent / 100.0).abs() < 1e-12);
        }
    }

    #[test]
    fn safe_maxima_come_back_from_the_curve() {
        // Safe maxima 3, 3, 2 and a conflict's at 2.5.
        let c = curve(&[(3.0, 2), (2.5, 2), (2.0, 3)], 3);
        assert_eq!(safe_maxima(&c), vec![3.0, 3.0, 2.0]);
    }

    #[test]
    fn tallies_count_warnings_lead_times_and_hours() {
        use crate::protocol::test_profile as profile;
        let mut c = ThresholdCollector::new(2.0);
        c.add(
            1,
            &profile(EventKind::Crash, Some(5.0), &[(0.0, 1.0), (3.5, 2.5)]),
            5.0,
        );
        c.add(0, &profile(EventKind::Crash, Some(5.0), &[(0.0, 1.0)]), 5.0);
        c.add(2, &profile(EventKind::Safe, None, &[(1.0, 3.0)]), 1800.0);
        c.add(3, &profile(EventKind::Safe, None, &[(1.0, 0.5)]), 1800.0);
        let r = c.finish("DRL");
        assert_eq!((r.crash.sequences, r.crash.warned), (2, 1));
        assert_eq!(r.crash.warned_percent(), Some(50.0));
        assert_eq!(r.crash.mean_lead_time(), Some(1.5));
        assert_eq!(r.safe.not_warned(), 1);
        assert_eq!(r.safe.warned_per_hour(), Some(1.0));
        assert_eq!(r.near_crash.warned_percent(), None);
        let json = r.to_json();
        assert_eq!(json["safe"]["false_alarm_rate"], 50.0);
        assert_eq!(json["near_crash"]["recall"], serde_json::Value::Null);
        assert!(markdown(&[r]).contains("| DRL | 2 | safe | 2 | 1 | 1 | 50.0 | 1.00 |  |"));
    }
}
