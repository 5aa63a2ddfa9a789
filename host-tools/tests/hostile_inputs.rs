//! The hostile-input cases of issue 21 (docs: shared reliability notes, case ids in each test):
//! sizes a user sets are refused before anything is allocated, spawned or written, and inputs
//! that cannot be trusted are refused or reported, never silently rewritten.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};
mod common;
use common::{riskctl, stderr};

const PAIR_HEADER: &str = "x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j";
const PAIR: &str = "0,0,10,0,1,0,0,4.5,1.8,20,0,5,0,1,0,0,4.5,1.8";

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A failed run: exit status 1, `needle` in its message, no panic.
fn assert_refused(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(needle), "expected {needle:?} in: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

fn pair_csv(dir: &Path) -> PathBuf {
    let path = dir.join("pairs.csv");
    std::fs::write(&path, format!("{PAIR_HEADER}\n{PAIR}\n")).unwrap();
    path
}

// ---- Limits before allocation -------------------------------------------------------------

#[test]
fn ssm_threads_far_above_the_cores_are_refused_before_any_thread_starts() {
    // N78: 100,000 threads aborted with "failed to spawn thread".
    let dir = tempfile::tempdir().unwrap();
    let input = pair_csv(dir.path());
    let out = dir.path().join("o.csv");
    let o = riskctl(&["ssm", "-i", s(&input), "-o", s(&out), "--threads", "100000"]);
    assert_refused(&o, "--threads 100000: at most ");
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn simulate_refuses_event_counts_above_the_cap_at_once() {
    // N92 (1e12: a 225 GB allocation aborted) and N93 (1e18: a silent hang).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    for events in [
        "1000000000000",
        "1000000000000000000",
        "18446744073709551615",
    ] {
        let started = Instant::now();
        let o = riskctl(&["simulate", "--out", s(&out), "--events", events]);
        assert_refused(&o, &format!("--events {events}: at most 10000000"));
        assert!(started.elapsed() < Duration::from_secs(30));
        assert!(!out.exists());
    }
}

#[test]
fn simulate_refuses_a_folder_larger_than_the_free_space_before_writing() {
    // Under the cap, but 10 million events of ~15 KB do not fit in the free space of a test
    // machine's temporary folder (skipped where they would: nothing to show there).
    let dir = tempfile::tempdir().unwrap();
    let free = riskscore_free_space(dir.path());
    if free >= 10_000_000 * 10_000 {
        eprintln!("skipped: {free} bytes free, the run would fit");
        return;
    }
    let out = dir.path().join("sim");
    let o = riskctl(&["simulate", "--out", s(&out), "--events", "10000000"]);
    assert_refused(
        &o,
        "--events 10000000 needs about 100.0 GB of disk space, but only",
    );
    assert!(stderr(&o).contains("lower --events"));
    assert!(!out.exists());
}

/// Free bytes where `dir` is, as `df` sees them.
fn riskscore_free_space(dir: &Path) -> u64 {
    let o = Command::new("df")
        .args(["-B1", "--output=avail", s(dir)])
        .output()
        .expect("df");
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .nth(1)
        .and_then(|l| l.trim().parse().ok())
        .unwrap_or(u64::MAX)
}

#[test]
fn simulate_threads_far_above_the_cores_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let o = riskctl(&[
        "simulate",
        "--out",
        s(&out),
        "--events",
        "3",
        "--threads",
        "100000",
    ]);
    assert_refused(&o, "--threads 100000: at most ");
    assert!(!out.exists());
}

/// configs/train.toml with `from` (a whole line's start) replaced by `to`.
fn train_config_with(dir: &Path, name: &str, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("configs/train.toml")).unwrap();
    assert!(text.contains(from), "configs/train.toml has no {from:?}");
    let path = dir.join(name);
    std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
    path
}

#[test]
fn train_refuses_absurd_pair_counts_and_negative_weight_decay_before_training() {
    // N116: pairs = 1e12 aborted on a 16 TB allocation; N117: weight_decay = -1 trained.
    let dir = tempfile::tempdir().unwrap();
    let events = dir.path().join("sim");
    let o = riskctl(&[
        "simulate",
        "--out",
        s(&events),
        "--events",
        "6",
        "--seed",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cases = [
        (
            train_config_with(
                dir.path(),
                "pairs.toml",
                "pairs = 4000",
                "pairs = 1000000000000",
            ),
            "comparisons.temporal.pairs = 1000000000000: at most 10000000",
        ),
        (
            train_config_with(
                dir.path(),
                "wd.toml",
                // `[optimiser]`'s line (`[msra]` has a 0.0001 of its own since 2026-11-29).
                "weight_decay = 0.5 ",
                "weight_decay = -1.0 ",
            ),
            "optimiser.weight_decay = -1: must be finite and >= 0",
        ),
        (
            train_config_with(
                dir.path(),
                "epochs.toml",
                "max_epochs = 60",
                "max_epochs = 1000000000",
            ),
            "optimiser.max_epochs = 1000000000: at most 100000",
        ),
        (
            train_config_with(
                dir.path(),
                "lr.toml",
                "learning_rate = 0.003",
                "learning_rate = inf",
            ),
            "learning_rate (finite)",
        ),
    ];
    for (config, needle) in cases {
        let out = dir.path().join("model");
        let o = riskctl(&[
            "train",
            "--events",
            s(&events),
            "--config",
            s(&config),
            "--out",
            s(&out),
            "--quiet",
        ]);
        assert_refused(&o, needle);
        assert!(stderr(&o).contains(s(&config)), "{}", stderr(&o));
        assert!(!out.exists());
    }
}

// ---- import commonroad ----------------------------------------------------------------------

/// A 2020a scenario whose dynamic obstacles have these ids, 5 s of 10 m/s each, in lanes 3.7 m
/// apart (the generator of the reliability notes).
fn scenario_xml(ids: &[&str], declaration: &str, comment: &str) -> String {
    let state = |tag: &str, x0: f64, y: f64, k: usize| {
        format!(
            "<{tag}><position><point><x>{:.1}</x><y>{y}</y></point></position><orientation><exact>0</exact></orientation><time><exact>{k}</exact></time><velocity><exact>10</exact></velocity><acceleration><exact>0</exact></acceleration></{tag}>",
            x0 + k as f64
        )
    };
    let obstacles: Vec<String> = ids
        .iter()
        .enumerate()
        .map(|(n, id)| {
            let (x0, y) = (n as f64 * 12.0, if n % 2 == 1 { 3.7 } else { 0.0 });
            let states: String = (1..50).map(|k| state("state", x0, y, k)).collect();
            format!(
                "<dynamicObstacle id=\"{id}\"><type>car</type><shape><rectangle><length>4.5</length><width>1.8</width></rectangle></shape>{}<trajectory>{states}</trajectory></dynamicObstacle>",
                state("initialState", x0, y, 0)
            )
        })
        .collect();
    format!(
        "<?xml version=\"1.0\"{declaration}?>\n<!-- {comment} -->\n<commonRoad commonRoadVersion=\"2020a\" timeStepSize=\"0.1\">\n{}\n</commonRoad>\n",
        obstacles.join("\n")
    )
}

fn import(out: &Path, inputs: &[&Path]) -> Output {
    let mut args = vec!["import", "commonroad", "--out", s(out)];
    args.extend(inputs.iter().map(|p| s(p)));
    riskctl(&args)
}

#[test]
fn two_obstacles_with_one_id_are_an_error_naming_the_file_and_the_id() {
    // N5: imported with exit 0, and every event of the file was dropped later by evaluate.
    let dir = tempfile::tempdir().unwrap();
    let dup = dir.path().join("dup.xml");
    std::fs::write(&dup, scenario_xml(&["1", "2", "1"], "", "")).unwrap();
    let out = dir.path().join("ev");
    let o = import(&out, &[&dup]);
    assert_refused(
        &o,
        "dup.xml:6: <dynamicObstacle id=1>: obstacle id 1 is used again (first at line 4)",
    );
    assert!(!out.join("events.csv").exists());
    // With another good file, that one is imported and the duplicate still named.
    let good = dir.path().join("good.xml");
    std::fs::write(&good, scenario_xml(&["1", "2"], "", "")).unwrap();
    let o = import(&out, &[&dup, &good]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("obstacle id 1 is used again"),
        "{}",
        stderr(&o)
    );
    let events = std::fs::read_to_string(out.join("events.csv")).unwrap();
    assert!(
        events.lines().skip(1).all(|l| l.starts_with("good/")),
        "{events}"
    );
}

#[test]
fn a_latin1_file_that_declares_its_encoding_is_read_and_one_that_does_not_is_named() {
    // N7: a legal encoding="ISO-8859-1" declaration was refused as "not valid UTF-8".
    let dir = tempfile::tempdir().unwrap();
    let latin1 = dir.path().join("latin1.xml");
    let declared = scenario_xml(&["1", "2"], " encoding=\"ISO-8859-1\"", "Stra\u{df}e");
    let bytes: Vec<u8> = declared.chars().map(|c| u8::try_from(c).unwrap()).collect();
    assert!(std::str::from_utf8(&bytes).is_err());
    std::fs::write(&latin1, &bytes).unwrap();
    let out = dir.path().join("ev");
    let o = import(&out, &[&latin1]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("wrote 2 safe sequences"));

    let undeclared = dir.path().join("plain.xml");
    let text = scenario_xml(&["1", "2"], "", "Stra\u{df}e");
    let bytes: Vec<u8> = text.chars().map(|c| u8::try_from(c).unwrap()).collect();
    std::fs::write(&undeclared, bytes).unwrap();
    let o = import(&dir.path().join("ev2"), &[&undeclared]);
    assert_refused(
        &o,
        "plain.xml:2: not UTF-8 (invalid byte 0xDF) and no other encoding declared",
    );

    let utf16 = dir.path().join("utf16.xml");
    std::fs::write(&utf16, scenario_xml(&["1"], " encoding=\"UTF-16\"", "")).unwrap();
    let o = import(&dir.path().join("ev3"), &[&utf16]);
    assert_refused(&o, "utf16.xml:1: encoding \"UTF-16\" is not supported");
}

#[test]
fn links_back_up_the_tree_end_the_search_and_each_file_is_read_once() {
    // N15: two links to the parent made the search endless with growing memory; N14: one link
    // read the same file 41 times.
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("loop");
    std::fs::create_dir_all(root.join("d")).unwrap();
    std::fs::write(root.join("d/good.xml"), scenario_xml(&["1", "2"], "", "")).unwrap();
    std::os::unix::fs::symlink("..", root.join("d/up1")).unwrap();
    std::os::unix::fs::symlink("..", root.join("d/up2")).unwrap();
    std::os::unix::fs::symlink("good.xml", root.join("d/again.xml")).unwrap();
    let out = dir.path().join("ev");
    let started = Instant::now();
    let o = import(&out, &[&root]);
    assert!(started.elapsed() < Duration::from_secs(30));
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("read 1 scenario files"));
    assert_eq!(err.lines().count(), 3, "{err}");
    assert!(err.contains("d/up1:1: the same folder as "), "{err}");
    assert!(err.contains("d/up2:1: the same folder as "), "{err}");
    assert!(err.contains("d/good.xml:1: the same file as "), "{err}");

    // Started inside the loop: the parent is searched once, the start folder not again.
    let o = import(&dir.path().join("ev2"), &[&root.join("d")]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("read 1 scenario files"));
    assert!(!err.contains("already imported"), "{err}");
}

// ---- Parquet page checksums -------------------------------------------------------------------

fn parquet_fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/parquet")
        .join(name)
}

/// The intact fixture `good` scores its 200 rows; `flipped`, the same file with one bit of
/// `column`'s page in row group 1 flipped, is refused with that row group and column named and
/// nothing written, to CSV and to Parquet. The fixtures and the scripts that made them:
/// tests/data/parquet/.
fn assert_flipped_page_refused(good: &str, flipped: &str, column: &str) {
    let dir = tempfile::tempdir().unwrap();
    for out in ["good.csv", "good.parquet"] {
        let out = dir.path().join(out);
        let o = riskctl(&["ssm", "-i", s(&parquet_fixture(good)), "-o", s(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains("200 rows ok, 0 rows bad"));
    }
    for out in ["flipped.csv", "flipped.parquet"] {
        let out = dir.path().join(out);
        let flipped = parquet_fixture(flipped);
        let o = riskctl(&["ssm", "-i", s(&flipped), "-o", s(&out)]);
        assert_refused(
            &o,
            &format!(
                "{}: row group 1 (counting from 0), column {column}: a page's CRC-32 checksum \
                 does not match its bytes",
                flipped.display()
            ),
        );
        assert!(!out.exists());
    }
}

#[test]
fn a_flipped_bit_in_a_checksummed_parquet_page_is_an_error_naming_file_row_group_and_column() {
    // N60: x_j of three rows was read as 42.0078125 instead of 42 and scored, exit 0.
    assert_flipped_page_refused("crc.parquet", "crc_flipped.parquet", "x_j");
}

#[test]
fn a_flipped_bit_in_a_copied_text_column_is_an_error_naming_row_group_and_column() {
    // Parquet -> Parquet copies the `id` column's pages without decoding them: their checksums
    // are verified all the same. Parquet -> CSV decodes it.
    assert_flipped_page_refused("crc_text.parquet", "crc_text_flipped.parquet", "id");
}

// ---- Bytes that are not UTF-8 -------------------------------------------------------------------

#[test]
fn a_non_utf8_header_name_is_kept_byte_for_byte_in_csv_and_refused_for_parquet() {
    // D8-d: the header `n\xf6te` came out as `n\u{FFFD}te` without a word.
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("nh.csv");
    let mut bytes = format!("{PAIR_HEADER}, n").into_bytes();
    bytes.extend_from_slice(b"\xf6te ,\"a\xff,b\"\n");
    bytes.extend_from_slice(format!("{PAIR},x,y\n").as_bytes());
    std::fs::write(&input, &bytes).unwrap();
    let out = dir.path().join("o.csv");
    let o = riskctl(&["ssm", "-i", s(&input), "-o", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let written = std::fs::read(&out).unwrap();
    let header = written.split(|&b| b == b'\n').next().unwrap();
    let mut expected = format!("{PAIR_HEADER},n").into_bytes();
    expected.extend_from_slice(b"\xf6te,\"a\xff,b\",box_distance,");
    assert!(
        header.starts_with(&expected),
        "{}",
        String::from_utf8_lossy(header)
    );

    let parquet = dir.path().join("o.parquet");
    let o = riskctl(&["ssm", "-i", s(&input), "-o", s(&parquet)]);
    assert_refused(&o, "header, column 19: name \"n\\xF6te\" is not UTF-8");
    assert!(!parquet.exists());
}

#[test]
fn a_non_utf8_pass_through_value_is_reported_with_its_line_when_parquet_cannot_hold_it() {
    // N63: `caf\xe9` became `caf\u{FFFD}` in the Parquet output, exit 0, no message.
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("n.csv");
    let mut bytes = format!("{PAIR_HEADER},note\n{PAIR},caf").into_bytes();
    bytes.extend_from_slice(b"\xe9\n");
    bytes.extend_from_slice(format!("{PAIR},ok\n").as_bytes());
    std::fs::write(&input, &bytes).unwrap();
    let parquet = dir.path().join("o.parquet");
    let o = riskctl(&["ssm", "-i", s(&input), "-o", s(&parquet)]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("n.csv: line 2, column note: text \"caf\\xE9\" is not UTF-8"),
        "{err}"
    );
    assert!(err.contains("1 rows ok, 1 rows bad"), "{err}");
    // Back to CSV: only the good row, and no replacement character anywhere.
    let back = dir.path().join("back.csv");
    let o = riskctl(&["ssm", "-i", s(&parquet), "-o", s(&back)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&back).unwrap();
    assert_eq!(text.lines().count(), 2, "{text}");
    assert!(!text.contains('\u{FFFD}'));

    let o = riskctl(&["ssm", "-i", s(&input), "-o", s(&parquet), "--strict"]);
    assert_refused(&o, "line 2, column note: text \"caf\\xE9\" is not UTF-8");
    // CSV output keeps the bytes as they are.
    let csv = dir.path().join("o.csv");
    let o = riskctl(&["ssm", "-i", s(&input), "-o", s(&csv)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(&csv)
        .unwrap()
        .windows(5)
        .any(|w| w == b",caf\xe9"));
}

#[test]
fn ssm_output_that_is_a_folder_is_refused_before_any_input_is_read() {
    // N73: refused only after the whole input was processed, leaving `outdir.partial` behind.
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("bad.csv");
    std::fs::write(&input, format!("{PAIR_HEADER}\n{PAIR}\n0,zz\n")).unwrap();
    let folder = dir.path().join("outdir");
    std::fs::create_dir(&folder).unwrap();
    for output in [folder.clone(), dir.path().join("outdir.parquet")] {
        std::fs::create_dir_all(&output).unwrap();
        let o = riskctl(&["ssm", "-i", s(&input), "-o", s(&output)]);
        assert_refused(&o, "is a folder, not a file");
        // The bad row was never reached.
        assert!(!stderr(&o).contains("row skipped"), "{}", stderr(&o));
        assert_eq!(std::fs::read_dir(&output).unwrap().count(), 0);
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3);
}

#[test]
fn ssm_line_limit_above_its_cap_is_refused_before_reading() {
    // A limit of 100 GB let /dev/zero (no line break) grow the process without bound.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.csv");
    let o = riskctl(&[
        "ssm",
        "-i",
        "/dev/zero",
        "-o",
        s(&out),
        "--max-line-bytes",
        "100000000000",
    ]);
    assert_refused(&o, "--max-line-bytes 100000000000: at most 1073741824");
    assert!(!out.exists());
}

// ---- Nothing to write, outputs inside input folders (verification of 2026-11-26) -----------

/// `dir/ev`: an event folder imported from a good two-car scenario.
fn imported_folder(dir: &Path) -> PathBuf {
    let good = dir.join("good.xml");
    std::fs::write(&good, scenario_xml(&["1", "2"], "", "")).unwrap();
    let ev = dir.join("ev");
    assert!(import(&ev, &[&good]).status.success());
    ev
}

fn read_all(paths: &[PathBuf]) -> Vec<Vec<u8>> {
    paths.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

#[test]
fn a_run_with_nothing_to_write_leaves_every_old_output_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ev = imported_folder(d);
    let ev_files = vec![ev.join("events.csv"), ev.join("frames.csv")];
    let before = read_all(&ev_files);

    // A readable scenario without a single road-user pair: the folder was emptied, exit 0.
    let empty = d.join("noroad.xml");
    std::fs::write(&empty, scenario_xml(&[], "", "")).unwrap();
    let o = import(&ev, &[&empty]);
    assert_refused(
        &o,
        "no safe sequence found in 1 scenario files: nothing written, ",
    );
    assert!(stderr(&o).contains("ev left as it was"), "{}", stderr(&o));
    assert_eq!(read_all(&ev_files), before);
    // Into a folder that does not exist yet: none is made.
    let fresh = d.join("new/deeper");
    assert_refused(&import(&fresh, &[&empty]), "deeper not created");
    assert!(!d.join("new").exists());

    // An event folder with no event: the old log stays.
    let hollow = d.join("hollow");
    std::fs::create_dir(&hollow).unwrap();
    for (file, content) in ev_files.iter().zip(&before) {
        let header = content.split(|&b| b == b'\n').next().unwrap();
        let mut line = header.to_vec();
        line.push(b'\n');
        std::fs::write(hollow.join(file.file_name().unwrap()), line).unwrap();
    }
    let log = d.join("old.log");
    std::fs::write(&log, "old log\n").unwrap();
    let o = riskctl(&[
        "events-to-candump",
        "--events",
        s(&hollow),
        "--out",
        s(&log),
    ]);
    assert_refused(&o, "no event in ");
    assert_eq!(std::fs::read_to_string(&log).unwrap(), "old log\n");

    // Pairs whose every row is bad: the old table stays (the rows are reported).
    let bad = d.join("bad.csv");
    std::fs::write(
        &bad,
        format!("{PAIR_HEADER}\n{}\n", PAIR.replace("10", "x")),
    )
    .unwrap();
    let table = d.join("old.csv");
    std::fs::write(&table, "old table\n").unwrap();
    let o = riskctl(&["ssm", "-i", s(&bad), "-o", s(&table)]);
    assert_refused(&o, "(1 bad rows): nothing written, ");
    assert_eq!(std::fs::read_to_string(&table).unwrap(), "old table\n");
    let o = riskctl(&["ssm", "-i", s(&bad), "-o", s(&d.join("t.parquet"))]);
    assert_refused(&o, "t.parquet not created");
    assert!(!d.join("t.parquet").exists());
}

#[test]
fn an_output_inside_an_input_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ev = imported_folder(d);
    // A file of the folder that the command does not read belongs to the user as well.
    let mine = ev.join("scenarios.csv");
    std::fs::write(&mine, "mine\n").unwrap();
    let model = repo().join("models/msra-default.rsk");
    let o = riskctl(&[
        "score",
        "--model",
        s(&model),
        "--events",
        s(&ev),
        "--out",
        s(&mine),
    ]);
    assert_refused(&o, "lies inside --events");
    let o = riskctl(&[
        "events-to-candump",
        "--events",
        s(&ev),
        "--out",
        s(&ev.join("drive.log")),
    ]);
    assert_refused(&o, "lies inside --events");
    assert_eq!(std::fs::read_to_string(&mine).unwrap(), "mine\n");
    assert!(!ev.join("drive.log").exists());
}

#[test]
fn an_endless_header_line_ends_the_run_at_once() {
    // D7-a: `ssm --input /dev/zero` kept reading (bounded memory) until killed.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.csv");
    let started = Instant::now();
    let o = riskctl(&["ssm", "--input", "/dev/zero", "--output", s(&out)]);
    assert_refused(
        &o,
        "header (line 1): line longer than 1048576 bytes; no row can be read",
    );
    assert!(started.elapsed() < Duration::from_secs(30));
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
