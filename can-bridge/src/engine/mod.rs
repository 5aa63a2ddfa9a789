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
//! Each rule that drops something reports it as a typed [`Problem`] in [`Output::Problem`].
//!
//! Files: `assemble` (inputs -> ego and partner state), `warn` (score -> warning state and
//! frame), `decode` (frame -> field values), `track` (what is kept per track), `output` and
//! `problem` (what comes out), `config`.
mod assemble;
mod config;
mod decode;
mod flags;
mod output;
mod problem;
mod track;
mod warn;

pub use assemble::HEADING_FROM_VELOCITY_MIN_SPEED;
pub use config::{ConfigError, EngineConfig, MAX_TRACKS};
pub use flags::InputFlags;
pub use output::{LossKind, Output, ReleaseReason, ScoredUpdate, Stats};
pub use problem::{DecodeError, EncodeError, Problem};

use crate::map::{CompiledMap, EgoField, PartnerField, EGO_FIELDS};
use crate::timeline::{Action, Timeline};
use assemble::{assemble, Unscored};
use can_codec::{E2eConfig, E2eProtector, Frame, FrameKind};
use decode::decode_message;
use scorer_core::model::ModelBlob;
use scorer_core::warning::TrackTable;
use track::{HeadingRate, PartnerSlots, Stamped, TrackMap};

/// A frame the timeline may hold: the frame, its source (log line) and its bus.
type HeldFrame = (Frame, u64, Option<u8>);

/// The engine. Holds the decoded model (borrowing its blob), the map and all track state.
pub struct Engine<'m> {
    /// The model and its training domain (scored through the guard, as on the ECU).
    model: ModelBlob<'m>,
    map: CompiledMap,
    config: EngineConfig,
    table: TrackTable<MAX_TRACKS>,
    ego: [Option<Stamped>; EGO_FIELDS],
    partners: TrackMap<PartnerSlots>,
    protector: E2eProtector,
    /// Each held frame comes with its source (log line) and bus, handed back when it is dropped.
    timeline: Timeline<HeldFrame>,
    /// Slot maps: the track each slot last carried (companion messages join it).
    slot_tracks: Vec<Option<u32>>,
    /// The ego's heading over the motion window, when the yaw rate is derived from it.
    heading_rate: Option<HeadingRate>,
    /// Source of the frame being processed.
    source: u64,
    /// Source of the newest frame processed (0: unknown): a late frame names it, so the one
    /// frame stamped ahead of the rest can be found in the log.
    newest_source: u64,
    last_cleanup_us: u64,
    /// No track can be stale before this time (skips scanning the table on every update).
    next_expiry_us: u64,
    /// The missing ego speed has been reported (once, until it arrives).
    ego_waiting: bool,
    stats: Stats,
}

impl<'m> Engine<'m> {
    /// A [`Output::Problem`] about the frame being processed: it names that frame's source.
    fn problem(&self, t_us: u64, reason: Problem, lost: Option<LossKind>) -> Output {
        Output::Problem {
            t_us,
            source: self.source,
            reason,
            lost,
        }
    }

    /// An engine scoring with `model`: a decoded blob (with its training domain, if any) or a
    /// bare model (unguarded).
    pub fn new(
        model: impl Into<ModelBlob<'m>>,
        map: CompiledMap,
        config: EngineConfig,
    ) -> Result<Self, ConfigError> {
        let model = model.into();
        let table = TrackTable::new(config.warning_config()).map_err(ConfigError)?;
        let protector = E2eProtector::new(E2eConfig {
            data_id: map.warning.data_id,
            crc_byte: map.warning.crc_byte,
            counter_byte: map.warning.counter_byte,
            max_delta: 3,
        });
        let slot_tracks = vec![None; map.slots];
        Ok(Self {
            slot_tracks,
            heading_rate: None,
            model,
            map,
            config,
            table,
            ego: [None; EGO_FIELDS],
            partners: TrackMap::default(),
            protector,
            timeline: Timeline::default(),
            source: 0,
            newest_source: 0,
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

    /// The newest timestamp processed on the current timeline ([`crate::timeline`]).
    pub fn newest_us(&self) -> Option<u64> {
        self.timeline.newest_us()
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
    /// [`Output::Problem`] about the frame being dropped names it in its `source`, also when
    /// the frame was held for a while.
    pub fn process_from(
        &mut self,
        t_us: u64,
        frame: &Frame,
        source: u64,
        out: &mut impl FnMut(Output),
    ) {
        self.process_on_bus(t_us, frame, None, source, out);
    }

    /// [`Engine::process_from`] for a frame received on `bus` ([`CompiledMap::bus_of`] of its
    /// interface; `None`: not a bound bus, so only messages of unbound DBC files match).
    pub fn process_on_bus(
        &mut self,
        t_us: u64,
        frame: &Frame,
        bus: Option<u8>,
        source: u64,
        out: &mut impl FnMut(Output),
    ) {
        self.stats.frames += 1;
        let step = self.timeline.admit(t_us, &(*frame, source, bus));
        if !step.dropped.is_empty() {
            self.drop_out_of_window(&step.dropped, out);
        }
        match step.action {
            Action::Process => {
                self.set_source(t_us, source);
                self.process_in_order(t_us, frame, bus, out);
            }
            Action::Late { newest_us } => {
                self.stats.reordered += 1;
                out(Output::Problem {
                    source,
                    lost: Some(LossKind::Late),
                    t_us,
                    reason: Problem::Late {
                        id: frame.id,
                        t_us,
                        newest_us,
                        newest_source: self.newest_source,
                    },
                });
            }
            Action::Held => {}
            Action::Continue(held) => self.process_held(&held, out),
            Action::NewSegment(held) => {
                // The segment starts at its first frame, which its problem line names.
                let (t, (_, source, _)) = &held[0];
                self.set_source(*t, *source);
                self.start_segment(*t, out);
                self.process_held(&held, out);
            }
        }
    }

    /// Processes frames the timeline held, in order.
    #[cold]
    fn process_held(&mut self, held: &[(u64, HeldFrame)], out: &mut impl FnMut(Output)) {
        for (t, (f, source, bus)) in held {
            self.set_source(*t, *source);
            self.process_in_order(*t, f, *bus, out);
        }
    }

    /// End of input: frames held for a jump that was never confirmed are dropped and counted;
    /// those held after a gap are processed ([`crate::timeline`]).
    pub fn finish(&mut self, out: &mut impl FnMut(Output)) {
        let step = self.timeline.finish();
        self.drop_out_of_window(&step.dropped, out);
        if let Action::Continue(held) = step.action {
            self.process_held(&held, out);
        }
    }

    #[cold]
    fn drop_out_of_window(&mut self, dropped: &[(u64, HeldFrame)], out: &mut impl FnMut(Output)) {
        let newest = self.timeline.newest_us().unwrap_or(0);
        for (t, (f, source, _)) in dropped {
            self.stats.out_of_window += 1;
            out(Output::Problem {
                source: *source,
                lost: Some(LossKind::OffTimeline),
                t_us: *t,
                reason: Problem::OffTimeline {
                    id: f.id,
                    t_us: *t,
                    newest_us: newest,
                },
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
        self.partners.clear();
        self.slot_tracks.iter_mut().for_each(|s| *s = None);
        self.heading_rate = None;
        self.last_cleanup_us = t_us;
        self.next_expiry_us = 0;
        out(self.problem(t_us, Problem::NewSegment { t_us }, None));
    }

    /// The source of the frame about to be processed, and of the newest frame when it is that.
    fn set_source(&mut self, t_us: u64, source: u64) {
        self.source = source;
        if self.timeline.newest_us() == Some(t_us) {
            self.newest_source = source;
        }
    }

    fn process_in_order(
        &mut self,
        t_us: u64,
        frame: &Frame,
        bus: Option<u8>,
        out: &mut impl FnMut(Output),
    ) {
        match frame.kind {
            FrameKind::Error { class } => {
                self.stats.error_frames += 1;
                if frame.is_bus_off() {
                    self.stats.bus_off += 1;
                }
                out(self.problem(
                    t_us,
                    Problem::ErrorFrame {
                        class,
                        bus_off: frame.is_bus_off(),
                    },
                    None,
                ));
                return;
            }
            FrameKind::Remote { .. } => {
                self.stats.remote_frames += 1;
                return;
            }
            FrameKind::Data { .. } | FrameKind::Fd { .. } => {}
        }
        let Some(index) = self.map.input_index(frame.id, bus) else {
            self.stats.unknown_ids += 1;
            if self.map.inputs.iter().any(|m| m.spec.id == frame.id)
                && !self.map.defined_on(frame.id, bus)
            {
                self.stats.unknown_other_bus += 1;
            }
            return;
        };
        let msg = &self.map.inputs[index];
        let is_trigger = msg.is_trigger
            && match (msg.trigger_mux, msg.spec.multiplexor) {
                (Some(want), Some(m)) => msg.spec.signals[m].raw(frame.data()).ok() == Some(want),
                _ => true,
            };
        let decoded = decode_message(msg, frame.data()).map_err(|cause| Problem::Undecodable {
            message: msg.spec.name.clone(),
            id: frame.id,
            cause,
        });
        match decoded {
            Err(reason) => {
                self.stats.decode_errors += 1;
                out(self.problem(t_us, reason, Some(LossKind::Decode)));
            }
            Ok(decoded) => {
                self.stats.decoded += 1;
                for (field, value) in decoded.ego.iter().take(decoded.n_ego) {
                    self.ego[*field as usize] = Some(Stamped {
                        value: *value,
                        t_us,
                    });
                    if *field == EgoField::Heading {
                        self.derive_yaw_rate(t_us, *value);
                    }
                }
                let msg = &self.map.inputs[index];
                let track = match (msg.slot, msg.companion) {
                    // A companion joins the track its slot carries now.
                    (Some(slot), true) => self.slot_tracks[slot as usize],
                    (Some(slot), false) => {
                        self.slot_tracks[slot as usize] = decoded.track;
                        decoded.track
                    }
                    (None, _) => decoded.track,
                };
                if let Some(track) = track {
                    let new_object = decoded.partner[..decoded.n_partner]
                        .iter()
                        .any(|(f, v)| *f == PartnerField::NewTrack && *v != 0.0);
                    if new_object {
                        self.restart_track(track, t_us, out);
                    }
                    let slots = self.partners.entry(track).or_default();
                    slots.last_seen_us = t_us;
                    for (field, value) in decoded.partner.iter().take(decoded.n_partner) {
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

    /// The ego's yaw rate from its heading's change over the motion window, when the map has a
    /// heading but no yaw rate: stored as the yaw-rate input.
    fn derive_yaw_rate(&mut self, t_us: u64, heading: f64) {
        if self.map.has_ego_field[EgoField::YawRate as usize] {
            return;
        }
        let window = self.map.motion_window_us;
        let rate = track::update_heading_rate(
            &mut self.heading_rate,
            t_us,
            heading,
            window,
            self.config.stale_us,
        );
        if let Some(value) = rate {
            self.ego[EgoField::YawRate as usize] = Some(Stamped { value, t_us });
        }
    }

    /// A new object in `track`'s slot: release the old object's warning and forget its state.
    fn restart_track(&mut self, track: u32, t_us: u64, out: &mut impl FnMut(Output)) {
        self.stats.new_objects += 1;
        self.end_track(track, t_us, ReleaseReason::NewObject, out);
        if let Some(o) = self.partners.get_mut(&track) {
            *o = PartnerSlots::default();
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
        if let Some(o) = self.partners.get_mut(&track) {
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
        self.partners
            .retain(|_, o| now_us.saturating_sub(o.last_seen_us) <= keep);
    }

    fn expire(&mut self, now_us: u64, out: &mut impl FnMut(Output)) {
        let stale = self.config.stale_us;
        if now_us <= self.next_expiry_us {
            return;
        }
        let mut dropped = 0u64;
        for t in self.table.iter() {
            if t.is_expired(now_us, stale) {
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

    /// Runs the trigger of `track` at `t_us`: assembles the track's state, then either reports
    /// why it is not scored or runs the warning step.
    fn score_track(&mut self, track: u32, t_us: u64, out: &mut impl FnMut(Output)) {
        let Some(slots) = self.partners.get_mut(&track) else {
            return;
        };
        match assemble(&self.map, self.config.stale_us, &self.ego, slots, t_us) {
            Ok(states) => {
                self.ego_waiting = false;
                self.warn(track, t_us, states, out);
            }
            Err(unscored) => {
                if unscored.after_ego_speed() {
                    self.ego_waiting = false;
                }
                self.not_scored(track, t_us, unscored, out);
            }
        }
    }

    /// Counts an update that was not scored and reports it (missing inputs once, until they
    /// arrive); an invalid object's track is dropped.
    fn not_scored(&mut self, track: u32, t_us: u64, why: Unscored, out: &mut impl FnMut(Output)) {
        let stale_ms = self.config.stale_us / 1000;
        let problem = match why {
            Unscored::Duplicate => {
                self.stats.duplicates += 1;
                Problem::Duplicate { track }
            }
            Unscored::ValidFlagMissing => {
                self.stats.stale_drops += 1;
                Problem::ValidFlagMissing { track }
            }
            Unscored::Invalid => {
                self.stats.invalid_objects += 1;
                self.end_track(track, t_us, ReleaseReason::Invalid, out);
                return;
            }
            Unscored::OutsideView => {
                self.stats.outside_view += 1;
                self.end_track(track, t_us, ReleaseReason::OutsideView, out);
                return;
            }
            Unscored::EgoSpeedMissing => {
                self.stats.stale_drops += 1;
                if self.ego_waiting {
                    return;
                }
                self.ego_waiting = true;
                Problem::EgoSpeedMissing {
                    origin: self.map.ego_source[EgoField::VelLong as usize].clone(),
                    stale_ms,
                }
            }
            Unscored::InputMissing(field) => {
                self.stats.stale_drops += 1;
                let o = self.partners.entry(track).or_default();
                if o.waiting_reported {
                    return;
                }
                o.waiting_reported = true;
                Problem::InputMissing {
                    track,
                    field,
                    origin: self.map.partner_source[field as usize].clone(),
                    stale_ms,
                }
            }
            Unscored::MotionPending => {
                self.stats.motion_pending += 1;
                return;
            }
            Unscored::BadState => {
                self.stats.decode_errors += 1;
                out(self.problem(t_us, Problem::BadState { track }, Some(LossKind::Decode)));
                return;
            }
        };
        out(self.problem(t_us, problem, None));
    }
}
