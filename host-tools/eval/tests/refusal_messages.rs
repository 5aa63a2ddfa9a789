//! The refusal of an event folder with load problems says what those problems leave out: their
//! events, or (frame rows of an event id that events.csv lacks) no event but those rows. It used
//! to say "would leave their events out" for every mix, also when no event was left out.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::path::Path;

use riskscore_data::events::{PrepareConfig, KEPT_PER_KIND};
use riskscore_data::sim::{simulate_to_dir, SimConfig};
use riskscore_eval::streaming::{
    evaluate_folder, BadRowsWording, FolderEvaluation, FolderRefusal, LeftOut, ValidEvents,
};
use riskscore_eval::Method;

const EVENTS: usize = 12;

fn simulated() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let cfg = SimConfig {
        seed: 5,
        events: EVENTS,
        threads: 1,
        ..SimConfig::default()
    };
    simulate_to_dir(dir.path(), &cfg).unwrap();
    dir
}

/// Appends `ids.len()` frame rows, each a copy of the first frame under one of `ids`.
fn add_frames_of_unknown_ids(dir: &Path, ids: &[String]) {
    let path = dir.join("frames.csv");
    let mut text = std::fs::read_to_string(&path).unwrap();
    let first = text.lines().nth(1).unwrap().to_owned();
    let rest = &first[first.find(',').unwrap()..];
    for id in ids {
        text.push_str(&format!("{id}{rest}\n"));
    }
    std::fs::write(&path, text).unwrap();
}

/// Gives the first event an unknown kind: that event is skipped.
fn skip_the_first_event(dir: &Path) {
    let path = dir.join("events.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let first = text.lines().nth(1).unwrap().to_owned();
    let mut fields: Vec<&str> = first.split(',').collect();
    fields[1] = "bogus";
    std::fs::write(&path, text.replacen(&first, &fields.join(","), 1)).unwrap();
}

fn evaluated(dir: &Path) -> FolderEvaluation {
    evaluate_folder(dir, &Method::baselines(), PrepareConfig::default(), 2).unwrap()
}

fn refusal(folder: &FolderEvaluation) -> FolderRefusal {
    let refusal = folder.check(false).unwrap_err();
    assert!(folder.check(true).is_ok(), "--skip-bad-events evaluates it");
    refusal
}

const PYTHON: BadRowsWording<'static> = BadRowsWording {
    listed: "below",
    left_out_of: "metrics",
    skip: Some("skip_bad_events=True"),
};

const CALIBRATE: BadRowsWording<'static> = BadRowsWording {
    listed: "above",
    left_out_of: "calibration",
    skip: None,
};

fn message(refusal: FolderRefusal, wording: BadRowsWording<'_>) -> String {
    match refusal {
        FolderRefusal::BadRows { valid_events } => {
            FolderRefusal::bad_rows_message(valid_events, wording)
        }
        other => panic!("not a bad-rows refusal: {other:?}"),
    }
}

#[test]
fn only_rows_of_unknown_ids_leave_no_event_out_and_the_refusal_says_so() {
    let dir = simulated();
    // More ids than the loader lists one by one: the rest are counted, still rows only.
    let ids: Vec<String> = (0..KEPT_PER_KIND + 3)
        .map(|n| format!("ghost{n}"))
        .collect();
    add_frames_of_unknown_ids(dir.path(), &ids);
    let folder = evaluated(dir.path());
    assert_eq!(folder.events, EVENTS, "every event of events.csv is valid");
    assert!(folder
        .load_issues
        .iter()
        .any(|i| i.problem.kind() == "MoreOfKind"));
    let refusal = refusal(&folder);
    assert_eq!(
        refusal,
        FolderRefusal::BadRows {
            valid_events: ValidEvents {
                count: EVENTS,
                left_out: LeftOut::UnknownIdRows,
            }
        }
    );
    assert_eq!(
        refusal.to_string(),
        format!(
            "the problems listed above are frame rows of event ids that events.csv lacks: no \
             event would be left out of the metrics, but those rows would be dropped; add their \
             events to events.csv or remove those rows, or pass --skip-bad-events to evaluate \
             the {EVENTS} events without them"
        )
    );
    assert_eq!(
        message(refusal, PYTHON),
        format!(
            "the problems listed below are frame rows of event ids that events.csv lacks: no \
             event would be left out of the metrics, but those rows would be dropped; add their \
             events to events.csv or remove those rows, or pass skip_bad_events=True to \
             evaluate the {EVENTS} events without them"
        )
    );
    assert_eq!(
        message(refusal, CALIBRATE),
        "the problems listed above are frame rows of event ids that events.csv lacks: no event \
         would be left out of the calibration, but those rows would be dropped; add their events \
         to events.csv or remove those rows"
    );
}

#[test]
fn problems_that_skip_events_say_their_events_are_left_out() {
    let dir = simulated();
    skip_the_first_event(dir.path());
    let folder = evaluated(dir.path());
    let valid = EVENTS - 1;
    assert_eq!(folder.events, valid);
    let refusal = refusal(&folder);
    assert_eq!(
        refusal,
        FolderRefusal::BadRows {
            valid_events: ValidEvents {
                count: valid,
                left_out: LeftOut::Events,
            }
        }
    );
    assert_eq!(
        refusal.to_string(),
        format!(
            "the problems listed above would leave their events out of the metrics; fix those \
             rows, or pass --skip-bad-events to evaluate the {valid} valid events"
        )
    );
    assert_eq!(
        message(refusal, CALIBRATE),
        format!(
            "the problems listed above would leave their events out of the calibration; fix \
             those rows (or write the {valid} valid events to a folder of their own)"
        )
    );
}

#[test]
fn a_mix_says_which_problems_leave_events_out_and_which_only_rows() {
    let dir = simulated();
    skip_the_first_event(dir.path());
    add_frames_of_unknown_ids(dir.path(), &["ghost".to_owned()]);
    let folder = evaluated(dir.path());
    let valid = EVENTS - 1;
    let refusal = refusal(&folder);
    assert_eq!(
        refusal,
        FolderRefusal::BadRows {
            valid_events: ValidEvents {
                count: valid,
                left_out: LeftOut::EventsAndUnknownIdRows,
            }
        }
    );
    assert_eq!(
        refusal.to_string(),
        format!(
            "the problems listed above would leave their events out of the metrics (except the \
             frame rows of event ids that events.csv lacks: only those rows are dropped); fix \
             those rows, or pass --skip-bad-events to evaluate the {valid} valid events"
        )
    );
    assert_eq!(
        message(refusal, PYTHON),
        format!(
            "the problems listed below would leave their events out of the metrics (except the \
             frame rows of event ids that events.csv lacks: only those rows are dropped); fix \
             those rows, or pass skip_bad_events=True to evaluate the {valid} valid events"
        )
    );
}

#[test]
fn notes_alone_are_not_refused() {
    let dir = simulated();
    // No newline at the end of frames.csv: a note, nothing is left out.
    let path = dir.path().join("frames.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, text.trim_end()).unwrap();
    let folder = evaluated(dir.path());
    assert!(folder.load_issues.iter().all(|i| i.problem.is_note()));
    assert!(!folder.load_issues.is_empty());
    assert_eq!(LeftOut::of(&folder.load_issues), None);
    assert!(folder.check(false).is_ok());
}
