//! The scoring engine: CAN frames in, scored tracks, warning frames and warning events out.
//!
//! Socket-free and clock-free: every call carries the frame's timestamp (kernel receive time live,
//! log time offline), so live, replay and offline scoring run exactly this code and give the same
//! results for the same frames.
//!
//! Per frame: input messages (by id, from the map) are decoded; ego fields update the ego state,
//! object fields the state of the track named by the message's track-id signal. The trigger message
//! completes a track update: the track is scored through `scorer-core` ([`Model::score`]) with the
//! ego at the origin heading +x, its warning state updated in the core's [`TrackTable`], and a
//! protected warning frame produced while it warns.
//!
//! Data quality rules (each counted in [`Stats`], never a panic, never blocking other tracks):
//! - unknown ids and remote frames are ignored; error frames are counted (bus-off separately);
//! - a frame whose length differs from the DBC, or with a non-finite or out-of-DBC-range signal,
//!   is dropped whole (decode error), the rest of the bus is unaffected;
//! - a frame up to 1 s older than the newest frame seen is dropped (reordered); a frame far off the
//!   timeline is dropped alone unless the following frames confirm a new log segment
//!   ([`crate::timeline`]); a second trigger for a track at the same timestamp is dropped
//!   (duplicate);
//! - a track is scored only if the ego motion and the object's position and velocity are at most
//!   `stale_us` old (else: stale drop); a track not updated for `stale_us` is dropped from the table
//!   and its warning released, so nothing is ever warned on stale data;
//! - an object whose valid flag is 0 is not scored and its track is dropped (an invalid slot's
//!   other signals are not even read: empty radar slots often carry out-of-range filler);
//! - an object whose `new_track` flag is 1 starts a fresh track in its slot: the old object's
//!   warning is released (`new_object`) and nothing of its state is carried over;
//! - a required input that has not arrived (ego speed, object position, a mapped velocity) is
//!   named once with its signal and message, not per frame.
//!
//! Object kinematics (bridge logic, documented in docs/can-bridge.md): Cartesian or polar
//! positions in the sensor frame, rotated and shifted by the sensor mounting into the ego frame;
//! velocity components the sensor does not send are taken from the track's own motion (position
//! change over the map's window) or are zero; relative velocities get the ego velocity added.
use crate::map::{
    CompiledMap, EgoField, InputMessage, MissingVelocity, ObjField, PositionKind, VelocityFrame,
    EGO_FIELDS, OBJ_FIELDS,
};
use crate::timeline::{Action, Timeline};
use can_codec::{E2eConfig, E2eProtector, Frame, FrameKind, SignalError};
use scorer_core::model::Model;
use scorer_core::warning::{TrackTable, WarningConfig, WarningError, WarningEvent};
use scorer_core::VehicleState;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Track ids are small integers chosen by a sensor, not by an attacker: a multiplicative hash is
/// enough and several times cheaper than SipHash on the per-frame path.
#[derive(Default)]
struct TrackIdHasher(u64);

impl Hasher for TrackIdHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(*b)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.0 = (u64::from(v) ^ 0x5555_5555).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

type TrackMap<V> = HashMap<u32, V, BuildHasherDefault<TrackIdHasher>>;

/// Most tracks held at once (radars report up to 64-100 objects).
pub const MAX_TRACKS: usize = 128;

/// Speed (m/s) above which a partner's heading may be taken from its velocity.
pub const HEADING_FROM_VELOCITY_MIN_SPEED: f32 = 0.5;

/// Warning and data-freshness parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EngineConfig {
    /// Warn when the score is `>= threshold`.
    pub threshold: f32,
    /// Level 2 ("urgent") when the score is `>= urgent`.
    pub urgent: Option<f32>,
    /// Release when the score falls below `threshold - hysteresis` (live mode).
    pub hysteresis: f32,
    /// A warning stays on at least this long (live mode).
    pub min_on_us: u64,
    /// Data older than this is stale; tracks not updated for this long are dropped.
    pub stale_us: u64,
    /// Latched warnings (evaluation semantics): never released while the track lives.
    pub latch: bool,
}

impl EngineConfig {
    pub fn new(threshold: f32) -> Self {
        Self {
            threshold,
            urgent: None,
            hysteresis: 0.0,
            min_on_us: 500_000,
            stale_us: 500_000,
            latch: false,
        }
    }

    fn warning_config(&self) -> WarningConfig {
        if self.latch {
            WarningConfig::first_threshold(self.threshold, self.stale_us)
        } else {
            WarningConfig::live(
                self.threshold,
                self.hysteresis,
                self.min_on_us,
                self.stale_us,
            )
        }
    }
}

/// Counters over everything the engine has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Stats {
    pub frames: u64,
    /// Frames of an input message that decoded cleanly.
    pub decoded: u64,
    pub scored: u64,
    pub unknown_ids: u64,
    pub remote_frames: u64,
    pub decode_errors: u64,
    pub stale_drops: u64,
    pub invalid_objects: u64,
    pub reordered: u64,
    /// Frames dropped because their timestamp was far off the log's timeline (a glitch).
    pub out_of_window: u64,
    /// New log segments started (timestamp jumps confirmed by the following frames).
    pub segments: u64,
    pub duplicates: u64,
    pub error_frames: u64,
    pub bus_off: u64,
    pub warning_frames: u64,
    pub tracks_dropped: u64,
    pub table_full: u64,
    /// Updates not scored because a velocity derived from the track's motion is not yet known.
    pub motion_pending: u64,
    /// Slots whose `new_track` flag started a fresh track.
    pub new_objects: u64,
}

impl Stats {
    /// Bus errors as the status line reports them.
    pub fn bus_errors(&self) -> u64 {
        self.error_frames
    }
}

/// One scored track update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    pub t_us: u64,
    pub track: u32,
    pub ego: VehicleState,
    pub partner: VehicleState,
    pub score: f32,
    pub warning: bool,
    pub level: u8,
}

/// Why a warning turned off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReleaseReason {
    /// The score fell below the release level.
    Score,
    /// The track stopped updating.
    Stale,
    /// The sensor flagged the object invalid.
    Invalid,
    /// The sensor reported a new object in the track's slot.
    NewObject,
}

impl ReleaseReason {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Score => "score",
            Self::Stale => "stale",
            Self::Invalid => "invalid",
            Self::NewObject => "new_object",
        }
    }
}

/// What the engine produces.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// A track was scored.
    Scored(Observation),
    /// A protected warning frame to send.
    WarningFrame { t_us: u64, track: u32, frame: Frame },
    /// A track's warning turned on.
    WarningOn {
        t_us: u64,
        track: u32,
        score: f32,
        level: u8,
    },
    /// A track's warning turned off.
    WarningOff {
        t_us: u64,
        track: u32,
        score: f32,
        reason: ReleaseReason,
    },
    /// Something went wrong; `reason` says what (for diagnostics, rate-limited by the caller).
    /// `lost` is set when a frame was dropped and its content lost.
    Problem {
        t_us: u64,
        reason: String,
        lost: Option<Lost>,
    },
}

/// A frame the engine dropped: where it came from and why it is lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lost {
    /// The frame's source as given to [`Engine::process_from`] (a log line; 0 from
    /// [`Engine::process`]).
    pub source: u64,
    pub kind: LossKind,
}

/// Why a frame of the input was lost. Frames the map does not use (unknown ids, remote frames)
/// and updates that are not scored for a data-quality reason (stale or invalid objects) are not
/// losses: nothing the bridge needs was in them, or it was used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum LossKind {
    /// Up to 1 s older than the newest frame ([`crate::timeline`]).
    Late,
    /// Far off the timeline and not confirmed as a new segment ([`crate::timeline`]).
    OffTimeline,
    /// A frame of a mapped message that does not decode (wrong length, a signal out of its DBC
    /// range or not finite), or a track update whose decoded state cannot be scored.
    Decode,
}

impl LossKind {
    /// The kind as counted in summaries (plural: "3 late frames").
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Late => "late frames",
            Self::OffTimeline => "frames off the timeline",
            Self::Decode => "frames not decodable",
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Stamped {
    value: f64,
    t_us: u64,
}

/// A track's own motion: the position at the start of the current window and the velocity
/// measured over the last complete window (ego frame, relative to the ego).
#[derive(Clone, Copy, Debug)]
struct Motion {
    anchor_us: u64,
    anchor: (f64, f64),
    velocity: Option<(f64, f64)>,
}

#[derive(Clone, Debug, Default)]
struct ObjectSlots {
    values: [Option<Stamped>; OBJ_FIELDS],
    last_trigger_us: Option<u64>,
    last_heading: Option<(f32, f32)>,
    last_seen_us: u64,
    motion: Option<Motion>,
    /// A missing input of this track has been reported (once, until it arrives).
    waiting_reported: bool,
}

/// The engine. Holds the decoded model (borrowing its blob), the map and all track state.
pub struct Engine<'m> {
    model: Model<'m>,
    map: CompiledMap,
    config: EngineConfig,
    table: TrackTable<MAX_TRACKS>,
    ego: [Option<Stamped>; EGO_FIELDS],
    objects: TrackMap<ObjectSlots>,
    protector: E2eProtector,
    /// Each held frame comes with its source (log line), handed back when it is dropped.
    timeline: Timeline<(Frame, u64)>,
    /// Source of the frame being processed.
    source: u64,
    last_cleanup_us: u64,
    /// No track can be stale before this time (skips scanning the table on every update).
    next_expiry_us: u64,
    /// The missing ego speed has been reported (once, until it arrives).
    ego_waiting: bool,
    stats: Stats,
}

/// The engine refused its configuration.
#[derive(Debug, thiserror::Error)]
#[error("warning configuration: {0}")]
pub struct ConfigError(String);

impl<'m> Engine<'m> {
    pub fn new(
        model: Model<'m>,
        map: CompiledMap,
        config: EngineConfig,
    ) -> Result<Self, ConfigError> {
        let table =
            TrackTable::new(config.warning_config()).map_err(|e| ConfigError(e.to_string()))?;
        let protector = E2eProtector::new(E2eConfig {
            data_id: map.warning.data_id,
            crc_byte: map.warning.crc_byte,
            counter_byte: map.warning.counter_byte,
            max_delta: 3,
        });
        Ok(Self {
            model,
            map,
            config,
            table,
            ego: [None; EGO_FIELDS],
            objects: TrackMap::default(),
            protector,
            timeline: Timeline::default(),
            source: 0,
            last_cleanup_us: 0,
            next_expiry_us: 0,
            ego_waiting: false,
            stats: Stats::default(),
        })
    }

    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    pub fn map(&self) -> &CompiledMap {
        &self.map
    }

    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    /// Tracks currently held (fresh or not yet expired).
    pub fn track_count(&self) -> usize {
        self.table.len()
    }

    /// Processes one frame received at `t_us` (in timestamp order; see [`crate::timeline`] for
    /// late frames and jumps).
    pub fn process(&mut self, t_us: u64, frame: &Frame, out: &mut impl FnMut(Output)) {
        self.process_from(t_us, frame, 0, out);
    }

    /// [`Engine::process`] for a frame read from `source` (its line in a log): every
    /// [`Output::Problem`] about the frame being dropped names it in [`Lost::source`], also when
    /// the frame was held for a while.
    pub fn process_from(
        &mut self,
        t_us: u64,
        frame: &Frame,
        source: u64,
        out: &mut impl FnMut(Output),
    ) {
        self.stats.frames += 1;
        let step = self.timeline.admit(t_us, &(*frame, source));
        if !step.dropped.is_empty() {
            self.drop_out_of_window(&step.dropped, out);
        }
        match step.action {
            Action::Process => {
                self.source = source;
                self.process_in_order(t_us, frame, out);
            }
            Action::Late { newest_us } => {
                self.stats.reordered += 1;
                out(Output::Problem {
                    lost: Some(Lost {
                        source,
                        kind: LossKind::Late,
                    }),
                    t_us,
                    reason: format!(
                        "frame {} at {t_us} us is older than the newest frame ({newest_us} us): dropped",
                        frame.id
                    ),
                });
            }
            Action::Held => {}
            Action::NewSegment(held) => {
                self.start_segment(held[0].0, out);
                for (t, (f, source)) in &held {
                    self.source = *source;
                    self.process_in_order(*t, f, out);
                }
            }
        }
    }

    /// What a problem about the frame being processed loses.
    fn lost(&self, kind: LossKind) -> Lost {
        Lost {
            source: self.source,
            kind,
        }
    }

    /// End of input: frames held for a jump that was never confirmed are dropped and counted.
    pub fn finish(&mut self, out: &mut impl FnMut(Output)) {
        let held = self.timeline.finish();
        self.drop_out_of_window(&held, out);
    }

    #[cold]
    fn drop_out_of_window(
        &mut self,
        dropped: &[(u64, (Frame, u64))],
        out: &mut impl FnMut(Output),
    ) {
        let newest = self.timeline.newest_us().unwrap_or(0);
        for (t, (f, source)) in dropped {
            self.stats.out_of_window += 1;
            out(Output::Problem {
                lost: Some(Lost {
                    source: *source,
                    kind: LossKind::OffTimeline,
                }),
                t_us: *t,
                reason: format!(
                    "frame {} at {t} us is far outside the log's timeline (newest frame {newest} us) and no frame follows it: dropped",
                    f.id
                ),
            });
        }
    }

    /// A new log segment from `t_us`: every track is dropped (warnings released as stale) and the
    /// ego and object data forgotten, because they belong to another time.
    #[cold]
    fn start_segment(&mut self, t_us: u64, out: &mut impl FnMut(Output)) {
        self.stats.segments += 1;
        for t in self.table.iter() {
            self.stats.tracks_dropped += 1;
            if t.warning {
                out(Output::WarningOff {
                    t_us,
                    track: t.id,
                    score: t.last_score,
                    reason: ReleaseReason::Stale,
                });
            }
        }
        self.table.expire(u64::MAX);
        self.ego = [None; EGO_FIELDS];
        self.objects.clear();
        self.last_cleanup_us = t_us;
        self.next_expiry_us = 0;
        out(Output::Problem {
            lost: None,
            t_us,
            reason: format!(
                "timestamps jump to {t_us} us: a new log segment starts, all tracks dropped"
            ),
        });
    }

    fn process_in_order(&mut self, t_us: u64, frame: &Frame, out: &mut impl FnMut(Output)) {
        match frame.kind {
            FrameKind::Error { class } => {
                self.stats.error_frames += 1;
                if frame.is_bus_off() {
                    self.stats.bus_off += 1;
                }
                out(Output::Problem {
                    lost: None,
                    t_us,
                    reason: format!(
                        "error frame (class 0x{class:08X}{})",
                        if frame.is_bus_off() { ", bus-off" } else { "" }
                    ),
                });
                return;
            }
            FrameKind::Remote { .. } => {
                self.stats.remote_frames += 1;
                return;
            }
            FrameKind::Data { .. } | FrameKind::Fd { .. } => {}
        }
        let Some(index) = self.map.inputs.iter().position(|m| m.spec.id == frame.id) else {
            self.stats.unknown_ids += 1;
            return;
        };
        let msg = &self.map.inputs[index];
        let is_trigger = msg.is_trigger
            && match (msg.trigger_mux, msg.spec.multiplexor) {
                (Some(want), Some(m)) => msg.spec.signals[m].raw(frame.data()).ok() == Some(want),
                _ => true,
            };
        let decoded = decode_message(msg, frame.data())
            .map_err(|reason| format!("{} ({}): {reason}: frame dropped", msg.spec.name, frame.id));
        match decoded {
            Err(reason) => {
                self.stats.decode_errors += 1;
                out(Output::Problem {
                    t_us,
                    reason,
                    lost: Some(self.lost(LossKind::Decode)),
                });
            }
            Ok(decoded) => {
                self.stats.decoded += 1;
                for (field, value) in decoded.ego.iter().take(decoded.n_ego) {
                    self.ego[*field as usize] = Some(Stamped {
                        value: *value,
                        t_us,
                    });
                }
                if let Some(track) = decoded.track {
                    let new_object = decoded.object[..decoded.n_object]
                        .iter()
                        .any(|(f, v)| *f == ObjField::NewTrack && *v != 0.0);
                    if new_object {
                        self.restart_track(track, t_us, out);
                    }
                    let slots = self.objects.entry(track).or_default();
                    slots.last_seen_us = t_us;
                    for (field, value) in decoded.object.iter().take(decoded.n_object) {
                        slots.values[*field as usize] = Some(Stamped {
                            value: *value,
                            t_us,
                        });
                    }
                    if is_trigger {
                        self.score_track(track, t_us, out);
                    }
                }
            }
        }
        if t_us.saturating_sub(self.last_cleanup_us) >= 1_000_000 {
            self.tick(t_us, out);
        }
    }

    /// A new object in `track`'s slot: release the old object's warning and forget its state.
    fn restart_track(&mut self, track: u32, t_us: u64, out: &mut impl FnMut(Output)) {
        self.stats.new_objects += 1;
        self.end_track(track, t_us, ReleaseReason::NewObject, out);
        if let Some(o) = self.objects.get_mut(&track) {
            *o = ObjectSlots::default();
        }
    }

    /// Drops `track` from the warning table (releasing its warning for `reason`) and forgets
    /// the motion and heading it had built up.
    fn end_track(
        &mut self,
        track: u32,
        t_us: u64,
        reason: ReleaseReason,
        out: &mut impl FnMut(Output),
    ) {
        if let Some(t) = self.table.get(track) {
            if t.warning {
                out(Output::WarningOff {
                    t_us,
                    track,
                    score: t.last_score,
                    reason,
                });
            }
            self.table.remove(track);
            self.stats.tracks_dropped += 1;
        }
        if let Some(o) = self.objects.get_mut(&track) {
            o.motion = None;
            o.last_heading = None;
        }
    }

    /// Drops tracks that went stale by `now_us` (releasing their warnings) and forgets old object
    /// data. Called by `process` about once per second of frame time; call it from a timer when
    /// the bus is quiet.
    pub fn tick(&mut self, now_us: u64, out: &mut impl FnMut(Output)) {
        self.last_cleanup_us = now_us;
        self.expire(now_us, out);
        let keep = self.config.stale_us.saturating_mul(4).max(5_000_000);
        self.objects
            .retain(|_, o| now_us.saturating_sub(o.last_seen_us) <= keep);
    }

    fn expire(&mut self, now_us: u64, out: &mut impl FnMut(Output)) {
        let stale = self.config.stale_us;
        if now_us <= self.next_expiry_us {
            return;
        }
        let mut dropped = 0u64;
        for t in self.table.iter() {
            if now_us.saturating_sub(t.last_update_us) > stale {
                dropped += 1;
                if t.warning {
                    out(Output::WarningOff {
                        t_us: now_us,
                        track: t.id,
                        score: t.last_score,
                        reason: ReleaseReason::Stale,
                    });
                }
            }
        }
        self.stats.tracks_dropped += dropped;
        self.table.expire(now_us);
        self.next_expiry_us = self
            .table
            .iter()
            .map(|t| t.last_update_us.saturating_add(stale))
            .min()
            .unwrap_or(u64::MAX);
    }

    fn fresh(&self, v: Option<Stamped>, t_us: u64) -> Option<f64> {
        v.filter(|s| t_us.saturating_sub(s.t_us) <= self.config.stale_us)
            .map(|s| s.value)
    }

    fn score_track(&mut self, track: u32, t_us: u64, out: &mut impl FnMut(Output)) {
        let Some(slots) = self.objects.get(&track).cloned() else {
            return;
        };
        if slots.last_trigger_us == Some(t_us) {
            self.stats.duplicates += 1;
            out(Output::Problem {
                lost: None,
                t_us,
                reason: format!("track {track}: second update at the same timestamp: dropped"),
            });
            return;
        }
        let has = self.map.has_obj_field;
        let obj = |f: ObjField| slots.values[f as usize];
        if has[ObjField::Valid as usize] {
            match self.fresh(obj(ObjField::Valid), t_us) {
                Some(v) if v != 0.0 => {}
                None => {
                    self.stats.stale_drops += 1;
                    out(Output::Problem {
                        lost: None,
                        t_us,
                        reason: format!("track {track}: valid flag missing or stale: not scored"),
                    });
                    return;
                }
                Some(_) => {
                    self.stats.invalid_objects += 1;
                    self.end_track(track, t_us, ReleaseReason::Invalid, out);
                    return;
                }
            }
        }
        let Some(ego_vx) = self.fresh(self.ego[EgoField::VelLong as usize], t_us) else {
            self.stats.stale_drops += 1;
            if !self.ego_waiting {
                self.ego_waiting = true;
                out(Output::Problem {
                    lost: None,
                    t_us,
                    reason: format!(
                        "waiting for ego.vel_long: {} not received in the last {} ms; no track is scored until it arrives (reported once)",
                        self.map.ego_source[EgoField::VelLong as usize],
                        self.config.stale_us / 1000
                    ),
                });
            }
            return;
        };
        self.ego_waiting = false;
        let (pos_fields, vel_fields) = match self.map.position {
            PositionKind::Cartesian => ([ObjField::PosX, ObjField::PosY], ObjField::VelX),
            PositionKind::Polar => ([ObjField::Range, ObjField::Azimuth], ObjField::RangeRate),
        };
        let required = pos_fields
            .into_iter()
            .chain([vel_fields, ObjField::VelX, ObjField::VelY])
            .filter(|f| has[*f as usize]);
        for f in required {
            if self.fresh(obj(f), t_us).is_none() {
                self.stats.stale_drops += 1;
                let o = self.objects.entry(track).or_default();
                if !o.waiting_reported {
                    o.waiting_reported = true;
                    out(Output::Problem {
                        lost: None,
                        t_us,
                        reason: format!(
                            "track {track}: waiting for {}: {} not received in the last {} ms; not scored until it arrives (reported once)",
                            f.name(),
                            self.map.obj_source[f as usize],
                            self.config.stale_us / 1000
                        ),
                    });
                }
                return;
            }
        }
        let stale_us = self.config.stale_us;
        let value = |f: ObjField| {
            obj(f)
                .filter(|s| t_us.saturating_sub(s.t_us) <= stale_us)
                .map(|s| s.value)
        };
        let mount = self.map.mount;
        // Position and line of sight in the sensor frame.
        let (p_sensor, line_of_sight) = match self.map.position {
            PositionKind::Cartesian => (
                (
                    value(ObjField::PosX).unwrap_or(0.0),
                    value(ObjField::PosY).unwrap_or(0.0),
                ),
                None,
            ),
            PositionKind::Polar => {
                let r = value(ObjField::Range).unwrap_or(0.0);
                let az = value(ObjField::Azimuth).unwrap_or(0.0);
                let (c, s) = (libm::cos(az), libm::sin(az));
                ((r * c, r * s), Some((c, s)))
            }
        };
        let (px, py) = mount.place(p_sensor);
        let window = self.map.motion_window_us;
        let derive = self.map.missing_velocity == Some(MissingVelocity::TrackMotion);
        let derived = if derive {
            let o = self.objects.entry(track).or_default();
            o.waiting_reported = false;
            update_motion(&mut o.motion, t_us, (px, py), window, stale_us)
        } else {
            if let Some(o) = self.objects.get_mut(&track) {
                o.waiting_reported = false;
            }
            None
        };
        let complete = has[ObjField::VelX as usize] && has[ObjField::VelY as usize];
        if derive && !complete && derived.is_none() {
            self.stats.motion_pending += 1;
            return;
        }
        let d = mount.unrotate(derived.unwrap_or((0.0, 0.0)));
        let v_sensor = match (line_of_sight, value(ObjField::RangeRate)) {
            _ if complete => (
                value(ObjField::VelX).unwrap_or(0.0),
                value(ObjField::VelY).unwrap_or(0.0),
            ),
            (Some((c, s)), Some(rr)) => {
                // Radial from the sensor, tangential from the track's motion (or zero).
                let tangential = -d.0 * s + d.1 * c;
                (rr * c - tangential * s, rr * s + tangential * c)
            }
            _ => (
                value(ObjField::VelX).unwrap_or(d.0),
                value(ObjField::VelY).unwrap_or(d.1),
            ),
        };
        let (vx, vy) = mount.rotate(v_sensor);
        let ego_opt = |f: EgoField, default: f64| -> f64 {
            self.fresh(self.ego[f as usize], t_us).unwrap_or(default)
        };
        let ego_vy = ego_opt(EgoField::VelLat, 0.0);
        let ego_acc = ego_opt(EgoField::Accel, 0.0);
        let ego_len =
            self.ego[EgoField::Length as usize].map_or(self.map.ego_defaults.0, |s| s.value as f32);
        let ego_wid =
            self.ego[EgoField::Width as usize].map_or(self.map.ego_defaults.1, |s| s.value as f32);
        let ego = VehicleState {
            x: 0.0,
            y: 0.0,
            vx: ego_vx as f32,
            vy: ego_vy as f32,
            hx: 1.0,
            hy: 0.0,
            acc: ego_acc as f32,
            length: ego_len,
            width: ego_wid,
        };
        let (abs_vx, abs_vy) = match self.map.velocity {
            VelocityFrame::Relative => ((vx + ego_vx) as f32, (vy + ego_vy) as f32),
            VelocityFrame::Absolute => (vx as f32, vy as f32),
        };
        let heading_valid = !has[ObjField::HeadingValid as usize]
            || self
                .fresh(obj(ObjField::HeadingValid), t_us)
                .is_some_and(|v| v != 0.0);
        let heading = match self.fresh(obj(ObjField::Heading), t_us) {
            Some(h) if heading_valid => Some((libm::cos(h) as f32, libm::sin(h) as f32)),
            _ => {
                let speed = libm::hypotf(abs_vx, abs_vy);
                (speed >= HEADING_FROM_VELOCITY_MIN_SPEED).then(|| (abs_vx / speed, abs_vy / speed))
            }
        };
        let (hx, hy) = heading.or(slots.last_heading).unwrap_or((1.0, 0.0));
        let partner = VehicleState {
            x: px as f32,
            y: py as f32,
            vx: abs_vx,
            vy: abs_vy,
            hx,
            hy,
            acc: self.fresh(obj(ObjField::Accel), t_us).unwrap_or(0.0) as f32,
            length: obj(ObjField::Length).map_or(self.map.object_defaults.0, |s| s.value as f32),
            width: obj(ObjField::Width).map_or(self.map.object_defaults.1, |s| s.value as f32),
        };
        if let Some(s) = self.objects.get_mut(&track) {
            s.last_trigger_us = Some(t_us);
            s.last_heading = Some((hx, hy));
        }
        if !(ego.is_finite()
            && partner.is_finite()
            && ego.length > 0.0
            && ego.width > 0.0
            && partner.length > 0.0
            && partner.width > 0.0)
        {
            self.stats.decode_errors += 1;
            out(Output::Problem {
                lost: Some(self.lost(LossKind::Decode)),
                t_us,
                reason: format!("track {track}: state not finite or non-positive size: not scored"),
            });
            return;
        }
        let score = self.model.score(&ego, &partner);
        // Release warnings of tracks that went stale before this update.
        self.expire(t_us, out);
        let status = match self.table.update(track, t_us, score) {
            Ok(s) => s,
            Err(WarningError::TableFull { .. }) => {
                self.stats.table_full += 1;
                out(Output::Problem {
                    lost: None,
                    t_us,
                    reason: format!("track {track}: track table full ({MAX_TRACKS}): not scored"),
                });
                return;
            }
            Err(e) => {
                self.stats.decode_errors += 1;
                out(Output::Problem {
                    lost: Some(self.lost(LossKind::Decode)),
                    t_us,
                    reason: e.to_string(),
                });
                return;
            }
        };
        // The core evicts only tracks that are not warning, so an eviction releases nothing.
        if status.evicted.is_some() {
            self.stats.tracks_dropped += 1;
        }
        self.next_expiry_us = self
            .next_expiry_us
            .min(t_us.saturating_add(self.config.stale_us));
        self.stats.scored += 1;
        let level = if status.warning {
            match self.config.urgent {
                Some(u) if score >= u => 2,
                _ => 1,
            }
        } else {
            0
        };
        match status.event {
            WarningEvent::Onset => out(Output::WarningOn {
                t_us,
                track,
                score,
                level,
            }),
            WarningEvent::Release => out(Output::WarningOff {
                t_us,
                track,
                score,
                reason: ReleaseReason::Score,
            }),
            WarningEvent::None => {}
        }
        out(Output::Scored(Observation {
            t_us,
            track,
            ego,
            partner,
            score,
            warning: status.warning,
            level,
        }));
        if status.warning {
            match self.warning_frame(track, score, level) {
                Ok(frame) => {
                    self.stats.warning_frames += 1;
                    out(Output::WarningFrame { t_us, track, frame });
                }
                Err(reason) => out(Output::Problem {
                    lost: None,
                    t_us,
                    reason: format!("track {track}: warning frame not encodable: {reason}"),
                }),
            }
        }
    }

    fn warning_frame(&mut self, track: u32, score: f32, level: u8) -> Result<Frame, String> {
        let w = &self.map.warning;
        let mut data = [0u8; can_codec::frame::MAX_DATA_LEN];
        let payload = &mut data[..w.spec.size];
        let put = |index: usize, value: f64, payload: &mut [u8]| -> Result<(), String> {
            let s = &w.spec.signals[index];
            let value = if s.has_range() {
                value.clamp(s.min, s.max)
            } else {
                value
            };
            s.encode(value, payload)
                .map_err(|e| format!("{}: {e}", s.name))
        };
        put(w.track_id, f64::from(track), payload)?;
        put(w.level, f64::from(level), payload)?;
        put(w.score, f64::from(score), payload)?;
        self.protector
            .protect(payload)
            .ok_or_else(|| "payload too short for E2E protection".to_string())?;
        let frame = if w.spec.size <= 8 {
            Frame::data_frame(w.spec.id, payload)
        } else {
            Frame::fd_frame(w.spec.id, 0, payload)
        };
        frame.ok_or_else(|| "invalid frame length".to_string())
    }
}

struct Decoded {
    ego: [(EgoField, f64); EGO_FIELDS],
    n_ego: usize,
    object: [(ObjField, f64); OBJ_FIELDS],
    n_object: usize,
    track: Option<u32>,
}

fn decode_message(msg: &InputMessage, data: &[u8]) -> Result<Decoded, String> {
    let spec = &msg.spec;
    let expected = spec.size;
    let len_ok = data.len() == expected
        || (expected > 8
            && can_codec::frame::is_valid_fd_len(data.len())
            && data.len() >= expected);
    if !len_ok {
        return Err(format!(
            "wrong DLC: {} bytes, DBC says {expected}",
            data.len()
        ));
    }
    let read = |signal: usize, check_range: bool| -> Result<Option<f64>, String> {
        let s = &spec.signals[signal];
        match spec.value(signal, data) {
            Ok(None) => Ok(None),
            Ok(Some(v)) if !check_range && v.is_finite() => Ok(Some(v)),
            Ok(Some(v)) => s
                .check_range(v)
                .map(Some)
                .map_err(|e| format!("signal {}: {e}", s.name)),
            Err(SignalError::NotFinite) => Err(format!("signal {}: not finite", s.name)),
            Err(e) => Err(format!("signal {}: {e}", s.name)),
        }
    };
    let mut d = Decoded {
        ego: [(EgoField::VelLong, 0.0); EGO_FIELDS],
        n_ego: 0,
        object: [(ObjField::PosX, 0.0); OBJ_FIELDS],
        n_object: 0,
        track: None,
    };
    for slot in &msg.ego {
        if let Some(v) = read(slot.signal, slot.check_range)? {
            d.ego[d.n_ego] = (slot.field, slot.apply(v));
            d.n_ego += 1;
        }
    }
    let track = match (msg.track_id, msg.slot) {
        (Some(id_signal), _) => {
            let Some(id) = read(id_signal, true)? else {
                return Ok(d);
            };
            if !(id >= 0.0 && id <= f64::from(u32::MAX) && id.fract() == 0.0) {
                return Err(format!("track id {id} is not a non-negative integer"));
            }
            id as u32
        }
        (None, Some(slot)) => slot,
        (None, None) => return Ok(d),
    };
    d.track = Some(track);
    for slot in &msg.object {
        if let Some(v) = read(slot.signal, slot.check_range)? {
            let v = slot.apply(v);
            d.object[d.n_object] = (slot.field, v);
            d.n_object += 1;
            // An invalid object's other signals are filler: not read, never a decode error.
            if slot.field == ObjField::Valid && v == 0.0 {
                break;
            }
        }
    }
    Ok(d)
}

/// Advances a track's motion window with the position `p` at `t_us`; returns the velocity over
/// the last complete window. A gap longer than the window plus the staleness limit restarts it.
fn update_motion(
    motion: &mut Option<Motion>,
    t_us: u64,
    p: (f64, f64),
    window_us: u64,
    stale_us: u64,
) -> Option<(f64, f64)> {
    let restart = Motion {
        anchor_us: t_us,
        anchor: p,
        velocity: None,
    };
    let m = match motion {
        Some(m) if t_us >= m.anchor_us && t_us - m.anchor_us <= window_us + stale_us => m,
        _ => {
            *motion = Some(restart);
            return None;
        }
    };
    let dt_us = t_us - m.anchor_us;
    if dt_us >= window_us {
        let dt = dt_us as f64 / 1e6;
        m.velocity = Some(((p.0 - m.anchor.0) / dt, (p.1 - m.anchor.1) / dt));
        m.anchor_us = t_us;
        m.anchor = p;
    }
    m.velocity
}
