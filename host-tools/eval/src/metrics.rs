//! Operating points over all thresholds and the five metrics: A^ROC_90/80, P^PRC_90/80, mTTI^90_p.
//!
//! Thresholds are all distinct sequence maxima. At threshold `T` a sequence is warned iff its
//! maximum is `>= T`; its alert time is the first running-maximum record `>= T`
//! ([`AlertProfile::alert_time`]). [`warning_curve`] sweeps the thresholds from the highest down in
//! `O(S log S)` over all records; [`warning_curve_reference`] applies the core's
//! [`FirstThreshold`](scorer_core::warning::FirstThreshold) rule to every frame at every threshold
//! and exists to prove the sweep right (tests compare the two). Formulas: `docs/evaluation.md`.
use serde::{Deserialize, Serialize};

use super::protocol::{lead_time, AlertProfile, ProtocolError, ScoredSequence};

/// Recall / TPR levels of the partial metrics, in percent (exact integer comparisons).
pub const ALPHA_90: u32 = 90;
pub const ALPHA_80: u32 = 80;
/// Minimum precision (percent) for a threshold to count towards mTTI^90_p.
pub const MTTI_PRECISION: u32 = 90;

/// The outcome of warning at one threshold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OperatingPoint {
    pub threshold: f32,
    /// Conflict sequences warned (true positives).
    pub true_positives: usize,
    /// Safe sequences warned (false alarms).
    pub false_positives: usize,
    /// Sum over the true positives of `endpoint - alert time` (s).
    pub lead_time_sum: f64,
}

impl OperatingPoint {
    pub fn warned(&self) -> usize {
        self.true_positives + self.false_positives
    }

    /// `TP / (TP + FP)`; `None` when nothing is warned.
    pub fn precision(&self) -> Option<f64> {
        ratio(self.true_positives, self.warned())
    }

    /// Mean lead time of the true positives (s); `None` without true positives.
    pub fn mean_lead_time(&self) -> Option<f64> {
        (self.true_positives > 0).then(|| self.lead_time_sum / self.true_positives as f64)
    }
}

fn ratio(num: usize, den: usize) -> Option<f64> {
    (den > 0).then(|| num as f64 / den as f64)
}

/// All operating points of one method on one set of sequences.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WarningCurve {
    /// Number of conflict sequences (crash + near-crash).
    pub positives: usize,
    /// Number of safe sequences.
    pub negatives: usize,
    /// One point per distinct sequence maximum, thresholds strictly decreasing.
    pub points: Vec<OperatingPoint>,
}

/// The five metrics of one method. Percentages are 0-100, lead time in seconds; `None` where
/// undefined (see [`WarningCurve::metrics`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    pub a_roc_90: Option<f64>,
    pub a_roc_80: Option<f64>,
    pub p_prc_90: Option<f64>,
    pub p_prc_80: Option<f64>,
    pub mtti_90: Option<f64>,
}

impl Metrics {
    /// The values in table order, with their JSON/CSV keys.
    pub fn named(&self) -> [(&'static str, Option<f64>); 5] {
        Metric::ALL.map(|m| (m.key(), self.get(m)))
    }

    /// One metric's value; `None` where it is undefined.
    pub fn get(&self, metric: Metric) -> Option<f64> {
        match metric {
            Metric::ARoc90 => self.a_roc_90,
            Metric::ARoc80 => self.a_roc_80,
            Metric::PPrc90 => self.p_prc_90,
            Metric::PPrc80 => self.p_prc_80,
            Metric::MTti90 => self.mtti_90,
        }
    }
}

/// Keys of [`Metrics::named`], in order.
pub const METRIC_KEYS: [&str; 5] = ["A_ROC_90", "A_ROC_80", "P_PRC_90", "P_PRC_80", "mTTI_90"];

/// The five warning metrics, in table order (the order of [`METRIC_KEYS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Metric {
    ARoc90,
    ARoc80,
    PPrc90,
    PPrc80,
    MTti90,
}

impl Metric {
    pub const ALL: [Metric; 5] = [
        Metric::ARoc90,
        Metric::ARoc80,
        Metric::PPrc90,
        Metric::PPrc80,
        Metric::MTti90,
    ];

    /// The column name in tables and JSON (`A_ROC_90`, ...).
    pub const fn key(self) -> &'static str {
        METRIC_KEYS[self as usize]
    }
}

impl WarningCurve {
    /// TPR (= recall) at a point; `None` without positives.
    pub fn tpr(&self, p: &OperatingPoint) -> Option<f64> {
        ratio(p.true_positives, self.positives)
    }

    /// FPR at a point; `None` without negatives.
    pub fn fpr(&self, p: &OperatingPoint) -> Option<f64> {
        ratio(p.false_positives, self.negatives)
    }

    /// The ROC polyline `(FPR, TPR)`: `(0,0)`, the points by decreasing threshold, `(1,1)`.
    /// `None` when there are no positives or no negatives.
    pub fn roc_curve(&self) -> Option<Vec<(f64, f64)>> {
        if self.positives == 0 || self.negatives == 0 {
            return None;
        }
        let mut curve = Vec::with_capacity(self.points.len() + 2);
        curve.push((0.0, 0.0));
        for p in &self.points {
            curve.push((self.fpr(p)?, self.tpr(p)?));
        }
        curve.push((1.0, 1.0));
        Some(curve)
    }

    /// The precision-recall points `(recall, precision)` by decreasing threshold (no interpolation).
    pub fn pr_points(&self) -> Vec<(f64, f64)> {
        self.points
            .iter()
            .filter_map(|p| Some((self.tpr(p)?, p.precision()?)))
            .collect()
    }

    /// A^ROC_alpha in percent: the area of `(1 - FPR)` over TPR in `[alpha, 1]` along the ROC
    /// polyline, divided by `1 - alpha`. `None` without positives or negatives, or for
    /// `alpha_percent >= 100`.
    pub fn a_roc(&self, alpha_percent: u32) -> Option<f64> {
        if alpha_percent >= 100 {
            return None;
        }
        let alpha = f64::from(alpha_percent) / 100.0;
        let curve = self.roc_curve()?;
        Some(100.0 * partial_roc_area(&curve, alpha) / (1.0 - alpha))
    }

    /// P^PRC_alpha in percent: the largest precision among thresholds with recall `>= alpha`.
    /// `None` without positives, or when recall never reaches alpha.
    pub fn p_prc(&self, alpha_percent: u32) -> Option<f64> {
        if self.positives == 0 {
            return None;
        }
        self.points
            .iter()
            .filter(|p| at_least_percent(p.true_positives, self.positives, alpha_percent))
            .filter_map(OperatingPoint::precision)
            .map(|x| 100.0 * x)
            .reduce(f64::max)
    }

    /// mTTI^p in seconds: the largest mean lead time among thresholds whose precision is
    /// `>= precision_percent` (and that warn at least one conflict). `None` if no threshold qualifies.
    pub fn mtti(&self, precision_percent: u32) -> Option<f64> {
        self.points
            .iter()
            .filter(|p| at_least_percent(p.true_positives, p.warned(), precision_percent))
            .filter_map(OperatingPoint::mean_lead_time)
            .reduce(f64::max)
    }

    /// The five reported metrics.
    pub fn metrics(&self) -> Metrics {
        Metrics {
            a_roc_90: self.a_roc(ALPHA_90),
            a_roc_80: self.a_roc(ALPHA_80),
            p_prc_90: self.p_prc(ALPHA_90),
            p_prc_80: self.p_prc(ALPHA_80),
            mtti_90: self.mtti(MTTI_PRECISION),
        }
    }
}

/// `num / den >= percent / 100`, exactly, for `den > 0` (and false for `den == 0`).
fn at_least_percent(num: usize, den: usize, percent: u32) -> bool {
    den > 0 && (num as u128) * 100 >= u128::from(percent) * den as u128
}

/// `∫ (1 - FPR) dTPR` over `TPR ∈ [alpha, 1]` along a polyline of `(FPR, TPR)` vertices whose TPR
/// never decreases (segments are linear; vertical jumps in TPR at constant FPR are ordinary
/// segments, horizontal ones contribute nothing). Not normalised.
pub fn partial_roc_area(curve: &[(f64, f64)], alpha: f64) -> f64 {
    curve
        .windows(2)
        .filter_map(|w| match *w {
            [(f0, t0), (f1, t1)] if t1 > t0 => {
                let lo = t0.max(alpha);
                let hi = t1.min(1.0);
                (hi > lo).then(|| {
                    let fpr_at = |t: f64| f0 + (f1 - f0) * (t - t0) / (t1 - t0);
                    (hi - lo) * (1.0 - 0.5 * (fpr_at(lo) + fpr_at(hi)))
                })
            }
            _ => None,
        })
        .sum()
}

/// The distinct sequence maxima, highest first (sequences without any score contribute none).
pub fn thresholds(profiles: &[AlertProfile]) -> Vec<f32> {
    let mut t: Vec<f32> = profiles.iter().filter_map(AlertProfile::max).collect();
    t.sort_by(|a, b| b.total_cmp(a));
    t.dedup_by(|a, b| a == b);
    t
}

/// Every operating point, by one sweep over the running-maximum records (the fast path).
///
/// As the threshold falls past a conflict sequence's maximum it becomes a true positive, warned at
/// its last record; each further record it passes moves the alert earlier. Sorting those events by
/// level and sweeping the thresholds downwards gives all points in `O(S log S)`, `S` = records.
pub fn warning_curve(profiles: &[AlertProfile]) -> WarningCurve {
    struct Step {
        level: f32,
        new_tp: usize,
        new_fp: usize,
        lead_delta: f64,
    }
    let mut steps = Vec::new();
    for p in profiles {
        let Some(last) = p.records.last() else {
            continue;
        };
        match (p.kind.is_conflict(), p.endpoint) {
            (true, Some(endpoint)) => {
                steps.push(Step {
                    level: last.level,
                    new_tp: 1,
                    new_fp: 0,
                    lead_delta: lead_time(endpoint, last.time),
                });
                for pair in p.records.windows(2) {
                    if let [earlier, later] = pair {
                        steps.push(Step {
                            level: earlier.level,
                            new_tp: 0,
                            new_fp: 0,
                            lead_delta: lead_time(endpoint, earlier.time)
                                - lead_time(endpoint, later.time),
                        });
                    }
                }
            }
            (true, None) => {} // unreachable for profiles built by AlertProfileBuilder
            (false, _) => steps.push(Step {
                level: last.level,
                new_tp: 0,
                new_fp: 1,
                lead_delta: 0.0,
            }),
        }
    }
    steps.sort_by(|a, b| b.level.total_cmp(&a.level));

    let mut points = Vec::new();
    let (mut tp, mut fp, mut lead) = (0usize, 0usize, 0.0f64);
    let mut next = steps.iter().peekable();
    for threshold in thresholds(profiles) {
        while let Some(step) = next.next_if(|s| s.level >= threshold) {
            tp += step.new_tp;
            fp += step.new_fp;
            lead += step.lead_delta;
        }
        points.push(OperatingPoint {
            threshold,
            true_positives: tp,
            false_positives: fp,
            lead_time_sum: lead,
        });
    }
    let positives = profiles.iter().filter(|p| p.kind.is_conflict()).count();
    WarningCurve {
        positives,
        negatives: profiles.len() - positives,
        points,
    }
}

/// Every operating point, by running the core's first-threshold rule over every frame of every
/// sequence at every threshold. `O(thresholds × frames)`: for tests and small sets only.
pub fn warning_curve_reference(
    sequences: &[ScoredSequence],
) -> Result<WarningCurve, ProtocolError> {
    let profiles = super::protocol::alert_profiles(sequences)?;
    let mut points = Vec::new();
    for threshold in thresholds(&profiles) {
        let mut point = OperatingPoint {
            threshold,
            true_positives: 0,
            false_positives: 0,
            lead_time_sum: 0.0,
        };
        for s in sequences {
            let Some(alert) = super::protocol::first_alert(s, threshold) else {
                continue;
            };
            if s.kind.is_conflict() {
                point.true_positives += 1;
                if let Some(endpoint) = s.endpoint {
                    point.lead_time_sum += lead_time(endpoint, alert);
                }
            } else {
                point.false_positives += 1;
            }
        }
        points.push(point);
    }
    let positives = sequences.iter().filter(|s| s.kind.is_conflict()).count();
    Ok(WarningCurve {
        positives,
        negatives: sequences.len() - positives,
        points,
    })
}

/// Metrics of one method from its scored sequences (the usual entry point).
pub fn evaluate_sequences(sequences: &[ScoredSequence]) -> Result<Metrics, ProtocolError> {
    Ok(warning_curve(&super::protocol::alert_profiles(sequences)?).metrics())
}

/// Metrics of one method from per-sequence alert data built elsewhere (e.g. the CAN bridge).
pub fn evaluate_profiles(profiles: &[AlertProfile]) -> Metrics {
    warning_curve(profiles).metrics()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::EventKind;

    #[test]
    fn metrics_are_named_in_table_order() {
        let m = Metrics {
            a_roc_90: Some(1.0),
            a_roc_80: Some(2.0),
            p_prc_90: Some(3.0),
            p_prc_80: None,
            mtti_90: Some(5.0),
        };
        for (i, metric) in Metric::ALL.into_iter().enumerate() {
            assert_eq!(metric as usize, i);
            assert_eq!(m.named()[i], (METRIC_KEYS[i], m.get(metric)));
        }
        assert_eq!(m.get(Metric::PPrc80), None);
    }

    use crate::protocol::test_profile as profile;

    #[test]
    fn percent_levels_are_exact() {
        assert!(at_least_percent(9, 10, 90));
        assert!(!at_least_percent(8, 9, 90));
        assert!(at_least_percent(4, 5, 80));
        assert!(!at_least_percent(0, 0, 0), "no denominator, no level");
        assert!(at_least_percent(usize::MAX, usize::MAX, 100), "no overflow");
    }

    #[test]
    fn thresholds_are_distinct_maxima_highest_first() {
        let p = [
            profile(EventKind::Safe, None, &[(0.0, 0.0)]),
            profile(EventKind::Safe, None, &[(0.0, -1.0), (1.0, -0.0)]),
            profile(EventKind::Crash, Some(2.0), &[(0.0, 3.0)]),
            profile(EventKind::Crash, Some(2.0), &[]),
        ];
        let t = thresholds(&p);
        assert_eq!(t.len(), 2, "0.0 and -0.0 are one threshold: {t:?}");
        assert_eq!(t[0], 3.0);
        let curve = warning_curve(&p);
        assert_eq!((curve.positives, curve.negatives), (2, 2));
        assert_eq!(curve.points[1].false_positives, 2);
    }

    #[test]
    fn lead_time_steps_move_the_alert_earlier() {
        // Records at 1 s (level 1), 2 s (level 2), 3 s (level 3); endpoint 4 s. Thresholds are the
        // maxima 3 (this one) and 1.5 and 0.5 (safe sequences).
        let p = [
            profile(
                EventKind::Crash,
                Some(4.0),
                &[(1.0, 1.0), (2.0, 2.0), (3.0, 3.0)],
            ),
            profile(EventKind::Safe, None, &[(0.0, 1.5)]),
            profile(EventKind::Safe, None, &[(0.0, 0.5)]),
        ];
        let c = warning_curve(&p);
        let leads: Vec<_> = c
            .points
            .iter()
            .map(OperatingPoint::mean_lead_time)
            .collect();
        // At 3: alert at 3 s (1 s lead); at 1.5: first record >= 1.5 is 2 s (2 s); at 0.5: 1 s (3 s).
        assert_eq!(leads, [Some(1.0), Some(2.0), Some(3.0)]);
        // Precision 1, 1/2, 1/3: only the first qualifies for mTTI^90.
        assert_eq!(c.mtti(90), Some(1.0));
        assert_eq!(c.mtti(50), Some(2.0));
    }

    #[test]
    fn undefined_inputs_give_none() {
        let c = warning_curve(&[profile(EventKind::Crash, Some(1.0), &[(0.0, 1.0)])]);
        assert_eq!(c.roc_curve(), None, "no negatives");
        assert_eq!(c.a_roc(90), None);
        assert_eq!(c.a_roc(100), None);
        assert_eq!(c.p_prc(90), Some(100.0));
    }
}
