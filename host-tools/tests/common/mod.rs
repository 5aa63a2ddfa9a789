//! What the `riskctl` command-line tests share: running the binary and reading what it printed,
//! and the shipped models. Each test file uses a part of it.
#![allow(dead_code)]
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

/// Runs `riskctl` with `args` in the test's working directory.
pub fn riskctl(args: &[&str]) -> Output {
    Command::new(RISKCTL)
        .args(args)
        .output()
        .expect("run riskctl")
}

/// Runs `riskctl` with `args` in `dir` (relative paths in `args` are `dir`'s).
pub fn riskctl_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(RISKCTL)
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run riskctl")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A model blob shipped under `models/`.
pub fn shipped_model(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../models")
        .join(name)
}

/// A safe sequence of calm following (3 s at 10 Hz, as `riskctl import commonroad` writes real
/// recordings): two cars at `v` m/s, `gap` m between the boxes.
pub fn calm_following(id: String, v: f32, gap: f32) -> riskscore_data::events::Event {
    use riskscore_data::events::{Dims, Event, EventKind, Frame};
    let state = |x: f32| scorer_core::VehicleState {
        x,
        vx: v,
        hx: 1.0,
        length: 4.5,
        width: 1.8,
        ..Default::default()
    };
    let frames: Vec<Frame> = (0..30)
        .map(|i| {
            let t = i as f64 * 0.1;
            let x = v * t as f32;
            Frame {
                time: t,
                ego: state(x),
                partner: state(x + 4.5 + gap),
            }
        })
        .collect();
    Event {
        id,
        kind: EventKind::Safe,
        t_start: 0.0,
        t_end: 2.9,
        t_impact: None,
        dims: Dims {
            length_ego: 4.5,
            width_ego: 1.8,
            length_partner: 4.5,
            width_partner: 1.8,
        },
        frames,
    }
}

/// A small simulated event folder `dir/events` (seed 3, 9 events, 3 of each kind).
pub fn simulate(dir: &Path) -> PathBuf {
    simulate_mix(dir, "events", "9", "3,3,3")
}

/// A simulated event folder `dir/name` of `events` events in the crash,near-crash,safe `mix`
/// (seed 3).
pub fn simulate_mix(dir: &Path, name: &str, events: &str, mix: &str) -> PathBuf {
    let out = dir.join(name);
    let o = riskctl(&[
        "simulate",
        "--out",
        out.to_str().unwrap(),
        "--seed",
        "3",
        "--events",
        events,
        "--mix",
        mix,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    out
}
