//! `can-bridge decode`: the state table the scorer sees, and the run-end sanity report catching
//! the map mistakes a new user makes (a wrong lateral sign, a missing sensor offset, a km/h speed
//! left unconverted), while the right map for the same log passes.
#![cfg(feature = "check")]
mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The front radar sits at the bumper, 2.25 m ahead of the ego centre.
const SENSOR_X: f64 = 2.25;
const STEP_US: u64 = 100_000;

/// One object as the scene has it: ego-frame centre at time 0 and relative velocity.
struct Object {
    track: u32,
    pos: (f64, f64),
    vel_rel: (f64, f64),
}

/// A queue at 3 m/s: a lead 1.5 m ahead of the bumper, two cut-ins from either side, and
/// traffic on both sides; 6 s at 10 Hz, positions as the bumper radar reports them.
/// `kmh`: object speeds sent in km/h.
fn scene(kmh: bool) -> String {
    let db = project_db();
    let mut objects = vec![
        Object {
            track: 1,
            pos: (6.0, 0.0),
            vel_rel: (0.0, 0.0),
        },
        Object {
            track: 2,
            pos: (20.0, 3.5),
            vel_rel: (-1.5, -0.7),
        },
        Object {
            track: 3,
            pos: (30.0, -3.5),
            vel_rel: (-1.5, 0.7),
        },
    ];
    for k in 0..8u32 {
        let side = if k % 2 == 0 { 3.5 } else { -3.5 };
        let sign = if k % 4 < 2 { 1.5 } else { -1.5 };
        objects.push(Object {
            track: 10 + k,
            pos: (15.0 + 6.0 * f64::from(k), side),
            vel_rel: (sign, 0.0),
        });
    }
    let unit = if kmh { 3.6 } else { 1.0 };
    let mut lines = String::new();
    let mut push = |t_us: u64, f: &can_codec::Frame| {
        can_codec::format_line(&mut lines, t_us, "can0", f);
        lines.push('\n');
    };
    for step in 0..60u64 {
        let t0 = 1_700_000_000_000_000 + step * STEP_US;
        let t = step as f64 * STEP_US as f64 / 1e6;
        push(
            t0,
            &frame(&db, can_codec::project::EGO_MOTION, &[("EgoVelLong", 3.0)]),
        );
        push(
            t0 + 10,
            &frame(
                &db,
                can_codec::project::EGO_SIZE,
                &[("EgoLength", 4.5), ("EgoWidth", 1.8)],
            ),
        );
        for (k, o) in objects.iter().enumerate() {
            let id = f64::from(o.track);
            let x = o.pos.0 + o.vel_rel.0 * t - SENSOR_X;
            let y = o.pos.1 + o.vel_rel.1 * t;
            let t_obj = t0 + 100 + 300 * k as u64;
            push(
                t_obj,
                &frame(
                    &db,
                    can_codec::project::OBJECT_POSITION,
                    &[
                        ("ObjId", id),
                        ("ObjPosX", x),
                        ("ObjPosY", y),
                        ("ObjValid", 1.0),
                    ],
                ),
            );
            push(
                t_obj + 100,
                &frame(
                    &db,
                    can_codec::project::OBJECT_SIZE,
                    &[("ObjId", id), ("ObjLength", 4.5), ("ObjWidth", 1.8)],
                ),
            );
            push(
                t_obj + 200,
                &frame(
                    &db,
                    can_codec::project::OBJECT_MOTION,
                    &[
                        ("ObjId", id),
                        ("ObjVelRelX", o.vel_rel.0 * unit),
                        ("ObjVelRelY", o.vel_rel.1 * unit),
                    ],
                ),
            );
        }
    }
    lines
}

/// The project map with the bumper radar's offset and `edit` applied.
fn map(dir: &Path, name: &str, sensor: bool, edit: &[(&str, &str)]) -> PathBuf {
    let mut text = can_bridge::map::DEFAULT_MAP.to_string();
    for (from, to) in edit {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, to);
    }
    if sensor {
        text.push_str(&format!("\n[sensor]\nx = {SENSOR_X}\n"));
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `decode` and returns (stderr, the CSV table).
fn decode(log: &Path, map: &Path, out: &Path) -> (String, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_can-bridge"))
        .arg("decode")
        .arg("--log")
        .arg(log)
        .arg("--map")
        .arg(map)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(run.status.success(), "{stderr}");
    (stderr, std::fs::read_to_string(out).unwrap_or_default())
}

fn sanity_lines(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.contains("sanity:")).collect()
}

const POS_Y: &str = r#"pos_y = { message = "OBJECT_POSITION", signal = "ObjPosY" }"#;
const VEL_X: &str = r#"vel_x = { message = "OBJECT_MOTION", signal = "ObjVelRelX" }"#;
const VEL_Y: &str = r#"vel_y = { message = "OBJECT_MOTION", signal = "ObjVelRelY" }"#;

#[test]
fn the_right_map_passes_and_each_map_mistake_is_caught_by_the_sanity_report() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let log = dir.join("queue.log");
    std::fs::write(&log, scene(false)).unwrap();
    let out = dir.join("states.csv");

    let (stderr, table) = decode(&log, &map(dir, "right.toml", true, &[]), &out);
    assert!(sanity_lines(&stderr).is_empty(), "{stderr}");
    // The lead 1.5 m ahead of the bumper: centre 6.0 m ahead, in the ego's lane.
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let lead = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|r| r[col("track")] == "1")
        .unwrap();
    let x: f64 = lead[col("x")].parse().unwrap();
    assert!((x - 6.0).abs() < 0.01, "{x}");
    assert_eq!(lead[col("size_default")], "false");

    // A lateral sign flipped on the position only: position change and sent speed disagree.
    let flipped = format!("{}, factor = -1 }}", POS_Y.trim_end_matches(" }"));
    let (stderr, _) = decode(
        &log,
        &map(dir, "sign.toml", true, &[(POS_Y, &flipped)]),
        &out,
    );
    let lines = sanity_lines(&stderr);
    assert!(
        lines.len() == 1 && lines[0].contains("opposite sign") && lines[0].contains("factor = -1"),
        "{stderr}"
    );

    // The bumper radar's offset forgotten: the lead sits inside the ego, 0.75 m past touching.
    let (stderr, _) = decode(&log, &map(dir, "offset.toml", false, &[]), &out);
    let lines = sanity_lines(&stderr);
    assert!(
        lines.len() == 1
            && lines[0].contains("inside the ego's box")
            && lines[0].contains("x 3.75 m")
            && lines[0].contains("0.75 m past touching")
            && lines[0].contains("sensor offset"),
        "{stderr}"
    );

    // Object speeds sent in km/h: right with factor 1/3.6, 3.6x too fast without it.
    let kmh_log = dir.join("kmh.log");
    std::fs::write(&kmh_log, scene(true)).unwrap();
    let converted = |s: &str| {
        format!(
            "{}, factor = 0.2777777777777778 }}",
            s.trim_end_matches(" }")
        )
    };
    let (vx, vy) = (converted(VEL_X), converted(VEL_Y));
    let (stderr, _) = decode(
        &kmh_log,
        &map(dir, "kmh-right.toml", true, &[(VEL_X, &vx), (VEL_Y, &vy)]),
        &out,
    );
    assert!(sanity_lines(&stderr).is_empty(), "{stderr}");
    let (stderr, _) = decode(&kmh_log, &map(dir, "kmh.toml", true, &[]), &out);
    let lines = sanity_lines(&stderr);
    assert!(
        lines
            .iter()
            .any(|l| l.contains("3.60 times") && l.contains("km/h")),
        "{stderr}"
    );
}

/// The table goes through the output layer: `--out` equal to the log is refused before anything
/// is read (the log stays byte for byte), `-` is CSV on stdout, `.parquet` is Parquet.
#[test]
fn decode_output_is_refused_over_its_input_and_goes_to_stdout_or_parquet() {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("queue.log");
    let text = scene(false);
    std::fs::write(&log, &text).unwrap();
    let run = |out: &Path| {
        Command::new(env!("CARGO_BIN_EXE_can-bridge"))
            .arg("decode")
            .arg("--log")
            .arg(&log)
            .arg("--out")
            .arg(out)
            .output()
            .unwrap()
    };
    let same = run(&log);
    assert_eq!(same.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&same.stderr).contains("--out"));
    assert_eq!(std::fs::read_to_string(&log).unwrap(), text);

    let stdout = run(Path::new("-"));
    assert!(stdout.status.success());
    let csv = String::from_utf8(stdout.stdout).unwrap();
    assert!(csv.starts_with("t,track,ego_vx,"), "{csv}");
    // 11 objects, 60 cycles.
    assert_eq!(csv.lines().count(), 1 + 11 * 60);

    let parquet = tmp.path().join("states.parquet");
    assert!(run(&parquet).status.success());
    let bytes = std::fs::read(&parquet).unwrap();
    assert!(bytes.starts_with(b"PAR1") && bytes.ends_with(b"PAR1"));
}

/// `--threshold` sets the `warning` column, which only `--model` adds: alone it was silently
/// ignored (no score, no warning column), now it is refused naming `--model`.
#[test]
fn decode_threshold_without_a_model_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("queue.log");
    std::fs::write(&log, scene(false)).unwrap();
    let out = tmp.path().join("states.csv");
    let run = Command::new(env!("CARGO_BIN_EXE_can-bridge"))
        .arg("decode")
        .arg("--log")
        .arg(&log)
        .args(["--threshold", "3", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--model"), "{stderr}");
    assert!(!out.exists());
}

/// `score-log` runs the same report at its end.
#[test]
fn score_log_prints_the_same_sanity_report() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let log = dir.join("queue.log");
    std::fs::write(&log, scene(false)).unwrap();
    let model = dir.join("m.rsk");
    std::fs::write(&model, msra_blob()).unwrap();
    let run = |map: &Path| {
        let out = Command::new(env!("CARGO_BIN_EXE_can-bridge"))
            .args(["score-log", "--threshold", "1.5", "--log"])
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .arg("--map")
            .arg(map)
            .arg("--events-out")
            .arg(dir.join("ev.jsonl"))
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let stderr = run(&map(dir, "offset.toml", false, &[]));
    assert!(
        stderr.contains("score-log: sanity: ") && stderr.contains("inside the ego's box"),
        "{stderr}"
    );
    let stderr = run(&map(dir, "right.toml", true, &[]));
    assert!(!stderr.contains("sanity:"), "{stderr}");
}
