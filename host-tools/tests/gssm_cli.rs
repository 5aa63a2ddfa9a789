//! `riskctl gssm ship` end to end on a tiny simulated folder: the command wires the library
//! (`riskscore_train::gssm::ship`) to its flags and writes the three models and the summary.
use std::path::Path;
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

#[test]
fn gssm_ship_writes_three_models_and_a_summary_of_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let events = dir.path().join("events");
    riskctl(&[
        "simulate",
        "--out",
        arg(&events),
        "--events",
        "40",
        "--seed",
        "3",
    ]);
    // The tiny configurations of riskscore-train's ship test.
    let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("train/tests/data/tiny");
    let (train_toml, gssm_toml) = (tiny.join("train.toml"), tiny.join("gssm.toml"));
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
    assert!(stdout.contains("MSRA(TAdv+EI+GSSM)"), "{stdout}");
    for file in ["gssm-default.rsk", "ssra-default.rsk", "msra-gssm.rsk"] {
        let bytes = std::fs::read(models.join(file)).unwrap();
        scorer_core::model::decode(&bytes).unwrap();
    }
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(models.join("gssm-ship.json")).unwrap()).unwrap();
    assert_eq!(summary["events"][0], arg(&events));
    assert!(summary["normal"].is_null());
    assert_eq!(summary["seed"], 1);
    assert_eq!(summary["msra"]["configuration"], "TAdv+EI+GSSM");
}
