//! Shared helpers for the bridge's integration tests: a small MSRA model built in memory, a small
//! simulated event folder, and frame builders for the project DBC.
#![allow(dead_code)]
use can_codec::{project, CanId, Database, Frame};
use scorer_core::model::{encode, BoundedVec, Model};
use scorer_core::msra::{MsraModel, MsraTerm};
use scorer_core::SurrogateKind;

/// An MSRA model over TTC2D and EI (sum of weights 3.0), encoded as a model blob.
pub fn msra_blob() -> Vec<u8> {
    let terms = [
        MsraTerm {
            kind: SurrogateKind::Ttc2d,
            weight: 2.0,
            a: -1.5,
            b: 3.0,
            lo: 0.0,
            hi: 10.0,
        },
        MsraTerm {
            kind: SurrogateKind::Ei,
            weight: 1.0,
            a: 0.8,
            b: -2.0,
            lo: -5.0,
            hi: 20.0,
        },
    ];
    let model = Model::Msra(MsraModel {
        terms: BoundedVec::from_slice(&terms).unwrap(),
        gssm: None,
    });
    let mut buf = vec![0u8; 4096];
    let n = encode(&model, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

pub fn project_db() -> Database {
    Database::parse(project::PROJECT_DBC).unwrap()
}

pub fn frame(db: &Database, message: &str, values: &[(&str, f64)]) -> Frame {
    let m = db.message_by_name(message).unwrap();
    Frame::data_frame(m.id, &m.encode(values).unwrap()).unwrap()
}

pub fn id_of(db: &Database, message: &str) -> CanId {
    db.message_by_name(message).unwrap().id
}

/// One full cycle (ego + one object) for the project DBC, trigger last.
pub struct Cycle {
    pub ego_speed: f64,
    pub track: u32,
    pub pos: (f64, f64),
    pub vel_rel: (f64, f64),
    pub heading: f64,
}

impl Cycle {
    pub fn frames(&self, db: &Database) -> Vec<Frame> {
        let id = f64::from(self.track);
        vec![
            frame(db, project::EGO_MOTION, &[("EgoVelLong", self.ego_speed)]),
            frame(
                db,
                project::EGO_SIZE,
                &[("EgoLength", 4.5), ("EgoWidth", 1.8)],
            ),
            frame(
                db,
                project::OBJECT_POSITION,
                &[
                    ("ObjId", id),
                    ("ObjPosX", self.pos.0),
                    ("ObjPosY", self.pos.1),
                    ("ObjHeading", self.heading),
                    ("ObjHeadingValid", 1.0),
                    ("ObjValid", 1.0),
                ],
            ),
            frame(
                db,
                project::OBJECT_SIZE,
                &[("ObjId", id), ("ObjLength", 4.6), ("ObjWidth", 1.9)],
            ),
            frame(
                db,
                project::OBJECT_MOTION,
                &[
                    ("ObjId", id),
                    ("ObjVelRelX", self.vel_rel.0),
                    ("ObjVelRelY", self.vel_rel.1),
                ],
            ),
        ]
    }

    /// A stopped car `gap` m ahead while the ego drives 20 m/s: high risk.
    pub fn closing(track: u32, gap: f64) -> Self {
        Self {
            ego_speed: 20.0,
            track,
            pos: (gap, 0.0),
            vel_rel: (-20.0, 0.0),
            heading: 0.0,
        }
    }

    /// A car 40 m ahead driving away: low risk.
    pub fn receding(track: u32) -> Self {
        Self {
            ego_speed: 20.0,
            track,
            pos: (40.0, 3.5),
            vel_rel: (5.0, 0.0),
            heading: 0.0,
        }
    }
}

/// A small simulated event folder (deterministic).
#[cfg(feature = "check")]
pub fn simulated_events(n: usize, seed: u64) -> riskscore_data::events::EventSet {
    let cfg = riskscore_data::sim::SimConfig {
        seed,
        events: n,
        threads: 1,
        ..Default::default()
    };
    riskscore_data::sim::simulate_events(&cfg).unwrap().0
}

/// `cycles` 10 Hz cycles of two tracks (one closing, one receding) from `t0`, 5 frames each per
/// track, each frame 100 us after the previous one within a cycle; the closing track's distance
/// follows the cycle index, so `0..n` then `n..m` is one drive in two parts.
pub fn two_track_drive(
    db: &Database,
    cycles: std::ops::Range<usize>,
    t0: u64,
) -> Vec<(u64, Frame)> {
    let mut out = Vec::new();
    let mut t = t0;
    for k in cycles {
        let gap = 60.0 - (k % 200) as f64 * 0.25;
        for c in [Cycle::closing(3, gap), Cycle::receding(9)] {
            for f in c.frames(db) {
                out.push((t, f));
                t += 100;
            }
        }
        t += 100_000 - 1_000;
    }
    out
}

/// `frames` as a candump -L log on `can0`, one line each.
pub fn candump_log(frames: &[(u64, Frame)]) -> String {
    let mut s = String::new();
    for (t, f) in frames {
        can_codec::format_line(&mut s, *t, "can0", f);
        s.push('\n');
    }
    s
}
