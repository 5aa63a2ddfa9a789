//! Event tables as 10 Hz vehicle CAN traffic in the project DBC (`can-bridge/dbc/riskscore.dbc`),
//! written in `candump -L` format, so simulated and recorded trajectories can be driven through
//! the CAN bridge.
//!
//! Timeline ([`Layout`]): events are placed one after another in file order, each starting
//! `gap_us` after the previous one ends, from `start_us`. Event `k` is object track `k % 256`, so a
//! track id is reused only after 256 events, long after the bridge dropped the old track. Frame
//! `i` of an event is one cycle at `cycle_start(k, i)`: `EGO_MOTION` (+0 us), `EGO_SIZE` (+200),
//! `OBJECT_POSITION` (+400), `OBJECT_SIZE` (+600) and `OBJECT_MOTION` (+800, the bridge's trigger).
//!
//! Frame conversion (world frame -> ego frame, computed in f64): the ego is at the origin heading
//! +x; partner position and heading are rotated into the ego frame, the partner velocity is sent
//! relative to the ego velocity, both in ego axes; ego velocity components are along and across
//! its heading. Values outside a signal's DBC range are not clamped: the whole cycle is skipped and
//! reported, so the log never carries a silently wrong state.
use crate::events::{Event, EventSet, Frame as EventFrame};
use can_codec::{project, Database, Frame};
use std::collections::HashMap;
use std::io::Write;

/// Default log start: 2023-11-14T22:13:20Z, a plausible recording epoch.
pub const DEFAULT_START_US: u64 = 1_700_000_000_000_000;
/// Default pause between events (longer than any sensible bridge stale timeout).
pub const DEFAULT_GAP_US: u64 = 2_000_000;
/// Offset of each message inside a cycle.
pub const SLOT_US: u64 = 200;
/// Offset of the trigger message (`OBJECT_MOTION`) inside a cycle.
pub const TRIGGER_OFFSET_US: u64 = 4 * SLOT_US;

/// Where the exporter puts things.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportOptions {
    pub iface: String,
    pub start_us: u64,
    pub gap_us: u64,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            iface: "vcan0".into(),
            start_us: DEFAULT_START_US,
            gap_us: DEFAULT_GAP_US,
        }
    }
}

/// One event on the timeline.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Placement {
    pub track_id: u32,
    /// Cycle start (us) of every frame of the event.
    pub cycle_us: Vec<u64>,
}

/// All events on the timeline, in event-set order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    pub placements: Vec<Placement>,
}

impl Layout {
    /// Places the events of `set` as described in the module documentation.
    pub fn new(set: &EventSet, opts: &ExportOptions) -> Self {
        let mut next_start = opts.start_us;
        let placements = set
            .events
            .iter()
            .enumerate()
            .map(|(k, ev)| {
                let t0 = ev.frames.first().map_or(0.0, |f| f.time);
                let cycle_us: Vec<u64> = ev
                    .frames
                    .iter()
                    .map(|f| next_start + ((f.time - t0) * 1e6).round().max(0.0) as u64)
                    .collect();
                let end = cycle_us.last().copied().unwrap_or(next_start) + TRIGGER_OFFSET_US;
                next_start = end + opts.gap_us;
                Placement {
                    track_id: (k % 256) as u32,
                    cycle_us,
                }
            })
            .collect();
        Self { placements }
    }

    /// `(track id, trigger timestamp)` -> `(event index, frame index)`: how a bridge output is
    /// traced back to the event frame it scored.
    pub fn trigger_index(&self) -> HashMap<(u32, u64), (usize, usize)> {
        let mut map = HashMap::new();
        for (k, p) in self.placements.iter().enumerate() {
            for (i, c) in p.cycle_us.iter().enumerate() {
                map.insert((p.track_id, c + TRIGGER_OFFSET_US), (k, i));
            }
        }
        map
    }
}

/// Why one cycle could not be encoded.
#[derive(Debug, thiserror::Error)]
pub enum EncodeError {
    #[error("message {0} missing from the project DBC")]
    MissingMessage(&'static str),
    /// A signal value the DBC cannot carry (out of range, unknown signal).
    #[error(transparent)]
    Signal(#[from] can_codec::DbcError),
    #[error("{0}: payload above 8 bytes")]
    PayloadTooLong(&'static str),
}

/// A cycle the exporter could not encode.
#[derive(Debug)]
pub struct SkippedFrame {
    pub event_id: String,
    pub time: f64,
    pub reason: EncodeError,
}

/// What [`write_candump`] wrote.
#[derive(Debug, Default)]
pub struct ExportSummary {
    pub events: usize,
    pub cycles: usize,
    pub can_frames: usize,
    pub duration_s: f64,
    pub skipped: Vec<SkippedFrame>,
}

impl ExportSummary {
    /// How many events lost at least one cycle (skips come in event order).
    pub fn events_with_skips(&self) -> usize {
        let mut n = 0;
        let mut last: Option<&str> = None;
        for s in &self.skipped {
            if last != Some(s.event_id.as_str()) {
                n += 1;
                last = Some(&s.event_id);
            }
        }
        n
    }
}

/// Why the export failed as a whole.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("project DBC: {0}")]
    Dbc(#[from] can_codec::DbcError),
    #[error("writing the log: {0}")]
    Io(#[from] std::io::Error),
    /// [`ExportOptions::iface`] cannot be read back from a candump line.
    #[error("--iface: {0}")]
    Iface(String),
}

/// The project's messages, resolved once.
pub struct Encoder {
    db: Database,
}

/// Ego-frame quantities of one event frame (what the CAN messages carry), before quantisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EgoFrameState {
    pub ego_vel_long: f64,
    pub ego_vel_lat: f64,
    pub ego_accel: f64,
    pub pos_x: f64,
    pub pos_y: f64,
    pub vel_rel_x: f64,
    pub vel_rel_y: f64,
    /// Partner heading in the ego frame, radians in `[0, 2 pi)`.
    pub heading: f64,
    pub accel: f64,
}

/// World frame -> ego frame (ego at origin, heading +x), in f64.
pub fn to_ego_frame(f: &EventFrame) -> EgoFrameState {
    let (e, s) = (&f.ego, &f.partner);
    let norm = f64::from(e.hx).hypot(f64::from(e.hy));
    let (c, sn) = if norm > 0.0 {
        (f64::from(e.hx) / norm, f64::from(e.hy) / norm)
    } else {
        (1.0, 0.0)
    };
    let rot = |x: f64, y: f64| (c * x + sn * y, -sn * x + c * y);
    let (pos_x, pos_y) = rot(
        f64::from(s.x) - f64::from(e.x),
        f64::from(s.y) - f64::from(e.y),
    );
    let (evx, evy) = rot(f64::from(e.vx), f64::from(e.vy));
    let (svx, svy) = rot(f64::from(s.vx), f64::from(s.vy));
    let (hx, hy) = rot(f64::from(s.hx), f64::from(s.hy));
    let mut heading = hy.atan2(hx);
    if heading < 0.0 {
        heading += std::f64::consts::TAU;
    }
    // Rounding to the signal resolution must not produce 2 pi (outside [0, 2 pi)).
    if heading >= std::f64::consts::TAU - 0.0002 {
        heading = 0.0;
    }
    EgoFrameState {
        ego_vel_long: evx,
        ego_vel_lat: evy,
        ego_accel: f64::from(e.acc),
        pos_x,
        pos_y,
        vel_rel_x: svx - evx,
        vel_rel_y: svy - evy,
        heading,
        accel: f64::from(s.acc),
    }
}

impl Encoder {
    pub fn new() -> Result<Self, ExportError> {
        Ok(Self {
            db: Database::parse(project::PROJECT_DBC)?,
        })
    }

    fn message(&self, name: &'static str, values: &[(&str, f64)]) -> Result<Frame, EncodeError> {
        let m = self
            .db
            .message_by_name(name)
            .ok_or(EncodeError::MissingMessage(name))?;
        let data = m.encode(values)?;
        Frame::data_frame(m.id, &data).ok_or(EncodeError::PayloadTooLong(name))
    }

    /// The value the receiver decodes when `value` is sent in `signal` of `message` (rounded to
    /// the signal's resolution); `value` itself when it cannot be encoded (the cycle then fails
    /// on that signal).
    fn as_decoded(&self, message: &str, signal: &str, value: f64) -> f64 {
        let Some(m) = self.db.message_by_name(message) else {
            return value;
        };
        let Some(sig) = m.signal_index(signal).map(|i| &m.signals[i]) else {
            return value;
        };
        let mut data = vec![0u8; m.size];
        sig.encode(value, &mut data)
            .and_then(|()| sig.decode(&data))
            .unwrap_or(value)
    }

    /// The five frames of one cycle, in send order (trigger last).
    ///
    /// The receiver adds the ego velocity *as decoded* to the relative velocity, so the relative
    /// velocity is taken against the ego velocity rounded to its signal's resolution: decoded
    /// ego + decoded relative is the partner's velocity to the relative signal's resolution, and
    /// a partner at rest decodes as exactly 0 (not +-0.001 m/s, which a surrogate such as TAdv
    /// reads as moving, possibly against the ego's direction).
    pub fn cycle(&self, ev: &Event, f: &EventFrame, track: u32) -> Result<[Frame; 5], EncodeError> {
        let mut s = to_ego_frame(f);
        let partner_vx = s.vel_rel_x + s.ego_vel_long;
        let partner_vy = s.vel_rel_y + s.ego_vel_lat;
        s.vel_rel_x =
            partner_vx - self.as_decoded(project::EGO_MOTION, "EgoVelLong", s.ego_vel_long);
        s.vel_rel_y = partner_vy - self.as_decoded(project::EGO_MOTION, "EgoVelLat", s.ego_vel_lat);
        let id = f64::from(track);
        Ok([
            self.message(
                project::EGO_MOTION,
                &[
                    ("EgoVelLong", s.ego_vel_long),
                    ("EgoVelLat", s.ego_vel_lat),
                    ("EgoAccel", s.ego_accel),
                    ("EgoYawRate", 0.0),
                ],
            )?,
            self.message(
                project::EGO_SIZE,
                &[
                    ("EgoLength", f64::from(ev.dims.length_ego)),
                    ("EgoWidth", f64::from(ev.dims.width_ego)),
                ],
            )?,
            self.message(
                project::OBJECT_POSITION,
                &[
                    ("ObjId", id),
                    ("ObjPosX", s.pos_x),
                    ("ObjPosY", s.pos_y),
                    ("ObjHeading", s.heading),
                    ("ObjHeadingValid", 1.0),
                    ("ObjValid", 1.0),
                ],
            )?,
            self.message(
                project::OBJECT_SIZE,
                &[
                    ("ObjId", id),
                    ("ObjLength", f64::from(ev.dims.length_partner)),
                    ("ObjWidth", f64::from(ev.dims.width_partner)),
                ],
            )?,
            self.message(
                project::OBJECT_MOTION,
                &[
                    ("ObjId", id),
                    ("ObjVelRelX", s.vel_rel_x),
                    ("ObjVelRelY", s.vel_rel_y),
                    ("ObjAccel", s.accel),
                ],
            )?,
        ])
    }
}

/// Writes `set` as a candump `-L` log into `out`.
pub fn write_candump<W: Write>(
    set: &EventSet,
    opts: &ExportOptions,
    out: W,
) -> Result<ExportSummary, ExportError> {
    can_codec::check_iface_name(&opts.iface).map_err(ExportError::Iface)?;
    let encoder = Encoder::new()?;
    let layout = Layout::new(set, opts);
    let mut out = std::io::BufWriter::new(out);
    let mut summary = ExportSummary {
        events: set.events.len(),
        ..ExportSummary::default()
    };
    let mut line = String::with_capacity(64);
    let mut last_us = opts.start_us;
    for (ev, place) in set.events.iter().zip(&layout.placements) {
        for (f, cycle) in ev.frames.iter().zip(&place.cycle_us) {
            match encoder.cycle(ev, f, place.track_id) {
                Ok(frames) => {
                    for (slot, frame) in frames.iter().enumerate() {
                        line.clear();
                        let t = cycle + slot as u64 * SLOT_US;
                        can_codec::format_line(&mut line, t, &opts.iface, frame);
                        line.push('\n');
                        out.write_all(line.as_bytes())?;
                        last_us = t;
                    }
                    summary.cycles += 1;
                    summary.can_frames += frames.len();
                }
                Err(reason) => summary.skipped.push(SkippedFrame {
                    event_id: ev.id.clone(),
                    time: f.time,
                    reason,
                }),
            }
        }
    }
    out.flush()?;
    summary.duration_s = last_us.saturating_sub(opts.start_us) as f64 / 1e6;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::{Dims, EventKind};
    use scorer_core::VehicleState;

    fn state(x: f32, y: f32, vx: f32, vy: f32, heading: f32) -> VehicleState {
        VehicleState {
            x,
            y,
            vx,
            vy,
            hx: heading.cos(),
            hy: heading.sin(),
            acc: 0.5,
            length: 4.5,
            width: 1.8,
        }
    }

    #[test]
    fn ego_frame_conversion_rotates_and_makes_velocity_relative() {
        // Ego heading +y (90 deg) at (10, 5) driving 10 m/s; partner 20 m ahead of it (world +y),
        // heading -x (180 deg), driving 5 m/s.
        let f = EventFrame {
            time: 0.0,
            ego: state(10.0, 5.0, 0.0, 10.0, std::f32::consts::FRAC_PI_2),
            partner: state(10.0, 25.0, -5.0, 0.0, std::f32::consts::PI),
        };
        let s = to_ego_frame(&f);
        assert!((s.pos_x - 20.0).abs() < 1e-5, "{s:?}");
        assert!(s.pos_y.abs() < 1e-5);
        assert!((s.ego_vel_long - 10.0).abs() < 1e-5);
        assert!(s.ego_vel_lat.abs() < 1e-5);
        // Partner velocity in ego axes: world -x is ego +y (left). Relative: (0 - 10, 5 - 0).
        assert!((s.vel_rel_x + 10.0).abs() < 1e-5);
        assert!((s.vel_rel_y - 5.0).abs() < 1e-5);
        // Partner heading world 180 deg = ego-frame 90 deg.
        assert!((s.heading - std::f64::consts::FRAC_PI_2).abs() < 1e-5);
    }

    #[test]
    fn layout_places_events_in_order_with_gaps_and_skips_out_of_range_cycles() {
        let mk = |id: &str, n: usize, far: bool| Event {
            id: id.into(),
            kind: EventKind::Safe,
            t_start: 0.0,
            t_end: n as f64 * 0.1,
            t_impact: None,
            dims: Dims {
                length_ego: 4.5,
                width_ego: 1.8,
                length_partner: 4.8,
                width_partner: 1.9,
            },
            frames: (0..n)
                .map(|i| EventFrame {
                    time: 3.0 + i as f64 * 0.1,
                    ego: state(0.0, 0.0, 10.0, 0.0, 0.0),
                    partner: state(if far && i == 1 { 900.0 } else { 20.0 }, 0.0, 8.0, 0.0, 0.0),
                })
                .collect(),
        };
        let set = EventSet {
            events: vec![mk("a", 3, false), mk("b", 2, true)],
        };
        let opts = ExportOptions::default();
        let layout = Layout::new(&set, &opts);
        assert_eq!(
            layout.placements[0].cycle_us,
            vec![
                opts.start_us,
                opts.start_us + 100_000,
                opts.start_us + 200_000
            ]
        );
        let b0 = opts.start_us + 200_000 + TRIGGER_OFFSET_US + opts.gap_us;
        assert_eq!(layout.placements[1].cycle_us[0], b0);
        assert_eq!(layout.placements[1].track_id, 1);
        assert_eq!(layout.trigger_index()[&(1, b0 + TRIGGER_OFFSET_US)], (1, 0));

        let mut buf = Vec::new();
        let summary = write_candump(&set, &opts, &mut buf).unwrap();
        assert_eq!(summary.cycles, 4);
        assert_eq!(summary.skipped.len(), 1);
        assert_eq!(summary.skipped[0].event_id, "b");
        // The codec's own error is the reason, not a copy of its text.
        assert!(matches!(
            summary.skipped[0].reason,
            EncodeError::Signal(can_codec::DbcError::BadSignal { .. }) | EncodeError::Signal(_)
        ));
        assert_eq!(summary.events_with_skips(), 1);
        let text = String::from_utf8(buf).unwrap();
        assert_eq!(text.lines().count(), 20);
        let first = can_codec::parse_line(text.lines().next().unwrap()).unwrap();
        assert_eq!(first.timestamp_us, opts.start_us);
        assert_eq!(first.iface, "vcan0");
        assert_eq!(first.frame.id, can_codec::CanId::Standard(0x100));
        // EgoVelLong = 10 m/s at 0.002 m/s resolution = raw 5000 (Intel, little endian).
        assert_eq!(&first.frame.data()[..2], &5000u16.to_le_bytes());
    }
}
