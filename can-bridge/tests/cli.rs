//! The `can-bridge` command line: exit codes, line-numbered log problems, outputs.
mod common;
use can_codec::{project, Database, E2eChecker, E2eConfig};
use common::*;
use std::process::Command;

fn bridge() -> Command {
    Command::new(env!("CARGO_BIN_EXE_can-bridge"))
}

fn write_model(dir: &std::path::Path) -> std::path::PathBuf {
    let p = dir.join("model.rsk");
    std::fs::write(&p, msra_blob()).unwrap();
    p
}

#[test]
fn score_log_reads_real_candump_lines_and_reports_the_rest_by_line_number() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let db = project_db();
    let mut lines = vec![
        "(1700000000.000000) can0 18FEF100#0102030405060708 R".to_string(),
        "# a comment is not a frame".to_string(),
        "(1700000000.000100) can0 7FF#R".to_string(),
        "(1700000000.000200) can0 123##1AABBCCDDEEFF001122334455".to_string(),
        "(1700000000.000300) can0 20000004#0004000000000000".to_string(),
        "(1700000000.000400) can0 123###00".to_string(),
        String::new(),
    ];
    let mut t = 1_700_000_000_001_000u64;
    for k in 0..10 {
        for f in Cycle::closing(7, 30.0 - 2.0 * k as f64).frames(&db) {
            let mut s = String::new();
            can_codec::format_line(&mut s, t, "can0", &f);
            lines.push(format!("{s} T"));
            t += 200;
        }
        t += 100_000;
    }
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, lines.join("\n")).unwrap();
    let warnings = tmp.path().join("w.log");
    let events = tmp.path().join("e.jsonl");
    let out = bridge()
        .args([
            "score-log",
            "--threshold",
            "1.5",
            "--max-lost",
            "0.05",
            "--log",
        ])
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .arg("--warnings-out")
        .arg(&warnings)
        .arg("--events-out")
        .arg(&events)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("drive.log:2: not a candump -L frame line"),
        "{stderr}"
    );
    assert!(
        stderr.contains("drive.log:6: not a candump -L frame line: CAN XL"),
        "{stderr}"
    );
    assert!(stderr.contains("1 error frames"), "{stderr}");
    assert!(stderr.contains("2 unknown ids, 1 remote"), "{stderr}");
    assert!(stderr.contains("10 scored"), "{stderr}");

    let text = std::fs::read_to_string(&warnings).unwrap();
    let mut checker = E2eChecker::new(E2eConfig {
        data_id: project::WARNING_DATA_ID,
        crc_byte: 0,
        counter_byte: 1,
        max_delta: 1,
    });
    let mut n = 0;
    for line in text.lines() {
        let rec = can_codec::parse_line(line).unwrap();
        assert_eq!(rec.frame.id, can_codec::CanId::Standard(0x080));
        assert!(matches!(
            checker.check(rec.frame.data()),
            can_codec::E2eStatus::Initial | can_codec::E2eStatus::Ok
        ));
        n += 1;
    }
    assert!(n > 0);
    let ev = std::fs::read_to_string(&events).unwrap();
    let first: serde_json::Value = serde_json::from_str(ev.lines().next().unwrap()).unwrap();
    assert_eq!(first["track"], 7);
    assert_eq!(first["warning"], true);
}

#[test]
fn a_log_the_map_reads_nothing_of_is_an_error_and_leaves_old_outputs_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    // Another car's bus: ids the project DBC does not define.
    let log = tmp.path().join("other-car.log");
    std::fs::write(
        &log,
        "(0.000000) can0 1A0#0102030405060708\n(0.010000) can0 1A1#0102030405060708\n",
    )
    .unwrap();
    let warnings = tmp.path().join("w.log");
    std::fs::write(&warnings, "old warnings\n").unwrap();
    let states = tmp.path().join("states.csv");
    std::fs::write(&states, "old states\n").unwrap();
    let mut commands = vec![("score-log", "--warnings-out", &warnings)];
    // `decode` comes with the `check` feature.
    if cfg!(feature = "check") {
        commands.push(("decode", "--out", &states));
    }
    for (command, out_flag, out_path) in commands {
        let out = bridge()
            .arg(command)
            .arg("--log")
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .arg(out_flag)
            .arg(out_path)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{command}: {stderr}");
        assert!(
            stderr.contains("nothing was scored: none of the 2 data frames is a message the map reads (2 have ids the map does not read on their interface)"),
            "{command}: {stderr}"
        );
    }
    assert_eq!(
        std::fs::read_to_string(&warnings).unwrap(),
        "old warnings\n"
    );
    assert_eq!(std::fs::read_to_string(&states).unwrap(), "old states\n");
}

#[test]
fn a_log_on_the_wrong_interface_names_the_bus_mismatch_not_an_undefined_id() {
    // The project DBC bound to can0, the log recorded on can1: every id is defined and mapped,
    // only on another bus. "no --dbc file defines" would send the user hunting in the DBC.
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let log = tmp.path().join("can1.log");
    std::fs::write(
        &log,
        "(0.000000) can1 100#A115000000000000\n(0.000200) can1 101#FC113507\n(0.010000) can1 7FF#01\n",
    )
    .unwrap();
    let out = bridge()
        .args(["score-log", "--dbc", "can0=builtin:riskscore", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("none of the 3 data frames is a message the map reads (3 have ids the map does not read on their interface; 2 of them are messages the map reads on another bus"),
        "{stderr}"
    );
    assert!(!stderr.contains("no --dbc file defines"), "{stderr}");
}

#[test]
fn an_urgent_level_below_the_threshold_is_refused() {
    // `--urgent 1` with a threshold of 2 made every warning level 2 (and scores in [1, 2) no
    // warning at all), contrary to "level 2 when the score is >= this".
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, "(0.000000) can0 100#A115000000000000\n").unwrap();
    let run = |extra: &[&str]| {
        bridge()
            .args(["score-log", "--log"])
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run(&["--threshold", "2", "--urgent", "1"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--urgent 1 is below the warning threshold 2 (--threshold)"),
        "{stderr}"
    );
    // At the threshold is fine (every warning urgent, as asked).
    let out = run(&["--threshold", "2", "--urgent", "2"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("--urgent"), "{stderr}");
}

#[test]
fn warnings_out_dash_is_stdout_not_a_file_named_dash() {
    // `--log -` is stdin and `decode --out -` stdout; `score-log --warnings-out -` wrote a file
    // named `-` in the working folder.
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let db = project_db();
    let mut text = String::new();
    let mut t = 1_700_000_000_000_000u64;
    for k in 0..10 {
        for f in Cycle::closing(7, 30.0 - 2.0 * k as f64).frames(&db) {
            text.push_str(&line(t, &f));
            t += 200;
        }
        t += 100_000;
    }
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, text).unwrap();
    let run = |extra: &[&str]| {
        bridge()
            .current_dir(tmp.path())
            .args(["score-log", "--threshold", "1.5", "--log"])
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run(&["--warnings-out", "-", "--events-out", "e.jsonl"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!tmp.path().join("-").exists());
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.lines().count() > 0, "{stderr}");
    for l in stdout.lines() {
        assert_eq!(
            can_codec::parse_line(l).unwrap().frame.id,
            can_codec::CanId::Standard(0x080)
        );
    }
    assert!(std::fs::read_to_string(tmp.path().join("e.jsonl"))
        .unwrap()
        .contains("\"warning\":true"));
    // Frames and JSON events both on stdout would be one mixed stream: refused, whatever name
    // stdout goes by (`/dev/stdout` and `/proc/self/fd/1` ran with exit 0 and mixed them).
    for extra in [
        &["--warnings-out", "-"][..],
        &["--warnings-out", "-", "--events-out", "-"],
        &["--warnings-out", "/dev/stdout"],
        &["--warnings-out", "/proc/self/fd/1"],
        &["--warnings-out", "-", "--events-out", "/dev/stdout"],
    ] {
        let out = run(extra);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("give --events-out FILE"), "{stderr}");
        assert!(!tmp.path().join("-").exists());
    }
}

#[test]
#[cfg(feature = "check")]
fn check_outputs_named_dash_are_refused_not_written_as_files_named_dash() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    for (flag, name) in [
        ("--per-event-out", "-"),
        ("--decoded-events-out", "-"),
        // Other names of stdout ran with exit 0, the verdicts mixed into the report.
        ("--per-event-out", "/dev/stdout"),
        ("--per-event-out", "/proc/self/fd/1"),
    ] {
        let out = bridge()
            .current_dir(tmp.path())
            .args([
                "check",
                "--log",
                "drive.log",
                "--events",
                "events",
                "--model",
            ])
            .arg(&model)
            .args([flag, name])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains(&format!("{flag} {name}: stdout carries the report")),
            "{stderr}"
        );
        assert!(out.stdout.is_empty());
        assert!(!tmp.path().join("-").exists());
    }
}

#[test]
fn a_late_frame_names_the_line_of_the_frame_stamped_ahead() {
    // One frame stamped 0.6 s ahead (within the 5 s a log may jump) makes the frames after it
    // late; each late frame named only the newest timestamp, so the culprit had to be searched.
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let db = project_db();
    let mut lines = Vec::new();
    let mut t = 1_700_000_000_000_000u64;
    for k in 0..10 {
        for f in Cycle::closing(7, 30.0 - 2.0 * k as f64).frames(&db) {
            // The 12th line is stamped 0.6 s ahead.
            let stamp = if lines.len() == 11 { t + 600_000 } else { t };
            lines.push(line(stamp, &f));
            t += 200;
        }
        t += 100_000;
    }
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, lines.concat()).unwrap();
    let out = bridge()
        .args(["score-log", "--max-lost", "1", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("drive.log:13: frame ")
            && stderr
                .contains("is older than the newest frame (1700000000802200 us, line 12): dropped"),
        "{stderr}"
    );
}

#[test]
fn objects_logged_on_another_bus_than_their_binding_fail_and_leave_the_old_outputs() {
    // Ego frames on can0 (bound) decode, the object frames were logged on can1: nothing is
    // scored, and the closing line asked only whether the ego fields were on the log. Then it
    // named the other bus but exited 0 and emptied the old outputs.
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let db = project_db();
    let mut text = String::new();
    let mut ego_only = String::new();
    let mut t = 1_700_000_000_000_000u64;
    for k in 0..10 {
        for (i, f) in Cycle::closing(7, 30.0 - 2.0 * k as f64)
            .frames(&db)
            .iter()
            .enumerate()
        {
            let iface = if i < 2 { "can0" } else { "can1" };
            can_codec::format_line(&mut text, t, iface, f);
            text.push('\n');
            if i < 2 {
                can_codec::format_line(&mut ego_only, t, iface, f);
                ego_only.push('\n');
            }
            t += 200;
        }
        t += 100_000;
    }
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, text).unwrap();
    let ego_log = tmp.path().join("ego.log");
    std::fs::write(&ego_log, ego_only).unwrap();
    let (w, e) = (tmp.path().join("w.log"), tmp.path().join("e.jsonl"));
    let run = |log: &std::path::Path| {
        std::fs::write(&w, "old warnings\n").unwrap();
        std::fs::write(&e, "old events\n").unwrap();
        bridge()
            .args(["score-log", "--dbc", "can0=builtin:riskscore", "--log"])
            .arg(log)
            .arg("--model")
            .arg(&model)
            .arg("--warnings-out")
            .arg(&w)
            .arg("--events-out")
            .arg(&e)
            .output()
            .unwrap()
    };
    let out = run(&log);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("nothing was scored: 20 mapped messages decoded")
            && stderr.contains("30 frames are messages the map reads on another bus"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&w).unwrap(), "old warnings\n");
    assert_eq!(std::fs::read_to_string(&e).unwrap(), "old events\n");
    // A log that really holds ego frames only is no error: a note, exit 0, outputs written.
    let out = run(&ego_log);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("nothing was scored: 20 mapped messages decoded")
            && !stderr.contains("another bus"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&w).unwrap(), "");
}

#[test]
fn a_dbc_bus_longer_than_an_interface_name_is_refused_naming_the_option_and_the_limit() {
    // Before, `BUS=FILE` with a 16-byte BUS was read as one file name: "DBC
    // canbus-powertrain=builtin:riskscore: No such file or directory".
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, "").unwrap();
    let out = bridge()
        .args([
            "score-log",
            "--dbc",
            "canbus-powertrain=builtin:riskscore",
            "--log",
        ])
        .arg(&log)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--dbc"), "{stderr}");
    assert!(
        stderr.contains(
            "interface name `canbus-powertrain` is 17 bytes long; at most 15 (IFNAMSIZ - 1)"
        ),
        "{stderr}"
    );
    assert!(!stderr.contains("No such file"), "{stderr}");
}

/// A map's `[bus]` name was not checked (a 17-byte bus bound files no interface could carry);
/// it is refused when the map is loaded, naming the map, the key's line and the limit, as
/// `--dbc BUS=FILE` refuses it.
#[test]
fn a_map_bus_longer_than_an_interface_name_is_refused_naming_the_map_line_and_the_limit() {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, "").unwrap();
    let map = tmp.path().join("long-bus.toml");
    let text = format!(
        "{}\n[bus]\ncan0 = [\"builtin:riskscore\"]\ncanbus-powertrain = [\"builtin:riskscore\"]\n",
        can_bridge::map::DEFAULT_MAP
    );
    std::fs::write(&map, &text).unwrap();
    let line = 1 + text
        .lines()
        .position(|l| l.starts_with("canbus-powertrain"))
        .unwrap();
    let out = bridge()
        .args(["score-log", "--log"])
        .arg(&log)
        .arg("--map")
        .arg(&map)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!("map {}", map.display())),
        "{stderr}"
    );
    assert!(stderr.contains(&format!("line {line}")), "{stderr}");
    assert!(
        stderr.contains(
            "interface name `canbus-powertrain` is 17 bytes long; at most 15 (IFNAMSIZ - 1)"
        ),
        "{stderr}"
    );
}

#[test]
fn corrupt_model_is_refused_with_exit_code_1() {
    let tmp = tempfile::tempdir().unwrap();
    let model = tmp.path().join("bad.rsk");
    let mut blob = msra_blob();
    blob[0] = b'X';
    std::fs::write(&model, blob).unwrap();
    let log = tmp.path().join("x.log");
    std::fs::write(&log, "").unwrap();
    let out = bridge()
        .arg("score-log")
        .arg("--log")
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("bad.rsk") && stderr.contains("refused"),
        "{stderr}"
    );
}

#[test]
fn live_on_a_missing_interface_exits_2_with_a_clear_message() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let out = bridge()
        .args(["--iface", "rskcan-none0", "--duration", "1", "--model"])
        .arg(&model)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("interface rskcan-none0"), "{stderr}");
}

#[test]
fn live_on_several_interfaces_names_the_missing_one() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let out = bridge()
        .args(["live", "--iface", "rskcan-none1", "--iface", "rskcan-none2"])
        .args(["--merge-wait-ms", "5", "--duration", "1", "--model"])
        .arg(&model)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("interface rskcan-none1"), "{stderr}");
    // The wait is checked when parsed.
    let out = bridge()
        .args([
            "live",
            "--iface",
            "vcan0",
            "--merge-wait-ms",
            "5000",
            "--model",
        ])
        .arg(&model)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn bad_map_is_refused_naming_the_field() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let map = tmp.path().join("map.toml");
    std::fs::write(
        &map,
        can_bridge::map::DEFAULT_MAP.replace("\"ObjPosX\"", "\"PosX\""),
    )
    .unwrap();
    let log = tmp.path().join("x.log");
    std::fs::write(&log, "").unwrap();
    let out = bridge()
        .arg("score-log")
        .arg("--log")
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .arg("--map")
        .arg(&map)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("object.pos_x") && stderr.contains("PosX"),
        "{stderr}"
    );
}

#[test]
fn several_dbc_files_make_one_bus_and_a_doubly_defined_id_names_both_files() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let maps = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps");
    let honda = maps.join("dbc/acura_ilx_2016_nidec.dbc");
    let log = maps.join("scenes/honda_nidec.log");
    let run = |dbcs: &[&std::path::Path]| {
        let mut cmd = bridge();
        cmd.args(["score-log", "--threshold", "1.5", "--log"])
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .arg("--map")
            .arg(maps.join("honda_nidec_radar.toml"));
        for d in dbcs {
            cmd.arg("--dbc").arg(d);
        }
        cmd.output().unwrap()
    };
    // The radar's DBC plus the project's (for RISK_WARNING): decodes and warns.
    let out = run(&[&honda, std::path::Path::new("builtin:riskscore")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("can-bridge: input object.vel_y: DERIVED"),
        "{stderr}"
    );
    assert!(stderr.contains(" 0 decode errors"), "{stderr}");
    // Without the project DBC the warning message is missing: the map error names it.
    let out = run(&[&honda]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("warning.message") && stderr.contains("RISK_WARNING"),
        "{stderr}"
    );
    // A second file defining one of the radar's ids: refused, both files named.
    let clash = tmp.path().join("chassis.dbc");
    std::fs::write(
        &clash,
        "VERSION \"\"\n\nBU_: X\n\nBO_ 768 WHEEL_SPEEDS: 8 X\n SG_ WHEEL_SPEED_FL : 7|15@0+ (0.01,0) [0|250] \"kph\" X\n",
    )
    .unwrap();
    let out = run(&[&honda, &clash, std::path::Path::new("builtin:riskscore")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("defined twice")
            && stderr.contains("VEHICLE_STATE")
            && stderr.contains("acura_ilx_2016_nidec.dbc")
            && stderr.contains("WHEEL_SPEEDS")
            && stderr.contains("chassis.dbc"),
        "{stderr}"
    );
}

/// A warning track whose id the warning message cannot carry (24-bit sensor ids, 8-bit
/// `WarnTrackId`) is never sent as a clamped id: its frames are counted as unsent, the track is
/// named once, the summary says so, and tracks that fit warn on the bus as before.
#[test]
fn warning_frames_of_track_ids_the_warning_message_cannot_carry_are_reported_not_clamped() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let radar = "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: EGO RADAR RISK\n\n\
BO_ 256 EGO_MOTION: 8 EGO\n SG_ EgoVelLong : 0|16@1- (0.002,0) [-65.536|65.534] \"m/s\" RISK\n\n\
BO_ 768 OBJ_POS: 8 RADAR\n SG_ ObjId : 0|24@1+ (1,0) [0|16777215] \"\" RISK\n SG_ ObjPosX : 24|20@1- (0.001,0) [-524.288|524.287] \"m\" RISK\n SG_ ObjPosY : 44|20@1- (0.001,0) [-524.288|524.287] \"m\" RISK\n\n\
BO_ 769 OBJ_MOT: 8 RADAR\n SG_ ObjId : 0|24@1+ (1,0) [0|16777215] \"\" RISK\n SG_ ObjVelX : 24|20@1- (0.001,0) [-524.288|524.287] \"m/s\" RISK\n SG_ ObjVelY : 44|20@1- (0.001,0) [-524.288|524.287] \"m/s\" RISK\n\n\
BO_ 128 RISK_WARNING: 8 RISK\n SG_ WarnCrc : 0|8@1+ (1,0) [0|255] \"\" EGO\n SG_ WarnCounter : 8|4@1+ (1,0) [0|15] \"\" EGO\n SG_ WarnLevel : 12|4@1+ (1,0) [0|2] \"\" EGO\n SG_ WarnTrackId : 16|8@1+ (1,0) [0|255] \"\" EGO\n SG_ WarnScore : 24|32@1- (1,0) [0|0] \"\" EGO\n\n\
SIG_VALTYPE_ 128 WarnScore : 1;\n";
    let dbc = tmp.path().join("wide.dbc");
    std::fs::write(&dbc, radar).unwrap();
    let map = tmp.path().join("wide.toml");
    std::fs::write(
        &map,
        r#"[ego]
vel_long = { message = "EGO_MOTION", signal = "EgoVelLong" }
default_length = 4.5
default_width = 1.8
[object]
trigger = "OBJ_MOT"
velocity = "relative"
track_id = { OBJ_POS = "ObjId", OBJ_MOT = "ObjId" }
pos_x = { message = "OBJ_POS", signal = "ObjPosX" }
pos_y = { message = "OBJ_POS", signal = "ObjPosY" }
vel_x = { message = "OBJ_MOT", signal = "ObjVelX" }
vel_y = { message = "OBJ_MOT", signal = "ObjVelY" }
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
"#,
    )
    .unwrap();
    let db = Database::parse(radar).unwrap();
    // Tracks 250..=262 but 255 (a clamped id would show up as 255), each closing in from 20 m
    // ahead at 8 m/s, updated every 50 ms for 1 s.
    let tracks: Vec<u32> = (250..=262).filter(|&t| t != 255).collect();
    let mut lines = String::new();
    let mut t_us = 1_700_000_000_000_000u64;
    for step in 0..20 {
        lines += &line(t_us, &frame(&db, "EGO_MOTION", &[("EgoVelLong", 15.0)]));
        for &k in &tracks {
            let id = f64::from(k);
            let x = 20.0 - 8.0 * 0.05 * f64::from(step);
            t_us += 100;
            lines += &line(
                t_us,
                &frame(
                    &db,
                    "OBJ_POS",
                    &[("ObjId", id), ("ObjPosX", x), ("ObjPosY", 0.0)],
                ),
            );
            t_us += 100;
            lines += &line(
                t_us,
                &frame(
                    &db,
                    "OBJ_MOT",
                    &[("ObjId", id), ("ObjVelX", -8.0), ("ObjVelY", 0.0)],
                ),
            );
        }
        t_us += 50_000;
    }
    let log = tmp.path().join("tracks.log");
    std::fs::write(&log, lines).unwrap();
    let (events, warnings) = (tmp.path().join("ev.jsonl"), tmp.path().join("w.log"));
    let out = bridge()
        .args(["score-log", "--threshold", "0.5", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .arg("--map")
        .arg(&map)
        .arg("--dbc")
        .arg(&dbc)
        .arg("--events-out")
        .arg(&events)
        .arg("--warnings-out")
        .arg(&warnings)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let events = std::fs::read_to_string(&events).unwrap();
    let warned: std::collections::BTreeSet<u32> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v["warning"] == true)
        .map(|v| v["track"].as_u64().unwrap() as u32)
        .collect();
    assert!(
        warned.iter().any(|&t| t <= 255) && warned.iter().any(|&t| t > 255),
        "the scene must warn on tracks on both sides of 255: {warned:?}\n{events}"
    );
    let warning = db.message_by_name("RISK_WARNING").unwrap();
    let id_signal = &warning.signals[warning.signal_index("WarnTrackId").unwrap()];
    let sent: Vec<u32> = std::fs::read_to_string(&warnings)
        .unwrap()
        .lines()
        .map(|l| {
            let record = can_codec::parse_line(l).unwrap();
            id_signal.decode(record.frame.data()).unwrap() as u32
        })
        .collect();
    assert!(!sent.is_empty());
    let sent_tracks: std::collections::BTreeSet<u32> = sent.iter().copied().collect();
    let fitting: std::collections::BTreeSet<u32> =
        warned.iter().copied().filter(|&t| t <= 255).collect();
    assert_eq!(
        sent_tracks, fitting,
        "only fitting tracks go on the bus, as themselves"
    );
    let too_large: Vec<u32> = warned.iter().copied().filter(|&t| t > 255).collect();
    for t in &too_large {
        let named = format!(
            "track {t}: warning frames not sent: the id does not fit the warning message's WarnTrackId ([0, 255])"
        );
        assert_eq!(stderr.matches(&named).count(), 1, "{t}: {stderr}");
    }
    let summary = stderr.lines().find(|l| l.contains(" unsent, ")).unwrap();
    let unsent: u64 = summary
        .split(" unsent, ")
        .next()
        .and_then(|s| s.rsplit(", ").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{summary}"));
    assert!(unsent >= too_large.len() as u64, "{summary}");
    assert!(
        stderr.contains(&format!(
            "{unsent} warning frames NOT SENT ({} tracks with ids the warning message's WarnTrackId cannot carry",
            too_large.len()
        )),
        "{stderr}"
    );
}

/// One candump -L line (newline-terminated).
fn line(t_us: u64, frame: &can_codec::Frame) -> String {
    let mut s = String::new();
    can_codec::format_line(&mut s, t_us, "can0", frame);
    s.push('\n');
    s
}

#[test]
fn a_per_track_problem_names_the_log_line_as_a_decode_error_does() {
    // Before: `can-bridge: 1700000000.300600: track 7: second update ...`, no file or line.
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let db = project_db();
    let trigger = can_codec::CanId::Standard(0x201);
    let mut lines = Vec::new();
    let mut t = 1_700_000_000_000_000u64;
    for k in 0..10 {
        for f in Cycle::closing(7, 30.0 - 2.0 * k as f64).frames(&db) {
            lines.push(line(t, &f));
            t += 200;
        }
        t += 100_000;
    }
    // The fourth cycle's trigger twice: a second update of track 7 at the same timestamp.
    let at = lines
        .iter()
        .enumerate()
        .filter(|(_, l)| can_codec::parse_line(l.trim_end()).unwrap().frame.id == trigger)
        .nth(3)
        .unwrap()
        .0;
    lines.insert(at + 1, lines[at].clone());
    let stamp = lines[at][1..lines[at].find(')').unwrap()].to_string();
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, lines.concat()).unwrap();
    let out = bridge()
        .args(["score-log", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .args(["--events-out", "/dev/null"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "{}:{}: {stamp}: track 7: second update at the same timestamp",
            log.display(),
            at + 2
        )),
        "{stderr}"
    );
}
