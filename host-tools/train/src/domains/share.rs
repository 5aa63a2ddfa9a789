//! False alarms on real driving: the share of real safe sequences a method warns at its own
//! 90 %-recall threshold (the highest threshold at which it warns >= 90 % of the conflicts).
use std::ops::Range;

use serde::Serialize;

use riskscore_eval::protocol::first_alert;
use riskscore_eval::{MethodRun, Stat, WarningCurve};

/// The recall (percent) whose threshold the share is read at.
pub const SHARE_RECALL_PERCENT: u32 = 90;
/// The JSON key of the share in a method row (and the metric of its claim).
pub const SHARE_KEY: &str = "real_safe_above_recall_90";

/// The highest threshold at which the curve warns at least `percent` % of its conflicts; `None`
/// without conflicts (or when no threshold reaches it).
pub fn recall_threshold(curve: &WarningCurve, percent: u32) -> Option<f32> {
    let needed = curve.positives as u128 * u128::from(percent);
    if curve.positives == 0 {
        return None;
    }
    curve
        .points
        .iter()
        .find(|p| p.true_positives as u128 * 100 >= needed)
        .map(|p| p.threshold)
}

/// One method in one fold: how many of the real safe test sequences it warns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShareRun {
    pub seed: u64,
    pub fold: usize,
    pub method: String,
    /// The method's 90 %-recall threshold on this fold's test set; `None` without conflicts.
    pub threshold: Option<f32>,
    /// Real safe sequences warned at that threshold.
    pub above: usize,
    /// Real safe sequences in the fold's test set.
    pub of: usize,
}

impl ShareRun {
    /// `above / of` in percent; `None` without a threshold or without real safe sequences.
    pub fn percent(&self) -> Option<f64> {
        (self.threshold.is_some() && self.of > 0)
            .then(|| 100.0 * self.above as f64 / self.of as f64)
    }
}

/// The share of one method's run: its scored sequences in `real` (the real safe ones count)
/// warned, by the core's first-threshold rule, at its 90 %-recall threshold.
pub fn share_of(run: &MethodRun, real: Range<usize>, seed: u64, fold: usize) -> ShareRun {
    let threshold = recall_threshold(&run.curve, SHARE_RECALL_PERCENT);
    let safe: Vec<_> = run
        .scored
        .get(real)
        .unwrap_or_default()
        .iter()
        .filter(|s| !s.kind.is_conflict())
        .collect();
    let above = threshold.map_or(0, |t| {
        safe.iter().filter(|s| first_alert(s, t).is_some()).count()
    });
    ShareRun {
        seed,
        fold,
        method: run.name.clone(),
        threshold,
        above,
        of: safe.len(),
    }
}

/// One method's share over all runs: mean ± std of the per-run percentages where defined, and
/// the pooled count.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShareSummary {
    pub percent: Option<Stat>,
    pub above: usize,
    pub of: usize,
}

/// The summary of `method` over `runs`.
pub fn summarise(runs: &[ShareRun], method: &str) -> ShareSummary {
    let mine: Vec<&ShareRun> = runs.iter().filter(|r| r.method == method).collect();
    let percents: Vec<f64> = mine.iter().filter_map(|r| r.percent()).collect();
    ShareSummary {
        percent: Stat::of(&percents),
        above: mine.iter().map(|r| r.above).sum(),
        of: mine.iter().map(|r| r.of).sum(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use riskscore_data::events::EventKind;
    use riskscore_eval::evaluate_scored;
    use riskscore_eval::protocol::{ScoredFrame, ScoredSequence};

    fn seq(id: &str, kind: EventKind, scores: &[f32]) -> ScoredSequence {
        let endpoint = kind.is_conflict().then_some(scores.len() as f64 - 1.0);
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

    #[test]
    fn the_threshold_keeps_90_percent_recall_and_only_real_safe_count() {
        // Ten conflicts peaking at 1..=10: 90 % recall needs nine, so the threshold is 2.
        let mut scored: Vec<ScoredSequence> = (1..=10)
            .map(|k| seq(&format!("c{k}"), EventKind::Crash, &[0.0, k as f32]))
            .collect();
        // A simulated safe sequence at 9 (not real: must not count), then real ones at 1, 2, 5.
        scored.push(seq("sim-safe", EventKind::Safe, &[9.0]));
        let real_from = scored.len();
        for (k, s) in [1.0, 2.0, 5.0].into_iter().enumerate() {
            scored.push(seq(&format!("r/{k}"), EventKind::Safe, &[s]));
        }
        let (_, runs) = evaluate_scored(vec![("M".into(), scored.clone())]).unwrap();
        assert_eq!(recall_threshold(&runs[0].curve, 90), Some(2.0));
        assert_eq!(recall_threshold(&runs[0].curve, 100), Some(1.0));
        let share = share_of(&runs[0], real_from..scored.len(), 4, 1);
        assert_eq!((share.above, share.of), (2, 3));
        assert_eq!(share.threshold, Some(2.0));
        let summary = summarise(&[share.clone(), share], "M");
        assert_eq!((summary.above, summary.of), (4, 6));
        assert!((summary.percent.unwrap().mean - 200.0 / 3.0).abs() < 1e-9);
    }
}
