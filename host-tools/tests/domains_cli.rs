//! `riskctl benchmark domains` end to end on tiny data: the JSON shape (one `riskctl evaluate`
//! row group per round, the real-safe share per method), the report folder, a real-city round,
//! the errors for an empty round and an output that is an input, and `--sequences-out` (its rows
//! give back every run's report; the report is the same without it) and the claims (each run
//! tally recomputed from the fold and share files); `--draws` for it and for `benchmark transfer`
//! (the pooled runs are the single draws' runs, each draw judged as its single run).
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Output;

use riskscore_data::events::EventWriter;
use serde_json::Value;
mod common;
use common::riskctl_in as riskctl;

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
            w.write_event(&common::calm_following(
                format!("{sc}/{k}-{}", 50 + k),
                v,
                gap,
            ))
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
    let o = two_rounds(p, "out", &[]);
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
    assert!(md.contains("| DRL > TAdv on A_ROC_90 |"), "{md}");
    claims_are_the_runs_paired(&report, &json);
}

/// Every row of `claims.csv` recomputed from the other report files: its means from
/// `domains.json`, its verdict from the means, its run tally from `<round>.folds.csv` (or
/// `shares.csv` for the real-safe share) paired by seed and fold; and the claims `domains.json`
/// carries are the same rows.
fn claims_are_the_runs_paired(report: &Path, json: &Value) {
    let (header, claims) = csv_rows(&report.join("claims.csv"));
    assert_eq!(
        header.join(","),
        "round,method,baseline,metric,rule,method_mean,baseline_mean,verdict,runs_holding,runs_compared"
    );
    let rule = |r: &str, m: f64, b: f64| match r {
        ">" => m > b,
        ">=" => m >= b,
        "<=" => m <= b,
        other => panic!("rule {other}"),
    };
    let cell = |v: &str| (!v.is_empty()).then(|| v.parse::<f64>().unwrap());
    let (_, shares) = csv_rows(&report.join("shares.csv"));
    let mut per_round = BTreeMap::<String, usize>::new();
    let mut seen = BTreeSet::new();
    let mut tallies = BTreeSet::new();
    for c in &claims {
        let round = &c["round"];
        *per_round.entry(round.clone()).or_default() += 1;
        seen.insert((
            c["method"].clone(),
            c["baseline"].clone(),
            c["metric"].clone(),
        ));
        let r = json["rounds"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["round"] == round.as_str())
            .unwrap();
        let share_claim = c["metric"] == "real_safe_above_recall_90";
        let mean = |name: &str| {
            let m = r["methods"]
                .as_array()
                .unwrap()
                .iter()
                .find(|m| m["name"] == name)
                .unwrap();
            if share_claim {
                m["real_safe_above_recall_90"]["mean"].as_f64()
            } else {
                m[c["metric"].as_str()].as_f64()
            }
        };
        let (m, b) = (mean(&c["method"]), mean(&c["baseline"]));
        let close = |x: Option<f64>, y: Option<f64>| match (x, y) {
            (Some(x), Some(y)) => (x - y).abs() <= 1e-9 * x.abs().max(1.0),
            (x, y) => x.is_none() && y.is_none(),
        };
        assert!(close(cell(&c["method_mean"]), m), "{c:?}");
        assert!(close(cell(&c["baseline_mean"]), b), "{c:?}");
        let verdict = match (m, b) {
            (Some(_), None) => "n/a",
            (Some(m), Some(b)) if rule(&c["rule"], m, b) => "ok",
            _ => "FAIL",
        };
        assert_eq!(c["verdict"], verdict, "{c:?}");
        // The run values, by (seed, fold), of a method.
        let runs = |name: &str| -> BTreeMap<(String, String), Option<f64>> {
            if share_claim {
                shares
                    .iter()
                    .filter(|s| s["round"] == *round && s["method"] == name)
                    .map(|s| {
                        let of: f64 = s["of"].parse().unwrap();
                        let pct = (!s["threshold"].is_empty() && of > 0.0)
                            .then(|| 100.0 * s["above"].parse::<f64>().unwrap() / of);
                        ((s["seed"].clone(), s["fold"].clone()), pct)
                    })
                    .collect()
            } else {
                let (_, folds) = csv_rows(&report.join(format!("{round}.folds.csv")));
                folds
                    .iter()
                    .filter(|f| f["method"] == name)
                    .map(|f| {
                        (
                            (f["seed"].clone(), f["fold"].clone()),
                            cell(&f[c["metric"].as_str()]),
                        )
                    })
                    .collect()
            }
        };
        let (mine, theirs) = (runs(&c["method"]), runs(&c["baseline"]));
        assert_eq!(
            mine.len() as u64,
            r["runs"].as_u64().unwrap(),
            "{c:?}: a value per run (draws x seeds x folds)"
        );
        let (mut holding, mut compared) = (0, 0);
        for (run, b) in &theirs {
            let Some(b) = b else { continue };
            compared += 1;
            holding += usize::from(mine[run].is_some_and(|m| rule(&c["rule"], m, *b)));
        }
        assert_eq!(c["runs_holding"], holding.to_string(), "{c:?}");
        assert_eq!(c["runs_compared"], compared.to_string(), "{c:?}");
        let listed = r["claims"]
            .as_array()
            .unwrap()
            .iter()
            .find(|j| {
                j["method"] == c["method"].as_str()
                    && j["baseline"] == c["baseline"].as_str()
                    && j["metric"] == c["metric"].as_str()
            })
            .unwrap_or_else(|| panic!("{c:?} not in domains.json"));
        assert_eq!(listed["runs"]["holding"], holding);
        assert_eq!(listed["runs"]["compared"], compared);
        assert_eq!(listed["verdict"], verdict);
        let json_rule = match c["rule"].as_str() {
            ">" => "greater",
            ">=" => "at_least",
            _ => "at_most",
        };
        assert_eq!(listed["rule"], json_rule, "{c:?}");
        tallies.insert((holding, compared));
    }
    // The tallies are not all alike (the checks above would pass on all-zero ones): some claim
    // holds in every compared run, and some in none.
    assert!(tallies.iter().any(|&(k, n)| n > 0 && k == n), "{tallies:?}");
    assert!(tallies.iter().any(|&(k, n)| n > 0 && k == 0), "{tallies:?}");
    // Both rounds: DRL against 3 baselines x 3 metrics, MSRA against TAdv and EI x 3, SSRA >=
    // GSSM x 2, GSSM > TTC2D, DRL's real-safe share <= TAdv's.
    assert_eq!(per_round.len(), 2);
    assert!(
        per_round.values().all(|&n| n == 9 + 6 + 2 + 1 + 1),
        "{per_round:?}"
    );
    assert!(seen.contains(&(
        "DRL".to_string(),
        "TAdv".to_string(),
        "real_safe_above_recall_90".to_string()
    )));
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

/// The rounds, folds and seeds of the tiny two-round run.
const TWO_ROUNDS: [&str; 6] = [
    "--rounds",
    "speed-5-15,city-lankershim",
    "--folds",
    "2",
    "--seeds",
    "1",
];

/// The tiny two-round run of these tests into `out`, with `extra` arguments.
fn two_rounds(dir: &Path, out: &str, extra: &[&str]) -> Output {
    let mut args = TWO_ROUNDS.to_vec();
    args.extend_from_slice(&["--out", out]);
    args.extend_from_slice(extra);
    domains(dir, &args)
}

/// Every file of a folder, by name, with its bytes.
fn files_of(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}

/// A CSV row: column name -> cell.
type Row = BTreeMap<String, String>;
/// One method in one run: (round, seed, fold, method).
type RunKey = (String, String, String, String);

/// A CSV file as its header and rows.
fn csv_rows(path: &Path) -> (Vec<String>, Vec<Row>) {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|rec| {
            let rec = rec.unwrap();
            header
                .iter()
                .cloned()
                .zip(rec.iter().map(String::from))
                .collect()
        })
        .collect();
    (header, rows)
}

/// A^ROC_90 of one run from its sequence maxima (docs/evaluation.md, written out again here):
/// the ROC polyline through `(FPR(T), TPR(T))` at every distinct maximum `T`, highest first,
/// from `(0, 0)` to `(1, 1)`, and the area of `1 - FPR` over TPR in `[0.9, 1]`, divided by 0.1.
/// `None` without conflicts or safe sequences.
fn a_roc_90(maxima: &[(bool, Option<f32>)]) -> Option<f64> {
    let p = maxima.iter().filter(|(conflict, _)| *conflict).count();
    let n = maxima.len() - p;
    if p == 0 || n == 0 {
        return None;
    }
    let mut thresholds: Vec<f32> = maxima.iter().filter_map(|(_, m)| *m).collect();
    thresholds.sort_by(|a, b| b.total_cmp(a));
    thresholds.dedup();
    let mut curve = vec![(0.0, 0.0)];
    for t in thresholds {
        let warned = |conflict: bool| {
            maxima
                .iter()
                .filter(|(c, m)| *c == conflict && m.is_some_and(|m| m >= t))
                .count() as f64
        };
        curve.push((warned(false) / n as f64, warned(true) / p as f64));
    }
    curve.push((1.0, 1.0));
    let alpha = 0.9;
    let mut area = 0.0;
    for w in curve.windows(2) {
        let ((f0, t0), (f1, t1)) = (w[0], w[1]);
        let (lo, hi) = (f64::max(t0, alpha), f64::min(t1, 1.0));
        if t1 > t0 && hi > lo {
            let fpr = |t: f64| f0 + (f1 - f0) * (t - t0) / (t1 - t0);
            area += (hi - lo) * (1.0 - 0.5 * (fpr(lo) + fpr(hi)));
        }
    }
    Some(100.0 * area / (1.0 - alpha))
}

/// The 90 %-recall threshold from the maxima: the highest maximum at which at least 90 % of the
/// conflicts reach it.
fn t90(maxima: &[(bool, Option<f32>)]) -> Option<f32> {
    let p = maxima.iter().filter(|(conflict, _)| *conflict).count();
    let mut thresholds: Vec<f32> = maxima.iter().filter_map(|(_, m)| *m).collect();
    thresholds.sort_by(|a, b| b.total_cmp(a));
    thresholds.into_iter().find(|&t| {
        let tp = maxima
            .iter()
            .filter(|(c, m)| *c && m.is_some_and(|m| m >= t))
            .count();
        p > 0 && tp * 100 >= 90 * p
    })
}

fn f32_cell(row: &Row, key: &str) -> Option<f32> {
    let cell = &row[key];
    (!cell.is_empty()).then(|| cell.parse().unwrap())
}

#[test]
fn sequences_out_adds_a_file_whose_rows_give_back_every_runs_report() {
    let d = scratch();
    let p = d.path();
    let with = two_rounds(p, "a", &["--sequences-out", "a/rows/sequences.csv"]);
    assert!(
        with.status.success(),
        "{}",
        String::from_utf8_lossy(&with.stderr)
    );
    let without = two_rounds(p, "b", &[]);
    assert!(without.status.success());
    // The option only adds its file: stdout and every report file byte for byte the same.
    assert_eq!(with.stdout, without.stdout);
    let report = files_of(&p.join("a/report"));
    assert_eq!(report, files_of(&p.join("b/report")));
    let mut beside: Vec<String> = std::fs::read_dir(p.join("a"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    beside.sort();
    assert_eq!(beside, ["report", "rows"]);

    let (header, rows) = csv_rows(&p.join("a/rows/sequences.csv"));
    assert_eq!(
        header.join(","),
        "round,seed,fold,method,event_id,class,source,speed_band,geometry,max,peak_time,t90,\
         above_t90,in_domain,network,fallback,ttc2d,tadv,ei,v_ego,v_partner"
    );
    let mut runs: BTreeMap<RunKey, Vec<&Row>> = BTreeMap::new();
    for row in &rows {
        let key = ["round", "seed", "fold", "method"].map(|k| row[k].clone());
        runs.entry(key.into()).or_default().push(row);
    }
    // Every run's reported figures, by (round, seed, fold, method).
    let mut a_roc: BTreeMap<RunKey, String> = BTreeMap::new();
    for round in ["speed-5-15", "city-lankershim"] {
        let (_, folds) = csv_rows(&p.join(format!("a/report/{round}.folds.csv")));
        for f in folds {
            let key = (
                round.to_string(),
                f["seed"].clone(),
                f["fold"].clone(),
                f["method"].clone(),
            );
            a_roc.insert(key, f["A_ROC_90"].clone());
        }
    }
    let (_, shares) = csv_rows(&p.join("a/report/shares.csv"));
    assert_eq!(
        runs.len(),
        a_roc.len(),
        "one group of rows per method and run"
    );
    assert_eq!(runs.len(), shares.len());
    let splits: Value =
        serde_json::from_slice(&std::fs::read(p.join("a/report/splits.json")).unwrap()).unwrap();
    let (mut outside_checked, mut inside_checked) = (0, 0);
    for share in &shares {
        let key = (
            share["round"].clone(),
            share["seed"].clone(),
            share["fold"].clone(),
            share["method"].clone(),
        );
        let run = &runs[&key];
        // As many rows as the fold tested sequences.
        let split = splits
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["round"] == key.0.as_str())
            .unwrap()["folds"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| {
                f["seed"] == key.1.parse::<u64>().unwrap()
                    && f["fold"] == key.2.parse::<u64>().unwrap()
            })
            .unwrap()
            .clone();
        let tested =
            split["test"]["conflicts"].as_u64().unwrap() + split["test"]["safe"].as_u64().unwrap();
        assert_eq!(run.len() as u64, tested, "{key:?}");
        // The run's A^ROC_90 and T90 again from the dumped maxima alone.
        let maxima: Vec<(bool, Option<f32>)> = run
            .iter()
            .map(|r| (r["class"] != "safe", f32_cell(r, "max")))
            .collect();
        let reported = &a_roc[&key];
        match a_roc_90(&maxima) {
            Some(v) => {
                let r: f64 = reported.parse().unwrap();
                assert!(
                    (v - r).abs() < 1e-9,
                    "{key:?}: {v} from the rows, {r} reported"
                );
            }
            None => assert_eq!(reported, "", "{key:?}"),
        }
        let threshold = t90(&maxima);
        assert_eq!(
            threshold.map_or(String::new(), |t| t.to_string()),
            share["threshold"],
            "{key:?}"
        );
        // The real-safe share of the report: real safe rows above T90.
        let real_safe: Vec<_> = run
            .iter()
            .filter(|r| r["source"].starts_with("real-") && r["class"] == "safe")
            .collect();
        let above = real_safe.iter().filter(|r| r["above_t90"] == "1").count();
        assert_eq!(
            (above.to_string(), real_safe.len().to_string()),
            (share["above"].clone(), share["of"].clone()),
            "{key:?}"
        );
        for r in run {
            assert_eq!(r["t90"], share["threshold"]);
            let max = f32_cell(r, "max");
            let above = matches!((max, threshold), (Some(m), Some(t)) if m >= t);
            assert_eq!(r["above_t90"], if above { "1" } else { "0" });
            if key.0 == "city-lankershim" && r["source"] != "sim" {
                assert_eq!(r["source"], "real-city:Lankershim");
            }
            let guarded = !["TTC2D", "TAdv", "EI", "TAdv-corridor"].contains(&key.3.as_str());
            if !guarded {
                assert_eq!([&r["in_domain"], &r["network"], &r["fallback"]], [""; 3]);
                continue;
            }
            // The guard's parts at the peak frame: outside, a fallback scores alone; inside
            // without one, the network does.
            let (network, fallback) = (f32_cell(r, "network"), f32_cell(r, "fallback"));
            match (r["in_domain"].as_str(), fallback) {
                ("0", Some(fb)) => {
                    assert_eq!(max, Some(fb), "{key:?} {}", r["event_id"]);
                    outside_checked += 1;
                }
                ("1", None) => {
                    assert_eq!(max, network, "{key:?} {}", r["event_id"]);
                    inside_checked += 1;
                }
                ("0" | "1", _) => assert!(network.is_some()),
                (other, _) => panic!("{key:?}: in_domain {other:?}"),
            }
        }
    }
    assert!(
        outside_checked > 0 && inside_checked > 0,
        "{outside_checked} {inside_checked}"
    );
    let err = String::from_utf8_lossy(&with.stderr);
    assert!(
        err.contains(&format!(
            "{} per-sequence rows in a/rows/sequences.csv",
            rows.len()
        )),
        "{err}"
    );
}

#[test]
fn sequences_out_refuses_an_input_a_folder_the_run_writes_parquet_and_stdout() {
    let d = scratch();
    let p = d.path();
    let events = std::fs::read(p.join("freeway/events.csv")).unwrap();
    for (out, says) in [
        (
            "freeway/events.csv",
            "is the same file as --real freeway/events.csv",
        ),
        ("./t.toml", "is the same file as --config t.toml"),
        ("city/rows.csv", "lies inside --real-city city"),
        ("out", "is the same file as --out out"),
        (
            "out/report/rows.csv",
            "lies inside out/report, which this run writes whole",
        ),
        ("out/rows.parquet", "written as CSV only"),
        ("-", "standard output carries the report"),
    ] {
        let o = two_rounds(p, "out", &["--sequences-out", out]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{out}");
        assert!(
            err.contains(&format!("--sequences-out {out}")),
            "{out}: {err}"
        );
        assert!(err.contains(says), "{out}: {err}");
        assert!(!p.join("out").exists(), "{out}: something written");
    }
    assert_eq!(std::fs::read(p.join("freeway/events.csv")).unwrap(), events);
    assert!(!p.join("city/rows.csv").exists());
    // Simulated folders are written by the run too (refused before simulating).
    let o = riskctl(
        p,
        &[
            "benchmark",
            "domains",
            "--real",
            "freeway",
            "--rounds",
            "speed-5-15",
            "--out",
            "out",
            "--sequences-out",
            "out/train-data/r.csv",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("lies inside out/train-data"), "{err}");
    assert!(!p.join("out").exists());
}

/// The arguments of a tiny benchmark run on data it simulates itself (`--draws` needs that):
/// the fixtures' configurations (`config` for `--config`), 90 events per simulated folder, 2 folds
/// x 1 seed, into `out`.
fn simulated<'a>(config: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "--config",
        config,
        "--gssm-config",
        "g.toml",
        "--quiet",
        "--events",
        "90",
        "--train-mix",
        "30,30,30",
        "--test-mix",
        "30,20,40",
        "--folds",
        "2",
        "--seeds",
        "1",
        "--out",
        out,
    ]
}

/// The two-round domain run on data it simulates itself, into `out`.
fn simulated_two_rounds(dir: &Path, out: &str, config: &str, extra: &[&str]) -> Value {
    let mut args = vec![
        "benchmark",
        "domains",
        "--real",
        "freeway",
        "--real-city",
        "city",
        "--json",
        "--rounds",
        "speed-5-15,city-lankershim",
    ];
    args.extend(simulated(config, out));
    args.extend_from_slice(extra);
    serde_json::from_str(&ok(dir, &args)).unwrap()
}

fn without(mut v: Value, keys: &[&str]) -> Value {
    for key in keys {
        v.as_object_mut().unwrap().remove(*key);
    }
    v
}

/// `t1.toml`: `t.toml` with the training seed 1. Draw 2 of a run with one seed trains with the
/// seeds after draw 1's (one seed from 0), so its single-draw twin reads this.
fn write_seed_one_config(dir: &Path) {
    let config = std::fs::read_to_string(dir.join("t.toml")).unwrap();
    std::fs::write(dir.join("t1.toml"), format!("seed = 1\n{config}")).unwrap();
}

#[test]
fn draws_pool_each_draws_runs_and_judge_every_claim_on_each_draw_too() {
    let d = scratch();
    let p = d.path();
    write_seed_one_config(p);
    let pooled = simulated_two_rounds(p, "pooled", "t.toml", &["--draws", "2"]);
    let first = simulated_two_rounds(p, "first", "t.toml", &[]);
    let second = simulated_two_rounds(
        p,
        "second",
        "t1.toml",
        &["--train-seed", "101", "--test-seed", "102"],
    );
    for k in 1..=2 {
        assert!(p
            .join(format!(
                "pooled/draw-2/{}",
                ["train-data", "test-data"][k - 1]
            ))
            .is_dir());
    }
    for (i, name) in ["speed-5-15", "city-lankershim"].into_iter().enumerate() {
        let (r, one, two) = (
            &pooled["rounds"][i],
            &first["rounds"][i],
            &second["rounds"][i],
        );
        assert_eq!(r["status"], "ok", "{name}");
        assert_eq!(r["runs"], 4, "{name}: 2 draws x 1 seed x 2 folds");
        let draws = r["slice"]["draws"].as_array().unwrap();
        assert_eq!(draws.len(), 2);
        for (draw, (single, label, first_seed)) in draws
            .iter()
            .zip([(one, "sim seeds 1/2", 0), (two, "sim seeds 101/102", 1)])
        {
            assert_eq!(draw["label"], label);
            assert_eq!(draw["first_seed"], first_seed);
            assert_eq!(
                without(draw.clone(), &["draw", "label", "first_seed"]),
                single["slice"],
                "{name}: a draw's counts are its single run's"
            );
        }
        for key in ["test_conflicts", "test_safe", "real_safe"] {
            let sum = one["slice"][key].as_u64().unwrap() + two["slice"][key].as_u64().unwrap();
            assert_eq!(r["slice"][key], sum, "{name}: {key}");
        }
        let per_draw = r["claims_per_draw"].as_array().unwrap();
        assert_eq!(per_draw[0]["claims"], one["claims"], "{name}");
        assert_eq!(per_draw[1]["claims"], two["claims"], "{name}");
        assert!(one.get("claims_per_draw").is_none() && one["slice"].get("draws").is_none());
        // The pooled runs are the two single runs' runs, row for row.
        let folds = |dir: &str| {
            std::fs::read_to_string(p.join(format!("{dir}/report/{name}.folds.csv"))).unwrap()
        };
        let (a, b) = (folds("first"), folds("second"));
        let mut expected: Vec<&str> = a.lines().collect();
        expected.extend(b.lines().skip(1));
        assert_eq!(
            folds("pooled").lines().collect::<Vec<_>>(),
            expected,
            "{name}"
        );
    }
    let splits: Value =
        serde_json::from_slice(&std::fs::read(p.join("pooled/report/splits.json")).unwrap())
            .unwrap();
    let draws: Vec<u64> = splits[0]["folds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["draw"].as_u64().unwrap())
        .collect();
    assert_eq!(draws, [1, 1, 2, 2]);
    // The pooled claims are the pooled runs paired (recomputed from the report files).
    claims_are_the_runs_paired(&p.join("pooled/report"), &pooled);
    let (header, rows) = csv_rows(&p.join("pooled/report/claims-per-draw.csv"));
    assert_eq!(&header[..3], ["round", "draw", "label"]);
    let claims = |v: &Value| v["claims"].as_array().unwrap().len();
    assert_eq!(
        rows.len(),
        (0..2)
            .map(|i| claims(&first["rounds"][i]) + claims(&second["rounds"][i]))
            .sum::<usize>()
    );
    assert!(!p.join("first/report/claims-per-draw.csv").exists());
    let md = std::fs::read_to_string(p.join("pooled/report/domains.md")).unwrap();
    assert!(md.contains("Slice, over 2 simulator draws"), "{md}");
    assert!(md.contains("| Claim | draw 1 | draw 2 |"), "{md}");
}

#[test]
fn draws_refuse_given_event_folders_and_zero() {
    let d = scratch();
    let o = two_rounds(d.path(), "out", &["--draws", "2"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--draws 2") && err.contains("--train-events sim-train"),
        "{err}"
    );
    assert!(!d.path().join("out").exists());
    let o = two_rounds(d.path(), "out", &["--draws", "0"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--draws"));
}

/// `benchmark transfer` on data it simulates itself, into `out`; its standard output.
fn transfer(dir: &Path, out: &str, config: &str, extra: &[&str]) -> String {
    let mut args = vec!["benchmark", "transfer", "--real", "freeway"];
    args.extend(simulated(config, out));
    args.extend_from_slice(extra);
    ok(dir, &args)
}

#[test]
fn transfer_draws_pool_each_draws_runs_and_judge_every_claim_on_each_draw_too() {
    let d = scratch();
    let p = d.path();
    write_seed_one_config(p);
    let stdout = transfer(p, "pooled", "t.toml", &["--draws", "2"]);
    transfer(p, "first", "t.toml", &[]);
    transfer(
        p,
        "second",
        "t1.toml",
        &["--train-seed", "101", "--test-seed", "102"],
    );
    let file = |dir: &str, name: &str| {
        std::fs::read_to_string(p.join(format!("{dir}/report/{name}"))).unwrap()
    };
    // The pooled runs are the two single runs' runs, row for row.
    let mut expected: Vec<String> = file("first", "folds.csv")
        .lines()
        .map(String::from)
        .collect();
    expected.extend(
        file("second", "folds.csv")
            .lines()
            .skip(1)
            .map(String::from),
    );
    let pooled: Vec<String> = file("pooled", "folds.csv")
        .lines()
        .map(String::from)
        .collect();
    assert_eq!(pooled, expected);
    let results: Value = serde_json::from_str(&file("pooled", "results.json")).unwrap();
    assert_eq!(results["runs"], 4, "2 draws x 1 seed x 2 folds");
    let splits: Value = serde_json::from_str(&file("pooled", "splits.json")).unwrap();
    let draws: Vec<u64> = splits
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["draw"].as_u64().unwrap())
        .collect();
    assert_eq!(draws, [1, 1, 2, 2]);
    // Each draw's claims are its single run's, row for row.
    let (header, per_draw) = csv_rows(&p.join("pooled/report/claims-per-draw.csv"));
    assert_eq!(header[..2], ["draw", "label"]);
    for (draw, label, single) in [
        ("1", "sim seeds 1/2", "first"),
        ("2", "sim seeds 101/102", "second"),
    ] {
        let (_, rows) = csv_rows(&p.join(format!("{single}/report/claims.csv")));
        let mine: Vec<Row> = per_draw
            .iter()
            .filter(|r| r["draw"] == draw)
            .map(|r| {
                assert_eq!(r["label"], label);
                let mut r = r.clone();
                r.remove("draw");
                r.remove("label");
                r
            })
            .collect();
        assert_eq!(mine, rows, "draw {draw}");
    }
    // The pooled claims read the pooled means.
    let (_, claims) = csv_rows(&p.join("pooled/report/claims.csv"));
    let mean = |name: &str, metric: &str| {
        results["methods"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == name)
            .unwrap()[metric]
            .as_f64()
    };
    for c in &claims {
        let written: Option<f64> = c["method_mean"].parse().ok();
        match (written, mean(&c["method"], &c["metric"])) {
            (Some(w), Some(m)) => assert!((w - m).abs() <= 1e-9 * m.abs().max(1.0), "{c:?}"),
            (w, m) => assert_eq!(w, m, "{c:?}"),
        }
    }
    let md = file("pooled", "claims.md");
    assert!(md.contains("- draw 2: sim seeds 101/102"), "{md}");
    assert!(md.contains("| Claim | draw 1 | draw 2 |"), "{md}");
    assert!(stdout.contains("Draw 2: sim seeds 101/102"), "{stdout}");
    assert!(!p.join("first/report/claims-per-draw.csv").exists());
    // A given folder is one draw.
    let args = "benchmark transfer --real freeway --train-events sim-train --draws 3 --out x";
    let o = riskctl(p, &args.split(' ').collect::<Vec<_>>());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--draws 3"), "{err}");
}

/// `benchmark transfer --train-only` joins every model's training side and `--drl-only` DRL's
/// alone (the demo's transfer stage and `--extra-drl-only`): the test folds stay the same, the
/// fold models change where they trained on the folder and only there. An output inside such a
/// folder is refused before anything runs.
#[test]
fn transfer_trains_on_training_only_folders_and_never_writes_into_them() {
    let d = scratch();
    let p = d.path();
    transfer(p, "base", "t.toml", &[]);
    transfer(p, "all", "t.toml", &["--train-only", "city"]);
    transfer(p, "drl", "t.toml", &["--drl-only", "city"]);
    // The rows of one method in a run's folds.csv (seed, fold and the metrics).
    let rows = |out: &str, method: &str| -> Vec<String> {
        std::fs::read_to_string(p.join(format!("{out}/report/folds.csv")))
            .unwrap()
            .lines()
            .filter(|l| l.split(',').nth(2) == Some(method))
            .map(String::from)
            .collect()
    };
    for method in ["TTC2D", "TAdv", "EI"] {
        assert_eq!(
            rows("all", method),
            rows("base", method),
            "{method}: same test folds"
        );
    }
    assert_ne!(rows("all", "DRL"), rows("base", "DRL"));
    assert_ne!(rows("all", "MSRA"), rows("base", "MSRA"));
    assert_ne!(rows("drl", "DRL"), rows("base", "DRL"));
    assert_eq!(
        rows("drl", "MSRA"),
        rows("base", "MSRA"),
        "MSRA never sees --drl-only"
    );

    let events = std::fs::read(p.join("city/events.csv")).unwrap();
    for flag in ["--train-only", "--drl-only"] {
        let mut args = vec!["benchmark", "transfer", "--real", "freeway", flag, "city"];
        args.extend(simulated("t.toml", "city/run"));
        let o = riskctl(p, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{flag}");
        assert!(
            err.contains(&format!("lies inside {flag} city")),
            "{flag}: {err}"
        );
    }
    assert_eq!(std::fs::read(p.join("city/events.csv")).unwrap(), events);
    assert!(!p.join("city/run").exists());
}
