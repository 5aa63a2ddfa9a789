//! The scenario simulator: determinism, mix, labelling invariants checked independently on the
//! written-and-reloaded frames, kinematic consistency and diversity.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
use std::collections::BTreeSet;

use riskscore_data::events::{
    load_events, prepare_event, safe_rules_hold, Event, EventKind, EventSet, PrepareConfig,
};
use riskscore_data::sim::{simulate_events, simulate_to_dir, LabelRules, Mix, SimConfig};
use scorer_core::geometry::{box_distance, boxes_overlap};

fn cfg(seed: u64, events: usize, threads: usize) -> SimConfig {
    SimConfig {
        seed,
        events,
        threads,
        ..SimConfig::default()
    }
}

fn write_and_load(c: &SimConfig) -> (tempfile::TempDir, EventSet) {
    let dir = tempfile::tempdir().unwrap();
    let summary = simulate_to_dir(dir.path(), c).unwrap();
    assert_eq!(summary.counts.total(), c.events);
    let (set, issues) = load_events(dir.path()).unwrap();
    assert!(
        issues.is_empty(),
        "simulated folder has issues: {:#?}",
        &issues[..issues.len().min(5)]
    );
    assert_eq!(set.len(), c.events);
    (dir, set)
}

#[test]
fn same_seed_same_files_whatever_the_threads() {
    let (a, _) = write_and_load(&cfg(11, 48, 2));
    let (b, _) = write_and_load(&cfg(11, 48, 1));
    let (c, _) = write_and_load(&cfg(12, 48, 2));
    for f in ["events.csv", "frames.csv", "scenarios.csv"] {
        let fa = std::fs::read(a.path().join(f)).unwrap();
        let fb = std::fs::read(b.path().join(f)).unwrap();
        assert!(fa == fb, "{f} differs between runs with the same seed");
    }
    let fa = std::fs::read(a.path().join("frames.csv")).unwrap();
    let fc = std::fs::read(c.path().join("frames.csv")).unwrap();
    assert!(fa != fc, "different seeds gave identical frames");
}

#[test]
fn default_mix_resembles_100_car() {
    let c = Mix::default().counts(310);
    assert_eq!((c.crash, c.near_crash, c.safe), (70, 110, 130));
    let c = Mix::default().counts(1000);
    assert_eq!(c.total(), 1000);
    assert_eq!((c.crash, c.near_crash, c.safe), (226, 355, 419));
    let c = Mix {
        crash: 1.0,
        near_crash: 0.0,
        safe: 1.0,
    }
    .counts(7);
    assert_eq!((c.crash, c.near_crash, c.safe), (4, 0, 3));
}

fn check_kinematics(e: &Event) {
    assert!(e.frames.len() >= 21, "{}: {} frames", e.id, e.frames.len());
    assert_eq!(e.frames[0].time, e.t_start);
    assert_eq!(e.frames.last().unwrap().time, e.t_end);
    for w in e.frames.windows(2) {
        let dt = w[1].time - w[0].time;
        assert!((dt - 0.1).abs() < 1e-9, "{}: not 10 Hz ({dt})", e.id);
        for (a, b) in [(&w[0].ego, &w[1].ego), (&w[0].partner, &w[1].partner)] {
            // Positions advance with the mean velocity (trapezoid) to within a few cm.
            let ex = b.x - a.x - 0.05 * (a.vx + b.vx);
            let ey = b.y - a.y - 0.05 * (a.vy + b.vy);
            assert!(
                ex.hypot(ey) < 0.05,
                "{} t={}: position/velocity mismatch {ex} {ey}",
                e.id,
                w[1].time
            );
        }
    }
    for f in &e.frames {
        for s in [&f.ego, &f.partner] {
            assert!(s.is_finite());
            assert!(
                (s.hx.hypot(s.hy) - 1.0).abs() < 1e-5,
                "{}: heading not unit",
                e.id
            );
            let speed = s.speed();
            assert!(speed < 40.0, "{}: speed {speed}", e.id);
            // Heading consistent with the direction of motion (no side slip in the model).
            assert!(
                (s.hx * s.vy - s.hy * s.vx).abs() <= 1e-3 * speed.max(1.0),
                "{}: heading vs velocity",
                e.id
            );
            assert!(s.hx * s.vx + s.hy * s.vy >= -1e-3, "{}: reversing", e.id);
        }
        assert!(
            f.ego.acc > -10.0 && f.ego.acc < 4.5,
            "{}: ego acc {}",
            e.id,
            f.ego.acc
        );
    }
}

#[test]
fn labels_hold_on_the_written_frames() {
    let c = cfg(5, 120, 0);
    let (_d, set) = write_and_load(&c);
    let counts = set.counts();
    let want = c.mix.counts(120);
    assert_eq!(counts, want);
    let rules = LabelRules::default();
    let prep = PrepareConfig::default();
    for e in &set {
        check_kinematics(e);
        let overlaps: Vec<bool> = e
            .frames
            .iter()
            .map(|f| boxes_overlap(&f.ego, &f.partner))
            .collect();
        let gaps: Vec<f32> = e
            .frames
            .iter()
            .map(|f| box_distance(&f.ego, &f.partner))
            .collect();
        match e.kind {
            EventKind::Crash => {
                let t = e.t_impact.unwrap();
                let k = e
                    .frames
                    .iter()
                    .position(|f| f.time == t)
                    .expect("t_impact is a frame time");
                assert!(overlaps[k], "{}: no overlap at t_impact", e.id);
                assert!(
                    !overlaps[..k].iter().any(|&o| o),
                    "{}: overlap before t_impact",
                    e.id
                );
                assert!(
                    t - e.t_start >= 4.5 - 1e-9,
                    "{}: less than 4.5 s before impact",
                    e.id
                );
            }
            EventKind::NearCrash => {
                let t = e.t_impact.unwrap();
                assert!(
                    !overlaps.iter().any(|&o| o),
                    "{}: near-crash with contact",
                    e.id
                );
                let min = gaps.iter().cloned().fold(f32::INFINITY, f32::min);
                assert!(min < rules.near_crash_gap, "{}: min gap {min}", e.id);
                let k = gaps.iter().position(|&g| g == min).unwrap();
                assert_eq!(
                    e.frames[k].time, t,
                    "{}: endpoint is not the closest approach",
                    e.id
                );
                assert!(t - e.t_start >= 4.5 - 1e-9);
                let evasive = e.frames.iter().enumerate().any(|(i, f)| {
                    let lat =
                        |get: fn(&riskscore_data::events::Frame) -> &scorer_core::VehicleState| {
                            let (a, b) = (i.saturating_sub(1), (i + 1).min(e.frames.len() - 1));
                            let (sa, sb, s) = (get(&e.frames[a]), get(&e.frames[b]), get(f));
                            let dt = (e.frames[b].time - e.frames[a].time) as f32;
                            (s.hx * (sb.vy - sa.vy) - s.hy * (sb.vx - sa.vx)).abs() / dt
                        };
                    f.time <= t + 1e-9
                        && f.time >= t - rules.evasive_window - 1e-9
                        && (-f.ego.acc >= rules.evasive_decel
                            || -f.partner.acc >= rules.evasive_decel
                            || lat(|f| &f.ego) >= rules.evasive_lat_acc
                            || lat(|f| &f.partner) >= rules.evasive_lat_acc)
                });
                assert!(evasive, "{}: near-crash without an evasive manoeuvre", e.id);
            }
            EventKind::Safe => {
                assert!(e.t_impact.is_none());
                assert!(!overlaps.iter().any(|&o| o), "{}: safe with contact", e.id);
                assert!(
                    safe_rules_hold(&e.frames, &prep),
                    "{}: safe rules violated",
                    e.id
                );
                let s = prepare_event(e, &prep).unwrap();
                assert_eq!(
                    s.frames.len(),
                    e.frames.len(),
                    "{}: safe event not calm throughout",
                    e.id
                );
            }
        }
    }
}

#[test]
fn default_set_is_diverse() {
    let (set, sims, summary) = simulate_events(&SimConfig::default()).unwrap();
    let c = set.counts();
    assert_eq!((c.crash, c.near_crash, c.safe), (70, 110, 130));
    eprintln!(
        "default set: {c}; {} scenarios drawn; rejections {:?}",
        summary.attempts, summary.rejections
    );
    for (f, k) in &summary.families {
        eprintln!("  {f:<17} {k}");
    }
    let families: BTreeSet<&str> = sims.iter().map(|s| s.family.name()).collect();
    assert!(families.len() >= 8, "{families:?}");
    for kind in EventKind::ALL {
        let fams: BTreeSet<&str> = sims
            .iter()
            .filter(|s| s.event.kind == kind)
            .map(|s| s.family.name())
            .collect();
        assert!(fams.len() >= 5, "{kind}: only {fams:?}");
    }
    let classes: BTreeSet<&str> = sims.iter().map(|s| s.classes[1].name()).collect();
    assert!(classes.len() == 4, "partner classes {classes:?}");
    let lengths: Vec<f32> = set.iter().map(|e| e.dims.length_partner).collect();
    assert!(lengths.iter().any(|&l| l > 7.0) && lengths.iter().any(|&l| l < 2.5));
    // Speeds and closest approaches spread widely.
    let speeds: Vec<f32> = set.iter().map(|e| e.frames[0].ego.speed()).collect();
    let (lo, hi) = speeds
        .iter()
        .fold((f32::MAX, 0.0f32), |(a, b), &s| (a.min(s), b.max(s)));
    assert!(lo < 8.0 && hi > 22.0, "ego speeds {lo}..{hi}");
    // Safe events include close interactions (gap under 3 m), so proximity alone is not risk.
    let close_safe = sims
        .iter()
        .filter(|s| s.event.kind == EventKind::Safe && s.measures.min_gap < 3.0)
        .count();
    assert!(close_safe >= 5, "only {close_safe} close safe interactions");
}
