//! `riskctl evaluate`, `plot` and the other commands that write a table, log or image: an output
//! that holds a model (blob or training checkpoint) is refused and left as it is, the load
//! problems say what each leaves out, and the trajectory figure's title says what it plots.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use riskscore_data::events::{write_events, Dims, Event, EventKind, EventSet, Frame};
use scorer_core::VehicleState;
mod common;
use common::{calm_following, riskctl, shipped_model, stderr, RISKCTL};

const DIMS: Dims = Dims {
    length_ego: 4.5,
    width_ego: 1.8,
    length_partner: 4.5,
    width_partner: 1.8,
};

/// A training checkpoint as far as any command can tell (its first bytes name the format).
const CHECKPOINT: &str =
    "{\n  \"format\": \"riskscore-checkpoint\",\n  \"version\": 3,\n  \"model\": {}\n}\n";

fn car(x: f32, vx: f32, acc: f32) -> VehicleState {
    VehicleState {
        x,
        vx,
        hx: 1.0,
        acc,
        length: 4.5,
        width: 1.8,
        ..Default::default()
    }
}

/// The ego at `v` m/s towards a stopped car; with `brake`, it brakes at 6 m/s^2 after 1 s and
/// stops 1 m short (a near-crash, endpoint at the stop), else it hits the car at 4 s (a crash).
fn conflict(id: &str, v: f32, brake: bool) -> Event {
    let a = 6.0_f32;
    let (t_impact, x_stopped) = if brake {
        let t_stop = 1.0 + v / a;
        (t_stop, v + v * v / (2.0 * a) + 1.0 + 4.5)
    } else {
        (4.0, 4.0 * v + 4.5)
    };
    let t_impact = (f64::from(t_impact) * 10.0).round() / 10.0;
    let n = (t_impact * 10.0).round() as usize;
    let frames = (0..=n)
        .map(|k| {
            let time = k as f64 / 10.0;
            let t = time as f32;
            let (x, speed, acc) = if brake && t > 1.0 {
                let s = (t - 1.0).min(v / a);
                (v + v * s - 0.5 * a * s * s, (v - a * s).max(0.0), -a)
            } else {
                (v * t, v, 0.0)
            };
            Frame {
                time,
                ego: car(x, speed, acc),
                partner: car(x_stopped, 0.0, 0.0),
            }
        })
        .collect();
    Event {
        id: id.to_owned(),
        kind: if brake {
            EventKind::NearCrash
        } else {
            EventKind::Crash
        },
        t_start: 0.0,
        t_end: t_impact,
        t_impact: Some(t_impact),
        dims: DIMS,
        frames,
    }
}

/// An event folder `dir/name`: `crashes` crashes, three near-crashes (`near0`..`near2`) and four
/// safe following events.
fn folder(dir: &Path, name: &str, crashes: usize) -> PathBuf {
    let mut events = Vec::new();
    for i in 0..crashes {
        events.push(conflict(&format!("crash{i}"), 10.0 + 2.0 * i as f32, false));
    }
    for i in 0..3 {
        events.push(conflict(&format!("near{i}"), 10.0 + 2.0 * i as f32, true));
    }
    for i in 0..4 {
        events.push(calm_following(
            format!("safe{i}"),
            12.0 + i as f32,
            25.0 + 3.0 * i as f32,
        ));
    }
    let out = dir.join(name);
    write_events(&out, &EventSet { events }).unwrap();
    out
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// A model blob and a training checkpoint stored under `names` in `dir` (blob first).
fn models_named(dir: &Path, names: [&str; 2]) -> [(PathBuf, &'static str); 2] {
    let blob = dir.join(names[0]);
    std::fs::copy(shipped_model("msra-default.rsk"), &blob).unwrap();
    let checkpoint = dir.join(names[1]);
    std::fs::write(&checkpoint, CHECKPOINT).unwrap();
    [
        (blob, "it is a model blob"),
        (checkpoint, "it is a training checkpoint"),
    ]
}

/// Runs `command(out)` for each model file and checks it is refused, named with `flag`, and
/// left byte for byte as it was.
fn refused_and_kept(flag: &str, models: &[(PathBuf, &str)], command: impl Fn(&Path) -> Output) {
    for (model, what) in models {
        let before = std::fs::read(model).unwrap();
        let o = command(model);
        let err = stderr(&o);
        assert_eq!(
            o.status.code(),
            Some(1),
            "{flag} {}: {err}",
            model.display()
        );
        assert!(
            err.contains(&format!("{flag} {}: {what}", model.display()))
                && err.contains("would replace the model")
                && err.contains("left as it is"),
            "{err}"
        );
        assert_eq!(
            std::fs::read(model).unwrap(),
            before,
            "{} changed",
            model.display()
        );
    }
}

/// `plot --out` replaced a model blob or a checkpoint that was not one of its inputs with the
/// image; both are refused now, and an earlier image is still replaced.
#[test]
fn plot_refuses_an_out_that_holds_a_model() {
    let dir = tempfile::tempdir().unwrap();
    let events = folder(dir.path(), "events", 2);
    let models = models_named(dir.path(), ["drl.svg", "drl.png"]);
    let plot = |out: &Path| {
        riskctl(&[
            "plot",
            "--events",
            p(&events),
            "--event",
            "crash0",
            "--out",
            p(out),
        ])
    };
    refused_and_kept("--out", &models, plot);
    let image = dir.path().join("old.svg");
    std::fs::write(&image, "an earlier image").unwrap();
    let o = plot(&image);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&image).unwrap().contains("<svg"));
}

/// `evaluate --out DIR` swaps the folder whole but carries its other files over, so a model
/// there under another name was never lost; one stored under a result file's name was replaced.
/// That is refused now (the folder left as it was); a link of that name is replaced itself and
/// the model it points to stays.
#[test]
fn evaluate_refuses_a_result_file_name_that_holds_a_model_and_keeps_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let events = folder(dir.path(), "events", 3);
    let out = dir.path().join("report");
    std::fs::create_dir(&out).unwrap();
    let evaluate = || riskctl(&["evaluate", "--events", p(&events), "--out", p(&out)]);
    // Result names: a table, a figure.
    let models = models_named(&out, ["roc.png", "results.json"]);
    // results.json comes before roc.png: each is named in turn.
    for (model, what) in models.iter().rev() {
        let before = std::fs::read(model).unwrap();
        let o = evaluate();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(
            err.contains(&format!("--out {}: {what}", model.display()))
                && err.contains("left as it is"),
            "{err}"
        );
        assert_eq!(std::fs::read(model).unwrap(), before);
        assert_eq!(std::fs::read_dir(&out).unwrap().count(), models.len());
        std::fs::rename(
            model,
            out.join("kept").with_extension(model.extension().unwrap()),
        )
        .unwrap();
    }
    // Now under other names, with a link named results.csv to a checkpoint beside the folder.
    let outside = dir.path().join("ckpt.json");
    std::fs::write(&outside, CHECKPOINT).unwrap();
    std::os::unix::fs::symlink(&outside, out.join("results.csv")).unwrap();
    let o = evaluate();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(out.join("kept.png")).unwrap(),
        std::fs::read(shipped_model("msra-default.rsk")).unwrap()
    );
    assert_eq!(
        std::fs::read_to_string(out.join("kept.json")).unwrap(),
        CHECKPOINT
    );
    assert_eq!(std::fs::read_to_string(&outside).unwrap(), CHECKPOINT);
    assert!(std::fs::read_to_string(out.join("results.csv"))
        .unwrap()
        .starts_with("method,"));
}

/// The other commands that write a non-model file at a name given: `events-to-candump --out`,
/// `ssm --output`, `benchmark domains --sequences-out`.
#[test]
fn log_table_and_sequence_outputs_refuse_a_model() {
    let dir = tempfile::tempdir().unwrap();
    let events = folder(dir.path(), "events", 2);
    let models = models_named(dir.path(), ["drl.rsk", "msra.json"]);
    refused_and_kept("--out", &models, |out| {
        riskctl(&["events-to-candump", "--events", p(&events), "--out", p(out)])
    });
    let pairs = dir.path().join("pairs.csv");
    std::fs::write(
        &pairs,
        "x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,\
         x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j\n\
         0,0,10,0,1,0,0,4.5,1.8,20,0,5,0,1,0,0,4.5,1.8\n",
    )
    .unwrap();
    refused_and_kept("--output", &models, |out| {
        riskctl(&["ssm", "--input", p(&pairs), "--output", p(out)])
    });
    // Refused before any work; unrefused, the whole benchmark would run before the file is
    // replaced, so a run still going after a minute has not refused it.
    let bench = dir.path().join("bench");
    refused_and_kept("--sequences-out", &models, |out| {
        riskctl_within(
            &[
                "benchmark",
                "domains",
                "--out",
                p(&bench),
                "--sequences-out",
                p(out),
                "--quiet",
            ],
            Duration::from_secs(60),
        )
    });
    assert!(!bench.exists(), "benchmark started");
}

/// Runs `riskctl` with `args`; one still running after `limit` is killed and fails the test.
fn riskctl_within(args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(RISKCTL)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run riskctl");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("riskctl {} still running after {limit:?}", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Frames of an event id that events.csv lacks drop only those rows, yet the listing said
/// "those events are skipped" for them; each problem now says what it leaves out.
#[test]
fn load_problems_say_whether_an_event_or_only_rows_are_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let events = folder(dir.path(), "events", 3);
    let frames_csv = events.join("frames.csv");
    let frames = std::fs::read_to_string(&frames_csv).unwrap();
    let row = frames.lines().nth(1).unwrap();
    let ghost = format!("ghost{}", &row[row.find(',').unwrap()..]);
    std::fs::write(&frames_csv, format!("{frames}{ghost}\n{ghost}\n")).unwrap();
    let events_csv = events.join("events.csv");
    let table = std::fs::read_to_string(&events_csv).unwrap();
    let mut bad: Vec<&str> = table.lines().nth(1).unwrap().split(',').collect();
    bad[0] = "bad";
    bad[1] = "bogus";
    std::fs::write(&events_csv, format!("{table}{}\n", bad.join(","))).unwrap();

    let o = riskctl(&["evaluate", "--events", p(&events), "--skip-bad-events"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("riskctl: 2 problem(s) in the event folder:\n"),
        "{err}"
    );
    assert!(!err.contains("those events are skipped"), "{err}");
    let line = |needle: &str| {
        err.lines()
            .find(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("no line with {needle:?}: {err}"))
            .to_owned()
    };
    assert!(
        line("event `ghost`").ends_with(
            "2 frame(s) for an event that is not in events.csv \
             (only these rows are dropped: no event is skipped)"
        ),
        "{err}"
    );
    assert!(
        line("unknown kind `bogus`").ends_with("(the event is skipped)"),
        "{err}"
    );
    // The unknown rows leave every event in: 3 crashes, 3 near-crashes, 4 safe.
    let o = riskctl(&[
        "evaluate",
        "--events",
        p(&events),
        "--skip-bad-events",
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        json["events"],
        serde_json::json!({"crash": 3, "near_crash": 3, "safe": 4})
    );
}

/// The trajectory figure was titled "of crash events" though `--trajectory-event` draws
/// near-crash sequences too; its title and the message when nothing is drawn say what is.
#[test]
fn the_trajectory_figure_says_it_plots_crash_or_near_crash_events() {
    let dir = tempfile::tempdir().unwrap();
    let events = folder(dir.path(), "events", 0);
    let out = dir.path().join("report");
    // No crash: by default nothing is drawn, and the message says why and how to draw one.
    let o = riskctl(&["evaluate", "--events", p(&events), "--out", p(&out)]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("no crash sequence, so no trajectory plot")
            && err.contains("--trajectory-event ID draws a crash or near-crash one"),
        "{err}"
    );
    assert!(!out.join("trajectories.svg").exists());
    // A near-crash asked for is drawn under a title that covers it.
    let o = riskctl(&[
        "evaluate",
        "--events",
        p(&events),
        "--out",
        p(&out),
        "--trajectory-event",
        "near1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let svg = std::fs::read_to_string(out.join("trajectories.svg")).unwrap();
    assert!(
        svg.contains("Risk trajectories of crash or near-crash events (each method as its percentile over all frames)"),
        "title not found"
    );
    assert!(svg.contains("event near1"));
    assert!(!svg.contains("of crash events"));
}
