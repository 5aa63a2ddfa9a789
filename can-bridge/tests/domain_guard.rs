#![cfg(feature = "check")]
//! The training-domain guard in the bridge: every scored track update outside the model's
//! training domain is counted (summary, status line), the same updates the core's guard flags on
//! the states the bridge decoded, and a model without the record counts none.
mod common;
use can_bridge::check::check;
use can_bridge::engine::{Engine, EngineConfig};
use can_bridge::map::CompiledMap;
use can_bridge::ModelFile;
use riskscore_data::candump_export::{write_candump, ExportOptions, DEFAULT_GAP_US};
use riskscore_data::events::{load_events, write_events};
use scorer_core::model::{self, InputRange, ModelBlob, OutsidePolicy, TrainingDomain};
use std::path::Path;

/// The test MSRA blob with ego speed (feature 3) bounded to [0, 12] m/s: the simulator's faster
/// frames fall outside.
fn guarded_msra() -> Vec<u8> {
    let range = InputRange {
        input: 3,
        lo: 0.0,
        hi: 12.0,
    }
    .to_bytes();
    let plain = common::msra_blob();
    let mut blob = model::decode_blob(&plain).unwrap();
    blob.meta.training_domain = Some(TrainingDomain::new(OutsidePolicy::FlagOnly, &range));
    let mut out = vec![0u8; model::encoded_blob_len(&blob).unwrap()];
    model::encode_blob(&blob, &mut out).unwrap();
    out
}

#[test]
fn out_of_domain_updates_are_counted_exactly() {
    let tmp = tempfile::tempdir().unwrap();
    let events_dir = tmp.path().join("events");
    write_events(&events_dir, &common::simulated_events(30, 5)).unwrap();
    let (set, issues) = load_events(&events_dir).unwrap();
    assert!(issues.is_empty(), "{issues:?}");
    let log = tmp.path().join("drive.log");
    write_candump(
        &set,
        &ExportOptions::default(),
        std::fs::File::create(&log).unwrap(),
    )
    .unwrap();

    let run = |bytes: Vec<u8>| {
        let file = ModelFile::from_bytes(Path::new("msra.rsk"), bytes).unwrap();
        let (_db, map) = CompiledMap::project_default().unwrap();
        let mut engine = Engine::new(file.blob().unwrap(), map, EngineConfig::new(1.5)).unwrap();
        let report = check(&log, &set, &mut engine, "MSRA", DEFAULT_GAP_US, None, 20).unwrap();
        assert_eq!(report.untraced, 0);
        drop(engine);
        (report, file)
    };
    let (plain, _) = run(common::msra_blob());
    assert_eq!(plain.stats.out_of_domain, 0, "no record, nothing outside");

    let (guarded, file) = run(guarded_msra());
    let blob: ModelBlob<'_> = file.blob().unwrap();
    let expected = guarded
        .decoded
        .iter()
        .flat_map(|e| &e.frames)
        .filter(|f| !blob.score_pair_guarded(&f.ego, &f.partner).in_domain)
        .count() as u64;
    let scored: u64 = guarded.verdicts.iter().map(|v| v.scored as u64).sum();
    assert_eq!(guarded.stats.scored, scored);
    assert!(expected > 0 && expected < scored, "{expected} of {scored}");
    assert_eq!(guarded.stats.out_of_domain, expected);
    // FlagOnly: the warnings are those of the unguarded model.
    assert_eq!(guarded.stats.warning_frames, plain.stats.warning_frames);
    // The summary and the status line say it.
    let summary = can_bridge::commands::summary(&guarded.stats);
    assert!(
        summary.ends_with(&format!("{expected} outside the training domain")),
        "{summary}"
    );
    let status = can_bridge::events_out::status_line(&guarded.stats, &plain.stats, 1.0, 0);
    assert!(status.contains(&format!("{expected} outside the training domain")));
}
