#![cfg(feature = "check")]
//! `check` aligns a log with its event folder on the content, not on the first line, and refuses
//! a log and a folder that do not belong together.
mod common;
use can_bridge::check::{check, CheckError, CheckReport};
use can_bridge::engine::{Engine, EngineConfig};
use can_bridge::map::CompiledMap;
use can_bridge::ModelFile;
use riskscore_data::candump_export::{write_candump, ExportOptions, DEFAULT_GAP_US};
use riskscore_data::events::{write_events, EventSet};
use std::path::Path;
use std::process::Command;

fn run_check(log_text: &str, set: &EventSet) -> Result<CheckReport, CheckError> {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("drive.log");
    std::fs::write(&log, log_text).unwrap();
    let model_file = ModelFile::from_bytes(Path::new("msra.rsk"), common::msra_blob()).unwrap();
    let (_db, map) = CompiledMap::project_default().unwrap();
    let mut engine = Engine::new(model_file.model().unwrap(), map, EngineConfig::new(1.5)).unwrap();
    check(&log, set, &mut engine, "MSRA", DEFAULT_GAP_US, None, 20)
}

fn exported(set: &EventSet) -> String {
    let mut buf = Vec::new();
    write_candump(set, &ExportOptions::default(), &mut buf).unwrap();
    String::from_utf8(buf).unwrap()
}

#[test]
fn missing_corrupt_or_foreign_first_lines_do_not_shift_the_timeline() {
    let set = common::simulated_events(20, 5);
    let log = exported(&set);
    let full = run_check(&log, &set).unwrap();
    assert_eq!(full.untraced, 0);
    assert!(full.verdicts.iter().all(|v| v.scored == v.frames));

    // First line missing: only the first cycle of the first event lacks its ego motion.
    let (_, rest) = log.split_once('\n').unwrap();
    let r = run_check(rest, &set).unwrap();
    assert_eq!(r.untraced, 0);
    assert_eq!(r.verdicts[0].scored, r.verdicts[0].frames - 1);
    assert!(r.verdicts[1..].iter().all(|v| v.scored == v.frames));

    // First line corrupt: the same, and the bad line is reported.
    let r = run_check(&format!("(17000000\u{0}0.0) vcan0 100#\n{rest}"), &set).unwrap();
    assert_eq!(r.log.bad.len(), 1);
    assert_eq!(r.log.bad[0].line, 1);
    assert!(r.verdicts[1..].iter().all(|v| v.scored == v.frames));

    // An unrelated frame 10 s before the log: metrics identical to the clean log.
    let r = run_check(
        &format!("(1699999990.000000) vcan0 7DF#0201050000000000\n{log}"),
        &set,
    )
    .unwrap();
    assert_eq!(r.report.to_json(), full.report.to_json());
    assert_eq!(r.verdicts, full.verdicts);
}

#[test]
fn a_folder_from_another_drive_is_refused() {
    let set = common::simulated_events(20, 5);
    let other = common::simulated_events(20, 99);
    let log = exported(&set);
    let err = run_check(&log, &other).unwrap_err();
    // Same timeline layout, other content: refused on the content.
    assert!(
        matches!(
            err,
            CheckError::Mismatch(_) | CheckError::ContentMismatch(_)
        ),
        "{err}"
    );
    assert!(err.to_string().contains("do not belong together"), "{err}");

    // Through the command line: exit 1 and the message; --decoded-events-out = --events refused.
    let tmp = tempfile::tempdir().unwrap();
    let other_dir = tmp.path().join("other");
    write_events(&other_dir, &other).unwrap();
    let log_path = tmp.path().join("drive.log");
    std::fs::write(&log_path, &log).unwrap();
    let model = tmp.path().join("m.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    let run = |extra: &[&std::ffi::OsStr]| {
        Command::new(env!("CARGO_BIN_EXE_can-bridge"))
            .arg("check")
            .arg("--log")
            .arg(&log_path)
            .arg("--events")
            .arg(&other_dir)
            .arg("--model")
            .arg(&model)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("do not belong together"), "{stderr}");
    let before = std::fs::read(other_dir.join("frames.csv")).unwrap();
    let out = run(&["--decoded-events-out".as_ref(), other_dir.as_os_str()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--decoded-events-out"), "{stderr}");
    assert_eq!(std::fs::read(other_dir.join("frames.csv")).unwrap(), before);
}

#[test]
fn a_glitch_frame_in_the_log_costs_check_only_that_frame() {
    let set = common::simulated_events(20, 5);
    let log = exported(&set);
    let full = run_check(&log, &set).unwrap();
    let lines: Vec<&str> = log.lines().collect();

    // One frame stamped 1e6 s ahead, in the middle of the drive: dropped alone, all 20 events
    // evaluated with the clean log's metrics, the frame named by its line.
    let k = lines.len() / 2;
    let (stamp, rest) = lines[k].split_once(')').unwrap();
    let t: f64 = stamp.trim_start_matches('(').parse().unwrap();
    let glitch = format!("({:.6}){rest}", t + 1e6);
    let mut glitched: Vec<&str> = lines.clone();
    glitched.insert(k, &glitch);
    let r = run_check(&(glitched.join("\n") + "\n"), &set).unwrap();
    assert_eq!(r.stats.out_of_window, 1);
    assert_eq!(r.losses.total(), 1);
    assert_eq!(r.losses.kept[0].line, k as u64 + 1);
    assert_eq!(r.verdicts.len(), 20);
    assert_eq!(r.verdicts, full.verdicts);
    assert_eq!(r.report.to_json(), full.report.to_json());
}
