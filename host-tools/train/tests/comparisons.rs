//! Comparison construction: temporal ordering, training-partition only, determinism, weights, and
//! physics counterfactuals that scorer-core agrees are riskier.
use riskscore_data::events::Sequence;
use riskscore_train::comparisons::{self, physics, ComparisonConfig, RowOrigin, Source};

mod common;
use common::{car, conflict, following};

/// Steady following at a comfortable gap, possibly in the next lane.
fn safe(id: usize) -> Sequence {
    let v = 12.0 + id as f32 % 7.0;
    let gap = 25.0 + 3.0 * (id % 5) as f32;
    let lateral = if id.is_multiple_of(2) { 0.0 } else { 3.5 };
    following(id, v, gap, lateral)
}

fn dataset() -> Vec<Sequence> {
    let mut v = Vec::new();
    for i in 0..12 {
        v.push(conflict(i, 5.0 + i as f32 * 0.6, 0.1 * (i % 6) as f32));
        v.push(safe(i));
    }
    v
}

fn small_config() -> ComparisonConfig {
    let mut c = ComparisonConfig::default();
    c.temporal.pairs = 600;
    c.cross_sequence.pairs = 600;
    c.physics.pairs = 400;
    c.simulation.pairs = 300;
    c
}

fn frame_of(set: &comparisons::ComparisonSet, row: u32) -> (bool, usize, usize) {
    match set.table.origins[row as usize] {
        RowOrigin::Frame {
            augmentation,
            sequence,
            frame,
        } => (augmentation, sequence as usize, frame as usize),
        other => panic!("row {row} is not a frame: {other:?}"),
    }
}

#[test]
fn temporal_pairs_are_ordered_within_one_conflict_sequence() {
    let seqs = dataset();
    let cfg = small_config();
    let set = comparisons::build(&seqs, None, &cfg, 7);
    let temporal: Vec<_> = set
        .pairs
        .iter()
        .filter(|p| p.source == Source::Temporal)
        .collect();
    assert_eq!(temporal.len(), 600);
    let mut weight_sum = 0.0f64;
    for p in &temporal {
        let (_, sw, fw) = frame_of(&set, p.winner);
        let (_, sl, fl) = frame_of(&set, p.loser);
        assert_eq!(sw, sl, "temporal pair across sequences");
        let s = &seqs[sw];
        let endpoint = s
            .conflict_endpoint()
            .expect("temporal pairs come from conflict sequences");
        let (t2, t1) = (s.frames[fw].time, s.frames[fl].time);
        assert!(
            t1 < t2 && t2 <= endpoint + 1e-9,
            "t1 {t1} t2 {t2} endpoint {endpoint}"
        );
        let dt = t2 - t1;
        assert!(
            dt >= cfg.temporal.dmin - 1e-9 && dt <= cfg.temporal.dmax + 1e-9,
            "dt {dt}"
        );
        weight_sum += p.weight as f64;
    }
    // a_i is the time-to-impact difference normalised by its mean: mean 1, proportional to dt.
    assert!((weight_sum / temporal.len() as f64 - 1.0).abs() < 1e-4);
    let ratio = |p: &&comparisons::Pair| {
        let (_, s, fw) = frame_of(&set, p.winner);
        let (_, _, fl) = frame_of(&set, p.loser);
        p.weight as f64 / (seqs[s].frames[fw].time - seqs[s].frames[fl].time)
    };
    let r0 = ratio(&temporal[0]);
    for p in &temporal {
        assert!((ratio(p) - r0).abs() < 1e-3 * r0);
    }
}

#[test]
fn cross_sequence_pairs_put_a_conflict_frame_over_a_safe_frame() {
    let seqs = dataset();
    let set = comparisons::build(&seqs, None, &small_config(), 7);
    let cross: Vec<_> = set
        .pairs
        .iter()
        .filter(|p| p.source == Source::CrossSequence)
        .collect();
    assert_eq!(cross.len(), 600);
    let mut conflict_events = std::collections::BTreeSet::new();
    for p in cross {
        let (_, sw, fw) = frame_of(&set, p.winner);
        let (_, sl, _) = frame_of(&set, p.loser);
        assert!(seqs[sw].is_conflict());
        assert!(!seqs[sl].is_conflict());
        assert!(seqs[sw].frames[fw].time <= seqs[sw].conflict_endpoint().unwrap() + 1e-9);
        assert_eq!(p.weight, 1.0);
        conflict_events.insert(sw);
    }
    // Uniform over events: with 600 draws every one of the 12 conflict events appears.
    assert_eq!(conflict_events.len(), 12);
}

#[test]
fn only_the_sequences_passed_in_are_used() {
    let all = dataset();
    // Hold out every third event as "test": the build never sees them.
    let train: Vec<Sequence> = all
        .iter()
        .enumerate()
        .filter(|(i, _)| i % 3 != 0)
        .map(|(_, s)| s.clone())
        .collect();
    let held: std::collections::BTreeSet<String> = all
        .iter()
        .enumerate()
        .filter(|(i, _)| i % 3 == 0)
        .map(|(_, s)| s.event_id.clone())
        .collect();
    let set = comparisons::build(&train, None, &small_config(), 3);
    assert!(!set.pairs.is_empty());
    for origin in &set.table.origins {
        if let RowOrigin::Frame { sequence, .. } = origin {
            let id = &train[*sequence as usize].event_id;
            assert!(!held.contains(id), "held-out event {id} used");
        }
    }
    // Anchors come from training conflict sequences only, inside / before the impact window, and
    // never after the endpoint (the fixtures run 0.5 s past it, when a near-crash pair opens).
    assert!(train.iter().any(|s| s
        .conflict_endpoint()
        .is_some_and(|e| s.frames.iter().any(|f| f.time > e + 0.05))));
    for &row in &set.anchors.impact {
        let (_, s, f) = frame_of(&set, row);
        let endpoint = train[s].conflict_endpoint().unwrap();
        let t = train[s].frames[f].time;
        assert!(
            t <= endpoint + 1e-6,
            "impact anchor {t} after endpoint {endpoint}"
        );
        assert!(endpoint - t <= 0.2 + 1e-9);
    }
    for &row in &set.anchors.upper {
        let (_, s, f) = frame_of(&set, row);
        assert!(train[s].frames[f].time < train[s].conflict_endpoint().unwrap() - 0.2);
    }
    assert!(!set.anchors.impact.is_empty() && !set.anchors.upper.is_empty());
}

#[test]
fn construction_is_deterministic_and_seeded() {
    let seqs = dataset();
    let aug: Vec<Sequence> = dataset().into_iter().rev().collect();
    let a = comparisons::build(&seqs, Some(&aug), &small_config(), 11);
    let b = comparisons::build(&seqs, Some(&aug), &small_config(), 11);
    let c = comparisons::build(&seqs, Some(&aug), &small_config(), 12);
    assert_eq!(a.pairs, b.pairs);
    assert_eq!(a.table.features, b.table.features);
    assert_eq!(a.anchors, b.anchors);
    assert_ne!(a.pairs, c.pairs);
    // Sources are independent streams: dropping physics leaves the temporal pairs unchanged.
    let d = comparisons::build(
        &seqs,
        Some(&aug),
        &small_config().restricted_to(&[Source::Temporal]),
        11,
    );
    let rows = |s: &comparisons::ComparisonSet| -> Vec<_> {
        s.pairs
            .iter()
            .filter(|p| p.source == Source::Temporal)
            .map(|p| {
                (
                    s.table.origins[p.winner as usize],
                    s.table.origins[p.loser as usize],
                    p.weight,
                )
            })
            .collect()
    };
    assert_eq!(rows(&a), rows(&d));
    assert_eq!(d.pairs_of(Source::Physics), 0);
}

#[test]
fn augmentation_pairs_come_from_the_second_folder_and_are_tagged() {
    let seqs = dataset();
    let aug = dataset();
    let set = comparisons::build(&seqs, Some(&aug), &small_config(), 5);
    let sim: Vec<_> = set
        .pairs
        .iter()
        .filter(|p| p.source == Source::Simulation)
        .collect();
    assert!(sim.len() >= 290, "{}", sim.len());
    for p in &sim {
        // Every recorded frame of a pair (both rows, or the one a counterfactual is made of).
        for row in [p.winner, p.loser] {
            match set.table.origins[row as usize] {
                RowOrigin::Frame { augmentation, .. } => assert!(augmentation),
                RowOrigin::Counterfactual { of } => assert!(of == p.winner || of == p.loser),

                other => panic!("unexpected origin {other:?}"),
            }
        }
    }
    // No augmentation folder: no simulation pairs even with a non-zero target.
    let none = comparisons::build(&seqs, None, &small_config(), 5);
    assert_eq!(none.pairs_of(Source::Simulation), 0);
}

/// Checks every physics pair of `set` against the core and returns how many are lane shifts.
fn check_physics_pairs(set: &comparisons::ComparisonSet) -> usize {
    let phys: Vec<_> = set
        .pairs
        .iter()
        .filter(|p| p.source == Source::Physics)
        .collect();
    assert_eq!(phys.len(), 400);
    let mut strictly_ordered = 0;
    let mut lane_shifts = 0;
    for p in &phys {
        let counterfactual = if set.table.origins[p.winner as usize]
            == (RowOrigin::Counterfactual { of: p.loser })
        {
            p.winner
        } else {
            // A lane shift: the recorded frame wins over its partner moved a lane aside.
            assert_eq!(
                set.table.origins[p.loser as usize],
                RowOrigin::Counterfactual { of: p.winner }
            );
            lane_shifts += 1;
            p.loser
        };
        let c = set.table.surrogates[counterfactual as usize];
        assert!(c.box_distance > 0.0, "counterfactual in contact");
        let w = set.table.surrogates[p.winner as usize];
        let l = set.table.surrogates[p.loser as usize];
        assert!(w.box_distance <= l.box_distance + 1e-5);
        assert!(w.ttc2d <= l.ttc2d * (1.0 + 1e-4) + 1e-4 || w.ttc2d <= l.ttc2d);
        assert!(w.tadv <= l.tadv * (1.0 + 1e-4) + 1e-4 || w.tadv <= l.tadv);
        assert!(w.ei >= l.ei - 1e-4 * (1.0 + l.ei.abs()) || w.ei >= l.ei);
        if w.box_distance < l.box_distance {
            strictly_ordered += 1;
        }
    }
    // Gap and size pairs (and lane shifts) order the box distance strictly; the kinds take turns.
    let (strict, kinds) = if lane_shifts > 0 { (3, 5) } else { (2, 4) };
    assert!(
        strictly_ordered >= phys.len() * strict / kinds,
        "{strictly_ordered}"
    );
    let mean = phys.iter().map(|p| p.weight as f64).sum::<f64>() / phys.len() as f64;
    assert!((mean - 1.0).abs() < 1e-3, "{mean}");
    lane_shifts
}

#[test]
fn physics_counterfactuals_are_riskier_per_the_core() {
    let seqs = dataset();
    let cfg = small_config();
    assert_eq!(cfg.physics.lane_shift, None, "lane shifts are opt-in");
    let set = comparisons::build(&seqs, None, &cfg, 9);
    assert_eq!(check_physics_pairs(&set), 0);
}

#[test]
fn lane_shift_pairs_put_the_recorded_frame_over_the_partner_a_lane_aside() {
    let seqs = dataset();
    let mut cfg = small_config();
    cfg.physics.lane_shift = Some([2.5, 4.0]);
    let set = comparisons::build(&seqs, None, &cfg, 9);
    // The kinds take turns: a fifth of the pairs are lane shifts.
    assert_eq!(check_physics_pairs(&set), 400 / 5);
}

#[test]
fn each_perturbation_changes_its_variable_in_the_risky_direction() {
    let mut cfg = ComparisonConfig::default().physics;
    cfg.lane_shift = Some([2.5, 4.0]);
    let ego = car(0.0, 0.0, 15.0);
    let partner = car(20.0, 1.0, 10.0);
    let before = scorer_core::surrogates(&ego, &partner);
    for kind in physics::Perturbation::ALL {
        let cf = physics::perturb(&ego, &partner, kind, 0.5, &cfg).expect("admissible");
        let after = scorer_core::surrogates(&ego, &cf.partner);
        assert!(cf.magnitude > 0.0);
        assert!(
            physics::order_holds(&ego, &partner, &cf, &before, &after, &cfg),
            "{kind:?}"
        );
        match kind {
            physics::Perturbation::Gap => assert!(after.box_distance < before.box_distance),
            physics::Perturbation::ClosingSpeed => {
                assert!(cf.partner.vx < partner.vx);
                assert!(after.ttc2d < before.ttc2d);
            }
            physics::Perturbation::LateralClearance => {
                assert!(cf.partner.y.abs() < partner.y.abs())
            }
            physics::Perturbation::Size => {
                assert!(cf.partner.length > partner.length && cf.partner.width > partner.width);
                assert!(after.box_distance < before.box_distance);
            }
            physics::Perturbation::LaneShift => {
                // Away from the ego's axis on the partner's own side (left here), by a lane width.
                let moved = cf.partner.y - partner.y;
                assert!((2.5..=4.0).contains(&moved), "{moved}");
                assert!(after.box_distance > before.box_distance);
                assert!(after.tadv >= before.tadv && after.ei <= before.ei);
            }
        }
    }
    // A state in contact admits no gap counterfactual.
    let touching = car(4.5, 0.0, 10.0);
    assert!(physics::perturb(&ego, &touching, physics::Perturbation::Gap, 0.5, &cfg).is_none());
}

#[test]
fn a_partner_on_the_ego_axis_is_shifted_to_either_side_across_the_range() {
    let mut cfg = ComparisonConfig::default().physics;
    let ego = car(0.0, 0.0, 15.0);
    let ahead = car(20.0, 0.0, 10.0);
    let kind = physics::Perturbation::LaneShift;
    assert!(
        physics::perturb(&ego, &ahead, kind, 0.3, &cfg).is_none(),
        "opt-in"
    );
    cfg.lane_shift = Some([2.5, 4.0]);
    let shift = |u: f32| {
        let cf = physics::perturb(&ego, &ahead, physics::Perturbation::LaneShift, u, &cfg)
            .expect("admissible");
        assert!((cf.partner.y.abs() - cf.magnitude).abs() < 1e-5);
        cf.partner.y
    };
    let [lo, hi] = [2.5, 4.0];
    assert!((shift(0.0) - lo).abs() < 1e-5 && (shift(0.4999) - hi).abs() < 1e-3);
    assert!((shift(0.5) + lo).abs() < 1e-5 && (shift(0.9999) + hi).abs() < 1e-3);
    // The shifted state is safer by every surrogate, so the recorded one wins the pair.
    let cf = physics::perturb(&ego, &ahead, physics::Perturbation::LaneShift, 0.3, &cfg).unwrap();
    let before = scorer_core::surrogates(&ego, &ahead);
    let after = scorer_core::surrogates(&ego, &cf.partner);
    assert!(physics::order_holds(
        &ego, &ahead, &cf, &before, &after, &cfg
    ));
    // The same move read as "riskier" (a kind whose counterfactual wins) does not hold.
    let as_riskier = physics::Counterfactual {
        kind: physics::Perturbation::LateralClearance,
        ..cf
    };
    assert!(!physics::order_holds(
        &ego,
        &ahead,
        &as_riskier,
        &before,
        &after,
        &cfg
    ));
}

#[test]
fn build_statistics_report_rates() {
    let seqs = dataset();
    let set = comparisons::build(&seqs, None, &small_config(), 1);
    assert_eq!(set.stats.pairs(), set.pairs.len());
    assert_eq!(set.stats.observations, set.table.len());
    assert!(set.stats.pairs_per_second() > 0.0);
    for (source, s) in &set.stats.per_source {
        assert!(s.built <= s.requested, "{source:?}");
    }
}

/// The test data set with every safe sequence closing in and opening again, so that its closest
/// approach is one inner frame.
fn safe_sequences_closing_in_and_opening() -> Vec<Sequence> {
    let mut seqs = dataset();
    for s in seqs.iter_mut().filter(|s| !s.is_conflict()) {
        let n = s.frames.len();
        for (k, p) in s.frames.iter_mut().map(|f| &mut f.partner).enumerate() {
            p.x -= 20.0 * (1.0 - (k as f32 - n as f32 / 2.0).abs() / (n as f32 / 2.0));
        }
    }
    seqs
}

/// Index of the frame with the smallest box gap (per scorer-core).
fn closest_frame(s: &Sequence) -> usize {
    (0..s.len())
        .min_by(|&a, &b| {
            scorer_core::box_distance(&s.frames[a].ego, &s.frames[a].partner).total_cmp(
                &scorer_core::box_distance(&s.frames[b].ego, &s.frames[b].partner),
            )
        })
        .unwrap()
}

/// Cross-sequence pairs with `closest_fraction = 1` always use the safe sequence's closest approach
/// (smallest box gap per scorer-core); with 0, uniform frames (and the closest one only by chance).
#[test]
fn cross_sequence_safe_frames_at_closest_approach() {
    let seqs = safe_sequences_closing_in_and_opening();
    let at_closest = |fraction: f64| {
        let mut c = small_config();
        c.cross_sequence.closest_fraction = fraction;
        c.cross_sequence.closest_window = 0.0;
        let set = comparisons::build(&seqs, None, &c, 5);
        let cross: Vec<_> = set
            .pairs
            .iter()
            .filter(|p| p.source == Source::CrossSequence)
            .collect();
        assert!(!cross.is_empty());
        let hits = cross
            .iter()
            .filter(|p| {
                let (_, s, f) = frame_of(&set, p.loser);
                assert!(!seqs[s].is_conflict());
                f == closest_frame(&seqs[s])
            })
            .count();
        hits as f64 / cross.len() as f64
    };
    assert_eq!(at_closest(1.0), 1.0);
    assert!(at_closest(0.0) < 0.2);
}

/// With `closest_window = w` the safe frames of cross-sequence pairs come from the `w` seconds
/// that end at the closest approach: never after it, never earlier, and spread over the stretch.
#[test]
fn cross_sequence_safe_frames_from_the_approach_window() {
    let seqs = safe_sequences_closing_in_and_opening();
    let window = 0.5;
    let mut c = small_config();
    c.cross_sequence.closest_fraction = 1.0;
    c.cross_sequence.closest_window = window;
    let set = comparisons::build(&seqs, None, &c, 5);
    let mut before_closest = std::collections::BTreeSet::new();
    for p in set
        .pairs
        .iter()
        .filter(|p| p.source == Source::CrossSequence)
    {
        let (_, s, f) = frame_of(&set, p.loser);
        let seq = &seqs[s];
        let k = closest_frame(seq);
        assert!(f <= k, "safe frame {f} after the closest approach {k}");
        assert!(
            seq.frames[k].time - seq.frames[f].time <= window + 1e-9,
            "safe frame {f} is {} s before the closest approach",
            seq.frames[k].time - seq.frames[f].time
        );
        before_closest.insert(k - f);
    }
    assert!(
        before_closest.len() > 2,
        "frames spread over the window: {before_closest:?}"
    );
    c.cross_sequence.closest_window = -1.0;
    assert!(c.validate().is_err(), "a negative window is refused");
}
