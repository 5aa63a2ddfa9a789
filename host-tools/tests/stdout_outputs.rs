//! Output paths as a Unix user expects them (docs/outputs.md, guarantees 8 and 9):
//!
//! - `-` is standard output for every command that writes one file, `events-to-candump --out`
//!   and `calibrate --out` included (they used to create a file named `-`); the stream there is
//!   exactly what `--out FILE` writes, and the command's summary goes to stderr.
//! - A missing parent folder of an output (`--out a/b/c.csv` with no `a/b`) is created, for a
//!   file, a folder and an event-folder output alike; a run that fails or is interrupted leaves
//!   no folder it created behind.
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
mod common;
use common::{riskctl_in as riskctl, RISKCTL};

#[track_caller]
fn ok(dir: &Path, args: &[&str]) -> Output {
    let o = riskctl(dir, args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

#[track_caller]
fn fails(dir: &Path, args: &[&str]) -> String {
    let o = riskctl(dir, args);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    stderr
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Every name in `dir`, hidden ones included, recursively, sorted.
fn tree(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            out.push(p.strip_prefix(root).unwrap().to_path_buf());
            if p.is_dir() && !p.is_symlink() {
                walk(root, &p, out);
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// A scratch folder with a small simulated event folder `sim` (2 crash, 2 near-crash, 2 safe),
/// a folder `empty` holding no event, and the shipped DRL model as `m.rsk`.
fn scratch() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    ok(
        p,
        &[
            "simulate", "--out", "sim", "--events", "6", "--seed", "3", "--mix", "2,2,2",
        ],
    );
    std::fs::create_dir(p.join("empty")).unwrap();
    for f in ["events.csv", "frames.csv"] {
        let all = std::fs::read_to_string(p.join("sim").join(f)).unwrap();
        let header = all.lines().next().unwrap();
        std::fs::write(p.join("empty").join(f), format!("{header}\n")).unwrap();
    }
    let model = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../models/drl-default.rsk");
    std::fs::copy(model, p.join("m.rsk")).unwrap();
    d
}

#[test]
fn events_to_candump_dash_streams_the_log_and_says_the_summary_on_stderr() {
    let d = scratch();
    let p = d.path();
    let file = ok(
        p,
        &["events-to-candump", "--events", "sim", "--out", "d.log"],
    );
    assert!(text(&file.stdout).starts_with("wrote d.log: 6 events"));
    let log = std::fs::read(p.join("d.log")).unwrap();
    assert!(!log.is_empty());
    let before = tree(p);

    let o = ok(p, &["events-to-candump", "--events", "sim", "--out", "-"]);
    assert!(
        o.stdout == log,
        "standard output differs from --out FILE ({} vs {} bytes)",
        o.stdout.len(),
        log.len()
    );
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("wrote standard output: 6 events"),
        "{stderr}"
    );
    assert!(!p.join("-").exists(), "a file named - was created");
    assert_eq!(tree(p), before, "files appeared or changed");

    // Every line is one can-bridge's replay reads (its log reader is can_codec::parse_line).
    let stream = String::from_utf8(o.stdout).unwrap();
    let lines = stream.lines().count();
    assert!(lines > 100, "{lines} lines");
    for line in stream.lines() {
        can_codec::parse_line(line).unwrap_or_else(|e| panic!("{line:?}: {e}"));
    }

    // Another name of standard output (here a pipe) is standard output too.
    let o = ok(
        p,
        &[
            "events-to-candump",
            "--events",
            "sim",
            "--out",
            "/dev/stdout",
        ],
    );
    assert!(o.stdout == log, "/dev/stdout differs from --out FILE");
    assert!(text(&o.stderr).contains("wrote /dev/stdout: 6 events"));
}

#[test]
fn events_to_candump_dash_into_a_file_redirect_keeps_dev_stdout_a_link() {
    // `riskctl events-to-candump --out /dev/stdout > x.log`: standard output is a regular file.
    // It is written through the descriptor, never renamed over (which would have replaced the
    // /dev/stdout link itself).
    let d = scratch();
    let p = d.path();
    ok(
        p,
        &["events-to-candump", "--events", "sim", "--out", "d.log"],
    );
    let log = std::fs::read(p.join("d.log")).unwrap();
    for out in ["-", "/dev/stdout"] {
        let redirect = std::fs::File::create(p.join("x.log")).unwrap();
        let o = Command::new(RISKCTL)
            .current_dir(p)
            .args(["events-to-candump", "--events", "sim", "--out", out])
            .stdout(Stdio::from(redirect))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o.stderr));
        assert!(
            std::fs::read(p.join("x.log")).unwrap() == log,
            "--out {out} > x.log"
        );
        assert!(text(&o.stderr).contains("6 events"), "{}", text(&o.stderr));
    }
    if let Ok(m) = std::fs::symlink_metadata("/dev/stdout") {
        assert!(!m.is_file(), "/dev/stdout was replaced by a file");
    }
}

#[test]
fn calibrate_dash_writes_the_blob_to_standard_output_and_the_summary_to_stderr() {
    let d = scratch();
    let p = d.path();
    let calibrate = |out: &str| {
        ok(
            p,
            &[
                "calibrate",
                "--model",
                "m.rsk",
                "--normal",
                "sim",
                "--false-alarm-rate",
                "5",
                "--out",
                out,
            ],
        )
    };
    let file = calibrate("c.rsk");
    assert!(text(&file.stdout).contains("m.rsk -> c.rsk: default threshold"));
    let blob = std::fs::read(p.join("c.rsk")).unwrap();
    let before = tree(p);
    let o = calibrate("-");
    assert!(o.stdout == blob, "standard output differs from --out FILE");
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("m.rsk -> standard output: default threshold"),
        "{stderr}"
    );
    // The blob's description (inspect-model's) is part of the summary: on stderr too.
    assert!(stderr.contains("RSKM"), "{stderr}");
    assert!(!p.join("-").exists(), "a file named - was created");
    assert_eq!(tree(p), before, "files appeared or changed");
    // And the blob on standard output is one `inspect-model` reads.
    std::fs::write(p.join("piped.rsk"), &o.stdout).unwrap();
    ok(p, &["inspect-model", "piped.rsk"]);
}

/// `export-model --out -` wrote a file named `-` (and its summary on standard output), though
/// `-` is standard output for every command that writes one file; now the blob is the stream,
/// byte for byte what `--out FILE` writes, and the summary goes to stderr.
#[test]
fn export_model_dash_writes_the_blob_to_standard_output_and_the_summary_to_stderr() {
    let d = scratch();
    let p = d.path();
    std::fs::write(
        p.join("tiny.toml"),
        "[comparisons.temporal]\npairs = 100\n[comparisons.cross_sequence]\npairs = 100\n\
         [comparisons.physics]\npairs = 50\n[optimiser]\nmax_epochs = 2\n[drl]\nhidden = [8]\n",
    )
    .unwrap();
    ok(
        p,
        &[
            "train",
            "--events",
            "sim",
            "--config",
            "tiny.toml",
            "--out",
            "run",
            "--quiet",
        ],
    );
    for checkpoint in ["run/drl.json", "run/msra.json"] {
        let file = ok(p, &["export-model", checkpoint, "--out", "x.rsk"]);
        assert!(
            text(&file.stdout).contains(&format!("{checkpoint} (")),
            "{}",
            text(&file.stdout)
        );
        let blob = std::fs::read(p.join("x.rsk")).unwrap();
        let before = tree(p);
        let o = ok(p, &["export-model", checkpoint, "--out", "-"]);
        assert!(
            o.stdout == blob,
            "{checkpoint}: standard output differs from --out FILE"
        );
        let stderr = text(&o.stderr);
        assert!(
            stderr.contains(&format!("-> standard output ({} bytes)", blob.len()))
                && stderr.contains("RSKM"),
            "{stderr}"
        );
        assert!(!p.join("-").exists(), "a file named - was created");
        assert_eq!(tree(p), before, "files appeared or changed");
    }
}

/// `gssm fit --out -` (and `align`, `msra`) wrote a file named `-`, its summary on standard
/// output; the model now goes to standard output, byte for byte what `--out FILE` writes, and the
/// summary to stderr.
#[test]
fn gssm_fit_dash_writes_the_model_to_standard_output_and_the_summary_to_stderr() {
    let d = scratch();
    let p = d.path();
    let fit = |out: &str| ok(p, &["gssm", "fit", "--events", "sim", "--out", out]);
    let file = fit("g.rsk");
    assert!(
        text(&file.stdout).contains("GSSM "),
        "{}",
        text(&file.stdout)
    );
    let blob = std::fs::read(p.join("g.rsk")).unwrap();
    let before = tree(p);
    let o = fit("-");
    assert!(o.stdout == blob, "standard output differs from --out FILE");
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("GSSM ") && stderr.contains("wrote standard output"),
        "{stderr}"
    );
    assert!(!p.join("-").exists(), "a file named - was created");
    assert_eq!(tree(p), before, "files appeared or changed");
}

/// `gssm cv --out -` wrote cv.json into a file named `-` (`riskctl: wrote -`); cv.json now goes
/// to standard output, what `--out FILE` writes (but for the runs' timings), and the report to
/// stderr.
#[test]
fn gssm_cv_dash_writes_cv_json_to_standard_output_and_the_report_to_stderr() {
    let d = scratch();
    let p = d.path();
    let cv = |out: &str| {
        ok(
            p,
            &[
                "gssm", "cv", "--events", "sim", "--folds", "2", "--out", out,
            ],
        )
    };
    let file = cv("cv.json");
    let report = text(&file.stdout);
    assert!(report.contains("| Method |"), "{report}");
    let json = std::fs::read(p.join("cv.json")).unwrap();
    let before = tree(p);
    let o = cv("-");
    // The same JSON but for the runs' timings ("seconds").
    fn untimed(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.remove("seconds");
                m.values_mut().for_each(untimed);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(untimed),
            _ => {}
        }
    }
    let mut streamed: serde_json::Value = serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("standard output is no JSON ({e}):\n{}", text(&o.stdout)));
    let mut written: serde_json::Value = serde_json::from_slice(&json).unwrap();
    untimed(&mut streamed);
    untimed(&mut written);
    assert!(
        streamed == written,
        "standard output differs from --out FILE"
    );
    assert!(streamed.get("folds").is_some(), "{streamed}");
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains(&report) && stderr.contains("wrote standard output"),
        "{stderr}"
    );
    assert!(!p.join("-").exists(), "a file named - was created");
    assert_eq!(tree(p), before, "files appeared or changed");
}

#[test]
fn a_missing_parent_folder_is_created_for_files_folders_and_event_folders() {
    let d = scratch();
    let p = d.path();
    // A file output.
    ok(
        p,
        &["events-to-candump", "--events", "sim", "--out", "f/a/d.log"],
    );
    assert!(p.join("f/a/d.log").is_file());
    ok(
        p,
        &[
            "calibrate",
            "--model",
            "m.rsk",
            "--normal",
            "sim",
            "--false-alarm-rate",
            "5",
            "--out",
            "c/a/c.rsk",
        ],
    );
    assert!(p.join("c/a/c.rsk").is_file());
    // A folder output (swapped in whole).
    ok(
        p,
        &[
            "evaluate", "--model", "m.rsk", "--events", "sim", "--out", "e/a/ev",
        ],
    );
    assert!(p.join("e/a/ev").is_dir());
    // An event-folder output.
    ok(
        p,
        &[
            "simulate", "--out", "s/a/sim", "--events", "3", "--seed", "4", "--mix", "1,1,1",
        ],
    );
    for f in ["events.csv", "frames.csv"] {
        assert!(p.join("s/a/sim").join(f).is_file(), "{f}");
    }
    // No temporary or lock file is left beside any of them.
    let left: Vec<PathBuf> = tree(p)
        .into_iter()
        .filter(|f| {
            let name = f.file_name().unwrap().to_string_lossy();
            name.ends_with(".tmp") || name.ends_with(".lock")
        })
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn a_failed_run_leaves_no_folder_it_created() {
    let d = scratch();
    let p = d.path();
    let before = tree(p);
    // A file output that fails after it was opened is the output layer's unit test
    // (`file::tests::missing_parent_folders_are_made_and_removed_again_unless_committed`): the
    // commands that write one file refuse an empty folder before they open it.
    // A folder output, locked (so its parents made) before the events are read.
    let e = fails(
        p,
        &[
            "evaluate", "--model", "m.rsk", "--events", "empty", "--out", "n/a/ev",
        ],
    );
    assert!(e.contains("empty"), "{e}");
    // The demo makes its own folder first; a run that fails before writing into it removes it.
    let e = fails(
        p,
        &["demo", "--data", "empty", "--quiet", "--out", "n/a/demo"],
    );
    assert!(e.contains("empty"), "{e}");
    assert_eq!(tree(p), before, "a failed run left something");

    // A file where a folder must be made: the message names the output and the folder.
    std::fs::write(p.join("plain"), "mine").unwrap();
    let e = fails(
        p,
        &[
            "events-to-candump",
            "--events",
            "sim",
            "--out",
            "plain/x/d.log",
        ],
    );
    assert!(
        e.contains("plain/x/d.log") && e.contains("cannot create the folder plain/x"),
        "{e}"
    );
    let e = fails(
        p,
        &[
            "evaluate",
            "--model",
            "m.rsk",
            "--events",
            "sim",
            "--out",
            "plain/x/ev",
        ],
    );
    assert!(
        e.contains("--out plain/x/ev") && e.contains("plain/x"),
        "{e}"
    );
    assert_eq!(std::fs::read_to_string(p.join("plain")).unwrap(), "mine");
}

#[test]
fn an_interrupted_run_leaves_no_folder_it_created() {
    let d = scratch();
    let p = d.path();
    let before = tree(p);
    // An event folder being written into new folders (a long, streamed run). 200,000 events run
    // for minutes and ask for about 2 GB free: 2,000,000 asked for 20 GB, and on a disk with less
    // simulate refused to start, so the test failed before it could interrupt anything.
    let args = [
        "simulate", "--out", "n/a/sim", "--events", "200000", "--seed", "11",
    ];
    let mut child = Command::new(RISKCTL)
        .current_dir(p)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Interrupted once its temporaries appear (it is writing).
    let start = std::time::Instant::now();
    let writing = loop {
        let tmp = std::fs::read_dir(p.join("n/a/sim")).ok().is_some_and(|rd| {
            rd.flatten()
                .any(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        });
        if tmp || start.elapsed().as_secs() > 60 || child.try_wait().unwrap().is_some() {
            break tmp;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    assert!(writing, "never saw its temporaries: {}", text(&o.stderr));
    assert_eq!(o.status.code(), Some(130), "{}", text(&o.stderr));
    assert_eq!(tree(p), before, "an interrupted run left something");
}

#[test]
fn score_into_dev_stdout_redirected_to_a_file_writes_the_table_once() {
    // A folder that cannot be streamed: the second event's frames moved to the end, after more
    // than one batch of rows (64 Ki) of the others. `score` streams into a restartable output,
    // meets the moved event, and reads the folder whole. Standard output under another name
    // (`/dev/stdout` redirected to a file is a regular file) must not be restarted, or the batch
    // already written would stand there twice.
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    ok(
        p,
        &["simulate", "--out", "sim", "--events", "700", "--seed", "3"],
    );
    let model = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../models/msra-default.rsk");
    std::fs::copy(model, p.join("m.rsk")).unwrap();
    std::fs::create_dir(p.join("moved")).unwrap();
    std::fs::copy(p.join("sim/events.csv"), p.join("moved/events.csv")).unwrap();
    let frames = std::fs::read_to_string(p.join("sim/frames.csv")).unwrap();
    let mut lines = frames.lines();
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    assert!(
        rows.len() > 70_000,
        "{} rows: not more than one batch",
        rows.len()
    );
    let mut ids: Vec<&str> = rows.iter().map(|r| r.split(',').next().unwrap()).collect();
    ids.dedup();
    let second = ids[1];
    let (own, rest): (Vec<&str>, Vec<&str>) = rows
        .iter()
        .partition(|r| r.split(',').next() == Some(second));
    let moved = [vec![header], rest, own].concat().join("\n") + "\n";
    std::fs::write(p.join("moved/frames.csv"), moved).unwrap();

    let file = ok(
        p,
        &[
            "score", "--model", "m.rsk", "--events", "moved", "--out", "t.csv",
        ],
    );
    assert!(text(&file.stderr).contains("reading the folder whole instead"));
    let table = std::fs::read(p.join("t.csv")).unwrap();
    let redirect = std::fs::File::create(p.join("r.csv")).unwrap();
    let o = Command::new(RISKCTL)
        .current_dir(p)
        .args([
            "score",
            "--model",
            "m.rsk",
            "--events",
            "moved",
            "--out",
            "/dev/stdout",
        ])
        .stdout(Stdio::from(redirect))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    let redirected = std::fs::read(p.join("r.csv")).unwrap();
    assert!(
        redirected == table,
        "the table on redirected standard output differs from --out FILE's: {} bytes, not {}",
        redirected.len(),
        table.len()
    );
}
