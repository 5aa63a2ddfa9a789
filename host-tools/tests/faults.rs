//! The fault suite of issue #21 for `riskctl`: every command that writes (the table [`WRITERS`])
//! against every fault of the matrix:
//!
//! - its output is one of its inputs (each input as given, as `./x`, through a symlink and a hard
//!   link; a folder input also through the files in it),
//! - an input does not exist,
//! - a second process holds the output (its lock), and, for the commands with a long run, a real
//!   second run starts while the first writes,
//! - the disk is full (a small tmpfs, root only),
//! - the target folder is read-only (a read-only tmpfs: chmod does not stop root),
//! - Ctrl-C (SIGINT) in the middle of a long run.
//!
//! Each case asserts a non-zero exit, a message naming the file, every pre-existing file of the
//! scratch folder byte for byte unchanged and no temporary or lock file left (the whole folder,
//! hidden files included, is compared before and after). The matrix is in docs/outputs.md.
#![cfg(feature = "parquet")]
mod fault_harness;

use fault_harness::{
    ctrl_c_and_second_run, every_writer_into, missing_input, output_is_input,
    output_of_the_wrong_kind, run, second_writer, Streams, Tmpfs, Writer,
};
use std::path::{Path, PathBuf};

const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

const EVENTS: &[&str] = &["sim"];

const WRITERS: &[Writer] = &[
    Writer {
        name: "ssm (CSV)",
        args: "ssm --input p.csv --output OUT",
        out: "o.csv",
        inputs: &["p.csv"],
        lock: "OUT",
        long: Some(("ssm --input big.csv --output OUT", Streams::Yes)),
    },
    Writer {
        name: "ssm (Parquet)",
        args: "ssm --input p.parquet --output OUT",
        out: "o.parquet",
        inputs: &["p.parquet"],
        lock: "OUT",
        long: Some(("ssm --input big.csv --output OUT", Streams::Yes)),
    },
    Writer {
        name: "simulate",
        args: "simulate --out OUT --events 6 --seed 5 --mix 2,2,2",
        out: "simo/",
        inputs: &[],
        lock: "OUT/events.csv",
        // Minutes of writing, about 2 GB asked for (2,000,000 events asked for 20 GB free).
        long: Some(("simulate --out OUT --events 200000 --seed 11", Streams::Yes)),
    },
    Writer {
        name: "import commonroad",
        args: "import commonroad --out OUT cr",
        out: "imp/",
        inputs: &["cr"],
        lock: "OUT/events.csv",
        long: Some(("import commonroad --out OUT crbig", Streams::Yes)),
    },
    Writer {
        name: "score (CSV)",
        args: "score --model m.rsk --events sim --out OUT",
        out: "s.csv",
        inputs: &["m.rsk", "sim"],
        lock: "OUT",
        long: Some(("score --model m.rsk --events big --out OUT", Streams::Yes)),
    },
    Writer {
        name: "score (Parquet)",
        args: "score --model m.rsk --events sim --out OUT",
        out: "s.parquet",
        inputs: &["m.rsk", "sim"],
        lock: "OUT",
        long: Some(("score --model m.rsk --events big --out OUT", Streams::Yes)),
    },
    Writer {
        name: "evaluate --out",
        args: "evaluate --model m.rsk --events sim --out OUT",
        out: "ev/",
        inputs: &["m.rsk", "sim"],
        lock: "OUT",
        long: Some(("evaluate --model m.rsk --events bigger --out OUT", Streams::Yes)),
    },
    Writer {
        name: "calibrate",
        args: "calibrate --model m.rsk --normal sim --false-alarm-rate 5 --out OUT",
        out: "cal.rsk",
        inputs: &["m.rsk", "sim"],
        lock: "OUT",
        long: None,
    },
    Writer {
        name: "plot",
        args: "plot --events sim --event 000001 --model m.rsk --out OUT",
        out: "p.svg",
        inputs: &["sim", "m.rsk"],
        lock: "OUT",
        long: None,
    },
    Writer {
        name: "events-to-candump",
        args: "events-to-candump --events sim --out OUT",
        out: "d.log",
        inputs: EVENTS,
        lock: "OUT",
        long: Some(("events-to-candump --events big --out OUT", Streams::Yes)),
    },
    Writer {
        name: "train",
        args: "train --events sim --config t.toml --out OUT --quiet",
        out: "tr/",
        inputs: &["sim", "t.toml"],
        lock: "OUT/drl.json",
        long: Some((
            "train --events sim --config long.toml --out OUT --quiet",
            Streams::No,
        )),
    },
    Writer {
        name: "export-model",
        args: "export-model ck.json --out OUT",
        out: "e.rsk",
        inputs: &["ck.json"],
        lock: "OUT",
        long: None,
    },
    Writer {
        name: "gssm fit",
        args: "gssm fit --events sim --gssm-config g.toml --out OUT",
        out: "gf.rsk",
        inputs: &["sim", "g.toml"],
        lock: "OUT",
        long: Some((
            "gssm fit --events sim --gssm-config glong.toml --out OUT",
            Streams::No,
        )),
    },
    Writer {
        name: "gssm align",
        args: "gssm align --events sim --config t.toml --gssm-config g.toml --gssm g.rsk --out OUT",
        out: "ga.rsk",
        inputs: &["sim", "t.toml", "g.toml", "g.rsk"],
        lock: "OUT",
        long: None,
    },
    Writer {
        name: "gssm msra",
        args: "gssm msra --events sim --config t.toml --gssm-config g.toml --gssm g.rsk --out OUT",
        out: "gm.rsk",
        inputs: &["sim", "t.toml", "g.toml", "g.rsk"],
        lock: "OUT",
        long: None,
    },
    Writer {
        name: "gssm ship",
        args: "gssm ship --events sim --config t.toml --gssm-config g.toml --out-dir OUT",
        out: "ship/",
        inputs: &["sim", "t.toml", "g.toml"],
        lock: "OUT/gssm-default.rsk",
        long: None,
    },
    Writer {
        name: "gssm cv --out",
        args: "gssm cv --events sim --config t.toml --gssm-config g.toml --folds 2 --out OUT",
        out: "cv.json",
        inputs: &["sim", "t.toml", "g.toml"],
        lock: "OUT",
        long: None,
    },
    Writer {
        name: "ablation",
        args: "ablation --events sim --config t.toml --out OUT --folds 2 --fractions 1 --singles-only --quiet",
        out: "abl/",
        inputs: &["sim", "t.toml"],
        lock: "OUT/ablation.csv",
        long: None,
    },
    Writer {
        name: "demo",
        args: "demo --out OUT --config t.toml --events 12 --folds 2 --no-real --no-transfer --quiet",
        out: "demo/",
        inputs: &["t.toml"],
        // The run's lock in --out, held for the run (before, only each folder as it was written).
        lock: "OUT/demo",
        long: None,
    },
    Writer {
        name: "benchmark transfer",
        args: "benchmark transfer --real real --train-events sim --test-events sim --config t.toml --gssm-config g.toml --folds 2 --seeds 1 --out OUT --quiet",
        out: "bt/",
        inputs: &["real", "sim", "t.toml", "g.toml"],
        lock: "OUT/report",
        long: None,
    },
    Writer {
        name: "benchmark domains",
        args: "benchmark domains --real real --real-city real --train-events sim --test-events sim --config t.toml --gssm-config g.toml --folds 2 --seeds 1 --out OUT --quiet",
        out: "bd/",
        inputs: &["real", "sim", "t.toml", "g.toml"],
        lock: "OUT/report",
        long: None,
    },
    Writer {
        name: "benchmark domains --sequences-out",
        args: "benchmark domains --real real --real-city real --train-events sim --test-events sim --config t.toml --gssm-config g.toml --folds 2 --seeds 1 --out bds --sequences-out OUT --quiet",
        out: "bds.csv",
        inputs: &["real", "sim", "t.toml", "g.toml"],
        lock: "OUT",
        long: None,
    },
    Writer {
        name: "man --out-dir",
        args: "man --out-dir OUT",
        out: "man/",
        inputs: &[],
        lock: "OUT",
        long: None,
    },
];

fn repo(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(rel)
}

#[track_caller]
fn ok(dir: &Path, args: &[&str]) {
    let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    let o = run(RISKCTL, dir, &args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A scratch folder with every input of [`WRITERS`] (small: each command runs in well under a
/// second) and every command's old output.
fn scratch() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    ok(
        p,
        &[
            "simulate", "--out", "sim", "--events", "6", "--seed", "3", "--mix", "2,2,2",
        ],
    );
    std::fs::copy(repo("../models/drl-default.rsk"), p.join("m.rsk")).unwrap();
    let h = "x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j";
    let g = "0,0,10,0,1,0,0,4.5,1.8,20,0,5,0,1,0,0,4.5,1.8";
    let bad = "0,0,10,zz,1,0,0,4.5,1.8,20,0,5,0,1,0,0,4.5,1.8";
    std::fs::write(p.join("p.csv"), format!("{h}\n{g}\n{bad}\n{g}\n")).unwrap();
    ok(p, &["ssm", "--input", "p.csv", "--output", "p.parquet"]);
    let tiny = "[comparisons.temporal]\npairs = 50\n[comparisons.cross_sequence]\npairs = 50\n\
                [comparisons.physics]\npairs = 20\n[optimiser]\nmax_epochs = 2\nbatch_pairs = 32\n";
    std::fs::write(p.join("t.toml"), tiny).unwrap();
    std::fs::write(
        p.join("g.toml"),
        "[fit]\nmax_epochs = 2\nhidden = [4]\n[ssra]\nmax_epochs = 2\n",
    )
    .unwrap();
    ok(
        p,
        &[
            "gssm",
            "fit",
            "--events",
            "sim",
            "--gssm-config",
            "g.toml",
            "--out",
            "g.rsk",
        ],
    );
    ok(
        p,
        &[
            "train", "--events", "sim", "--config", "t.toml", "--out", "ck", "--quiet",
        ],
    );
    std::fs::rename(p.join("ck/drl.json"), p.join("ck.json")).unwrap();
    std::fs::remove_dir_all(p.join("ck")).unwrap();
    std::fs::create_dir(p.join("cr")).unwrap();
    // Two scenario files: the transfer benchmark holds real recordings out by file.
    for (from, to) in [
        ("ZAM_Merge-1_1_T-1", "merge"),
        ("ZAM_Legacy-1_1_T-1", "legacy"),
    ] {
        let from = repo(&format!("tests/data/commonroad/{from}.xml"));
        std::fs::copy(from, p.join(format!("cr/{to}.xml"))).unwrap();
    }
    ok(p, &["import", "commonroad", "--out", "real", "cr"]);
    for w in WRITERS {
        w.place_old_output(p);
    }
    d
}

#[test]
fn an_output_that_is_an_input_is_refused_in_every_spelling() {
    let d = scratch();
    output_is_input(RISKCTL, d.path(), WRITERS);
}

#[test]
fn a_missing_input_leaves_the_old_output_alone() {
    let d = scratch();
    missing_input(RISKCTL, d.path(), WRITERS);
}

#[test]
fn an_output_of_the_wrong_kind_is_refused() {
    let d = scratch();
    output_of_the_wrong_kind(RISKCTL, d.path(), WRITERS);
}

#[test]
fn a_second_writer_is_refused() {
    let d = scratch();
    second_writer(RISKCTL, d.path(), WRITERS);
}

#[test]
fn a_full_disk_fails_naming_the_file_and_keeps_the_old_output() {
    let d = scratch();
    every_writer_into(RISKCTL, d.path(), WRITERS, "full disk", Tmpfs::fill);
}

#[test]
fn a_read_only_target_folder_fails_naming_the_file() {
    let d = scratch();
    every_writer_into(
        RISKCTL,
        d.path(),
        WRITERS,
        "read-only folder",
        Tmpfs::make_read_only,
    );
}

#[test]
fn a_disk_that_fills_between_two_files_of_a_set_changes_none() {
    // Room for train's first file (drl.json, about 30 KB: 8 pages) and no more: written one by one,
    // drl.json was replaced and the other four kept their old contents.
    let d = scratch();
    let p = d.path();
    let Some(tmpfs) = Tmpfs::mount(&p.join("mnt"), 512, "disk full half-way") else {
        return;
    };
    let out = p.join("mnt/tr");
    std::fs::create_dir(&out).unwrap();
    for f in [
        "drl.json",
        "msra.json",
        "drl.rsk",
        "drl-f32.rsk",
        "msra.rsk",
    ] {
        std::fs::write(out.join(f), format!("old {f}\n")).unwrap();
    }
    tmpfs.fill_leaving(8 * 4096);
    let args: Vec<String> = "train --events sim --config t.toml --out mnt/tr --quiet"
        .split_whitespace()
        .map(String::from)
        .collect();
    fault_harness::refused(RISKCTL, p, &args, &["mnt/tr/"]).unwrap();
}

/// Extra inputs the long runs need: a 40,000-row pairs file, a 150-event folder and the same
/// events 16 times over (`evaluate` computes for a while before it writes: 150 events take a
/// quarter of a second), 150 scenario files and slow configurations.
fn add_long_inputs(p: &Path) {
    std::fs::create_dir(p.join("crbig")).unwrap();
    for k in 0..150 {
        std::fs::copy(p.join("cr/merge.xml"), p.join(format!("crbig/s{k}.xml"))).unwrap();
    }
    let g = "0,0,10,0,1,0,0,4.5,1.8,20,0,5,0,1,0,0,4.5,1.8\n";
    let mut big = std::fs::read_to_string(p.join("p.csv"))
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .to_string();
    big.push('\n');
    big.push_str(&g.repeat(40_000));
    std::fs::write(p.join("big.csv"), big).unwrap();
    ok(
        p,
        &["simulate", "--out", "big", "--events", "150", "--seed", "4"],
    );
    std::fs::create_dir(p.join("bigger")).unwrap();
    for file in ["events.csv", "frames.csv"] {
        let text = std::fs::read_to_string(p.join("big").join(file)).unwrap();
        let (header, rows) = text.split_once('\n').unwrap();
        let copies: String = (0..16)
            .map(|k| {
                rows.lines()
                    .map(|row| format!("c{k}_{row}\n"))
                    .collect::<String>()
            })
            .collect();
        std::fs::write(p.join("bigger").join(file), format!("{header}\n{copies}")).unwrap();
    }
    std::fs::write(
        p.join("long.toml"),
        "[optimiser]\nmax_epochs = 100000\npatience = 100000\n",
    )
    .unwrap();
    std::fs::write(
        p.join("glong.toml"),
        "[fit]\nmax_epochs = 100000\npatience = 100000\n",
    )
    .unwrap();
}

#[test]
fn ctrl_c_in_the_middle_and_a_second_run_leave_the_old_output() {
    let d = scratch();
    add_long_inputs(d.path());
    ctrl_c_and_second_run(RISKCTL, d.path(), WRITERS);
}
