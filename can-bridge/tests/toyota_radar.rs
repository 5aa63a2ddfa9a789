//! The Toyota TSS-P radar on its own bus next to the car's powertrain bus, through the shipped map
//! `maps/toyota_tss_p_radar.toml` and the two real DBCs, unmodified: a simulated event folder is
//! encoded as that car's two-bus candump log (`common/toyota.rs`), scored by `score-log`, and
//! compared with the project DBC's single-bus log of the same folder (`riskctl
//! events-to-candump`'s encoding): the same events warn, at nearly the same time, wherever the
//! radar sees the partner.
#![cfg(feature = "check")]
mod common;
#[path = "common/run.rs"]
mod run;
use run::bridge;
#[path = "common/toyota.rs"]
mod toyota;
use riskscore_data::candump_export::{write_candump, ExportOptions, Layout};
use std::path::{Path, PathBuf};

fn maps() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("maps")
}

/// First warning onset (s) per event, from `score-log`'s JSON events: an onset belongs to the
/// event whose time span (first cycle .. last cycle + 1 s) holds it.
fn onsets(events_jsonl: &str, layout: &Layout) -> Vec<Option<f64>> {
    let mut first: Vec<Option<f64>> = vec![None; layout.placements.len()];
    for line in events_jsonl.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        if v["warning"] != serde_json::Value::Bool(true) {
            continue;
        }
        let t_us = (v["t"].as_f64().unwrap() * 1e6).round() as u64;
        let k = layout
            .placements
            .iter()
            .position(|p| t_us >= p.cycle_us[0] && t_us <= p.cycle_us.last().unwrap() + 1_000_000)
            .unwrap_or_else(|| panic!("onset at {t_us} us is in no event"));
        first[k].get_or_insert(t_us as f64 / 1e6);
    }
    first
}

struct Runs {
    project: Vec<Option<f64>>,
    toyota: Vec<Option<f64>>,
    /// Per event: whether the radar saw the partner on every frame up to the single-bus path's
    /// onset (to the end of the event when it did not warn).
    seen_until_onset: Vec<bool>,
    toyota_stderr: String,
}

fn score(log: &Path, model: &Path, extra: &[&str], out: &Path) -> String {
    let mut args = vec![
        "score-log",
        "--log",
        log.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--threshold",
        "1.5",
        "--events-out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let (code, _, stderr) = bridge(&args);
    assert_eq!(code, Some(0), "{stderr}");
    stderr
}

fn run_both(events: usize, seed: u64) -> Runs {
    let tmp = tempfile::tempdir().unwrap();
    let mut set = common::simulated_events(events, seed);
    // Every partner a car of the map's default box: what a radar without a size signal assumes.
    // (What a truck costs is measured in examples/toyota_missing_inputs.rs.)
    for ev in &mut set.events {
        ev.dims.length_partner = 4.5;
        ev.dims.width_partner = 1.8;
        for f in &mut ev.frames {
            f.partner.length = 4.5;
            f.partner.width = 1.8;
        }
    }
    let model = tmp.path().join("msra.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    let layout = Layout::new(&set, &ExportOptions::default());

    let project_log = tmp.path().join("project.log");
    let summary = write_candump(
        &set,
        &ExportOptions::default(),
        std::fs::File::create(&project_log).unwrap(),
    )
    .unwrap();
    assert!(summary.skipped.is_empty());
    let project_events = tmp.path().join("project.jsonl");
    score(&project_log, &model, &[], &project_events);

    let car = toyota::ToyotaCar::new(toyota::RadarModel::default());
    let encoded = car.encode(&set);
    let toyota_log = tmp.path().join("toyota.log");
    std::fs::write(&toyota_log, &encoded.log).unwrap();
    let toyota_events = tmp.path().join("toyota.jsonl");
    let map = maps().join("toyota_tss_p_radar.toml");
    let toyota_stderr = score(
        &toyota_log,
        &model,
        &["--map", map.to_str().unwrap(), "--max-lost", "0"],
        &toyota_events,
    );
    let read = |p: &Path| std::fs::read_to_string(p).unwrap();
    let project = onsets(&read(&project_events), &layout);
    let seen_until_onset = encoded
        .seen
        .iter()
        .zip(&layout.placements)
        .zip(&project)
        .map(|((seen, place), onset)| {
            let until = onset.map_or(u64::MAX, |t| (t * 1e6).round() as u64);
            seen.iter()
                .zip(&place.cycle_us)
                .all(|(s, c)| *s || *c > until)
        })
        .collect();
    Runs {
        project,
        toyota: onsets(&read(&toyota_events), &layout),
        seen_until_onset,
        toyota_stderr,
    }
}

#[test]
fn the_real_radar_and_powertrain_dbcs_load_together_only_bound_to_their_buses() {
    let tmp = tempfile::tempdir().unwrap();
    // One ego speed frame on the powertrain bus (a log the map reads nothing of is an error).
    let log = tmp.path().join("speed.log");
    std::fs::write(&log, "(0.000000) can0 0B4#0000000000000000\n").unwrap();
    let model = tmp.path().join("msra.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    let dbc = maps().join("dbc");
    let adas = dbc.join("toyota_adas.dbc");
    let pt = dbc.join("toyota_new_mc_pt_generated.dbc");
    let map = maps().join("toyota_tss_p_radar.toml");
    let base = [
        "score-log",
        "--log",
        log.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--map",
        map.to_str().unwrap(),
    ];
    // The map's [bus] table.
    let (code, _, stderr) = bridge(&base);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stderr.contains("bus can1: 32 input messages"), "{stderr}");
    // The same on the command line.
    let can1 = format!("can1={}", adas.display());
    let can0 = format!("can0={}", pt.display());
    let bound = [
        &base[..],
        &[
            "--dbc",
            &can1,
            "--dbc",
            &can0,
            "--dbc",
            "can0=builtin:riskscore",
        ],
    ]
    .concat();
    let (code, _, stderr) = bridge(&bound);
    assert_eq!(code, Some(0), "{stderr}");
    // Unbound, both files are on every bus: refused, every clashing id named in one message.
    let unbound = [
        &base[..],
        &[
            "--dbc",
            adas.to_str().unwrap(),
            "--dbc",
            pt.to_str().unwrap(),
            "--dbc",
            "builtin:riskscore",
        ],
    ]
    .concat();
    let (code, _, stderr) = bridge(&unbound);
    assert_eq!(code, Some(1), "{stderr}");
    for needle in [
        "2 message ids",
        "0x224",
        "TRACK_B_4",
        "BRAKE_MODULE",
        "0x228",
        "TRACK_B_8",
        "VSC1S29",
    ] {
        assert!(stderr.contains(needle), "{needle}: {stderr}");
    }
}

#[test]
fn the_same_id_on_two_buses_is_two_messages_routed_by_interface() {
    let tmp = tempfile::tempdir().unwrap();
    let model = tmp.path().join("msra.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    let map = maps().join("toyota_tss_p_radar.toml");
    // 0x224 is TRACK_B_4 (8 bytes) on the radar bus and BRAKE_MODULE (not read) on the
    // powertrain bus. A 2-byte 0x224 on can0 is a frame the map does not read; on can1 it is a
    // TRACK_B_4 of the wrong length; on an interface no file is bound to, it is unknown too.
    let log = tmp.path().join("two.log");
    std::fs::write(
        &log,
        "(1700000000.000000) can0 224#0102\n(1700000000.001000) can1 224#0102\n(1700000000.002000) can9 224#0102\n",
    )
    .unwrap();
    let (code, _, stderr) = bridge(&[
        "score-log",
        "--log",
        log.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--map",
        map.to_str().unwrap(),
        "--max-lost",
        "1",
    ]);
    assert!(stderr.contains(" 1 decode errors"), "{stderr}");
    assert!(stderr.contains(" 2 unknown ids"), "{stderr}");
    assert!(stderr.contains("two.log:2: TRACK_B_4"), "{stderr}");
    // Nothing scored and a radar id on can9, which no file is bound to: the radar logged on the
    // wrong interface, a failure. The can0 frame is BRAKE_MODULE, a message of its own bus, and
    // is not counted with it.
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("; 1 frames are messages the map reads on another bus"),
        "{stderr}"
    );
}

#[test]
fn a_two_bus_toyota_log_warns_like_the_single_bus_log_where_the_radar_sees_the_partner() {
    let runs = run_both(80, 11);
    let stderr = &runs.toyota_stderr;
    assert!(stderr.contains(" 0 decode errors"), "{stderr}");
    assert!(!stderr.contains(" 0 scored"), "{stderr}");
    let mut compared = 0;
    let mut warned = 0;
    let mut table = String::new();
    for (k, seen) in runs.seen_until_onset.iter().enumerate() {
        table.push_str(&format!(
            "event {k}: seen {seen}, project {:?}, toyota {:?}\n",
            runs.project[k], runs.toyota[k]
        ));
    }
    eprintln!("{table}");
    for (k, seen) in runs.seen_until_onset.iter().enumerate() {
        if !seen {
            continue;
        }
        compared += 1;
        match (runs.project[k], runs.toyota[k]) {
            (None, None) => {}
            // One radar cycle (0.1 s) apart at most: 0.04 m / 0.025 m/s steps and a lateral
            // speed from the track's motion move a threshold crossing by a cycle, no more.
            (Some(a), Some(b)) => {
                warned += 1;
                assert!(
                    (a - b).abs() <= 0.11,
                    "event {k}: onsets {a} vs {b}\n{table}"
                )
            }
            (a, b) => panic!("event {k}: project {a:?}, toyota {b:?}\n{table}"),
        }
    }
    assert!(
        compared >= 10 && warned >= 4,
        "{compared} compared, {warned} warned\n{table}"
    );
}
