//! Map features for radars we have not seen: companion slot messages joined by slot, flag
//! expressions, a field of view, and a lateral speed derived from the track's motion that is
//! compensated for the ego's yaw (from a yaw-rate signal, or from the ego's heading change).
mod common;
use can_bridge::engine::{Engine, EngineConfig, Output, ReleaseReason, ScoredUpdate};
use can_bridge::map::{BusDatabase, BusPart, CompiledMap, MapFile};
use can_bridge::{ModelFile, Stats};
use can_codec::{project, Database, Frame};
use std::path::Path;

const RADAR_DBC: &str = r#"VERSION ""

BU_: X

BO_ 768 EGO: 8 X
 SG_ Speed : 0|16@1+ (0.01,0) [0|300] "m/s" X
 SG_ YawRate : 16|16@1- (0.0001,0) [-3|3] "rad/s" X
 SG_ Heading : 32|16@1+ (0.0001,0) [0|6.5] "rad" X
 SG_ Accel : 48|16@1- (0.001,0) [-30|30] "m/s2" X

BO_ 528 TRACK_A_0: 8 X
 SG_ LONG_DIST : 0|16@1+ (0.01,0) [0|500] "m" X
 SG_ LAT_DIST : 16|16@1- (0.01,0) [-300|300] "m" X
 SG_ REL_SPEED : 32|16@1- (0.01,0) [-300|300] "m/s" X
 SG_ VALID : 48|1@1+ (1,0) [0|1] "" X
 SG_ NEW_TRACK : 49|1@1+ (1,0) [0|1] "" X

BO_ 529 TRACK_A_1: 8 X
 SG_ LONG_DIST : 0|16@1+ (0.01,0) [0|500] "m" X
 SG_ LAT_DIST : 16|16@1- (0.01,0) [-300|300] "m" X
 SG_ REL_SPEED : 32|16@1- (0.01,0) [-300|300] "m/s" X
 SG_ VALID : 48|1@1+ (1,0) [0|1] "" X
 SG_ NEW_TRACK : 49|1@1+ (1,0) [0|1] "" X

BO_ 544 TRACK_B_0: 2 X
 SG_ REL_ACCEL : 0|8@1- (0.1,0) [-12|12] "m/s2" X

BO_ 545 TRACK_B_1: 2 X
 SG_ REL_ACCEL : 0|8@1- (0.1,0) [-12|12] "m/s2" X
"#;

const MAP: &str = r#"
[sensor]
fov_deg = 40.0

[ego]
vel_long = { message = "EGO", signal = "Speed" }
yaw_rate = { message = "EGO", signal = "YawRate" }
accel = { message = "EGO", signal = "Accel" }
default_length = 4.5
default_width = 1.8

[object]
slots = "TRACK_A_*"
companions = "TRACK_B_*"
velocity = "relative"
valid = "VALID and not NEW_TRACK"
pos_x = { signal = "LONG_DIST" }
pos_y = { signal = "LAT_DIST" }
vel_x = { signal = "REL_SPEED" }
missing_velocity = "track_motion"
motion_window_ms = 200
accel = { companion = true, signal = "REL_ACCEL" }
accel_relative = true
default_length = 4.5
default_width = 1.8

[warning]
message = "RISK_WARNING"
track_id = "WarnTrackId"
score = "WarnScore"
level = "WarnLevel"
counter = "WarnCounter"
crc = "WarnCrc"
data_id = 0x0A51
"#;

fn db() -> (Database, BusDatabase) {
    let radar = Database::parse(RADAR_DBC).unwrap();
    let mut all = BusDatabase::default();
    for (origin, db) in [
        ("radar.dbc", radar.clone()),
        (
            "builtin:riskscore",
            Database::parse(project::PROJECT_DBC).unwrap(),
        ),
    ] {
        all.add(BusPart {
            bus: None,
            origin: origin.into(),
            db,
        })
        .unwrap();
    }
    (radar, all)
}

fn compile(map: &str) -> Result<CompiledMap, String> {
    CompiledMap::compile_on(&MapFile::parse(map).map_err(|e| e.to_string())?, &db().1)
        .map_err(|e| e.to_string())
}

fn frame(db: &Database, name: &str, values: &[(&str, f64)]) -> Frame {
    common::frame(db, name, values)
}

struct Run {
    scored: Vec<ScoredUpdate>,
    released: Vec<(u32, ReleaseReason)>,
    stats: Stats,
}

fn run(map: CompiledMap, frames: &[(u64, Frame)], threshold: f32) -> Run {
    let model = ModelFile::from_bytes(Path::new("m"), common::msra_blob()).unwrap();
    let mut config = EngineConfig::new(threshold);
    config.min_on_us = 0;
    let mut engine = Engine::new(model.model().unwrap(), map, config).unwrap();
    let mut r = Run {
        scored: Vec::new(),
        released: Vec::new(),
        stats: Stats::default(),
    };
    for (t, f) in frames {
        engine.process(*t, f, &mut |o| match o {
            Output::Scored(s) => r.scored.push(s),
            Output::WarningOff { track, reason, .. } => r.released.push((track, reason)),
            _ => {}
        });
    }
    r.stats = *engine.stats();
    r
}

/// An ego at 10 m/s turning left at `yaw_rate` past an object fixed on the ground 40 m ahead of
/// its start: 10 Hz cycles of EGO (yaw rate or heading as asked) and TRACK_A_0 (position and
/// longitudinal relative speed as a radar measures them in the turning ego frame).
fn turning_past_a_fixed_object(yaw_rate: f64, send_heading: bool) -> Vec<(u64, Frame)> {
    let (radar, _) = db();
    let speed = 10.0;
    let mut frames = Vec::new();
    let (mut ex, mut ey, mut th) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..20u64 {
        let t = 1_000_000 + k * 100_000;
        let (dx, dy) = (40.0 - ex, 5.0 - ey);
        let (c, s) = (th.cos(), th.sin());
        let (px, py) = (c * dx + s * dy, -s * dx + c * dy);
        let ego: Vec<(&str, f64)> = if send_heading {
            vec![("Speed", speed), ("Heading", th), ("Accel", 0.0)]
        } else {
            vec![("Speed", speed), ("YawRate", yaw_rate), ("Accel", 0.0)]
        };
        frames.push((t, frame(&radar, "EGO", &ego)));
        frames.push((
            t + 500,
            frame(
                &radar,
                "TRACK_A_0",
                &[
                    ("LONG_DIST", px),
                    ("LAT_DIST", py),
                    // The object is fixed: relative velocity -v_ego, along the ego's x axis.
                    ("REL_SPEED", -speed),
                    ("VALID", 1.0),
                ],
            ),
        ));
        // Along the arc of a steady turn.
        let next = th + yaw_rate * 0.1;
        ex += speed / yaw_rate * (next.sin() - th.sin());
        ey += speed / yaw_rate * (th.cos() - next.cos());
        th = next;
    }
    frames
}

#[test]
fn a_derived_lateral_speed_is_compensated_for_the_ego_yaw_rate() {
    let yaw = 0.2;
    let last_vy = |map: CompiledMap, frames: &[(u64, Frame)]| {
        let r = run(map, frames, 100.0);
        assert!(r.scored.len() > 10, "{:?}", r.stats);
        r.scored.last().unwrap().partner.vy
    };
    // A fixed object has no speed over ground: with the yaw rate, the derived lateral speed is ~0.
    let frames = turning_past_a_fixed_object(yaw, false);
    let with_rate = last_vy(compile(MAP).unwrap(), &frames);
    assert!(with_rate.abs() < 0.1, "{with_rate}");
    // Without it, the turn shows as the object sweeping right at about yaw * range (~ -6 m/s).
    let no_yaw = MAP.replace("yaw_rate = { message = \"EGO\", signal = \"YawRate\" }", "");
    let uncompensated = last_vy(compile(&no_yaw).unwrap(), &frames);
    assert!(uncompensated < -4.0, "{uncompensated}");
    // From the ego's heading change when no yaw rate is on the bus.
    let heading = MAP.replace(
        "yaw_rate = { message = \"EGO\", signal = \"YawRate\" }",
        "heading = { message = \"EGO\", signal = \"Heading\" }",
    );
    let map = compile(&heading).unwrap();
    assert!(map
        .input_report()
        .iter()
        .any(|l| l.contains("ego.yaw_rate: DERIVED from the change of ego.heading")));
    let from_heading = last_vy(map, &turning_past_a_fixed_object(yaw, true));
    assert!(from_heading.abs() < 0.1, "{from_heading}");
}

#[test]
fn companion_slots_join_their_slot_and_flag_expressions_combine_signals() {
    let (radar, _) = db();
    let map = compile(MAP).unwrap();
    assert!(map
        .input_report()
        .iter()
        .any(|l| l.contains("2 companion messages joined by slot")));
    let mut frames = Vec::new();
    for k in 0..6u64 {
        let t = 1_000_000 + k * 100_000;
        frames.push((t, frame(&radar, "EGO", &[("Speed", 20.0), ("Accel", 1.0)])));
        // Slot 1 is a new object in its first cycle: "VALID and not NEW_TRACK" is false.
        for (slot, x) in [(0, 30.0), (1, 50.0)] {
            let new = if slot == 1 && k == 0 { 1.0 } else { 0.0 };
            frames.push((
                t + 100 + slot * 50,
                frame(
                    &radar,
                    &format!("TRACK_A_{slot}"),
                    &[
                        ("LONG_DIST", x - k as f64),
                        ("LAT_DIST", 0.0),
                        ("REL_SPEED", -10.0),
                        ("VALID", 1.0),
                        ("NEW_TRACK", new),
                    ],
                ),
            ));
        }
        // Companions: slot 0 brakes relative to the ego, slot 1 does not.
        frames.push((t + 300, frame(&radar, "TRACK_B_0", &[("REL_ACCEL", -3.0)])));
        frames.push((t + 350, frame(&radar, "TRACK_B_1", &[("REL_ACCEL", 0.0)])));
    }
    let r = run(map, &frames, 100.0);
    assert_eq!(r.stats.invalid_objects, 1, "{:?}", r.stats);
    let last = |track: u32| *r.scored.iter().rfind(|s| s.track == track).unwrap();
    // Relative -3 m/s^2 plus the ego's 1 m/s^2.
    assert!((last(0).partner.acc - -2.0).abs() < 1e-4, "{:?}", last(0));
    assert!((last(1).partner.acc - 1.0).abs() < 1e-4, "{:?}", last(1));

    // Expressions and companions refuse what they cannot mean, naming the field.
    for (bad, needle) in [
        (
            MAP.replace("VALID and not NEW_TRACK", "VALID and not NEW"),
            "object.valid",
        ),
        (
            MAP.replace("VALID and not NEW_TRACK", "VALID or NEW_TRACK"),
            "object.valid",
        ),
        (
            MAP.replace("companions = \"TRACK_B_*\"", ""),
            "object.accel",
        ),
        (
            MAP.replace("companions = \"TRACK_B_*\"", "companions = \"TRACK_B_0\""),
            "object.companions",
        ),
        (
            MAP.replace("fov_deg = 40.0", "fov_deg = 0.0"),
            "sensor.fov_deg",
        ),
    ] {
        let err = compile(&bad).unwrap_err();
        assert!(err.contains(needle), "{needle}: {err}");
    }
}

#[test]
fn a_track_outside_the_field_of_view_is_not_scored_and_its_warning_is_released() {
    let (radar, _) = db();
    let mut frames = Vec::new();
    // A closing object dead ahead that warns, then (same slot) jumps to 30 deg left: outside a
    // 40 deg view.
    for k in 0..12u64 {
        let t = 1_000_000 + k * 100_000;
        frames.push((t, frame(&radar, "EGO", &[("Speed", 20.0)])));
        let (x, y) = if k < 8 {
            (12.0 - k as f64, 0.0)
        } else {
            (10.0, 10.0 * 30f64.to_radians().tan())
        };
        frames.push((
            t + 100,
            frame(
                &radar,
                "TRACK_A_0",
                &[
                    ("LONG_DIST", x),
                    ("LAT_DIST", y),
                    ("REL_SPEED", -10.0),
                    ("VALID", 1.0),
                ],
            ),
        ));
    }
    let r = run(compile(MAP).unwrap(), &frames, 1.5);
    assert_eq!(r.stats.outside_view, 4, "{:?}", r.stats);
    assert_eq!(r.released, [(0, ReleaseReason::OutsideView)]);
    assert!(r.scored.iter().all(|s| s.partner.y.abs() < 0.01));
    // Without the field of view the same frames are scored.
    let wide = run(
        compile(&MAP.replace("fov_deg = 40.0", "")).unwrap(),
        &frames,
        1.5,
    );
    assert_eq!(wide.stats.outside_view, 0);
    assert!(wide.scored.iter().any(|s| s.partner.y > 5.0));
}

#[test]
fn a_name_two_buses_define_is_refused_where_the_map_uses_it() {
    let (_, mut all) = db();
    let other_bus = Database::parse(
        "VERSION \"\"\n\nBU_: X\n\nBO_ 600 TRACK_A_0: 8 X\n SG_ LONG_DIST : 0|16@1+ (0.01,0) [0|500] \"m\" X\n\nBO_ 601 EGO: 8 X\n SG_ Speed : 0|16@1+ (0.01,0) [0|300] \"m/s\" X\n",
    )
    .unwrap();
    all.add(BusPart {
        bus: Some("can7".into()),
        origin: "other.dbc".into(),
        db: other_bus,
    })
    .unwrap();
    let err = CompiledMap::compile_on(&MapFile::parse(MAP).unwrap(), &all)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("ego.vel_long")
            && err.contains("`EGO` is defined twice")
            && err.contains("bus can7"),
        "{err}"
    );
    // `NAME@BUS` says which: with the radar's file bound to can1, `EGO@can1` is its EGO.
    let mut bound = BusDatabase::default();
    for (bus, origin, text) in [
        (Some("can1"), "radar.dbc", RADAR_DBC),
        (None, "builtin:riskscore", project::PROJECT_DBC),
    ] {
        bound
            .add(BusPart {
                bus: bus.map(Into::into),
                origin: origin.into(),
                db: Database::parse(text).unwrap(),
            })
            .unwrap();
    }
    bound
        .add(BusPart {
            bus: Some("can7".into()),
            origin: "other.dbc".into(),
            db: Database::parse(
                "VERSION \"\"\n\nBU_: X\n\nBO_ 601 EGO: 8 X\n SG_ Speed : 0|16@1+ (0.01,0) [0|300] \"m/s\" X\n",
            )
            .unwrap(),
        })
        .unwrap();
    let qualified = MAP.replace("message = \"EGO\"", "message = \"EGO@can1\"");
    let map = CompiledMap::compile_on(&MapFile::parse(&qualified).unwrap(), &bound).unwrap();
    let ego = map.inputs.iter().find(|m| m.spec.name == "EGO").unwrap();
    assert_eq!((ego.spec.id.raw(), ego.bus), (768, map.bus_of("can1")));
    assert_eq!(
        map.inputs.iter().filter(|m| m.spec.name == "EGO").count(),
        1
    );
    // The slot glob matching one name on two buses is refused too.
    let mut all = db().1;
    all.add(BusPart {
        bus: Some("can7".into()),
        origin: "other.dbc".into(),
        db: Database::parse(
            "VERSION \"\"\n\nBU_: X\n\nBO_ 600 TRACK_A_0: 8 X\n SG_ LONG_DIST : 0|16@1+ (0.01,0) [0|500] \"m\" X\n",
        )
        .unwrap(),
    })
    .unwrap();
    let err = CompiledMap::compile_on(&MapFile::parse(MAP).unwrap(), &all)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("object.slots") && err.contains("matches message `TRACK_A_0` twice"),
        "{err}"
    );
}
