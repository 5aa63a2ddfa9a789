//! What a first-time user runs into: problem counts, refused arguments, folders left behind,
//! messages and a closed standard output. Each test reproduces one reviewer finding.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
mod common;
use common::{riskctl, shipped_model as model, simulate, simulate_mix, RISKCTL};

/// 25 NaN frames of the first event (20 listed by the loader, 5 counted) and an unknown kind on
/// the last events.csv line: 26 problems in all.
fn damage(events: &Path) {
    let frames = std::fs::read_to_string(events.join("frames.csv")).unwrap();
    let mut lines: Vec<String> = frames.lines().map(str::to_owned).collect();
    let first = lines[1].split(',').next().unwrap().to_owned();
    let mut damaged = 0;
    for line in lines.iter_mut().skip(1) {
        let mut fields: Vec<&str> = line.split(',').collect();
        if fields[0] == first && damaged < 25 {
            fields[2] = "NaN";
            damaged += 1;
            *line = fields.join(",");
        }
    }
    assert_eq!(damaged, 25);
    std::fs::write(events.join("frames.csv"), lines.join("\n") + "\n").unwrap();
    let list = std::fs::read_to_string(events.join("events.csv")).unwrap();
    let mut lines: Vec<String> = list.lines().map(str::to_owned).collect();
    let last = lines.last_mut().unwrap();
    let mut fields: Vec<&str> = last.split(',').collect();
    fields[1] = "bogus";
    *last = fields.join(",");
    std::fs::write(events.join("events.csv"), lines.join("\n") + "\n").unwrap();
}

#[test]
fn score_counts_and_lists_every_load_problem_like_evaluate() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    damage(&events);
    let drl = model("drl-default.rsk");
    let o = riskctl(&[
        "score",
        "--model",
        drl.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--out",
        dir.path().join("s.csv").to_str().unwrap(),
    ]);
    let score_err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{score_err}");
    let o = riskctl(&[
        "evaluate",
        "--model",
        drl.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--skip-bad-events",
    ]);
    let eval_err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{eval_err}");
    for err in [&score_err, &eval_err] {
        assert!(err.contains("riskctl: 26 problem(s)"), "{err}");
        assert!(err.contains("unknown kind `bogus`"), "{err}");
        assert!(err.contains("5 more `NonFinite` problems"), "{err}");
        assert!(!err.contains("... and 2 more\n"), "{err}");
    }
}

#[test]
fn simulate_refuses_zero_events_and_leaves_the_folder_alone() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let before: Vec<(PathBuf, Vec<u8>)> = ["events.csv", "frames.csv", "scenarios.csv"]
        .iter()
        .map(|n| (events.join(n), std::fs::read(events.join(n)).unwrap()))
        .collect();
    let o = riskctl(&[
        "simulate",
        "--out",
        events.to_str().unwrap(),
        "--events",
        "0",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("--events 0"), "{err}");
    for (path, bytes) in before {
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "{}", path.display());
    }
    // A new folder is not created either.
    let fresh = dir.path().join("fresh");
    let o = riskctl(&[
        "simulate",
        "--out",
        fresh.to_str().unwrap(),
        "--events",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!fresh.exists());
}

#[test]
fn a_failed_ablation_removes_the_folder_it_created() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("new").join("ablation");
    let missing = dir.path().join("nonexist");
    let o = riskctl(&[
        "ablation",
        "--events",
        missing.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!dir.path().join("new").exists());
}

#[test]
fn model_names_that_clash_with_baselines_or_columns_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let drl = model("drl-default.rsk");
    let (drl, events) = (drl.to_str().unwrap(), events.to_str().unwrap());
    let scores = dir.path().join("s.csv");
    let scores = scores.to_str().unwrap();
    let cases: [(&str, Vec<String>, &str); 4] = [
        (
            "evaluate",
            vec![format!("TTC2D={drl}")],
            "baseline row TTC2D",
        ),
        (
            "score",
            vec![format!("event_id={drl}")],
            "column `event_id`",
        ),
        (
            "score",
            vec![format!("tadv={drl}"), format!("tadv={drl}")],
            "baseline row TAdv",
        ),
        ("evaluate", vec![format!("ei={drl}")], "baseline row EI"),
    ];
    for (command, models, clash) in cases {
        let mut args = vec![command];
        for m in &models {
            args.extend(["--model", m.as_str()]);
        }
        args.extend(["--events", events]);
        if command == "score" {
            args.extend(["--out", scores]);
        }
        let o = riskctl(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("--model") && err.contains(clash),
            "{args:?}: {err}"
        );
        assert!(!Path::new(scores).exists());
    }
    // A name that only resembles one is fine.
    let o = riskctl(&[
        "score",
        "--model",
        &format!("ttc={drl}"),
        "--events",
        events,
        "--out",
        scores,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn export_model_says_a_blob_is_not_a_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.rsk");
    let blob = model("drl-default.rsk");
    let export = |input: &Path| {
        let o = riskctl(&[
            "export-model",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(1), "{err}");
        err
    };
    let err = export(&blob);
    assert!(err.contains("not a riskscore checkpoint"), "{err}");
    assert!(err.contains("model blob"), "{err}");
    assert!(!err.contains("UTF-8"), "{err}");
    assert!(!out.exists());
    // Other binary input: still not a checkpoint, said so without the blob hint.
    let junk = dir.path().join("junk.bin");
    std::fs::write(&junk, [0xff_u8, 0xfe, 0x00, 0x01]).unwrap();
    let err = export(&junk);
    assert!(err.contains("not a riskscore checkpoint"), "{err}");
    assert!(!err.contains("model blob"), "{err}");
}

/// Runs riskctl with a standard output whose reader is already gone (`riskctl ... | true`).
fn riskctl_closed_stdout(args: &[&str]) -> Output {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    Command::new(RISKCTL)
        .args(args)
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("run riskctl")
}

#[test]
fn a_closed_standard_output_does_not_panic_or_lose_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let events = dir.path().join("events");
    let drl = model("drl-default.rsk");
    let (drl, ev) = (drl.to_str().unwrap(), events.to_str().unwrap());
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (train, ablation, calibrated) = (at("train"), at("ablation"), at("c.rsk"));
    let runs: Vec<Vec<&str>> = vec![
        vec![
            "simulate", "--out", ev, "--seed", "3", "--events", "30", "--mix", "1,1,1",
        ],
        vec!["evaluate", "--model", drl, "--events", ev],
        vec!["inspect-model", drl],
        vec!["train", "--events", ev, "--out", &train, "--quiet"],
        vec![
            "calibrate",
            "--model",
            drl,
            "--normal",
            ev,
            "--false-alarm-rate",
            "5",
            "--out",
            &calibrated,
        ],
        vec![
            "ablation",
            "--events",
            ev,
            "--out",
            &ablation,
            "--folds",
            "2",
            "--fractions",
            "0.5",
            "--models",
            "msra",
            "--sources",
            "physics",
            "--singles-only",
            "--quiet",
        ],
    ];
    for args in runs {
        let o = riskctl_closed_stdout(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    assert!(events.join("frames.csv").is_file());
    assert!(Path::new(&train).join("drl.rsk").is_file());
    assert!(Path::new(&calibrated).is_file());
    for name in ["ablation.csv", "ablation.md"] {
        assert!(Path::new(&ablation).join(name).is_file(), "{name}");
    }
}

/// A tiny training configuration (TOML) for runs that only need to reach their outputs.
fn tiny_config(dir: &Path) -> PathBuf {
    let path = dir.join("tiny.toml");
    std::fs::write(
        &path,
        "[comparisons.temporal]\npairs = 200\n[comparisons.cross_sequence]\npairs = 200\n\
         [comparisons.physics]\npairs = 100\n[optimiser]\nmax_epochs = 2\n[drl]\nhidden = [8]\n",
    )
    .unwrap();
    path
}

#[test]
fn demo_with_a_closed_standard_output_finishes_its_run() {
    // The shortest demo there is: a given 9-event folder, 2 folds x 1 seed, no real data, no
    // training-only data, no benchmarks, a tiny configuration (under a second). Its first print
    // (the results table) and the later ones (legend, summary) all meet the closed pipe.
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let config = tiny_config(dir.path());
    let out = dir.path().join("out");
    let o = riskctl_closed_stdout(&[
        "demo",
        "--out",
        out.to_str().unwrap(),
        "--data",
        events.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--folds",
        "2",
        "--seeds",
        "1",
        "--no-real",
        "--no-extra",
        "--no-transfer",
        "--no-domains",
        "--quiet",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // Every stage ran after the first print failed, and wrote its files.
    assert!(err.contains("[6/6] summary"), "{err}");
    for f in ["report/results.md", "models/msra.rsk", "plots/roc.svg"] {
        assert!(out.join(f).is_file(), "{f}: {err}");
    }
}

/// `riskctl train --events EVENTS --config CONFIG --out OUT --quiet`.
fn train_quietly(events: &Path, config: &Path, out: &Path) -> Output {
    riskctl(&[
        "train",
        "--events",
        events.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ])
}

#[test]
fn export_model_f32_of_an_msra_checkpoint_says_it_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let config = tiny_config(dir.path());
    let train = dir.path().join("train");
    let o = train_quietly(&events, &config, &train);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let export = |checkpoint: &str, f32: bool| {
        let out = dir.path().join(format!("{checkpoint}-{f32}.rsk"));
        let ck = train.join(format!("{checkpoint}.json"));
        let mut args = vec![
            "export-model",
            ck.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        if f32 {
            args.push("--f32");
        }
        let o = riskctl(&args);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
        (std::fs::read(&out).unwrap(), err)
    };
    // MSRA: a one-line note naming the flag and the kind; the blob is the one without --f32
    // (an MSRA blob is always f32).
    let (with, err) = export("msra", true);
    let (without, plain) = export("msra", false);
    assert_eq!(with, without);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("--f32") && err.contains("MSRA checkpoint"),
        "{err}"
    );
    assert!(err.contains("msra.json") && err.contains("f32"), "{err}");
    assert!(plain.is_empty(), "{plain}");
    // DRL: the flag means something, no note.
    let (int8, _) = export("drl", false);
    let (float, err) = export("drl", true);
    assert_ne!(int8, float);
    assert!(err.is_empty(), "{err}");
}

#[test]
fn train_without_a_conflict_warns_and_refuses_when_nothing_can_be_learnt() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate_mix(dir.path(), "safe", "12", "0,0,1");
    let ev = events.to_str().unwrap();
    let config = tiny_config(dir.path());
    // Physics pairs are still learnt: the models are written, with a warning that names the
    // folder and its counts and says what is missing.
    let out = dir.path().join("train");
    let o = train_quietly(&events, &config, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let warning = err
        .lines()
        .find(|l| l.starts_with("riskctl: warning:"))
        .unwrap_or_else(|| panic!("no warning: {err}"));
    for part in [ev, "12 safe sequences, 0 conflicts", "physics", "threshold"] {
        assert!(warning.contains(part), "{part}: {warning}");
    }
    assert!(out.join("msra.rsk").is_file());
    // Physics pairs off too: nothing can be learnt, so it fails with the counts and writes
    // nothing (a new folder is not created, an existing one is left as it was).
    let no_physics = dir.path().join("no-physics.toml");
    std::fs::write(&no_physics, "[comparisons.physics]\npairs = 0\n").unwrap();
    let existing = dir.path().join("existing");
    std::fs::create_dir(&existing).unwrap();
    std::fs::write(existing.join("keep.txt"), "old").unwrap();
    for (target, existed) in [(dir.path().join("fresh"), false), (existing, true)] {
        let o = train_quietly(&events, &no_physics, &target);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(
            err.contains(&format!("--events {ev}: 12 safe sequences, 0 conflicts")),
            "{err}"
        );
        assert!(err.contains("no comparison can be built"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        if existed {
            let names: Vec<_> = std::fs::read_dir(&target)
                .unwrap()
                .map(|e| e.unwrap().file_name())
                .collect();
            assert_eq!(names, ["keep.txt"]);
        } else {
            assert!(!target.exists());
        }
    }
}

/// A folder of conflicts only (or one whose safe rows were all dropped: `t_impact` written `NA`
/// by R) trained without a word, though no cross-sequence pair (conflict over safe driving) can
/// be built; it now warns like the folder without a conflict does, and still writes the models.
#[test]
fn train_without_a_safe_sequence_warns() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate_mix(dir.path(), "conflicts", "12", "1,1,0");
    let ev = events.to_str().unwrap();
    let config = tiny_config(dir.path());
    let out = dir.path().join("train");
    let o = train_quietly(&events, &config, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let warning = err
        .lines()
        .find(|l| l.contains("0 safe sequences"))
        .unwrap_or_else(|| panic!("no warning: {err}"));
    for part in [
        "riskctl: warning:",
        &format!("--events {ev}: 12 conflict sequences"),
        "normal driving",
        "threshold",
    ] {
        assert!(warning.contains(part), "{part}: {warning}");
    }
    assert!(out.join("drl.rsk").is_file() && out.join("msra.rsk").is_file());
    // A folder with both kinds says nothing of the sort.
    let mixed = simulate_mix(dir.path(), "mixed", "12", "1,1,1");
    let o = train_quietly(&mixed, &config, &dir.path().join("train-mixed"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && !err.contains("0 safe sequences"),
        "{err}"
    );
}

#[test]
fn a_frames_file_without_final_newline_is_a_warning_not_a_refusal() {
    // A copy cut inside the last row's last number still parses: the loader says the file ends
    // without a newline (file and line), keeps the row, and evaluate and score run.
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let frames = events.join("frames.csv");
    let text = std::fs::read_to_string(&frames).unwrap();
    let lines = text.lines().count();
    std::fs::write(&frames, &text[..text.len() - 2]).unwrap();
    let drl = model("drl-default.rsk");
    let scores = dir.path().join("s.csv");
    for command in ["evaluate", "score"] {
        let mut args = vec![
            command,
            "--model",
            drl.to_str().unwrap(),
            "--events",
            events.to_str().unwrap(),
        ];
        if command == "score" {
            args.extend(["--out", scores.to_str().unwrap()]);
        }
        let o = riskctl(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{command}: {err}");
        let expected = format!(
            "riskctl: warning: {}:{lines}: no newline at the end of the file",
            frames.display()
        );
        assert!(err.contains(&expected), "{command}: {err}");
        assert!(err.contains("cut short"), "{command}: {err}");
        assert!(!err.contains("problem(s)"), "{command}: {err}");
    }
    // The row is kept: every frame is scored.
    let rows = std::fs::read_to_string(&scores).unwrap().lines().count();
    assert_eq!(rows, lines, "header + one row per frame");
}

#[test]
fn train_lists_why_no_sequence_is_left() {
    // Kinds spelled `Crash`, `Safe`: every event is dropped. The error used to be only
    // "contains no usable sequences", without the problems that caused it.
    let tmp = tempfile::tempdir().unwrap();
    let events = simulate(tmp.path());
    let path = events.join("events.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let text = text
        .replace(",crash,", ",Crash,")
        .replace(",near_crash,", ",Near_crash,")
        .replace(",safe,", ",Safe,");
    std::fs::write(&path, text).unwrap();
    let out = tmp.path().join("run");
    let o = riskctl(&[
        "train",
        "--events",
        events.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("events.csv:2: column `kind`") && err.contains("unknown kind `"),
        "{err}"
    );
    assert!(err.contains("contains no usable sequences"), "{err}");
    // Each line names the folder it is about (several --events folders: which one?).
    let prefix = format!("riskctl: {}: warning: ", events.display());
    assert!(err.lines().any(|l| l.starts_with(&prefix)), "{err}");
    assert!(!out.exists());
    // calibrate-domain reads its folders the same way.
    let blob = tmp.path().join("guarded.rsk");
    let o = riskctl(&[
        "calibrate-domain",
        "--model",
        model("drl-default.rsk").to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--out",
        blob.to_str().unwrap(),
    ]);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("events.csv:2: column `kind`"), "{err}");
    assert!(!blob.exists());
}

#[test]
fn a_file_given_as_an_output_folder_is_refused_before_any_work() {
    // `--out` naming an existing model file: it was "training failed: export: FILE: File exists
    // (os error 17)", after the events had been read.
    let tmp = tempfile::tempdir().unwrap();
    let events = simulate(tmp.path());
    let file = tmp.path().join("drl.rsk");
    std::fs::write(&file, b"mine").unwrap();
    let f = file.to_str().unwrap();
    let e = events.to_str().unwrap();
    for args in [
        vec!["train", "--events", e, "--out", f],
        vec!["ablation", "--events", e, "--out", f, "--singles-only"],
        vec!["gssm", "ship", "--events", e, "--normal", e, "--out-dir", f],
    ] {
        let o = riskctl(&args);
        let err = common::stderr(&o);
        assert!(!o.status.success(), "{args:?}: {err}");
        assert!(
            err.contains(&format!("{f}: it is a file, not a folder"))
                && err.contains("left as it was"),
            "{args:?}: {err}"
        );
        assert!(
            !err.contains("events"),
            "{args:?}: refused before reading: {err}"
        );
        assert_eq!(std::fs::read(&file).unwrap(), b"mine");
    }
}

/// `riskctl train` of a small simulated folder with the tiny configuration into `dir/run`.
fn trained_run(dir: &Path) -> PathBuf {
    let events = simulate(dir);
    let config = tiny_config(dir);
    let run = dir.join("run");
    let o = train_quietly(&events, &config, &run);
    assert!(o.status.success(), "{}", common::stderr(&o));
    run
}

#[test]
fn inspect_model_says_a_checkpoint_is_not_a_blob_and_how_to_export_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = trained_run(dir.path());
    for name in ["drl.json", "msra.json"] {
        let checkpoint = run.join(name);
        let o = riskctl(&["inspect-model", checkpoint.to_str().unwrap()]);
        let err = common::stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        // It was "integrity check failed: not a model blob: magic [7b, 0a, 20, 20]".
        assert!(err.contains("it is a training checkpoint"), "{err}");
        assert!(err.contains("riskctl export-model"), "{err}");
    }
    // Saved again with a UTF-8 byte-order mark (export-model reads it): still named.
    let bom = dir.path().join("bom.json");
    let mut bytes = b"\xEF\xBB\xBF".to_vec();
    bytes.extend(std::fs::read(run.join("drl.json")).unwrap());
    std::fs::write(&bom, bytes).unwrap();
    let err = common::stderr(&riskctl(&["inspect-model", bom.to_str().unwrap()]));
    assert!(err.contains("it is a training checkpoint"), "{err}");
    // A blob is still inspected.
    let o = riskctl(&["inspect-model", run.join("drl.rsk").to_str().unwrap()]);
    assert!(o.status.success(), "{}", common::stderr(&o));
}

#[test]
fn train_warns_when_no_event_can_be_held_out_for_validation() {
    let dir = tempfile::tempdir().unwrap();
    let config = tiny_config(dir.path());
    let train = |events: &Path, out: &str| {
        let o = train_quietly(events, &config, &dir.path().join(out));
        let err = common::stderr(&o);
        assert!(o.status.success(), "{err}");
        err
    };
    // One crash: nothing to hold out, early stopping watched the training loss.
    let one = simulate_mix(dir.path(), "one", "1", "1,0,0");
    let err = train(&one, "run-one");
    assert!(
        err.contains("1 sequences are too few to hold out validation events")
            && err.contains("early stopping followed the training loss"),
        "{err}"
    );
    // Nine events: some are held out, no warning.
    let err = train(&simulate(dir.path()), "run-nine");
    assert!(!err.contains("too few to hold out"), "{err}");
}

/// `evaluate --help` said --trajectory-event takes "a crash, a near crash or a safe one", but the
/// trajectories are drawn against the time to the endpoint, which a safe event lacks, and a safe
/// id is refused: the help says what the command does.
#[test]
fn evaluate_trajectory_event_help_says_what_it_takes() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate_mix(dir.path(), "mixed", "6", "1,0,1");
    let text = std::fs::read_to_string(events.join("events.csv")).unwrap();
    let safe = text
        .lines()
        .find_map(|l| l.split_once(",safe,").map(|(id, _)| id.to_owned()))
        .unwrap();
    let drl = model("drl-default.rsk");
    let out = dir.path().join("report");
    let o = riskctl(&[
        "evaluate",
        "--model",
        drl.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--trajectory-event",
        &safe,
    ]);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no crash or near-crash event with that id"),
        "{err}"
    );
    // Refused before the folder is scored (the table used to be printed first).
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let help = String::from_utf8_lossy(&riskctl(&["evaluate", "--help"]).stdout).into_owned();
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        help.contains("Crash or near-crash event whose risk trajectory")
            && help.contains("A safe event has no endpoint to plot against and is refused")
            && !help.contains("or a safe one"),
        "{help}"
    );
}

/// A DRL trained on a small folder carries a training domain its own training frames mostly lie
/// outside (a geometry cell counts only where 5 training sequences reached it): 61 % of a
/// 30-event folder's frames, which its guard scores with the kinematic fallback instead of the
/// network. train said nothing of it; it now warns with the share.
#[test]
fn train_on_a_small_folder_warns_that_the_domain_leaves_most_frames_outside() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate_mix(dir.path(), "small", "30", "70,110,130");
    let out = dir.path().join("run");
    let o = riskctl(&[
        "train",
        "--events",
        events.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    let warning = err
        .lines()
        .find(|l| l.contains("lie outside the training domain it carries"))
        .unwrap_or_else(|| panic!("no warning: {err}"));
    assert!(
        warning.starts_with("riskctl: warning: drl.rsk: ")
            && warning.contains("training frames (")
            && warning.contains("kinematic fallback"),
        "{warning}"
    );
}

#[test]
fn augmenting_a_folder_with_itself_is_refused() {
    // It trained, repeating the events as a "simulation" source and carrying the validation
    // events into training.
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let link = dir.path().join("link");
    std::os::unix::fs::symlink(&events, &link).unwrap();
    let e = events.to_str().unwrap();
    let out = dir.path().join("run");
    let o = out.to_str().unwrap();
    let slash = format!("{e}/");
    for augment in [e, slash.as_str(), link.to_str().unwrap()] {
        for args in [
            vec!["train", "--events", e, "--augment", augment, "--out", o],
            vec!["ablation", "--events", e, "--augment", augment, "--out", o],
        ] {
            let r = riskctl(&args);
            let err = common::stderr(&r);
            assert!(!r.status.success(), "{args:?}: {err}");
            assert!(err.contains("is the --events folder"), "{args:?}: {err}");
            assert!(!out.exists(), "{args:?}");
        }
    }
}

#[test]
fn train_help_says_what_it_writes_and_when_it_warns() {
    // The doc comment of train's arguments was never shown: --help had the options only.
    let o = riskctl(&["train", "--help"]);
    let help = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    for said in [
        "drl.json and msra.json",
        "drl-f32.rsk",
        "a failed\nor interrupted run leaves the old ones",
        "Without a conflict",
    ] {
        assert!(help.contains(said), "{said}: {help}");
    }
}

#[test]
fn export_model_events_to_candump_demo_and_completions_help_say_what_they_do() {
    // Their argument doc comments were never shown by --help either.
    for (command, said) in [
        ("export-model", "so `--f32` changes nothing for it"),
        ("events-to-candump", "Any left-out cycle fails the run"),
        ("demo", "Everything goes under --out"),
        ("completions", "riskctl completions bash >"),
    ] {
        let o = riskctl(&[command, "--help"]);
        let help = String::from_utf8_lossy(&o.stdout);
        assert!(help.contains(said), "{command}: {help}");
    }
}

#[test]
fn export_model_over_a_guarded_blob_is_refused_unless_told_to_replace_it() {
    // `export-model run/drl.json --out run/drl.rsk` replaced the trained blob, which carries the
    // training domain and its guard, with a bare one, silently.
    let dir = tempfile::tempdir().unwrap();
    let run = trained_run(dir.path());
    let checkpoint = run.join("drl.json");
    let export = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "export-model",
            checkpoint.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        riskctl(&args)
    };
    let trained = run.join("drl.rsk");
    let before = std::fs::read(&trained).unwrap();
    let o = export(&trained, &[]);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("holds a training domain (its guard)")
            && err.contains("calibrate-domain")
            && err.contains("--replace-calibrated"),
        "{err}"
    );
    assert_eq!(std::fs::read(&trained).unwrap(), before, "left as it was");
    let o = export(&trained, &["--replace-calibrated"]);
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("warning") && err.contains("held a training domain"),
        "{err}"
    );
    assert_ne!(std::fs::read(&trained).unwrap(), before);
    // Now bare: exporting over it again, or to a new file, needs no flag and warns of nothing.
    for out in [trained, dir.path().join("new.rsk")] {
        let o = export(&out, &[]);
        assert!(o.status.success() && !common::stderr(&o).contains("warning"));
    }
}

/// `export-model run/drl.json --out run/msra.json` (a slip of the other checkpoint's name)
/// replaced the MSRA checkpoint, a training run's parameters, with the DRL blob; it is refused and
/// the checkpoint left as it is, with --replace-calibrated too.
#[test]
fn export_model_over_a_checkpoint_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let run = trained_run(dir.path());
    let (checkpoint, other) = (run.join("drl.json"), run.join("msra.json"));
    let before = std::fs::read(&other).unwrap();
    for extra in [None, Some("--replace-calibrated")] {
        let mut args = vec![
            "export-model",
            checkpoint.to_str().unwrap(),
            "--out",
            other.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = riskctl(&args);
        let err = common::stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(
            err.contains("is a training checkpoint") && err.contains("msra.json"),
            "{err}"
        );
        assert_eq!(std::fs::read(&other).unwrap(), before, "left as it was");
    }
}

/// `calibrate --out run/msra.json` (and `calibrate-domain`) replaced the MSRA checkpoint with a
/// blob, and any other file too (a score table), exit 0. A file that is not a blob is refused and
/// left as it is; a blob is still re-calibrated in place.
#[test]
fn calibrating_over_a_file_that_is_not_a_blob_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let run = trained_run(dir.path());
    let events = dir.path().join("events");
    let table = dir.path().join("scores.csv");
    std::fs::write(&table, "event_id,time,DRL\n000001,0.0,1.5\n").unwrap();
    let (blob, checkpoint) = (run.join("drl.rsk"), run.join("msra.json"));
    // `calibrate` and `calibrate-domain` of `blob` on `events`, into `out`.
    let blob_writer = |command: &str, folder_flag: &str, extra: &[&str], out: &Path| {
        let (blob, events, out) = (blob.to_str(), events.to_str(), out.to_str());
        let mut args = vec![
            command,
            "--model",
            blob.unwrap(),
            folder_flag,
            events.unwrap(),
        ];
        args.extend(extra);
        args.extend(["--out", out.unwrap()]);
        riskctl(&args)
    };
    let calibrate =
        |out: &Path| blob_writer("calibrate", "--normal", &["--false-alarm-rate", "5"], out);
    let calibrate_domain = |out: &Path| blob_writer("calibrate-domain", "--events", &[], out);
    for (out, what) in [
        (&checkpoint, "it is a training checkpoint"),
        (&table, "it is not a model blob"),
    ] {
        let before = std::fs::read(out).unwrap();
        for o in [calibrate(out), calibrate_domain(out)] {
            let err = common::stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{err}");
            assert!(err.contains(what) && err.contains("left as it is"), "{err}");
            assert_eq!(std::fs::read(out).unwrap(), before, "{}", out.display());
        }
    }
    // A blob at --out is re-calibrated in place, as before.
    let again = dir.path().join("drl-calibrated.rsk");
    std::fs::copy(&blob, &again).unwrap();
    let o = calibrate(&again);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert_ne!(
        std::fs::read(&again).unwrap(),
        std::fs::read(&blob).unwrap()
    );
}

/// A read-only output (a file, or an `evaluate --out` folder) was replaced by the rename whatever
/// its mode, and the folder's old copy was left behind as `.NAME.XXXXXX.old/` where its files
/// could not be removed. Both are refused and left as they are; evaluate says so before it
/// computes (no table printed).
#[test]
fn read_only_outputs_are_refused_and_left_as_they_are() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let (table, folder) = (dir.path().join("s.csv"), dir.path().join("rep"));
    std::fs::write(&table, "old\n").unwrap();
    std::fs::create_dir(&folder).unwrap();
    std::fs::write(folder.join("notes.txt"), "mine\n").unwrap();
    for p in [&table, &folder] {
        let mode = if p.is_dir() { 0o555 } else { 0o444 };
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
    }
    let blob = model("drl-default.rsk");
    let run = |command: &str, out: &Path| {
        riskctl(&[
            command,
            "--model",
            blob.to_str().unwrap(),
            "--events",
            events.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    for (command, out) in [("score", &table), ("evaluate", &folder)] {
        let o = run(command, out);
        let err = common::stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{command}: {err}");
        assert!(
            err.contains("is read-only") && err.contains("left as it is"),
            "{err}"
        );
        if command == "evaluate" {
            // It computes before it writes: refused first, no table printed.
            assert!(o.stdout.is_empty(), "{command} computed first");
        }
    }
    assert_eq!(std::fs::read_to_string(&table).unwrap(), "old\n");
    assert_eq!(
        std::fs::read_to_string(folder.join("notes.txt")).unwrap(),
        "mine\n"
    );
    let mut left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["events", "rep", "s.csv"], "temporaries left");
    for p in [&table, &folder] {
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
}

/// events-to-candump printed an event it dropped as a bare `warning: sim/frames.csv:3: ...`: no
/// tool prefix, and nothing said the event was gone from the log (now said as evaluate says it).
#[test]
fn events_to_candump_says_which_event_it_leaves_out() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let frames = events.join("frames.csv");
    let text = std::fs::read_to_string(&frames).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let mut fields: Vec<&str> = lines[2].split(',').collect();
    fields[2] = "abc";
    lines[2] = fields.join(",");
    std::fs::write(&frames, lines.join("\n") + "\n").unwrap();
    let out = dir.path().join("d.log");
    let o = riskctl(&[
        "events-to-candump",
        "--events",
        events.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("frames.csv:3"))
        .expect(&err);
    assert!(line.starts_with("riskctl: warning: "), "{line}");
    assert!(line.ends_with("(the event is skipped)"), "{line}");
}

/// A command that computes first is told at its start: `train` over a read-only checkpoint
/// trained and then failed to write it (the run lost), and `evaluate --out rep` with
/// `rep/results.md/` a folder of notes scored the folder before its swap refused.
#[test]
fn outputs_a_run_could_not_write_are_refused_before_it_computes() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let run = trained_run(dir.path());
    let events = dir.path().join("events");
    let checkpoint = run.join("msra.json");
    let before = std::fs::read(&checkpoint).unwrap();
    std::fs::set_permissions(&checkpoint, std::fs::Permissions::from_mode(0o444)).unwrap();
    let config = tiny_config(dir.path());
    let o = train_quietly(&events, &config, &run);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("msra.json: it is read-only"), "{err}");
    assert!(!err.contains("epoch"), "it trained first: {err}");
    assert_eq!(std::fs::read(&checkpoint).unwrap(), before);

    let rep = dir.path().join("rep");
    std::fs::create_dir_all(rep.join("results.md")).unwrap();
    std::fs::write(rep.join("results.md/note"), "mine\n").unwrap();
    let o = riskctl(&[
        "evaluate",
        "--model",
        run.join("drl.rsk").to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--out",
        rep.to_str().unwrap(),
    ]);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("results.md is a folder, not the file this run writes"),
        "{err}"
    );
    assert!(o.stdout.is_empty(), "it scored first");
    assert_eq!(
        std::fs::read_to_string(rep.join("results.md/note")).unwrap(),
        "mine\n"
    );
}

/// train writes five named files into --out and leaves the rest of the folder alone, so a
/// configuration kept in the run folder is no overlap (it was refused: "--out runs/x contains
/// --config runs/x/cfg.toml: refusing to replace it"); a configuration at one of those five
/// paths still is.
#[test]
fn train_keeps_a_configuration_that_lives_in_its_output_folder() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let run = dir.path().join("run");
    std::fs::create_dir(&run).unwrap();
    let config = run.join("cfg.toml");
    std::fs::copy(tiny_config(dir.path()), &config).unwrap();
    let before = std::fs::read(&config).unwrap();
    let train = |config: &Path| train_quietly(&events, config, &run);
    let o = train(&config);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert_eq!(std::fs::read(&config).unwrap(), before);
    assert!(run.join("drl.rsk").exists() && run.join("msra.json").exists());
    // A configuration where train writes a model is still refused, and left as it is.
    let at_a_model = run.join("drl.json");
    std::fs::copy(&config, &at_a_model).unwrap();
    let o = train(&at_a_model);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("is the same file as --config"), "{err}");
    assert_eq!(std::fs::read(&at_a_model).unwrap(), before);
}

/// `--out -` for a folder output made a folder literally named `-` (and `evaluate --out -`
/// merged its report into it): `-` is standard output everywhere else. Now refused before
/// anything runs; `./-` still names such a folder.
#[test]
fn a_dash_is_not_a_folder_to_write() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        ["simulate", "--out", "-", "--events", "3"].as_slice(),
        ["roadside-passes", "--out", "-"].as_slice(),
    ] {
        let o = common::riskctl_in(dir.path(), args);
        let err = common::stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("cannot hold a folder"), "{args:?}: {err}");
        assert!(!dir.path().join("-").exists(), "{args:?} made a folder `-`");
    }
    let o = common::riskctl_in(dir.path(), &["simulate", "--out", "./-", "--events", "3"]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(dir.path().join("-/events.csv").is_file());
}
