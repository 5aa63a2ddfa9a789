//! `riskctl benchmark domains` end to end on tiny data: the JSON shape (one `riskctl evaluate`
//! row group per round, the real-safe share per method), the report folder, a real-city round,
//! and the errors for an empty round and an output that is an input.
use std::path::Path;
use std::process::{Command, Output};

use riskscore_data::events::{Dims, Event, EventKind, EventWriter, Frame};
use serde_json::Value;

const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

fn riskctl(dir: &Path, args: &[&str]) -> Output {
    Command::new(RISKCTL)
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

#[track_caller]
fn ok(dir: &Path, args: &[&str]) -> String {
    let o = riskctl(dir, args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// Calm following, `per_scenario` sequences per scenario file, ego speeds alternating 10 and
/// 20 m/s (so a 5-15 m/s round has real sequences on both sides).
fn write_real(dir: &Path, scenarios: &[&str], per_scenario: usize) {
    let mut w = EventWriter::create(dir).unwrap();
    for sc in scenarios {
        for k in 0..per_scenario {
            let v = if k % 2 == 0 { 10.0 } else { 20.0 };
            let gap = 10.0 + 2.0 * k as f32;
            let state = |x: f32| scorer_core::VehicleState {
                x,
                vx: v,
                hx: 1.0,
                length: 4.5,
                width: 1.8,
                ..Default::default()
            };
            let frames: Vec<Frame> = (0..30)
                .map(|i| {
                    let t = i as f64 * 0.1;
                    let x = v * t as f32;
                    Frame {
                        time: t,
                        ego: state(x),
                        partner: state(x + 4.5 + gap),
                    }
                })
                .collect();
            w.write_event(&Event {
                id: format!("{sc}/{k}-{}", 50 + k),
                kind: EventKind::Safe,
                t_start: 0.0,
                t_end: 2.9,
                t_impact: None,
                dims: Dims {
                    length_ego: 4.5,
                    width_ego: 1.8,
                    length_partner: 4.5,
                    width_partner: 1.8,
                },
                frames,
            })
            .unwrap();
        }
    }
    w.finish().unwrap();
}

/// Simulated training/test folders, real freeway and city folders, tiny configurations.
fn scratch() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    for (out, seed, mix) in [
        ("sim-train", "1", "30,30,30"),
        ("sim-test", "2", "30,20,40"),
    ] {
        ok(
            p,
            &[
                "simulate", "--out", out, "--events", "90", "--seed", seed, "--mix", mix,
            ],
        );
    }
    write_real(
        &p.join("freeway"),
        &["USA_US101-1", "USA_US101-2", "USA_US101-3"],
        6,
    );
    write_real(
        &p.join("city"),
        &[
            "USA_Lanker-1_1_T-1",
            "USA_Lanker-2_1_T-1",
            "USA_Peach-1_1_T-1",
        ],
        4,
    );
    std::fs::write(
        p.join("t.toml"),
        "[comparisons.temporal]\npairs = 60\n[comparisons.cross_sequence]\npairs = 60\n\
         [comparisons.physics]\npairs = 20\n[optimiser]\nmax_epochs = 2\nbatch_pairs = 32\n",
    )
    .unwrap();
    std::fs::write(
        p.join("g.toml"),
        "[fit]\nmax_epochs = 2\nhidden = [4]\n[ssra]\nmax_epochs = 2\n",
    )
    .unwrap();
    d
}

const COMMON: [&str; 16] = [
    "benchmark",
    "domains",
    "--real",
    "freeway",
    "--real-city",
    "city",
    "--train-events",
    "sim-train",
    "--test-events",
    "sim-test",
    "--config",
    "t.toml",
    "--gssm-config",
    "g.toml",
    "--quiet",
    "--json",
];

fn domains(dir: &Path, extra: &[&str]) -> Output {
    let mut args = COMMON.to_vec();
    args.extend_from_slice(extra);
    riskctl(dir, &args)
}

#[test]
fn a_tiny_run_reports_each_round_like_evaluate_plus_the_real_safe_share() {
    let d = scratch();
    let p = d.path();
    let o = domains(
        p,
        &[
            "--rounds",
            "speed-5-15,city-lankershim",
            "--folds",
            "2",
            "--seeds",
            "1",
            "--out",
            "out",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: Value = serde_json::from_slice(&o.stdout).unwrap();
    let rounds = json["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 2);
    for (round, name) in rounds.iter().zip(["speed-5-15", "city-lankershim"]) {
        assert_eq!(round["round"], name);
        assert_eq!(round["status"], "ok");
        assert_eq!(round["runs"], 2, "1 seed x 2 folds");
        let slice = &round["slice"];
        let real_safe = slice["real_safe"].as_u64().unwrap();
        assert!(real_safe > 0, "{name}: {slice}");
        assert_eq!(slice["small"], true, "{name}: tiny slices are flagged");
        // The table header counts the slice's test sequences.
        let events = &round["events"];
        let conflicts = events["crash"].as_u64().unwrap() + events["near_crash"].as_u64().unwrap();
        assert_eq!(conflicts, slice["test_conflicts"].as_u64().unwrap());
        assert_eq!(events["safe"], slice["test_safe"]);
        let methods = round["methods"].as_array().unwrap();
        let names: Vec<&str> = methods
            .iter()
            .map(|m| m["name"].as_str().unwrap())
            .collect();
        for expected in [
            "DRL", "DRL-f32", "MSRA", "TTC2D", "TAdv", "EI", "GSSM", "SSRA",
        ] {
            assert!(names.contains(&expected), "{name}: {names:?}");
        }
        // The fold models' guards: every test frame of every fold counted, as `evaluate` does.
        let domain = round["domain"].as_array().unwrap();
        let guarded: Vec<&str> = domain.iter().map(|d| d["name"].as_str().unwrap()).collect();
        for expected in ["DRL", "DRL-f32", "MSRA"] {
            assert!(guarded.contains(&expected), "{name}: {guarded:?}");
        }
        for d in domain {
            let (frames, outside) = (
                d["frames"].as_u64().unwrap(),
                d["outside"].as_u64().unwrap(),
            );
            assert!(frames > 0 && outside <= frames, "{name}: {d}");
        }
        for m in methods {
            for key in ["A_ROC_90", "A_ROC_80", "P_PRC_90", "P_PRC_80", "mTTI_90"] {
                assert!(m.get(key).is_some() && m["std"].get(key).is_some(), "{m}");
            }
            let share = &m["real_safe_above_recall_90"];
            let (above, of) = (
                share["above"].as_u64().unwrap(),
                share["of"].as_u64().unwrap(),
            );
            assert!(of >= real_safe && above <= of, "{name}: {share}");
            match share["mean"].as_f64() {
                Some(pct) => {
                    assert!((0.0..=100.0).contains(&pct), "{share}");
                    assert_eq!(share["n"], 2);
                }
                None => assert_eq!(share["n"], 0),
            }
        }
    }
    // Lankershim (2 scenario files, 8 sequences) is held out; Peachtree trains.
    assert_eq!(rounds[1]["slice"]["real_safe"], 8);
    let report = p.join("out/report");
    for f in [
        "domains.md",
        "domains.json",
        "shares.csv",
        "splits.json",
        "speed-5-15.folds.csv",
        "city-lankershim.folds.csv",
    ] {
        assert!(report.join(f).is_file(), "{f} missing");
    }
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("domains.json")).unwrap())
            .unwrap();
    assert_eq!(written, json);
    let shares = std::fs::read_to_string(report.join("shares.csv")).unwrap();
    assert_eq!(
        shares.lines().next(),
        Some("round,seed,fold,method,threshold,above,of")
    );
    let md = std::fs::read_to_string(report.join("domains.md")).unwrap();
    assert!(
        md.contains("### Held out: real city traffic of Lankershim"),
        "{md}"
    );
    assert!(md.contains("90 %-recall threshold"), "{md}");
    assert!(md.contains("Outside the training domain"), "{md}");
}

#[test]
fn a_named_round_with_an_empty_slice_is_an_error_naming_it_and_its_counts() {
    let d = scratch();
    let o = domains(
        d.path(),
        &["--rounds", "speed-35-50", "--folds", "2", "--out", "out"],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("round `speed-35-50`"), "{err}");
    assert!(err.contains("0 conflicts"), "{err}");
    assert!(!d.path().join("out/report").exists());

    let o = domains(d.path(), &["--rounds", "speed-99", "--out", "out"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown round `speed-99`"));
}

#[test]
fn all_runs_every_round_and_reports_the_empty_ones_as_no_data() {
    let d = scratch();
    let o = domains(
        d.path(),
        &[
            "--rounds", "all", "--folds", "2", "--seeds", "1", "--out", "out",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: Value = serde_json::from_slice(&o.stdout).unwrap();
    let rounds = json["rounds"].as_array().unwrap();
    let listed = ok(d.path(), &["benchmark", "domains", "--list-rounds"]);
    let names: Vec<&str> = rounds
        .iter()
        .map(|r| r["round"].as_str().unwrap())
        .collect();
    let every: Vec<&str> = listed
        .lines()
        .map(|l| l[1..].split_whitespace().next().unwrap())
        .collect();
    assert_eq!(names, every);
    let status = |name: &str| {
        rounds.iter().find(|r| r["round"] == name).unwrap()["status"]
            .as_str()
            .unwrap()
            .to_owned()
    };
    // The tiny data has nothing at 35-50 m/s (named alone, that round is an error) ...
    assert_eq!(status("speed-35-50"), "no data");
    // ... and runs the rounds it has data for.
    assert_eq!(status("speed-5-15"), "ok");
    assert_eq!(status("city-lankershim"), "ok");
}

#[test]
fn an_output_that_is_an_input_is_refused() {
    let d = scratch();
    let o = domains(d.path(), &["--rounds", "speed-5-15", "--out", "city"]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--out"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn list_rounds_marks_the_defaults() {
    let d = tempfile::tempdir().unwrap();
    let out = ok(d.path(), &["benchmark", "domains", "--list-rounds"]);
    let defaults: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with('*'))
        .map(|l| l.split_whitespace().nth(1).unwrap())
        .collect();
    assert_eq!(
        defaults,
        [
            "speed-35-50",
            "geometry-crossing",
            "geometry-oncoming",
            "city-lankershim",
            "city-peachtree"
        ]
    );
}
