//! Which frames the engine processes, by timestamp: in order, late (dropped), or the start of a
//! new log segment.
//!
//! A single frame with a wrong timestamp must not poison the timeline, and a log that jumps in
//! time (recordings concatenated, a bus or logger restarted, a clock step) must not turn into
//! thousands of "late" frames. Rules, with `newest` the newest frame processed:
//! - `newest <= t <= newest + FORWARD_WINDOW_US`: processed.
//! - `newest - LATE_WINDOW_US <= t < newest`: a late frame, dropped (`reordered`).
//! - anything else opens a *candidate segment*: the frame is held, not processed. Frames that
//!   continue the candidate (in order, each within the forward window of the previous one) are held
//!   too; at [`CONFIRM_FRAMES`] held frames the candidate is confirmed: a new segment starts (the
//!   engine forgets its tracks) and the held frames are processed in order, none lost. A frame that
//!   fits the current timeline first refutes the candidate: the held frames were glitches and are
//!   dropped, each counted (`out of window`).
//!
//! Limitation: a new segment shorter than [`CONFIRM_FRAMES`] frames at the end of a log cannot be
//! told from a glitch and is dropped (counted); live, the first frames after a jump wait for
//! [`CONFIRM_FRAMES`] frames (under a millisecond on a loaded bus).
//!
//! The same rules drive the engine (what is scored) and `replay` (what is sent, and when); the
//! timeline holds whatever item its user needs back with a held or dropped frame (the engine: the
//! frame and its log line).

/// Largest forward step (us) taken as the same timeline (above the exporter's 2 s event gap and
/// ordinary quiet periods of a bus).
pub const FORWARD_WINDOW_US: u64 = 5_000_000;
/// Largest backward step (us) taken as a late frame rather than a jump.
pub const LATE_WINDOW_US: u64 = 1_000_000;
/// Consecutive frames that confirm a jump as a new segment.
pub const CONFIRM_FRAMES: usize = 4;

/// Log segments of a run that read `frames` frames and started `new_segments` new ones after the
/// first: the first frame opens the first segment, so a log without frames has none (not one).
pub fn segment_count(frames: u64, new_segments: u64) -> u64 {
    if frames == 0 {
        0
    } else {
        new_segments + 1
    }
}

/// What to do with a frame.
#[derive(Debug, PartialEq)]
pub enum Action<T> {
    /// In order: process it.
    Process,
    /// Late (at most [`LATE_WINDOW_US`] before the newest frame): drop it.
    Late { newest_us: u64 },
    /// Held while a candidate segment is open.
    Held,
    /// A new segment is confirmed: forget the old state, then process these frames in order (the
    /// current frame is the last).
    NewSegment(Vec<(u64, T)>),
}

/// The verdict on one frame: frames dropped as glitches (usually none), then the action.
#[derive(Debug, PartialEq)]
pub struct Step<T> {
    pub dropped: Vec<(u64, T)>,
    pub action: Action<T>,
}

impl<T> Step<T> {
    fn only(action: Action<T>) -> Self {
        Self {
            dropped: Vec::new(),
            action,
        }
    }
}

/// The timeline state; `T` is what is held with a frame's timestamp.
#[derive(Clone, Debug)]
pub struct Timeline<T> {
    newest_us: Option<u64>,
    held: Vec<(u64, T)>,
}

impl<T> Default for Timeline<T> {
    fn default() -> Self {
        Self {
            newest_us: None,
            held: Vec::new(),
        }
    }
}

impl<T: Copy> Timeline<T> {
    /// The newest timestamp processed.
    pub fn newest_us(&self) -> Option<u64> {
        self.newest_us
    }

    /// Decides on the frame `item` stamped `t_us`.
    #[inline]
    pub fn admit(&mut self, t_us: u64, item: &T) -> Step<T> {
        let Some(newest) = self.newest_us else {
            self.newest_us = Some(t_us);
            return Step::only(Action::Process);
        };
        let in_window = t_us >= newest && t_us - newest <= FORWARD_WINDOW_US;
        if self.held.is_empty() {
            if in_window {
                self.newest_us = Some(t_us);
                return Step::only(Action::Process);
            }
            if t_us < newest && newest - t_us <= LATE_WINDOW_US {
                return Step::only(Action::Late { newest_us: newest });
            }
            self.held.push((t_us, *item));
            return Step::only(Action::Held);
        }
        self.admit_with_candidate(t_us, item, newest, in_window)
    }

    #[cold]
    fn admit_with_candidate(
        &mut self,
        t_us: u64,
        item: &T,
        newest: u64,
        in_window: bool,
    ) -> Step<T> {
        let last = self.held.last().map_or(0, |h| h.0);
        if t_us >= last && t_us - last <= FORWARD_WINDOW_US {
            self.held.push((t_us, *item));
            if self.held.len() < CONFIRM_FRAMES {
                return Step::only(Action::Held);
            }
            self.newest_us = Some(t_us);
            return Step::only(Action::NewSegment(std::mem::take(&mut self.held)));
        }
        let dropped = std::mem::take(&mut self.held);
        if in_window {
            self.newest_us = Some(t_us);
            return Step {
                dropped,
                action: Action::Process,
            };
        }
        if t_us < newest && newest - t_us <= LATE_WINDOW_US {
            return Step {
                dropped,
                action: Action::Late { newest_us: newest },
            };
        }
        self.held.push((t_us, *item));
        Step {
            dropped,
            action: Action::Held,
        }
    }

    /// End of input: frames still held are dropped (a candidate that was never confirmed).
    pub fn finish(&mut self) -> Vec<(u64, T)> {
        std::mem::take(&mut self.held)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Any item: the timeline only looks at timestamps.
    fn f() -> u32 {
        7
    }

    #[test]
    fn a_single_far_future_frame_is_dropped_alone() {
        let mut tl = Timeline::default();
        assert_eq!(tl.admit(1_000, &f()).action, Action::Process);
        assert_eq!(tl.admit(1_000_000_000_000, &f()).action, Action::Held);
        let s = tl.admit(1_100, &f());
        assert_eq!(s.dropped.len(), 1);
        assert_eq!(s.action, Action::Process);
        assert_eq!(
            tl.admit(900, &f()).action,
            Action::Late { newest_us: 1_100 }
        );
        assert_eq!(tl.newest_us(), Some(1_100));
    }

    #[test]
    fn a_jump_back_or_forward_confirmed_by_following_frames_is_a_new_segment() {
        for start in [1_000_000_000u64, 10_000_000] {
            let mut tl = Timeline::default();
            assert_eq!(tl.admit(200_000_000, &f()).action, Action::Process);
            for k in 0..CONFIRM_FRAMES as u64 - 1 {
                assert_eq!(tl.admit(start + k, &f()).action, Action::Held);
            }
            match tl.admit(start + 10, &f()).action {
                Action::NewSegment(held) => {
                    assert_eq!(held.len(), CONFIRM_FRAMES);
                    assert_eq!(held[0].0, start);
                }
                other => panic!("{other:?}"),
            }
            assert_eq!(tl.newest_us(), Some(start + 10));
            assert!(tl.finish().is_empty());
        }
    }
}
