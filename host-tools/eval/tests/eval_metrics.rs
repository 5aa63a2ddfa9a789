//! The evaluation metrics against hand-computed cases, and the fast sweep against the core's
//! first-threshold rule. Every expected number below is worked out in the comment above it.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::float_cmp)]

use proptest::prelude::*;
use riskscore_eval::metrics::{partial_roc_area, warning_curve, warning_curve_reference, Metric};
use riskscore_eval::protocol::{alert_profiles, decisions};
use riskscore_eval::{
    aggregate, evaluate_sequences, EvaluationReport, EventCounts, EventKind, FoldResult,
    MethodResult, Metrics, ScoredFrame, ScoredSequence,
};

const EPS: f64 = 1e-9;

fn close(a: Option<f64>, b: f64) -> bool {
    a.is_some_and(|a| (a - b).abs() < EPS)
}

/// A sequence whose frames are `(time, score)`; conflict sequences end at `endpoint`.
fn seq(id: &str, kind: EventKind, endpoint: Option<f64>, frames: &[(f64, f32)]) -> ScoredSequence {
    ScoredSequence {
        event_id: id.into(),
        kind,
        endpoint,
        frames: frames
            .iter()
            .map(|&(time, score)| ScoredFrame { time, score })
            .collect(),
    }
}

/// A conflict sequence that reaches its maximum at its endpoint `1.0` (lead time 0 when warned)
/// after a frame below every threshold of the tests.
fn conflict(id: &str, max: f32) -> ScoredSequence {
    seq(
        id,
        EventKind::Crash,
        Some(1.0),
        &[(0.5, -1000.0), (1.0, max)],
    )
}

fn safe(id: &str, max: f32) -> ScoredSequence {
    seq(
        id,
        EventKind::Safe,
        None,
        &[(0.0, max - 1.0), (0.1, max), (0.2, max - 2.0)],
    )
}

fn metrics(seqs: &[ScoredSequence]) -> Metrics {
    evaluate_sequences(seqs).unwrap()
}

#[test]
fn interleaved_ranking_by_hand() {
    // Conflict maxima 9, 8, 6, 4; safe maxima 7, 5, 3, 2. Thresholds (desc) give (TP, FP):
    // 9:(1,0) 8:(2,0) 7:(2,1) 6:(3,1) 5:(3,2) 4:(4,2) 3:(4,3) 2:(4,4).
    // ROC (FPR, TPR): (0,0) (0,.25) (0,.5) (.25,.5) (.25,.75) (.5,.75) (.5,1) (.75,1) (1,1) (1,1).
    let s = vec![
        conflict("c1", 9.0),
        conflict("c2", 8.0),
        conflict("c3", 6.0),
        conflict("c4", 4.0),
        safe("s1", 7.0),
        safe("s2", 5.0),
        safe("s3", 3.0),
        safe("s4", 2.0),
    ];
    let curve = warning_curve(&alert_profiles(&s).unwrap());
    let tp_fp: Vec<_> = curve
        .points
        .iter()
        .map(|p| (p.threshold, p.true_positives, p.false_positives))
        .collect();
    assert_eq!(
        tp_fp,
        vec![
            (9.0, 1, 0),
            (8.0, 2, 0),
            (7.0, 2, 1),
            (6.0, 3, 1),
            (5.0, 3, 2),
            (4.0, 4, 2),
            (3.0, 4, 3),
            (2.0, 4, 4)
        ]
    );
    // TPR in [.9, 1] lies on the vertical segment at FPR .5: 0.1 * 0.5 / 0.1 = 50 %.
    // Same for [.8, 1]: 0.2 * 0.5 / 0.2 = 50 %.
    // TPR in [.5, 1]: .25 * (1 - .25) + .25 * (1 - .5) = .3125, / .5 = 62.5 %.
    assert!(close(curve.a_roc(90), 50.0));
    assert!(close(curve.a_roc(80), 50.0));
    assert!(close(curve.a_roc(50), 62.5));
    // Recall 1 first at threshold 4 with precision 4/6; later thresholds only add false alarms.
    let m = curve.metrics();
    assert!(close(m.p_prc_90, 100.0 * 4.0 / 6.0));
    assert!(close(m.p_prc_80, 100.0 * 4.0 / 6.0));
    // Recall .75 (threshold 6) has precision 3/4; recall >= .5 at threshold 8 has precision 1.
    assert!(close(curve.p_prc(75), 100.0 * 3.0 / 4.0));
    assert!(close(curve.p_prc(50), 100.0));
    // Precision >= 90 % only at thresholds 9 and 8, where every alert is at the endpoint: 0 s.
    assert!(close(m.mtti_90, 0.0));
}

#[test]
fn ties_at_a_threshold_move_diagonally() {
    // Conflict maxima 9, 5; safe maxima 5, 1. Threshold 5 warns one conflict and one safe at once:
    // ROC (0,0) (0,.5) (.5,1) (1,1) (1,1); on the tie segment FPR = TPR - .5.
    let s = vec![
        conflict("c1", 9.0),
        conflict("c2", 5.0),
        safe("s1", 5.0),
        safe("s2", 1.0),
    ];
    let curve = warning_curve(&alert_profiles(&s).unwrap());
    assert_eq!(curve.points.len(), 3);
    assert_eq!(curve.points[1].true_positives, 2);
    assert_eq!(curve.points[1].false_positives, 1);
    let m = curve.metrics();
    // [.9, 1]: FPR from .4 to .5, mean .45: .1 * .55 / .1 = 55 %.
    assert!(close(m.a_roc_90, 55.0));
    // [.8, 1]: FPR from .3 to .5, mean .4: .2 * .6 / .2 = 60 %.
    assert!(close(m.a_roc_80, 60.0));
    // Recall >= .8 first at threshold 5 (tie included): precision 2/3.
    assert!(close(m.p_prc_90, 100.0 * 2.0 / 3.0));
    assert!(close(m.p_prc_80, 100.0 * 2.0 / 3.0));
    assert_eq!(curve.roc_curve().unwrap()[2], (0.5, 1.0));
}

#[test]
fn no_positives_above_the_highest_threshold() {
    // Safe maximum 9 is above every conflict: threshold 9 has TP 0, FP 1 (precision 0, recall 0).
    // Then 5:(1,1) 4:(2,1) 1:(2,2). ROC (0,0) (.5,0) (.5,.5) (.5,1) (1,1) (1,1).
    let s = vec![
        conflict("c1", 5.0),
        conflict("c2", 4.0),
        safe("s1", 9.0),
        safe("s2", 1.0),
    ];
    let curve = warning_curve(&alert_profiles(&s).unwrap());
    let first = curve.points[0];
    assert_eq!((first.true_positives, first.false_positives), (0, 1));
    assert_eq!(first.precision(), Some(0.0));
    assert_eq!(first.mean_lead_time(), None);
    let m = curve.metrics();
    // TPR in [.8, 1] on the vertical segment at FPR .5.
    assert!(close(m.a_roc_90, 50.0));
    assert!(close(m.a_roc_80, 50.0));
    // Recall 1 at thresholds 4 (2/3) and 1 (2/4).
    assert!(close(m.p_prc_90, 100.0 * 2.0 / 3.0));
    // No threshold reaches 90 % precision.
    assert_eq!(m.mtti_90, None);
}

#[test]
fn recall_never_reaching_alpha() {
    // c4 has no score in its alert window (its only high frame is after the endpoint, the other
    // NaN), so at most 3 of 4 conflicts are ever warned: recall <= 75 %.
    // Thresholds 9:(1,0) 8:(2,0) 7:(3,0) 3:(3,1) 2:(3,2);
    // ROC (0,0) (0,.25) (0,.5) (0,.75) (.5,.75) (1,.75) then the join (1,1).
    let s = vec![
        conflict("c1", 9.0),
        conflict("c2", 8.0),
        conflict("c3", 7.0),
        seq(
            "c4",
            EventKind::NearCrash,
            Some(1.0),
            &[(1.0, f32::NAN), (1.1, 100.0)],
        ),
        safe("s1", 3.0),
        safe("s2", 2.0),
    ];
    let curve = warning_curve(&alert_profiles(&s).unwrap());
    assert_eq!(curve.positives, 4);
    assert_eq!(
        curve.points.len(),
        5,
        "100 after the endpoint is not a threshold"
    );
    let m = curve.metrics();
    // The only ROC piece above TPR .75 is the join (1,.75)-(1,1) at FPR 1: area 0.
    assert!(close(m.a_roc_90, 0.0));
    assert!(close(m.a_roc_80, 0.0));
    // Recall never reaches 80 %: undefined, not 0.
    assert_eq!(m.p_prc_90, None);
    assert_eq!(m.p_prc_80, None);
    assert!(close(curve.p_prc(75), 100.0));
    assert!(close(m.mtti_90, 0.0));
}

#[test]
fn all_safe_and_all_conflict() {
    let all_safe = metrics(&[safe("s1", 1.0), safe("s2", 2.0)]);
    assert_eq!(
        all_safe,
        Metrics::default(),
        "nothing is defined without conflicts"
    );

    // No safe sequences: FPR is undefined, so A^ROC is; precision is 100 % everywhere.
    let all_conflict = vec![
        seq("a", EventKind::Crash, Some(2.0), &[(1.0, 0.5), (2.0, 0.9)]),
        seq("b", EventKind::Crash, Some(3.0), &[(1.0, 0.5)]),
    ];
    let m = metrics(&all_conflict);
    assert_eq!(m.a_roc_90, None);
    assert_eq!(m.a_roc_80, None);
    assert!(close(m.p_prc_90, 100.0));
    assert!(close(m.p_prc_80, 100.0));
    // Threshold .9: a warned at 2.0 (lead 0). Threshold .5: a at 1.0 (lead 1), b at 1.0 (lead 2).
    assert!(close(m.mtti_90, 1.5));

    assert_eq!(metrics(&[]), Metrics::default());
}

#[test]
fn perfect_and_worst_separation() {
    let perfect = metrics(&[
        conflict("c1", 9.0),
        conflict("c2", 8.0),
        safe("s1", 2.0),
        safe("s2", 1.0),
    ]);
    assert!(close(perfect.a_roc_90, 100.0));
    assert!(close(perfect.a_roc_80, 100.0));
    assert!(close(perfect.p_prc_90, 100.0));
    assert!(close(perfect.p_prc_80, 100.0));

    let worst = metrics(&[
        conflict("c1", 1.0),
        conflict("c2", 2.0),
        safe("s1", 8.0),
        safe("s2", 9.0),
    ]);
    assert!(close(worst.a_roc_90, 0.0));
    assert!(close(worst.a_roc_80, 0.0));
    // Recall 1 only once both safe sequences are warned: 2/4.
    assert!(close(worst.p_prc_90, 50.0));
    assert_eq!(worst.mtti_90, None);

    // All scores equal: one threshold warns everything; ROC is the diagonal, and the partial area
    // of the diagonal is (1 - alpha) / 2 of the normalised area: 5 % at 90, 10 % at 80.
    let chance = metrics(&[conflict("c1", 1.0), safe("s1", 1.0)]);
    assert!(close(chance.a_roc_90, 5.0));
    assert!(close(chance.a_roc_80, 10.0));
}

#[test]
fn lead_time_with_an_alert_exactly_at_the_endpoint() {
    // a: endpoint 5.0; R = .1 @4.0, .3 @4.5, .8 @5.0 (at the endpoint: inside), 2.0 @5.1 (ignored).
    // b: endpoint 2.0; R = .3 @2.0.
    // Thresholds are the maxima .8 and .3 (not 2.0, which is after a's endpoint).
    //   .8: a warned at 5.0, lead 0            -> mean 0
    //   .3: a warned at 4.5 (lead .5), b at 2.0 (lead 0) -> mean .25
    let s = vec![
        seq(
            "a",
            EventKind::Crash,
            Some(5.0),
            &[(4.0, 0.1), (4.5, 0.3), (5.0, 0.8), (5.1, 2.0)],
        ),
        seq("b", EventKind::NearCrash, Some(2.0), &[(2.0, 0.3)]),
    ];
    let curve = warning_curve(&alert_profiles(&s).unwrap());
    let thresholds: Vec<f32> = curve.points.iter().map(|p| p.threshold).collect();
    assert_eq!(thresholds, vec![0.8, 0.3]);
    assert_eq!(curve.points[0].true_positives, 1);
    assert!(close(curve.points[0].mean_lead_time(), 0.0));
    assert!(close(curve.points[1].mean_lead_time(), 0.25));
    assert!(close(curve.metrics().mtti_90, 0.25));

    // The per-threshold decisions agree, and the alert at the endpoint counts as warned.
    let d = decisions(&s, 0.8);
    assert_eq!(d[0].alert_time, Some(5.0));
    assert_eq!(d[0].lead_time, Some(0.0));
    assert_eq!(d[1].alert_time, None);
    let d = decisions(&s, 1.5);
    assert_eq!(
        d[0].alert_time, None,
        "the 2.0 after the endpoint never warns"
    );
}

#[test]
fn mtti_picks_the_best_threshold_with_enough_precision() {
    // Ten conflicts whose R rises to their max one second before the endpoint (lead 1 s) or at it
    // (lead 0), and one safe sequence. Conflicts c0..c8 max 10+i, lead 1 s; c9 max 5, lead 0;
    // safe max 7.
    //   thresholds 18..10: only c's with lead 1, precision 1, mean lead 1.
    //   7: 9 TP + 1 FP, precision .9 (qualifies), mean lead 1.
    //   5: 10 TP + 1 FP, precision 10/11 >= .9, mean lead .9.
    let mut s: Vec<ScoredSequence> = (0..9)
        .map(|i| {
            let max = 10.0 + i as f32;
            seq(
                &format!("c{i}"),
                EventKind::Crash,
                Some(3.0),
                &[(1.0, 0.0), (2.0, max), (3.0, max - 0.5)],
            )
        })
        .collect();
    s.push(seq("c9", EventKind::Crash, Some(3.0), &[(3.0, 5.0)]));
    s.push(safe("s", 7.0));
    let curve = warning_curve(&alert_profiles(&s).unwrap());
    let at7 = curve.points.iter().find(|p| p.threshold == 7.0).unwrap();
    assert_eq!((at7.true_positives, at7.false_positives), (9, 1));
    assert!(close(at7.precision(), 0.9), "exactly 90 % qualifies");
    assert!(close(curve.metrics().mtti_90, 1.0));
    assert!(close(curve.mtti(91), 1.0));
}

#[test]
fn partial_area_of_simple_polylines() {
    // Diagonal: ∫_{.9}^{1} (1 - t) dt = .005.
    let diagonal = [(0.0, 0.0), (1.0, 1.0)];
    assert!((partial_roc_area(&diagonal, 0.9) - 0.005).abs() < 1e-12);
    // Horizontal segments add nothing; TPR jumps at FPR .2 integrate .8 over their span.
    let step = [(0.0, 0.0), (0.2, 0.0), (0.2, 1.0), (1.0, 1.0)];
    assert!((partial_roc_area(&step, 0.5) - 0.4).abs() < 1e-12);
}

#[test]
fn aggregation_is_mean_and_sample_std() {
    let m = |a: Option<f64>| Metrics {
        a_roc_90: a,
        a_roc_80: Some(50.0),
        p_prc_90: None,
        p_prc_80: Some(10.0),
        mtti_90: Some(1.0),
    };
    let folds = vec![
        FoldResult {
            seed: 1,
            fold: 0,
            methods: vec![MethodResult {
                name: "DRL".into(),
                metrics: m(Some(80.0)),
            }],
        },
        FoldResult {
            seed: 1,
            fold: 1,
            methods: vec![MethodResult {
                name: "DRL".into(),
                metrics: m(Some(90.0)),
            }],
        },
        FoldResult {
            seed: 2,
            fold: 0,
            methods: vec![MethodResult {
                name: "DRL".into(),
                metrics: m(None),
            }],
        },
    ];
    let cv = aggregate(EventCounts::default(), &folds);
    assert_eq!(cv.runs, 3);
    let drl = &cv.methods[0];
    let a90 = drl.stat(Metric::ARoc90).unwrap();
    // mean of 80 and 90 = 85; sample std = sqrt(((-5)^2 + 5^2) / 1) = 7.0711.
    assert!((a90.mean - 85.0).abs() < EPS);
    assert!((a90.std - 50f64.sqrt()).abs() < EPS);
    assert_eq!(a90.n, 2);
    assert_eq!(drl.stat(Metric::PPrc90), None);
    assert_eq!(drl.stat(Metric::ARoc80).unwrap().std, 0.0);
    let table = cv.to_markdown();
    assert!(
        table.contains("| DRL | 85.0 ± 7.1 (2/3) | 50.0 ± 0.0 | n/a | 10.0 ± 0.0 | 1.00 ± 0.00 |"),
        "{table}"
    );
}

#[test]
fn json_schema_is_exact() {
    let report = EvaluationReport {
        events: EventCounts {
            crash: 3,
            near_crash: 2,
            safe: 4,
        },
        methods: vec![
            MethodResult {
                name: "DRL".into(),
                metrics: Metrics {
                    a_roc_90: Some(91.5),
                    a_roc_80: Some(93.0),
                    p_prc_90: Some(80.0),
                    p_prc_80: Some(85.0),
                    mtti_90: Some(2.5),
                },
            },
            MethodResult {
                name: "TTC2D".into(),
                metrics: Metrics::default(),
            },
        ],
    };
    let v = report.to_json();
    let top: Vec<&String> = v.as_object().unwrap().keys().collect();
    assert_eq!(top, ["events", "methods"]);
    assert_eq!(
        v["events"],
        serde_json::json!({"crash": 3, "near_crash": 2, "safe": 4})
    );
    let methods = v["methods"].as_array().unwrap();
    assert_eq!(methods.len(), 2);
    for row in methods {
        let mut keys: Vec<&str> = row
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        keys.sort_unstable();
        assert_eq!(
            keys,
            ["A_ROC_80", "A_ROC_90", "P_PRC_80", "P_PRC_90", "mTTI_90", "name"]
        );
    }
    assert_eq!(methods[0]["name"], "DRL");
    assert_eq!(methods[0]["A_ROC_90"], 91.5);
    assert_eq!(methods[0]["mTTI_90"], 2.5);
    assert!(methods[1]["P_PRC_90"].is_null());
    // The printed text (what scripts parse) is the same object, `name` first in each row.
    let text = report.to_json_string();
    let back: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(back, v);
    assert!(text.find("\"name\"").unwrap() < text.find("\"A_ROC_90\"").unwrap());

    let mut csv = Vec::new();
    report.write_csv(&mut csv).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    assert_eq!(
        csv.lines().collect::<Vec<_>>(),
        [
            "method,A_ROC_90,A_ROC_80,P_PRC_90,P_PRC_80,mTTI_90",
            "DRL,91.5,93,80,85,2.5",
            "TTC2D,,,,,"
        ]
    );
}

fn arb_sequences() -> impl Strategy<Value = Vec<ScoredSequence>> {
    // Scores from a small grid so that ties between sequences and inside a sequence are common;
    // some NaN frames; conflict endpoints anywhere, including between and after the frames.
    let frame_scores = prop::collection::vec(
        prop_oneof![9 => (0i8..8).prop_map(|k| f32::from(k) * 0.5), 1 => Just(f32::NAN)],
        0..12,
    );
    let one = (0u8..3, frame_scores, 0u32..14, 0u32..3).prop_map(|(kind, scores, end, dt)| {
        let kind = match kind {
            0 => EventKind::Crash,
            1 => EventKind::NearCrash,
            _ => EventKind::Safe,
        };
        let step = [0.1, 0.25, 1.0][dt as usize];
        let frames = scores
            .iter()
            .enumerate()
            .map(|(i, &score)| ScoredFrame {
                time: 3.0 + i as f64 * step,
                score,
            })
            .collect();
        ScoredSequence {
            event_id: String::new(),
            kind,
            endpoint: kind.is_conflict().then(|| 3.0 + f64::from(end) * step),
            frames,
        }
    });
    prop::collection::vec(one, 0..25)
}

proptest! {
    #[test]
    fn fast_sweep_equals_first_threshold_rule(seqs in arb_sequences()) {
        let fast = warning_curve(&alert_profiles(&seqs).unwrap());
        let reference = warning_curve_reference(&seqs).unwrap();
        prop_assert_eq!(fast.positives, reference.positives);
        prop_assert_eq!(fast.negatives, reference.negatives);
        prop_assert_eq!(fast.points.len(), reference.points.len());
        for (f, r) in fast.points.iter().zip(&reference.points) {
            prop_assert_eq!(f.threshold, r.threshold);
            prop_assert_eq!(f.true_positives, r.true_positives);
            prop_assert_eq!(f.false_positives, r.false_positives);
            prop_assert!((f.lead_time_sum - r.lead_time_sum).abs() < 1e-9,
                "lead sums {} vs {}", f.lead_time_sum, r.lead_time_sum);
        }
        // And the per-threshold decisions reproduce each point.
        for p in &reference.points {
            let d = decisions(&seqs, p.threshold);
            let tp = d.iter().filter(|d| d.kind.is_conflict() && d.alert_time.is_some()).count();
            let fp = d.iter().filter(|d| !d.kind.is_conflict() && d.alert_time.is_some()).count();
            prop_assert_eq!((tp, fp), (p.true_positives, p.false_positives));
        }
    }
}
