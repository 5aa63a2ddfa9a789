//! The engine's data-quality rules, one test per fault of issue 4, plus warning-frame protection.
mod common;
use can_bridge::engine::{Engine, EngineConfig, Output, ReleaseReason};
use can_bridge::map::CompiledMap;
use can_bridge::ModelFile;
use can_codec::{project, E2eChecker, E2eConfig, E2eStatus, Frame};
use common::*;
use std::path::Path;

struct Run {
    outputs: Vec<Output>,
}

impl Run {
    fn scored(&self, track: u32) -> usize {
        self.outputs
            .iter()
            .filter(|o| matches!(o, Output::Scored(s) if s.track == track))
            .count()
    }
    fn warning_frames(&self) -> Vec<Frame> {
        self.outputs
            .iter()
            .filter_map(|o| match o {
                Output::WarningFrame { frame, .. } => Some(*frame),
                _ => None,
            })
            .collect()
    }
}

fn with_engine(
    config: EngineConfig,
    f: impl FnOnce(&mut Engine<'_>, &mut dyn FnMut(u64, &Frame)),
) -> Run {
    let blob = msra_blob();
    let model = ModelFile::from_bytes(Path::new("test.rsk"), blob).unwrap();
    let (_db, map) = CompiledMap::project_default().unwrap();
    let mut engine = Engine::new(model.model().unwrap(), map, config).unwrap();
    let mut outputs = Vec::new();
    let feed = |engine: &mut Engine<'_>, t: u64, fr: &Frame, outputs: &mut Vec<Output>| {
        engine.process(t, fr, &mut |o| outputs.push(o));
    };
    // The closure given to `f` feeds frames into the engine and collects outputs.
    let mut pending: Vec<(u64, Frame)> = Vec::new();
    f(&mut engine, &mut |t, fr| pending.push((t, *fr)));
    for (t, fr) in pending {
        feed(&mut engine, t, &fr, &mut outputs);
    }
    Run { outputs }
}

fn cfg() -> EngineConfig {
    EngineConfig {
        threshold: 1.5,
        ..EngineConfig::new(1.5)
    }
}

/// Feeds `cycles` at 10 Hz from t0; each entry is the list of cycles of that tick.
fn feed_ticks(send: &mut dyn FnMut(u64, &Frame), t0: u64, ticks: &[Vec<Cycle>]) {
    let db = project_db();
    for (k, cycles) in ticks.iter().enumerate() {
        let mut t = t0 + k as u64 * 100_000;
        for c in cycles {
            for fr in c.frames(&db) {
                send(t, &fr);
                t += 100;
            }
        }
    }
}

#[test]
fn healthy_tracks_are_scored_and_warned_with_protected_frames() {
    let run = with_engine(cfg(), |_, send| {
        let ticks: Vec<Vec<Cycle>> = (0..10)
            .map(|k| vec![Cycle::closing(7, 30.0 - 2.0 * k as f64), Cycle::receding(9)])
            .collect();
        feed_ticks(send, 1_000_000, &ticks);
    });
    assert_eq!(run.scored(7), 10);
    assert_eq!(run.scored(9), 10);
    let frames = run.warning_frames();
    assert!(!frames.is_empty(), "the closing track must warn");
    let db = project_db();
    let w = db.message_by_name(project::RISK_WARNING).unwrap();
    let mut checker = E2eChecker::new(E2eConfig {
        data_id: project::WARNING_DATA_ID,
        crc_byte: 0,
        counter_byte: 1,
        max_delta: 3,
    });
    let scores: Vec<f32> = run
        .outputs
        .iter()
        .filter_map(|o| match o {
            Output::Scored(s) if s.warning => Some(s.score),
            _ => None,
        })
        .collect();
    assert_eq!(scores.len(), frames.len());
    for (i, (f, score)) in frames.iter().zip(&scores).enumerate() {
        assert_eq!(f.id, w.id);
        let status = checker.check(f.data());
        assert_eq!(
            status,
            if i == 0 {
                E2eStatus::Initial
            } else {
                E2eStatus::Ok
            }
        );
        let get = |name: &str| {
            w.value(w.signal_index(name).unwrap(), f.data())
                .unwrap()
                .unwrap()
        };
        assert_eq!(get("WarnTrackId"), 7.0);
        assert_eq!(get("WarnLevel"), 1.0);
        assert_eq!(
            get("WarnScore") as f32,
            *score,
            "score is sent bit-exact as float32"
        );
        assert!(*score >= 1.5);
    }
    assert!(run
        .outputs
        .iter()
        .any(|o| matches!(o, Output::WarningOn { track: 7, .. })));
    assert!(!run
        .outputs
        .iter()
        .any(|o| matches!(o, Output::WarningOn { track: 9, .. })));
}

#[test]
fn unknown_ids_remote_and_error_frames_are_counted_and_do_not_disturb_scoring() {
    let blob = msra_blob();
    let model = ModelFile::from_bytes(Path::new("m"), blob).unwrap();
    let (db, map) = CompiledMap::project_default().unwrap();
    let mut e = Engine::new(model.model().unwrap(), map, cfg()).unwrap();
    let mut n_scored = 0;
    let mut sink = |o: Output| {
        if matches!(o, Output::Scored(_)) {
            n_scored += 1;
        }
    };
    let junk = [
        Frame::data_frame(can_codec::CanId::Standard(0x7AB), &[1, 2, 3]).unwrap(),
        Frame::data_frame(can_codec::CanId::Extended(0x100), &[0; 8]).unwrap(),
        Frame::remote_frame(id_of(&db, project::OBJECT_MOTION), 8).unwrap(),
        Frame::error_frame(0x04, &[0, 0x10, 0, 0, 0, 0, 0, 0]).unwrap(),
        Frame::error_frame(can_codec::frame::CAN_ERR_BUSOFF, &[0; 8]).unwrap(),
    ];
    let mut t = 0;
    for k in 0..5 {
        for j in &junk {
            t += 10;
            e.process(t, j, &mut sink);
        }
        for f in Cycle::closing(3, 40.0 - k as f64).frames(&db) {
            t += 10;
            e.process(t, &f, &mut sink);
        }
        t += 100_000;
    }
    let s = *e.stats();
    assert_eq!(n_scored, 5);
    assert_eq!(
        s.unknown_ids, 10,
        "standard 0x7AB and extended 0x100 are not inputs"
    );
    assert_eq!(s.remote_frames, 5);
    assert_eq!(s.error_frames, 10);
    assert_eq!(s.bus_off, 5);
    assert_eq!(s.decode_errors, 0);
}

#[test]
fn wrong_dlc_and_out_of_range_values_drop_only_that_frame() {
    let run = with_engine(cfg(), |_, send| {
        let db = project_db();
        let pos = db.message_by_name(project::OBJECT_POSITION).unwrap();
        let size = db.message_by_name(project::OBJECT_SIZE).unwrap();
        for k in 0..5u64 {
            let t = 1_000_000 + k * 100_000;
            let good = Cycle::receding(1).frames(&db);
            let mut bad = Cycle::closing(2, 30.0).frames(&db);
            if k == 1 {
                // Track 2's position frame arrives with 7 bytes instead of 8.
                bad[2] = Frame::data_frame(pos.id, &bad[2].data()[..7]).unwrap();
            }
            if k == 2 {
                // Track 2's length is 40 m: outside the DBC range [0.2, 30].
                let mut d = bad[3].data().to_vec();
                let s = &size.signals[size.signal_index("ObjLength").unwrap()];
                s.write_raw(40_000, &mut d).unwrap();
                bad[3] = Frame::data_frame(size.id, &d).unwrap();
            }
            for (i, f) in good.iter().chain(bad.iter()).enumerate() {
                send(t + i as u64 * 100, f);
            }
        }
    });
    assert_eq!(run.scored(1), 5, "the healthy track is scored every cycle");
    // Track 2 is still scored in cycles 1 and 2 from its previous (fresh) position and size.
    assert_eq!(run.scored(2), 5);
    let problems: Vec<String> = run
        .outputs
        .iter()
        .filter_map(|o| match o {
            Output::Problem { reason, .. } => Some(reason.to_string()),
            _ => None,
        })
        .collect();
    assert!(
        problems
            .iter()
            .any(|p| p.contains("wrong DLC: 7 bytes, DBC says 8")),
        "{problems:?}"
    );
    assert!(
        problems
            .iter()
            .any(|p| p.contains("ObjLength") && p.contains("outside")),
        "{problems:?}"
    );
    // The partner length used in cycle 2 is the last valid one (4.6 m), not 40 m.
    for o in &run.outputs {
        if let Output::Scored(s) = o {
            assert!((s.partner.length - 4.6).abs() < 1e-6);
        }
    }
}

#[test]
fn reordered_and_duplicated_timestamps_are_dropped() {
    let run = with_engine(cfg(), |_, send| {
        let db = project_db();
        let c = Cycle::closing(4, 30.0).frames(&db);
        for (i, f) in c.iter().enumerate() {
            send(1_000_000 + i as u64, f);
        }
        // The same trigger again at the same time: a duplicate.
        send(1_000_004, &c[4]);
        // A frame from the past: reordered.
        send(900_000, &c[4]);
        let c2 = Cycle::closing(4, 28.0).frames(&db);
        for (i, f) in c2.iter().enumerate() {
            send(1_100_000 + i as u64, f);
        }
    });
    assert_eq!(run.scored(4), 2);
    let problems = run
        .outputs
        .iter()
        .filter(|o| matches!(o, Output::Problem { .. }))
        .count();
    assert_eq!(problems, 2);
}

#[test]
fn stale_tracks_are_dropped_released_and_never_warned_on_stale_data() {
    let blob = msra_blob();
    let model = ModelFile::from_bytes(Path::new("m"), blob).unwrap();
    let (db, map) = CompiledMap::project_default().unwrap();
    let config = EngineConfig {
        stale_us: 300_000,
        min_on_us: 0,
        ..cfg()
    };
    let mut e = Engine::new(model.model().unwrap(), map, config).unwrap();
    let mut out = Vec::new();
    // Track 5 warns, then stops updating while track 6 goes on.
    for k in 0..3u64 {
        let t = k * 100_000;
        for (i, f) in Cycle::closing(5, 15.0).frames(&db).iter().enumerate() {
            e.process(t + i as u64, f, &mut |o| out.push(o));
        }
    }
    assert!(out
        .iter()
        .any(|o| matches!(o, Output::WarningOn { track: 5, .. })));
    for k in 3..10u64 {
        let t = k * 100_000;
        for (i, f) in Cycle::receding(6).frames(&db).iter().enumerate() {
            e.process(t + i as u64, f, &mut |o| out.push(o));
        }
    }
    let off: Vec<_> = out
        .iter()
        .filter_map(|o| match o {
            Output::WarningOff {
                track: 5,
                reason,
                t_us,
                ..
            } => Some((*reason, *t_us)),
            _ => None,
        })
        .collect();
    assert_eq!(off.len(), 1, "{off:?}");
    assert_eq!(off[0].0, ReleaseReason::Stale);
    assert!(off[0].1 > 200_000 + 300_000);
    assert!(e.stats().tracks_dropped >= 1);

    // Position of track 8 at 1.0 s, its motion (trigger) only at 1.5 s: the position is stale.
    let frames = Cycle::closing(8, 10.0).frames(&db);
    let mut got = Vec::new();
    for (i, f) in frames[..4].iter().enumerate() {
        e.process(1_000_000 + i as u64, f, &mut |o| got.push(o));
    }
    // Keep the ego fresh.
    e.process(1_499_000, &frames[0], &mut |o| got.push(o));
    e.process(1_500_000, &frames[4], &mut |o| got.push(o));
    assert!(!got
        .iter()
        .any(|o| matches!(o, Output::Scored(_) | Output::WarningFrame { .. })));
    assert_eq!(e.stats().stale_drops, 1);

    // Ego silent for longer than the timeout: nothing is scored.
    let mut got = Vec::new();
    for (i, f) in frames[2..].iter().enumerate() {
        e.process(2_500_000 + i as u64, f, &mut |o| got.push(o));
    }
    assert!(!got.iter().any(|o| matches!(o, Output::Scored(_))));
    assert_eq!(e.stats().stale_drops, 2);
}

#[test]
fn invalid_objects_are_not_scored_and_their_track_is_dropped() {
    let run = with_engine(cfg(), |_, send| {
        let db = project_db();
        let mut t = 0;
        for k in 0..4 {
            let mut frames = Cycle::closing(2, 20.0).frames(&db);
            if k == 2 {
                frames[2] = frame(
                    &db,
                    project::OBJECT_POSITION,
                    &[("ObjId", 2.0), ("ObjPosX", 20.0), ("ObjValid", 0.0)],
                );
            }
            for f in &frames {
                send(t, f);
                t += 10;
            }
            t += 100_000;
        }
    });
    assert_eq!(run.scored(2), 3);
    assert!(run.outputs.iter().any(|o| matches!(
        o,
        Output::WarningOff {
            track: 2,
            reason: ReleaseReason::Invalid,
            ..
        }
    )));
}

#[test]
fn corrupt_and_mismatched_models_are_refused_with_the_reason() {
    let good = msra_blob();
    assert!(ModelFile::from_bytes(Path::new("ok.rsk"), good.clone()).is_ok());

    let mut flipped = good.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x40;
    let err = ModelFile::from_bytes(Path::new("flip.rsk"), flipped)
        .unwrap_err()
        .to_string();
    assert!(err.contains("flip.rsk") && err.contains("refused"), "{err}");
    assert!(err.to_lowercase().contains("crc"), "{err}");

    let err = ModelFile::from_bytes(Path::new("short.rsk"), good[..10].to_vec())
        .unwrap_err()
        .to_string();
    assert!(err.contains("short.rsk"), "{err}");

    // Another feature schema (header bytes 8..10): a model trained on other inputs.
    let mut schema = good.clone();
    schema[8] = 0x7F;
    let err = ModelFile::from_bytes(Path::new("schema.rsk"), schema)
        .unwrap_err()
        .to_string();
    assert!(err.to_lowercase().contains("schema"), "{err}");

    let err = ModelFile::from_bytes(Path::new("text.rsk"), b"not a model at all".to_vec())
        .unwrap_err()
        .to_string();
    assert!(
        err.to_lowercase().contains("magic") || err.to_lowercase().contains("truncated"),
        "{err}"
    );

    let err = ModelFile::load(Path::new("/nonexistent/model.rsk"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("/nonexistent/model.rsk"), "{err}");
}
