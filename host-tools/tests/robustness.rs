//! Nothing lost without saying so (issue #10, part 2): physical bounds in the event loader,
//! bounded problem lists, and outputs that would overwrite inputs.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
use riskscore_data::events::{load_events, IssueProblem, KEPT_PER_KIND};
use std::path::Path;
use std::process::Command;

const EV_HEADER: &str =
    "event_id,kind,t_start,t_end,t_impact,length_ego,width_ego,length_sur,width_sur\n";
const FR_HEADER: &str =
    "event_id,time,x_ego,y_ego,vx_ego,vy_ego,hx_ego,hy_ego,acc_ego,x_sur,y_sur,vx_sur,vy_sur,hx_sur,hy_sur\n";

fn rows(id: &str, n: usize, partner_speed: f64) -> String {
    (0..n)
        .map(|k| {
            let t = k as f64 / 10.0;
            format!(
                "{id},{t},{},0,10,0,1,0,-0.5,{},0,{partner_speed},0,1,0\n",
                10.0 * t,
                30.0 + 8.0 * t
            )
        })
        .collect()
}

fn folder(events: &str, frames: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("events.csv"), events).unwrap();
    std::fs::write(dir.path().join("frames.csv"), frames).unwrap();
    dir
}

#[test]
fn implausible_sizes_and_speeds_drop_their_event_naming_the_row() {
    let ev = format!(
        "{EV_HEADER}ok,crash,0,2,1.0,4.5,1.8,5,2\nhuge,crash,0,2,1.0,4.5,1.8,1e30,2\nwide,safe,0,2,,4.5,9,5,2\nfast,safe,0,2,,4.5,1.8,5,2\n"
    );
    let fr = format!(
        "{FR_HEADER}{}{}{}{}",
        rows("ok", 21, 8.0),
        rows("huge", 21, 8.0),
        rows("wide", 21, 8.0),
        rows("fast", 21, 150.0)
    );
    let dir = folder(&ev, &fr);
    let (set, issues) = load_events(dir.path()).unwrap();
    assert_eq!(set.events.len(), 1, "{issues:#?}");
    assert_eq!(set.events[0].id, "ok");
    let find = |id: &str| {
        issues
            .iter()
            .find(|i| i.event_id.as_deref() == Some(id))
            .unwrap()
    };
    let huge = find("huge");
    assert_eq!((huge.line, huge.column.as_deref()), (3, Some("length_sur")));
    assert!(matches!(
        huge.problem,
        IssueProblem::ImplausibleDimension { .. }
    ));
    assert!(
        huge.to_string()
            .contains("events.csv:3: column `length_sur`"),
        "{huge}"
    );
    let wide = find("wide");
    assert_eq!(wide.column.as_deref(), Some("width_ego"));
    let fast = find("fast");
    assert_eq!(fast.column.as_deref(), Some("vx_sur"));
    assert_eq!(fast.line, 2 + 3 * 21);
    assert!(fast.to_string().contains("speed 150 m/s"), "{fast}");
}

#[test]
fn millions_of_bad_rows_give_a_bounded_list_and_a_count() {
    let ev = format!("{EV_HEADER}ok,safe,0,2,,4.5,1.8,5,2\n");
    let mut fr = format!("{FR_HEADER}{}", rows("ok", 21, 8.0));
    let bad = 200_000;
    for k in 0..bad {
        fr.push_str(&format!("ok,{k}.5,x,0,10,0,1,0,0,30,0,8,0,1,0\n"));
    }
    let dir = folder(&ev, &fr);
    let (set, issues) = load_events(dir.path()).unwrap();
    assert!(set.events.is_empty());
    assert!(issues.len() <= 3 * (KEPT_PER_KIND + 1), "{}", issues.len());
    let bad_numbers: u64 = issues
        .iter()
        .filter(|i| {
            matches!(i.problem, IssueProblem::BadNumber(_))
                || matches!(
                    i.problem,
                    IssueProblem::MoreOfKind {
                        kind: "BadNumber",
                        ..
                    }
                )
        })
        .map(|i| i.count())
        .sum();
    assert_eq!(bad_numbers, bad);

    // riskctl evaluate prints the kept problems and the true total, not 200,000 lines.
    let out = Command::new(env!("CARGO_BIN_EXE_riskctl"))
        .args(["evaluate", "--events"])
        .arg(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.lines().count() < 100,
        "{} lines",
        stderr.lines().count()
    );
    assert!(stderr.contains("more `BadNumber` problems"), "{stderr}");
}

#[test]
fn events_to_candump_refuses_to_overwrite_its_input_and_checks_numbers() {
    let ev = format!("{EV_HEADER}ok,safe,0,2,,4.5,1.8,5,2\n");
    let fr = format!("{FR_HEADER}{}", rows("ok", 21, 8.0));
    let dir = folder(&ev, &fr);
    let to_candump = |out: &Path, extra: &[String]| {
        Command::new(env!("CARGO_BIN_EXE_riskctl"))
            .args(["events-to-candump", "--events"])
            .arg(dir.path())
            .arg("--out")
            .arg(out)
            .args(extra)
            .output()
            .unwrap()
    };
    let frames = dir.path().join("frames.csv");
    let out = to_candump(&frames, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("same file as --events"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&frames).unwrap(), fr);

    let out_dir = tempfile::tempdir().unwrap();
    for (flag, value) in [("--gap", "nan"), ("--start", "-1"), ("--gap", "1e300")] {
        let x = out_dir.path().join("x.log");
        let out = to_candump(&x, &[format!("{flag}={value}")]);
        assert!(!out.status.success(), "{flag} {value}");
        assert!(!x.exists());
    }

    // Not into the event folder, an input.
    let out = to_candump(&dir.path().join("drive.log"), &[]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("lies inside --events"));
    // A good run writes the log and leaves no temporary file.
    let log = out_dir.path().join("drive.log");
    let out = to_candump(&log, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read_to_string(&log).unwrap().lines().count(), 105);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    assert_eq!(std::fs::read_dir(out_dir.path()).unwrap().count(), 1);
}

#[test]
fn events_to_candump_fails_on_skipped_cycles_unless_allowed() {
    // Event `far`: its frame 5 puts the partner 900 m ahead, outside ObjPosX's DBC range.
    let ev = format!("{EV_HEADER}ok,safe,0,2,,4.5,1.8,5,2\nfar,safe,0,2,,4.5,1.8,5,2\n");
    let far: String = rows("far", 21, 8.0)
        .lines()
        .enumerate()
        .map(|(k, row)| {
            let mut cols: Vec<&str> = row.split(',').collect();
            if k == 5 {
                cols[9] = "900";
            }
            cols.join(",") + "\n"
        })
        .collect();
    let fr = format!("{FR_HEADER}{}{far}", rows("ok", 21, 8.0));
    let dir = folder(&ev, &fr);
    // Beside the event folder: nothing is written into an input folder.
    let out_dir = tempfile::tempdir().unwrap();
    let log = out_dir.path().join("drive.log");
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_riskctl"))
            .args(["events-to-candump", "--events"])
            .arg(dir.path())
            .arg("--out")
            .arg(&log)
            .args(extra)
            .output()
            .unwrap()
    };

    // Default: any skipped cycle fails the run, names the file, the event and the count, and
    // writes nothing (not even a temporary file).
    let out = run(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("frames.csv: event far at t=0.5: cycle not encoded")
            && stderr.contains("ObjPosX"),
        "{stderr}"
    );
    assert!(
        stderr.contains("1 of 42 cycles") && stderr.contains("--max-skipped 0"),
        "{stderr}"
    );
    assert!(!log.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    assert_eq!(std::fs::read_dir(out_dir.path()).unwrap().count(), 0);

    // A share below the allowance: written, the loss still reported.
    let out = run(&["--max-skipped", "0.05"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("within --max-skipped 0.05"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(&log).unwrap().lines().count(),
        41 * 5
    );

    // Above it: refused, and the previous log is left as it was.
    let before = std::fs::read_to_string(&log).unwrap();
    let out = run(&["--max-skipped", "0.01"]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read_to_string(&log).unwrap(), before);

    for bad in ["-0.1", "1.5", "nan", "x"] {
        let out = run(&["--max-skipped", bad]);
        assert!(!out.status.success(), "--max-skipped {bad} accepted");
    }
}
