//! Ctrl-C (SIGINT) and SIGTERM in the middle of `riskctl benchmark domains`, `benchmark
//! transfer`, `demo` and `ablation`: the run stops within seconds with 130 / 143, and an --out
//! folder (and a --sequences-out file) that a previous run left stays byte for byte as it was,
//! with no temporary, lock file or new folder left behind. These commands simulate their event
//! folders into --out before they train: an interrupted run must not have replaced them. A run
//! that fails at its report (the last output) leaves --sequences-out and the simulated folders
//! as they were too.
use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod fault_harness;
use fault_harness::Stop;

const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

/// How long a run may take to stop after the signal.
const STOP_WITHIN: Duration = Duration::from_secs(20);

/// Every file and folder under `dir` (hidden ones included): path -> contents (None: a folder).
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    fn walk(root: &Path, dir: &Path, into: &mut BTreeMap<PathBuf, Option<Vec<u8>>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let path = e.unwrap().path();
            let rel = path.strip_prefix(root).unwrap().to_path_buf();
            if path.is_dir() {
                into.insert(rel, None);
                walk(root, &path, into);
            } else {
                into.insert(rel, Some(std::fs::read(&path).unwrap()));
            }
        }
    }
    let mut map = BTreeMap::new();
    walk(dir, dir, &mut map);
    map
}

/// A [`snapshot`] of before and after the run: nothing may have changed or been left (`run`:
/// "interrupted", "failed").
fn assert_unchanged(
    before: &BTreeMap<PathBuf, Option<Vec<u8>>>,
    after: &BTreeMap<PathBuf, Option<Vec<u8>>>,
    run: &str,
    stderr: &str,
) {
    let changed: BTreeSet<&PathBuf> = (before.keys().chain(after.keys()))
        .filter(|k| before.get(*k) != after.get(*k))
        .collect();
    assert!(
        changed.is_empty(),
        "the {run} run changed or left {changed:?}; stderr: {stderr}"
    );
}

/// The simulated folders of the benchmarks under --out.
const BENCHMARK_FOLDERS: &[&str] = &["train-data", "test-data"];

/// What an old simulated folder `folder` (e.g. `domains-data/test`, named by its last part)
/// holds in `file` (`events`, `frames`, `scenarios`).
fn old_text(folder: &str, file: &str) -> String {
    let name = Path::new(folder).file_name().unwrap().to_string_lossy();
    format!("old {name} {file}\n")
}

/// The --out folder (its simulated `folders`, a report) and --sequences-out file a previous run
/// left, plus a note of the user's.
fn old_output(p: &Path, folders: &[&str]) {
    let mut files: Vec<(String, String)> = folders
        .iter()
        .flat_map(|f| {
            ["events", "frames", "scenarios"]
                .map(|file| (format!("out/{f}/{file}.csv"), old_text(f, file)))
        })
        .collect();
    for (file, text) in [
        ("out/report/results.md", "old report\n"),
        ("out/notes.txt", "mine\n"),
        ("sequences.csv", "old per-sequence table\n"),
    ] {
        files.push((file.into(), text.into()));
    }
    for (file, text) in files {
        let path = p.join(file);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
}

/// Kills `child` for good (the run ignored the signal) and fails with `why`.
fn kill_and_fail(mut child: Child, why: String) -> ! {
    let _ = child.kill();
    let _ = child.wait();
    panic!("{why}");
}

/// Whether `file` of the folder `folder` has been written: complete in the staged folder beside
/// it (`.NAME.*.tmp`), or (a run that writes in place) in `folder` itself with other contents than
/// `old`.
fn written(folder: &Path, file: &str, old: &str) -> bool {
    let name = folder.file_name().unwrap().to_string_lossy().into_owned();
    let Ok(entries) = std::fs::read_dir(folder.parent().unwrap()) else {
        return false;
    };
    entries.flatten().any(|e| {
        let entry = e.file_name().to_string_lossy().into_owned();
        let staged = entry.starts_with(&format!(".{name}.")) && entry.ends_with(".tmp");
        let path = e.path().join(file);
        (staged && path.is_file())
            || (entry == name && std::fs::read(&path).is_ok_and(|b| b != old.as_bytes()))
    })
}

/// Whether the folder `folder` (e.g. `out/test-data`) has been simulated: its `events.csv` is
/// [`written`].
fn simulated(folder: &Path) -> bool {
    let name = folder.file_name().unwrap().to_string_lossy();
    written(folder, "events.csv", &old_text(&name, "events"))
}

/// Runs riskctl `args` in `p` over the old output (its simulated `folders` under `out/`), sends
/// `stop` once it is working (the last folder it simulates, `last`, is complete: loading and
/// training follow), and checks the exit, the time to stop and the folder.
fn interrupted_in_training(p: &Path, args: &[String], folders: &[&str], last: &str, stop: Stop) {
    old_output(p, folders);
    let before = snapshot(p);
    let stderr = stopped_once_simulated(p, args, last, stop);
    let after = snapshot(p);
    assert_unchanged(&before, &after, "interrupted", &stderr);
    assert!(
        stderr.contains(&format!("out/{}", folders[0])) && stderr.contains("left as it was"),
        "the message does not name the simulated folder it left alone: {stderr}"
    );
}

/// Runs riskctl `args` in `p`, sends `stop` once `last` is simulated (plus 0.5 s) and checks that
/// the run stops within [`STOP_WITHIN`] with the signal's status and message. Returns its stderr.
fn stopped_once_simulated(p: &Path, args: &[String], last: &str, stop: Stop) -> String {
    let ready = |_: &str| simulated(&p.join(last));
    stopped_once(p, args, &format!("simulated {last}"), ready, 500, stop)
}

/// Runs riskctl `args` in `p`, sends `stop` `settle_ms` after `ready` (given the stderr so far)
/// holds (`what` names it) and checks that the run stops within [`STOP_WITHIN`] with the signal's
/// status and message. Returns its stderr.
fn stopped_once(
    p: &Path,
    args: &[String],
    what: &str,
    ready: impl Fn(&str) -> bool,
    settle_ms: u64,
    stop: Stop,
) -> String {
    let mut child = Command::new(RISKCTL)
        .current_dir(p)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let so_far = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let shared = std::sync::Arc::clone(&so_far);
    let reader = std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let mut all = shared.lock().unwrap();
            all.push_str(&line);
            all.push('\n');
        }
        shared.lock().unwrap().clone()
    });
    let start = Instant::now();
    while !ready(&so_far.lock().unwrap().clone()) {
        if let Some(status) = child.try_wait().unwrap() {
            let all = reader.join().unwrap();
            panic!("the run ended ({status}) before it {what}: {all}");
        }
        if start.elapsed() > Duration::from_secs(120) {
            kill_and_fail(child, format!("not {what} within 120 s"));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(settle_ms));
    if let Some(status) = child.try_wait().unwrap() {
        let all = reader.join().unwrap();
        panic!("the run ended ({status}) before the signal: {all}");
    }
    fault_harness::send(&child, stop);
    let signalled = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if signalled.elapsed() > STOP_WITHIN {
            kill_and_fail(
                child,
                format!(
                    "SIG{} ignored: still running {STOP_WITHIN:?} later",
                    stop.name()
                ),
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let stderr = reader.join().unwrap();
    assert_eq!(
        status.code(),
        Some(stop.exit_code()),
        "SIG{}: {status}; stderr: {stderr}",
        stop.name()
    );
    assert!(
        stderr.contains(&format!("interrupted (SIG{})", stop.name())),
        "{stderr}"
    );
    stderr
}

/// A small but real run: default training, 2 folds, 2 seeds (`domains`: 90 events per simulated
/// folder, several rounds; `transfer`, one round: 310 events), about 15 s in a debug build.
fn small(mode: &str) -> [&'static str; 8] {
    let events = if mode == "domains" { "90" } else { "310" };
    [
        "--events", events, "--folds", "2", "--seeds", "2", "--out", "out",
    ]
}

/// `riskctl benchmark <mode>` on [`small`] and `extra`.
fn benchmark(mode: &str, extra: &[&str]) -> Vec<String> {
    (["benchmark", mode].iter().chain(&small(mode)).chain(extra))
        .map(|s| s.to_string())
        .collect()
}

#[test]
fn ctrl_c_stops_benchmark_domains_and_leaves_the_old_out_and_sequences_out() {
    let d = tempfile::tempdir().unwrap();
    let args = benchmark("domains", &["--sequences-out", "sequences.csv"]);
    let last = "out/test-data";
    interrupted_in_training(d.path(), &args, BENCHMARK_FOLDERS, last, Stop::Int);
}

#[test]
fn sigterm_stops_benchmark_domains_over_two_draws_and_leaves_the_old_out() {
    let d = tempfile::tempdir().unwrap();
    let args = benchmark("domains", &["--draws", "2"]);
    let last = "out/draw-2/test-data";
    interrupted_in_training(d.path(), &args, BENCHMARK_FOLDERS, last, Stop::Term);
}

#[test]
fn ctrl_c_stops_benchmark_transfer_and_leaves_the_old_out() {
    let d = tempfile::tempdir().unwrap();
    let args = benchmark("transfer", &[]);
    let last = "out/test-data";
    interrupted_in_training(d.path(), &args, BENCHMARK_FOLDERS, last, Stop::Int);
}

#[test]
fn sigterm_stops_benchmark_transfer_and_leaves_the_old_out() {
    let d = tempfile::tempdir().unwrap();
    let args = benchmark("transfer", &[]);
    let last = "out/test-data";
    interrupted_in_training(d.path(), &args, BENCHMARK_FOLDERS, last, Stop::Term);
}

/// `riskctl demo`, small (about 4 s in a debug build): 200 simulated events and 60 training-only
/// ones (`data/`, `extra-data/`), 2 folds x 2 seeds, no real data (so no transfer or domain
/// benchmark).
fn demo() -> Vec<String> {
    [
        "demo",
        "--events",
        "200",
        "--extra-events",
        "60",
        "--folds",
        "2",
        "--seeds",
        "2",
        "--no-real",
        "--quiet",
        "--out",
        "out",
    ]
    .map(String::from)
    .to_vec()
}

#[test]
fn ctrl_c_stops_demo_and_leaves_the_old_data_and_extra_data() {
    // Before, `data/` and `extra-data/` were simulated in place: the interrupted run left the
    // new run's events beside the old report.
    let d = tempfile::tempdir().unwrap();
    let folders = ["data", "extra-data"];
    interrupted_in_training(d.path(), &demo(), &folders, "out/extra-data", Stop::Int);
}

#[test]
fn sigterm_stops_demo_and_leaves_the_old_data_and_extra_data() {
    let d = tempfile::tempdir().unwrap();
    let folders = ["data", "extra-data"];
    interrupted_in_training(d.path(), &demo(), &folders, "out/extra-data", Stop::Term);
}

/// The demo's benchmark stages over an old --out: the run is stopped by `stop` once `last` (under
/// `out/`) is simulated, in the middle of the benchmark. The benchmark's own folders and report
/// must be the old ones (every folder of the demo goes in at the end, together), and no temporary
/// is left anywhere.
fn demo_interrupted_in_a_benchmark(last: &str, kept: &[&str], stop: Stop) {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let folders = ["transfer-data", "domains-data/train", "domains-data/test"];
    old_output(p, &folders);
    for (file, text) in [
        ("out/report/transfer/results.md", "old transfer report\n"),
        ("out/report/domains/domains.md", "old domain report\n"),
    ] {
        std::fs::create_dir_all(p.join(file).parent().unwrap()).unwrap();
        std::fs::write(p.join(file), text).unwrap();
    }
    let under = |snap: BTreeMap<PathBuf, Option<Vec<u8>>>| -> BTreeMap<_, _> {
        snap.into_iter()
            .filter(|(k, _)| {
                kept.iter()
                    .any(|dir| k.starts_with(Path::new("out").join(dir)))
            })
            .collect()
    };
    let before = under(snapshot(p));
    // The real freeway extract is the default --real: the transfer and domain benchmarks run.
    let args = [
        "demo",
        "--events",
        "100",
        "--no-extra",
        "--folds",
        "2",
        "--seeds",
        "1",
        "--quiet",
        "--out",
        "out",
    ]
    .map(String::from);
    let stderr = stopped_once_simulated(p, &args, &format!("out/{last}"), stop);
    let all = snapshot(p);
    let hidden: Vec<&PathBuf> = (all.keys())
        .filter(|k| k.iter().any(|c| c.to_string_lossy().starts_with('.')))
        .collect();
    assert!(hidden.is_empty(), "temporaries left: {hidden:?}; {stderr}");
    let after = under(all);
    assert_unchanged(&before, &after, "interrupted", &stderr);
    assert!(
        stderr.contains(&format!("out/{last}")) && stderr.contains("left as it was"),
        "the message does not name the simulated folder it left alone: {stderr}"
    );
}

#[test]
fn ctrl_c_in_demo_s_domain_benchmark_leaves_the_old_domains_data() {
    let kept = ["domains-data", "report/domains"];
    demo_interrupted_in_a_benchmark("domains-data/test", &kept, Stop::Int);
}

#[test]
fn sigterm_in_demo_s_transfer_benchmark_leaves_the_old_transfer_and_domains_data() {
    let kept = [
        "transfer-data",
        "report/transfer",
        "domains-data",
        "report/domains",
    ];
    demo_interrupted_in_a_benchmark("transfer-data", &kept, Stop::Term);
}

#[test]
fn sigterm_in_demo_s_final_models_leaves_every_old_folder() {
    // Stopped once its report is written, as the final models train: before, the report and the
    // simulated data/ and extra-data/ had gone in place beside the old models/ and plots/.
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    old_output(p, &["data", "extra-data"]);
    for (file, text) in [
        ("out/models/drl.rsk", "old model\n"),
        ("out/plots/roc.svg", "old figure\n"),
    ] {
        std::fs::create_dir_all(p.join(file).parent().unwrap()).unwrap();
        std::fs::write(p.join(file), text).unwrap();
    }
    let before = snapshot(p);
    // Its report written and its final models begun: before, both had gone in place by then.
    let report = p.join("out/report");
    let ready =
        |stderr: &str| written(&report, "results.md", "old report\n") && stderr.contains("[4/6]");
    let stderr = stopped_once(p, &demo(), "began its final models", ready, 0, Stop::Term);
    let after = snapshot(p);
    assert_unchanged(&before, &after, "interrupted", &stderr);
}

/// `riskctl ablation`, small (about 3 s in a debug build): the default simulated set into
/// `data/`, two sources, one fraction, 3 folds.
fn ablation() -> Vec<String> {
    [
        "ablation",
        "--sources",
        "temporal,physics",
        "--fractions",
        "0.5",
        "--folds",
        "3",
        "--quiet",
        "--out",
        "out",
    ]
    .map(String::from)
    .to_vec()
}

#[test]
fn ctrl_c_stops_ablation_and_leaves_the_old_data() {
    // Before, `data/` was simulated in place: the interrupted run left the new run's events
    // beside the old tables.
    let d = tempfile::tempdir().unwrap();
    interrupted_in_training(d.path(), &ablation(), &["data"], "out/data", Stop::Int);
}

#[test]
fn sigterm_stops_ablation_and_leaves_the_old_data() {
    let d = tempfile::tempdir().unwrap();
    interrupted_in_training(d.path(), &ablation(), &["data"], "out/data", Stop::Term);
}

/// Runs riskctl `args` in `p` (the old output there, `report` its last output and in the way):
/// the run must fail (exit 1) naming `report` and leave everything byte for byte as it was.
/// Returns the message.
fn failed_at(p: &Path, args: &[String], report: &str) -> String {
    let before = snapshot(p);
    let o = Command::new(RISKCTL)
        .current_dir(p)
        .args(args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(report), "{stderr}");
    let after = snapshot(p);
    assert_unchanged(&before, &after, "failed", &stderr);
    stderr.into_owned()
}

#[test]
fn a_run_that_fails_at_its_report_leaves_the_old_sequences_out_and_simulated_folders() {
    // The report is written last and fails here (out/report is a file): the per-sequence table
    // and the simulated folders, complete by then, must not have been put in place before it.
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    old_output(p, BENCHMARK_FOLDERS);
    std::fs::remove_dir_all(p.join("out/report")).unwrap();
    std::fs::write(p.join("out/report"), "not a folder\n").unwrap();
    let mut args = benchmark("domains", &["--sequences-out", "sequences.csv"]);
    args.extend(["--rounds", "speed-5-15", "--quiet"].map(String::from));
    failed_at(p, &args, "out/report");
}

/// [`demo`] with `extra` arguments over an old --out (its `data/` and `extra-data/`), after
/// `fault` has set up the test folder: it must fail naming `names` and change nothing.
fn demo_fails(fault: impl FnOnce(&Path), extra: &[&str], names: &str) -> String {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    old_output(p, &["data", "extra-data"]);
    fault(p);
    let mut args = demo();
    args.extend(extra.iter().map(|a| a.to_string()));
    failed_at(p, &args, names)
}

#[test]
fn a_demo_whose_report_is_a_file_is_refused_and_leaves_the_old_data_and_extra_data() {
    // out/report is a file: the run fails at its start, where it stages its folders (before,
    // after cross-validation, and the data/ and extra-data/ simulated by then must not have gone
    // in place).
    let report_a_file = |p: &Path| {
        std::fs::remove_dir_all(p.join("out/report")).unwrap();
        std::fs::write(p.join("out/report"), "not a folder\n").unwrap();
    };
    let stderr = demo_fails(report_a_file, &[], "out/report exists and is not a folder");
    // Named once: the demo's error no longer repeats the path the output layer's names.
    assert_eq!(stderr.matches("out/report").count(), 1, "{stderr}");
}

#[test]
fn a_demo_whose_transfer_data_is_a_file_is_refused_before_it_simulates() {
    // transfer-data/ is simulated after the cross-validation; a file in its place was found
    // only then. It is checked at the start now, with report/, models/ and plots/.
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    old_output(p, &["data", "extra-data"]);
    std::fs::write(p.join("out/transfer-data"), "not a folder\n").unwrap();
    let args: Vec<String> = demo()
        .into_iter()
        .map(|a| {
            if a == "--no-real" {
                "--real=real".into()
            } else {
                a
            }
        })
        .collect();
    let stderr = failed_at(p, &args, "out/transfer-data exists and is not a folder");
    assert!(!stderr.contains("[1/6]"), "the run started: {stderr}");
}

#[test]
fn a_demo_that_fails_after_simulating_leaves_every_old_folder() {
    // Its DRL-only folder does not load, after data/ and extra-data/ are simulated and staged
    // (report/, models/ and plots/ too): nothing may change, no temporary or folder be left.
    let bad_drl_only = |p: &Path| {
        std::fs::create_dir_all(p.join("bad")).unwrap();
        std::fs::write(p.join("bad/events.csv"), "not,an,event,folder\n").unwrap();
    };
    demo_fails(bad_drl_only, &["--extra-drl-only", "bad"], "bad");
}

#[test]
fn an_ablation_that_fails_at_its_tables_leaves_the_old_data() {
    // out/ablation.md is a folder: the tables, written last, fail; data/ stays the old one.
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    old_output(p, &["data"]);
    std::fs::create_dir_all(p.join("out/ablation.md")).unwrap();
    std::fs::write(p.join("out/ablation.md/mine.txt"), "in the way\n").unwrap();
    let mut args = ablation();
    args.extend(["--models", "msra"].map(String::from));
    failed_at(p, &args, "out/ablation.md");
}
