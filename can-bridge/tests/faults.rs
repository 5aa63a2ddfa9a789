//! The fault suite of issue #21 for `can-bridge`: every option that writes a file (`score-log
//! --warnings-out/--events-out`, `check --decoded-events-out/--per-event-out`, `decode --out`; `monitor --out` is
//! a live capture and not here) against the matrix of riskctl's suite (the harness is shared:
//! `host-tools/tests/fault_harness`): output = each input in four spellings, a missing input, a
//! second writer, a full disk and a read-only folder (tmpfs, root only), Ctrl-C in the middle.
//! Each case asserts a non-zero exit, a message naming the file, the scratch folder byte for byte
//! as before and no temporary left. The matrix is in docs/outputs.md.
#![cfg(feature = "check")]
mod common;
#[path = "../../host-tools/tests/fault_harness/mod.rs"]
mod fault_harness;

use fault_harness::{
    ctrl_c_and_second_run, every_writer_into, missing_input, output_is_input,
    output_of_the_wrong_kind, refused, second_writer, Streams, Tmpfs, Writer,
};
use riskscore_data::candump_export::{write_candump, ExportOptions};
use riskscore_data::events::{load_events, write_events};
use std::path::{Path, PathBuf};

const BRIDGE: &str = env!("CARGO_BIN_EXE_can-bridge");

/// The inputs every scoring run names explicitly, so each can be tried as an output.
const SCORING: &str = "--model m.rsk --dbc bus.dbc --map bus.toml";

const WRITERS: &[Writer] = &[
    Writer {
        name: "score-log --warnings-out",
        args: "score-log --log drive.log --model m.rsk --dbc bus.dbc --map bus.toml --warnings-out OUT",
        out: "w.log",
        inputs: &["drive.log", "m.rsk", "bus.dbc", "bus.toml"],
        lock: "OUT",
        long: Some((
            "score-log --log long.log --model m.rsk --warnings-out OUT --events-out e.jsonl",
            Streams::Yes,
        )),
    },
    Writer {
        name: "score-log --events-out",
        args: "score-log --log drive.log --model m.rsk --dbc bus.dbc --map bus.toml --events-out OUT",
        out: "e.jsonl",
        inputs: &["drive.log", "m.rsk", "bus.dbc", "bus.toml"],
        lock: "OUT",
        long: Some((
            "score-log --log long.log --model m.rsk --events-out OUT --warnings-out w.log",
            Streams::Yes,
        )),
    },
    Writer {
        name: "check --decoded-events-out",
        args: "check --log drive.log --events sim --model m.rsk --dbc bus.dbc --map bus.toml --decoded-events-out OUT",
        out: "dec/",
        inputs: &["drive.log", "sim", "m.rsk", "bus.dbc", "bus.toml"],
        lock: "OUT/events.csv",
        long: Some((
            "check --log long.log --events long --model m.rsk --decoded-events-out OUT",
            Streams::No,
        )),
    },
    Writer {
        name: "check --per-event-out",
        args: "check --log drive.log --events sim --model m.rsk --dbc bus.dbc --map bus.toml --per-event-out OUT",
        out: "pe.jsonl",
        inputs: &["drive.log", "sim", "m.rsk", "bus.dbc", "bus.toml"],
        lock: "OUT",
        long: Some((
            "check --log long.log --events long --model m.rsk --per-event-out OUT",
            Streams::No,
        )),
    },
    Writer {
        name: "decode --out (CSV)",
        args: "decode --log drive.log --model m.rsk --dbc bus.dbc --map bus.toml --out OUT",
        out: "states.csv",
        inputs: &["drive.log", "m.rsk", "bus.dbc", "bus.toml"],
        lock: "OUT",
        long: Some(("decode --log long.log --model m.rsk --out OUT", Streams::Yes)),
    },
    Writer {
        name: "decode --out (Parquet)",
        args: "decode --log drive.log --dbc bus.dbc --map bus.toml --out OUT",
        out: "states.parquet",
        inputs: &["drive.log", "bus.dbc", "bus.toml"],
        lock: "OUT",
        long: None,
    },
];

fn repo(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// Writes `events` simulated events as the folder `dir/name` and its candump log `dir/log`.
fn event_folder_and_log(dir: &Path, name: &str, log: &str, events: usize) {
    write_events(&dir.join(name), &common::simulated_events(events, 11)).unwrap();
    let (set, issues) = load_events(&dir.join(name)).unwrap();
    assert!(issues.is_empty(), "{issues:?}");
    let file = std::fs::File::create(dir.join(log)).unwrap();
    write_candump(&set, &ExportOptions::default(), file).unwrap();
}

/// A scratch folder with the inputs (a 6-event folder `sim` and its log `drive.log`, the model,
/// the project DBC and map as files) and every writer's old output.
fn scratch() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    event_folder_and_log(p, "sim", "drive.log", 6);
    std::fs::copy(repo("../models/drl-default.rsk"), p.join("m.rsk")).unwrap();
    std::fs::copy(repo("dbc/riskscore.dbc"), p.join("bus.dbc")).unwrap();
    std::fs::copy(repo("maps/riskscore.toml"), p.join("bus.toml")).unwrap();
    assert!(SCORING
        .split_whitespace()
        .all(|a| a.starts_with("--") || p.join(a).exists()));
    for w in WRITERS {
        w.place_old_output(p);
    }
    d
}

#[test]
fn an_output_that_is_an_input_is_refused_in_every_spelling() {
    let d = scratch();
    output_is_input(BRIDGE, d.path(), WRITERS);
}

#[test]
fn a_missing_input_leaves_the_old_output_alone() {
    let d = scratch();
    missing_input(BRIDGE, d.path(), WRITERS);
}

#[test]
fn an_output_of_the_wrong_kind_is_refused() {
    let d = scratch();
    output_of_the_wrong_kind(BRIDGE, d.path(), WRITERS);
}

#[test]
fn a_second_writer_is_refused() {
    let d = scratch();
    second_writer(BRIDGE, d.path(), WRITERS);
}

#[test]
fn a_full_disk_fails_naming_the_file_and_keeps_the_old_output() {
    let d = scratch();
    every_writer_into(BRIDGE, d.path(), WRITERS, "full disk", Tmpfs::fill);
}

#[test]
fn a_read_only_target_folder_fails_naming_the_file() {
    let d = scratch();
    every_writer_into(
        BRIDGE,
        d.path(),
        WRITERS,
        "read-only folder",
        Tmpfs::make_read_only,
    );
}

#[test]
fn ctrl_c_in_the_middle_and_a_second_run_leave_the_old_output() {
    let d = scratch();
    // Long enough that a `check` run (which writes only at its end) is still working when the
    // harness signals it 300 ms after the start: 150 events took 0.34 s on a fast core, a race.
    event_folder_and_log(d.path(), "long", "long.log", 1000);
    ctrl_c_and_second_run(BRIDGE, d.path(), WRITERS);
}

#[test]
fn check_replaces_both_of_its_outputs_or_neither() {
    // `check --decoded-events-out D --per-event-out F`: when one cannot be written, the other is
    // left as it was too (before, D was swapped in and then writing F failed).
    let d = scratch();
    std::fs::create_dir(d.path().join("pe-folder")).unwrap();
    std::fs::write(d.path().join("dec-file"), "a file, not a folder\n").unwrap();
    let check = |decoded: &str, per_event: &str| -> Vec<String> {
        format!(
            "check --log drive.log --events sim --model m.rsk --decoded-events-out {decoded} --per-event-out {per_event}"
        )
        .split_whitespace()
        .map(String::from)
        .collect()
    };
    refused(BRIDGE, d.path(), &check("dec", "pe-folder"), &["pe-folder"]).unwrap();
    refused(
        BRIDGE,
        d.path(),
        &check("dec-file", "pe.jsonl"),
        &["dec-file"],
    )
    .unwrap();
}
