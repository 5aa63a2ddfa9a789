//! `riskctl simulate --families`: the named mixes and family lists reach the simulator, the family
//! of every event is in scenarios.csv, the default is the original data set, and a bad list is
//! refused before anything is written.
use std::path::Path;
use std::process::Output;
mod common;
use common::riskctl;

fn simulate(out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["simulate", "--out", out.to_str().unwrap()];
    if !extra.contains(&"--events") {
        args.extend(["--events", "30"]);
    }
    args.extend_from_slice(extra);
    let o = riskctl(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The `family` column of scenarios.csv.
fn families(dir: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("scenarios.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "family").unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().to_string())
        .collect()
}

#[test]
fn default_families_are_the_original_data_set() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, named) = (dir.path().join("plain"), dir.path().join("named"));
    simulate(&plain, &[]);
    let o = simulate(&named, &["--families", "default"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("(families: default)"));
    for f in ["events.csv", "frames.csv", "scenarios.csv"] {
        assert_eq!(
            std::fs::read(plain.join(f)).unwrap(),
            std::fs::read(named.join(f)).unwrap(),
            "{f}"
        );
    }
    let original = [
        "lead_braking",
        "stopped_ahead",
        "cut_in",
        "lane_change",
        "merge",
        "crossing",
        "left_turn_across",
        "turn_into_path",
        "opposite_drift",
    ];
    assert!(families(&plain)
        .iter()
        .all(|f| original.contains(&f.as_str())));
}

#[test]
fn a_family_list_draws_only_those_families_and_domain_adds_the_new_ones() {
    let dir = tempfile::tempdir().unwrap();
    let listed = dir.path().join("listed");
    let o = simulate(
        &listed,
        &[
            "--families",
            "motorway_approach:2,roadside_object",
            "--seed",
            "4",
        ],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("motorway_approach"), "{stdout}");
    let got = families(&listed);
    assert_eq!(got.len(), 30);
    assert!(got
        .iter()
        .all(|f| f == "motorway_approach" || f == "roadside_object"));
    assert!(got.iter().any(|f| f == "motorway_approach"));

    let domain = dir.path().join("domain");
    simulate(&domain, &["--families", "domain", "--events", "120"]);
    let got = families(&domain);
    let new = [
        "motorway_approach",
        "motorway_cut_in",
        "signal_queue",
        "signal_crossing",
        "signal_left_turn",
        "signal_right_turn",
        "roadside_object",
    ];
    let new_count = got.iter().filter(|f| new.contains(&f.as_str())).count();
    assert!(
        new_count > 20 && new_count < 100,
        "{new_count} of 120 from new families"
    );
}

#[test]
fn an_unknown_family_is_refused_by_name_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let o = riskctl(&[
        "simulate",
        "--out",
        out.to_str().unwrap(),
        "--families",
        "motorway_approach,autobahn",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("unknown family `autobahn`"), "{err}");
    assert!(
        err.contains("signal_queue"),
        "lists the known families: {err}"
    );
    assert!(!out.exists());
}
