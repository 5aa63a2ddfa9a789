//! The warning step: an assembled track state scored by the model, its warning state updated in
//! the core's track table, and the transitions and protected warning frame that follow.
use super::assemble::States;
use super::{
    EncodeError, Engine, LossKind, Output, Problem, ReleaseReason, ScoredUpdate, MAX_TRACKS,
};
use can_codec::{Frame, SignalSpec, ValueKind};
use scorer_core::warning::{WarningError, WarningEvent};

impl Engine<'_> {
    /// Scores `states` of `track` at `t_us` and runs the warning rule over the score.
    pub(super) fn warn(
        &mut self,
        track: u32,
        t_us: u64,
        states: States,
        out: &mut impl FnMut(Output),
    ) {
        let States {
            ego,
            partner,
            flags,
        } = states;
        let guarded = self.model.score_pair_guarded(&ego, &partner);
        let score = guarded.score;
        // Release warnings of tracks that went stale before this update.
        self.expire(t_us, out);
        let status = match self.table.update(track, t_us, score) {
            Ok(s) => s,
            Err(WarningError::TableFull { .. }) => {
                self.stats.table_full += 1;
                out(self.problem(
                    t_us,
                    Problem::TableFull {
                        track,
                        capacity: MAX_TRACKS,
                    },
                    None,
                ));
                return;
            }
            Err(e) => {
                self.stats.decode_errors += 1;
                out(self.problem(t_us, Problem::Rejected(e), Some(LossKind::Decode)));
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
        if !guarded.in_domain {
            self.stats.out_of_domain += 1;
        }
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
        out(Output::Scored(ScoredUpdate {
            t_us,
            track,
            ego,
            partner,
            flags,
            score,
            warning: status.warning,
            level,
        }));
        if status.warning {
            self.send_warning_frame(track, t_us, score, level, out);
        }
    }

    /// Builds and hands out the warning frame of `track`. A track id the warning message cannot
    /// carry is never sent as another id: the frame is counted as unsent and the track named once.
    fn send_warning_frame(
        &mut self,
        track: u32,
        t_us: u64,
        score: f32,
        level: u8,
        out: &mut impl FnMut(Output),
    ) {
        let w = &self.map.warning;
        let id_signal = &w.spec.signals[w.track_id];
        if !fits_exactly(id_signal, f64::from(track)) {
            self.stats.warning_frames_unsent += 1;
            let slots = self.partners.entry(track).or_default();
            if !slots.unsent_reported {
                slots.unsent_reported = true;
                self.stats.tracks_unsent += 1;
                out(self.problem(
                    t_us,
                    Problem::TrackIdDoesNotFit {
                        track,
                        signal: id_signal.name.clone(),
                        range: carried_range(id_signal),
                    },
                    None,
                ));
            }
            return;
        }
        match self.warning_frame(track, score, level) {
            Ok(frame) => {
                self.stats.warning_frames += 1;
                out(Output::WarningFrame { t_us, track, frame });
            }
            Err(cause) => {
                self.stats.warning_frames_unsent += 1;
                out(self.problem(t_us, Problem::WarningFrame { track, cause }, None))
            }
        }
    }

    /// The map's warning message for `track`, E2E protected (advances the alive counter).
    fn warning_frame(&mut self, track: u32, score: f32, level: u8) -> Result<Frame, EncodeError> {
        let w = &self.map.warning;
        let mut data = [0u8; can_codec::frame::MAX_DATA_LEN];
        let payload = &mut data[..w.spec.size];
        // Level and score saturate at the DBC range (a score beyond it still means "warn"); the
        // track id is checked to fit before (`send_warning_frame`) and is never clamped.
        let put = |index: usize, value: f64, payload: &mut [u8]| -> Result<(), EncodeError> {
            let s = &w.spec.signals[index];
            let value = if s.has_range() && index != w.track_id {
                value.clamp(s.min, s.max)
            } else {
                value
            };
            s.encode(value, payload)
                .map_err(|cause| EncodeError::Signal {
                    signal: s.name.clone(),
                    cause,
                })
        };
        put(w.track_id, f64::from(track), payload)?;
        put(w.level, f64::from(level), payload)?;
        put(w.score, f64::from(score), payload)?;
        self.protector
            .protect(payload)
            .ok_or(EncodeError::TooShortForE2e)?;
        let frame = if w.spec.size <= 8 {
            Frame::data_frame(w.spec.id, payload)
        } else {
            Frame::fd_frame(w.spec.id, 0, payload)
        };
        frame.ok_or(EncodeError::FrameLength)
    }
}

/// True when `value` is inside the signal's DBC range (if it has one) and encodes to a raw value
/// that decodes back to exactly `value`.
fn fits_exactly(signal: &SignalSpec, value: f64) -> bool {
    signal.check_range(value).is_ok()
        && signal
            .to_raw(value)
            .is_ok_and(|raw| signal.raw_value(raw) == value)
}

/// The values a signal can carry, for messages: its DBC range, else what its raw bits span.
fn carried_range(signal: &SignalSpec) -> (f64, f64) {
    if signal.has_range() {
        return (signal.min, signal.max);
    }
    let bits = i32::from(signal.size);
    let (lo, hi) = match signal.kind {
        ValueKind::Unsigned => (0.0, 2f64.powi(bits) - 1.0),
        ValueKind::Signed => (-(2f64.powi(bits - 1)), 2f64.powi(bits - 1) - 1.0),
        ValueKind::Float32 => (f64::from(f32::MIN), f64::from(f32::MAX)),
        ValueKind::Float64 => (f64::MIN, f64::MAX),
    };
    let (a, b) = (
        lo * signal.factor + signal.offset,
        hi * signal.factor + signal.offset,
    );
    (a.min(b), a.max(b))
}
