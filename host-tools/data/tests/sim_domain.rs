//! The operating-domain families: each produces its outcome classes by physics, stays in the
//! speeds and geometry it advertises (docs/simulator.md), never shows an overlap before the impact
//! frame, is deterministic per seed and family mix; and the `domain` mix covers the operating
//! domain of issue #18 (speed bands, relative speeds, geometries; docs/simulator.md).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
use std::collections::BTreeMap;

use riskscore_data::events::{Event, EventKind, Frame};
use riskscore_data::sim::{
    simulate_events, simulate_to_dir, Family, FamilyMix, SimConfig, SimulatedEvent,
};
use scorer_core::geometry::{box_distance, boxes_overlap};

fn run(families: &str, seed: u64, events: usize) -> Vec<SimulatedEvent> {
    let cfg = SimConfig {
        seed,
        events,
        families: families.parse().unwrap(),
        ..SimConfig::default()
    };
    let (_, sims, summary) = simulate_events(&cfg).unwrap();
    assert_eq!(summary.counts.total(), events);
    sims
}

fn speed(s: &scorer_core::VehicleState) -> f32 {
    s.vx.hypot(s.vy)
}

/// Angle between the two headings (degrees, 0-180).
fn relative_heading(f: &Frame) -> f32 {
    let dot = f.ego.hx * f.partner.hx + f.ego.hy * f.partner.hy;
    dot.clamp(-1.0, 1.0).acos().to_degrees()
}

/// The partner's position in the ego frame: (longitudinal ahead, lateral left).
fn relative_position(f: &Frame) -> (f32, f32) {
    let (dx, dy) = (f.partner.x - f.ego.x, f.partner.y - f.ego.y);
    (
        dx * f.ego.hx + dy * f.ego.hy,
        -dx * f.ego.hy + dy * f.ego.hx,
    )
}

/// The frame a sequence is judged at: the impact or closest approach of a conflict, the closest
/// approach of a safe event.
fn endpoint(e: &Event) -> usize {
    match e.t_impact {
        Some(t) => e
            .frames
            .iter()
            .position(|f| (f.time - t).abs() < 1e-6)
            .unwrap(),
        None => (0..e.frames.len())
            .min_by(|&a, &b| {
                let d = |i: usize| box_distance(&e.frames[i].ego, &e.frames[i].partner);
                d(a).total_cmp(&d(b))
            })
            .unwrap(),
    }
}

fn of_family(sims: &[SimulatedEvent], family: Family) -> Vec<&SimulatedEvent> {
    sims.iter().filter(|s| s.family == family).collect()
}

/// Every requested outcome class of a single-family run was produced (the simulator only keeps
/// what the physics produced, so each class occurred), and nothing overlaps before the impact.
fn check_outcomes_and_no_early_overlap(sims: &[SimulatedEvent]) {
    let mut kinds = BTreeMap::new();
    for s in sims {
        *kinds.entry(s.event.kind.to_string()).or_insert(0) += 1;
        let e = &s.event;
        let last_free = match e.kind {
            EventKind::Crash => e.frames.len() - 1,
            _ => e.frames.len(),
        };
        for f in &e.frames[..last_free] {
            assert!(
                !boxes_overlap(&f.ego, &f.partner),
                "{} {}: overlap at {} before the impact",
                s.family.name(),
                e.id,
                f.time
            );
        }
        if e.kind == EventKind::Crash {
            let f = &e.frames[e.frames.len() - 1];
            assert!(boxes_overlap(&f.ego, &f.partner));
        }
    }
    assert_eq!(kinds.len(), 3, "{kinds:?}");
}

#[test]
fn motorway_families_run_at_motorway_speeds_on_motorway_lanes() {
    for (name, family) in [
        ("motorway_approach", Family::MotorwayApproach),
        ("motorway_cut_in", Family::MotorwayCutIn),
    ] {
        let sims = run(name, 5, 40);
        check_outcomes_and_no_early_overlap(&sims);
        let mut max_dv: f32 = 0.0;
        let mut ego_in_band = 0;
        let family_sims = of_family(&sims, family);
        for s in &family_sims {
            let e = &s.event;
            let first = &e.frames[0];
            let end = &e.frames[endpoint(e)];
            for v in [speed(&first.ego), speed(&first.partner)] {
                assert!(
                    (25.5..=50.0).contains(&v),
                    "{name} {}: starts at {v} m/s",
                    e.id
                );
            }
            // The conflict happens at motorway speed: the faster vehicle is still above 25 m/s
            // (the slower one may have braked hard by then).
            let faster = speed(&end.ego).max(speed(&end.partner));
            assert!(
                (25.0..=50.5).contains(&faster),
                "{name} {}: {faster} m/s",
                e.id
            );
            if (25.0..=50.5).contains(&speed(&end.ego)) {
                ego_in_band += 1;
            }
            max_dv = max_dv.max((speed(&first.ego) - speed(&first.partner)).abs());
            assert!(relative_heading(first) < 1.0, "{name}: same direction");
            let lateral = relative_position(first).1.abs();
            let expected = if family == Family::MotorwayCutIn {
                3.5..=3.75
            } else {
                0.0..=0.01
            };
            assert!(
                expected.contains(&lateral),
                "{name} {}: lateral offset {lateral}",
                e.id
            );
        }
        assert!(
            ego_in_band * 10 >= family_sims.len() * 9,
            "{name}: ego at 25-50 m/s at the endpoint in {ego_in_band} of {}",
            family_sims.len()
        );
        assert!(max_dv > 15.0, "{name}: largest speed difference {max_dv}");
    }
}

#[test]
fn queues_stay_slow_and_stand_at_queue_gaps() {
    let sims = run("signal_queue", 6, 50);
    check_outcomes_and_no_early_overlap(&sims);
    let mut standing_gaps = Vec::new();
    for s in &sims {
        let e = &s.event;
        for f in &e.frames {
            for v in [speed(&f.ego), speed(&f.partner)] {
                assert!(v <= 15.01, "{}: {v} m/s in a queue", e.id);
            }
            let same_lane = relative_position(f).1.abs() < 1.0;
            if e.kind == EventKind::Safe
                && same_lane
                && speed(&f.ego) < 0.3
                && speed(&f.partner) < 0.3
            {
                standing_gaps.push(box_distance(&f.ego, &f.partner));
            }
        }
    }
    standing_gaps.sort_by(f32::total_cmp);
    eprintln!(
        "standing gaps: {} frames, quartiles {:?}",
        standing_gaps.len(),
        [1, 2, 3].map(|q| standing_gaps.get(standing_gaps.len() * q / 4))
    );
    assert!(
        standing_gaps.len() > 50,
        "queues stand: {}",
        standing_gaps.len()
    );
    let median = standing_gaps[standing_gaps.len() / 2];
    assert!(
        (1.5..=4.0).contains(&median),
        "median standstill gap {median}"
    );
    assert!(
        standing_gaps[0] > 0.5,
        "closest standing gap {}",
        standing_gaps[0]
    );
}

#[test]
fn junction_partners_cross_or_come_from_ahead() {
    let sims = run("signal_crossing", 7, 40);
    check_outcomes_and_no_early_overlap(&sims);
    for s in &sims {
        let e = &s.event;
        let rel = relative_heading(&e.frames[endpoint(e)]);
        assert!((45.0..=135.0).contains(&rel), "{}: {rel} deg", e.id);
        let first = relative_heading(&e.frames[0]);
        assert!((75.0..=105.0).contains(&first), "{}: {first} deg", e.id);
    }
    let sims = run("signal_left_turn", 8, 40);
    check_outcomes_and_no_early_overlap(&sims);
    for s in &sims {
        let e = &s.event;
        let max_rel = e.frames.iter().map(relative_heading).fold(0.0, f32::max);
        assert!(max_rel > 150.0, "{}: oncoming at most {max_rel} deg", e.id);
    }
    let sims = run("signal_right_turn", 9, 40);
    check_outcomes_and_no_early_overlap(&sims);
    for s in &sims {
        let e = &s.event;
        let rel = relative_heading(&e.frames[0]);
        assert!(
            (85.0..=95.0).contains(&rel),
            "{}: {rel} deg before the turn",
            e.id
        );
    }
}

#[test]
fn roadside_objects_stand_beside_a_straight_lane_and_benign_passes_keep_3_m() {
    let sims = run("roadside_object", 10, 150);
    check_outcomes_and_no_early_overlap(&sims);
    let mut ego_speeds = Vec::new();
    for s in &sims {
        let e = &s.event;
        assert!(e.frames.iter().all(|f| speed(&f.partner) == 0.0));
        ego_speeds.push(speed(&e.frames[0].ego));
        if e.kind == EventKind::Safe {
            let passed = e
                .frames
                .iter()
                .any(|f| relative_position(f).0 < -0.5 * (f.ego.length + f.partner.length));
            assert!(passed, "{}: the ego drives past the object", e.id);
            for f in &e.frames {
                assert!(relative_heading(f) < 30.0 || relative_heading(f) > 150.0);
                let clearance = box_distance(&f.ego, &f.partner);
                assert!(clearance >= 3.0, "{}: {clearance} m", e.id);
                assert!(f.ego.hx == e.frames[0].ego.hx && f.ego.hy == e.frames[0].ego.hy);
            }
        }
    }
    ego_speeds.sort_by(f32::total_cmp);
    assert!(ego_speeds[0] >= 5.0 && ego_speeds[ego_speeds.len() - 1] <= 50.0);
    assert!(ego_speeds[0] < 15.0 && ego_speeds[ego_speeds.len() - 1] > 40.0);
}

#[test]
fn same_seed_and_families_same_files() {
    let cfg = |threads| SimConfig {
        seed: 21,
        events: 40,
        threads,
        families: FamilyMix::named("domain").unwrap(),
        ..SimConfig::default()
    };
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    simulate_to_dir(a.path(), &cfg(2)).unwrap();
    simulate_to_dir(b.path(), &cfg(1)).unwrap();
    for f in ["events.csv", "frames.csv", "scenarios.csv"] {
        let (fa, fb) = (
            std::fs::read(a.path().join(f)).unwrap(),
            std::fs::read(b.path().join(f)).unwrap(),
        );
        assert!(fa == fb, "{f} differs between runs with the same seed");
    }
    let default = run("default", 21, 40);
    let domain = run("domain", 21, 40);
    assert_ne!(
        default.iter().map(|s| s.family.name()).collect::<Vec<_>>(),
        domain.iter().map(|s| s.family.name()).collect::<Vec<_>>()
    );
}

/// Ego speed band at the endpoint, as the domain benchmark slices it.
fn band(v: f32) -> &'static str {
    match v {
        v if v < 5.0 => "0-5",
        v if v < 15.0 => "5-15",
        v if v < 25.0 => "15-25",
        v if v < 35.0 => "25-35",
        _ => "35-50",
    }
}

/// Geometry at the endpoint, by the one classifier every tool uses.
fn geometry(f: &Frame) -> &'static str {
    scorer_core::interaction::geometry(&f.ego, &f.partner).map_or("none", |g| g.as_str())
}

#[test]
fn the_domain_mix_covers_the_operating_domain() {
    let sims = run("domain", 3, 310);
    let mut bands: BTreeMap<&str, [usize; 3]> = BTreeMap::new();
    let mut shapes: BTreeMap<&str, [usize; 3]> = BTreeMap::new();
    let (mut max_speed, mut max_rel_speed, mut max_range): (f32, f32, f32) = (0.0, 0.0, 0.0);
    for s in &sims {
        let e = &s.event;
        let k = match e.kind {
            EventKind::Crash => 0,
            EventKind::NearCrash => 1,
            EventKind::Safe => 2,
        };
        let end = &e.frames[endpoint(e)];
        bands.entry(band(speed(&end.ego))).or_default()[k] += 1;
        shapes.entry(geometry(end)).or_default()[k] += 1;
        for f in &e.frames {
            max_speed = max_speed.max(speed(&f.ego)).max(speed(&f.partner));
            let rel = (f.ego.vx - f.partner.vx).hypot(f.ego.vy - f.partner.vy);
            max_rel_speed = max_rel_speed.max(rel);
            let (lon, lat) = relative_position(f);
            if lon.abs() <= 100.0 {
                max_range = max_range.max(lon.hypot(lat));
            }
        }
    }
    eprintln!("ego speed band at endpoint [crash, near_crash, safe]: {bands:?}");
    eprintln!("geometry at endpoint [crash, near_crash, safe]: {shapes:?}");
    eprintln!("max speed {max_speed}, max relative speed {max_rel_speed}, range {max_range}");
    for b in ["0-5", "5-15", "15-25", "25-35", "35-50"] {
        let c = bands.get(b).copied().unwrap_or_default();
        assert!(c.iter().all(|&n| n > 0), "band {b}: {c:?}");
    }
    for g in ["following", "adjacent", "crossing", "oncoming"] {
        let c = shapes.get(g).copied().unwrap_or_default();
        assert!(c[2] > 0 && c[0] + c[1] > 0, "geometry {g}: {c:?}");
    }
    assert!(max_speed > 45.0 && max_speed <= 50.5, "{max_speed}");
    assert!(max_rel_speed >= 30.0, "{max_rel_speed}");
    assert!(max_range > 90.0, "{max_range}");
}
