//! A simulated Toyota TSS-P car: an event folder as the two buses of `maps/toyota_tss_p_radar.toml`
//! would carry it (powertrain `SPEED` + `KINEMATICS` on can0, the radar's `TRACK_A_n`/`TRACK_B_n`
//! slots on can1), through the real DBCs in `maps/dbc/`.
//!
//! The radar model is physical, not the map's inverse: `LONG_DIST` is the distance from the radar
//! to the partner box's near face (its half extent along the ego's x axis), `LAT_DIST` the
//! centre's lateral offset, positive to the right; the partner is reported only while its centre
//! is ahead of the radar, inside [`RadarModel::half_fov`] and [`RadarModel::max_range`]. Event `k`
//! is slot `k % 16`; its first reported frame carries `NEW_TRACK = 1`; the other slots send
//! `VALID = 0`. Events are placed on the timeline of `riskctl events-to-candump`
//! ([`Layout`]), so the same event folder exported for the project DBC lines up with this log.
#![allow(dead_code)]
use can_codec::{Database, Frame};
use riskscore_data::candump_export::{to_ego_frame, ExportOptions, Layout};
use riskscore_data::events::EventSet;
use std::path::Path;

/// Where the simulated radar sits and what it sees (the shipped map's `[sensor]`).
#[derive(Clone, Copy, Debug)]
pub struct RadarModel {
    pub sensor_x: f64,
    pub half_fov: f64,
    pub max_range: f64,
    /// Send the yaw rate (KINEMATICS.YAW_RATE); false sends 0 deg/s (a car without the signal).
    pub yaw_rate: bool,
}

impl Default for RadarModel {
    fn default() -> Self {
        Self {
            sensor_x: 2.3,
            half_fov: 20f64.to_radians(),
            max_range: 150.0,
            yaw_rate: true,
        }
    }
}

/// What the radar reports of one event frame, or `None` when the partner is not seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Report {
    pub long_dist: f64,
    pub lat_dist: f64,
    pub rel_speed: f64,
    pub rel_accel: f64,
}

pub struct ToyotaCar {
    pt: Database,
    adas: Database,
    pub radar: RadarModel,
}

/// The encoded log and, per event, per frame, whether the radar saw the partner.
pub struct Encoded {
    pub log: String,
    pub seen: Vec<Vec<bool>>,
    pub frames: usize,
}

pub const SLOTS: u32 = 16;

impl ToyotaCar {
    pub fn new(radar: RadarModel) -> Self {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/dbc");
        Self {
            pt: Database::load(&dir.join("toyota_new_mc_pt_generated.dbc")).unwrap(),
            adas: Database::load(&dir.join("toyota_adas.dbc")).unwrap(),
            radar,
        }
    }

    fn frame(db: &Database, name: &str, values: &[(&str, f64)]) -> Frame {
        let m = db.message_by_name(name).unwrap();
        Frame::data_frame(
            m.id,
            &m.encode(values).unwrap_or_else(|e| panic!("{name}: {e}")),
        )
        .unwrap()
    }

    /// `KINEMATICS`, whose DBC range `[0|65535]` cannot hold a negative value: packed raw
    /// (unsigned, `(value - offset) / factor`).
    fn kinematics(&self, yaw_rate_deg_s: f64, accel_x: f64) -> Frame {
        let m = self.pt.message_by_name("KINEMATICS").unwrap();
        let mut data = vec![0u8; m.size];
        for (name, v) in [("YAW_RATE", yaw_rate_deg_s), ("ACCEL_X", accel_x)] {
            let s = &m.signals[m.signal_index(name).unwrap()];
            let top = ((1u64 << s.size) - 1) as f64;
            let raw = ((v - s.offset) / s.factor).round().clamp(0.0, top) as u64;
            s.write_raw(raw, &mut data).unwrap();
        }
        Frame::data_frame(m.id, &data).unwrap()
    }

    /// The radar's view of one event frame.
    pub fn report(&self, f: &riskscore_data::events::Frame) -> Option<Report> {
        let s = to_ego_frame(f);
        let (c, sn) = (s.heading.cos(), s.heading.sin());
        let (l, w) = (f64::from(f.partner.length), f64::from(f.partner.width));
        let half_extent_x = c.abs() * l / 2.0 + sn.abs() * w / 2.0;
        let (x, y) = (s.pos_x - self.radar.sensor_x, s.pos_y);
        let long_dist = x - half_extent_x;
        let seen = x > 0.0
            && long_dist > 0.5
            && y.atan2(x).abs() <= self.radar.half_fov
            && x.hypot(y) <= self.radar.max_range
            // What the signals can carry: LAT_DIST 11 bits signed at 0.04 m, REL_SPEED 12 bits
            // signed at 0.025 m/s.
            && y.abs() < 40.9
            && s.vel_rel_x.abs() < 51.1;
        let partner_accel_x = f64::from(f.partner.acc) * c;
        seen.then_some(Report {
            long_dist,
            lat_dist: -y,
            rel_speed: s.vel_rel_x,
            rel_accel: (partner_accel_x - s.ego_accel).round().clamp(-64.0, 63.0),
        })
    }

    /// Every event of `set` as candump lines on can0 (powertrain) and can1 (radar).
    pub fn encode(&self, set: &EventSet) -> Encoded {
        let layout = Layout::new(set, &ExportOptions::default());
        let mut log = String::new();
        let mut seen_all = Vec::new();
        let mut frames = 0;
        let mut push = |log: &mut String, t: u64, iface: &str, fr: &Frame| {
            can_codec::format_line(log, t, iface, fr);
            log.push('\n');
            frames += 1;
        };
        for (k, (ev, place)) in set.events.iter().zip(&layout.placements).enumerate() {
            let slot = k as u32 % SLOTS;
            let mut seen = Vec::new();
            let mut was_seen = false;
            for (i, (f, cycle)) in ev.frames.iter().zip(&place.cycle_us).enumerate() {
                let s = to_ego_frame(f);
                let yaw_rate = if self.radar.yaw_rate {
                    heading_rate(&ev.frames, i)
                } else {
                    0.0
                };
                push(
                    &mut log,
                    *cycle,
                    "can0",
                    &Self::frame(
                        &self.pt,
                        "SPEED",
                        &[("SPEED", s.ego_vel_long.max(0.0) * 3.6)],
                    ),
                );
                push(
                    &mut log,
                    cycle + 100,
                    "can0",
                    &self.kinematics(yaw_rate.to_degrees(), s.ego_accel),
                );
                let report = self.report(f);
                for n in 0..SLOTS {
                    let t = cycle + 1000 + 50 * u64::from(n);
                    let values: Vec<(&str, f64)> = match report {
                        Some(r) if n == slot => vec![
                            ("LONG_DIST", r.long_dist),
                            ("LAT_DIST", r.lat_dist),
                            ("REL_SPEED", r.rel_speed),
                            ("VALID", 1.0),
                            ("NEW_TRACK", if was_seen { 0.0 } else { 1.0 }),
                        ],
                        _ => vec![("VALID", 0.0)],
                    };
                    push(
                        &mut log,
                        t,
                        "can1",
                        &Self::frame(&self.adas, &format!("TRACK_A_{n}"), &values),
                    );
                }
                for n in 0..SLOTS {
                    let t = cycle + 2000 + 50 * u64::from(n);
                    let values: Vec<(&str, f64)> = match report {
                        Some(r) if n == slot => vec![("REL_ACCEL", r.rel_accel), ("SCORE", 100.0)],
                        _ => vec![],
                    };
                    push(
                        &mut log,
                        t,
                        "can1",
                        &Self::frame(&self.adas, &format!("TRACK_B_{n}"), &values),
                    );
                }
                was_seen = report.is_some();
                seen.push(was_seen);
            }
            seen_all.push(seen);
        }
        Encoded {
            log,
            seen: seen_all,
            frames,
        }
    }
}

/// The ego's yaw rate (rad/s) at frame `i` from its world heading (central difference).
fn heading_rate(frames: &[riskscore_data::events::Frame], i: usize) -> f64 {
    let a = &frames[i.saturating_sub(1)];
    let b = &frames[(i + 1).min(frames.len() - 1)];
    let h = |f: &riskscore_data::events::Frame| f64::from(f.ego.hy).atan2(f64::from(f.ego.hx));
    let dt = b.time - a.time;
    if dt <= 0.0 {
        return 0.0;
    }
    let mut d = h(b) - h(a);
    while d > std::f64::consts::PI {
        d -= std::f64::consts::TAU;
    }
    while d <= -std::f64::consts::PI {
        d += std::f64::consts::TAU;
    }
    d / dt
}
