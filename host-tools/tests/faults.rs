//! The fault suite of issue #21: every command that writes, run against its own inputs, a missing
//! input, a second writer, a target it cannot write, and (simulate) Ctrl-C in the middle. Every
//! case asserts a non-zero exit, a message naming the file, every pre-existing user file byte for
//! byte unchanged, and no temporary or lock file left behind (the whole scratch folder is compared
//! before and after, hidden files included).
//!
//! A read-only target folder is made with a regular file as the target's parent: chmod does not
//! stop root (CI runs as root), a file in the way does.
#![cfg(feature = "parquet")]
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

fn riskctl(dir: &Path, args: &[&str]) -> Output {
    Command::new(RISKCTL)
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run riskctl")
}

fn model() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../models/drl-default.rsk")
}

fn commonroad(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/commonroad")
        .join(name)
}

/// Every file under `dir` (hidden ones too) with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(dir).unwrap().to_path_buf();
            if p.is_dir() {
                out.insert(rel, b"<dir>".to_vec());
                stack.push(p);
            } else {
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

/// A scratch folder with a small event folder `sim` (and a copy `sim2`), the model `m.rsk`, a
/// pairs CSV `p.csv` with a bad row and its Parquet form `p.parquet`, and an old `out.csv`.
fn scratch() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let o = riskctl(
        d.path(),
        &[
            "simulate", "--out", "sim", "--events", "6", "--seed", "3", "--mix", "2,2,2",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::copy(model(), d.path().join("m.rsk")).unwrap();
    let h = "x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j";
    let g = "0,0,10,0,1,0,0,4.5,1.8,20,0,5,0,1,0,0,4.5,1.8";
    let bad = "0,0,10,zz,1,0,0,4.5,1.8,20,0,5,0,1,0,0,4.5,1.8";
    std::fs::write(d.path().join("p.csv"), format!("{h}\n{g}\n{bad}\n{g}\n")).unwrap();
    let o = riskctl(
        d.path(),
        &["ssm", "--input", "p.csv", "--output", "p.parquet"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::write(d.path().join("out.csv"), "old output\n").unwrap();
    std::fs::write(d.path().join("plain"), "a regular file\n").unwrap();
    d
}

/// Runs `args` in `dir` and asserts a failure whose message names `names`, with the folder
/// byte for byte as before.
#[track_caller]
fn refused(dir: &Path, args: &[&str], names: &[&str]) -> String {
    let before = snapshot(dir);
    let o = riskctl(dir, args);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "{args:?} succeeded: {stderr}");
    assert_ne!(o.status.code(), Some(101), "{args:?} panicked: {stderr}");
    for n in names {
        assert!(
            stderr.contains(n),
            "{args:?}: message does not name {n}: {stderr}"
        );
    }
    let after = snapshot(dir);
    let changed: Vec<_> = before
        .keys()
        .chain(after.keys())
        .filter(|k| before.get(*k) != after.get(*k))
        .collect();
    assert!(
        changed.is_empty(),
        "{args:?} changed or left {changed:?}: {stderr}"
    );
    stderr
}

/// Holds the output lock on `target` as another process would, for the duration of `f`.
fn while_locked(target: &Path, f: impl FnOnce()) {
    let lock = riskscore_output::OutputLock::acquire(target).unwrap();
    f();
    drop(lock);
}

const BUSY: &str = "another process is writing";

#[test]
fn import_commonroad_never_replaces_a_folder_it_cannot_fill() {
    let d = scratch();
    let p = d.path();
    std::fs::write(p.join("empty.xml"), "").unwrap();
    let good = commonroad("ZAM_Merge-1_1_T-1.xml");
    let good = good.to_str().unwrap();
    // N9: a typo in the input path; N8: a 0-byte XML. The old folder stays whole.
    refused(
        p,
        &["import", "commonroad", "--out", "sim", "no/such/typo/"],
        &["typo"],
    );
    refused(
        p,
        &["import", "commonroad", "--out", "sim", "empty.xml"],
        &["empty.xml"],
    );
    // N21: the output is the input.
    std::fs::copy(good, p.join("in.xml")).unwrap();
    refused(
        p,
        &["import", "commonroad", "--out", "in.xml", "in.xml"],
        &["--out", "in.xml"],
    );
    // A second writer; a target under a regular file.
    while_locked(&p.join("sim/events.csv"), || {
        refused(p, &["import", "commonroad", "--out", "sim", good], &[BUSY]);
    });
    refused(
        p,
        &["import", "commonroad", "--out", "plain/ev", good],
        &["plain"],
    );
}

#[test]
fn ssm_refuses_its_input_as_output_and_a_second_writer() {
    let d = scratch();
    let p = d.path();
    // N62 / N61: CSV and Parquet, also through `./`.
    for (i, o) in [
        ("p.csv", "p.csv"),
        ("p.csv", "./p.csv"),
        ("p.parquet", "p.parquet"),
    ] {
        refused(
            p,
            &["ssm", "--input", i, "--output", o],
            &["--output", "--input", "p."],
        );
    }
    refused(
        p,
        &["ssm", "--input", "missing.csv", "--output", "out.csv"],
        &["missing.csv"],
    );
    while_locked(&p.join("out.csv"), || {
        refused(
            p,
            &["ssm", "--input", "p.csv", "--output", "out.csv"],
            &[BUSY, "out.csv"],
        );
    });
    refused(
        p,
        &["ssm", "--input", "p.csv", "--output", "plain/o.csv"],
        &["plain/o.csv"],
    );
}

#[test]
fn score_refuses_the_event_files_and_the_model_as_output() {
    let d = scratch();
    let p = d.path();
    // N28, N30, N29.
    for out in [
        "sim/frames.csv",
        "sim/events.csv",
        "m.rsk",
        "./sim/../m.rsk",
    ] {
        refused(
            p,
            &["score", "--model", "m.rsk", "--events", "sim", "--out", out],
            &["--out", out],
        );
    }
    refused(
        p,
        &[
            "score", "--model", "m.rsk", "--events", "nosuch", "--out", "out.csv",
        ],
        &["nosuch"],
    );
    while_locked(&p.join("out.csv"), || {
        refused(
            p,
            &[
                "score", "--model", "m.rsk", "--events", "sim", "--out", "out.csv",
            ],
            &[BUSY, "out.csv"],
        );
    });
    refused(
        p,
        &[
            "score",
            "--model",
            "m.rsk",
            "--events",
            "sim",
            "--out",
            "plain/s.csv",
        ],
        &["plain/s.csv"],
    );
}

#[test]
fn gssm_fit_and_export_model_refuse_their_inputs_as_output() {
    let d = scratch();
    let p = d.path();
    // N133.
    refused(
        p,
        &["gssm", "fit", "--events", "sim", "--out", "sim/frames.csv"],
        &["--out", "sim/frames.csv", "--events"],
    );
    refused(
        p,
        &["gssm", "fit", "--events", "nosuch", "--out", "g.rsk"],
        &["nosuch"],
    );
    // N134: refused before the checkpoint is even read.
    std::fs::write(p.join("ck.json"), "{\"not\": \"read\"}").unwrap();
    refused(
        p,
        &["export-model", "ck.json", "--out", "ck.json"],
        &["--out", "ck.json"],
    );
    refused(
        p,
        &["export-model", "nosuch.json", "--out", "m2.rsk"],
        &["nosuch.json"],
    );
}

#[test]
fn evaluate_writes_its_folder_whole_or_not_at_all() {
    let d = scratch();
    let p = d.path();
    let o = riskctl(
        p,
        &[
            "evaluate", "--model", "m.rsk", "--events", "sim", "--out", "ev",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::write(p.join("ev/notes.txt"), "mine").unwrap();
    refused(
        p,
        &[
            "evaluate", "--model", "m.rsk", "--events", "nosuch", "--out", "ev",
        ],
        &["nosuch"],
    );
    refused(
        p,
        &[
            "evaluate", "--model", "m.rsk", "--events", "sim", "--out", "m.rsk",
        ],
        &["m.rsk"],
    );
    while_locked(&p.join("ev"), || {
        refused(
            p,
            &[
                "evaluate", "--model", "m.rsk", "--events", "sim", "--out", "ev",
            ],
            &[BUSY, "ev"],
        );
    });
    refused(
        p,
        &[
            "evaluate", "--model", "m.rsk", "--events", "sim", "--out", "plain/ev",
        ],
        &["plain"],
    );
    // A successful run replaces the report and keeps the user's file.
    let o = riskctl(
        p,
        &[
            "evaluate", "--model", "m.rsk", "--events", "sim", "--out", "ev",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(p.join("ev/notes.txt")).unwrap(),
        "mine"
    );
    let hidden: Vec<_> = snapshot(p)
        .into_keys()
        .filter(|k| k.to_string_lossy().contains("/.") || k.to_string_lossy().starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "temporaries left: {hidden:?}");
}

/// Waits until a temporary of the run appears in `dir` (the run is writing).
fn wait_for_temporary(dir: &Path, child: &mut std::process::Child) {
    let start = Instant::now();
    loop {
        let writing = std::fs::read_dir(dir)
            .unwrap()
            .any(|e| e.unwrap().file_name().to_string_lossy().ends_with(".tmp"));
        if writing {
            return;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it wrote"
        );
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "no temporary appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn simulate_interrupted_or_doubled_leaves_the_old_folder_as_it_was() {
    let d = scratch();
    let p = d.path();
    // N90: Ctrl-C in the middle of a long run over an old folder.
    let before = snapshot(p);
    let mut child = Command::new(RISKCTL)
        .current_dir(p)
        .args([
            "simulate", "--out", "sim", "--events", "2000000", "--seed", "11",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_temporary(&p.join("sim"), &mut child);
    std::thread::sleep(Duration::from_millis(200));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        snapshot(p),
        before,
        "Ctrl-C changed the old folder or left temporaries"
    );

    // N91: a second simulate into the same folder while the first writes is refused; the first
    // completes alone.
    let mut first = Command::new(RISKCTL)
        .current_dir(p)
        .args([
            "simulate", "--out", "sim", "--events", "400", "--seed", "21",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_temporary(&p.join("sim"), &mut first);
    let second = riskctl(
        p,
        &["simulate", "--out", "sim", "--events", "30", "--seed", "22"],
    );
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(
        !second.status.success() && stderr.contains(BUSY),
        "{stderr}"
    );
    assert!(stderr.contains("sim"), "{stderr}");
    let o = first.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scenarios = std::fs::read_to_string(p.join("sim/scenarios.csv")).unwrap();
    assert_eq!(scenarios.lines().count(), 401, "scenarios.csv mixed or cut");
    assert!(scenarios.lines().all(|l| l.split(',').count() == 9));
    let left: Vec<_> = snapshot(p)
        .into_keys()
        .filter(|k| k.to_string_lossy().contains("/."))
        .collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");

    // A target under a regular file.
    refused(
        p,
        &["simulate", "--out", "plain/sim", "--events", "3"],
        &["plain/sim"],
    );
}
