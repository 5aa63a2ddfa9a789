//! Test and benchmark inputs for the vcan VM harness (tests/vm/run.sh, tests/vm/bench.sh).
//!
//! `cargo run -p can-bridge --example vm_fixtures -- --out DIR [--model FILE] [--drive LOG]
//!  [--bench-fps N --bench-seconds S]` writes into DIR:
//! - `model.rsk`: the given model, or a small MSRA model (TTC2D + EI) when none is given;
//! - `corrupt.rsk`: the same model with one payload byte flipped (must be refused);
//! - `threshold.txt`: with `--drive`, a threshold at which about half of the drive's tracks warn
//!   (median of the per-track maximum scores), so the live/offline comparison is not vacuous;
//! - `faults.log`: two healthy tracks plus unknown ids, a wrong DLC, an out-of-range value, error
//!   frames (incl. bus-off), a remote frame, a CAN FD frame, and a track whose position stops;
//! - `bench.log`: with `--bench-fps`, `N` frames/s of project-DBC traffic for `S` seconds.
use can_bridge::engine::{Engine, EngineConfig, Output};
use can_bridge::map::CompiledMap;
use can_bridge::ModelFile;
use can_codec::{project, CanId, Database, Frame};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The integration tests' MSRA model, DBC and frame builders: the VM runs what the host tests ran.
#[path = "../tests/common/mod.rs"]
mod common;
use common::{frame, msra_blob, project_db};

struct Obj {
    id: f64,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
}

fn object_frames(db: &Database, o: &Obj) -> [Frame; 3] {
    [
        frame(
            db,
            project::OBJECT_POSITION,
            &[
                ("ObjId", o.id),
                ("ObjPosX", o.x),
                ("ObjPosY", o.y),
                ("ObjHeading", 0.0),
                ("ObjHeadingValid", 1.0),
                ("ObjValid", 1.0),
            ],
        ),
        frame(
            db,
            project::OBJECT_SIZE,
            &[("ObjId", o.id), ("ObjLength", 4.6), ("ObjWidth", 1.9)],
        ),
        frame(
            db,
            project::OBJECT_MOTION,
            &[("ObjId", o.id), ("ObjVelRelX", o.vx), ("ObjVelRelY", o.vy)],
        ),
    ]
}

fn ego_frames(db: &Database, speed: f64) -> [Frame; 2] {
    [
        frame(db, project::EGO_MOTION, &[("EgoVelLong", speed)]),
        frame(
            db,
            project::EGO_SIZE,
            &[("EgoLength", 4.5), ("EgoWidth", 1.8)],
        ),
    ]
}

fn write_log(path: &Path, lines: &[(u64, Frame)]) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut s = String::new();
    for (t, f) in lines {
        s.clear();
        can_codec::format_line(&mut s, *t, "vcan0", f);
        writeln!(w, "{s}")?;
    }
    w.flush()
}

fn faults_log(db: &Database) -> Vec<(u64, Frame)> {
    let mut out = Vec::new();
    let t0 = 1_700_000_000_000_000u64;
    for k in 0..30u64 {
        let mut t = t0 + k * 100_000;
        let mut push = |f: Frame, out: &mut Vec<(u64, Frame)>| {
            out.push((t, f));
            t += 250;
        };
        for f in ego_frames(db, 20.0) {
            push(f, &mut out);
        }
        // Track 1 closes in on a stopped car and warns; track 2 drives away.
        let gap = 45.0 - 1.2 * k as f64;
        let tracks = [
            Obj {
                id: 1.0,
                x: gap,
                y: 0.0,
                vx: -20.0,
                vy: 0.0,
            },
            Obj {
                id: 2.0,
                x: 40.0 + k as f64,
                y: 3.5,
                vx: 5.0,
                vy: 0.0,
            },
            Obj {
                id: 3.0,
                x: 30.0,
                y: -3.5,
                vx: -1.0,
                vy: 0.0,
            },
        ];
        for o in &tracks {
            let mut frames = object_frames(db, o);
            if o.id == 2.0 && k == 8 {
                let d = frames[0].data()[..7].to_vec();
                frames[0] = Frame::data_frame(frames[0].id, &d).expect("7 bytes");
            }
            if o.id == 2.0 && k == 10 {
                let m = db.message_by_name(project::OBJECT_SIZE).expect("size");
                let mut d = frames[1].data().to_vec();
                let s = &m.signals[m.signal_index("ObjLength").expect("signal")];
                s.write_raw(40_000, &mut d).expect("fits");
                frames[1] = Frame::data_frame(m.id, &d).expect("5 bytes");
            }
            // Track 3's position stops after cycle 15: its later updates are stale.
            let skip_position = o.id == 3.0 && k > 15;
            for (i, f) in frames.iter().enumerate() {
                if !(skip_position && i == 0) {
                    push(*f, &mut out);
                }
            }
        }
        match k {
            5 => {
                push(
                    Frame::data_frame(CanId::Standard(0x7AB), &[1, 2, 3]).expect("ok"),
                    &mut out,
                );
                push(
                    Frame::data_frame(CanId::Extended(0x18FE_F100), &[0; 8]).expect("ok"),
                    &mut out,
                );
                push(
                    Frame::remote_frame(CanId::Standard(0x201), 8).expect("ok"),
                    &mut out,
                );
                push(
                    Frame::fd_frame(CanId::Standard(0x3A0), 1, &[0xAA; 12]).expect("ok"),
                    &mut out,
                );
            }
            12 => {
                push(
                    Frame::error_frame(0x04, &[0, 0x10, 0, 0, 0, 0, 0, 0]).expect("ok"),
                    &mut out,
                );
                push(Frame::error_frame(0x40, &[0; 8]).expect("ok"), &mut out);
            }
            _ => {}
        }
    }
    out
}

fn bench_log(db: &Database, fps: u64, seconds: u64) -> Vec<(u64, Frame)> {
    // One cycle: ego (2 frames) + 40 objects (3 frames each), frames evenly spaced at 1/fps.
    let objects = 40u64;
    let per_cycle = 2 + 3 * objects;
    let step = 1_000_000 / fps;
    let total = fps * seconds;
    let mut out = Vec::with_capacity(total as usize);
    let mut t = 1_700_000_000_000_000u64;
    let mut cycle = 0u64;
    while (out.len() as u64) < total {
        let mut frames: Vec<Frame> = ego_frames(db, 25.0).to_vec();
        for i in 0..objects {
            // Lanes of traffic ahead and behind; every 8th object closes in on the ego and warns.
            let phase = ((cycle + i * 7) % 100) as f64 / 10.0;
            let closing = i % 8 == 0;
            let o = Obj {
                id: i as f64,
                x: if closing {
                    60.0 - 5.0 * phase
                } else {
                    -80.0 + 4.0 * i as f64
                },
                y: -7.0 + 3.5 * (i % 5) as f64,
                vx: if closing { -18.0 } else { 1.0 },
                vy: 0.0,
            };
            frames.extend(object_frames(db, &o));
        }
        for f in frames
            .into_iter()
            .take((total - out.len() as u64).min(per_cycle) as usize)
        {
            out.push((t, f));
            t += step;
        }
        cycle += 1;
    }
    out
}

/// Median over tracks of the maximum score each track reaches in `log`.
fn median_track_max(log: &Path, model: &ModelFile) -> f32 {
    let (_db, map) = CompiledMap::project_default().expect("project map");
    let mut engine = Engine::new(
        model.model().expect("model"),
        map,
        EngineConfig::new(f32::MAX),
    )
    .expect("engine");
    let mut max: HashMap<(u32, u64), f32> = HashMap::new();
    let mut epoch: HashMap<u32, (u64, u64)> = HashMap::new();
    can_bridge::logfile::for_each_frame(log, |_, rec| {
        engine.process(rec.timestamp_us, &rec.frame, &mut |o| {
            if let Output::Scored(s) = o {
                // A track id seen again after a pause is another event.
                let e = epoch.entry(s.track).or_insert((0, s.t_us));
                if s.t_us.saturating_sub(e.1) > 1_000_000 {
                    e.0 += 1;
                }
                e.1 = s.t_us;
                let m = max.entry((s.track, e.0)).or_insert(f32::NEG_INFINITY);
                *m = m.max(s.score);
            }
        });
    })
    .expect("drive log readable");
    let mut v: Vec<f32> = max.into_values().collect();
    v.sort_by(f32::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(1.0)
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut out, mut model, mut drive, mut fps, mut seconds) = (None, None, None, None, 60u64);
    while let Some(a) = args.next() {
        let mut val = || {
            args.next()
                .ok_or_else(|| anyhow::anyhow!("{a} needs a value"))
        };
        match a.as_str() {
            "--out" => out = Some(PathBuf::from(val()?)),
            "--model" => model = Some(PathBuf::from(val()?)),
            "--drive" => drive = Some(PathBuf::from(val()?)),
            "--bench-fps" => fps = Some(val()?.parse::<u64>()?),
            "--bench-seconds" => seconds = val()?.parse::<u64>()?,
            other => anyhow::bail!("unknown argument {other}"),
        }
    }
    let out = out.ok_or_else(|| anyhow::anyhow!("--out DIR is required"))?;
    std::fs::create_dir_all(&out)?;
    let blob = match &model {
        Some(p) => std::fs::read(p)?,
        None => msra_blob(),
    };
    let model_file = ModelFile::from_bytes(Path::new("model.rsk"), blob.clone())?;
    std::fs::write(out.join("model.rsk"), &blob)?;
    let mut corrupt = blob.clone();
    let last = corrupt.len() - 1;
    corrupt[last] ^= 0x5A;
    std::fs::write(out.join("corrupt.rsk"), &corrupt)?;
    let db = project_db();
    write_log(&out.join("faults.log"), &faults_log(&db))?;
    if let Some(d) = &drive {
        let t = median_track_max(d, &model_file);
        std::fs::write(out.join("threshold.txt"), format!("{t}\n"))?;
    }
    if let Some(fps) = fps {
        anyhow::ensure!(
            fps > 0 && fps <= 1_000_000,
            "--bench-fps must be 1..=1000000"
        );
        write_log(&out.join("bench.log"), &bench_log(&db, fps, seconds))?;
    }
    Ok(())
}
