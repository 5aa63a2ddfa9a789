//! Risk trajectories of drawn events as plot data: each method's score per frame, placed at its
//! percentile among all of that method's alert-window scores (no plotting here, so the streamed
//! evaluation can gather them without the `plots` feature).
use super::protocol::{in_alert_window, ScoredSequence, NO_CONFLICT_RISK};
use super::sketch::ScoreSketch;

/// One conflict event's (a crash or a near crash) normalised risk over time to its endpoint,
/// for every method.
#[derive(Clone, Debug, PartialEq)]
pub struct TrajectoryPanel {
    pub event_id: String,
    /// `(method, [(time - endpoint (s), normalised risk in [0, 1])])`; the risk is NaN at frames
    /// where the method sees no conflict (an infinite TTC2D, say), drawn as a gap, not as zero.
    pub lines: Vec<(String, Vec<(f64, f64)>)>,
}

/// Per-method scaling to the empirical CDF of the method's scores over the alert-window frames of
/// all its sequences: a frame's value is the fraction of those frames that are less risky (ties
/// count half). Unit-free and robust to outliers (a TTC of 10^4 s does not flatten everything
/// else), so methods with different units share one axis. [`NO_CONFLICT_RISK`] and NaN map to 0.
///
/// The counts come from a [`ScoreSketch`] of those scores: exact when the sketch is
/// ([`ScoreSketch::is_exact`]), else each value is within `rank_error / count` of the exact one.
pub fn percentile(scores: &mut ScoreSketch, r: f32) -> f64 {
    let n = scores.count() as f64;
    if r.is_nan() || r <= NO_CONFLICT_RISK || n == 0.0 {
        return 0.0;
    }
    let (below, at_or_below) = scores.ranks(r);
    (0.5 * (below as f64 + at_or_below as f64) / n).clamp(0.0, 1.0)
}

/// The alert-window scores of `sequences`, counted exactly (what [`percentile`] ranks against).
pub fn alert_window_scores(sequences: &[ScoredSequence]) -> ScoreSketch {
    let mut scores = ScoreSketch::exact();
    for s in sequences {
        for f in s
            .frames
            .iter()
            .filter(|f| in_alert_window(s.endpoint, f.time))
        {
            scores.push(f.score);
        }
    }
    scores
}

/// Builds the trajectory panels of `event_ids` (crash or near-crash events) from each method's
/// scored sequences (methods that lack the event, or its endpoint, are left out of its panel).
pub fn trajectory_panels(
    methods: &[(String, Vec<ScoredSequence>)],
    event_ids: &[String],
) -> Vec<TrajectoryPanel> {
    let mut scales: Vec<ScoreSketch> = methods
        .iter()
        .map(|(_, seqs)| alert_window_scores(seqs))
        .collect();
    trajectory_panels_ranked(methods, &mut scales, event_ids)
}

/// [`trajectory_panels`] with each method's percentiles taken from `scales` (in `methods` order,
/// the method's alert-window scores over *all* its sequences) rather than from the sequences given,
/// which then need only include the events drawn.
pub fn trajectory_panels_ranked(
    methods: &[(String, Vec<ScoredSequence>)],
    scales: &mut [ScoreSketch],
    event_ids: &[String],
) -> Vec<TrajectoryPanel> {
    event_ids
        .iter()
        .map(|id| TrajectoryPanel {
            event_id: id.clone(),
            lines: methods
                .iter()
                .zip(scales.iter_mut())
                .filter_map(|((name, seqs), scale)| {
                    let s = seqs.iter().find(|s| &s.event_id == id)?;
                    let endpoint = s.endpoint?;
                    let line = s
                        .frames
                        .iter()
                        .map(|f| (f.time - endpoint, plotted_percentile(scale, f.score)))
                        .collect();
                    Some((name.clone(), line))
                })
                .collect(),
        })
        .collect()
}

/// [`percentile`], but NaN where the method sees no conflict: a gap in the line.
fn plotted_percentile(scale: &mut ScoreSketch, r: f32) -> f64 {
    if r.is_nan() || r <= NO_CONFLICT_RISK {
        f64::NAN
    } else {
        percentile(scale, r)
    }
}

/// The first `n` crash sequences (with an endpoint) in input order: the events drawn when none
/// are named (`riskctl evaluate --trajectory-event` names crash or near-crash ones instead).
pub fn default_trajectory_events(sequences: &[ScoredSequence], n: usize) -> Vec<String> {
    sequences
        .iter()
        .filter(|s| s.kind == super::protocol::EventKind::Crash && s.endpoint.is_some())
        .take(n)
        .map(|s| s.event_id.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::test_sequence as seq;
    use crate::protocol::EventKind;

    #[test]
    fn trajectories_are_percentiles_over_alert_windows() {
        // Alert-window scores of the method: 2, 4, 6, 3, 3 and two no-conflict frames (7 frames;
        // the 100 after c's endpoint is not among them).
        let seqs = vec![
            seq("c", EventKind::Crash, Some(2.0), &[2.0, 4.0, 6.0, 100.0]),
            seq("s", EventKind::Safe, None, &[NO_CONFLICT_RISK, 3.0]),
            seq("g", EventKind::Crash, Some(1.0), &[NO_CONFLICT_RISK, 3.0]),
        ];
        assert_eq!(default_trajectory_events(&seqs, 3), ["c", "g"]);
        let panels = trajectory_panels(&[("M".into(), seqs)], &["c".to_owned(), "g".to_owned()]);
        // g's no-conflict frame is a gap; its 3.0 ranks among all alert-window frames.
        let gap = &panels[1].lines[0].1;
        assert!(
            gap[0].1.is_nan(),
            "no conflict is a gap, not a zero: {gap:?}"
        );
        assert!(gap[1].1 > 0.0);
        let line = &panels[0].lines[0].1;
        // 2: two frames below, itself half -> 2.5/7; 4: 5.5/7; 6: 6.5/7; 100: all below -> 1.
        let expected = [
            (-2.0, 2.5 / 7.0),
            (-1.0, 5.5 / 7.0),
            (0.0, 6.5 / 7.0),
            (1.0, 1.0),
        ];
        assert_eq!(line.len(), expected.len());
        for (got, want) in line.iter().zip(expected) {
            assert_eq!(got.0, want.0);
            assert!((got.1 - want.1).abs() < 1e-12, "{got:?} vs {want:?}");
        }
    }
}
