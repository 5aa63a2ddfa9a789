//! `riskctl evaluate` end to end on a small hand-built event folder: the JSON schema, agreement
//! with the library, the output files, and clear errors for bad models and folders.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::float_cmp)]

use std::path::{Path, PathBuf};

use riskscore_data::events::{
    load_events, prepare_sequences, write_events, Dims, Event, EventKind, EventSet, Frame,
    PrepareConfig,
};
use riskscore_eval::{evaluate_methods, observe, Method, Scorer};
use scorer_core::model::{encode, encoded_len, BoundedVec, Model};
use scorer_core::msra::{MsraModel, MsraTerm};
use scorer_core::{SurrogateKind, VehicleState};
mod common;
use common::riskctl;

const DIMS: Dims = Dims {
    length_ego: 4.5,
    width_ego: 1.8,
    length_partner: 4.8,
    width_partner: 1.9,
};

fn car(x: f64, vx: f64, acc: f64, length: f32, width: f32) -> VehicleState {
    VehicleState {
        x: x as f32,
        y: 0.0,
        vx: vx as f32,
        vy: 0.0,
        hx: 1.0,
        hy: 0.0,
        acc: acc as f32,
        length,
        width,
    }
}

/// Ego at `v` m/s and a partner `gap(t)` metres (bumper to bumper) ahead moving at `v_sur(t)`.
fn event(
    id: String,
    kind: EventKind,
    t_end: f64,
    t_impact: Option<f64>,
    ego: impl Fn(f64) -> (f64, f64, f64),
    sur: impl Fn(f64) -> (f64, f64),
) -> Event {
    let n = (t_end * 10.0).round() as usize;
    let frames = (0..=n)
        .map(|k| {
            let time = k as f64 / 10.0;
            let (xe, ve, ae) = ego(time);
            let (xs, vs) = sur(time);
            Frame {
                time,
                ego: car(xe, ve, ae, DIMS.length_ego, DIMS.width_ego),
                partner: car(xs, vs, 0.0, DIMS.length_partner, DIMS.width_partner),
            }
        })
        .collect();
    Event {
        id,
        kind,
        t_start: 0.0,
        t_end,
        t_impact,
        dims: DIMS,
        frames,
    }
}

/// 6 rear-end crashes into a stopped car (impact at 5 s), 4 near-crashes braking to a stop 1 m
/// short, 8 safe car-following events at equal speed.
fn event_set() -> EventSet {
    let half = f64::from(DIMS.length_ego + DIMS.length_partner) / 2.0;
    let mut events = Vec::new();
    for i in 0..6 {
        let v = 8.0 + 2.0 * f64::from(i);
        let x_sur = 5.0 * v + half; // contact at t = 5 s
        events.push(event(
            format!("crash{i}"),
            EventKind::Crash,
            5.5,
            Some(5.0),
            move |t| (v * t, v, 0.0),
            move |_| (x_sur, 0.0),
        ));
    }
    for i in 0..4 {
        let v = 10.0 + 2.0 * f64::from(i);
        let a = 6.0;
        let t_stop = v / a;
        let x_sur = v * v / (2.0 * a) + 1.0 + half + 10.0; // stops 1 m short after 10 m cruising
        let t_cruise = 10.0 / v;
        let t_end = (t_cruise + t_stop + 0.5).min(6.0);
        events.push(event(
            format!("near{i}"),
            EventKind::NearCrash,
            (t_end * 10.0).floor() / 10.0,
            Some(((t_cruise + t_stop) * 10.0).round() / 10.0),
            move |t| {
                if t <= t_cruise {
                    (v * t, v, 0.0)
                } else {
                    let s = (t - t_cruise).min(t_stop);
                    (10.0 + v * s - 0.5 * a * s * s, (v - a * s).max(0.0), -a)
                }
            },
            move |_| (x_sur, 0.0),
        ));
    }
    for i in 0..8 {
        let v = 12.0 + f64::from(i);
        let gap = 30.0 + 3.0 * f64::from(i);
        events.push(event(
            format!("safe{i}"),
            EventKind::Safe,
            4.0,
            None,
            move |t| (v * t, v, 0.0),
            move |t| (v * t + gap + half, v),
        ));
    }
    EventSet { events }
}

fn msra_ttc_blob(a: f32) -> Vec<u8> {
    let term = MsraTerm {
        kind: SurrogateKind::Ttc2d,
        weight: 1.0,
        a,
        b: 2.0,
        lo: 0.0,
        hi: 10.0,
    };
    let model = Model::Msra(MsraModel {
        terms: BoundedVec::from_slice(&[term]).unwrap(),
        gssm: None,
    });
    let mut buf = vec![0u8; encoded_len(&model).unwrap()];
    let n = encode(&model, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

struct Fixture {
    _dir: tempfile::TempDir,
    events: PathBuf,
    model: PathBuf,
    root: PathBuf,
}

fn fixture() -> Fixture {
    let dir = tempfile::tempdir().unwrap();
    let events = dir.path().join("events");
    write_events(&events, &event_set()).unwrap();
    let model = dir.path().join("msra-ttc.rsk");
    std::fs::write(&model, msra_ttc_blob(-1.0)).unwrap();
    Fixture {
        root: dir.path().to_path_buf(),
        _dir: dir,
        events,
        model,
    }
}

/// The folder's evaluation sequences with the core's observations, as `evaluate` sees them.
fn observed_sequences(dir: &Path) -> Vec<riskscore_eval::ObservedSequence> {
    let (set, _) = load_events(dir).unwrap();
    let (seqs, _) = prepare_sequences(&set, &PrepareConfig::default());
    observe(&seqs)
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

#[test]
fn json_output_follows_the_schema_and_matches_the_library() {
    let fx = fixture();
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&fx.model),
        "--events",
        p(&fx.events),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        v["events"],
        serde_json::json!({"crash": 6, "near_crash": 4, "safe": 8})
    );
    let names: Vec<&str> = v["methods"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["MSRA", "TTC2D", "TAdv", "EI"]);
    for m in v["methods"].as_array().unwrap() {
        let mut keys: Vec<&str> = m.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        assert_eq!(
            keys,
            ["A_ROC_80", "A_ROC_90", "P_PRC_80", "P_PRC_90", "mTTI_90", "name"]
        );
    }
    // Every conflict has a finite TTC and every safe pair none: TTC2D separates perfectly.
    let ttc = &v["methods"][1];
    assert_eq!(ttc["A_ROC_90"], 100.0);
    assert_eq!(ttc["P_PRC_90"], 100.0);
    let mtti = ttc["mTTI_90"].as_f64().unwrap();
    assert!(mtti > 0.0 && mtti <= 4.5 + 1e-9, "mTTI {mtti}");

    // The CLI reports exactly what the library computes on the same folder.
    let (set, issues) = load_events(&fx.events).unwrap();
    assert!(issues.is_empty(), "{issues:?}");
    let (seqs, prep) = prepare_sequences(&set, &PrepareConfig::default());
    assert!(prep.is_empty(), "{prep:?}");
    let blob = std::fs::read(&fx.model).unwrap();
    let mut methods = vec![Method {
        name: "MSRA".into(),
        scorer: Scorer::Model(scorer_core::model::decode(&blob).unwrap()),
    }];
    methods.extend(Method::baselines());
    let (report, _) = evaluate_methods(&observe(&seqs), &methods).unwrap();
    let mut v = v;
    let points = v
        .as_object_mut()
        .unwrap()
        .remove("operating_points")
        .unwrap();
    // A model without a training-domain record has no domain entry (docs/evaluation.md).
    let domain = v.as_object_mut().unwrap().remove("domain").unwrap();
    assert_eq!(domain, serde_json::json!([]));
    assert_eq!(report.to_json(), v);
    // The model row at its own default threshold (this hand-made blob has none stored, so its
    // kind's: MSRA's); the baselines have none.
    assert_eq!(points.as_array().unwrap().len(), 1, "{points}");
    assert_eq!(points[0]["name"], "MSRA");
    let kind_default = scorer_core::model::decode(&blob)
        .unwrap()
        .kind_default_threshold();
    assert_eq!(
        points[0]["threshold"].as_f64().unwrap() as f32,
        kind_default
    );
}

/// Ten safe events, ego at 15 m/s behind a partner 40 m ahead closing at `i` m/s (i = 0..9): the
/// smallest TTC2D differs per event and none collides.
fn safe_only_set() -> EventSet {
    let half = f64::from(DIMS.length_ego + DIMS.length_partner) / 2.0;
    let events = (0..10)
        .map(|i| {
            let dv = f64::from(i);
            event(
                format!("calm{i}"),
                EventKind::Safe,
                4.0,
                None,
                move |t| (15.0 * t, 15.0, 0.0),
                move |t| (40.0 + half + (15.0 - dv) * t, 15.0 - dv),
            )
        })
        .collect();
    EventSet { events }
}

#[test]
fn operating_points_on_safe_only_driving_give_the_false_alarm_rate() {
    let fx = fixture();
    let safe_dir = fx.root.join("safe-only");
    write_events(&safe_dir, &safe_only_set()).unwrap();
    // MSRA over TTC2D: R = sigmoid(2 - TTC2D); R >= 0.5 exactly when TTC2D <= 2 s.
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&fx.model),
        "--events",
        p(&safe_dir),
        "--threshold",
        "0.5",
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let point = &v["operating_points"][0];
    assert_eq!(point["name"], "MSRA");
    assert_eq!(point["threshold"], 0.5);
    let safe = &point["safe"];

    // The library's count: sequences whose TTC2D-driven score reaches 0.5 in their alert window.
    let (set, _) = load_events(&safe_dir).unwrap();
    let (seqs, _) = prepare_sequences(&set, &PrepareConfig::default());
    let blob = std::fs::read(&fx.model).unwrap();
    let model = scorer_core::model::decode(&blob).unwrap();
    let scored: Vec<_> = observe(&seqs)
        .iter()
        .map(|s| s.score(|f| model.score_observation(&f.observation)))
        .collect();
    let warned = scored
        .iter()
        .filter(|s| riskscore_eval::protocol::first_alert(s, 0.5).is_some())
        .count();
    assert!(
        warned > 0 && warned < 10,
        "the fixture spans the threshold: {warned}"
    );
    let hours: f64 = seqs.iter().map(|s| s.duration()).sum::<f64>() / 3600.0;
    assert_eq!(safe["sequences"], 10);
    assert_eq!(safe["warned"], warned);
    assert_eq!(safe["not_warned"], 10 - warned);
    assert!((safe["false_alarm_rate"].as_f64().unwrap() - 10.0 * warned as f64).abs() < 1e-9);
    let per_hour = safe["false_alarms_per_hour"].as_f64().unwrap();
    assert!(
        (per_hour - warned as f64 / hours).abs() < 1e-6 * per_hour,
        "{per_hour} vs {}",
        warned as f64 / hours
    );
    assert_eq!(point["crash"]["recall"], serde_json::Value::Null);

    // The Markdown table says the same.
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&fx.model),
        "--events",
        p(&safe_dir),
        "--threshold",
        "MSRA=0.5",
    ]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        table.contains(&format!("{warned}/10")) || table.contains(&format!("| {warned} |")),
        "{table}"
    );

    // A negative threshold needs no `=`, and a later `none` clears every row, baselines too.
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&fx.model),
        "--events",
        p(&safe_dir),
        "--json",
        "--threshold",
        "-0.5",
        "--threshold",
        "TTC2D=-1.5",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["operating_points"][0]["threshold"], -0.5);
    assert_eq!(v["operating_points"][0]["safe"]["warned"], 10);
    assert_eq!(v["operating_points"][1]["name"], "TTC2D");
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&fx.model),
        "--events",
        p(&safe_dir),
        "--json",
        "--threshold",
        "TTC2D=-1.5",
        "--threshold",
        "none",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["operating_points"], serde_json::json!([]));

    // Bad threshold specs are refused with the reason.
    for (spec, needle) in [
        ("NOPE=1", "no row named \"NOPE\""),
        ("abc", "not a finite number"),
        ("TTC2D=default", "baseline and has no default"),
    ] {
        let out = riskctl(&[
            "evaluate",
            "--model",
            p(&fx.model),
            "--events",
            p(&safe_dir),
            "--threshold",
            spec,
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && stderr.contains(needle),
            "{spec}: {stderr}"
        );
    }
}

#[test]
fn calibrate_stores_the_threshold_and_inspect_model_prints_its_rule() {
    let fx = fixture();
    let safe_dir = fx.root.join("safe-only");
    write_events(&safe_dir, &safe_only_set()).unwrap();
    let calibrated = fx.root.join("calibrated.rsk");
    let out = riskctl(&[
        "calibrate",
        "--model",
        p(&fx.model),
        "--normal",
        p(&safe_dir),
        "--false-alarm-rate",
        "20",
        "--out",
        p(&calibrated),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let bytes = std::fs::read(&calibrated).unwrap();
    let blob = scorer_core::model::decode_blob(&bytes).unwrap();
    let default = blob
        .meta
        .default_threshold
        .expect("a stored default threshold");
    // At most 2 of the 10 sequences may warn; the rule picks the smallest such maximum.
    let model = blob.model;
    let mut maxima: Vec<f32> = observed_sequences(&safe_dir)
        .iter()
        .map(|s| {
            s.frames
                .iter()
                .map(|f| model.score_observation(&f.observation))
                .fold(f32::NEG_INFINITY, f32::max)
        })
        .collect();
    maxima.sort_by(f32::total_cmp);
    let warned = maxima.iter().filter(|&&m| m >= default.threshold).count();
    assert!(warned <= 2, "{warned} of 10 warn at {}", default.threshold);
    let lower = maxima.iter().rfind(|&&m| m < default.threshold);
    if let Some(&lower) = lower {
        assert!(
            maxima.iter().filter(|&&m| m >= lower).count() > 2,
            "a lower maximum would also have met the target"
        );
    }
    // The model itself is unchanged, and inspect-model prints the threshold with its rule.
    assert_eq!(
        scorer_core::model::decode(&std::fs::read(&fx.model).unwrap()).unwrap(),
        model
    );
    let out = riskctl(&["inspect-model", p(&calibrated)]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("default threshold"), "{text}");
    assert!(text.contains("20"), "the target is stated: {text}");
    assert!(text.contains("safe-only"), "the data is named: {text}");
    // evaluate uses the stored default when no --threshold is given.
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&calibrated),
        "--events",
        p(&safe_dir),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        v["operating_points"][0]["threshold"].as_f64().unwrap() as f32,
        default.threshold
    );
    assert_eq!(v["operating_points"][0]["safe"]["warned"], warned);

    // The output may not be the input, and bad rates are refused before anything is written.
    let before = std::fs::read(&fx.model).unwrap();
    for (rate, out_path) in [("5", p(&fx.model)), ("150", p(&calibrated))] {
        let out = riskctl(&[
            "calibrate",
            "--model",
            p(&fx.model),
            "--normal",
            p(&safe_dir),
            "--false-alarm-rate",
            rate,
            "--out",
            out_path,
        ]);
        assert!(!out.status.success(), "rate {rate} -> {out_path}");
    }
    assert_eq!(std::fs::read(&fx.model).unwrap(), before);
}

#[test]
fn calibrate_never_warn_lifts_the_threshold_above_that_driving_and_refuses_conflicts() {
    let fx = fixture();
    let safe_dir = fx.root.join("safe-only");
    write_events(&safe_dir, &safe_only_set()).unwrap();
    let calibrate = |never_warn: &Path, out: &Path| {
        riskctl(&[
            "calibrate",
            "--model",
            p(&fx.model),
            "--normal",
            p(&safe_dir),
            "--false-alarm-rate",
            "20",
            "--never-warn",
            p(never_warn),
            "--out",
            p(out),
        ])
    };
    // The rule alone lets 2 of the 10 warn; with the same sequences as never-warn, none may.
    let lifted = fx.root.join("lifted.rsk");
    let out = calibrate(&safe_dir, &lifted);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("raised to"), "{stdout}");
    assert!(stdout.contains("0.0 % of 10"), "{stdout}");
    let bytes = std::fs::read(&lifted).unwrap();
    let blob = scorer_core::model::decode_blob(&bytes).unwrap();
    let threshold = blob.default_threshold();
    for s in observed_sequences(&safe_dir) {
        for f in &s.frames {
            let score = blob.model.score_observation(&f.observation);
            assert!(
                score < threshold,
                "{} warns: {score} >= {threshold}",
                s.event_id
            );
        }
    }
    // A folder with conflicts cannot be required never to warn; nothing is written.
    let refused = fx.root.join("refused.rsk");
    let out = calibrate(&fx.events, &refused);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("conflict sequences"),
        "{stderr}"
    );
    assert!(!refused.exists());
}

#[test]
fn plot_draws_any_event_and_names_what_is_wrong() {
    let fx = fixture();
    for (event, file) in [
        ("crash2", "crash2.png"),
        ("safe0", "safe0.svg"),
        ("near1", "near1.png"),
    ] {
        let image = fx.root.join(file);
        let out = riskctl(&[
            "plot",
            "--events",
            p(&fx.events),
            "--event",
            event,
            "--model",
            p(&fx.model),
            "--threshold",
            "0.5",
            "--out",
            p(&image),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{event}: {stderr}");
        let bytes = std::fs::read(&image).unwrap();
        if file.ends_with(".png") {
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
            // IHDR: width and height, big-endian, at bytes 16..24. One strip per method
            // (the model and the three baselines) below the map.
            let width = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
            let height = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
            // Caption with two note lines, map, four strips, one legend row.
            assert_eq!((width, height), (1100, 82 + 520 + 4 * 150 + 44));
            assert!(bytes.len() > 20_000, "{file}: {} bytes", bytes.len());
        } else {
            let svg = String::from_utf8(bytes).unwrap();
            for needle in ["<svg", "safe0", "MSRA", "TTC2D", "TAdv", "EI"] {
                assert!(svg.contains(needle), "{file} lacks {needle}");
            }
        }
        if event == "crash2" {
            assert!(
                stderr.contains("MSRA: threshold 0.5, first warning at"),
                "{stderr}"
            );
        }
    }
    for (args, needle) in [
        (
            vec!["--event", "nope", "--out", "x.png"],
            "no event \"nope\"",
        ),
        (
            vec!["--event", "crash0", "--out", "x.gif"],
            "must end in .svg or .png",
        ),
    ] {
        let mut all = vec!["plot", "--events", p(&fx.events)];
        all.extend(args);
        let out = riskctl(&all);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(needle), "{stderr}");
    }
    // An input file is never the image.
    let frames = fx.events.join("frames.csv");
    let before = std::fs::read(&frames).unwrap();
    let out = riskctl(&[
        "plot",
        "--events",
        p(&fx.events),
        "--event",
        "crash0",
        "--out",
        p(&frames),
    ]);
    assert!(!out.status.success());
    assert_eq!(std::fs::read(&frames).unwrap(), before);
}

/// An event with a note (here a hole of dropped frames) is kept by the loader, so it can be
/// drawn: the note is printed as a warning. It was refused as "cannot be drawn".
#[test]
fn plot_draws_an_event_with_a_note_and_prints_the_note() {
    let dir = tempfile::tempdir().unwrap();
    let events = common::simulate(dir.path());
    let frames = events.join("frames.csv");
    let text = std::fs::read_to_string(&frames).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            let mut cells = l.split(',');
            let (id, time) = (
                cells.next(),
                cells.next().and_then(|t| t.parse::<f64>().ok()),
            );
            !(id == Some("000001") && time.is_some_and(|t| (1.0..3.0).contains(&t)))
        })
        .collect();
    assert!(kept.len() + 10 < text.lines().count(), "no frames dropped");
    std::fs::write(&frames, kept.join("\n") + "\n").unwrap();
    let image = dir.path().join("gap.svg");
    let out = riskctl(&[
        "plot",
        "--events",
        p(&events),
        "--event",
        "000001",
        "--out",
        p(&image),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning") && stderr.contains("the frames jump from 0.9 to 3 s"),
        "{stderr}"
    );
    assert!(std::fs::read_to_string(&image).unwrap().contains("<svg"));
}

#[test]
fn completions_and_man_pages_come_from_the_cli_definition() {
    let out = riskctl(&["completions", "bash"]);
    let script = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    for sub in ["evaluate", "calibrate", "plot", "inspect-model"] {
        assert!(script.contains(sub), "bash completion lacks {sub}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = riskctl(&["man", "--out-dir", p(dir.path())]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = std::fs::read_to_string(dir.path().join("riskctl.1")).unwrap();
    assert!(page.contains(".TH") && page.contains("evaluate"), "{page}");
    assert!(dir.path().join("riskctl-plot.1").exists());
}

#[test]
fn markdown_table_by_default_and_files_with_out() {
    let fx = fixture();
    let out_dir = fx.root.join("report");
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&fx.model),
        "--events",
        p(&fx.events),
        "--out",
        p(&out_dir),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let table = String::from_utf8(out.stdout).unwrap();
    assert!(table.contains("| Method | A^ROC_90 (%)"), "{table}");
    assert!(
        table.contains("| TTC2D | 100.0 | 100.0 | 100.0 | 100.0 |"),
        "{table}"
    );
    for name in [
        "results.csv",
        "results.json",
        "results.md",
        "curves.csv",
        "roc.svg",
        "roc.png",
        "pr.svg",
        "pr.png",
        "trajectories.svg",
        "trajectories.png",
    ] {
        let path = out_dir.join(name);
        let meta = std::fs::metadata(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(meta.len() > 100, "{name} is nearly empty");
    }
    let svg = std::fs::read_to_string(out_dir.join("roc.svg")).unwrap();
    assert!(
        svg.contains("<svg") && svg.contains("TTC2D"),
        "labels are drawn"
    );
    let png = std::fs::read(out_dir.join("trajectories.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let traj = std::fs::read_to_string(out_dir.join("trajectories.svg")).unwrap();
    for id in ["crash0", "crash1", "crash2"] {
        assert!(traj.contains(id), "trajectory panel for {id}");
    }
    let curves = std::fs::read_to_string(out_dir.join("curves.csv")).unwrap();
    assert!(curves.starts_with("method,threshold,true_positives"));
}

#[test]
fn rows_sharing_a_kind_take_their_file_stems() {
    let fx = fixture();
    let second = fx.root.join("msra-steep.rsk");
    std::fs::write(&second, msra_ttc_blob(-3.0)).unwrap();
    let named = format!("Custom={}", p(&second));
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&fx.model),
        "--model",
        p(&second),
        "--model",
        &named,
        "--events",
        p(&fx.events),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let names: Vec<&str> = v["methods"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["msra-ttc", "msra-steep", "Custom", "TTC2D", "TAdv", "EI"]
    );
}

/// `--out`'s results.md and results.json held the metrics table alone, while the run prints the
/// operating points (and the frames outside a training domain) too: the figure a user wants on
/// normal driving was on the terminal only. Both files now hold exactly what the run prints,
/// Markdown or `--json`.
#[test]
fn result_files_hold_what_the_run_prints_operating_points_included() {
    let fx = fixture();
    let run = |out: &Path, json: bool| {
        let mut args = vec![
            "evaluate",
            "--model",
            p(&fx.model),
            "--events",
            p(&fx.events),
            "--threshold",
            "TTC2D=-1.5",
            "--out",
            p(out),
        ];
        if json {
            args.push("--json");
        }
        let o = riskctl(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).unwrap()
    };
    let dir = fx.root.join("report-md");
    let printed = run(&dir, false);
    assert!(
        printed.contains("| Method | threshold | kind |"),
        "{printed}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("results.md")).unwrap(),
        printed
    );
    let dir = fx.root.join("report-json");
    let printed: serde_json::Value = serde_json::from_str(&run(&dir, true)).unwrap();
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    assert_eq!(written, printed);
    assert_eq!(written["operating_points"][1]["name"], "TTC2D");
}

/// Rows named by their file stems keep an `=` of the stem (a sweep's `drl_lr=0.1.rsk`), and
/// `--threshold NAME=T` split at the first `=`: `--threshold msra_a=0.1=0.5` looked for a row
/// `msra_a` and was refused, while `riskscore.evaluate(thresholds={"msra_a=0.1": 0.5})` reached
/// the row. It splits at the last `=` now (a value never holds one).
#[test]
fn a_threshold_reaches_a_row_whose_name_holds_an_equals_sign() {
    let fx = fixture();
    let sweep = fx.root.join("sweep");
    std::fs::create_dir(&sweep).unwrap();
    let (first, second) = (sweep.join("msra_a=0.01.rsk"), sweep.join("msra_a=0.1.rsk"));
    std::fs::write(&first, msra_ttc_blob(-1.0)).unwrap();
    std::fs::write(&second, msra_ttc_blob(-3.0)).unwrap();
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&first),
        "--model",
        p(&second),
        "--events",
        p(&fx.events),
        "--threshold",
        "msra_a=0.1=0.5",
        "--threshold",
        "TTC2D=-1.5",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let points: Vec<(&str, f64)> = v["operating_points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            (
                o["name"].as_str().unwrap(),
                o["threshold"].as_f64().unwrap(),
            )
        })
        .collect();
    let default = f64::from(
        scorer_core::model::decode_blob(&msra_ttc_blob(-1.0))
            .unwrap()
            .default_threshold(),
    );
    assert_eq!(
        points,
        [
            ("msra_a=0.01", default),
            ("msra_a=0.1", 0.5),
            ("TTC2D", -1.5)
        ]
    );
}

#[test]
fn corrupt_and_missing_models_are_refused_with_the_reason() {
    let fx = fixture();
    let bad = fx.root.join("bad.rsk");
    std::fs::write(&bad, b"not a model at all, just text").unwrap();
    let out = riskctl(&["evaluate", "--model", p(&bad), "--events", p(&fx.events)]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.rsk") && err.contains("magic"), "{err}");

    let mut blob = msra_ttc_blob(-1.0);
    let last = blob.len() - 1;
    blob[last] ^= 0x5a;
    std::fs::write(&bad, &blob).unwrap();
    let out = riskctl(&["evaluate", "--model", p(&bad), "--events", p(&fx.events)]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.rsk") && err.to_lowercase().contains("crc"),
        "{err}"
    );

    let missing = fx.root.join("nope.rsk");
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&missing),
        "--events",
        p(&fx.events),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.rsk"));
}

#[test]
fn bad_event_folders_are_named() {
    let fx = fixture();
    let missing = fx.root.join("no-such-folder");
    let out = riskctl(&["evaluate", "--events", p(&missing)]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-such-folder"));

    // A folder with one broken row: the problem is listed by file and line, and the run fails
    // rather than leave the event out of the metrics.
    let events_csv = fx.events.join("events.csv");
    let text = std::fs::read_to_string(&events_csv).unwrap();
    let broken = text.replacen(",safe,", ",sideswipe,", 1);
    std::fs::write(&events_csv, broken).unwrap();
    let out = riskctl(&["evaluate", "--events", p(&fx.events), "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("events.csv:") && err.contains("sideswipe"),
        "{err}"
    );
    assert!(
        err.contains("--skip-bad-events to evaluate the 17 valid events"),
        "{err}"
    );
    assert!(out.stdout.is_empty());

    // Asked for: the good events are evaluated.
    let out = riskctl(&[
        "evaluate",
        "--events",
        p(&fx.events),
        "--json",
        "--skip-bad-events",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("events.csv") && err.contains("sideswipe"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["events"]["safe"], 7);
    assert_eq!(v["methods"].as_array().unwrap().len(), 3, "baselines only");
}

#[test]
fn out_files_are_replaced_together_or_not_at_all() {
    let fx = fixture();
    let out_dir = fx.root.join("report");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "evaluate",
            "--model",
            p(&fx.model),
            "--events",
            p(&fx.events),
            "--out",
            p(&out_dir),
        ];
        args.extend_from_slice(extra);
        riskctl(&args)
    };
    let out = run(&[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let snapshot = || {
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&out_dir)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                (
                    e.file_name().to_string_lossy().into_owned(),
                    std::fs::read(e.path()).unwrap(),
                )
            })
            .collect();
        files.sort();
        files
    };
    let before = snapshot();
    assert_eq!(
        before.len(),
        10,
        "{:?}",
        before.iter().map(|f| &f.0).collect::<Vec<_>>()
    );

    // Fails after the tables and curves are written: the trajectory event is a crash row of
    // events.csv (so not refused at the start) without frames, left out under
    // --skip-bad-events and found missing at the end. Nothing changes, no temporary is left.
    std::fs::write(&fx.model, msra_ttc_blob(-2.0)).unwrap();
    let events_csv = fx.events.join("events.csv");
    let table = std::fs::read_to_string(&events_csv).unwrap();
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let (id_at, kind_at) = (
        header.iter().position(|h| *h == "event_id").unwrap(),
        header.iter().position(|h| *h == "kind").unwrap(),
    );
    let crash = table
        .lines()
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|f| f[kind_at] == "crash")
        .unwrap();
    let mut ghost = crash.clone();
    ghost[id_at] = "ghost";
    std::fs::write(&events_csv, format!("{table}{}\n", ghost.join(","))).unwrap();
    let out = run(&["--skip-bad-events", "--trajectory-event", "ghost"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("nothing written to"), "{stderr}");
    assert_eq!(snapshot(), before);
    std::fs::write(&events_csv, table).unwrap();

    // The same run without the bad option replaces the results.
    let out = run(&[]);
    assert!(out.status.success());
    assert_eq!(snapshot().len(), 10);
    assert_ne!(snapshot(), before);

    // An input named like one of the figures is refused before anything is written.
    let model_as_figure = out_dir.join("roc.png");
    std::fs::copy(&fx.model, &model_as_figure).unwrap();
    let after = snapshot();
    let out = riskctl(&[
        "evaluate",
        "--model",
        p(&model_as_figure),
        "--events",
        p(&fx.events),
        "--out",
        p(&out_dir),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("same file as --model"), "{stderr}");
    assert_eq!(snapshot(), after);
}

#[test]
fn calibrate_lists_the_problems_of_a_normal_folder_it_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    let events = common::simulate(tmp.path());
    // A repeated frame (line 3 repeats line 2) drops the first event; the refusal used to say
    // "the problems listed above" without listing any, and advise a flag calibrate lacks.
    let frames = events.join("frames.csv");
    let text = std::fs::read_to_string(&frames).unwrap();
    let second = text.lines().nth(1).unwrap();
    let text = text.replacen(second, &format!("{second}\n{second}"), 1);
    std::fs::write(&frames, text).unwrap();
    let out = tmp.path().join("c.rsk");
    let o = common::riskctl(&[
        "calibrate",
        "--model",
        common::shipped_model("drl-default.rsk").to_str().unwrap(),
        "--normal",
        events.to_str().unwrap(),
        "--false-alarm-rate",
        "5",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("frames.csv:3: column `time`") && err.contains("repeats the frame on line 2"),
        "{err}"
    );
    assert!(
        err.contains("out of the calibration") && !err.contains("--skip-bad-events"),
        "{err}"
    );
    assert!(!out.exists());
}
