//! Event-folder loading, validation (file/line/column of every problem), writing, sequence
//! preparation and event-level folds.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
use riskscore_data::events::{
    cut_safe_sequences, kfold_by_event, load_events, prepare_event, prepare_sequences,
    stream_events, write_events, Dims, Event, EventKind, EventSet, EventsError, Frame,
    IssueProblem, LoadIssue, PrepareConfig, PrepareIssue,
};
use scorer_core::VehicleState;

const EV_HEADER: &str =
    "event_id,kind,t_start,t_end,t_impact,length_ego,width_ego,length_sur,width_sur\n";
const FR_HEADER: &str =
    "event_id,time,x_ego,y_ego,vx_ego,vy_ego,hx_ego,hy_ego,acc_ego,x_sur,y_sur,vx_sur,vy_sur,hx_sur,hy_sur\n";

fn folder(events: &str, frames: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("events.csv"), events).unwrap();
    std::fs::write(dir.path().join("frames.csv"), frames).unwrap();
    dir
}

/// A frame row: ego driving along +x at 10 m/s from x = 10 t, partner 30 m ahead at 8 m/s.
fn row(id: &str, t: f64) -> String {
    format!(
        "{id},{t},{},0,10,0,1,0,-0.5,{},0,8,0,1,0\n",
        10.0 * t,
        30.0 + 8.0 * t
    )
}

fn rows(id: &str, n: usize) -> String {
    (0..n).map(|k| row(id, k as f64 / 10.0)).collect()
}

/// Two good events: a crash "c1" (t_impact 1.0) and a safe "s1", 21 frames each.
fn good() -> (String, String) {
    let ev = format!("{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\n");
    let fr = format!("{FR_HEADER}{}{}", rows("c1", 21), rows("s1", 21));
    (ev, fr)
}

fn load(ev: &str, fr: &str) -> (EventSet, Vec<LoadIssue>, tempfile::TempDir) {
    let dir = folder(ev, fr);
    let (set, issues) = load_events(dir.path()).unwrap();
    (set, issues, dir)
}

fn ids(set: &EventSet) -> Vec<&str> {
    set.iter().map(|e| e.id.as_str()).collect()
}

/// The single issue, checked for file name, line and column.
fn only_issue<'a>(
    issues: &'a [LoadIssue],
    file: &str,
    line: u64,
    column: Option<&str>,
) -> &'a IssueProblem {
    assert_eq!(issues.len(), 1, "{issues:#?}");
    let i = &issues[0];
    assert_eq!(i.file.file_name().unwrap(), file, "{i}");
    assert_eq!(i.line, line, "{i}");
    assert_eq!(i.column.as_deref(), column, "{i}");
    &i.problem
}

#[test]
fn good_folder_loads_without_issues() {
    let (ev, fr) = good();
    let (set, issues, _d) = load(&ev, &fr);
    assert!(issues.is_empty(), "{issues:#?}");
    assert_eq!(ids(&set), ["c1", "s1"]);
    let c = set.get("c1").unwrap();
    assert_eq!(c.kind, EventKind::Crash);
    assert_eq!(c.t_impact, Some(1.0));
    assert_eq!(c.frames.len(), 21);
    let f = &c.frames[5];
    assert_eq!(f.time, 0.5);
    assert_eq!((f.ego.x, f.ego.vx, f.ego.acc), (5.0, 10.0, -0.5));
    assert_eq!(
        (f.ego.length, f.ego.width, f.partner.length, f.partner.width),
        (4.5, 1.8, 5.0, 2.0)
    );
    assert_eq!(f.partner.x, 34.0);
    // No acc_sur column: derived from the partner's velocity, constant here.
    assert!(c.frames.iter().all(|f| f.partner.acc == 0.0));
    assert!(set.get("s1").unwrap().t_impact.is_none());
    let counts = set.counts();
    assert_eq!((counts.crash, counts.near_crash, counts.safe), (1, 0, 1));
}

#[test]
fn partner_acceleration_is_derived_or_read() {
    // Partner speed 8 - 2 t along its heading: derived acc = -2 everywhere.
    let mut fr = String::from(FR_HEADER);
    for k in 0..11 {
        let t = k as f64 / 10.0;
        fr += &format!(
            "e,{t},{},0,10,0,1,0,0,{},0,{},0,1,0\n",
            10.0 * t,
            30.0 + 8.0 * t - t * t,
            8.0 - 2.0 * t
        );
    }
    let ev = format!("{EV_HEADER}e,safe,0,1,,4,2,4,2\n");
    let (set, issues, _d) = load(&ev, &fr);
    assert!(issues.is_empty());
    for f in &set.events[0].frames {
        assert!((f.partner.acc + 2.0).abs() < 1e-4, "{}", f.partner.acc);
    }
    // With an acc_sur column the recorded value is used.
    let fr2 = fr
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                format!("{l},acc_sur\n")
            } else {
                format!("{l},-0.25\n")
            }
        })
        .collect::<String>();
    let (set, issues, _d) = load(&ev, &fr2);
    assert!(issues.is_empty(), "{issues:#?}");
    assert!(set.events[0].frames.iter().all(|f| f.partner.acc == -0.25));
}

#[test]
fn unknown_kind_is_reported_and_others_kept() {
    let (ev, fr) = good();
    let ev = ev + "x1,collision,0,2,1.0,4.5,1.8,5,2\n";
    let fr = fr + &rows("x1", 21);
    let (set, issues, _d) = load(&ev, &fr);
    let p = only_issue(&issues, "events.csv", 4, Some("kind"));
    assert_eq!(p, &IssueProblem::UnknownKind("collision".into()));
    assert_eq!(issues[0].event_id.as_deref(), Some("x1"));
    // Its frames are not reported again as frames of an unknown event.
    assert_eq!(ids(&set), ["c1", "s1"]);
}

#[test]
fn conflict_without_impact_time() {
    let ev = format!("{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\nn1,near_crash,0,2,,4.5,1.8,5,2\n");
    let fr = format!("{FR_HEADER}{}{}", rows("c1", 21), rows("n1", 21));
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(
        only_issue(&issues, "events.csv", 3, Some("t_impact")),
        &IssueProblem::MissingImpactTime
    );
    assert_eq!(ids(&set), ["c1"]);
}

#[test]
fn safe_with_impact_time_and_impact_outside_event() {
    let ev = format!("{EV_HEADER}s1,safe,0,2,1.0,4.5,1.8,5,2\nc1,crash,0,2,2.5,4.5,1.8,5,2\nok,safe,0,2,,4,2,4,2\n");
    let fr = format!(
        "{FR_HEADER}{}{}{}",
        rows("s1", 21),
        rows("c1", 21),
        rows("ok", 21)
    );
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(issues.len(), 2, "{issues:#?}");
    assert_eq!(
        (issues[0].line, issues[0].column.as_deref()),
        (2, Some("t_impact"))
    );
    assert_eq!(issues[0].problem, IssueProblem::ImpactTimeOnSafe);
    assert_eq!(
        (issues[1].line, issues[1].column.as_deref()),
        (3, Some("t_impact"))
    );
    assert!(
        matches!(issues[1].problem, IssueProblem::ImpactOutsideEvent { t_impact, .. } if t_impact == 2.5)
    );
    assert_eq!(ids(&set), ["ok"]);
}

#[test]
fn bad_event_rows() {
    let ev = format!(
        "{EV_HEADER}a,safe,0,2,,4.5,1.8,-5,2\nb,safe,2,1,,4.5,1.8,5,2\nc,safe,zero,2,,4.5,1.8,5,2\nd,safe,0,2,,4.5,1.8,5\n,safe,0,2,,4,2,4,2\nok,safe,0,2,,4,2,4,2\n"
    );
    let fr = format!("{FR_HEADER}{}{}", rows("a", 3), rows("ok", 21));
    let (set, issues, _d) = load(&ev, &fr);
    let got: Vec<(u64, Option<&str>)> = issues
        .iter()
        .map(|i| (i.line, i.column.as_deref()))
        .collect();
    assert_eq!(
        got,
        [
            (2, Some("length_sur")),
            (3, Some("t_end")),
            (4, Some("t_start")),
            (5, None),
            (6, Some("event_id")),
        ],
        "{issues:#?}"
    );
    assert_eq!(issues[0].problem, IssueProblem::NonPositiveDimension(-5.0));
    assert!(matches!(
        issues[1].problem,
        IssueProblem::EmptyInterval { .. }
    ));
    assert_eq!(issues[2].problem, IssueProblem::BadNumber("zero".into()));
    assert_eq!(
        issues[3].problem,
        IssueProblem::RowLength {
            found: 8,
            expected: 9
        }
    );
    assert_eq!(issues[4].problem, IssueProblem::EmptyEventId);
    assert_eq!(ids(&set), ["ok"]);
}

#[test]
fn duplicate_event_ids_drop_both() {
    let ev = format!(
        "{EV_HEADER}d,safe,0,2,,4.5,1.8,5,2\nok,safe,0,2,,4,2,4,2\nd,crash,0,2,1,4.5,1.8,5,2\n"
    );
    let fr = format!("{FR_HEADER}{}{}", rows("d", 21), rows("ok", 21));
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(
        only_issue(&issues, "events.csv", 4, Some("event_id")),
        &IssueProblem::DuplicateEventId { first_line: 2 }
    );
    assert_eq!(ids(&set), ["ok"]);
}

#[test]
fn non_finite_and_unparsable_frame_values() {
    let (ev, fr) = good();
    // Line numbers: header 1, c1 frames 2..=22, s1 frames 23..=43.
    let fr = fr
        .replacen("c1,0.3,3,0,10,", "c1,0.3,3,0,NaN,", 1)
        .replacen(
            "s1,0.5,5,0,10,0,1,0,-0.5,34",
            "s1,0.5,5,0,10,0,1,0,-0.5,3x4",
            1,
        );
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(issues.len(), 2, "{issues:#?}");
    assert_eq!(
        (issues[0].line, issues[0].column.as_deref()),
        (5, Some("vx_ego"))
    );
    assert_eq!(issues[0].problem, IssueProblem::NonFinite("NaN".into()));
    assert_eq!(issues[0].event_id.as_deref(), Some("c1"));
    assert_eq!(
        (issues[1].line, issues[1].column.as_deref()),
        (28, Some("x_sur"))
    );
    assert_eq!(issues[1].problem, IssueProblem::BadNumber("3x4".into()));
    // The whole event is dropped (policy), nothing else is.
    assert!(set.is_empty());
    let text = issues[0].to_string();
    assert!(
        text.contains("frames.csv:5:") && text.contains("vx_ego") && text.contains("c1"),
        "{text}"
    );
}

/// A position far beyond any world frame (`1e30` from a broken export) is finite, so it used to
/// load and enter its frame's features (a TAdv of 4e28 s) and training; it is now a data error
/// naming the row and column, its event dropped like one with a speed above 100 m/s. A position
/// anywhere on Earth (UTM northings reach 1e7 m) still loads.
#[test]
fn a_position_beyond_any_world_frame_drops_its_event() {
    let (ev, fr) = good();
    // Line numbers: header 1, c1 frames 2..=22, s1 frames 23..=43.
    let bad = fr
        .replacen("c1,0.3,3,0,10,", "c1,0.3,1e30,0,10,", 1)
        .replacen(
            "s1,0.5,5,0,10,0,1,0,-0.5,34,0,",
            "s1,0.5,5,0,10,0,1,0,-0.5,34,-2e9,",
            1,
        );
    let (set, issues, _d) = load(&ev, &bad);
    assert!(set.is_empty(), "{:?}", ids(&set));
    assert_eq!(issues.len(), 2, "{issues:#?}");
    for (issue, line, column, value) in [
        (&issues[0], 5, "x_ego", "1e30"),
        (&issues[1], 28, "y_sur", "-2e9"),
    ] {
        assert_eq!(issue.problem.kind(), "ImplausiblePosition", "{issue}");
        assert!(!issue.problem.is_note(), "{issue}");
        assert_eq!((issue.line, issue.column.as_deref()), (line, Some(column)));
        let text = issue.to_string();
        assert!(
            text.contains(&format!("frames.csv:{line}:"))
                && text.contains(&format!("position {value} m is beyond 1e8 m")),
            "{text}"
        );
    }
    // UTM-sized coordinates are places, not errors (at most a note on their precision).
    let utm = fr.replace(",0,10,0,1,0,-0.5,", ",9999999,10,0,1,0,-0.5,");
    let (set, issues, _d) = load(&ev, &utm);
    assert_eq!(set.len(), 2, "{issues:#?}");
    assert!(issues.iter().all(|i| i.problem.is_note()), "{issues:#?}");
}

/// A file saved as UTF-16 (Excel's "Unicode Text") failed with `CSV parse error: record 0
/// (line 1, field: 0, byte: 0): invalid utf-8`; the error now says it is UTF-16 and how to
/// convert it.
#[test]
fn a_utf16_file_is_named_as_utf16() {
    let (ev, fr) = good();
    for (name, bom, le) in [
        ("events.csv", [0xFF, 0xFE], true),
        ("frames.csv", [0xFE, 0xFF], false),
    ] {
        let dir = folder(&ev, &fr);
        let text = if name == "events.csv" { &ev } else { &fr };
        let mut bytes = bom.to_vec();
        for unit in text.encode_utf16() {
            bytes.extend(if le {
                unit.to_le_bytes()
            } else {
                unit.to_be_bytes()
            });
        }
        std::fs::write(dir.path().join(name), bytes).unwrap();
        let err = load_events(dir.path()).map(|_| ()).unwrap_err().to_string();
        assert!(
            err.contains(name) && err.contains("UTF-16") && err.contains("UTF-8"),
            "{err}"
        );
    }
}

/// Positions in UTM (a northing of 5,400 km) are read as f32, resolved to 0.5 m: every gap of
/// the event is rounded to that, and the same 310 simulated events moved by a UTM origin scored
/// other metrics (DRL A^ROC_90 76.6 -> 77.2), silently. Such an event is now kept with a
/// `CoarsePositions` note on its events.csv line naming the largest coordinate and its spacing;
/// local coordinates (100 km and less) get none.
#[test]
fn positions_far_from_the_origin_are_noted_and_the_event_kept() {
    let (ev, fr) = good();
    // s1's partner at a UTM northing: its y_sur is 5,400,000 m on every frame.
    let utm = fr
        .lines()
        .map(|l| {
            if l.starts_with("s1,") {
                let mut f: Vec<&str> = l.split(',').collect();
                f[10] = "5400000";
                f.join(",")
            } else {
                l.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    let (set, issues, _d) = load(&ev, &utm);
    assert_eq!(ids(&set), ["c1", "s1"]);
    assert_eq!(issues.len(), 1, "{issues:#?}");
    let issue = &issues[0];
    assert_eq!(issue.problem.kind(), "CoarsePositions", "{issue}");
    assert!(issue.problem.is_note(), "{issue}");
    assert_eq!((issue.line, issue.event_id.as_deref()), (3, Some("s1")));
    let text = issue.to_string();
    assert!(
        text.contains("events.csv:3:") && text.contains("5400000 m") && text.contains("0.5 m"),
        "{text}"
    );
    // 100 km is still local.
    let local = utm.replace(",5400000,", ",100000,");
    let (set, issues, _d) = load(&ev, &local);
    assert_eq!((set.len(), issues.len()), (2, 0), "{issues:#?}");
}

/// An empty cell (a missing value, as pandas writes NaN) was reported as "`` is not a number";
/// it now says the field is empty.
#[test]
fn an_empty_frame_field_is_named_as_empty() {
    let (ev, fr) = good();
    let fr = fr.replacen("c1,0.3,3,0,10,", "c1,0.3,,0,10,", 1);
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(ids(&set), ["s1"]);
    let problem = only_issue(&issues, "frames.csv", 5, Some("x_ego"));
    assert_eq!(problem, &IssueProblem::BadNumber(String::new()));
    let text = issues[0].to_string();
    assert!(
        text.contains("x_ego") && text.contains("the field is empty") && !text.contains("``"),
        "{text}"
    );
}

#[test]
fn unsorted_and_duplicate_times() {
    let ev = format!(
        "{EV_HEADER}u,safe,0,2,,4.5,1.8,5,2\nd,safe,0,2,,4.5,1.8,5,2\nok,safe,0,2,,4,2,4,2\n"
    );
    let fr = format!(
        "{FR_HEADER}{}{}{}{}{}{}",
        row("u", 0.0),
        row("u", 0.2),
        row("u", 0.1),
        row("d", 0.0),
        row("d", 0.0),
        rows("ok", 21)
    );
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(issues.len(), 2, "{issues:#?}");
    assert_eq!(
        (issues[0].line, issues[0].column.as_deref()),
        (4, Some("time"))
    );
    assert_eq!(
        issues[0].problem,
        IssueProblem::UnsortedTime {
            time: 0.1,
            previous: 0.2,
            previous_line: 3
        }
    );
    assert_eq!(
        (issues[1].line, issues[1].column.as_deref()),
        (6, Some("time"))
    );
    assert_eq!(
        issues[1].problem,
        IssueProblem::DuplicateTime {
            time: 0.0,
            previous_line: 5
        }
    );
    assert_eq!(ids(&set), ["ok"]);
}

#[test]
fn frames_for_unknown_event_are_reported_once() {
    let (ev, fr) = good();
    let fr = fr + &rows("ghost", 4);
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(
        only_issue(&issues, "frames.csv", 44, Some("event_id")),
        &IssueProblem::UnknownEvent {
            frames: 4,
            similar: None,
            not_utf8: false
        }
    );
    assert_eq!(issues[0].event_id.as_deref(), Some("ghost"));
    assert_eq!(ids(&set), ["c1", "s1"]);
}

#[test]
fn frames_whose_ids_lost_leading_zeros_or_case_name_the_event_they_mean() {
    // A spreadsheet turned `0007` into `7` (and `S1` is `s1`): the frames are unknown, the
    // events have none; the message names the id events.csv has.
    let ev = format!("{EV_HEADER}0007,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\n");
    let fr = format!("{FR_HEADER}{}{}", rows("7", 21), rows("S1", 21));
    let (set, issues, _d) = load(&ev, &fr);
    assert!(set.is_empty());
    let similar: Vec<_> = issues
        .iter()
        .filter_map(|i| match &i.problem {
            IssueProblem::UnknownEvent { similar, .. } => Some(similar.as_deref()),
            _ => None,
        })
        .collect();
    assert_eq!(similar, [Some("0007"), Some("s1")], "{issues:#?}");
    // Two ids alike (`07` and `0007`): the hint is the smallest, the same on every run (it was
    // whichever a hash map gave first).
    let ev = format!("{EV_HEADER}0007,crash,0,2,1.0,4.5,1.8,5,2\n07,safe,0,2,,4.5,1.8,5,2\n");
    for _ in 0..8 {
        let (_, issues, _d) = load(&ev, &format!("{FR_HEADER}{}", rows("7", 21)));
        let hint = issues.iter().find_map(|i| match &i.problem {
            IssueProblem::UnknownEvent { similar, .. } => similar.clone(),
            _ => None,
        });
        assert_eq!(hint.as_deref(), Some("0007"), "{issues:#?}");
    }
    let text = issues
        .iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        text.contains("(events.csv has `0007`: leading zeros or case lost"),
        "{text}"
    );
}

#[test]
fn headings_are_normalised_within_tolerance_else_reported() {
    let (ev, fr) = good();
    // Slightly off (norm 1.005): normalised. Far off (norm 2): reported.
    let fr = fr
        .replacen("c1,0.2,2,0,10,0,1,0,", "c1,0.2,2,0,10,0,0.6030,0.8040,", 1)
        .replacen(
            "s1,0.5,5,0,10,0,1,0,-0.5,34,0,8,0,1,0",
            "s1,0.5,5,0,10,0,1,0,-0.5,34,0,8,0,2,0",
            1,
        );
    let (set, issues, _d) = load(&ev, &fr);
    let p = only_issue(&issues, "frames.csv", 28, Some("hx_sur"));
    assert!(matches!(p, IssueProblem::HeadingNotUnit { norm } if (norm - 2.0).abs() < 1e-9));
    assert_eq!(ids(&set), ["c1"]);
    let f = &set.get("c1").unwrap().frames[2];
    assert!(
        (f.ego.hx - 0.6).abs() < 1e-6 && (f.ego.hy - 0.8).abs() < 1e-6,
        "{f:?}"
    );
}

#[test]
fn events_without_frames_and_frames_outside_the_event() {
    let ev = format!(
        "{EV_HEADER}empty,safe,0,2,,4.5,1.8,5,2\nlate,crash,0,2,0.5,4.5,1.8,5,2\nout,safe,0,1,,4,2,4,2\nok,safe,0,2,,4,2,4,2\n"
    );
    let fr = format!(
        "{FR_HEADER}{}{}{}{}",
        row("late", 1.0),
        row("late", 1.1),
        rows("out", 12),
        rows("ok", 21)
    );
    let (set, issues, _d) = load(&ev, &fr);
    assert_eq!(issues.len(), 3, "{issues:#?}");
    // Frame of "out" at t = 1.1 > t_end = 1 (frames.csv line 2 + 2 + 11 = 15).
    assert_eq!(
        (issues[0].file.file_name().unwrap().to_str(), issues[0].line),
        (Some("frames.csv"), 15)
    );
    assert!(matches!(
        issues[0].problem,
        IssueProblem::FrameOutsideEvent { .. }
    ));
    assert_eq!(
        (issues[1].line, issues[1].problem.clone()),
        (2, IssueProblem::NoFrames)
    );
    assert_eq!(issues[2].line, 3);
    assert_eq!(issues[2].column.as_deref(), Some("t_impact"));
    assert!(matches!(
        issues[2].problem,
        IssueProblem::ImpactBeforeFrames { .. }
    ));
    assert_eq!(ids(&set), ["ok"]);
}

#[test]
fn missing_columns_and_files_are_errors() {
    let (ev, fr) = good();
    let no_kind = ev.replace("kind,", "type,");
    let dir = folder(&no_kind, &fr);
    match load_events(dir.path()) {
        Err(EventsError::MissingColumn { column, path, hint }) => {
            assert_eq!(column, "kind");
            assert!(path.ends_with("events.csv"));
            assert_eq!(hint, "", "nothing explains a missing column");
        }
        other => panic!("{other:?}"),
    }
    let no_acc = fr.replace(",acc_ego,", ",accel,");
    let dir = folder(&ev, &no_acc);
    let e = load_events(dir.path()).unwrap_err();
    assert!(
        e.to_string()
            .contains("frames.csv: line 1: missing required column `acc_ego`"),
        "{e}"
    );
    let empty = tempfile::tempdir().unwrap();
    let e = load_events(empty.path()).unwrap_err();
    assert!(
        matches!(e, EventsError::Io { .. }) && e.to_string().contains("events.csv"),
        "{e}"
    );
}

#[test]
fn the_optional_acc_sur_column_twice_or_in_other_case_is_an_error() {
    // Both were read silently: a second `acc_sur` as if the first were the only one, `Acc_Sur` as
    // an extra column (its data dropped, the partner acceleration derived instead).
    let (ev, fr) = good();
    let mut lines = fr.lines();
    let header = lines.next().unwrap().to_string();
    let rows: Vec<String> = lines.map(String::from).collect();
    let with = |extra: &str| -> String {
        std::iter::once(format!("{header},{extra}"))
            .chain(
                rows.iter()
                    .map(|l| format!("{l},{}", vec!["0.1"; extra.split(',').count()].join(","))),
            )
            .map(|l| l + "\n")
            .collect()
    };
    // Exactly spelled once: read.
    assert!(load_events(folder(&ev, &with("acc_sur")).path()).is_ok());
    let dir = folder(&ev, &with("acc_sur,acc_sur"));
    match load_events(dir.path()) {
        Err(EventsError::DuplicateColumn { column, path, .. }) => {
            assert_eq!(column, "acc_sur");
            assert!(path.ends_with("frames.csv"));
        }
        other => panic!("{other:?}"),
    }
    let dir = folder(&ev, &with("Acc_Sur"));
    let e = load_events(dir.path()).unwrap_err();
    assert!(
        matches!(
            e,
            EventsError::MiscasedColumn {
                column: "acc_sur",
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        e.to_string().ends_with(
            "frames.csv: line 1: column `Acc_Sur` is `acc_sur` in other case: column names are \
             lower case, spelled exactly"
        ),
        "{e}"
    );
}

#[test]
fn a_duplicated_column_and_an_empty_file_are_named() {
    // A second `x_ego` of 99999 was read as if absent (the first won without a word), and a
    // 0-byte events.csv was "missing required column `event_id`".
    let (ev, fr) = good();
    let mut lines = fr.lines();
    let header = lines.next().unwrap();
    let twice: String = std::iter::once(format!("{header},x_ego"))
        .chain(lines.map(|l| format!("{l},99999")))
        .map(|l| l + "\n")
        .collect();
    let dir = folder(&ev, &twice);
    let e = load_events(dir.path()).unwrap_err();
    let at = header.split(',').position(|h| h == "x_ego").unwrap() + 1;
    let end = header.split(',').count() + 1;
    assert_eq!(
        e.to_string(),
        format!(
            "{}: line 1: column `x_ego` appears twice in the header (columns {at} and {end}): \
             which one holds the data cannot be told",
            dir.path().join("frames.csv").display()
        )
    );
    let dir = folder("", &fr);
    let e = load_events(dir.path()).unwrap_err();
    assert!(matches!(e, EventsError::EmptyFile { .. }), "{e}");
    assert!(
        e.to_string()
            .ends_with("events.csv: the file is empty (no header line)"),
        "{e}"
    );
}

#[test]
fn columns_may_come_in_any_order_with_extras() {
    let ev = "kind,event_id,note,t_start,t_end,t_impact,length_ego,width_ego,length_sur,width_sur\nsafe,z,hello,0,2,,4,2,4,2\n";
    let mut fr = String::from(FR_HEADER);
    fr += &rows("z", 21);
    let (set, issues, _d) = load(ev, &fr);
    assert!(issues.is_empty(), "{issues:#?}");
    assert_eq!(ids(&set), ["z"]);
}

fn state(x: f32, vx: f32, acc: f32) -> VehicleState {
    VehicleState {
        x,
        y: 0.25,
        vx,
        vy: 0.0,
        hx: 1.0,
        hy: 0.0,
        acc,
        length: 4.4,
        width: 1.8,
    }
}

fn event(
    id: &str,
    kind: EventKind,
    n: usize,
    t_impact: Option<f64>,
    acc: impl Fn(usize) -> f32,
) -> Event {
    let frames: Vec<Frame> = (0..n)
        .map(|k| Frame {
            time: k as f64 / 10.0,
            ego: state(k as f32 * 1.1 + 0.123_456_7, 11.0, acc(k)),
            partner: state(40.0 - k as f32 * 0.3, -3.0 / 7.0, 0.0),
        })
        .collect();
    Event {
        id: id.into(),
        kind,
        t_start: 0.0,
        t_end: frames.last().map_or(0.0, |f| f.time),
        t_impact,
        dims: Dims {
            length_ego: 4.4,
            width_ego: 1.8,
            length_partner: 4.4,
            width_partner: 1.8,
        },
        frames,
    }
}

#[test]
fn write_then_load_is_bit_exact() {
    let set = EventSet {
        events: vec![
            event("a,with comma", EventKind::Crash, 30, Some(2.9), |k| {
                -0.37 * k as f32
            }),
            event("b", EventKind::Safe, 25, None, |_| 0.1),
        ],
    };
    let dir = tempfile::tempdir().unwrap();
    write_events(dir.path(), &set).unwrap();
    let (back, issues) = load_events(dir.path()).unwrap();
    assert!(issues.is_empty(), "{issues:#?}");
    assert_eq!(back.len(), 2);
    for (a, b) in set.iter().zip(back.iter()) {
        assert_eq!(
            (&a.id, a.kind, a.t_start, a.t_end, a.t_impact, a.dims),
            (&b.id, b.kind, b.t_start, b.t_end, b.t_impact, b.dims)
        );
        for (fa, fb) in a.frames.iter().zip(&b.frames) {
            assert_eq!(fa.time, fb.time);
            assert_eq!(fa.ego, fb.ego);
            // partner.acc is not in the format: the loader derives it (constant velocity -> 0).
            assert_eq!(
                VehicleState {
                    acc: 0.0,
                    ..fa.partner
                },
                fb.partner
            );
        }
    }
}

#[test]
fn conflict_sequence_window() {
    let cfg = PrepareConfig::default();
    // 100 frames (0..9.9 s), impact at 7.0: window [2.5, 7.5].
    let ev = event("c", EventKind::Crash, 100, Some(7.0), |_| 0.0);
    let s = prepare_event(&ev, &cfg).unwrap();
    assert_eq!(s.endpoint, Some(7.0));
    assert_eq!(s.frames.first().unwrap().time, 2.5);
    assert_eq!(s.frames.last().unwrap().time, 7.5);
    assert_eq!(s.frames.len(), 51);
    assert_eq!(s.alert_frames().len(), 46);
    assert_eq!(s.alert_frames().last().unwrap().time, 7.0);
    // Impact near the start and end: clipped by t_start / t_end.
    let ev = event("c2", EventKind::NearCrash, 30, Some(2.9), |_| 0.0);
    let s = prepare_event(&ev, &cfg).unwrap();
    assert_eq!(
        (
            s.frames.first().unwrap().time,
            s.frames.last().unwrap().time
        ),
        (0.0, 2.9)
    );
    assert_eq!(s.alert_frames().len(), 30);
}

#[test]
fn safe_sequences_follow_the_rules() {
    let cfg = PrepareConfig::default();
    let calm = event("s", EventKind::Safe, 40, None, |_| 1.5);
    assert_eq!(prepare_event(&calm, &cfg).unwrap().frames.len(), 40);
    // A hard-braking stretch in the middle: the longest calm run (frames 15..40, 2.4 s) is kept.
    let bumpy = event("b", EventKind::Safe, 40, None, |k| {
        if (10..15).contains(&k) {
            -2.0
        } else {
            0.0
        }
    });
    let s = prepare_event(&bumpy, &cfg).unwrap();
    assert_eq!((s.frames.first().unwrap().time, s.frames.len()), (1.5, 25));
    assert!(s.endpoint.is_none() && s.alert_frames().len() == 25);
    // Too short: 20 frames span 1.9 s.
    let short = event("t", EventKind::Safe, 20, None, |_| 0.0);
    let err = prepare_event(&short, &cfg).unwrap_err();
    assert!(matches!(err, PrepareIssue::SafeTooShort { .. }));
    // The message says what cut it short: here the event's own length, not the acceleration.
    assert!(
        err.to_string()
            .ends_with("(the event itself lasts 1.90 s over 20 frames)"),
        "{err}"
    );
    // Braking every third frame: the ego's acceleration, named with its count and peak.
    let jerky = event("j", EventKind::Safe, 30, None, |k| {
        if k % 3 == 0 {
            -3.0
        } else {
            0.0
        }
    });
    let err = prepare_event(&jerky, &cfg).unwrap_err().to_string();
    assert!(
        err.ends_with("(|acc| above the limit on 10 of 30 frames for the ego (up to 3.00 m/s^2))"),
        "{err}"
    );
    let exactly = event("x", EventKind::Safe, 21, None, |_| 0.0);
    assert!(prepare_event(&exactly, &cfg).is_ok());
    let (seqs, issues) = prepare_sequences(
        &EventSet {
            events: vec![calm, short, bumpy],
        },
        &cfg,
    );
    assert_eq!(
        seqs.iter().map(|s| s.event_id.as_str()).collect::<Vec<_>>(),
        ["s", "b"]
    );
    assert_eq!(issues.len(), 1);
}

#[test]
fn cutting_safe_sequences_from_a_long_recording() {
    let cfg = PrepareConfig::default();
    // 60 s recording; an event in [20, 22]; a hard brake at 40.0..40.5 s.
    let rec = event("trip", EventKind::Safe, 600, None, |k| {
        if (400..405).contains(&k) {
            -3.0
        } else {
            0.0
        }
    });
    let seqs = cut_safe_sequences("trip", &rec.frames, &[(20.0, 22.0)], &cfg);
    let spans: Vec<(f64, f64)> = seqs
        .iter()
        .map(|s| {
            (
                s.frames.first().unwrap().time,
                s.frames.last().unwrap().time,
            )
        })
        .collect();
    // [0, 17) cut to <= 10 s pieces; (25, 40) likewise; (40.5, 59.9].
    assert_eq!(
        spans,
        [
            (0.0, 10.0),
            (10.1, 16.9),
            (25.1, 35.1),
            (35.2, 39.9),
            (40.5, 50.5),
            (50.6, 59.9)
        ]
    );
    assert!(seqs.iter().all(|s| s.kind == EventKind::Safe));
    assert_eq!(seqs[1].event_id, "trip#1");
    for s in &seqs {
        for f in &s.frames {
            assert!(f.time < 17.0 + 1e-9 || f.time > 25.0 - 1e-9);
        }
    }
}

#[test]
fn folds_are_by_event_stratified_and_seeded() {
    let mut events = Vec::new();
    for i in 0..23 {
        let kind = EventKind::ALL[i % 3];
        events.push(event(
            &format!("e{i}"),
            kind,
            2,
            kind.is_conflict().then_some(0.1),
            |_| 0.0,
        ));
    }
    let folds = kfold_by_event(&events, 5, 42);
    assert_eq!(folds, kfold_by_event(&events, 5, 42));
    assert_ne!(folds, kfold_by_event(&events, 5, 43));
    let sizes: Vec<usize> = (0..5).map(|f| folds.test(f).len()).collect();
    assert!(
        sizes.iter().max().unwrap() - sizes.iter().min().unwrap() <= 1,
        "{sizes:?}"
    );
    for kind in EventKind::ALL {
        let per: Vec<usize> = (0..5)
            .map(|f| {
                folds
                    .test(f)
                    .iter()
                    .filter(|&&i| events[i].kind == kind)
                    .count()
            })
            .collect();
        assert!(
            per.iter().max().unwrap() - per.iter().min().unwrap() <= 1,
            "{kind}: {per:?}"
        );
    }
    for f in 0..5 {
        let (tr, te) = (folds.train(f), folds.test(f));
        assert_eq!(tr.len() + te.len(), events.len());
        assert!(te.iter().all(|i| !tr.contains(i)));
    }
    // Sequences of one event always share a fold.
    let cfg = PrepareConfig::default();
    let rec = event("trip", EventKind::Safe, 300, None, |_| 0.0);
    let mut seqs = cut_safe_sequences("trip", &rec.frames, &[], &cfg);
    for s in &mut seqs {
        s.event_id = "trip".into();
    }
    seqs.push(prepare_event(&event("other", EventKind::Safe, 30, None, |_| 0.0), &cfg).unwrap());
    let f = kfold_by_event(&seqs, 2, 1);
    assert!(seqs.len() >= 3);
    assert!((1..seqs.len() - 1).all(|i| f.fold_of(i) == f.fold_of(0)));
    // Events of one recording (`recording/...` ids, as `riskctl import` writes them) share a fold,
    // whatever the seed; ids without a `/` are their own group.
    let mut rec_events = Vec::new();
    for r in 0..6 {
        for k in 0..4 {
            rec_events.push(event(
                &format!("REC{r}/{k}-9@0#{k}"),
                EventKind::Safe,
                2,
                None,
                |_| 0.0,
            ));
        }
    }
    rec_events.push(event("lone", EventKind::Safe, 2, None, |_| 0.0));
    for seed in 0..5 {
        let f = kfold_by_event(&rec_events, 3, seed);
        for r in 0..6 {
            let first = f.fold_of(4 * r);
            assert!((0..4).all(|k| f.fold_of(4 * r + k) == first), "seed {seed}");
        }
        let used: std::collections::BTreeSet<usize> = (0..24).map(|i| f.fold_of(i)).collect();
        assert!(used.len() > 1, "recordings are spread over folds");
    }
    assert_eq!(riskscore_data::events::fold_group("REC1/3-9@0#0"), "REC1");
    assert_eq!(riskscore_data::events::fold_group("e7"), "e7");
}

#[test]
fn good_events_survive_many_bad_ones() {
    let (ev, fr) = good();
    let mut ev = ev;
    let mut fr = fr;
    for i in 0..50 {
        ev += &format!("bad{i},crash,0,2,,4.5,1.8,5,2\n");
        fr += &rows(&format!("bad{i}"), 5);
    }
    ev += "late_good,near_crash,0,2,1.5,4,2,4,2\n";
    fr += &rows("late_good", 21);
    let (set, issues, _d) = load(&ev, &fr);
    // The first 20 of a kind are listed, the other 30 counted in one issue.
    assert_eq!(issues.len(), 21);
    assert_eq!(issues.iter().map(|i| i.count()).sum::<u64>(), 50);
    assert!(issues[..20]
        .iter()
        .all(|i| i.problem == IssueProblem::MissingImpactTime));
    assert_eq!(
        issues[20].problem,
        IssueProblem::MoreOfKind {
            kind: "MissingImpactTime",
            more: 30
        }
    );
    assert_eq!(ids(&set), ["c1", "s1", "late_good"]);
    assert_eq!(set.get("late_good").unwrap().frames.len(), 21);
}

#[test]
fn invalid_utf8_and_short_frame_rows_drop_their_event() {
    let (ev, fr) = good();
    let dir = folder(&ev, &fr);
    // Cut s1's frame at t = 0.1 (line 24) short, and make the y_ego field of c1's frame at
    // t = 0.4 (line 6) invalid UTF-8.
    let short = fr.replacen(
        "s1,0.1,1,0,10,0,1,0,-0.5,30.8,0,8,0,1,0",
        "s1,0.1,1,0,10",
        1,
    );
    assert_ne!(short, fr);
    let mut bytes = short.into_bytes();
    let needle = b"c1,0.4,4,0,";
    let at = bytes
        .windows(needle.len())
        .position(|w| w == needle)
        .unwrap()
        + needle.len()
        - 2;
    bytes[at] = 0xff;
    std::fs::write(dir.path().join("frames.csv"), bytes).unwrap();
    let (set, issues) = load_events(dir.path()).unwrap();
    assert_eq!(issues.len(), 2, "{issues:#?}");
    assert_eq!(
        (
            issues[0].line,
            issues[0].column.as_deref(),
            issues[0].event_id.as_deref()
        ),
        (6, Some("y_ego"), Some("c1"))
    );
    // The invalid byte is shown escaped, not as U+FFFD.
    assert_eq!(issues[0].problem, IssueProblem::BadNumber(r"\xff".into()));
    assert_eq!(
        (
            issues[1].line,
            issues[1].column.as_deref(),
            issues[1].event_id.as_deref()
        ),
        (24, None, Some("s1"))
    );
    assert_eq!(
        issues[1].problem,
        IssueProblem::RowLength {
            found: 5,
            expected: 15
        }
    );
    assert!(set.is_empty());
}

/// [`load`], checking that [`stream_events`] keeps the same events and reports the same issues.
fn load_and_stream(ev: &str, fr: &str) -> (EventSet, Vec<LoadIssue>, tempfile::TempDir) {
    let (set, issues, dir) = load(ev, fr);
    let mut streamed = Vec::new();
    let stream_issues = stream_events(dir.path(), true, |_, e| {
        streamed.push(e.id);
        Ok::<_, EventsError>(())
    })
    .unwrap();
    assert_eq!(stream_issues, issues);
    assert_eq!(streamed, ids(&set));
    (set, issues, dir)
}

/// Each issue as (line, event, problem kind), the shape the quote tests compare.
fn line_event_kind(issues: &[LoadIssue]) -> Vec<(u64, Option<&str>, &'static str)> {
    issues
        .iter()
        .map(|i| (i.line, i.event_id.as_deref(), i.problem.kind()))
        .collect()
}

#[test]
fn unmatched_quote_drops_its_events_and_reading_resumes() {
    // Three events, frames in runs: c1 on lines 2-22, s1 on 23-43, n1 on 44-64.
    let ev = format!(
        "{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\nn1,safe,0,2,,4.5,1.8,5,2\n"
    );
    let fr = format!(
        "{FR_HEADER}{}{}{}",
        rows("c1", 21),
        rows("s1", 21),
        rows("n1", 21)
    );
    // A stray `"` at the start of s1's frame at t = 0.8 (line 31): the CSV reader takes the rest
    // of the file as one field.
    let broken = fr.replacen("s1,0.8,", "\"s1,0.8,", 1);
    assert_ne!(broken, fr);
    let (set, issues, _d) = load_and_stream(&ev, &broken);
    let problem = only_issue(&issues, "frames.csv", 31, None);
    assert!(
        matches!(problem, IssueProblem::BadRow(m) if m.contains("unmatched `\"`")),
        "{problem}"
    );
    assert_eq!(issues[0].event_id.as_deref(), Some("s1"));
    // s1 is dropped whole, not kept with its frames before t = 0.8; n1 (after the broken line)
    // loads completely.
    assert_eq!(ids(&set), ["c1", "n1"]);
    assert_eq!(set.get("n1").unwrap().frames.len(), 21);

    // On the boundary of two events (s1's first frame, line 23) the row may belong to either:
    // both neighbours are dropped, each named by an issue on that line.
    let broken = fr.replacen("s1,0,", "\"s1,0,", 1);
    let (set, issues, _d) = load_and_stream(&ev, &broken);
    let got = line_event_kind(&issues);
    assert_eq!(
        got,
        [(23, Some("c1"), "BadRow"), (23, Some("s1"), "BadRow")],
        "{issues:#?}"
    );
    assert_eq!(ids(&set), ["n1"]);

    // A quote that closes three lines later: the swallowed lines are read again (the closing
    // line's id `s1"` is not an event's).
    let broken = fr
        .replacen("s1,0.8,", "\"s1,0.8,", 1)
        .replacen("s1,1.1,", "s1\",1.1,", 1);
    let (set, issues, _d) = load_and_stream(&ev, &broken);
    let got = line_event_kind(&issues);
    assert_eq!(
        got,
        [
            (31, Some("s1"), "BadRow"),
            (34, Some("s1\""), "UnknownEvent")
        ],
        "{issues:#?}"
    );
    assert_eq!(ids(&set), ["c1", "n1"]);

    // A whole frame row quoted as one field: its "event id" is the row's text, no event's, so the
    // event around it is dropped and named instead.
    let row = "s1,0.8,8,0,10,0,1,0,-0.5,36.4,0,8,0,1,0";
    let broken = fr.replacen(row, &format!("\"{row}\""), 1);
    assert!(broken != fr);
    let (set, issues, _d) = load_and_stream(&ev, &broken);
    let problem = only_issue(&issues, "frames.csv", 31, None);
    assert!(matches!(problem, IssueProblem::RowLength { found: 1, .. }));
    assert_eq!(issues[0].event_id.as_deref(), Some("s1"));
    assert_eq!(ids(&set), ["c1", "n1"]);

    // An event id in a message is at most 40 characters long.
    let issue = LoadIssue {
        event_id: Some(format!("{}\n{}", "x".repeat(39), "y".repeat(1000))),
        ..issues[0].clone()
    };
    assert!(
        issue
            .to_string()
            .contains(&format!("event `{}\\n…`:", "x".repeat(39))),
        "{issue}"
    );
}

/// A file that ends without a newline is read as it stands (its last row kept: many writers leave
/// the last line end out), with a note on its last line: a copy cut inside the last number still
/// parses (`...,8.37` read as `...,8.3`), and nothing else would say the file may be truncated.
#[test]
fn a_last_line_without_newline_is_noted_on_that_line_and_kept() {
    let (ev, fr) = good();
    // frames.csv: header + 42 rows; the last row's last number (`hy_sur` 0.0001) cut short to
    // `0.0`, no newline.
    let full = format!("{},1,0.0001\n", fr.trim_end_matches(",1,0\n"));
    assert!(load(&ev, &full).1.is_empty());
    let cut = &full[..full.len() - 4];
    assert!(cut.ends_with(",1,0.0"), "{cut}");
    let (set, issues, _d) = load_and_stream(&ev, cut);
    let problem = only_issue(&issues, "frames.csv", 43, None);
    assert_eq!(problem, &IssueProblem::NoFinalNewline);
    assert!(problem.is_note());
    assert_eq!(issues[0].event_id, None);
    assert!(
        issues[0].to_string().contains("frames.csv:43: no newline"),
        "{}",
        issues[0]
    );
    assert!(issues[0].to_string().contains("cut short"), "{}", issues[0]);
    assert_eq!(ids(&set), ["c1", "s1"]);
    assert_eq!(set.get("s1").unwrap().frames.len(), 21);

    // events.csv: the note is on its last line (3), both events kept.
    let (set, issues, _d) = load_and_stream(ev.trim_end_matches('\n'), &fr);
    assert_eq!(
        only_issue(&issues, "events.csv", 3, None),
        &IssueProblem::NoFinalNewline
    );
    assert_eq!(ids(&set), ["c1", "s1"]);

    // Cut between fields: the row is short (RowLength, its event dropped), and the note says why.
    let short = &fr[..fr.trim_end_matches('\n').rfind(",8,0,").unwrap()];
    let (set, issues, _d) = load_and_stream(&ev, short);
    assert_eq!(
        line_event_kind(&issues),
        [(43, Some("s1"), "RowLength"), (43, None, "NoFinalNewline")],
        "{issues:#?}"
    );
    assert_eq!(ids(&set), ["c1"]);

    // A line end of either kind is a line end: no note.
    for end in ["\n", "\r\n"] {
        let fr = format!("{}{end}", fr.trim_end_matches('\n'));
        let (_, issues, _d) = load_and_stream(&ev, &fr);
        assert!(issues.is_empty(), "{end:?}: {issues:#?}");
    }
    // The only note: every other kind drops an event (or, UnknownEvent, names rows left out).
    assert!(!IssueProblem::RowLength {
        found: 1,
        expected: 2
    }
    .is_note());
}

#[test]
fn line_numbers_hold_for_windows_line_ends_and_blank_lines() {
    // Bad rows: events.csv line 3 (kind `Safe`), frames.csv line 5 (NaN), line 25 (time repeats
    // line 24), in LF and CRLF files, and with a blank line before each.
    let (ev, fr) = good();
    let ev = ev.replacen("s1,safe", "s1,Safe", 1);
    let fr = fr
        .replacen("c1,0.3,3,0,10,", "c1,0.3,3,0,NaN,", 1)
        .replacen("s1,0.2,", "s1,0.1,", 1);
    let expected = |blank: u64| {
        vec![
            (3 + blank, Some("s1"), "UnknownKind"),
            (5 + blank, Some("c1"), "NonFinite"),
        ]
    };
    for end in ["\n", "\r\n"] {
        let crlf = |s: &str| s.replace('\n', end);
        let (_, issues, _d) = load_and_stream(&crlf(&ev), &crlf(&fr));
        assert_eq!(
            line_event_kind(&issues),
            expected(0),
            "{end:?}: {issues:#?}"
        );
        // A blank line after the first row moves the rows after it one line down.
        let blank = |s: &str, next: &str| crlf(&s.replacen(next, &format!("\n{next}"), 1));
        let (ev, fr) = (blank(&ev, "\ns1,"), blank(&fr, "\nc1,0.1,"));
        let (_, issues, _d) = load_and_stream(&ev, &fr);
        assert_eq!(
            line_event_kind(&issues),
            expected(1),
            "{end:?}: {issues:#?}"
        );
    }
    // The duplicate time of s1 (dropped already by its kind) names both lines: 25 and 24.
    let ev_ok = format!("{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\n");
    let (_, issues, _d) = load_and_stream(&ev_ok.replace('\n', "\r\n"), &fr.replace('\n', "\r\n"));
    let dup = issues.iter().find(|i| i.problem.kind() == "DuplicateTime");
    assert!(
        dup.is_some_and(|i| i.line == 25 && i.to_string().contains("line 24")),
        "{issues:#?}"
    );
}

#[test]
fn speeds_in_km_h_are_noted_and_the_event_kept() {
    // s1's ego speeds in km/h (36 for 10 m/s: its positions cover 20 m, its speeds 72 m); n1's
    // partner speeds in km/h (28.8 for 8 m/s); c1 in m/s.
    let ev = format!(
        "{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\nn1,safe,0,2,,4.5,1.8,5,2\n"
    );
    let fr = format!(
        "{FR_HEADER}{}{}{}",
        rows("c1", 21),
        rows("s1", 21).replace(",10,0,1,0,-0.5,", ",36,0,1,0,-0.5,"),
        rows("n1", 21).replace(",8,0,1,0\n", ",28.8,0,1,0\n")
    );
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1", "n1"], "notes drop nothing");
    assert_eq!(
        line_event_kind(&issues),
        [
            (3, Some("s1"), "SpeedsExceedPath"),
            (4, Some("n1"), "SpeedsExceedPath")
        ],
        "{issues:#?}"
    );
    assert!(issues.iter().all(|i| i.problem.is_note()));
    let (ego, sur) = (issues[0].to_string(), issues[1].to_string());
    assert!(
        ego.contains("`vx_ego`") && ego.contains("3.6 times"),
        "{ego}"
    );
    assert!(
        sur.contains("`vx_sur`") && sur.contains("3.6 times"),
        "{sur}"
    );
    // The notes beyond the first 20 are counted in a note too.
    let many: String = (0..25)
        .map(|k| format!("k{k},safe,0,2,,4.5,1.8,5,2\n"))
        .collect();
    let frames: String = (0..25)
        .map(|k| rows(&format!("k{k}"), 21).replace(",10,0,1,0,-0.5,", ",36,0,1,0,-0.5,"))
        .collect();
    let (set, issues, _d) = load_and_stream(
        &format!("{EV_HEADER}{many}"),
        &format!("{FR_HEADER}{frames}"),
    );
    assert_eq!(set.len(), 25);
    assert_eq!(issues.len(), 21, "{issues:#?}");
    assert!(issues.iter().all(|i| i.problem.is_note()), "{issues:#?}");
    let count = issues[20].to_string();
    assert!(count.contains("5 more `SpeedsExceedPath` notes"), "{count}");
    // A standing partner (no path) and speeds that match their path get no note.
    let fr = format!(
        "{FR_HEADER}{}",
        rows("s1", 21).replace(",8,0,1,0\n", ",0.5,0,1,0\n")
    );
    let ev = format!("{EV_HEADER}s1,safe,0,2,,4.5,1.8,5,2\n");
    let standing = fr
        .lines()
        .map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            if f[0] == "s1" {
                f[9] = "30";
            }
            f.join(",") + "\n"
        })
        .collect::<String>();
    let (set, issues, _d) = load_and_stream(&ev, &standing);
    assert_eq!((set.len(), issues.len()), (1, 0), "{issues:#?}");
    // An ego-centred folder (ego at the origin, as can-bridge check writes) is not checked.
    let centred = fr
        .lines()
        .map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            if f[0] == "s1" {
                f[2] = "0";
            }
            f.join(",") + "\n"
        })
        .collect::<String>();
    let (set, issues, _d) = load_and_stream(&ev, &centred);
    assert_eq!((set.len(), issues.len()), (1, 0), "{issues:#?}");
    // Times in milliseconds in both files: the speeds cover 1000 times the path.
    let ms = |t: &str| format!("{}", t.parse::<f64>().unwrap() * 1000.0);
    let ev_ms = format!("{EV_HEADER}s1,safe,0,2000,,4.5,1.8,5,2\n");
    let fr_ms: String = rows("s1", 21)
        .lines()
        .map(|l| {
            let mut f: Vec<String> = l.split(',').map(str::to_owned).collect();
            f[1] = ms(&f[1]);
            f.join(",") + "\n"
        })
        .collect();
    let (_, issues, _d) = load_and_stream(&ev_ms, &format!("{FR_HEADER}{fr_ms}"));
    let text = issues[0].to_string();
    assert!(
        text.contains("1000.0 times") && text.contains("times in ms"),
        "{text}"
    );
}

#[test]
fn a_missing_column_names_another_separator_or_case() {
    let (ev, fr) = good();
    // Semicolons (a spreadsheet in a comma-decimal locale): the header is one column.
    let dir = folder(&ev.replace(',', ";"), &fr);
    let e = load_events(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains("events.csv: line 1: missing required column `event_id`")
            && e.contains("the file is separated by semicolons"),
        "{e}"
    );
    let dir = folder(&ev, &fr.replace(',', "\t"));
    let e = load_events(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains("frames.csv") && e.contains("separated by tabs"),
        "{e}"
    );
    // Upper-case names.
    let dir = folder(&ev.replacen("kind", "Kind", 1), &fr);
    let e = load_events(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains("missing required column `kind` (there is `Kind`: column names are lower case"),
        "{e}"
    );
}

#[test]
fn problem_notes_count_the_problems_left_unlisted() {
    // 25 unknown kinds: the loader keeps 20 and counts 5 in one MoreOfKind issue; the notes list
    // 20 and must say 5 more problems (they said "1 more", the issues left).
    let bad: String = (0..25)
        .map(|k| format!("b{k},Safe,0,2,,4.5,1.8,5,2\n"))
        .collect();
    let ev = format!("{EV_HEADER}{bad}ok,safe,0,2,,4.5,1.8,5,2\n");
    let dir = folder(&ev, &format!("{FR_HEADER}{}", rows("ok", 21)));
    let unknown_kinds =
        riskscore_data::events::load_prepared(dir.path(), &PrepareConfig::default()).unwrap();
    let notes = unknown_kinds.problem_notes();
    assert_eq!(notes.len(), 21, "{notes:#?}");
    assert_eq!(notes[20], "warning: ... and 5 more problems", "{notes:#?}");

    // 25 events with a hole in their frames: notes, which leave nothing out, are not counted as
    // problems (they were "... and 5 more problems").
    let ev: String = (0..25)
        .map(|k| format!("g{k},safe,0,2,,4.5,1.8,5,2\n"))
        .collect();
    let holed: String = (0..25)
        .flat_map(|k| {
            (0..21)
                .filter(|i| !(5..15).contains(i))
                .map(move |i| row(&format!("g{k}"), f64::from(i) / 10.0))
        })
        .collect();
    let dir = folder(&format!("{EV_HEADER}{ev}"), &format!("{FR_HEADER}{holed}"));
    let holes =
        riskscore_data::events::load_prepared(dir.path(), &PrepareConfig::default()).unwrap();
    let notes = holes.problem_notes();
    assert_eq!(notes.len(), 21, "{notes:#?}");
    assert_eq!(notes[20], "warning: ... and 5 more notes", "{notes:#?}");
}

#[test]
fn headings_across_the_direction_of_travel_are_noted_and_the_event_kept() {
    // s1's ego heading as from north (0, 1) while it drives along +x; n1's partner heading from
    // 90 taken as radians (cos 90, sin 90 = -0.448, 0.894); r1's ego reverses (heading against
    // the velocity): no note; c1 is fine.
    let ev = format!(
        "{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\nn1,safe,0,2,,4.5,1.8,5,2\nr1,safe,0,2,,4.5,1.8,5,2\n"
    );
    let (c, s, n) = (90f64.cos(), 90f64.sin(), "\n");
    let fr = format!(
        "{FR_HEADER}{}{}{}{}",
        rows("c1", 21),
        rows("s1", 21).replace(",10,0,1,0,-0.5,", ",10,0,0,1,-0.5,"),
        rows("n1", 21).replace(&format!(",8,0,1,0{n}"), &format!(",8,0,{c},{s}{n}")),
        rows("r1", 21).replace(",10,0,1,0,-0.5,", ",10,0,-1,0,-0.5,")
    );
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1", "n1", "r1"], "notes drop nothing");
    assert_eq!(
        line_event_kind(&issues),
        [
            (3, Some("s1"), "HeadingAcrossVelocity"),
            (4, Some("n1"), "HeadingAcrossVelocity")
        ],
        "{issues:#?}"
    );
    assert!(issues.iter().all(|i| i.problem.is_note()));
    let (ego, sur) = (issues[0].to_string(), issues[1].to_string());
    assert!(
        ego.contains("`hx_ego`") && ego.contains("on 21 of the 21 frames"),
        "{ego}"
    );
    assert!(
        sur.contains("`hx_sur`") && sur.contains("degrees taken as radians"),
        "{sur}"
    );
}

#[test]
fn an_impact_after_the_last_frame_is_noted_and_the_event_kept() {
    // c1: frames to 0.5 s, t_impact 1.0 (0.5 s without frames); c2: t_impact 2.05, half an
    // interval after its last frame (2.0): no note; c3: a last frame 10 ms after the one before
    // and t_impact 0.56, within one 0.1 s sampling interval of it: no note (the limit was the
    // last interval, 10 ms).
    let ev = format!(
        "{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\nc2,near_crash,0,2.1,2.05,4.5,1.8,5,2\n\
         c3,crash,0,0.6,0.56,4.5,1.8,5,2\n"
    );
    let fr = format!(
        "{FR_HEADER}{}{}{}{}",
        rows("c1", 6),
        rows("c2", 21),
        rows("c3", 6),
        row("c3", 0.51)
    );
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "c2", "c3"], "notes drop nothing");
    assert_eq!(
        line_event_kind(&issues),
        [(2, Some("c1"), "ImpactAfterFrames")],
        "{issues:#?}"
    );
    assert!(issues[0].problem.is_note());
    assert_eq!(issues[0].column.as_deref(), Some("t_impact"));
    let text = issues[0].to_string();
    assert!(
        text.contains("0.500 s after the last frame (0.5)"),
        "{text}"
    );
}

#[test]
fn a_file_given_as_the_folder_is_named_as_such() {
    // It was "DIR/events.csv/events.csv: Not a directory (os error 20)".
    let (ev, fr) = good();
    let dir = folder(&ev, &fr);
    let file = dir.path().join("events.csv");
    let e = load_events(&file).unwrap_err().to_string();
    assert!(
        e.contains("events.csv: a file, not an event folder")
            && e.contains(&format!("({})", dir.path().display()))
            && !e.contains("os error"),
        "{e}"
    );
    let e = stream_events(&file, true, |_, _| Ok::<_, EventsError>(()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("a file, not an event folder"), "{e}");
}

#[test]
fn a_hole_in_the_frames_is_noted_and_the_event_kept() {
    // s1 at 10 Hz without its frames from 0.5 to 1.5 s (one hole of 1 s); n1 has one frame
    // dropped (0.2 s: two intervals, not a hole).
    let ev = format!(
        "{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\nn1,safe,0,2,,4.5,1.8,5,2\n"
    );
    let keep = |id: &str, drop: &dyn Fn(f64) -> bool| -> String {
        (0..21)
            .map(|k| k as f64 / 10.0)
            .filter(|&t| !drop(t))
            .map(|t| row(id, t))
            .collect()
    };
    let fr = format!(
        "{FR_HEADER}{}{}{}",
        rows("c1", 21),
        keep("s1", &|t| t > 0.45 && t < 1.45),
        keep("n1", &|t| (t - 0.7).abs() < 0.01)
    );
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1", "n1"], "notes drop nothing");
    assert_eq!(
        line_event_kind(&issues),
        [(3, Some("s1"), "FrameGap")],
        "{issues:#?}"
    );
    assert!(issues[0].problem.is_note());
    let text = issues[0].to_string();
    assert!(
        text.contains("jump from 0.4 to 1.5 s, where they are 0.100 s apart"),
        "{text}"
    );
}

#[test]
fn a_repeated_header_line_is_noted_and_skipped() {
    // Two files joined with their headers (`cat a.csv b.csv`): the second header was a row of
    // eight "not a number" problems (events.csv) or frames of an unknown event `event_id`.
    let (ev, fr) = good();
    let ev = ev.replacen("\ns1,", &format!("\n{EV_HEADER}s1,"), 1);
    // In the middle of c1's frames too: its run goes on after it.
    let fr = fr.replacen("\nc1,0.5,", &format!("\n{FR_HEADER}c1,0.5,"), 1);
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1"]);
    assert_eq!(set.events[0].frames.len(), 21);
    assert_eq!(
        line_event_kind(&issues),
        [(3, None, "RepeatedHeader"), (7, None, "RepeatedHeader")],
        "{issues:#?}"
    );
    assert!(issues.iter().all(|i| i.problem.is_note()));
}

#[test]
fn a_repeated_header_with_a_byte_order_mark_is_noted_and_skipped() {
    // Two spreadsheet exports joined with `cat`: the second keeps its UTF-8 byte-order mark,
    // and its header was an unknown event `\u{feff}event_id`.
    let (ev, fr) = good();
    let fr = fr.replacen("\nc1,0.5,", &format!("\n\u{feff}{FR_HEADER}c1,0.5,"), 1);
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1"]);
    assert_eq!(
        line_event_kind(&issues),
        [(7, None, "RepeatedHeader")],
        "{issues:#?}"
    );
}

#[test]
fn rows_of_empty_fields_are_blank_lines() {
    // A spreadsheet saves a row it shows blank as `,,,,`: in events.csv each was eight
    // problems, and a short one after a frame dropped that frame's event.
    let (ev, fr) = good();
    let ev = ev.replacen("\ns1,", "\n,,,,,,,,\ns1,", 1) + ",,,,,,,,\n";
    let fr = fr + ",,,\n";
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1"]);
    assert_eq!(set.events[1].frames.len(), 21);
    assert!(issues.is_empty(), "{issues:#?}");
    // A row with one value is no blank line: still a short row.
    let (_, issues, _d) = load(&ev, &(fr_with_row(",,5,")));
    assert_eq!(line_event_kind(&issues), [(44, Some("s1"), "RowLength")]);
}

fn fr_with_row(extra: &str) -> String {
    let (_, fr) = good();
    format!("{fr}{extra}\n")
}

#[test]
fn an_id_in_another_encoding_is_named_and_never_merged() {
    // `é01` and `è01` in Windows-1252 (one byte each, invalid UTF-8): both were read as
    // `\u{fffd}01`, then dropped as a duplicate id; with unique ids they loaded with the id garbled.
    let ev = format!("{EV_HEADER}\u{0}01,safe,0,2,,4.5,1.8,5,2\n\u{1}01,safe,0,2,,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\n");
    let fr = format!(
        "{FR_HEADER}{}{}{}",
        rows("\u{0}01", 21),
        rows("\u{1}01", 21),
        rows("s1", 21)
    );
    let latin1 = |s: &str| s.replace('\u{0}', "\u{e9}").replace('\u{1}', "\u{e8}");
    let to_cp1252 = |s: String| -> Vec<u8> { s.chars().map(|c| c as u32 as u8).collect() };
    let dir = folder("", "");
    std::fs::write(dir.path().join("events.csv"), to_cp1252(latin1(&ev))).unwrap();
    std::fs::write(dir.path().join("frames.csv"), to_cp1252(latin1(&fr))).unwrap();
    let (set, issues) = load_events(dir.path()).unwrap();
    assert_eq!(ids(&set), ["s1"]);
    assert_eq!(
        line_event_kind(&issues),
        [
            (2, Some(r"\xe901"), "NotUtf8"),
            (3, Some(r"\xe801"), "NotUtf8")
        ],
        "{issues:#?}"
    );
    assert_eq!(issues[0].column.as_deref(), Some("event_id"));
    assert!(
        issues[0].to_string().contains("WINDOWS-1252"),
        "{}",
        issues[0]
    );
}

#[test]
fn positions_in_another_unit_are_noted_and_the_event_kept() {
    // s1's ego positions in cm (its speeds add up to 20 m, its positions carry it 2,000 m); n1's
    // partner positions in feet (3.28 times); c1's partner stands with its positions jittering
    // by 0.5 m a frame (a path of 10 m, but it goes nowhere): no note.
    let ev = format!(
        "{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\nn1,safe,0,2,,4.5,1.8,5,2\n"
    );
    let scaled = |id: &str, ego: f64, partner: f64| -> String {
        (0..21)
            .map(|k| {
                let t = k as f64 / 10.0;
                format!(
                    "{id},{t},{},0,10,0,1,0,-0.5,{},0,8,0,1,0\n",
                    ego * 10.0 * t,
                    partner * (30.0 + 8.0 * t)
                )
            })
            .collect()
    };
    let fr = format!(
        "{FR_HEADER}{}{}{}",
        (0..21)
            .map(|k| {
                let t = k as f64 / 10.0;
                let x = 30.0 + 0.5 * (k % 2) as f64;
                format!("c1,{t},{},0,10,0,1,0,-0.5,{x},0,0,0,1,0\n", 10.0 * t)
            })
            .collect::<String>(),
        scaled("s1", 100.0, 1.0),
        scaled("n1", 1.0, 3.28)
    );
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1", "n1"], "notes drop nothing");
    assert_eq!(
        line_event_kind(&issues),
        [
            (3, Some("s1"), "PathExceedsSpeeds"),
            (4, Some("n1"), "PathExceedsSpeeds")
        ],
        "{issues:#?}"
    );
    assert!(issues.iter().all(|i| i.problem.is_note()));
    let text = issues[0].to_string();
    assert!(
        text.contains("`x_ego`, `y_ego`: the positions carry it 2000.0 m"),
        "{text}"
    );
    assert!(text.contains("add up to only 20.0 m"), "{text}");
}

#[test]
fn events_of_one_or_two_frames_get_the_gap_and_impact_notes() {
    // c1: one frame, 0.5 s before its impact (no interval to allow for); s1: two frames 3 s
    // apart; n1: frames at 0, 0.1 and 3.1 s, a hole the upper median (3 s) hid; n2: two frames
    // 0.1 s apart, no note.
    let ev = format!(
        "{EV_HEADER}c1,crash,0,2,1.0,4.5,1.8,5,2\ns1,safe,0,3,,4.5,1.8,5,2\n\
         n1,safe,0,3.1,,4.5,1.8,5,2\nn2,safe,0,2,,4.5,1.8,5,2\n"
    );
    let fr = format!(
        "{FR_HEADER}{}{}{}{}{}{}{}{}",
        row("c1", 0.5),
        row("s1", 0.0),
        row("s1", 3.0),
        row("n1", 0.0),
        row("n1", 0.1),
        row("n1", 3.1),
        row("n2", 0.0),
        row("n2", 0.1)
    );
    let (set, issues, _d) = load_and_stream(&ev, &fr);
    assert_eq!(ids(&set), ["c1", "s1", "n1", "n2"], "notes drop nothing");
    assert_eq!(
        line_event_kind(&issues),
        [
            (2, Some("c1"), "ImpactAfterFrames"),
            (2, Some("c1"), "OneFrame"),
            (3, Some("s1"), "TwoFramesApart"),
            (4, Some("n1"), "FrameGap")
        ],
        "{issues:#?}"
    );
    assert!(issues.iter().all(|i| i.problem.is_note()));
    // A conflict event of one frame was kept without a word (a crash of 0-2 s with one frame).
    let one = issues
        .iter()
        .find(|i| i.problem.kind() == "OneFrame")
        .unwrap();
    assert!(
        one.to_string()
            .contains("the event (0 to 2 s) has one frame, at 0.5 s"),
        "{one}"
    );
}

/// `s` with `\u{0}` as the Windows-1252 byte of `é` (0xe9, invalid UTF-8 alone).
fn cp1252(s: &str) -> Vec<u8> {
    s.bytes().map(|b| if b == 0 { 0xe9 } else { b }).collect()
}

#[test]
fn a_short_row_of_an_id_in_another_encoding_drops_no_other_event() {
    // The row's id was read lossily where index and rejected ids are escaped: the short frame
    // row of `\xe901` was unattributed and dropped the event before it (`a`).
    let ev = format!(
        "{EV_HEADER}a,safe,0,2,,4.5,1.8,5,2\n\u{0}01,safe,0,2,,4.5,1.8,5,2\nb,safe,0,2,,4.5,1.8,5,2\n"
    );
    let short = rows("\u{0}01", 21).replacen(",0,0,10,0,1,0,-0.5,30,0,8,0,1,0\n", ",0\n", 1);
    let fr = format!("{FR_HEADER}{}{short}{}", rows("a", 21), rows("b", 21));
    let dir = folder("", "");
    std::fs::write(dir.path().join("events.csv"), cp1252(&ev)).unwrap();
    std::fs::write(dir.path().join("frames.csv"), cp1252(&fr)).unwrap();
    let (set, issues) = load_events(dir.path()).unwrap();
    assert_eq!(ids(&set), ["a", "b"]);
    assert_eq!(
        line_event_kind(&issues),
        [
            (3, Some(r"\xe901"), "NotUtf8"),
            (23, Some(r"\xe901"), "RowLength")
        ],
        "{issues:#?}"
    );
    let streamed = stream_events(dir.path(), true, |_, _| Ok::<_, EventsError>(())).unwrap();
    assert_eq!(streamed, issues);
}

#[test]
fn frames_in_another_encoding_than_events_csv_say_so() {
    // events.csv in UTF-8 (`é01`), frames.csv re-saved as Windows-1252 (`\xe901`).
    let ev = format!("{EV_HEADER}é01,safe,0,2,,4.5,1.8,5,2\ns1,safe,0,2,,4.5,1.8,5,2\n");
    let fr = format!("{FR_HEADER}{}{}", rows("\u{0}01", 21), rows("s1", 21));
    let dir = folder(&ev, "");
    std::fs::write(dir.path().join("frames.csv"), cp1252(&fr)).unwrap();
    let (set, issues) = load_events(dir.path()).unwrap();
    assert_eq!(ids(&set), ["s1"]);
    let unknown = issues
        .iter()
        .find(|i| i.problem.kind() == "UnknownEvent")
        .expect("an UnknownEvent");
    assert_eq!(unknown.event_id.as_deref(), Some(r"\xe901"));
    let text = unknown.to_string();
    assert!(
        text.contains("not valid UTF-8: frames.csv is in another encoding"),
        "{text}"
    );
}

#[test]
fn line_numbers_hold_after_rows_of_empty_fields() {
    // A bad value after spreadsheet blank rows, in a Unix and in a Windows file.
    let (ev, fr) = good();
    let fr = fr.replacen("\ns1,0.2,", "\n,,,\n,,,\ns1,0.2,", 1);
    let fr = fr.replacen("s1,0.2,2,", "s1,0.2,x,", 1);
    for crlf in [false, true] {
        let (ev, fr) = if crlf {
            (ev.replace('\n', "\r\n"), fr.replace('\n', "\r\n"))
        } else {
            (ev.clone(), fr.clone())
        };
        let (_, issues, _d) = load_and_stream(&ev, &fr);
        assert_eq!(
            line_event_kind(&issues),
            [(27, Some("s1"), "BadNumber")],
            "crlf {crlf}: {issues:#?}"
        );
    }
}
