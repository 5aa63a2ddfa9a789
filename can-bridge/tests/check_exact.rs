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
    let report = check(&log, &set, &mut engine, "MSRA", DEFAULT_GAP_US).unwrap();
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
