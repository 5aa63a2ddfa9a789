//! `riskctl gssm ship` end to end on a tiny simulated folder: the command wires the library
//! (`riskscore_train::gssm::ship`) to its flags and writes the three models and the summary.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn riskctl(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_riskctl"))
        .args(args)
        .output()
        .expect("running riskctl");
    assert!(
        out.status.success(),
        "riskctl {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn arg(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// A simulated folder of `events` events under `dir`, and the tiny training and GSSM
/// configurations of riskscore-train's ship test.
fn simulated_with_tiny_configs(
    dir: &Path,
    events: &str,
    seed: &str,
) -> (PathBuf, PathBuf, PathBuf) {
    let folder = dir.join("events");
    riskctl(&[
        "simulate",
        "--out",
        arg(&folder),
        "--events",
        events,
        "--seed",
        seed,
    ]);
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("train/tests/data/tiny");
    (folder, tiny.join("train.toml"), tiny.join("gssm.toml"))
}

#[test]
fn gssm_ship_writes_three_models_and_a_summary_of_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let (events, train_toml, gssm_toml) = simulated_with_tiny_configs(dir.path(), "40", "3");
    let models = dir.path().join("models");
    let out = riskctl(&[
        "gssm",
        "ship",
        "--events",
        arg(&events),
        "--config",
        arg(&train_toml),
        "--gssm-config",
        arg(&gssm_toml),
        "--seed",
        "1",
        "--out-dir",
        arg(&models),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("MSRA(TAdv-corridor+EI+GSSM)"), "{stdout}");
    for file in ["gssm-default.rsk", "ssra-default.rsk", "msra-gssm.rsk"] {
        let bytes = std::fs::read(models.join(file)).unwrap();
        scorer_core::model::decode(&bytes).unwrap();
    }
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(models.join("gssm-ship.json")).unwrap()).unwrap();
    assert_eq!(summary["events"][0], arg(&events));
    assert_eq!(summary["normal"], serde_json::json!([]));
    assert_eq!(summary["seed"], 1);
    assert_eq!(summary["msra"]["configuration"], "TAdv-corridor+EI+GSSM");
}

/// `N + M` of "GSSM ...: N safe observations (M validation)" in `riskctl gssm fit`'s report: every
/// safe observation the fit read, whichever events its validation split holds out.
fn fitted_observations(stdout: &[u8]) -> usize {
    let text = String::from_utf8_lossy(stdout);
    let (_, rest) = text.split_once(": ").expect("fit report");
    let (fit, rest) = rest.split_once(" safe observations (").expect("fit report");
    let (validation, _) = rest.split_once(" validation)").expect("fit report");
    let count = |n: &str| n.parse::<usize>().expect("observation count");
    count(fit) + count(validation)
}

#[test]
fn gssm_fit_pools_the_safe_driving_of_every_normal_folder() {
    let dir = tempfile::tempdir().unwrap();
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("train/tests/data/tiny");
    let (train_toml, gssm_toml) = (tiny.join("train.toml"), tiny.join("gssm.toml"));
    let folders: Vec<_> = [("a", "3"), ("b", "4")]
        .iter()
        .map(|(name, seed)| {
            let folder = dir.path().join(name);
            riskctl(&[
                "simulate",
                "--out",
                arg(&folder),
                "--events",
                "30",
                "--seed",
                seed,
            ]);
            folder
        })
        .collect();
    let fit = |normal: &[&Path], out: &str| {
        let mut args = vec!["gssm", "fit", "--events", arg(&folders[0])];
        for n in normal {
            args.extend(["--normal", arg(n)]);
        }
        let out = dir.path().join(out);
        args.extend([
            "--config",
            arg(&train_toml),
            "--gssm-config",
            arg(&gssm_toml),
        ]);
        args.extend(["--out", arg(&out)]);
        let observations = fitted_observations(&riskctl(&args).stdout);
        scorer_core::model::decode(&std::fs::read(&out).unwrap()).unwrap();
        observations
    };
    let a = fit(&[&folders[0]], "a.rsk");
    let b = fit(&[&folders[1]], "b.rsk");
    assert!(a > 0 && b > 0 && a != b, "{a} {b}");
    assert_eq!(fit(&[&folders[0], &folders[1]], "ab.rsk"), a + b);

    // `gssm nll` scores the same safe observations, each folder in the five speed bands.
    let model = dir.path().join("ab.rsk");
    let out = riskctl(&[
        "gssm",
        "nll",
        "--gssm",
        arg(&model),
        "--events",
        arg(&folders[0]),
        "--events",
        arg(&folders[1]),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(2)
        .map(|l| l.trim_matches('|').split(" | ").map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 10, "{text}");
    let per_folder = |folder: &Path| -> usize {
        rows.iter()
            .filter(|r| r[0] == arg(folder))
            .map(|r| r[2].parse::<usize>().expect("observations"))
            .sum()
    };
    assert_eq!((per_folder(&folders[0]), per_folder(&folders[1])), (a, b));
    for r in &rows {
        let observed = r[2] != "0";
        assert_eq!(
            r[3].parse::<f64>().is_ok_and(f64::is_finite),
            observed,
            "{text}"
        );
    }
}

#[test]
fn gssm_ship_and_cv_hand_the_gssm_over_to_the_fallback_of_the_given_msra() {
    let dir = tempfile::tempdir().unwrap();
    let (events, train_toml, gssm_toml) = simulated_with_tiny_configs(dir.path(), "150", "4");
    let msra = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/msra-default.rsk");
    let common = [
        "--events",
        arg(&events),
        "--config",
        arg(&train_toml),
        "--gssm-config",
        arg(&gssm_toml),
        "--fallback-from",
        arg(&msra),
    ];
    let models = dir.path().join("models");
    riskctl(&[&["gssm", "ship"], &common[..], &["--out-dir", arg(&models)]].concat());
    let bytes = std::fs::read(models.join("gssm-default.rsk")).unwrap();
    let blob = scorer_core::model::decode_blob(&bytes).unwrap();
    let fallback = blob.meta.kinematic_fallback.expect("the GSSM falls back");
    let msra_bytes = std::fs::read(&msra).unwrap();
    let scorer_core::Model::Msra(m) = scorer_core::model::decode(&msra_bytes).unwrap() else {
        panic!("msra-default.rsk is an MSRA")
    };
    assert_eq!(fallback.terms().collect::<Vec<_>>(), m.terms.to_vec());
    // The study scores its fold models through the same guard (150 events: enough for cells of 5
    // safe sequences, and the GSSM row differs); a source that is no MSRA is refused before
    // anything runs.
    let gssm_row = |args: &[&str]| {
        let out = riskctl(&[&["gssm", "cv", "--folds", "2", "--json"], args].concat());
        assert!(
            !String::from_utf8_lossy(&out.stderr).contains("no kinematic fallback"),
            "every fold's fallback is fitted"
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let methods = v["methods"].as_array().unwrap().clone();
        methods
            .into_iter()
            .find(|m| m["name"] == "GSSM")
            .expect("a GSSM row")
    };
    let guarded = gssm_row(&common);
    let unguarded = gssm_row(&common[..common.len() - 2]);
    assert_ne!(guarded, unguarded);
    // A source with neither MSRA terms nor a fallback record of its own (the GSSM without its
    // guard) is refused; the guarded one's fallback terms would be taken.
    let bytes = std::fs::read(models.join("gssm-default.rsk")).unwrap();
    let mut bare = scorer_core::model::decode_blob(&bytes).unwrap();
    bare.meta.training_domain = None;
    bare.meta.kinematic_fallback = None;
    let mut buf = vec![0u8; scorer_core::model::encoded_blob_len(&bare).unwrap()];
    let n = scorer_core::model::encode_blob(&bare, &mut buf).unwrap();
    let bare_path = models.join("gssm-bare.rsk");
    std::fs::write(&bare_path, &buf[..n]).unwrap();
    let refused = Command::new(env!("CARGO_BIN_EXE_riskctl"))
        .args(["gssm", "cv", "--events", arg(&events), "--fallback-from"])
        .arg(&bare_path)
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("a GSSM blob without a kinematic fallback"),
        "{err}"
    );
}

/// `gssm align` and `gssm msra` read the GSSM of `--gssm` and fit none, yet took `--normal` (from
/// the flags they shared with `fit` and `ship`) and ignored it, even for a folder that does not
/// exist: the model was written as if it had not been given. Only `fit`, `ship` and `cv` declare
/// the flag now, so clap rejects it on `align` and `msra` (exit 2, naming `--normal`) before any
/// input is read, and nothing is written.
#[test]
fn gssm_align_and_msra_refuse_normal_driving_they_would_ignore() {
    let dir = tempfile::tempdir().unwrap();
    // Never read: clap refuses the command line first.
    let events = dir.path().join("events");
    let gssm = dir.path().join("gssm.rsk");
    let missing = dir.path().join("no-such-normal-folder");
    for sub in ["align", "msra"] {
        let out = dir.path().join(format!("{sub}.rsk"));
        let o = Command::new(env!("CARGO_BIN_EXE_riskctl"))
            .args([
                "gssm",
                sub,
                "--events",
                arg(&events),
                "--normal",
                arg(&missing),
                "--gssm",
                arg(&gssm),
                "--out",
                arg(&out),
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{sub}: {err}");
        assert!(
            err.contains("unexpected argument '--normal'"),
            "{sub}: {err}"
        );
        assert!(!out.exists(), "{sub}: {err}");
    }
}
