//! A small demo-like end-to-end run on a tiny simulated set: simulate, cross-validate (comparisons,
//! training, int8, evaluation through the core), export, plot, and check what was written.
use host_tools::demo::{self, DemoOptions};
use riskscore_train::export;
use riskscore_train::train::{Progress, TrainConfig};
mod common;

fn tiny_config() -> TrainConfig {
    let mut c = TrainConfig::default();
    c.comparisons.temporal.pairs = 400;
    c.comparisons.cross_sequence.pairs = 400;
    c.comparisons.physics.pairs = 200;
    c.optimiser.max_epochs = 6;
    c.drl.hidden = vec![16, 8];
    c
}

/// A small "real recordings" folder: calm following in three scenario files, named the way
/// `riskctl import commonroad` names its events.
fn write_real(dir: &std::path::Path) {
    use riskscore_data::events::EventWriter;
    let mut w = EventWriter::create(dir).unwrap();
    for sc in 0..3 {
        for k in 0..4 {
            let v = 10.0 + k as f32;
            let gap = 8.0 + 3.0 * k as f32;
            w.write_event(&common::calm_following(
                format!("REC-{sc}/{k}-{}@0#0", 50 + k),
                v,
                gap,
            ))
            .unwrap();
        }
    }
    w.finish().unwrap();
}

#[test]
fn tiny_demo_runs_end_to_end_and_writes_everything() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let real = dir.path().join("real");
    write_real(&real);
    // DRL-only training data: a small simulated folder (its ids restart at 000001 like the
    // training set's, so the demo must keep them apart).
    let drl_only = dir.path().join("drl-only");
    riskscore_data::sim::simulate_to_dir(
        &drl_only,
        &riskscore_data::sim::SimConfig {
            seed: 9,
            events: 20,
            progress: false,
            ..Default::default()
        },
    )
    .unwrap();
    let mut gssm = riskscore_train::gssm::GssmConfig::default();
    gssm.fit.max_epochs = 3;
    gssm.ssra.max_epochs = 2;
    let opts = DemoOptions {
        out: out.clone(),
        config: tiny_config(),
        sim_seed: 3,
        events: 60,
        data: None,
        folds: 3,
        seeds: 1,
        real: Some(real),
        transfer: Some(demo::TransferSettings {
            test_events: 40,
            ..demo::TransferSettings::default()
        }),
        gssm,
        domains: Some(demo::DomainSettings {
            events: 80,
            folds: 2,
            seeds: 1,
            real_city: None,
        }),
        extra: demo::ExtraTraining {
            sim: Some(demo::ExtraSim {
                seed: 4,
                events: 40,
                families: riskscore_data::sim::FamilyMix::domain(),
            }),
            real: Vec::new(),
            drl_only: vec![drl_only],
        },
        progress: Progress::Hidden,
    };
    // A previous run's --out with the user's notes in it, at the top and in report subfolders.
    let notes = [
        "notes.txt",
        "report/mine.md",
        "report/transfer/notes.txt",
        "report/domains/notes.txt",
    ];
    for n in notes {
        std::fs::create_dir_all(out.join(n).parent().unwrap()).unwrap();
        std::fs::write(out.join(n), n).unwrap();
    }
    let summary = demo::run(&opts).unwrap();
    for n in notes {
        assert_eq!(
            std::fs::read_to_string(out.join(n)).unwrap(),
            n,
            "note lost"
        );
    }
    // The files it names are where they went in (not its staged temporaries), and none is left.
    let hidden = |p: &std::path::Path| {
        p.strip_prefix(&out)
            .unwrap()
            .components()
            .any(|c| c.as_os_str().to_string_lossy().starts_with('.'))
    };
    for f in &summary.files {
        assert!(f.is_file() && !hidden(f), "{}", f.display());
    }
    fn walk(dir: &std::path::Path, into: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, into);
            }
            into.push(p);
        }
    }
    let mut all = Vec::new();
    walk(&out, &mut all);
    let left: Vec<_> = all.iter().filter(|p| hidden(p)).collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
    for f in [
        "data/events.csv",
        "data/frames.csv",
        "report/results.md",
        "report/results.csv",
        "report/results.json",
        "report/folds.csv",
        "report/curves.csv",
        "report/claims.md",
        "report/claims.csv",
        "report/sequence_maxima.csv",
        "report/training.json",
        "report/transfer/results.md",
        "report/transfer/results.json",
        "report/transfer/folds.csv",
        "report/transfer/splits.json",
        "report/transfer/claims.md",
        "report/transfer/claims.csv",
        "transfer-data/events.csv",
        "extra-data/events.csv",
        "report/domains/domains.md",
        "report/domains/domains.json",
        "report/domains/claims.csv",
        "domains-data/train/events.csv",
        "domains-data/test/events.csv",
        "models/drl.rsk",
        "models/drl-f32.rsk",
        "models/msra.rsk",
        "models/drl.json",
        "models/msra.json",
        "plots/roc.svg",
        "plots/roc.png",
        "plots/pr.svg",
        "plots/trajectories.svg",
        "plots/event-1.svg",
        "plots/event-1.png",
    ] {
        let p = out.join(f);
        assert!(p.is_file(), "missing {}", p.display());
        assert!(
            std::fs::metadata(&p).unwrap().len() > 0,
            "empty {}",
            p.display()
        );
    }
    // The transfer claims as printed, one CSV row each, with their run tallies (the transfer
    // benchmark runs folds x seeds = 3 x 1; a claim is compared in the runs its baseline has a
    // value).
    let transfer_claims = std::fs::read_to_string(out.join("report/transfer/claims.csv")).unwrap();
    let rows: Vec<&str> = transfer_claims.lines().skip(1).collect();
    assert_eq!(rows.len(), summary.transfer_claims.len());
    assert!(summary.transfer_claims.iter().any(|c| c.method == "GSSM"));
    for (row, claim) in rows.iter().zip(&summary.transfer_claims) {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells[0], claim.method);
        assert_eq!(cells[6], claim.verdict);
        let (holding, compared): (usize, usize) =
            (cells[7].parse().unwrap(), cells[8].parse().unwrap());
        assert!(holding <= compared && compared <= 3, "{row}");
        if (
            claim.method.as_str(),
            claim.baseline.as_str(),
            claim.metric.as_str(),
        ) == ("DRL", "TAdv", "A_ROC_90")
        {
            // TAdv has an A_ROC_90 in every run: all three are compared.
            assert_eq!(compared, 3, "{row}");
        }
    }
    // Training-only events train every fold and the transfer's training side, and are never
    // scored as test events.
    assert!(summary.extra_sequences > 0);
    let maxima = std::fs::read_to_string(out.join("report/sequence_maxima.csv")).unwrap();
    assert!(maxima.lines().count() > 1);
    assert!(
        !maxima.contains(demo::EXTRA_SIM_PREFIX),
        "an extra event was tested"
    );
    let splits: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("report/transfer/splits.json")).unwrap(),
    )
    .unwrap();
    for split in splits.as_array().unwrap() {
        let train = split["train_sequences"].as_u64().unwrap() as usize;
        assert!(train > summary.extra_sequences, "{split}");
    }
    assert!(
        !maxima.contains(demo::DRL_ONLY_PREFIX),
        "a DRL-only event was tested"
    );
    // The final DRL trained on the DRL-only folder (more comparison observations), MSRA not.
    let observations = |model: &str| {
        let ck: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("models").join(model)).unwrap())
                .unwrap();
        ck["meta"]["comparisons"]["observations"].as_u64().unwrap()
    };
    assert!(
        observations("drl.json") > observations("msra.json"),
        "DRL {} vs MSRA {} comparison observations",
        observations("drl.json"),
        observations("msra.json")
    );
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
    // The claims are computed from the table, one per (method, baseline, metric): DRL against
    // the three surrogates, MSRA against its own inputs (TAdv and EI by default); the transfer
    // benchmark adds SSRA >= GSSM on two metrics and GSSM > TTC2D on A_ROC_90.
    assert_eq!(summary.claims.len(), 3 * 3 + 2 * 3);
    assert_eq!(summary.transfer_claims.len(), 3 * 3 + 2 * 3 + 2 + 1);
    assert!(stage_names_of(&summary).contains(&"transfer benchmark"));
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
    // The same model; training adds the domain record measured on its data.
    let exported = export::export(&ck, export::DrlFormat::Int8).unwrap();
    let trained = scorer_core::model::decode_blob(&blob).unwrap();
    assert_eq!(
        scorer_core::model::decode(&exported).unwrap(),
        trained.model
    );
    assert!(trained.meta.training_domain.is_some(), "no training domain");
    let msra = std::fs::read(out.join("models/msra.rsk")).unwrap();
    assert!(scorer_core::model::decode(&msra).is_ok());
    let stage_names = stage_names_of(&summary);
    assert_eq!(stage_names[0], "simulate + load");
    assert!(stage_names.contains(&"cross-validation"));
    assert!(stage_names.contains(&"domain benchmark"));
    // Every default round is reported, run or "no data" (this tiny run has no city folder).
    let domains_md = std::fs::read_to_string(out.join("report/domains/domains.md")).unwrap();
    for round in [
        "speed-35-50",
        "city-lankershim",
        "city-peachtree",
        "geometry-crossing",
    ] {
        assert!(domains_md.contains(round), "{round} missing:\n{domains_md}");
    }

    // The event figures draw the trajectory figure's events; every figure says what it plots.
    let trajectories = std::fs::read_to_string(out.join("plots/trajectories.svg")).unwrap();
    let event = std::fs::read_to_string(out.join("plots/event-1.svg")).unwrap();
    let first_event = event
        .split("event ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap();
    assert!(trajectories.contains(first_event), "{first_event}");
    assert!(trajectories.contains("pooled over the"));
    assert!(std::fs::read_to_string(out.join("plots/roc.svg"))
        .unwrap()
        .contains("pooled over the"));

    // The closing paragraph: what was shown on which data, with the measured caveats.
    let text = demo::conclusion(&summary, &opts);
    assert!(text.starts_with("Conclusion: on "), "{text}");
    // The run's own fold count (the text said "5-fold" whatever --folds was).
    assert!(text.contains("3-fold event-level CV x 1 seeds"), "{text}");
    assert!(text.contains("held out by file"), "transfer caveat: {text}");
    assert!(text.contains(demo::WITHOUT_REAL_FIGURES), "{text}");
    let ok = summary.claims.iter().filter(|c| c.verdict == "ok").count();
    assert!(
        text.contains(&format!("{ok} of {} claims hold", summary.claims.len())),
        "{text}"
    );
    assert!(text.contains("training-only sequences"), "{text}");
    let no_real = DemoOptions {
        real: None,
        ..opts.clone()
    };
    assert!(demo::conclusion(&summary, &no_real).contains(demo::WITH_REAL_FIGURES));
    // On the user's own --data the recorded run's figures, of the simulated set, are not quoted.
    let own = DemoOptions {
        data: Some(dir.path().join("mine")),
        ..opts
    };
    let text = demo::conclusion(&summary, &own);
    assert!(!text.contains(demo::WITHOUT_REAL_FIGURES), "{text}");
    assert!(!text.contains("recorded run"), "{text}");
}

fn stage_names_of(summary: &demo::DemoSummary) -> Vec<&str> {
    summary.stages.iter().map(|(n, _)| n.as_str()).collect()
}
