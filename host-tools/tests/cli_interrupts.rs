//! Ctrl-C (SIGINT) and SIGTERM in the middle of `riskctl benchmark domains` and `benchmark
//! transfer`: the run stops within seconds with 130 / 143, and an --out folder (and a
//! --sequences-out file) that a previous run left stays byte for byte as it was, with no
//! temporary, lock file or new folder left behind. The benchmarks simulate their training and
//! test folders into --out before they train: an interrupted run must not have replaced them.
//! A run that fails at its report (the last output) leaves --sequences-out and the simulated
//! folders as they were too.
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

/// The --out folder and --sequences-out file a previous run left, plus a note of the user's.
fn old_output(p: &Path) {
    for (file, text) in [
        ("out/train-data/events.csv", "old training events\n"),
        ("out/train-data/frames.csv", "old training frames\n"),
        ("out/train-data/scenarios.csv", "old training scenarios\n"),
        ("out/test-data/events.csv", "old test events\n"),
        ("out/test-data/frames.csv", "old test frames\n"),
        ("out/test-data/scenarios.csv", "old test scenarios\n"),
        ("out/report/results.md", "old report\n"),
        ("out/notes.txt", "mine\n"),
        ("sequences.csv", "old per-sequence table\n"),
    ] {
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

/// Whether the test folder under `dir` has been simulated: its `events.csv` is complete, in the
/// staged folder beside `test-data` or (a run that writes in place) in `test-data` itself.
fn test_data_simulated(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return false;
    };
    entries.flatten().any(|e| {
        let name = e.file_name().to_string_lossy().into_owned();
        let staged = name.starts_with(".test-data.") && name.ends_with(".tmp");
        let events = e.path().join("events.csv");
        (staged && events.is_file())
            || (name == "test-data"
                && std::fs::read(&events).is_ok_and(|b| b != b"old test events\n"))
    })
}

/// Runs riskctl `args` in `p` over the old output, sends `stop` once it is working (the last
/// test folder, under `last_draw`, simulated: loading and training follow), and checks the exit,
/// the time to stop and the folder.
fn interrupted_in_training(p: &Path, args: &[String], last_draw: &str, stop: Stop) {
    old_output(p);
    let before = snapshot(p);
    let mut child = Command::new(RISKCTL)
        .current_dir(p)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    let start = Instant::now();
    while !test_data_simulated(&p.join(last_draw)) {
        if let Some(status) = child.try_wait().unwrap() {
            let all = reader.join().unwrap();
            panic!("the run ended ({status}) before it simulated its test folder: {all}");
        }
        if start.elapsed() > Duration::from_secs(120) {
            kill_and_fail(child, "no simulated test folder within 120 s".into());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    let kill = Command::new("kill")
        .args([&format!("-{}", stop.name()), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
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
    let after = snapshot(p);
    let changed: BTreeSet<&PathBuf> = (before.keys().chain(after.keys()))
        .filter(|k| before.get(*k) != after.get(*k))
        .collect();
    assert!(
        changed.is_empty(),
        "the interrupted run changed or left {changed:?}; stderr: {stderr}"
    );
    assert!(
        stderr.contains("out/train-data") && stderr.contains("left as it was"),
        "the message does not name the simulated folder it left alone: {stderr}"
    );
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
    interrupted_in_training(d.path(), &args, "out", Stop::Int);
}

#[test]
fn sigterm_stops_benchmark_domains_over_two_draws_and_leaves_the_old_out() {
    let d = tempfile::tempdir().unwrap();
    let args = benchmark("domains", &["--draws", "2"]);
    interrupted_in_training(d.path(), &args, "out/draw-2", Stop::Term);
}

#[test]
fn ctrl_c_stops_benchmark_transfer_and_leaves_the_old_out() {
    let d = tempfile::tempdir().unwrap();
    let args = benchmark("transfer", &[]);
    interrupted_in_training(d.path(), &args, "out", Stop::Int);
}

#[test]
fn sigterm_stops_benchmark_transfer_and_leaves_the_old_out() {
    let d = tempfile::tempdir().unwrap();
    let args = benchmark("transfer", &[]);
    interrupted_in_training(d.path(), &args, "out", Stop::Term);
}

#[test]
fn a_run_that_fails_at_its_report_leaves_the_old_sequences_out_and_simulated_folders() {
    // The report is written last and fails here (out/report is a file): the per-sequence table
    // and the simulated folders, complete by then, must not have been put in place before it.
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    old_output(p);
    std::fs::remove_dir_all(p.join("out/report")).unwrap();
    std::fs::write(p.join("out/report"), "not a folder\n").unwrap();
    let before = snapshot(p);
    let mut args = benchmark("domains", &["--sequences-out", "sequences.csv"]);
    args.extend(["--rounds", "speed-5-15", "--quiet"].map(String::from));
    let o = Command::new(RISKCTL)
        .current_dir(p)
        .args(&args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("out/report"), "{stderr}");
    let after = snapshot(p);
    let changed: BTreeSet<&PathBuf> = (before.keys().chain(after.keys()))
        .filter(|k| before.get(*k) != after.get(*k))
        .collect();
    assert!(
        changed.is_empty(),
        "the failed run changed or left {changed:?}; stderr: {stderr}"
    );
}
