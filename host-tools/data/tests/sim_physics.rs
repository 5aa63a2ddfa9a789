//! Physical honesty of the simulator on every family (the `domain` mix draws all sixteen),
//! measured on the frames as written, independently of the simulator's own bookkeeping:
//! heading along the velocity, positions that follow the speeds, speeds and longitudinal
//! accelerations inside the documented limits, and labels that match the box geometry.
//!
//! One test is `#[ignore]`d: it demonstrates a defect found in an audit (2026-11-28) that is not
//! fixed (D2 in docs/simulator.md, see its comment; D1 and D3 are fixed); run it with
//! `cargo test -p riskscore-data --test sim_physics -- --ignored`.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
use riskscore_data::events::{safe_rules_hold, EventKind, Frame, PrepareConfig};
use riskscore_data::sim::{simulate_events, LabelRules, Mix, SimConfig, SimulatedEvent};
use scorer_core::geometry::{box_distance, boxes_overlap};
use scorer_core::VehicleState;

fn run(families: &str, seed: u64, events: usize, mix: Mix) -> Vec<SimulatedEvent> {
    let cfg = SimConfig {
        seed,
        events,
        mix,
        families: families.parse().unwrap(),
        ..SimConfig::default()
    };
    let (_, sims, summary) = simulate_events(&cfg).unwrap();
    assert_eq!(summary.counts.total(), events);
    sims
}

type Get = fn(&Frame) -> &VehicleState;
const WHO: [(&str, Get); 2] = [("ego", |f| &f.ego), ("partner", |f| &f.partner)];

/// Velocity change per second at frame `i` (central differences, one-sided at the ends), as the
/// labelling measures it: (along the heading, across it).
fn acceleration(frames: &[Frame], i: usize, get: Get) -> (f32, f32) {
    let (a, b) = (i.saturating_sub(1), (i + 1).min(frames.len() - 1));
    let dt = (frames[b].time - frames[a].time) as f32;
    let (sa, sb, s) = (get(&frames[a]), get(&frames[b]), get(&frames[i]));
    let (dvx, dvy) = ((sb.vx - sa.vx) / dt, (sb.vy - sa.vy) / dt);
    (s.hx * dvx + s.hy * dvy, s.hx * dvy - s.hy * dvx)
}

/// Largest ground speed of any vehicle (m/s): no driver wants more than 50 m/s; a lateral move
/// adds at most 0.3 % (docs/simulator.md).
const MAX_SPEED: f32 = 50.0 * 1.003;
/// Hardest braking of any vehicle class (car, U(7.0, 9.5) m/s^2), with 0.5 m/s^2 for the ground
/// speed a lateral move adds and removes.
const MAX_DECEL: f32 = 10.0;
/// Strongest engine acceleration of any class (motorbike, 4.0 m/s^2).
const MAX_ACCEL: f32 = 4.0;

#[test]
fn every_family_moves_along_its_heading_at_documented_speeds_and_accelerations() {
    let sims = run("domain", 3, 400, Mix::default());
    let families: std::collections::BTreeSet<&str> = sims.iter().map(|s| s.family.name()).collect();
    assert_eq!(families.len(), 16, "{families:?}");
    for s in &sims {
        let e = &s.event;
        let id = format!("{} {}", s.family.name(), e.id);
        for (who, get) in WHO {
            for (i, f) in e.frames.iter().enumerate() {
                let v = get(f);
                let speed = v.speed();
                assert!(speed <= MAX_SPEED, "{id} {who} t={}: {speed} m/s", f.time);
                // No side slip in the model: the velocity lies along the heading, forwards.
                assert!(
                    (v.hx * v.vy - v.hy * v.vx).abs() <= 1e-3 * speed.max(1.0)
                        && v.hx * v.vx + v.hy * v.vy >= -1e-3,
                    "{id} {who} t={}: velocity ({}, {}) off heading ({}, {})",
                    f.time,
                    v.vx,
                    v.vy,
                    v.hx,
                    v.hy
                );
                let (lon, _) = acceleration(&e.frames, i, get);
                assert!(
                    (-MAX_DECEL..=MAX_ACCEL).contains(&lon),
                    "{id} {who} t={}: longitudinal acceleration {lon} m/s^2",
                    f.time
                );
            }
            for w in e.frames.windows(2) {
                let (a, b) = (get(&w[0]), get(&w[1]));
                // Positions advance with the mean velocity (no teleports, no drift while
                // standing): within 2 cm per 0.1 s frame (measured at most 1.1 cm).
                let dt = (w[1].time - w[0].time) as f32;
                let ex = b.x - a.x - 0.5 * dt * (a.vx + b.vx);
                let ey = b.y - a.y - 0.5 * dt * (a.vy + b.vy);
                assert!(
                    ex.hypot(ey) < 0.02,
                    "{id} {who} t={}: moved {} m more than its speeds say",
                    w[1].time,
                    ex.hypot(ey)
                );
            }
        }
    }
}

#[test]
fn every_family_labels_match_the_box_geometry() {
    let rules = LabelRules::default();
    let prep = PrepareConfig::default();
    let sims = run("domain", 4, 400, Mix::default());
    for s in &sims {
        let e = &s.event;
        let id = format!("{} {}", s.family.name(), e.id);
        let overlap: Vec<bool> = e
            .frames
            .iter()
            .map(|f| boxes_overlap(&f.ego, &f.partner))
            .collect();
        let gaps: Vec<f32> = e
            .frames
            .iter()
            .map(|f| box_distance(&f.ego, &f.partner))
            .collect();
        let first_overlap = overlap.iter().position(|&o| o);
        match e.kind {
            EventKind::Crash => {
                // The impact is the first frame whose boxes overlap, and the recording ends there.
                let k = first_overlap.unwrap_or_else(|| panic!("{id}: crash without contact"));
                assert_eq!(Some(e.frames[k].time), e.t_impact, "{id}: impact time");
                assert_eq!(k + 1, e.frames.len(), "{id}: frames after the impact");
                assert!(e.t_impact.unwrap() - e.t_start >= rules.min_history - 1e-9);
            }
            EventKind::NearCrash => {
                assert_eq!(first_overlap, None, "{id}: near-crash with contact");
                let min = gaps.iter().copied().fold(f32::INFINITY, f32::min);
                assert!(min < rules.near_crash_gap, "{id}: closest gap {min} m");
                let k = gaps.iter().position(|&g| g == min).unwrap();
                assert_eq!(Some(e.frames[k].time), e.t_impact, "{id}: endpoint");
                assert!(
                    k + 1 < e.frames.len(),
                    "{id}: recording ends at the endpoint"
                );
            }
            EventKind::Safe => {
                assert_eq!(first_overlap, None, "{id}: safe with contact");
                assert!(safe_rules_hold(&e.frames, &prep), "{id}: not calm");
                for (who, get) in WHO {
                    for i in 0..e.frames.len() {
                        let (_, lat) = acceleration(&e.frames, i, get);
                        assert!(
                            lat.abs() < rules.safe_max_lat_acc,
                            "{id} {who} t={}: lateral acceleration {lat} m/s^2 in a safe event",
                            e.frames[i].time
                        );
                    }
                }
            }
        }
    }
}

/// Audit defect D1 (2026-11-28), fixed: lateral moves were not limited by the vehicle (the
/// opposite_drift steer-back reached 12.5 m/s² for a car, 11.7 m/s² for a truck, and swerves
/// added to full braking). Every lateral move is now sized within the class's lateral limit and
/// braking shares the tyre with it (friction circle). The bound is each vehicle's own tyre limit
/// `b_phys` (drawn per vehicle: car U(7.0, 9.5), van U(6.5, 8.5), truck U(4.5, 6.5), motorbike
/// U(5.5, 9.0) m/s²) for the total acceleration, and for a truck's lateral acceleration its
/// rollover threshold `min(b_phys, 4.0)` as well (docs/simulator.md, "Lateral moves stay within
/// the vehicle"). Tolerances: 0.3 m/s² laterally for the finite differences (the velocity is
/// differenced centrally over 0.2 s, so a move's onset or end is smeared over two frames);
/// 0.5 m/s² on the total, because the simulator applies the friction circle to the speed along
/// the reference path while the frames carry the ground speed, `v·sqrt((1 − κd)² + d'²)`: a
/// vehicle braking at `b_phys` during a lateral move of slope `d'` slows over the ground by about
/// `(1 + d'²/2)·b_phys + v²·d'·d''` (measured up to 0.38 m/s² over `b_phys` on 1,800 vehicles of
/// these families, seeds 1-3; the same 0.5 m/s² the longitudinal bound `MAX_DECEL` allows).
#[test]
fn total_acceleration_stays_within_the_vehicles_friction_limit() {
    let sims = run("opposite_drift,cut_in", 1, 300, "1,2,0".parse().unwrap());
    let mut worst = Vec::new();
    for s in &sims {
        let e = &s.event;
        for (k, (who, get)) in WHO.iter().enumerate() {
            let class = s.classes[k].name();
            let limit = s.b_phys[k] as f32;
            let lat_limit = match class {
                "car" | "van" | "motorbike" => limit,
                "truck" => limit.min(4.0),
                _ => continue,
            };
            for i in 0..e.frames.len() {
                let (lon, lat) = acceleration(&e.frames, i, *get);
                let total = lon.hypot(lat);
                if total > limit + 0.5 || lat.abs() > lat_limit + 0.3 {
                    worst.push(format!(
                        "{} {} {who} ({class}) t={}: {total:.2} m/s^2 (lateral {lat:.2}) > \
                         {limit:.2} (lateral {lat_limit:.2})",
                        s.family.name(),
                        e.id,
                        e.frames[i].time
                    ));
                    break;
                }
            }
        }
    }
    assert!(
        worst.is_empty(),
        "{} vehicles beyond their friction limit, e.g. {:#?}",
        worst.len(),
        &worst[..worst.len().min(8)]
    );
}

/// DEFECT (audit 2026-11-28, not fixed: the fix changes every data set). The near-crash rule
/// takes "lateral acceleration >= 3 m/s² by either vehicle in the 3 s before the closest
/// approach" as the evasive manoeuvre, so the lane change that creates the conflict counts as
/// its own evasion: a close cut-in or lane change with a lateral peak of 3-4 m/s², where nobody
/// brakes at 4 m/s² or steers away, is labelled near-crash (the same pass at 2.9 m/s² is safe
/// or rejected). Measured on 7 draws of 300-1000 events: 355 of 2,730 near-crashes (13 %),
/// 152 of 279 cut_in and 112 of 175 lane_change near-crashes. A labeller that passes this test
/// was measured and not adopted (docs/training.md, "Audit defect D2 fixed in the labels").
#[test]
#[ignore = "defect: the conflicting lane change counts as the evasive manoeuvre"]
fn defect_near_crash_evasion_is_not_the_conflicting_move_itself() {
    let rules = LabelRules::default();
    let sims = run("cut_in,lane_change", 1, 150, "0,1,0".parse().unwrap());
    let mut bad = Vec::new();
    for s in &sims {
        let e = &s.event;
        let t = e.t_impact.unwrap();
        let window: Vec<usize> = (0..e.frames.len())
            .filter(|&i| {
                let ti = e.frames[i].time;
                ti <= t + 1e-6 && ti >= t - rules.evasive_window - 1e-6
            })
            .collect();
        let (k0, k1) = (window[0], window[window.len() - 1]);
        let braked = window.iter().any(|&i| {
            let f = &e.frames[i];
            -f.ego.acc >= rules.evasive_decel
                || -acceleration(&e.frames, i, |f| &f.partner).0 >= rules.evasive_decel
        });
        // A vehicle's lateral acceleration is evasive unless its only lateral motion in the
        // window is toward the other vehicle (the lane change or cut-in itself).
        let evaded_sideways = WHO.iter().enumerate().any(|(k, (_, get))| {
            let swerved = window
                .iter()
                .any(|&i| acceleration(&e.frames, i, *get).1.abs() >= rules.evasive_lat_acc);
            let other: Get = WHO[1 - k].1;
            let (s0, o1) = (get(&e.frames[k0]), other(&e.frames[k1]));
            let (nx, ny) = (-s0.hy, s0.hx);
            let side = ((o1.x - s0.x) * nx + (o1.y - s0.y) * ny).signum();
            let lateral = |i: usize| {
                let v = get(&e.frames[i]);
                side * ((v.x - s0.x) * nx + (v.y - s0.y) * ny)
            };
            let toward_only =
                (k0..k1).all(|i| lateral(i + 1) >= lateral(i) - 0.005) && lateral(k1) > 0.1;
            swerved && !toward_only
        });
        if !braked && !evaded_sideways {
            bad.push(format!(
                "{} {} (closest gap {:.2} m at {t} s)",
                s.family.name(),
                e.id,
                s.measures.min_gap
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "{} of {} near-crashes whose only 'evasive manoeuvre' is the conflicting lateral move, e.g. {:#?}",
        bad.len(),
        sims.len(),
        &bad[..bad.len().min(8)]
    );
}

/// Tightest radius each class can steer (m, `parts::handling`: half the kerb-to-kerb turning
/// circle), stated here independently of the simulator; `None` for a roadside object.
fn r_min(class: &str) -> Option<f32> {
    match class {
        "car" => Some(5.0),
        "van" => Some(6.0),
        "truck" => Some(8.0),
        "motorbike" => Some(2.5),
        _ => None,
    }
}

/// Every family whose paths have arcs (turns and the on-ramp), and the crossing families where
/// swerves at walking speed were the tightest curves (D3).
const ARC_FAMILIES: &str = "crossing,signal_crossing,left_turn_across,turn_into_path,merge,\
                            signal_left_turn,signal_right_turn";

/// Audit defect D3 (2026-11-28), fixed: a swerve was at least 3 m long, so one triggered at
/// walking speed (a give-way driver braking at a crossing) turned on a radius down to about 1 m
/// (curvature 0.86 1/m), where a car, van or truck cannot steer tighter than about 4-5 m. Every
/// lateral move is now long enough for the class's turning circle (`lateral_len`), and every turn
/// or ramp arc is drawn no tighter than the class of the vehicle that drives it (a truck turned
/// on 6-8 m arcs before 2026-11-29). The geometry is what shows it, since the lateral
/// acceleration stays small at walking speed.
///
/// Tolerance 1 %: the curvature is measured as the heading change over the chord between two
/// frames, which exceeds the path's by a factor 1 + θ²/24 for a turn of θ per frame (θ ≤ 0.25 rad
/// at 14 m/s on an 8 m arc: 0.3 %); positions are f32 within about 1 km of the origin, rounded to
/// 3e-5 m, at most 0.15 % of the shortest step measured (5 cm); headings are f32 unit vectors
/// (1e-7 rad).
#[test]
fn paths_stay_within_the_turning_circle() {
    let sims = run(ARC_FAMILIES, 1, 400, "1,1,1".parse().unwrap());
    let mut bad = Vec::new();
    for s in &sims {
        let e = &s.event;
        for (k, (who, get)) in WHO.iter().enumerate() {
            let Some(r_min) = r_min(s.classes[k].name()) else {
                continue;
            };
            for w in e.frames.windows(2) {
                let (a, b) = (get(&w[0]), get(&w[1]));
                let step = (b.x - a.x).hypot(b.y - a.y);
                if step < 0.05 {
                    continue;
                }
                let turn = (a.hx * b.hy - a.hy * b.hx).atan2(a.hx * b.hx + a.hy * b.hy);
                let curvature = turn.abs() / step;
                if curvature * r_min > 1.01 {
                    bad.push(format!(
                        "{} {} {who} ({}) t={}: radius {:.2} m < {r_min} m at {:.1} m/s",
                        s.family.name(),
                        e.id,
                        s.classes[k].name(),
                        w[1].time,
                        1.0 / curvature,
                        b.speed()
                    ));
                    break;
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} vehicles turning tighter than their class can, e.g. {:#?}",
        bad.len(),
        &bad[..bad.len().min(8)]
    );
}
