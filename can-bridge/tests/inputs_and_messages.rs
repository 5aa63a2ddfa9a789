#![cfg(feature = "check")]
//! What the bridge and `riskctl events-to-candump` accept and what they say: CANdb++'s
//! independent-signals message, logs of unreadable lines, interface names, a log exported with
//! another `--gap`, help and error wording, and the exporter's relative velocities.
mod common;
#[path = "common/run.rs"]
mod run;
use can_bridge::check::{check, CheckError};
use can_bridge::engine::{Engine, EngineConfig, Problem};
use can_bridge::map::CompiledMap;
use can_bridge::ModelFile;
use can_codec::{CanId, Database, DbcFileError};
use riskscore_data::candump_export::{write_candump, ExportError, ExportOptions, DEFAULT_GAP_US};
use riskscore_data::events::EventSet;
use run::bridge;
use std::path::Path;

fn model(dir: &Path) -> String {
    let p = dir.join("msra.rsk");
    std::fs::write(&p, common::msra_blob()).unwrap();
    p.to_str().unwrap().to_string()
}

fn export(set: &EventSet, opts: &ExportOptions) -> Result<String, ExportError> {
    let mut buf = Vec::new();
    write_candump(set, opts, &mut buf)?;
    Ok(String::from_utf8(buf).unwrap())
}

/// A CANdb++ export: unplaced signals in `VECTOR__INDEPENDENT_SIG_MSG` (id 0xC0000000, size 0).
const CANDB_EXPORT: &str = r#"VERSION ""

NS_ :

BS_:

BU_: XXX

BO_ 291 STATUS_MSG: 8 XXX
 SG_ RADAR_AVAILABLE : 0|1@1+ (1,0) [0|1] "" XXX

BO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX
 SG_ OldSignal : 0|8@1+ (1,0) [0|0] "" Vector__XXX
 SG_ OtherOld : 8|16@1- (0.1,0) [0|0] "" Vector__XXX
"#;

#[test]
fn the_candb_independent_signals_message_is_skipped() {
    let db = Database::parse(CANDB_EXPORT).unwrap();
    assert!(db.message_by_name("VECTOR__INDEPENDENT_SIG_MSG").is_none());
    assert_eq!(
        db.message_by_name("STATUS_MSG").unwrap().id,
        CanId::standard(291).unwrap()
    );
}

#[test]
fn a_log_of_unreadable_lines_lists_each_line_before_refusing() {
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let log = tmp.path().join("junk.log");
    std::fs::write(&log, "garbage\n(1.0) can0\n").unwrap();
    let log = log.to_str().unwrap();
    for args in [
        vec!["score-log", "--log", log, "--model", &m],
        vec!["decode", "--log", log, "--out", "-"],
    ] {
        let (code, _, stderr) = bridge(&args);
        assert_eq!(code, Some(1), "{stderr}");
        let first = stderr.find("junk.log:1: not a candump -L frame line");
        let second = stderr.find("junk.log:2: not a candump -L frame line");
        let verdict = stderr
            .find("nothing was scored: no CAN data frame (2 unreadable lines")
            .unwrap_or_else(|| panic!("{stderr}"));
        assert!(
            first.unwrap() < verdict && second.unwrap() < verdict,
            "{stderr}"
        );
        assert!(!stderr.contains("error and remote frames only"), "{stderr}");
    }
    let events = tmp.path().join("events");
    riskscore_data::events::write_events(&events, &common::simulated_events(1, 1)).unwrap();
    let (code, _, stderr) = bridge(&[
        "check",
        "--log",
        log,
        "--events",
        events.to_str().unwrap(),
        "--model",
        &m,
    ]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("junk.log:1: not a candump"), "{stderr}");
    assert!(
        stderr.contains("the log holds no frames: 2 unreadable lines"),
        "{stderr}"
    );
}

#[test]
fn a_log_whose_timestamps_never_advance_is_refused_naming_the_file_and_first_line() {
    // Before: exit 0 with 198 of 200 track updates dropped as duplicates (2 scored).
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let set = common::simulated_events(2, 1);
    let events = tmp.path().join("events");
    riskscore_data::events::write_events(&events, &set).unwrap();
    let frozen: String = export(&set, &ExportOptions::default())
        .unwrap()
        .lines()
        .map(|l| format!("(1700000000.500000){}\n", &l[l.find(')').unwrap() + 1..]))
        .collect();
    let frames = frozen.lines().count();
    let log = tmp.path().join("frozen.log");
    std::fs::write(&log, &frozen).unwrap();
    let log = log.to_str().unwrap();
    let old = tmp.path().join("old-output");
    std::fs::write(&old, "previous run\n").unwrap();
    let old = old.to_str().unwrap();
    let events = events.to_str().unwrap();
    let said = format!(
        "the timestamps do not advance: all {frames} frames, from line 1 on, are stamped 1700000000.500000"
    );
    for args in [
        vec![
            "score-log",
            "--log",
            log,
            "--model",
            &m,
            "--events-out",
            old,
        ],
        vec!["decode", "--log", log, "--out", old],
        vec![
            "check",
            "--log",
            log,
            "--events",
            events,
            "--model",
            &m,
            "--per-event-out",
            old,
        ],
    ] {
        let (code, _, stderr) = bridge(&args);
        assert_eq!(code, Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(log), "{stderr}");
        assert!(stderr.contains(&said), "{args:?}: {stderr}");
        assert_eq!(std::fs::read_to_string(old).unwrap(), "previous run\n");
    }
    // One snapshot (every track updated once at one time) costs nothing and is scored.
    let snapshot: String = frozen.lines().take(5).map(|l| format!("{l}\n")).collect();
    let one = tmp.path().join("snapshot.log");
    std::fs::write(&one, snapshot).unwrap();
    let (code, _, stderr) = bridge(&["score-log", "--log", one.to_str().unwrap(), "--model", &m]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("do not advance"), "{stderr}");
}

#[test]
fn an_empty_log_is_refused_as_empty_with_no_log_segment() {
    // Before: "1 log segments" in the summary and "no CAN data frame (the log has no frame
    // line)". An empty log is a failed capture or a wrong path, so it stays an error (exit 1,
    // old outputs kept), and says so.
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    for (name, text) in [("empty.log", ""), ("blank.log", "\n\n")] {
        let log = tmp.path().join(name);
        std::fs::write(&log, text).unwrap();
        let log = log.to_str().unwrap();
        refused_keeping_the_old_output(tmp.path(), log, &m, &[], |stderr| {
            assert!(stderr.contains(", 0 log segments,"), "{stderr}");
            assert!(
                stderr.contains(&format!("{log} holds no frames: the log is empty")),
                "{stderr}"
            );
        });
    }
    let (code, _, stderr) = bridge(&["score-log", "--log", "-", "--model", &m]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("standard input (--log -) holds no frames: the log is empty"),
        "{stderr}"
    );
    let events = tmp.path().join("events");
    riskscore_data::events::write_events(&events, &common::simulated_events(1, 1)).unwrap();
    let empty = tmp.path().join("empty.log");
    let (code, _, stderr) = bridge(&[
        "check",
        "--log",
        empty.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--model",
        &m,
    ]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("the log holds no frames: it is empty"),
        "{stderr}"
    );
}

/// `replay` of an empty log said "0 frames sent" and exited 0 (once the interface opened); it is
/// refused as score-log and check refuse it, exit 1, before any socket is opened: the interface
/// here does not exist, and is never named.
#[test]
fn replay_refuses_an_empty_log_before_opening_the_interface() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, text, blank) in [
        ("empty.log", "", ""),
        ("blank.log", "\n \n\r\n", " (3 blank lines)"),
    ] {
        let log = tmp.path().join(name);
        std::fs::write(&log, text).unwrap();
        let log = log.to_str().unwrap();
        let (code, _, stderr) = bridge(&["replay", "--log", log, "--iface", "nosuchcan9"]);
        assert_eq!(code, Some(1), "{stderr}");
        assert!(
            stderr.contains(&format!(
                "nothing was sent: {log} holds no frames: the log is empty{blank}"
            )),
            "{stderr}"
        );
        assert!(!stderr.contains("nosuchcan9"), "{stderr}");
        assert!(!stderr.contains("frames sent"), "{stderr}");
    }
}

#[test]
fn interface_names_no_candump_line_can_carry_are_refused_naming_the_flag() {
    let set = common::simulated_events(1, 2);
    for bad in ["can 0", "", "can#0", "can(0)", "a_very_long_name"] {
        let opts = ExportOptions {
            iface: bad.into(),
            ..ExportOptions::default()
        };
        let err = export(&set, &opts).unwrap_err();
        assert!(err.to_string().starts_with("--iface: "), "{bad:?}: {err}");
    }
    let ok = ExportOptions {
        iface: "fifteen_bytes_x".into(),
        ..ExportOptions::default()
    };
    assert!(export(&set, &ok).is_ok());

    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let log = tmp.path().join("d.log");
    std::fs::write(&log, export(&set, &ExportOptions::default()).unwrap()).unwrap();
    let (code, _, stderr) = bridge(&[
        "score-log",
        "--log",
        log.to_str().unwrap(),
        "--model",
        &m,
        "--warnings-iface",
        "can 0",
    ]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("--warnings-iface") && stderr.contains("whitespace"),
        "{stderr}"
    );
}

#[test]
fn check_of_a_log_exported_with_another_gap_names_the_gap_to_pass() {
    let set = common::simulated_events(12, 4);
    let opts = ExportOptions {
        gap_us: 10_000_000,
        ..ExportOptions::default()
    };
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("gap10.log");
    std::fs::write(&log, export(&set, &opts).unwrap()).unwrap();
    let model_file = ModelFile::from_bytes(Path::new("msra.rsk"), common::msra_blob()).unwrap();
    let (_db, map) = CompiledMap::project_default().unwrap();
    let mut engine = Engine::new(model_file.model().unwrap(), map, EngineConfig::new(1.5)).unwrap();
    let err = check(&log, &set, &mut engine, "MSRA", DEFAULT_GAP_US, None, 20).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, CheckError::Mismatch(_)), "{text}");
    assert!(
        text.contains(
            "the log fits the folder with --gap 10: pass the --gap events-to-candump was run with"
        ),
        "{text}"
    );
}

#[test]
fn help_and_errors_say_what_is_true() {
    // A DBC that cannot be read names the OS error once, as part of the message only.
    let err = Database::load(Path::new("/nonexistent/x.dbc")).unwrap_err();
    assert!(matches!(err, DbcFileError::Read { .. }));
    assert!(std::error::Error::source(&err).is_none());
    assert_eq!(err.to_string().matches("os error").count(), 1, "{err}");

    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let log = tmp.path().join("d.log");
    std::fs::write(
        &log,
        export(&common::simulated_events(1, 2), &ExportOptions::default()).unwrap(),
    )
    .unwrap();
    let log = log.to_str().unwrap();
    let (code, _, stderr) = bridge(&[
        "score-log",
        "--log",
        log,
        "--model",
        &m,
        "--dbc",
        "builtin:nope",
    ]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("--dbc builtin:nope: no such built-in DBC"),
        "{stderr}"
    );
    let (code, _, stderr) = bridge(&[
        "score-log",
        "--log",
        log,
        "--model",
        &m,
        "--dbc",
        "/nonexistent/x.dbc",
    ]);
    assert_eq!(code, Some(1));
    assert_eq!(stderr.matches("os error 2").count(), 1, "{stderr}");
    // An error that prints its cause, then the cause itself: the cause once.
    let set = common::simulated_events(1, 2);
    let events = tmp.path().join("events");
    riskscore_data::events::write_events(&events, &set).unwrap();
    std::fs::write(tmp.path().join("plain"), "mine").unwrap();
    let decoded = tmp.path().join("plain/x/dec");
    let (code, _, stderr) = bridge(&[
        "check",
        "--log",
        log,
        "--events",
        events.to_str().unwrap(),
        "--model",
        &m,
        "--decoded-events-out",
        decoded.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(1), "{stderr}");
    assert_eq!(stderr.matches("Not a directory").count(), 1, "{stderr}");

    let (_, help, _) = bridge(&["score-log", "--help"]);
    assert!(help.contains("--dbc <[BUS=]FILE>"), "{help}");
    assert!(help.contains("only where they share a bus"), "{help}");
    let (_, help, _) = bridge(&["check", "--help"]);
    assert!(
        help.contains("`operating_points`, `domain`") && help.contains("not part of it"),
        "{help}"
    );

    let off = Problem::OffTimeline {
        id: CanId::standard(0x100).unwrap(),
        t_us: 7,
        newest_us: 3,
    }
    .to_string();
    assert!(!off.contains("no frame follows it"), "{off}");
    assert!(
        off.contains("fewer than 3 frames after it continue from it"),
        "{off}"
    );
}

#[test]
fn a_partner_at_rest_decodes_at_rest_whatever_the_ego_speed() {
    let mut set = common::simulated_events(1, 6);
    // Ego speeds that the 0.002 m/s EgoVelLong does not carry exactly, world heading +x.
    for (i, f) in set.events[0].frames.iter_mut().enumerate() {
        f.ego.vx = 13.4567 + 0.0013 * i as f32;
        f.ego.vy = 0.0;
        f.ego.hx = 1.0;
        f.ego.hy = 0.0;
        f.partner.vx = 0.0;
        f.partner.vy = 0.0;
    }
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("rest.log");
    std::fs::write(&log, export(&set, &ExportOptions::default()).unwrap()).unwrap();
    let (code, table, stderr) = bridge(&["decode", "--log", log.to_str().unwrap(), "--out", "-"]);
    assert_eq!(code, Some(0), "{stderr}");
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (vx, vy) = (col("vx"), col("vy"));
    let mut rows = 0;
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let v: (f64, f64) = (cells[vx].parse().unwrap(), cells[vy].parse().unwrap());
        assert_eq!(v, (0.0, 0.0), "{line}");
        rows += 1;
    }
    assert_eq!(rows, set.events[0].frames.len(), "{stderr}");
}

#[test]
fn a_map_whose_warning_fields_share_a_signal_is_refused_naming_the_map_and_both_fields() {
    // Before: exit 0, and every warning frame carried the score's bits as its track id.
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let map = tmp.path().join("wtrack.toml");
    std::fs::write(
        &map,
        can_bridge::map::DEFAULT_MAP
            .replace("track_id = \"WarnTrackId\"", "track_id = \"WarnScore\""),
    )
    .unwrap();
    let log = tmp.path().join("a.log");
    std::fs::write(&log, "(1700000000.000000) can0 100#0000000000000000\n").unwrap();
    let out = tmp.path().join("w.log");
    let (code, _, stderr) = bridge(&[
        "score-log",
        "--log",
        log.to_str().unwrap(),
        "--map",
        map.to_str().unwrap(),
        "--model",
        &m,
        "--warnings-out",
        out.to_str().unwrap(),
    ]);
    assert_ne!(code, Some(0), "{stderr}");
    assert!(stderr.contains(map.to_str().unwrap()), "{stderr}");
    assert!(
        stderr.contains("warning.score") && stderr.contains("`warning.track_id`"),
        "{stderr}"
    );
    assert!(!out.exists());
}

#[test]
fn an_output_file_holding_a_model_or_checkpoint_is_refused_and_left_as_it_is() {
    // Before: every one of these replaced the model copy with a log or table, exit 0.
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let set = common::simulated_events(2, 1);
    let events = tmp.path().join("events");
    riskscore_data::events::write_events(&events, &set).unwrap();
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, export(&set, &ExportOptions::default()).unwrap()).unwrap();
    let (log, events) = (log.to_str().unwrap(), events.to_str().unwrap());
    let copy = tmp.path().join("mcopy.rsk");
    let checkpoint = tmp.path().join("drl.json");
    let checkpoint_text = "{\"format\": \"riskscore-checkpoint\", \"weights\": []}\n";
    std::fs::write(&checkpoint, checkpoint_text).unwrap();
    let blob = std::fs::read(&m).unwrap();
    for (target, what) in [
        (&copy, "a model blob"),
        (&checkpoint, "a training checkpoint"),
    ] {
        std::fs::write(&copy, &blob).unwrap();
        let t = target.to_str().unwrap();
        for (flag, args) in [
            (
                "--warnings-out",
                vec![
                    "score-log",
                    "--log",
                    log,
                    "--model",
                    &m,
                    "--warnings-out",
                    t,
                ],
            ),
            (
                "--events-out",
                vec!["score-log", "--log", log, "--model", &m, "--events-out", t],
            ),
            ("--out", vec!["decode", "--log", log, "--out", t]),
            (
                "--per-event-out",
                vec![
                    "check",
                    "--log",
                    log,
                    "--events",
                    events,
                    "--model",
                    &m,
                    "--per-event-out",
                    t,
                ],
            ),
        ] {
            let (code, stdout, stderr) = bridge(&args);
            assert_eq!(code, Some(1), "{args:?}: {stderr}");
            assert!(
                stderr.contains(&format!("{flag} {t}: it is {what}")),
                "{args:?}: {stderr}"
            );
            assert!(
                stderr.contains("writing there would replace the model; it is left as it is"),
                "{stderr}"
            );
            assert!(stdout.is_empty(), "{args:?}: {stdout}");
            assert_eq!(std::fs::read(&copy).unwrap(), blob);
            assert_eq!(
                std::fs::read_to_string(&checkpoint).unwrap(),
                checkpoint_text
            );
        }
    }
    // A file of the user's that is no model is an output as before.
    let notes = tmp.path().join("w.log");
    std::fs::write(&notes, "previous run\n").unwrap();
    let (code, _, stderr) = bridge(&[
        "score-log",
        "--log",
        log,
        "--model",
        &m,
        "--warnings-out",
        notes.to_str().unwrap(),
        "--events-out",
        "/dev/null",
    ]);
    assert_eq!(code, Some(0), "{stderr}");
}

#[test]
fn a_decoded_events_folder_that_holds_the_inputs_is_refused() {
    // Before: `--decoded-events-out proj` beside proj/drive.log and proj/sim ran with exit 0
    // and replaced the user's proj/frames.csv and proj/events.csv.
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let proj = tmp.path().join("proj");
    let set = common::simulated_events(2, 1);
    let events = proj.join("sim");
    riskscore_data::events::write_events(&events, &set).unwrap();
    let log = proj.join("drive.log");
    std::fs::write(&log, export(&set, &ExportOptions::default()).unwrap()).unwrap();
    let users = proj.join("frames.csv");
    std::fs::write(&users, "the user's own table\n").unwrap();
    let check = |out: &Path| {
        bridge(&[
            "check",
            "--log",
            log.to_str().unwrap(),
            "--events",
            events.to_str().unwrap(),
            "--model",
            &m,
            "--decoded-events-out",
            out.to_str().unwrap(),
        ])
    };
    let (code, stdout, stderr) = check(&proj);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "--decoded-events-out {} contains --",
            proj.display()
        )),
        "{stderr}"
    );
    assert!(stdout.is_empty(), "{stdout}");
    assert_eq!(
        std::fs::read_to_string(&users).unwrap(),
        "the user's own table\n"
    );
    assert!(!proj.join("events.csv").exists());
    // A folder of its own beside the inputs is written.
    let (code, _, stderr) = check(&proj.join("decoded"));
    assert_eq!(code, Some(0), "{stderr}");
    assert!(proj.join("decoded").join("frames.csv").exists());
    // So is a folder that holds the model: only its two files are replaced.
    let run = tmp.path().join("run");
    std::fs::create_dir(&run).unwrap();
    let model_in_run = run.join("m.rsk");
    std::fs::copy(&m, &model_in_run).unwrap();
    let (code, _, stderr) = bridge(&[
        "check",
        "--log",
        log.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--model",
        model_in_run.to_str().unwrap(),
        "--decoded-events-out",
        run.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(run.join("frames.csv").exists());
}

#[test]
fn a_log_with_timestamps_truncated_to_whole_seconds_is_refused() {
    // Before: exit 0 (also with --max-lost 0) with most track updates dropped as duplicates;
    // only a log whose every frame had one timestamp was refused.
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let set = common::simulated_events(2, 1);
    let coarse: String = export(&set, &ExportOptions::default())
        .unwrap()
        .lines()
        .map(|l| {
            let dot = l.find('.').unwrap();
            format!("{}.000000{}\n", &l[..dot], &l[l.find(')').unwrap()..])
        })
        .collect();
    let log = tmp.path().join("secs.log");
    std::fs::write(&log, &coarse).unwrap();
    let log = log.to_str().unwrap();
    refused_keeping_the_old_output(tmp.path(), log, &m, &["--max-lost", "0"], |stderr| {
        assert!(
            stderr.contains(&format!(
                "{log}: the timestamps are too coarse to order the track updates: "
            )),
            "{stderr}"
        );
    });
}

/// `score-log` (with `score_args` added) and `decode` of `log` both exit 1, pass `check` on
/// their stderr, and leave an existing output as it was.
fn refused_keeping_the_old_output(
    dir: &std::path::Path,
    log: &str,
    model: &str,
    score_args: &[&str],
    check: impl Fn(&str),
) {
    let old = dir.join("old-output");
    std::fs::write(&old, "previous run\n").unwrap();
    let old = old.to_str().unwrap();
    let mut score = vec![
        "score-log",
        "--log",
        log,
        "--model",
        model,
        "--events-out",
        old,
    ];
    score.extend_from_slice(score_args);
    for args in [score, vec!["decode", "--log", log, "--out", old]] {
        let (code, _, stderr) = bridge(&args);
        assert_eq!(code, Some(1), "{args:?}: {stderr}");
        check(&stderr);
        assert_eq!(std::fs::read_to_string(old).unwrap(), "previous run\n");
    }
}

#[test]
fn a_new_log_segment_names_the_line_of_its_first_frame() {
    // Before: the line of the last frame processed before the jump was confirmed, with the
    // time of the first frame after it.
    let tmp = tempfile::tempdir().unwrap();
    let m = model(tmp.path());
    let set = common::simulated_events(3, 2);
    let text = export(&set, &ExportOptions::default()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let half = lines.len() / 2;
    let shifted: String = lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let close = l.find(')').unwrap();
            let t: f64 = l[1..close].parse().unwrap();
            let t = if i >= half { t + 600.0 } else { t };
            format!("({t:.6}){}\n", &l[close + 1..])
        })
        .collect();
    let log = tmp.path().join("two.log");
    std::fs::write(&log, shifted).unwrap();
    let log = log.to_str().unwrap();
    let (code, _, stderr) = bridge(&[
        "score-log",
        "--log",
        log,
        "--model",
        &m,
        "--events-out",
        "/dev/null",
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let line = stderr
        .lines()
        .find(|l| l.contains("a new log segment starts"))
        .unwrap_or_else(|| panic!("{stderr}"));
    assert!(line.starts_with(&format!("{log}:{}: ", half + 1)), "{line}");
}
