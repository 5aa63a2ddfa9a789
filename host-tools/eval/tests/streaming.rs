//! Evaluating and scoring an event folder one event at a time: the streamed loader hands on exactly
//! the events and issues of the whole-folder loader, the streamed evaluation gives bit for bit the
//! report of the in-memory one, and folders that cannot be streamed are detected and read whole.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::path::Path;

use riskscore_data::events::{
    load_events, prepare_sequences, stream_events, Event, EventsError, LoadIssue, PrepareConfig,
};
use riskscore_data::sim::{simulate_to_dir, SimConfig};
use riskscore_eval::bundle::ReportFile;
use riskscore_eval::outputs::result_files;
use riskscore_eval::plots::{default_trajectory_events, trajectory_panels};
use riskscore_eval::sketch::DEFAULT_CAPACITY;
use riskscore_eval::streaming::{
    evaluate_folder, evaluate_folder_with_trajectories, Trajectories, TrajectoryEvents,
    TrajectoryRequest,
};
use riskscore_eval::{evaluate_methods, observe, Method};

/// A simulated folder (grouped frames, events.csv order), as `riskctl simulate` writes it.
fn simulated(events: usize) -> tempfile::TempDir {
    simulated_with(SimConfig {
        seed: 5,
        events,
        threads: 1,
        ..SimConfig::default()
    })
}

fn simulated_with(cfg: SimConfig) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    simulate_to_dir(dir.path(), &cfg).unwrap();
    dir
}

fn read(dir: &Path, name: &str) -> Vec<String> {
    std::fs::read_to_string(dir.join(name))
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect()
}

fn write(dir: &Path, name: &str, lines: &[String]) {
    std::fs::write(dir.join(name), lines.join("\n") + "\n").unwrap();
}

/// Replaces field `col` of the first frames.csv row of event `id` at position `nth` among its rows.
fn spoil_frame(lines: &mut [String], id: &str, nth: usize, col: usize, value: &str) {
    let row = lines
        .iter_mut()
        .filter(|l| l.starts_with(&format!("{id},")))
        .nth(nth)
        .unwrap();
    let mut fields: Vec<&str> = row.split(',').collect();
    fields[col] = value;
    *row = fields.join(",");
}

fn streamed(
    dir: &Path,
    in_events_order: bool,
) -> Result<(Vec<Event>, Vec<LoadIssue>), EventsError> {
    let mut events = Vec::new();
    let issues = stream_events(dir, in_events_order, |position, event| {
        events.push((position, event));
        Ok::<(), EventsError>(())
    })?;
    events.sort_by_key(|(position, _)| *position);
    Ok((events.into_iter().map(|(_, e)| e).collect(), issues))
}

#[test]
fn streamed_events_and_issues_equal_the_whole_folder_load() {
    let dir = simulated(40);
    let ids: Vec<String> = read(dir.path(), "events.csv")[1..]
        .iter()
        .map(|l| l.split(',').next().unwrap().to_owned())
        .collect();
    let mut frames = read(dir.path(), "frames.csv");
    // A bad number, a frame out of order, a row of the wrong length, frames of an unknown event.
    spoil_frame(&mut frames, &ids[3], 5, 2, "x");
    spoil_frame(&mut frames, &ids[7], 2, 1, "0.05");
    let short = frames
        .iter()
        .position(|l| l.starts_with(&format!("{},", ids[9])))
        .unwrap();
    frames[short] = format!("{},1.0,2.0", ids[9]);
    frames.insert(1, "nobody,0,1,2,3,4,1,0,0,5,6,7,8,1,0".into());
    // An event whose frames are all gone, and one whose impact comes before its first frame.
    frames.retain(|l| !l.starts_with(&format!("{},", ids[12])));
    write(dir.path(), "frames.csv", &frames);
    let mut events = read(dir.path(), "events.csv");
    let row = events.iter().position(|l| {
        l.starts_with(&format!("{},crash,", ids[20]))
            || l.starts_with(&format!("{},near_crash,", ids[20]))
    });
    if let Some(row) = row {
        let mut f: Vec<String> = events[row].split(',').map(str::to_owned).collect();
        f[2] = "-50".into(); // t_start
        f[4] = "-40".into(); // t_impact, before the first frame at >= 0
        events[row] = f.join(",");
    }
    write(dir.path(), "events.csv", &events);

    let (whole, whole_issues) = load_events(dir.path()).unwrap();
    let (events, issues) = streamed(dir.path(), true).unwrap();
    assert!(whole.len() < 40 && whole.len() > 30, "{}", whole.len());
    assert_eq!(events, whole.events);
    assert_eq!(issues, whole_issues);
    let kinds: Vec<&str> = issues.iter().map(|i| i.problem.kind()).collect();
    for kind in [
        "BadNumber",
        "UnsortedTime",
        "RowLength",
        "UnknownEvent",
        "NoFrames",
    ] {
        assert!(kinds.contains(&kind), "{kind} missing from {kinds:?}");
    }
    assert_eq!(
        row.is_some(),
        kinds.contains(&"ImpactBeforeFrames"),
        "{kinds:?}"
    );
}

#[test]
fn frames_split_or_out_of_order_are_not_streamed() {
    let dir = simulated(12);
    let frames = read(dir.path(), "frames.csv");
    let id_of = |l: &String| l.split(',').next().unwrap().to_owned();
    let first = id_of(&frames[1]);
    let run: Vec<String> = frames[1..]
        .iter()
        .filter(|l| id_of(l) == first)
        .cloned()
        .collect();
    let rest: Vec<String> = frames[1..]
        .iter()
        .filter(|l| id_of(l) != first)
        .cloned()
        .collect();

    // The first event's frames after the others': readable, even streamed without order...
    let mut moved = vec![frames[0].clone()];
    moved.extend(rest.iter().cloned());
    moved.extend(run.iter().cloned());
    write(dir.path(), "frames.csv", &moved);
    let (whole, whole_issues) = load_events(dir.path()).unwrap();
    let (events, issues) = streamed(dir.path(), false).unwrap();
    assert_eq!((events, issues), (whole.events, whole_issues));
    // ... but not in events.csv order.
    match streamed(dir.path(), true) {
        Err(EventsError::NotStreamable {
            line,
            event_id,
            reason,
            ..
        }) => {
            assert_eq!(event_id, first);
            assert_eq!(line, rest.len() as u64 + 2);
            // The first event of events.csv comes last in frames.csv (the text said "before
            // those of an event listed earlier").
            assert_eq!(
                reason,
                "its frames come after those of an event listed later in events.csv"
            );
        }
        other => panic!("expected NotStreamable, got {other:?}"),
    }

    // The first event's last frame at the very end: two runs of one event.
    let mut split = vec![frames[0].clone()];
    split.extend(run[..run.len() - 1].iter().cloned());
    split.extend(rest.iter().cloned());
    split.push(run[run.len() - 1].clone());
    write(dir.path(), "frames.csv", &split);
    let err = streamed(dir.path(), false).unwrap_err();
    assert!(
        err.to_string().contains("not one run of consecutive rows"),
        "{err}"
    );
    assert!(load_events(dir.path()).unwrap().1.is_empty());
}

/// The in-memory evaluation of `riskctl evaluate` before streaming, as JSON.
fn in_memory_report(dir: &Path, methods: &[Method<'_>]) -> String {
    let (set, _) = load_events(dir).unwrap();
    let (sequences, _) = prepare_sequences(&set, &PrepareConfig::default());
    let (report, _) = evaluate_methods(&observe(&sequences), methods).unwrap();
    report.to_json_string()
}

/// The shipped DRL and MSRA model files.
fn model_files() -> Vec<Vec<u8>> {
    ["drl-default.rsk", "msra-default.rsk"]
        .iter()
        .map(|m| {
            std::fs::read(
                Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../../models")
                    .join(m),
            )
            .unwrap()
        })
        .collect()
}

/// The models of `files` and the three baselines.
fn methods_of(files: &[Vec<u8>]) -> Vec<Method<'_>> {
    let mut methods: Vec<Method<'_>> = files
        .iter()
        .zip(["DRL", "MSRA"])
        .map(|(bytes, name)| Method {
            name: name.into(),
            scorer: riskscore_eval::Scorer::Model(scorer_core::model::decode(bytes).unwrap()),
        })
        .collect();
    methods.extend(Method::baselines());
    methods
}

#[test]
fn streamed_evaluation_is_bit_identical_to_the_in_memory_one() {
    let dir = simulated(150);
    let files = model_files();
    let methods = methods_of(&files);
    let expected = in_memory_report(dir.path(), &methods);
    for workers in [1, 3] {
        let got = evaluate_folder(dir.path(), &methods, PrepareConfig::default(), workers).unwrap();
        assert!(got.streamed);
        assert_eq!(got.report.to_json_string(), expected, "{workers} workers");
        assert_eq!(got.sequences, got.events - got.prepare_issues.len());
    }

    // Frames of one event split into two runs: read whole, same report.
    let mut frames = read(dir.path(), "frames.csv");
    let last = frames.remove(1);
    frames.push(last);
    write(dir.path(), "frames.csv", &frames);
    let got = evaluate_folder(dir.path(), &methods, PrepareConfig::default(), 2).unwrap();
    assert!(!got.streamed);
    assert_eq!(
        got.report.to_json_string(),
        in_memory_report(dir.path(), &methods)
    );
}

/// Every `riskctl evaluate --out` file as the whole-folder path rendered them before streaming:
/// all sequences scored in memory, each trajectory percentile ranked among all scores kept.
fn whole_folder_files(
    dir: &Path,
    methods: &[Method<'_>],
    ids: Option<&[String]>,
) -> Vec<ReportFile> {
    let (set, _) = load_events(dir).unwrap();
    let (sequences, _) = prepare_sequences(&set, &PrepareConfig::default());
    let (report, runs) = evaluate_methods(&observe(&sequences), methods).unwrap();
    let curves: Vec<_> = runs
        .iter()
        .map(|r| (r.name.clone(), r.curve.clone()))
        .collect();
    let scored: Vec<_> = runs
        .iter()
        .map(|r| (r.name.clone(), r.scored.clone()))
        .collect();
    let ids = ids.map_or_else(
        || default_trajectory_events(&scored[0].1, 3),
        <[String]>::to_vec,
    );
    let (json, markdown) = (report.to_json_string() + "\n", report.to_markdown());
    result_files(
        &report,
        json,
        markdown,
        &curves,
        &trajectory_panels(&scored, &ids),
    )
    .unwrap()
    .files
}

fn streamed_files(
    dir: &Path,
    methods: &[Method<'_>],
    workers: usize,
    request: &TrajectoryRequest,
) -> (bool, f64, Vec<ReportFile>) {
    let folder = evaluate_folder_with_trajectories(
        dir,
        methods,
        PrepareConfig::default(),
        workers,
        Some(request),
    )
    .unwrap();
    let mut trajectories = folder.trajectories.unwrap();
    assert!(
        trajectories.unknown.is_empty(),
        "{:?}",
        trajectories.unknown
    );
    let (json, markdown) = (
        folder.report.to_json_string() + "\n",
        folder.report.to_markdown(),
    );
    let files = result_files(
        &folder.report,
        json,
        markdown,
        &folder.curves,
        &trajectories.panels(),
    )
    .unwrap();
    (
        folder.streamed,
        trajectories.percentile_error(),
        files.files,
    )
}

/// What the streamed evaluation (2 workers) gathers for the trajectory plot.
fn streamed_trajectories(
    dir: &Path,
    methods: &[Method<'_>],
    request: &TrajectoryRequest,
) -> Trajectories {
    evaluate_folder_with_trajectories(dir, methods, PrepareConfig::default(), 2, Some(request))
        .unwrap()
        .trajectories
        .unwrap()
}

fn assert_same_files(got: &[ReportFile], expected: &[ReportFile], what: &str) {
    let names = |f: &[ReportFile]| f.iter().map(|f| f.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(got), names(expected), "{what}");
    assert_eq!(got.len(), 10, "{what}: tables, ROC, PR and trajectories");
    for (g, e) in got.iter().zip(expected) {
        assert!(g.bytes == e.bytes, "{what}: {} differs", g.name);
    }
}

#[test]
fn streamed_out_files_are_byte_identical_to_the_whole_folder_ones() {
    // The default folder of `riskctl simulate` / the demo (310 events, seed 1).
    let dir = simulated_with(SimConfig {
        threads: 1,
        ..SimConfig::default()
    });
    let files = model_files();
    let methods = methods_of(&files);
    let first_crashes = TrajectoryRequest {
        events: TrajectoryEvents::FirstCrashes(3),
        sketch_capacity: DEFAULT_CAPACITY,
    };
    let expected = whole_folder_files(dir.path(), &methods, None);
    for workers in [1, 2] {
        let (streamed, error, got) = streamed_files(dir.path(), &methods, workers, &first_crashes);
        assert!(streamed);
        assert_eq!(error, 0.0, "the default folder fits the sketch exactly");
        assert_same_files(&got, &expected, &format!("{workers} workers"));
    }

    // Named events, in the order given (a later one first).
    let conflicts: Vec<String> = read(dir.path(), "events.csv")[1..]
        .iter()
        .filter(|l| l.contains(",crash,") || l.contains(",near_crash,"))
        .map(|l| l.split(',').next().unwrap().to_owned())
        .collect();
    let named = vec![conflicts[conflicts.len() - 1].clone(), conflicts[1].clone()];
    let request = TrajectoryRequest {
        events: TrajectoryEvents::Named(named.clone()),
        sketch_capacity: DEFAULT_CAPACITY,
    };
    let (_, _, got) = streamed_files(dir.path(), &methods, 2, &request);
    assert_same_files(
        &got,
        &whole_folder_files(dir.path(), &methods, Some(&named)),
        "named",
    );

    // An unknown event is reported, not drawn.
    let request = TrajectoryRequest {
        events: TrajectoryEvents::Named(vec!["no-such-event".into()]),
        sketch_capacity: DEFAULT_CAPACITY,
    };
    assert_eq!(
        streamed_trajectories(dir.path(), &methods, &request).unknown,
        ["no-such-event"]
    );

    // Frames not grouped by event: read whole, and the same files.
    let mut frames = read(dir.path(), "frames.csv");
    let last = frames.remove(1);
    frames.push(last);
    write(dir.path(), "frames.csv", &frames);
    let (streamed, error, got) = streamed_files(
        dir.path(),
        &methods,
        2,
        &TrajectoryRequest {
            sketch_capacity: 2,
            ..first_crashes
        },
    );
    assert!(!streamed);
    assert_eq!(error, 0.0, "a folder read whole is ranked exactly");
    assert_same_files(
        &got,
        &whole_folder_files(dir.path(), &methods, None),
        "read whole",
    );
}

#[test]
fn summarised_trajectory_percentiles_stay_within_the_stated_error() {
    let dir = simulated(60);
    let files = model_files();
    let methods = methods_of(&files);
    let (set, _) = load_events(dir.path()).unwrap();
    let (sequences, _) = prepare_sequences(&set, &PrepareConfig::default());
    let (_, runs) = evaluate_methods(&observe(&sequences), &methods).unwrap();
    let scored: Vec<_> = runs
        .iter()
        .map(|r| (r.name.clone(), r.scored.clone()))
        .collect();
    let ids = default_trajectory_events(&scored[0].1, 3);
    assert!(!ids.is_empty());
    let exact = trajectory_panels(&scored, &ids);

    // A tiny sketch, so that the percentile scale is summarised many times over.
    let request = TrajectoryRequest {
        events: TrajectoryEvents::FirstCrashes(3),
        sketch_capacity: 64,
    };
    let mut trajectories = streamed_trajectories(dir.path(), &methods, &request);
    let error = trajectories.percentile_error();
    assert!(error > 0.0 && error < 0.25, "{error}");
    assert_eq!(trajectories.event_ids, ids);
    let got = trajectories.panels();
    let mut worst = 0.0f64;
    for (g, e) in got.iter().zip(&exact) {
        assert_eq!(g.event_id, e.event_id);
        for ((gn, gl), (en, el)) in g.lines.iter().zip(&e.lines) {
            assert_eq!(gn, en);
            assert_eq!(gl.len(), el.len());
            for (gp, ep) in gl.iter().zip(el) {
                assert_eq!(gp.0, ep.0, "times are the frames' own");
                assert_eq!(gp.1.is_nan(), ep.1.is_nan(), "gaps are the same frames");
                if gp.1.is_nan() {
                    continue;
                }
                worst = worst.max((gp.1 - ep.1).abs());
            }
        }
    }
    assert!(worst <= error + 1e-12, "{worst} > stated {error}");
    assert!(worst > 0.0, "the summary is not exact at this size");
}
