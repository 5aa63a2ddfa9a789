//! `--log -` is standard input in every command that reads a candump log (`replay`, `score-log`,
//! `check`, `decode`), as `-` is in riskctl: never a file named `-` (each test puts one, holding a
//! frame, in the working directory), and each command's `--help` says so. `check` and `decode`
//! (and the exported logs) need feature `check`; `replay` and `score-log` are tested without.
mod common;
#[path = "common/run.rs"]
mod run;
use run::{bridge, bridge_piped};
use std::path::Path;

/// A file named `-` in `dir` that `--log -` must not read.
fn decoy_dash_file(dir: &Path) {
    std::fs::write(dir.join("-"), "(1.000000) can0 123#00\n").unwrap();
}

/// `replay --log -` opened a file named `-` ("reading -: No such file or directory", or that
/// file's frames). It reads standard input, peeking its leading blank bytes as it does a file's:
/// an empty or blank-only log is refused before any interface is opened (also when the blank
/// lines fill more than a pipe buffer), a log with frames gets to the interface (none here: exit
/// 2 naming it).
#[test]
fn replay_reads_the_log_from_standard_input() {
    let tmp = tempfile::tempdir().unwrap();
    decoy_dash_file(tmp.path());
    let args = ["replay", "--log", "-", "--iface", "nosuchcan9"];
    for (input, blank) in [
        (b"".to_vec(), String::new()),
        (b"\n \n\r\n".to_vec(), " (3 blank lines)".to_string()),
        (vec![b'\n'; 200_000], " (200000 blank lines)".to_string()),
    ] {
        let (code, _, stderr) = bridge_piped(tmp.path(), &args, &input);
        assert_eq!(code, Some(1), "{stderr}");
        assert!(
            stderr.contains(&format!(
                "nothing was sent: standard input (--log -) holds no frames: the log is empty{blank}"
            )),
            "{stderr}"
        );
        assert!(!stderr.contains("nosuchcan9"), "{stderr}");
    }
    let (code, _, stderr) = bridge_piped(tmp.path(), &args, b"\n\n(1.000000) can0 123#00\n");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("nosuchcan9"), "{stderr}");
    assert!(!stderr.contains("reading"), "{stderr}");
    // The file named `-` is `./-`: read as a file (its frame gets to the interface).
    let file_args = ["replay", "--log", "./-", "--iface", "nosuchcan9"];
    let (code, _, stderr) = bridge_piped(tmp.path(), &file_args, b"");
    assert_eq!(code, Some(2), "{stderr}");
}

/// Every command that reads a log says in its `--help` that `--log -` is standard input.
#[test]
fn the_help_of_every_log_command_says_dash_is_standard_input() {
    let mut commands = vec!["replay", "score-log"];
    if cfg!(feature = "check") {
        commands.extend(["check", "decode"]);
    }
    for command in commands {
        let (code, help, stderr) = bridge(&[command, "--help"]);
        assert_eq!(code, Some(0), "{command}: {stderr}");
        // The option's text, up to the next option, its line breaks undone.
        let mut lines = help
            .lines()
            .skip_while(|l| !l.trim_start().starts_with("--log <LOG>"));
        let first = lines.next().expect(command);
        let rest = lines.take_while(|l| !l.trim_start().starts_with('-'));
        let log = std::iter::once(first)
            .chain(rest)
            .flat_map(str::split_whitespace)
            .collect::<Vec<_>>()
            .join(" ");
        assert!(log.contains("`-`: standard input"), "{command}: {log}");
    }
}

#[cfg(feature = "check")]
/// A simulated event folder in `dir/events`, its `riskctl events-to-candump` log (text) and a
/// model.
fn exported(dir: &Path) -> (String, String, String) {
    let set = common::simulated_events(3, 8);
    let events = dir.join("events");
    riskscore_data::events::write_events(&events, &set).unwrap();
    let mut log = Vec::new();
    riskscore_data::candump_export::write_candump(
        &set,
        &riskscore_data::candump_export::ExportOptions::default(),
        &mut log,
    )
    .unwrap();
    let model = dir.join("msra.rsk");
    std::fs::write(&model, common::msra_blob()).unwrap();
    (
        String::from_utf8(log).unwrap(),
        events.to_str().unwrap().to_string(),
        model.to_str().unwrap().to_string(),
    )
}

#[cfg(feature = "check")]
/// The offline commands' arguments for the log `log` (`-` or a path): what each writes on stdout
/// (events, the check report, the CSV state table).
fn offline_commands<'a>(log: &'a str, events: &'a str, model: &'a str) -> Vec<Vec<&'a str>> {
    let model_args = ["--model", model, "--threshold", "1.5", "--max-lost", "0.5"];
    let mut score_log = vec!["score-log", "--log", log, "--all-scores"];
    score_log.extend(model_args);
    let mut check = vec!["check", "--log", log, "--events", events, "--json"];
    check.extend(model_args);
    let mut decode = vec!["decode", "--log", log, "--out", "-"];
    decode.extend(model_args);
    vec![score_log, check, decode]
}

#[cfg(feature = "check")]
/// `score-log`, `check` and `decode` read `--log -` from a pipe as they read the file: the same
/// exit code and stdout (a file named `-` in the working directory is not read).
#[test]
fn score_log_check_and_decode_read_standard_input_as_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    decoy_dash_file(tmp.path());
    let (log, events, model) = exported(tmp.path());
    let file = tmp.path().join("sim.log");
    std::fs::write(&file, &log).unwrap();
    let from_file = offline_commands(file.to_str().unwrap(), &events, &model);
    let from_stdin = offline_commands("-", &events, &model);
    for (file_args, stdin_args) in from_file.iter().zip(&from_stdin) {
        let (code, expected, stderr) = bridge(file_args);
        assert_eq!(code, Some(0), "{file_args:?}: {stderr}");
        assert!(!expected.is_empty(), "{file_args:?}");
        let (code, stdout, stderr) = bridge_piped(tmp.path(), stdin_args, log.as_bytes());
        assert_eq!(code, Some(0), "{stdin_args:?}: {stderr}");
        assert_eq!(stdout, expected, "{stdin_args:?}");
    }
}

#[cfg(feature = "check")]
/// A bad line of a log on standard input was named `-:3:`; it is `<stdin>:3:`, as riskctl names
/// standard input, and so are a lost (late) frame's line and the loss summary. A read error names `standard input (--log -)`
/// and the line (it said `reading -: line 1: ...`).
#[test]
fn errors_in_a_log_on_standard_input_name_stdin_and_the_line() {
    let tmp = tempfile::tempdir().unwrap();
    decoy_dash_file(tmp.path());
    let (log, events, model) = exported(tmp.path());
    let mut lines: Vec<&str> = log.lines().collect();
    lines.insert(2, "not a frame");
    // The first frame again at the end: late, dropped (a lost frame, also named by its line).
    lines.push(lines[0]);
    let late = format!("<stdin>:{}: ", lines.len());
    let bad = lines.join("\n") + "\n";
    for args in offline_commands("-", &events, &model) {
        let (code, _, stderr) = bridge_piped(tmp.path(), &args, bad.as_bytes());
        assert_eq!(code, Some(0), "{args:?}: {stderr}");
        assert!(
            stderr.contains("<stdin>:3: not a candump -L frame line"),
            "{args:?}: {stderr}"
        );
        assert!(stderr.contains(&late), "{args:?}: {stderr}");
        assert!(stderr.contains("<stdin>: lost 2 of "), "{args:?}: {stderr}");
        assert!(!stderr.contains("-:3:"), "{args:?}: {stderr}");
    }
    // A "line" of 17 MiB without a line break: not a text log.
    let endless = vec![b'x'; 17 << 20];
    for args in offline_commands("-", &events, &model) {
        let (code, _, stderr) = bridge_piped(tmp.path(), &args, &endless);
        assert_eq!(code, Some(1), "{args:?}: {stderr}");
        assert!(
            stderr.contains("line 1: no line break in 16 MiB: not a text log"),
            "{args:?}: {stderr}"
        );
        if args[0] == "check" {
            assert!(stderr.contains("--log - with --events"), "{stderr}");
        } else {
            assert!(
                stderr.contains("reading standard input (--log -): line 1:"),
                "{args:?}: {stderr}"
            );
        }
    }
}
