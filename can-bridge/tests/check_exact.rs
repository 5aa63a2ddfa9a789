#![cfg(feature = "check")]
//! `check` against the offline evaluation: the bridge's metrics equal `riskctl evaluate`'s on the
//! event set as the bridge decoded it, number for number; and decoding is faithful to the tables.
mod common;
use can_bridge::check::{check, write_decoded_events};
use can_bridge::engine::{Engine, EngineConfig};
use can_bridge::map::CompiledMap;
use can_bridge::ModelFile;
use riskscore_data::candump_export::{write_candump, ExportOptions, DEFAULT_GAP_US};
use riskscore_data::events::{load_events, prepare_sequences, write_events, PrepareConfig};
use riskscore_eval::scoring::{evaluate_methods, observe, Method, Scorer};
use std::path::Path;

#[test]
fn check_metrics_equal_evaluate_on_the_decoded_events_exactly() {
    let tmp = tempfile::tempdir().unwrap();
    let events_dir = tmp.path().join("events");
    write_events(&events_dir, &common::simulated_events(40, 11)).unwrap();
    let (set, issues) = load_events(&events_dir).unwrap();
    assert!(issues.is_empty(), "{issues:?}");

    let log = tmp.path().join("drive.log");
    let summary = write_candump(
        &set,
        &ExportOptions::default(),
        std::fs::File::create(&log).unwrap(),
    )
    .unwrap();
    assert!(summary.skipped.is_empty(), "{:?}", summary.skipped);

    let model_file = ModelFile::from_bytes(Path::new("msra.rsk"), common::msra_blob()).unwrap();
    let (_db, map) = CompiledMap::project_default().unwrap();
    let mut engine = Engine::new(model_file.model().unwrap(), map, EngineConfig::new(1.5)).unwrap();
    let report = check(&log, &set, &mut engine, "MSRA", DEFAULT_GAP_US, None, 20).unwrap();
    assert_eq!(report.untraced, 0);
    assert!(report.log.bad.is_empty());
    for v in &report.verdicts {
        assert_eq!(
            v.scored, v.frames,
            "event {}: every frame is scored",
            v.event_id
        );
    }
    assert_eq!(report.stats.decode_errors + report.stats.stale_drops, 0);

    // riskctl evaluate's path on the decoded folder.
    let decoded_dir = tmp.path().join("decoded");
    write_decoded_events(&decoded_dir, &report.decoded).unwrap();
    let (decoded, issues) = load_events(&decoded_dir).unwrap();
    assert!(issues.is_empty(), "{issues:?}");
    assert_eq!(
        decoded, report.decoded,
        "the decoded folder reads back bit-identical"
    );
    let (sequences, _) = prepare_sequences(&decoded, &PrepareConfig::default());
    let observed = observe(&sequences);
    let methods = [Method {
        name: "MSRA".into(),
        scorer: Scorer::Model(model_file.model().unwrap()),
    }];
    let (evaluate_report, _) = evaluate_methods(&observed, &methods).unwrap();
    assert_eq!(report.report.to_json(), evaluate_report.to_json());
    assert_eq!(report.report.to_markdown(), evaluate_report.to_markdown());
    let counts = report.report.events;
    assert!(
        counts.crash + counts.near_crash > 0 && counts.safe > 0,
        "{counts:?}"
    );

    // Decoding fidelity: scores from decoded states are close to scores from the tables.
    let model = model_file.model().unwrap();
    let mut diffs: Vec<f32> = Vec::new();
    for (orig, dec) in set.events.iter().zip(&report.decoded.events) {
        assert_eq!(orig.id, dec.id);
        for (a, b) in orig.frames.iter().zip(&dec.frames) {
            assert_eq!(a.time, b.time);
            diffs.push((model.score(&a.ego, &a.partner) - model.score(&b.ego, &b.partner)).abs());
        }
    }
    diffs.sort_by(f32::total_cmp);
    let median = diffs[diffs.len() / 2];
    let p99 = diffs[diffs.len() * 99 / 100];
    assert!(
        median < 1e-3 && p99 < 2e-2,
        "score change from DBC resolution: median {median}, p99 {p99}"
    );
}

/// A radar coarser than the project DBC (positions in 0.04 m steps, as the TSS-P radar sends
/// them): `check` derives its tolerance from the mapped signals' resolution, passes, and its
/// metrics equal `riskctl evaluate`'s on the events as that radar reports them. A tolerance finer
/// than the radar says which field is how far off.
#[test]
fn a_coarser_radar_passes_check_with_the_tolerance_of_its_resolution() {
    use can_bridge::check::CheckError;
    use can_bridge::map::{MapFile, DEFAULT_MAP};
    use can_codec::{project, Database};

    let tmp = tempfile::tempdir().unwrap();
    let set = common::simulated_events(30, 7);
    let mut fine = Vec::new();
    write_candump(&set, &ExportOptions::default(), &mut fine).unwrap();

    let mut dbc = project::PROJECT_DBC.to_string();
    for signal in ["ObjPosX", "ObjPosY"] {
        let start = if signal == "ObjPosX" { 15 } else { 27 };
        let from = format!(" SG_ {signal} : {start}|20@0- (0.001,0) [-524.288|524.287] \"m\" RISK");
        let to = format!(" SG_ {signal} : {start}|20@0- (0.04,0) [-20971.52|20971.48] \"m\" RISK");
        assert!(dbc.contains(&from), "{from}");
        dbc = dbc.replace(&from, &to);
    }
    let project_db = Database::parse(project::PROJECT_DBC).unwrap();
    let coarse_db = Database::parse(&dbc).unwrap();
    let position = project_db
        .message_by_name(project::OBJECT_POSITION)
        .unwrap();
    let coarse_position = coarse_db.message_by_name(project::OBJECT_POSITION).unwrap();
    // The same frames, object positions re-encoded in the radar's 0.04 m steps.
    let mut coarse = String::new();
    for line in String::from_utf8(fine).unwrap().lines() {
        let rec = can_codec::parse_line(line).unwrap();
        let frame = if rec.frame.id == position.id {
            let values: Vec<(&str, f64)> = position
                .signals
                .iter()
                .map(|s| (s.name.as_str(), s.decode(rec.frame.data()).unwrap()))
                .collect();
            can_codec::Frame::data_frame(position.id, &coarse_position.encode(&values).unwrap())
                .unwrap()
        } else {
            rec.frame
        };
        can_codec::format_line(&mut coarse, rec.timestamp_us, rec.iface, &frame);
        coarse.push('\n');
    }
    let log = tmp.path().join("coarse.log");
    std::fs::write(&log, coarse).unwrap();

    let model_file = ModelFile::from_bytes(Path::new("msra.rsk"), common::msra_blob()).unwrap();
    let map = CompiledMap::compile(&MapFile::parse(DEFAULT_MAP).unwrap(), &coarse_db).unwrap();
    let engine = || {
        Engine::new(
            model_file.model().unwrap(),
            map.clone(),
            EngineConfig::new(1.5),
        )
        .unwrap()
    };
    let report = check(&log, &set, &mut engine(), "MSRA", DEFAULT_GAP_US, None, 20).unwrap();
    assert_eq!(report.untraced, 0);
    assert!(report.verdicts.iter().all(|v| v.not_reported == 0));
    // The bridge saw the radar's grid, more than 1 cm away from the tables on many frames.
    let on_grid = |v: f32| {
        let steps = f64::from(v) / 0.04;
        (steps - steps.round()).abs() < 1e-3
    };
    let mut coarser_than_1cm = 0;
    for (orig, dec) in set.events.iter().zip(&report.decoded.events) {
        for (a, b) in orig.frames.iter().zip(&dec.frames) {
            assert!(on_grid(b.partner.x) && on_grid(b.partner.y), "{b:?}");
            let expected = riskscore_data::candump_export::to_ego_frame(a);
            if (f64::from(b.partner.x) - expected.pos_x).abs() > 0.01 {
                coarser_than_1cm += 1;
            }
        }
    }
    assert!(coarser_than_1cm > 100, "{coarser_than_1cm}");

    // `riskctl evaluate` on the events as this radar reports them gives the same metrics.
    let decoded_dir = tmp.path().join("decoded");
    write_decoded_events(&decoded_dir, &report.decoded).unwrap();
    let (decoded, _) = load_events(&decoded_dir).unwrap();
    let (sequences, _) = prepare_sequences(&decoded, &PrepareConfig::default());
    let methods = [Method {
        name: "MSRA".into(),
        scorer: Scorer::Model(model_file.model().unwrap()),
    }];
    let (evaluate_report, _) = evaluate_methods(&observe(&sequences), &methods).unwrap();
    assert_eq!(report.report.to_json(), evaluate_report.to_json());

    // The old fixed 1 cm is finer than the radar: refused, naming the fields and how far off.
    let err = check(
        &log,
        &set,
        &mut engine(),
        "MSRA",
        DEFAULT_GAP_US,
        Some(0.01),
        20,
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, CheckError::ContentMismatch(_)), "{text}");
    assert!(
        text.contains("object x up to 0.02") && text.contains("object y up to 0.02"),
        "{text}"
    );
    assert!(text.contains("--tolerance"), "{text}");

    // The same through the command line: the per-event trace report as JSON Lines.
    let events_dir = tmp.path().join("events");
    write_events(&events_dir, &set).unwrap();
    let dbc_path = tmp.path().join("coarse_radar.dbc");
    std::fs::write(&dbc_path, &dbc).unwrap();
    let model = tmp.path().join("m.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    let per_event = tmp.path().join("per_event.jsonl");
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_can-bridge"))
            .args(["check", "--threshold", "1.5", "--log"])
            .arg(&log)
            .arg("--events")
            .arg(&events_dir)
            .arg("--model")
            .arg(&model)
            .arg("--dbc")
            .arg(&dbc_path)
            .arg("--per-event-out")
            .arg(&per_event)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(&per_event)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), set.events.len());
    for (line, verdict) in lines.iter().zip(&report.verdicts) {
        assert_eq!(line["event_id"], verdict.event_id.as_str());
        assert_eq!(line["not_reported"], 0);
        assert_eq!(line["warned_at"].as_f64(), verdict.warned_at);
        assert_eq!(line["lead_time"].as_f64(), verdict.lead_time);
    }
    let before = std::fs::read(&per_event).unwrap();
    let out = run(&["--tolerance", "0.01"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("object x up to 0.02"), "{stderr}");
    assert_eq!(
        std::fs::read(&per_event).unwrap(),
        before,
        "a refused run writes nothing"
    );
}
