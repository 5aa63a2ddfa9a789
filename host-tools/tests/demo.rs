//! A small demo-like end-to-end run on a tiny simulated set: simulate, cross-validate (comparisons,
//! training, int8, evaluation through the core), export, plot, and check what was written.
use host_tools::demo::{self, DemoOptions};
use host_tools::export;
use host_tools::train::{Progress, TrainConfig};

fn tiny_config() -> TrainConfig {
    let mut c = TrainConfig::default();
    c.comparisons.temporal.pairs = 400;
    c.comparisons.cross_sequence.pairs = 400;
    c.comparisons.physics.pairs = 200;
    c.optimiser.max_epochs = 6;
    c.drl.hidden = vec![16, 8];
    c
}

#[test]
fn tiny_demo_runs_end_to_end_and_writes_everything() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let opts = DemoOptions {
        out: out.clone(),
        config: tiny_config(),
        sim_seed: 3,
        events: 60,
        data: None,
        folds: 3,
        seeds: 1,
        progress: Progress::Hidden,
    };
    let summary = demo::run(&opts).unwrap();
    for f in [
        "data/events.csv",
        "data/frames.csv",
        "report/results.md",
        "report/results.csv",
        "report/results.json",
        "report/folds.csv",
        "report/curves.csv",
        "report/sequence_maxima.csv",
        "report/training.json",
        "models/drl.rsk",
        "models/drl-f32.rsk",
        "models/msra.rsk",
        "models/drl.json",
        "models/msra.json",
        "plots/roc.svg",
        "plots/roc.png",
        "plots/pr.svg",
        "plots/trajectories.svg",
    ] {
        let p = out.join(f);
        assert!(p.is_file(), "missing {}", p.display());
        assert!(
            std::fs::metadata(&p).unwrap().len() > 0,
            "empty {}",
            p.display()
        );
    }
    // Every method of the table, three folds each.
    let cv = summary.cv.as_ref().unwrap();
    let names: Vec<&str> = cv.methods.iter().map(|m| m.name.as_str()).collect();
    for n in ["DRL", "DRL-f32", "MSRA", "TTC2D", "TAdv", "EI"] {
        assert!(names.contains(&n), "{names:?}");
    }
    assert_eq!(cv.runs, 3);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report/results.json")).unwrap())
            .unwrap();
    assert!(json["methods"].as_array().unwrap().len() >= 6);
    // The claims are computed from the table, one per (method, baseline, metric).
    assert_eq!(summary.claims.len(), 3 * 3 + 3 * 3);
    assert!(summary.pairs_per_second > 0.0 && summary.drl_epochs_per_second > 0.0);
    assert!(
        summary.final_agreement.correlation > 0.99,
        "{:?}",
        summary.final_agreement
    );
    // The shipped blobs decode and score; the checkpoint re-exports to the same int8 blob.
    let blob = std::fs::read(out.join("models/drl.rsk")).unwrap();
    let text = export::inspect(&blob).unwrap();
    assert!(
        text.contains("drl-int8") && text.contains("13-16-8-1"),
        "{text}"
    );
    let ck = export::Checkpoint::load(&out.join("models/drl.json")).unwrap();
    assert_eq!(export::export(&ck, export::DrlFormat::Int8).unwrap(), blob);
    let msra = std::fs::read(out.join("models/msra.rsk")).unwrap();
    assert!(scorer_core::model::decode(&msra).is_ok());
    let stage_names: Vec<&str> = summary.stages.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(stage_names[0], "simulate + load");
    assert!(stage_names.contains(&"cross-validation"));
}
