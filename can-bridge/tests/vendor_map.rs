//! A vehicle's own DBC through a map file: extended ids, Motorola signals, a multiplexed CAN FD
//! radar message with IEEE float signals, unit and sign conversion, absolute velocities and headings
//! derived from velocity. Configuration, not code.
mod common;
use can_bridge::engine::{Engine, EngineConfig, Output};
use can_bridge::map::{CompiledMap, MapFile};
use can_bridge::ModelFile;
use can_codec::{Database, Frame};
use std::path::Path;

const VENDOR_DBC: &str = r#"VERSION ""

NS_ :

BS_:

BU_: VEH RADAR ADAS

BO_ 2566844672 ACC_EGO: 8 VEH
 SG_ VehSpeedKph : 0|16@1+ (0.01,0) [0|250] "km/h" ADAS

BO_ 2147484417 RADAR_TRACK: 12 RADAR
 SG_ Page M : 7|1@0+ (1,0) [0|1] "" ADAS
 SG_ TrackNo : 6|7@0+ (1,0) [0|127] "" ADAS
 SG_ RangeX m0 : 15|16@0- (0.01,0) [-300|300] "m" ADAS
 SG_ RangeY m0 : 31|16@0- (0.01,0) [-100|100] "m" ADAS
 SG_ SpeedX m1 : 8|32@1- (1,0) [0|0] "m/s" ADAS
 SG_ SpeedY m1 : 40|32@1- (1,0) [0|0] "m/s" ADAS

BO_ 2016 RISK_OUT: 8 ADAS
 SG_ Crc : 0|8@1+ (1,0) [0|255] "" VEH
 SG_ Cnt : 8|4@1+ (1,0) [0|15] "" VEH
 SG_ Lvl : 12|4@1+ (1,0) [0|3] "" VEH
 SG_ Trk : 16|8@1+ (1,0) [0|255] "" VEH
 SG_ Score : 24|16@1+ (0.001,0) [0|60] "" VEH

SIG_VALTYPE_ 2147484417 SpeedX : 1;
SIG_VALTYPE_ 2147484417 SpeedY : 1;
"#;

const VENDOR_MAP: &str = r#"
[ego]
vel_long = { message = "ACC_EGO", signal = "VehSpeedKph", factor = 0.2777777777777778 }
default_length = 4.8
default_width = 1.9

[object]
trigger = "RADAR_TRACK"
trigger_mux = 1
velocity = "absolute"
track_id = { RADAR_TRACK = "TrackNo" }
pos_x = { message = "RADAR_TRACK", signal = "RangeX" }
pos_y = { message = "RADAR_TRACK", signal = "RangeY", factor = -1.0 }
vel_x = { message = "RADAR_TRACK", signal = "SpeedX" }
vel_y = { message = "RADAR_TRACK", signal = "SpeedY", factor = -1.0 }
default_length = 4.4
default_width = 1.7

[warning]
message = "RISK_OUT"
track_id = "Trk"
score = "Score"
level = "Lvl"
counter = "Cnt"
crc = "Crc"
data_id = 0x1234
"#;

fn fd(db: &Database, name: &str, values: &[(&str, f64)]) -> Frame {
    let m = db.message_by_name(name).unwrap();
    let data = m.encode(values).unwrap();
    if data.len() > 8 {
        Frame::fd_frame(m.id, 0, &data).unwrap()
    } else {
        Frame::data_frame(m.id, &data).unwrap()
    }
}

#[test]
fn vendor_dbc_is_decoded_through_the_map() {
    let db = Database::parse(VENDOR_DBC).unwrap();
    let map = CompiledMap::compile(&MapFile::parse(VENDOR_MAP).unwrap(), &db).unwrap();
    let ids = map.input_ids();
    assert!(ids.contains(&can_codec::CanId::Extended(0x18FE_F100)));
    assert!(ids.contains(&can_codec::CanId::Extended(0x301)));
    let model = ModelFile::from_bytes(Path::new("m"), common::msra_blob()).unwrap();
    let mut engine = Engine::new(model.model().unwrap(), map, EngineConfig::new(1.5)).unwrap();
    let mut out = Vec::new();
    let mut t = 1_000_000;
    let mut send = |f: Frame, out: &mut Vec<Output>| {
        t += 1000;
        engine.process(t, &f, &mut |o| out.push(o));
    };
    send(fd(&db, "ACC_EGO", &[("VehSpeedKph", 72.0)]), &mut out);
    // Track 5: 25 m ahead, 3 m to the right; moving over ground at 10 m/s forward, 1 m/s to the right.
    send(
        fd(
            &db,
            "RADAR_TRACK",
            &[
                ("Page", 0.0),
                ("TrackNo", 5.0),
                ("RangeX", 25.0),
                ("RangeY", 3.0),
            ],
        ),
        &mut out,
    );
    send(
        fd(
            &db,
            "RADAR_TRACK",
            &[
                ("Page", 1.0),
                ("TrackNo", 5.0),
                ("SpeedX", 10.0),
                ("SpeedY", 1.0),
            ],
        ),
        &mut out,
    );
    // Track 6 sends a NaN speed: that frame is dropped, track 5 is unaffected.
    send(
        fd(
            &db,
            "RADAR_TRACK",
            &[
                ("Page", 0.0),
                ("TrackNo", 6.0),
                ("RangeX", 10.0),
                ("RangeY", 0.0),
            ],
        ),
        &mut out,
    );
    let m = db.message_by_name("RADAR_TRACK").unwrap();
    let mut nan = m
        .encode(&[("Page", 1.0), ("TrackNo", 6.0), ("SpeedY", 0.0)])
        .unwrap();
    nan[1..5].copy_from_slice(&f32::NAN.to_le_bytes());
    send(Frame::fd_frame(m.id, 0, &nan).unwrap(), &mut out);

    let scored: Vec<_> = out
        .iter()
        .filter_map(|o| match o {
            Output::Scored(s) => Some(*s),
            _ => None,
        })
        .collect();
    assert_eq!(
        scored.len(),
        1,
        "one trigger (page 1) for track 5; the page-0 frames do not trigger"
    );
    let s = scored[0];
    assert_eq!(s.track, 5);
    assert!(
        (s.ego.vx - 20.0).abs() < 1e-4,
        "72 km/h = 20 m/s, got {}",
        s.ego.vx
    );
    assert_eq!((s.ego.length, s.ego.width), (4.8, 1.9));
    assert!((s.partner.x - 25.0).abs() < 1e-6);
    assert!(
        (s.partner.y + 3.0).abs() < 1e-6,
        "right-positive radar y becomes -3 (left-positive)"
    );
    assert!((s.partner.vx - 10.0).abs() < 1e-6 && (s.partner.vy + 1.0).abs() < 1e-6);
    let speed = (101.0f32).sqrt();
    assert!(
        (s.partner.hx - 10.0 / speed).abs() < 1e-6 && (s.partner.hy + 1.0 / speed).abs() < 1e-6
    );
    assert_eq!((s.partner.length, s.partner.width), (4.4, 1.7));
    let problems: Vec<_> = out
        .iter()
        .filter_map(|o| match o {
            Output::Problem { reason, .. } => Some(reason.to_string()),
            _ => None,
        })
        .collect();
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].contains("SpeedX") && problems[0].contains("not finite"),
        "{problems:?}"
    );
    assert_eq!(engine.stats().decode_errors, 1);
}

#[test]
fn map_with_unknown_trigger_mux_target_is_refused() {
    let db = Database::parse(can_codec::project::PROJECT_DBC).unwrap();
    let text = can_bridge::map::DEFAULT_MAP.replace(
        "trigger = \"OBJECT_MOTION\"",
        "trigger = \"OBJECT_MOTION\"\ntrigger_mux = 1",
    );
    let err = CompiledMap::compile(&MapFile::parse(&text).unwrap(), &db)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("object.trigger_mux") && err.contains("not multiplexed"),
        "{err}"
    );
}
