//! How a log reaches the engine offline (`can_bridge::offline`): `score-log`, `check` and
//! `decode` route each line to its bus by the interface name and put a log of several
//! interfaces (as `candump -L can0 can1` interleaves them) back in timestamp order within
//! `--merge-wait-ms`.
#![cfg(feature = "check")]
mod common;
#[path = "common/run.rs"]
mod run;
use run::bridge;
#[path = "common/toyota.rs"]
mod toyota;
use std::path::{Path, PathBuf};

fn toyota_map() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/toyota_tss_p_radar.toml")
}

/// A two-bus Toyota log (powertrain on can0, radar on can1) of a small simulated folder, and a
/// model.
fn toyota_log(dir: &Path) -> (PathBuf, PathBuf) {
    let set = common::simulated_events(4, 3);
    let car = toyota::ToyotaCar::new(toyota::RadarModel::default());
    let log = dir.join("toyota.log");
    std::fs::write(&log, car.encode(&set).log).unwrap();
    let model = dir.join("msra.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    (log, model)
}

/// The log as `candump -L can0 can1` could print it: each line of can0 printed 3 ms late, so the
/// powertrain frames come after radar frames up to 3 ms newer.
fn interleaved(log: &str) -> String {
    let mut lines: Vec<(u64, &str)> = log
        .lines()
        .map(|l| {
            let t: f64 = l[1..l.find(')').unwrap()].parse().unwrap();
            let t_us = (t * 1e6).round() as u64;
            let delay = if l.contains(" can0 ") { 3_000 } else { 0 };
            (t_us + delay, l)
        })
        .collect();
    lines.sort_by_key(|(printed, _)| *printed);
    let mut out = String::new();
    for (_, l) in lines {
        out.push_str(l);
        out.push('\n');
    }
    out
}

fn decode(log: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let mut args = vec!["decode", "--log", log.to_str().unwrap(), "--out", "-"];
    args.extend_from_slice(extra);
    bridge(&args)
}

/// `score-log` of `log` (`-`: standard input) with every score printed and no line to lose.
fn score_log_args<'a>(log: &'a str, model: &'a Path) -> Vec<&'a str> {
    vec![
        "score-log",
        "--log",
        log,
        "--model",
        model.to_str().unwrap(),
        "--threshold",
        "1.5",
        "--all-scores",
        "--max-lost",
        "0",
    ]
}

fn score_log(log: &Path, model: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let mut args = score_log_args(log.to_str().unwrap(), model);
    args.extend_from_slice(extra);
    bridge(&args)
}

#[test]
fn decode_routes_frames_to_their_bus_like_score_log() {
    let tmp = tempfile::tempdir().unwrap();
    let (log, model) = toyota_log(tmp.path());
    let map = toyota_map();
    let map = map.to_str().unwrap();
    let (code, events, stderr) = score_log(&log, &model, &["--map", map]);
    assert_eq!(code, Some(0), "{stderr}");
    let scored = events
        .lines()
        .filter(|l| l.contains("\"scored\":true"))
        .count();
    assert!(scored > 0, "{stderr}");

    // The map's [bus] table, then the same binding given with --dbc BUS=FILE.
    let dbc = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/dbc");
    let pt = format!(
        "can0={}",
        dbc.join("toyota_new_mc_pt_generated.dbc").display()
    );
    let adas = format!("can1={}", dbc.join("toyota_adas.dbc").display());
    for extra in [
        vec!["--map", map],
        vec![
            "--map",
            map,
            "--dbc",
            &pt,
            "--dbc",
            "can0=builtin:riskscore",
            "--dbc",
            &adas,
        ],
    ] {
        let (code, table, stderr) = decode(&log, &extra);
        assert_eq!(code, Some(0), "{extra:?}: {stderr}");
        assert_eq!(
            table.lines().count() - 1,
            scored,
            "{extra:?}: one row per scored update: {stderr}"
        );
        assert!(stderr.contains(" 0 unknown ids"), "{stderr}");
    }
}

#[test]
fn a_log_of_two_interfaces_with_inversions_scores_like_the_ordered_log() {
    let tmp = tempfile::tempdir().unwrap();
    let (log, model) = toyota_log(tmp.path());
    let mixed = tmp.path().join("mixed.log");
    std::fs::write(&mixed, interleaved(&std::fs::read_to_string(&log).unwrap())).unwrap();
    let map = toyota_map();
    let map = map.to_str().unwrap();

    let (code, ordered_events, stderr) = score_log(&log, &model, &["--map", map]);
    assert_eq!(code, Some(0), "{stderr}");
    let (code, mixed_events, stderr) = score_log(&mixed, &model, &["--map", map]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stderr.contains(" 0 reordered"), "{stderr}");
    assert_eq!(mixed_events, ordered_events);

    let (code, ordered_table, _) = decode(&log, &["--map", map]);
    assert_eq!(code, Some(0));
    let (code, mixed_table, stderr) = decode(&mixed, &["--map", map]);
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(mixed_table, ordered_table);

    // Without the window the inverted frames are late: lost, and the run fails.
    let (code, _, stderr) = score_log(&mixed, &model, &["--map", map, "--merge-wait-ms", "0"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("late frames"), "{stderr}");
    // A window shorter than the inversions leaves the older frames late, as before.
    let (code, _, stderr) = score_log(&mixed, &model, &["--map", map, "--merge-wait-ms", "1"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("is older than the newest frame"),
        "{stderr}"
    );
}

#[test]
fn a_log_of_one_interface_is_read_as_without_the_window_inversions_and_all() {
    let tmp = tempfile::tempdir().unwrap();
    let set = common::simulated_events(3, 8);
    let mut buf = Vec::new();
    riskscore_data::candump_export::write_candump(
        &set,
        &riskscore_data::candump_export::ExportOptions::default(),
        &mut buf,
    )
    .unwrap();
    let text = String::from_utf8(buf).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    // Two cycles swapped (100 ms back) and two frames 0.4 ms apart swapped: late frames.
    lines.swap(50, 55);
    lines.swap(100, 102);
    let log = tmp.path().join("one.log");
    std::fs::write(&log, lines.join("\n") + "\n").unwrap();
    let model = tmp.path().join("msra.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    let run = |wait: &str| {
        let warnings = tmp.path().join(format!("w{wait}.log"));
        let (code, events, stderr) = bridge(&[
            "score-log",
            "--log",
            log.to_str().unwrap(),
            "--model",
            model.to_str().unwrap(),
            "--threshold",
            "1.5",
            "--all-scores",
            "--merge-wait-ms",
            wait,
            "--max-lost",
            "1",
            "--warnings-out",
            warnings.to_str().unwrap(),
        ]);
        assert_eq!(code, Some(0), "{stderr}");
        (events, stderr, std::fs::read(&warnings).unwrap())
    };
    let (events, stderr, warnings) = run("20");
    assert!(stderr.contains("late frames"), "{stderr}");
    assert_eq!((events, stderr, warnings), run("0"));
}

#[test]
fn a_log_on_standard_input_scores_like_the_file() {
    // `riskctl events-to-candump --out - | can-bridge score-log --log -`.
    let tmp = tempfile::tempdir().unwrap();
    let set = common::simulated_events(3, 8);
    let log = tmp.path().join("sim.log");
    let file = std::fs::File::create(&log).unwrap();
    riskscore_data::candump_export::write_candump(
        &set,
        &riskscore_data::candump_export::ExportOptions::default(),
        file,
    )
    .unwrap();
    let model = tmp.path().join("msra.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    let (code, from_file, stderr) = score_log(&log, &model, &[]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!from_file.is_empty());
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_can-bridge"))
        .args(score_log_args("-", &model))
        .stdin(std::fs::File::open(&log).unwrap())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert_eq!(String::from_utf8_lossy(&out.stdout), from_file);
}
