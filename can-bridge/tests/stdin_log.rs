#![cfg(feature = "check")]
//! `--log -` is standard input in every command that reads a candump log (`replay`, `score-log`,
//! `check`, `decode`), as `-` is in riskctl: never a file named `-` (each test puts one, holding a
//! frame, in the working directory), and each command's `--help` says so.
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
    for command in ["replay", "score-log", "check", "decode"] {
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
