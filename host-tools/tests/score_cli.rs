//! `riskctl score`: one row per frame with each model's score and the surrogates, equal to the
//! library's evaluation scoring path; CSV and Parquet carry the same values.
#![cfg(feature = "parquet")]
use std::path::Path;

use arrow_array::cast::AsArray;
use arrow_array::types::{Float32Type, Float64Type, UInt8Type};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use riskscore_data::events::{load_events, Sequence};
use riskscore_eval::{observe, Scorer};
mod common;
use common::{riskctl, shipped_model as model, simulate};

fn parse_out(v: &str) -> f32 {
    v.parse()
        .unwrap_or_else(|_| panic!("{v:?} is not a number"))
}

#[test]
fn every_frame_is_scored_like_the_evaluation() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let (drl, msra) = (model("drl-default.rsk"), model("msra-default.rsk"));
    let csv_out = dir.path().join("scores.csv");
    let o = riskctl(&[
        "score",
        "--model",
        drl.to_str().unwrap(),
        "--model",
        &format!("mine={}", msra.display()),
        "--events",
        events.to_str().unwrap(),
        "--out",
        csv_out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");

    // Expected: every frame of every event through the library's scorer.
    let (set, issues) = load_events(&events).unwrap();
    assert!(issues.is_empty());
    let models: Vec<Vec<u8>> = [&drl, &msra]
        .iter()
        .map(|p| std::fs::read(p).unwrap())
        .collect();
    // The shipped blobs carry a training-domain record: scored through their guard, as on the ECU.
    let scorers: Vec<Scorer> = models
        .iter()
        .map(|b| Scorer::Guarded(scorer_core::model::decode_blob(b).unwrap()))
        .collect();
    let mut expected = Vec::new();
    for ev in set.iter() {
        let seq = Sequence {
            event_id: ev.id.clone(),
            kind: ev.kind,
            frames: ev.frames.clone(),
            endpoint: ev.t_impact,
        };
        for obs in observe(&[seq]) {
            for f in &obs.frames {
                expected.push((
                    ev.id.clone(),
                    f.time,
                    ev.kind.as_str(),
                    scorers
                        .iter()
                        .map(|s| s.score(&f.observation))
                        .collect::<Vec<f32>>(),
                    scorers
                        .iter()
                        .map(|s| u8::from(s.score_guarded(&f.observation).unwrap().in_domain))
                        .collect::<Vec<u8>>(),
                    [
                        f.observation.surrogates.ttc2d,
                        f.observation.surrogates.tadv,
                        f.observation.surrogates.ei,
                        f.observation.surrogates.tadv_corridor,
                    ],
                ));
            }
        }
    }
    assert!(expected.len() > 100);
    assert!(
        err.contains(&format!("{} frames of 9 events", expected.len())),
        "{err}"
    );

    let mut reader = csv::Reader::from_path(&csv_out).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(
        header,
        [
            "event_id",
            "time",
            "class",
            "DRL",
            "mine",
            "ttc2d",
            "tadv",
            "ei",
            "tadv_corridor",
            "DRL_in_domain",
            "mine_in_domain"
        ]
    );
    let rows: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), expected.len());
    for (row, (id, time, class, scores, flags, surrogates)) in rows.iter().zip(&expected) {
        assert_eq!(&row[0], id);
        assert_eq!(row[1].parse::<f64>().unwrap(), *time);
        assert_eq!(&row[2], *class);
        for (k, s) in scores.iter().chain(surrogates).enumerate() {
            assert_eq!(parse_out(&row[3 + k]).to_bits(), s.to_bits(), "{row:?}");
        }
        for (k, flag) in flags.iter().enumerate() {
            assert_eq!(row[9 + k].parse::<u8>().unwrap(), *flag, "{row:?}");
        }
    }
    // Risk rises towards a crash: the DRL score at the impact frame beats the event's first frame.
    let crash = set
        .iter()
        .find(|e| e.kind.as_str() == "crash")
        .expect("a crash");
    let crash_drl: Vec<f32> = expected
        .iter()
        .filter(|r| r.0 == crash.id)
        .map(|r| r.3[0])
        .collect();
    let first = crash_drl[0];
    let peak = crash_drl.iter().copied().fold(f32::MIN, f32::max);
    assert!(peak > first, "{first} -> {peak}");

    // Parquet: same columns and values.
    let pq = dir.path().join("scores.parquet");
    let o = riskctl(&[
        "score",
        "--model",
        drl.to_str().unwrap(),
        "--model",
        &format!("mine={}", msra.display()),
        "--events",
        events.to_str().unwrap(),
        "--out",
        pq.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let reader = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(&pq).unwrap())
        .unwrap()
        .build()
        .unwrap();
    let mut k = 0usize;
    for batch in reader {
        let batch = batch.unwrap();
        let names: Vec<String> = batch
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        assert_eq!(names, header);
        for r in 0..batch.num_rows() {
            let (id, time, class, scores, flags, surrogates) = &expected[k];
            assert_eq!(batch.column(0).as_string::<i32>().value(r), id);
            assert_eq!(
                batch.column(1).as_primitive::<Float64Type>().value(r),
                *time
            );
            assert_eq!(batch.column(2).as_string::<i32>().value(r), *class);
            for (c, s) in scores.iter().chain(surrogates).enumerate() {
                let got = batch.column(3 + c).as_primitive::<Float32Type>().value(r);
                assert_eq!(got.to_bits(), s.to_bits());
            }
            for (c, flag) in flags.iter().enumerate() {
                let got = batch.column(9 + c).as_primitive::<UInt8Type>().value(r);
                assert_eq!(got, *flag);
            }
            k += 1;
        }
    }
    assert_eq!(k, expected.len());
}

#[test]
fn sequences_flag_scores_the_evaluation_windows_only() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let drl = model("drl-default.rsk");
    let (all, windows) = (dir.path().join("all.csv"), dir.path().join("win.csv"));
    for (out, extra) in [(&all, None), (&windows, Some("--sequences"))] {
        let mut args = vec![
            "score",
            "--model",
            drl.to_str().unwrap(),
            "--events",
            events.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = riskctl(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let count = |p: &Path| std::fs::read_to_string(p).unwrap().lines().count();
    assert!(count(&windows) > 1);
    assert!(count(&windows) < count(&all));
}

#[test]
fn a_bad_model_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let bogus = dir.path().join("bogus.rsk");
    std::fs::write(&bogus, b"not a model").unwrap();
    let o = riskctl(&[
        "score",
        "--model",
        bogus.to_str().unwrap(),
        "--events",
        dir.path().to_str().unwrap(),
        "--out",
        dir.path().join("x.csv").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bogus.rsk"), "{err}");
    assert!(!dir.path().join("x.csv").exists());
}

/// `score --out FILE` replaced a model blob or a training checkpoint that was not one of the
/// `--model` files (`--out run/msra.rsk` for `run/msra.csv`) with the score table; both are
/// refused, named, and left as they are. A table from an earlier run is still replaced.
#[test]
fn an_out_that_is_a_model_blob_or_a_checkpoint_is_refused_and_left_as_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let events = simulate(dir.path());
    let blob = dir.path().join("msra.rsk");
    std::fs::copy(model("msra-default.rsk"), &blob).unwrap();
    let checkpoint = dir.path().join("drl.json");
    std::fs::write(
        &checkpoint,
        "{\n  \"format\": \"riskscore-checkpoint\",\n  \"version\": 3,\n  \"model\": {}\n}\n",
    )
    .unwrap();
    let drl = model("drl-default.rsk");
    let score = |out: &Path| {
        riskctl(&[
            "score",
            "--model",
            drl.to_str().unwrap(),
            "--events",
            events.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    for (out, what) in [
        (&blob, "it is a model blob"),
        (&checkpoint, "it is a training checkpoint"),
    ] {
        let before = std::fs::read(out).unwrap();
        let o = score(out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(
            err.contains(&format!("--out {}: {what}", out.display()))
                && err.contains("left as it is"),
            "{err}"
        );
        assert_eq!(
            std::fs::read(out).unwrap(),
            before,
            "{} changed",
            out.display()
        );
    }
    let table = dir.path().join("scores.csv");
    std::fs::write(&table, "an earlier table\n").unwrap();
    let o = score(&table);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read_to_string(&table)
        .unwrap()
        .starts_with("event_id,"));
}
