//! Two real radar DBCs (opendbc, see can-bridge/maps/dbc/PROVENANCE.md) through map files alone:
//! the Honda/Acura Nidec radar (16 slot messages, Cartesian, no id, no lateral speed, NEW_TRACK,
//! left-negative LAT_DIST, wrong DBC ranges) and the GM long-range radar object list (20 slots
//! with an id signal, polar range + azimuth + range rate, Motorola, ego speed on another DBC).
//!
//! One scene (a closing lead, a cut-in from the left, a slot reused by a new object) is encoded
//! three ways: through each real DBC (the committed logs `can-bridge/maps/scenes/*.log`) and
//! through the project's own DBC. The bridge must give the same warnings for all three: same
//! onsets (time, track, level), same releases (time, track), and scores that agree within the
//! sensors' resolution. Set `BLESS_RADAR_SCENES=1` to rewrite the committed logs.
mod common;
use can_bridge::engine::{Engine, EngineConfig, Output, ReleaseReason};
use can_bridge::map::{CompiledMap, MapFile};
use can_bridge::ModelFile;
use can_codec::{project, Database, Frame, MessageSpec};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const CYCLE_US: u64 = 100_000;
const T0_US: u64 = 1_700_000_000_000_000;
const CYCLES: u64 = 50;
const EGO_SPEED: f64 = 20.0;
/// Offsets of the maps: sensor x + half a car length from the near face to the centre.
const HONDA_X0: f64 = 2.3 + 2.25;
const GM_SENSOR_X: f64 = 2.4;
const THRESHOLD: f32 = 1.5;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("maps")
}

/// One object of the scene at one cycle: ego frame, centre position, velocity relative to the ego.
#[derive(Clone, Copy, Debug)]
struct Obj {
    /// Index of the slot message (Honda TRACK_n, GM LRRObject(n+1)).
    slot: u32,
    /// The object's id where the sensor has one (GM); the own DBC uses it as track id too.
    gm_id: u32,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    /// First cycle of a new object in a reused slot.
    new: bool,
}

impl Obj {
    /// The track id the bridge reports: the slot for Honda, the object id for GM.
    fn track(&self, gm: bool) -> u32 {
        if gm {
            self.gm_id
        } else {
            self.slot
        }
    }
}

/// The scene at cycle `k`: all values on the Honda grid (0.0625 m, 0.03125 m/s) and on the
/// project DBC's (1 mm, 1 mm/s).
fn scene(k: u64) -> Vec<Obj> {
    let kf = k as f64;
    let mut objs = Vec::new();
    if k <= 28 {
        // Closing lead: 40 m ahead (near face), 12.5 m/s slower than the ego.
        objs.push(Obj {
            slot: 0,
            gm_id: 11,
            x: HONDA_X0 + 40.0 - 1.25 * kf,
            y: 0.0,
            vx: -12.5,
            vy: 0.0,
            new: false,
        });
        // Cut-in from the left lane: 3.5 m left, drifting right at 1.25 m/s, 6.25 m/s slower.
        objs.push(Obj {
            slot: 5,
            gm_id: 23,
            x: HONDA_X0 + 20.25 - 0.625 * kf,
            y: 3.5 - 0.125 * kf,
            vx: -6.25,
            vy: -1.25,
            new: false,
        });
    }
    if k <= 12 {
        // Slot 9, object A: a stopped car 1 m to the right, closing at the ego's speed.
        objs.push(Obj {
            slot: 9,
            gm_id: 40,
            x: HONDA_X0 + 50.0 - 2.0 * kf,
            y: -1.0,
            vx: -20.0,
            vy: 0.0,
            new: false,
        });
    } else if k <= 28 {
        // Slot 9 reused by object B: far away in the right lane, pulling away.
        objs.push(Obj {
            slot: 9,
            gm_id: 41,
            x: HONDA_X0 + 45.0 + 2.5 * (kf - 13.0),
            y: -3.5,
            vx: 2.5,
            vy: 0.0,
            new: k == 13,
        });
    }
    objs
}

fn cycle_start(k: u64) -> u64 {
    T0_US + k * CYCLE_US
}

/// Slot frames and own-DBC triggers of slot `s` leave at this time in cycle `k`.
fn slot_time(k: u64, slot: u32) -> u64 {
    cycle_start(k) + 1000 * (u64::from(slot) + 1) + 500
}

/// Encodes physical values without the DBC's range check (the real DBCs declare wrong ranges
/// for signed signals, and an empty slot carries a value above the declared maximum).
fn encode_raw(m: &MessageSpec, values: &[(&str, f64)]) -> Frame {
    let mut data = vec![0u8; m.size];
    for (name, v) in values {
        let s = &m.signals[m.signal_index(name).unwrap()];
        let raw = ((v - s.offset) / s.factor).round() as i64;
        s.write_raw(raw as u64, &mut data).unwrap();
    }
    Frame::data_frame(m.id, &data).unwrap()
}

fn load_db(files: &[&str]) -> Database {
    let mut db = Database::default();
    for f in files {
        let one = if *f == "builtin:riskscore" {
            Database::parse(project::PROJECT_DBC).unwrap()
        } else {
            let text = std::fs::read_to_string(dir().join("dbc").join(f)).unwrap();
            Database::parse(&text).unwrap_or_else(|e| panic!("{f}: {e}"))
        };
        db.merge(one).unwrap();
    }
    db
}

fn honda_db() -> Database {
    load_db(&["acura_ilx_2016_nidec.dbc", "builtin:riskscore"])
}

fn gm_db() -> Database {
    load_db(&[
        "gm_global_a_object.excerpt.dbc",
        "gm_global_a_powertrain.excerpt.dbc",
        "builtin:riskscore",
    ])
}

fn map_for(name: &str, db: &Database) -> CompiledMap {
    let text = std::fs::read_to_string(dir().join(name)).unwrap();
    CompiledMap::compile(&MapFile::parse(&text).unwrap(), db)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The scene through the Honda Nidec DBC: ego speed, then all 16 slots.
fn honda_frames() -> Vec<(u64, Frame)> {
    let db = honda_db();
    let ego = db.message_by_name("VEHICLE_STATE").unwrap();
    let mut out = Vec::new();
    for k in 0..CYCLES {
        out.push((
            cycle_start(k),
            encode_raw(ego, &[("VEHICLE_SPEED", EGO_SPEED * 3.6)]),
        ));
        let objs = scene(k);
        for slot in 0..16u32 {
            let m = db.message_by_name(&format!("TRACK_{slot}")).unwrap();
            let frame = match objs.iter().find(|o| o.slot == slot) {
                Some(o) => encode_raw(
                    m,
                    &[
                        ("LONG_DIST", o.x - HONDA_X0),
                        ("LAT_DIST", -o.y),
                        ("REL_SPEED", o.vx),
                        ("NEW_TRACK", if o.new { 1.0 } else { 0.0 }),
                    ],
                ),
                // An empty slot: LONG_DIST at its maximum raw value, the rest filler.
                None => encode_raw(m, &[("LONG_DIST", 255.9375), ("LAT_DIST", -0.0625)]),
            };
            out.push((slot_time(k, slot), frame));
        }
    }
    out
}

/// The scene through the GM object and powertrain DBCs: ego speed, then all 20 slots (polar).
fn gm_frames() -> Vec<(u64, Frame)> {
    let db = gm_db();
    let ego = db.message_by_name("ECMVehicleSpeed").unwrap();
    let mut out = Vec::new();
    for k in 0..CYCLES {
        out.push((
            cycle_start(k),
            encode_raw(ego, &[("VehicleSpeed", EGO_SPEED / 0.44704)]),
        ));
        let objs = scene(k);
        for slot in 0..20u32 {
            let m = db
                .message_by_name(&format!("LRRObject{:02}", slot + 1))
                .unwrap();
            let frame = match objs.iter().find(|o| o.slot == slot) {
                Some(o) => {
                    // Sensor frame, then polar: the map adds 2.25 m (near face) to the range.
                    let (xs, ys) = (o.x - GM_SENSOR_X, o.y);
                    let az = ys.atan2(xs);
                    let range = xs.hypot(ys) - 2.25;
                    let range_rate = o.vx * az.cos() + o.vy * az.sin();
                    encode_raw(
                        m,
                        &[
                            ("TrkRange", range),
                            ("TrkAzimuth", az.to_degrees()),
                            ("TrkRangeRate", range_rate),
                            ("TrkObjectID", f64::from(o.gm_id)),
                        ],
                    )
                }
                None => encode_raw(m, &[("TrkRange", 0.0)]),
            };
            out.push((slot_time(k, slot), frame));
        }
    }
    out
}

/// The same scene through the project's own DBC. `gm`: track ids are the GM object ids, and a
/// reused slot is simply a new id; otherwise (slot ids) the old object is flagged invalid first.
fn own_frames(gm: bool) -> Vec<(u64, Frame)> {
    let db = common::project_db();
    let f = |name: &str, values: &[(&str, f64)]| common::frame(&db, name, values);
    let mut out = Vec::new();
    for k in 0..CYCLES {
        let t = cycle_start(k);
        out.push((t, f(project::EGO_MOTION, &[("EgoVelLong", EGO_SPEED)])));
        let ego_len = if gm { 5.0 } else { 4.6 };
        out.push((
            t + 200,
            f(
                project::EGO_SIZE,
                &[
                    ("EgoLength", ego_len),
                    ("EgoWidth", 1.9 - if gm { 0.0 } else { 0.1 }),
                ],
            ),
        ));
        // Slot sensors report a vanished object as an empty (invalid) slot; sensors with ids
        // simply stop sending it (it goes stale).
        let now = scene(k);
        if !gm && k > 0 {
            for gone in scene(k - 1)
                .iter()
                .filter(|p| !now.iter().any(|o| o.slot == p.slot))
            {
                let ts = slot_time(k, gone.slot);
                let id = f64::from(gone.slot);
                out.push((
                    ts - 500,
                    f(
                        project::OBJECT_POSITION,
                        &[("ObjId", id), ("ObjValid", 0.0)],
                    ),
                ));
                out.push((ts, f(project::OBJECT_MOTION, &[("ObjId", id)])));
            }
        }
        for o in now {
            let track = f64::from(o.track(gm));
            let ts = slot_time(k, o.slot);
            let valid = if o.new && !gm { 0.0 } else { 1.0 };
            out.push((
                ts - 500,
                f(
                    project::OBJECT_POSITION,
                    &[
                        ("ObjId", track),
                        ("ObjPosX", o.x),
                        ("ObjPosY", o.y),
                        ("ObjHeadingValid", 0.0),
                        ("ObjValid", valid),
                    ],
                ),
            ));
            out.push((
                ts,
                f(
                    project::OBJECT_MOTION,
                    &[("ObjId", track), ("ObjVelRelX", o.vx), ("ObjVelRelY", o.vy)],
                ),
            ));
        }
    }
    out
}

/// The committed log equals the scene (or is rewritten with BLESS_RADAR_SCENES=1).
fn committed_log(name: &str, frames: &[(u64, Frame)]) -> PathBuf {
    let path = dir().join("scenes").join(name);
    let text = common::candump_log(frames);
    if std::env::var_os("BLESS_RADAR_SCENES").is_some() {
        std::fs::write(&path, &text).unwrap();
    }
    let committed = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (BLESS_RADAR_SCENES=1 writes it)", path.display()));
    assert!(
        committed == text,
        "{} differs from the scene in this test (BLESS_RADAR_SCENES=1 rewrites it)",
        path.display()
    );
    path
}

#[derive(Debug, Default)]
struct Run {
    onsets: Vec<(u64, u32, u8)>,
    releases: Vec<(u64, u32, ReleaseReason)>,
    scores: BTreeMap<(u64, u32), f32>,
    warning_frames: Vec<(u64, u32, Vec<u8>)>,
    problems: Vec<String>,
    stats: can_bridge::Stats,
}

fn run_frames(map: CompiledMap, frames: impl Iterator<Item = (u64, Frame)>) -> Run {
    let model = ModelFile::from_bytes(Path::new("m"), common::msra_blob()).unwrap();
    let mut config = EngineConfig::new(THRESHOLD);
    config.min_on_us = 0;
    let mut engine = Engine::new(model.model().unwrap(), map, config).unwrap();
    let mut run = Run::default();
    let mut last_t = 0;
    for (t, frame) in frames {
        last_t = t;
        engine.process(t, &frame, &mut |o| match o {
            Output::WarningOn {
                t_us, track, level, ..
            } => run.onsets.push((t_us, track, level)),
            Output::WarningOff {
                t_us,
                track,
                reason,
                ..
            } => run.releases.push((t_us, track, reason)),
            Output::Scored(s) => {
                run.scores.insert((s.t_us, s.track), s.score);
            }
            Output::WarningFrame { t_us, track, frame } => {
                run.warning_frames
                    .push((t_us, track, frame.data().to_vec()))
            }
            Output::Problem { reason, .. } => run.problems.push(reason.to_string()),
        });
    }
    engine.tick(last_t + 2_000_000, &mut |o| {
        if let Output::WarningOff {
            t_us,
            track,
            reason,
            ..
        } = o
        {
            run.releases.push((t_us, track, reason))
        }
    });
    run.stats = *engine.stats();
    run
}

fn run_log(map: CompiledMap, log: &Path) -> Run {
    let text = std::fs::read_to_string(log).unwrap();
    let frames: Vec<(u64, Frame)> = text
        .lines()
        .map(|l| {
            let r = can_codec::parse_line(l).unwrap();
            (r.timestamp_us, r.frame)
        })
        .collect();
    run_frames(map, frames.into_iter())
}

/// Same onsets and releases (times and tracks), scores within `tol` where both scored, and no
/// threshold crossing closer to the threshold than `tol` (so agreement is not luck).
fn assert_same_warnings(real: &Run, own: &Run, tol: f32, what: &str) {
    let mut matched = 0;
    let mut worst = (0.0f32, 0u64, 0u32);
    for (key, s) in &real.scores {
        if let Some(o) = own.scores.get(key) {
            matched += 1;
            if (s - o).abs() > worst.0 {
                worst = ((s - o).abs(), key.0, key.1);
            }
        }
    }
    eprintln!(
        "{what}: {matched} updates compared, largest score difference {:e} (track {} at {} us)",
        worst.0, worst.2, worst.1
    );
    for (key, s) in &real.scores {
        if let Some(o) = own.scores.get(key) {
            assert!(
                (s - o).abs() <= tol,
                "{what}: track {} at {} us: score {s} vs {o} through the own DBC",
                key.1,
                key.0
            );
            assert!(
                (o - THRESHOLD).abs() > tol,
                "{what}: track {} at {} us: score {o} within {tol} of the threshold: choose another scene",
                key.1,
                key.0
            );
        }
    }
    assert!(
        matched >= 60,
        "{what}: only {matched} updates scored by both"
    );
    assert_eq!(real.onsets, own.onsets, "{what}: warning onsets");
    let rel =
        |r: &Run| -> Vec<(u64, u32)> { r.releases.iter().map(|(t, k, _)| (*t, *k)).collect() };
    assert_eq!(rel(real), rel(own), "{what}: warning releases");
    let times = |r: &Run| -> Vec<(u64, u32)> {
        r.warning_frames.iter().map(|(t, k, _)| (*t, *k)).collect()
    };
    assert_eq!(times(real), times(own), "{what}: warning frames");
}

/// What the scene must show, whatever the model: the lead and the cut-in warn, object A in the
/// reused slot warns and is released when B takes its slot, and B never warns.
fn assert_scene_shape(run: &Run, gm: bool, what: &str) -> (u64, ReleaseReason) {
    let warned = |track: u32| run.onsets.iter().any(|(_, k, _)| *k == track);
    let ids: Vec<u32> = [0u32, 5, 9]
        .iter()
        .map(|s| scene(0).iter().find(|o| o.slot == *s).unwrap().track(gm))
        .collect();
    for id in &ids {
        assert!(
            warned(*id),
            "{what}: track {id} never warned: {:?}",
            run.onsets
        );
    }
    let b = if gm { 41 } else { 9 };
    let a_release = run
        .releases
        .iter()
        .find(|(_, k, _)| *k == ids[2])
        .expect("object A released");
    let b_onsets = run
        .onsets
        .iter()
        .filter(|(t, k, _)| *k == b && *t > a_release.0)
        .count();
    assert_eq!(b_onsets, 0, "{what}: object B inherited A's warning");
    (a_release.0, a_release.2)
}

#[test]
fn honda_nidec_radar_gives_the_warnings_of_the_own_dbc() {
    let log = committed_log("honda_nidec.log", &honda_frames());
    let real = run_log(map_for("honda_nidec_radar.toml", &honda_db()), &log);
    let (_db, own_map) = CompiledMap::project_default().unwrap();
    let own = run_frames(own_map, own_frames(false).into_iter());
    let a_release = assert_scene_shape(&real, false, "honda");
    assert_eq!(
        a_release,
        (slot_time(13, 9), ReleaseReason::NewObject),
        "object A's warning ends when NEW_TRACK says a new object took slot 9"
    );
    assert_scene_shape(&own, false, "own DBC (honda ids)");
    assert_eq!(real.stats.decode_errors, 0, "{:?}", real.problems);
    assert!(
        real.stats.invalid_objects > 0,
        "empty slots are read as invalid"
    );
    assert_eq!(real.stats.new_objects, 1);
    // Every input is on both grids: the same scores, bit for bit, and the same warning frames.
    assert_same_warnings(&real, &own, 0.0, "honda");
    assert_eq!(real.warning_frames, own.warning_frames);
}

#[test]
fn gm_object_radar_gives_the_warnings_of_the_own_dbc() {
    let log = committed_log("gm_lrr.log", &gm_frames());
    let real = run_log(map_for("gm_lrr_radar.toml", &gm_db()), &log);
    let (_db, own_map) = CompiledMap::project_default().unwrap();
    let own = run_frames(own_map, own_frames(true).into_iter());
    let (_, reason) = assert_scene_shape(&real, true, "gm");
    assert_eq!(
        reason,
        ReleaseReason::Stale,
        "object 40 stops updating when 41 takes its slot"
    );
    assert_scene_shape(&own, true, "own DBC (gm ids)");
    assert_eq!(real.stats.decode_errors, 0, "{:?}", real.problems);
    // Polar at 0.125 m / 0.125 deg / 0.125 m/s and a tangential speed from quantised positions:
    // the scores agree within 0.025 (no score of the scene is that close to the threshold), the
    // warnings exactly.
    assert_same_warnings(&real, &own, 0.025, "gm");
}

#[test]
fn a_missing_ego_speed_is_named_once() {
    // The GM scene without the powertrain bus: the bridge names what it waits for, once.
    let frames: Vec<(u64, Frame)> = gm_frames()
        .into_iter()
        .filter(|(_, f)| f.id != can_codec::CanId::Standard(1001))
        .collect();
    let run = run_frames(map_for("gm_lrr_radar.toml", &gm_db()), frames.into_iter());
    let waiting: Vec<_> = run
        .problems
        .iter()
        .filter(|p| p.contains("waiting for"))
        .collect();
    assert_eq!(waiting.len(), 1, "{:?}", run.problems);
    assert!(
        waiting[0].contains("ego.vel_long")
            && waiting[0].contains("`VehicleSpeed`")
            && waiting[0].contains("`ECMVehicleSpeed`"),
        "{}",
        waiting[0]
    );
    assert_eq!(run.stats.scored, 0);
    assert!(run.stats.stale_drops > 50);
}

#[test]
fn start_up_report_names_derived_and_defaulted_inputs() {
    let map = map_for("honda_nidec_radar.toml", &honda_db());
    let report = map.input_report().join("\n");
    for want in [
        "object.vel_y: DERIVED from the track's motion over 200 ms",
        "object.heading: DERIVED",
        "object.length: DEFAULT 4.5 m",
        "ego.vel_long <- signal `VEHICLE_SPEED` of message `VEHICLE_STATE`",
        "16 slot messages",
        "sensor mounted at x 2.3 m",
    ] {
        assert!(report.contains(want), "missing {want:?} in\n{report}");
    }
    let gm = map_for("gm_lrr_radar.toml", &gm_db())
        .input_report()
        .join("\n");
    assert!(gm.contains("object tangential velocity: DERIVED"), "{gm}");
    assert!(gm.contains("object.azimuth <- signal `TrkAzimuth`"), "{gm}");
}

#[test]
fn slot_maps_refuse_what_they_cannot_mean() {
    let db = honda_db();
    let text = std::fs::read_to_string(dir().join("honda_nidec_radar.toml")).unwrap();
    let compile = |t: &str| CompiledMap::compile(&MapFile::parse(t).unwrap(), &db);
    let err = compile(&text.replace("slots = \"TRACK_*\"", "slots = \"TRAK_*\""))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("object.slots") && err.contains("TRAK_*"),
        "{err}"
    );
    let err = compile(&text.replace(
        "pos_x = { signal = \"LONG_DIST\"",
        "pos_x = { message = \"TRACK_0\", signal = \"LONG_DIST\"",
    ))
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("object.pos_x") && err.contains("name only the signal"),
        "{err}"
    );
    let err = compile(&text.replace("missing_velocity = \"track_motion\"", ""))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("object.vel_y") && err.contains("missing_velocity"),
        "{err}"
    );
    let err = compile(&text.replace("signal = \"NEW_TRACK\"", "signal = \"NEW_TRAK\""))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("object.new_track") && err.contains("TRACK_0"),
        "{err}"
    );
}
