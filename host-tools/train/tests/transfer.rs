//! The transfer benchmark: real sequences are held out by scenario file (never split across train
//! and test), every fold trains and scores DRL, MSRA, GSSM and SSRA, and the report has the
//! evaluate schema.
use riskscore_data::events::{EventKind, Frame, Sequence};
use riskscore_data::sim::{simulate_to_dir, Mix, SimConfig};
use riskscore_train::gssm::GssmConfig;
use riskscore_train::train::{Progress, TrainConfig};
use riskscore_train::transfer::{self, scenario_of, TransferData, TransferOptions};
use scorer_core::VehicleState;

fn simulated(seed: u64, mix: Mix, dir: &std::path::Path) -> Vec<Sequence> {
    let cfg = SimConfig {
        seed,
        events: 30,
        mix,
        ..SimConfig::default()
    };
    simulate_to_dir(dir, &cfg).unwrap();
    riskscore_data::events::load_prepared(dir, &riskscore_data::events::PrepareConfig::default())
        .unwrap()
        .sequences
}

/// Calm following in one of `scenarios` recordings, named like `riskctl import commonroad` does.
fn real(scenarios: usize, per: usize) -> Vec<Sequence> {
    let mut out = Vec::new();
    for sc in 0..scenarios {
        for k in 0..per {
            let v = 8.0 + (sc * per + k) as f32 % 9.0;
            let gap = 6.0 + 2.0 * k as f32;
            let frames = (0..30)
                .map(|i| {
                    let t = i as f64 * 0.1;
                    let x = v * t as f32;
                    let state = |x: f32| VehicleState {
                        x,
                        y: 0.0,
                        vx: v,
                        vy: 0.0,
                        hx: 1.0,
                        hy: 0.0,
                        acc: 0.0,
                        length: 4.5,
                        width: 1.8,
                    };
                    Frame {
                        time: t,
                        ego: state(x),
                        partner: state(x + 4.5 + gap),
                    }
                })
                .collect();
            out.push(Sequence {
                event_id: format!("REC-{sc}/{k}-{}@0#0", k + 100),
                kind: EventKind::Safe,
                frames,
                endpoint: None,
            });
        }
    }
    out
}

#[test]
fn real_scenarios_are_held_out_whole_and_every_model_is_scored() {
    let dir = tempfile::tempdir().unwrap();
    let data = TransferData {
        train_sim: simulated(3, Mix::default(), &dir.path().join("a")),
        train_drl_only: Vec::new(),
        test_sim: simulated(
            4,
            Mix {
                crash: 1.0,
                near_crash: 1.0,
                safe: 2.0,
            },
            &dir.path().join("b"),
        ),
        real: real(4, 3),
    };
    let mut config = TrainConfig::default();
    config.comparisons.temporal.pairs = 200;
    config.comparisons.cross_sequence.pairs = 200;
    config.comparisons.physics.pairs = 100;
    config.optimiser.max_epochs = 3;
    let mut gssm = GssmConfig::default();
    gssm.fit.max_epochs = 3;
    gssm.ssra.max_epochs = 2;
    let options = TransferOptions {
        folds: 2,
        seeds: 1,
        progress: Progress::Hidden,
    };
    let result = transfer::run(&data, &config, &gssm, &options).unwrap();
    assert_eq!(result.folds.len(), 2);
    // Each scenario file is held out exactly once, whole.
    let mut held: Vec<&String> = result
        .splits
        .iter()
        .flat_map(|s| &s.test_scenarios)
        .collect();
    held.sort();
    held.dedup();
    assert_eq!(held.len(), 4);
    for s in &result.splits {
        let n_real_test = data
            .real
            .iter()
            .filter(|r| {
                s.test_scenarios
                    .iter()
                    .any(|t| t == scenario_of(&r.event_id))
            })
            .count();
        assert_eq!(s.test_sequences, data.test_sim.len() + n_real_test);
        assert_eq!(
            s.train_sequences,
            data.train_sim.len() + data.real.len() - n_real_test
        );
    }
    let names: Vec<&str> = result
        .report
        .methods
        .iter()
        .map(|m| m.name.as_str())
        .collect();
    for m in [
        "DRL", "DRL-f32", "MSRA", "TTC2D", "TAdv", "EI", "GSSM", "SSRA",
    ] {
        assert!(names.contains(&m), "{m} missing from {names:?}");
    }
    let json = result.report.to_json();
    assert!(json.get("methods").is_some(), "{json}");
}

#[test]
fn too_few_scenario_files_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(3, Mix::default(), &dir.path().join("a"));
    let data = TransferData {
        train_sim: sim.clone(),
        train_drl_only: Vec::new(),
        test_sim: sim,
        real: real(1, 2),
    };
    let err = transfer::run(
        &data,
        &TrainConfig::default(),
        &GssmConfig::default(),
        &TransferOptions {
            folds: 2,
            seeds: 1,
            progress: Progress::Hidden,
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("1 found for 2 folds"), "{err}");
}
