//! Warning rule and track table: first threshold, hysteresis, minimum on-time, staleness, id reuse,
//! capacity policies, error cases, determinism.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use scorer_core::warning::{
    first_crossing, FirstThreshold, FullPolicy, TrackTable, WarningConfig, WarningError,
    WarningEvent,
};

const MS: u64 = 1_000;
const S: u64 = 1_000_000;

#[test]
fn first_threshold_warns_at_first_crossing_and_latches() {
    let scores = [0.1, 0.4, 0.69999, 0.7, 0.2, 0.9, f32::NAN];
    let mut rule = FirstThreshold::new(0.7);
    let on: Vec<bool> = scores.iter().map(|&r| rule.update(r)).collect();
    assert_eq!(on, [false, false, false, true, true, true, true]);
    assert_eq!(rule.first_warning(), Some(3));
    assert_eq!(rule.updates(), 7);
    assert_eq!(first_crossing(scores, 0.7), Some(3));
    assert_eq!(first_crossing(scores, 0.95), None);
    // Inclusive: a threshold equal to the sequence maximum warns (evaluation thresholds are maxima).
    assert_eq!(first_crossing(scores, 0.9), Some(5));
    rule.reset();
    assert!(!rule.is_warning());
    assert_eq!(rule.updates(), 0);
    // NaN never triggers; +inf does.
    let mut rule = FirstThreshold::new(0.5);
    assert!(!rule.update(f32::NAN));
    assert!(rule.update(f32::INFINITY));
    // Consistency with first_crossing on a pseudo-random sequence.
    let seq: Vec<f32> = (0..500)
        .map(|i| ((i * 7919 % 1000) as f32) / 1000.0)
        .collect();
    for t in [0.0, 0.3, 0.998, 0.999, 1.0] {
        let mut rule = FirstThreshold::new(t);
        for &r in &seq {
            rule.update(r);
        }
        assert_eq!(
            rule.first_warning().map(|i| i as usize),
            first_crossing(seq.iter().copied(), t)
        );
    }
}

#[test]
fn latched_table_follows_first_threshold_per_track() {
    let mut t = TrackTable::<4>::new(WarningConfig::first_threshold(0.5, 500 * MS)).unwrap();
    let a = t.update(1, 0, 0.2).unwrap();
    assert!(a.new_track && !a.warning && a.event == WarningEvent::None);
    let b = t.update(2, 0, 0.6).unwrap();
    assert_eq!(b.event, WarningEvent::Onset);
    let a = t.update(1, 100 * MS, 0.5).unwrap();
    assert_eq!(
        (a.warning, a.event, a.new_track),
        (true, WarningEvent::Onset, false)
    );
    // Latched: low scores do not release.
    for k in 2..5 {
        let a = t.update(1, k * 100 * MS, 0.0).unwrap();
        assert!(a.warning && a.event == WarningEvent::None);
    }
    let tr = t.get(1).unwrap();
    assert_eq!(tr.first_warning_us(), Some(100 * MS));
    assert_eq!((tr.onsets, tr.updates), (1, 5));
    assert!(t.is_warning(1, 400 * MS));
    let ids: Vec<u32> = t.warnings(400 * MS).map(|tr| tr.id).collect();
    assert_eq!(ids, [1, 2]); // insertion order
                             // Track 2 was last updated at 0: stale after 500 ms, while track 1 (updated at 400 ms) is not.
    let ids: Vec<u32> = t.warnings(600 * MS).map(|tr| tr.id).collect();
    assert_eq!(ids, [1]);
}

#[test]
fn live_mode_hysteresis_and_minimum_on_time() {
    let cfg = WarningConfig::live(0.6, 0.1, 300 * MS, S);
    let mut t = TrackTable::<2>::new(cfg).unwrap();
    let ev = |t: &mut TrackTable<2>, at: u64, r: f32| t.update(7, at * MS, r).unwrap().event;
    assert_eq!(ev(&mut t, 0, 0.65), WarningEvent::Onset);
    // Below the release level (0.5) but before the minimum on-time: stays on.
    assert_eq!(ev(&mut t, 100, 0.1), WarningEvent::None);
    assert!(t.is_warning(7, 100 * MS));
    // After the on-time, inside the hysteresis band (0.5 <= r < 0.6): stays on.
    assert_eq!(ev(&mut t, 300, 0.55), WarningEvent::None);
    assert_eq!(ev(&mut t, 350, 0.5), WarningEvent::None);
    // Below the band: released.
    assert_eq!(ev(&mut t, 400, 0.49), WarningEvent::Release);
    assert!(!t.is_warning(7, 400 * MS));
    // Inside the band again: no re-onset until r >= threshold.
    assert_eq!(ev(&mut t, 500, 0.59), WarningEvent::None);
    assert_eq!(ev(&mut t, 600, 0.6), WarningEvent::Onset);
    let tr = t.get(7).unwrap();
    assert_eq!(tr.onsets, 2);
    assert_eq!(tr.first_warning_us(), Some(0));
    assert_eq!(tr.on_since_us(), Some(600 * MS));
    // The minimum on-time counts from the new onset.
    assert_eq!(ev(&mut t, 800, 0.0), WarningEvent::None);
    assert_eq!(ev(&mut t, 900, 0.0), WarningEvent::Release);
}

#[test]
fn stale_tracks_never_warn_and_are_dropped() {
    let mut t = TrackTable::<4>::new(WarningConfig::first_threshold(0.5, 200 * MS)).unwrap();
    t.update(3, 0, 0.9).unwrap();
    assert!(t.is_warning(3, 200 * MS)); // exactly at the timeout: still fresh
    assert!(!t.is_warning(3, 200 * MS + 1)); // stale: not reported even before it is dropped
    assert!(!t.any_warning(200 * MS + 1));
    assert_eq!(t.warnings(300 * MS).count(), 0);
    assert_eq!(t.len(), 1);
    assert_eq!(t.expire(200 * MS + 1), 1);
    assert!(t.is_empty());
    // Dropped on update of another id too.
    t.update(3, S, 0.9).unwrap();
    t.update(4, S + 250 * MS, 0.1).unwrap();
    assert!(t.get(3).is_none());
    assert_eq!(t.len(), 1);
}

#[test]
fn reused_id_after_drop_starts_fresh() {
    let mut t = TrackTable::<4>::new(WarningConfig::first_threshold(0.5, 100 * MS)).unwrap();
    t.update(9, 0, 0.8).unwrap();
    assert!(t.is_warning(9, 50 * MS));
    // Same id, after the old track went stale: a new partner, no latched warning.
    let s = t.update(9, 500 * MS, 0.1).unwrap();
    assert!(s.new_track && !s.warning);
    let tr = t.get(9).unwrap();
    assert_eq!(
        (tr.created_us, tr.first_warning_us(), tr.updates),
        (500 * MS, None, 1)
    );
    // Explicit removal.
    t.update(9, 550 * MS, 0.9).unwrap();
    assert!(t.remove(9));
    assert!(!t.remove(9));
    let s = t.update(9, 560 * MS, 0.1).unwrap();
    assert!(s.new_track && !s.warning);
}

#[test]
fn full_table_reject_policy() {
    let mut cfg = WarningConfig::first_threshold(0.5, S);
    cfg.when_full = FullPolicy::Reject;
    let mut t = TrackTable::<2>::new(cfg).unwrap();
    t.update(1, 0, 0.1).unwrap();
    t.update(2, 0, 0.1).unwrap();
    assert_eq!(t.update(3, 10, 0.9), Err(WarningError::TableFull { id: 3 }));
    assert_eq!(t.len(), 2);
    // Existing ids still update.
    assert!(t.update(1, 20, 0.9).unwrap().warning);
    // Once a track is stale there is room again.
    assert!(t.update(3, 2 * S, 0.9).unwrap().new_track);
}

#[test]
fn full_table_evicts_least_recent_non_warning_track() {
    let mut t = TrackTable::<3>::new(WarningConfig::first_threshold(0.5, 10 * S)).unwrap();
    t.update(1, 0, 0.9).unwrap(); // warning, oldest
    t.update(2, 10, 0.1).unwrap();
    t.update(3, 20, 0.1).unwrap();
    t.update(2, 30, 0.1).unwrap(); // 3 is now the least recent non-warning track
    let s = t.update(4, 40, 0.2).unwrap();
    assert_eq!(s.evicted, Some(3));
    let ids: Vec<u32> = t.iter().map(|tr| tr.id).collect();
    assert_eq!(ids, [1, 2, 4]);
    // When every track warns, nothing is evicted and the new id is refused.
    t.update(2, 50, 0.9).unwrap();
    t.update(4, 50, 0.9).unwrap();
    assert_eq!(t.update(5, 60, 0.1), Err(WarningError::TableFull { id: 5 }));
    assert_eq!(t.len(), 3);
    assert_eq!(t.capacity(), 3);
}

#[test]
fn rejected_updates_change_nothing() {
    let mut t = TrackTable::<2>::new(WarningConfig::first_threshold(0.5, S)).unwrap();
    t.update(1, 100, 0.1).unwrap();
    let before = *t.get(1).unwrap();
    assert_eq!(
        t.update(1, 50, 0.9),
        Err(WarningError::OutOfOrder {
            id: 1,
            last_us: 100,
            now_us: 50
        })
    );
    assert_eq!(
        t.update(1, 200, f32::NAN),
        Err(WarningError::NonFiniteScore { id: 1 })
    );
    assert_eq!(*t.get(1).unwrap(), before);
    assert!(t.update(2, 200, f32::NAN).is_err());
    assert!(t.get(2).is_none());
    // Same timestamp twice is accepted (two partners reported in one frame, or a repeated frame).
    assert!(t.update(1, 100, 0.9).unwrap().warning);
}

/// `WarningError::NonFiniteScore` refuses NaN only: `+inf` and `-inf` are accepted updates
/// compared with the threshold as IEEE floats (the variant's documentation states this rule).
#[test]
fn infinite_scores_are_accepted_updates() {
    let (inf, ninf) = (f32::INFINITY, f32::NEG_INFINITY);
    let (none, onset, release) = (
        WarningEvent::None,
        WarningEvent::Onset,
        WarningEvent::Release,
    );
    let status = |t: &mut TrackTable<4>, id, now, r| {
        let s = t.update(id, now, r).unwrap();
        (s.warning, s.event, s.new_track)
    };

    // Live, warn at 2.0, release below 1.9 once on for 0.5 s, stale after 1 s.
    let mut t = TrackTable::<4>::new(WarningConfig::live(2.0, 0.1, 500 * MS, S)).unwrap();
    // -inf creates a track without warning; +inf turns it on.
    assert_eq!(status(&mut t, 1, 0, ninf), (false, none, true));
    assert_eq!(status(&mut t, 1, 100 * MS, inf), (true, onset, false));
    // +inf never releases, however long the warning has been on.
    assert_eq!(status(&mut t, 1, 900 * MS, inf), (true, none, false));
    // -inf releases once the minimum on-time is over (it was: on since 0.1 s).
    assert_eq!(status(&mut t, 1, 1_000 * MS, ninf), (false, release, false));
    let track = *t.get(1).unwrap();
    assert_eq!(track.last_update_us, 1_000 * MS);
    assert_eq!(track.last_score, ninf);
    assert_eq!((track.updates, track.onsets), (4, 1));
    // An infinite score keeps the track fresh (accepted), a NaN one does not move it.
    assert_eq!(
        t.update(1, 1_500 * MS, f32::NAN),
        Err(WarningError::NonFiniteScore { id: 1 })
    );
    assert_eq!(*t.get(1).unwrap(), track);
    // -inf within the minimum on-time holds the warning.
    assert_eq!(status(&mut t, 2, 0, inf), (true, onset, true));
    assert_eq!(status(&mut t, 2, 100 * MS, ninf), (true, none, false));

    // Latched: -inf never releases.
    let mut t = TrackTable::<4>::new(WarningConfig::first_threshold(2.0, S)).unwrap();
    assert_eq!(status(&mut t, 1, 0, inf), (true, onset, true));
    assert_eq!(status(&mut t, 1, 100 * MS, ninf), (true, none, false));

    // Infinite thresholds are refused by the config (`infinite_thresholds_are_refused`). At the
    // largest finite one, f32::MAX and +inf warn, and a lower score releases.
    let mut t = TrackTable::<4>::new(WarningConfig::live(f32::MAX, 0.0, 0, S)).unwrap();
    assert_eq!(status(&mut t, 1, 0, f32::MAX), (true, onset, true));
    assert_eq!(status(&mut t, 2, 0, 1.0), (false, none, true));
    assert_eq!(status(&mut t, 2, 1, inf), (true, onset, false));
    assert_eq!(status(&mut t, 2, 2, 1.0), (false, release, false));

    // The evaluation rule agrees: +inf triggers, -inf does not.
    let mut rule = FirstThreshold::new(2.0);
    assert!(!rule.update(ninf));
    assert!(rule.update(inf));
    assert_eq!(rule.first_warning(), Some(1));
}

#[test]
fn time_base_reset_makes_the_track_stale_and_restarts_it() {
    // Live mode, stale after 1 s: a warning on at t = 5000 s, then the clock restarts near 0.
    let mut t = TrackTable::<2>::new(WarningConfig::live(2.0, 0.05, 500 * MS, S)).unwrap();
    assert!(t.update(7, 5_000 * S, 9.0).unwrap().warning);
    // A step back within the stale window is out of order and the track stays fresh.
    assert!(matches!(
        t.update(7, 5_000 * S - S, 0.0),
        Err(WarningError::OutOfOrder { .. })
    ));
    assert!(t.is_warning(7, 5_000 * S - S));
    // Further back: the time base was reset. The track is stale (no warning reported, evictable)...
    assert!(!t.is_warning(7, 1_000));
    assert!(!t.any_warning(1_000));
    assert!(t.get(7).unwrap().is_stale(1_000, S));
    // ...and the next update drops it and starts a new track instead of OUT_OF_ORDER forever.
    let s = t.update(7, 1_000, 0.0).unwrap();
    assert!(s.new_track && !s.warning);
    assert_eq!(t.get(7).unwrap().created_us, 1_000);
    assert_eq!(t.len(), 1);
    assert!(t.update(7, 2_000, 0.0).is_ok());
}

#[test]
fn an_early_time_for_one_id_leaves_the_other_tracks_as_they_are() {
    // One update with a bogus early time (a delayed sensor, an uninitialised clock) must not clear
    // the table: only its own track, if it has one, starts afresh.
    let mut t = TrackTable::<4>::new(WarningConfig::live(2.0, 0.05, 500 * MS, S)).unwrap();
    assert!(t.update(1, 5_000 * S, 9.0).unwrap().warning);
    assert!(!t.update(2, 5_000 * S, 0.0).unwrap().warning);
    let s = t.update(3, 0, 0.0).unwrap();
    assert!(s.new_track && s.evicted.is_none());
    assert_eq!(t.len(), 3);
    assert!(t.is_warning(1, 5_000 * S + MS));
    // Reported at the early time, the tracks ahead of it are stale; they are not expired.
    assert!(!t.is_warning(1, 0));
    assert_eq!(t.expire(0), 0);
    // The clock goes on where it was: track 1 still warns and updates normally.
    let s = t.update(1, 5_000 * S + 100 * MS, 9.0).unwrap();
    assert!(s.warning && !s.new_track);
}

#[test]
fn invalid_configs_are_rejected() {
    assert!(matches!(
        TrackTable::<2>::new(WarningConfig::first_threshold(f32::NAN, S)),
        Err(WarningError::InvalidConfig(_))
    ));
    assert!(matches!(
        TrackTable::<2>::new(WarningConfig::live(0.5, -0.1, 0, S)),
        Err(WarningError::InvalidConfig(_))
    ));
    assert!(TrackTable::<2>::new(WarningConfig::live(0.5, 0.0, 0, u64::MAX)).is_ok());
}

/// The refusals of `invalid_configs_are_rejected`, through `validate` and `TrackTable::new` alike,
/// in both modes.
fn refused(cfg: WarningConfig) -> bool {
    let by_validate = matches!(cfg.validate(), Err(WarningError::InvalidConfig(_)));
    let by_new = matches!(
        TrackTable::<2>::new(cfg),
        Err(WarningError::InvalidConfig(_))
    );
    assert_eq!(by_validate, by_new, "{cfg:?}");
    by_validate
}

#[test]
fn zero_stale_window_is_refused() {
    // 0: every track is stale at the next tick, so no warning persists (riskscore_init refuses
    // it too).
    assert!(refused(WarningConfig::first_threshold(0.5, 0)));
    assert!(refused(WarningConfig::live(0.5, 0.1, 0, 0)));
    assert_eq!(
        WarningConfig::live(0.5, 0.1, 0, 0).validate(),
        Err(WarningError::InvalidConfig(
            "stale_after_us must be > 0 (u64::MAX: never stale)"
        ))
    );
    // The shortest window and "never" stay accepted.
    for stale in [1, S, u64::MAX] {
        assert!(!refused(WarningConfig::first_threshold(0.5, stale)));
        assert!(!refused(WarningConfig::live(0.5, 0.1, 0, stale)));
    }
    let mut t = TrackTable::<2>::new(WarningConfig::live(0.5, 0.0, 0, 1)).unwrap();
    assert!(t.update(1, 0, 1.0).unwrap().warning);
    assert!(t.is_warning(1, 1) && !t.is_warning(1, 2));
}

#[test]
fn infinite_thresholds_are_refused() {
    // +inf: no finite score ever warns; -inf: every partner warns and is never released.
    let bad = [f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
    let accepted: Vec<f32> = bad
        .into_iter()
        .filter(|&t| !refused(WarningConfig::first_threshold(t, S)))
        .chain(
            bad.into_iter()
                .filter(|&t| !refused(WarningConfig::live(t, 0.0, 0, S))),
        )
        .collect();
    assert!(accepted.is_empty(), "accepted thresholds: {accepted:?}");
    for threshold in bad {
        assert_eq!(
            WarningConfig::live(threshold, 0.0, 0, S).validate(),
            Err(WarningError::InvalidConfig(
                "threshold must be finite (NaN, +inf and -inf are refused)"
            ))
        );
    }
    // Every finite threshold stays accepted, the extremes included.
    for threshold in [0.5, -3.0, 0.0, f32::MAX, f32::MIN] {
        assert!(!refused(WarningConfig::first_threshold(threshold, S)));
        assert!(!refused(WarningConfig::live(threshold, 0.0, 0, 1)));
    }
}

#[test]
fn never_stale_with_max_timeout() {
    let mut t = TrackTable::<2>::new(WarningConfig::first_threshold(0.5, u64::MAX)).unwrap();
    t.update(1, 0, 0.9).unwrap();
    assert!(t.is_warning(1, u64::MAX));
    assert_eq!(t.expire(u64::MAX), 0);
}

#[test]
fn table_is_deterministic() {
    // The same update stream gives the same states and events, run after run.
    let run = || {
        let mut t =
            TrackTable::<8>::new(WarningConfig::live(0.55, 0.05, 150 * MS, 400 * MS)).unwrap();
        let mut log = Vec::new();
        let mut x: u64 = 42;
        for step in 0..5000u64 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let id = ((x >> 33) % 12) as u32;
            let r = ((x >> 20) % 1000) as f32 / 1000.0;
            let res = t.update(id, step * 20 * MS, r);
            log.push(format!("{res:?}"));
            log.push(format!(
                "{:?}",
                t.iter().map(|tr| (tr.id, tr.warning)).collect::<Vec<_>>()
            ));
        }
        log
    };
    assert_eq!(run(), run());
}

#[test]
fn release_level_that_overflows_is_refused() {
    // threshold - hysteresis is the live release level; when it overflows to -inf no score is
    // below it (not even -inf), so a warning could never be released.
    const WHY: &str = "threshold - hysteresis (the release level) must be finite, not -inf";
    for (threshold, hysteresis) in [(f32::MIN, f32::MAX), (-1.0e38, 3.0e38), (f32::MIN, 1.0e32)] {
        assert_eq!(threshold - hysteresis, f32::NEG_INFINITY);
        let live = WarningConfig::live(threshold, hysteresis, 0, S);
        assert!(refused(live), "{live:?}");
        assert_eq!(live.validate(), Err(WarningError::InvalidConfig(WHY)));
        // Refused latched too: the config is the same, whatever the mode.
        assert!(refused(WarningConfig {
            latch: true,
            ..live
        }));
    }
    // A finite release level stays accepted however extreme, and -inf releases the warning there.
    for (threshold, hysteresis) in [
        (2.0, f32::MAX),
        (f32::MAX, f32::MAX),
        (f32::MIN, 0.0),
        (f32::MIN, 1.0e30), // rounds back to f32::MIN
    ] {
        assert!((threshold - hysteresis).is_finite());
        let mut t = TrackTable::<2>::new(WarningConfig::live(threshold, hysteresis, 0, S)).unwrap();
        assert_eq!(
            t.update(1, 0, f32::INFINITY).unwrap().event,
            WarningEvent::Onset
        );
        assert_eq!(
            t.update(1, MS, f32::NEG_INFINITY).unwrap().event,
            WarningEvent::Release,
            "threshold {threshold}, hysteresis {hysteresis}"
        );
    }
}
