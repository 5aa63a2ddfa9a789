//! Nothing lost without saying so: timestamp glitches and jumps, unreadable and over-long lines,
//! outputs that would overwrite inputs, numeric options, DBC and map mistakes (issue #10, part 2).
mod common;
use can_bridge::engine::{Engine, EngineConfig, Output};
use can_bridge::map::{CompiledMap, MapFile, DEFAULT_MAP};
use can_bridge::ModelFile;
use can_codec::Frame;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bridge() -> Command {
    Command::new(env!("CARGO_BIN_EXE_can-bridge"))
}

fn write_model(dir: &Path) -> PathBuf {
    let p = dir.join("model.rsk");
    std::fs::write(&p, msra_blob()).unwrap();
    p
}

struct Run {
    scored: Vec<(u32, u64)>,
    stats: can_bridge::Stats,
}

fn run_engine(frames: &[(u64, Frame)]) -> Run {
    let model_file = ModelFile::from_bytes(Path::new("m.rsk"), msra_blob()).unwrap();
    let (_db, map) = CompiledMap::project_default().unwrap();
    let mut engine = Engine::new(model_file.model().unwrap(), map, EngineConfig::new(1.5)).unwrap();
    let mut scored = Vec::new();
    let mut collect = |o: Output| {
        if let Output::Scored(obs) = o {
            scored.push((obs.track, obs.t_us));
        }
    };
    for (t, f) in frames {
        engine.process(*t, f, &mut collect);
    }
    engine.finish(&mut collect);
    Run {
        scored,
        stats: *engine.stats(),
    }
}

const T0: u64 = 1_700_000_000_000_000;

#[test]
fn one_frame_a_million_seconds_ahead_costs_that_frame_only() {
    let db = project_db();
    let clean = two_track_drive(&db, 0..1200, T0);
    let mut glitched = clean.clone();
    let (t, f) = glitched[3000];
    glitched.insert(3000, (t + 1_000_000_000_000, f));
    let (a, b) = (run_engine(&clean), run_engine(&glitched));
    assert_eq!(b.stats.out_of_window, 1);
    assert_eq!(b.stats.reordered, 0);
    assert_eq!(b.stats.segments, 0);
    assert_eq!(
        a.scored, b.scored,
        "every update of the clean log is scored"
    );
    assert_eq!(a.scored.len(), 2400);

    // The same log through score-log: exit 0 (1 of 12,001 lines), the loss named.
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("glitch.log");
    std::fs::write(&log, candump_log(&glitched)).unwrap();
    let out = bridge()
        .args(["score-log", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .arg("--events-out")
        .arg(tmp.path().join("e.jsonl"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("2400 scored"), "{stderr}");
    assert!(stderr.contains("1 off the timeline"), "{stderr}");
    assert!(stderr.contains("lost 1 of 12001 lines"), "{stderr}");
    // With --max-lost 0 the same loss fails the run.
    let out = bridge()
        .args(["score-log", "--max-lost", "0", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn a_jump_back_of_100_s_starts_a_new_segment_and_loses_nothing() {
    let db = project_db();
    let first = two_track_drive(&db, 0..600, T0);
    let end = first.last().unwrap().0;
    // Recordings concatenated: the second starts 100 s before the first ended.
    let second = two_track_drive(&db, 0..600, end - 100_000_000);
    let mut log = first.clone();
    log.extend(second);
    let r = run_engine(&log);
    assert_eq!(r.stats.reordered, 0);
    assert_eq!(r.stats.out_of_window, 0);
    assert_eq!(r.stats.segments, 1);
    assert_eq!(r.scored.len(), 2400, "{:?}", r.stats);
    // A forward jump of an hour (a logger paused) is a new segment too.
    let mut log = first;
    log.extend(two_track_drive(&db, 0..600, end + 3_600_000_000));
    let r = run_engine(&log);
    assert_eq!((r.stats.segments, r.stats.out_of_window), (1, 0));
    assert_eq!(r.scored.len(), 2400);
}

#[test]
fn a_run_that_loses_too_much_fails_with_a_summary_and_writes_no_output() {
    let db = project_db();
    let mut text = String::new();
    for (i, line) in candump_log(&two_track_drive(&db, 0..100, T0))
        .lines()
        .enumerate()
    {
        text.push_str(line);
        text.push('\n');
        if i % 10 == 0 {
            text.push_str("garbage\n");
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("bad.log");
    std::fs::write(&log, &text).unwrap();
    let warnings = tmp.path().join("w.log");
    std::fs::write(&warnings, "previous run\n").unwrap();
    let out = bridge()
        .args(["score-log", "--threshold", "1.5", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .arg("--warnings-out")
        .arg(&warnings)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("bad.log:2: not a candump -L frame line"),
        "{stderr}"
    );
    assert!(stderr.contains("lost 100 of 1100 lines"), "{stderr}");
    assert!(stderr.contains("more than --max-lost 0.01"), "{stderr}");
    assert!(stderr.contains("80 more lines skipped"), "{stderr}");
    // The failed run left the previous output as it was, and no temporary file.
    assert_eq!(
        std::fs::read_to_string(&warnings).unwrap(),
        "previous run\n"
    );
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 3);
}

#[test]
fn non_utf8_and_over_long_lines_are_skipped_by_line_and_the_rest_is_kept() {
    let db = project_db();
    let text = candump_log(&two_track_drive(&db, 0..500, T0));
    let mut bytes = Vec::new();
    for (i, line) in text.lines().enumerate() {
        bytes.extend_from_slice(line.as_bytes());
        if i == 10 {
            bytes.extend_from_slice(b" \xe9t\xe9");
        }
        bytes.push(b'\n');
        if i == 20 {
            bytes.extend(std::iter::repeat_n(b'7', 200 << 20 >> 4));
            bytes.push(b'\n');
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("mixed.log");
    std::fs::write(&log, &bytes).unwrap();
    let out = bridge()
        .args(["score-log", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("mixed.log:11: not UTF-8"), "{stderr}");
    assert!(
        stderr.contains("mixed.log:22: line of 13107200 bytes is longer than the 4096-byte limit"),
        "{stderr}"
    );
    // Line 11 was an EGO_MOTION frame of the first cycle: that cycle is stale, all others score.
    assert!(stderr.contains("lost 2 of 5001 lines"), "{stderr}");
}

#[test]
fn a_file_without_line_breaks_is_refused_quickly() {
    let tmp = tempfile::tempdir().unwrap();
    let out = bridge()
        .args(["score-log", "--log", "/dev/zero", "--model"])
        .arg(write_model(tmp.path()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("/dev/zero") && stderr.contains("no line break"),
        "{stderr}"
    );
}

#[test]
fn outputs_that_name_an_input_are_refused_and_the_input_is_untouched() {
    let db = project_db();
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("drive.log");
    let text = candump_log(&two_track_drive(&db, 0..20, T0));
    std::fs::write(&log, &text).unwrap();
    let model = write_model(tmp.path());
    for flag in ["--warnings-out", "--events-out"] {
        let out = bridge()
            .args(["score-log", "--log"])
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .arg(flag)
            .arg(tmp.path().join(".").join("drive.log"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains(flag) && stderr.contains("same file as --log"),
            "{stderr}"
        );
        assert_eq!(std::fs::read_to_string(&log).unwrap(), text);
    }
    let out = bridge()
        .args(["score-log", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .arg("--events-out")
        .arg(&model)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read(&model).unwrap(), msra_blob());
}

#[test]
fn numeric_options_are_validated_when_parsed() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let log = tmp.path().join("x.log");
    std::fs::write(&log, "").unwrap();
    for (flag, value) in [
        ("--stale-ms", "18446744073709552"),
        ("--stale-ms", "0"),
        ("--urgent", "nan"),
        ("--threshold", "inf"),
        ("--hysteresis", "-1"),
        ("--min-on-ms", "99999999999"),
        ("--max-lost", "2"),
    ] {
        let out = bridge()
            .args(["score-log", "--log"])
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .arg(format!("{flag}={value}"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {stderr}");
        assert!(stderr.contains(flag), "{stderr}");
    }
}

#[test]
fn impossible_dbc_content_is_refused_with_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let model = write_model(tmp.path());
    let log = tmp.path().join("x.log");
    std::fs::write(&log, "").unwrap();
    let project = can_codec::project::PROJECT_DBC;
    let line_of = |needle: &str| project.lines().position(|l| l.contains(needle)).unwrap() + 1;
    let cases = [
        (
            project.replace("[0.5|30] \"m\"", "[30|0.5] \"m\""),
            line_of("SG_ EgoLength"),
            "min > max",
        ),
        (
            project.replace("BO_ 256 EGO_MOTION", "BO_ 4294967295 EGO_MOTION"),
            line_of("BO_ 256 EGO_MOTION"),
            "extended (29-bit) id",
        ),
        (
            project.replace("BO_ 257 EGO_SIZE: 4", "BO_ 257 EGO_SIZE: 9"),
            line_of("BO_ 257 EGO_SIZE"),
            "size 9 bytes",
        ),
        // A second ObjPosX (0.002 m) before the original: refused at the original's line, the
        // second definition, instead of the first one decoding.
        (
            project.replace(
                " SG_ ObjPosX :",
                " SG_ ObjPosX : 15|20@0- (0.002,0) [-1048.576|1048.574] \"m\" RISK\n SG_ ObjPosX :",
            ),
            line_of("SG_ ObjPosX") + 1,
            "message OBJECT_POSITION: signal ObjPosX: defined twice",
        ),
    ];
    for (text, line, why) in cases {
        let dbc = tmp.path().join("bad.dbc");
        std::fs::write(&dbc, text).unwrap();
        let out = bridge()
            .args(["score-log", "--log"])
            .arg(&log)
            .arg("--model")
            .arg(&model)
            .arg("--dbc")
            .arg(&dbc)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains(&format!("bad.dbc:{line}:")) && stderr.contains(why),
            "{why}: {stderr}"
        );
    }
    // Harmless: a byte-order mark and a Latin-1 comment (vendor files carry both). One ego frame
    // to decode: a log without a frame the map reads is an error of its own.
    std::fs::write(&log, "(0.000000) can0 100#0000000000000000\n").unwrap();
    let mut bytes = b"\xEF\xBB\xBF".to_vec();
    bytes.extend_from_slice(project.as_bytes());
    bytes.extend_from_slice(b"\nCM_ BO_ 256 \"Vitesse du v\xe9hicule\";\n");
    let dbc = tmp.path().join("vendor.dbc");
    std::fs::write(&dbc, bytes).unwrap();
    let out = bridge()
        .args(["score-log", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(&model)
        .arg("--dbc")
        .arg(&dbc)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
}

#[test]
fn a_signal_mapped_twice_or_a_wide_signal_as_a_flag_is_refused() {
    let db = project_db();
    let twice = DEFAULT_MAP.replace(
        "pos_y = { message = \"OBJECT_POSITION\", signal = \"ObjPosY\" }",
        "pos_y = { message = \"OBJECT_POSITION\", signal = \"ObjPosX\" }",
    );
    assert_ne!(twice, DEFAULT_MAP);
    let err = CompiledMap::compile(&MapFile::parse(&twice).unwrap(), &db).unwrap_err();
    assert!(
        err.to_string().contains("object.pos_y") && err.to_string().contains("object.pos_x"),
        "{err}"
    );
    // A 16-bit measurement (the object length) as the valid flag.
    let wide = DEFAULT_MAP
        .replace(
            "valid = { message = \"OBJECT_POSITION\", signal = \"ObjValid\" }",
            "valid = { message = \"OBJECT_SIZE\", signal = \"ObjLength\" }",
        )
        .replace(
            "length = { message = \"OBJECT_SIZE\", signal = \"ObjLength\" }\n",
            "",
        );
    assert_ne!(wide, DEFAULT_MAP);
    let err = CompiledMap::compile(&MapFile::parse(&wide).unwrap(), &db).unwrap_err();
    assert!(
        err.to_string().contains("object.valid") && err.to_string().contains("16-bit"),
        "{err}"
    );
}

#[test]
fn undecodable_frames_of_mapped_messages_are_losses_named_by_line() {
    let db = project_db();
    let mut frames = two_track_drive(&db, 0..100, T0);
    // 20 OBJECT_SIZE frames (a mapped message) one byte short: 2% of the log, dropped whole.
    for k in 0..20 {
        let (_, f) = &mut frames[k * 10 + 3];
        *f = Frame::data_frame(f.id, &f.data()[..4]).unwrap();
    }
    // 100 RISK_WARNING frames of the wrong length: a DBC message the map does not read, so
    // nothing the bridge needs is lost with them.
    let warning_id = id_of(&db, can_codec::project::RISK_WARNING);
    let mut with_unmapped = Vec::new();
    for (i, (t, f)) in frames.iter().enumerate() {
        with_unmapped.push((*t, *f));
        if i % 10 == 9 {
            with_unmapped.push((*t, Frame::data_frame(warning_id, &[1, 2, 3]).unwrap()));
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("dlc.log");
    std::fs::write(&log, candump_log(&with_unmapped)).unwrap();
    let model = write_model(tmp.path());
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
    let out = run(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    // Line 4 is the first short OBJECT_SIZE frame (the unmapped frames follow each 10th line).
    assert!(
        stderr.contains("dlc.log:4: OBJECT_SIZE (202)")
            && stderr.contains("wrong DLC: 4 bytes, DBC says 5"),
        "{stderr}"
    );
    assert!(stderr.contains("dlc.log:213: OBJECT_SIZE"), "{stderr}");
    assert!(
        stderr.contains(
            "dlc.log: lost 20 of 1100 lines (1.818%): 0 unreadable lines, 20 frames not decodable; more than --max-lost 0.01"
        ),
        "{stderr}"
    );
    // Listed by line only, not once more by timestamp among the per-frame problems.
    assert_eq!(stderr.matches("wrong DLC").count(), 20, "{stderr}");
    let out = run(&["--max-lost", "0.02"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("(within --max-lost 0.02)"), "{stderr}");
    assert!(stderr.contains("100 unknown ids"), "{stderr}");
}

#[test]
fn a_held_glitch_frame_is_reported_at_its_own_line() {
    let db = project_db();
    let mut frames = two_track_drive(&db, 0..50, T0);
    let (t, f) = frames[100];
    frames.insert(100, (t + 1_000_000_000_000, f));
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("glitch.log");
    std::fs::write(&log, candump_log(&frames)).unwrap();
    let out = bridge()
        .args(["score-log", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .args(["--max-lost", "0"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("glitch.log:101: frame 100 at 1701000001000000 us is far outside"),
        "{stderr}"
    );
    assert!(
        stderr.contains(
            "lost 1 of 501 lines (0.200%): 0 unreadable lines, 1 frames off the timeline"
        ),
        "{stderr}"
    );
}

/// `--events-out /dev/null` (as tests/vm/bench.sh does) must write into the device, not rename a
/// temporary file over it: as root that replaced /dev/null with a regular file for the machine.
#[cfg(unix)]
#[test]
fn outputs_to_dev_null_leave_the_device_in_place() {
    use std::os::unix::fs::FileTypeExt;
    let null = Path::new("/dev/null");
    let is_device = || std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device());
    assert!(
        is_device(),
        "/dev/null is not a character device before the test"
    );
    let db = project_db();
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, candump_log(&two_track_drive(&db, 0..50, T0))).unwrap();
    let out = bridge()
        .args(["score-log", "--threshold", "1.5", "--log"])
        .arg(&log)
        .arg("--model")
        .arg(write_model(tmp.path()))
        .args(["--events-out", "/dev/null", "--warnings-out", "/dev/null"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(is_device(), "score-log replaced /dev/null");
}
