//! Which frames the engine processes, by timestamp: in order, late (dropped), or the start of a
//! new log segment.
//!
//! A single frame with a wrong timestamp must not poison the timeline, and a log that jumps in
//! time (recordings concatenated, a bus or logger restarted, a clock step) must not turn into
//! thousands of "late" frames. Rules, with `newest` the newest frame processed:
//! - `newest <= t <= newest + AHEAD_WINDOW_US`: processed.
//! - `newest - LATE_WINDOW_US <= t < newest`: a late frame, dropped (`reordered`).
//! - anything else opens a *candidate*: the frame is held, not processed. Frames that continue the
//!   candidate (in order, each within the forward window of the previous one) are held too; at
//!   [`CONFIRM_FRAMES`] held frames the candidate is confirmed and the held frames are processed
//!   in order, none lost:
//!   - a *gap* (the first held frame at most [`FORWARD_WINDOW_US`] after `newest`: the bus was
//!     silent, then went on) continues the current segment, exactly as if each frame had been
//!     processed when it came;
//!   - any other jump starts a new segment (the engine forgets its tracks).
//!
//!   A frame that does not continue the candidate first refutes it: the held frames were glitches
//!   and are dropped, each counted (`off the timeline`), and the frame is judged by the rules
//!   above. So one frame stamped 1-5 s ahead costs that frame, where processing it at once would
//!   have made the frames after it look like a jump back (a new segment).
//!
//! Limitations: a new segment shorter than [`CONFIRM_FRAMES`] frames at the end of a log cannot be
//! told from a glitch and is dropped (counted), while a gap's frames held at the end are
//! processed (a glitch as the very last frame is then processed too, as before); live, the first
//! frames after a jump or a gap of more than 1 s wait for [`CONFIRM_FRAMES`] frames (under a
//! millisecond on a loaded bus). A frame stamped up to [`AHEAD_WINDOW_US`] ahead is processed, so
//! the frames after it, up to that much older, are late.
//!
//! The same rules drive the engine (what is scored) and `replay` (what is sent, and when); the
//! timeline holds whatever item its user needs back with a held or dropped frame (the engine: the
//! frame and its log line).

/// Largest forward step (us) taken as the same timeline (above the exporter's 2 s event gap and
/// ordinary quiet periods of a bus).
pub const FORWARD_WINDOW_US: u64 = 5_000_000;
/// Largest backward step (us) taken as a late frame rather than a jump.
pub const LATE_WINDOW_US: u64 = 1_000_000;
/// Largest forward step (us) processed at once; a larger one (up to [`FORWARD_WINDOW_US`]) is a
/// gap, held until the following frames confirm it.
pub const AHEAD_WINDOW_US: u64 = 1_000_000;
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
    /// Held while a candidate is open.
    Held,
    /// A gap is confirmed: process these frames in order on the current segment (the current
    /// frame is the last).
    Continue(Vec<(u64, T)>),
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
        let in_window = t_us >= newest && t_us - newest <= AHEAD_WINDOW_US;
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
            let held = std::mem::take(&mut self.held);
            return Step::only(if is_gap(newest, held[0].0) {
                Action::Continue(held)
            } else {
                Action::NewSegment(held)
            });
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

    /// End of input: frames still held for a candidate that was never confirmed. Those of a gap
    /// are processed ([`Action::Continue`]: they fit the current segment and nothing refuted
    /// them); those of a jump are dropped.
    pub fn finish(&mut self) -> Step<T> {
        let held = std::mem::take(&mut self.held);
        match (self.newest_us, held.last()) {
            (Some(newest), Some(&(last, _))) if is_gap(newest, held[0].0) => {
                self.newest_us = Some(last);
                Step::only(Action::Continue(held))
            }
            _ => Step {
                dropped: held,
                action: Action::Continue(Vec::new()),
            },
        }
    }
}

/// A candidate whose first frame is stamped `first_us` is a gap after `newest_us` (the bus silent
/// for a while: the current segment goes on), not a jump to a new segment.
fn is_gap(newest_us: u64, first_us: u64) -> bool {
    first_us > newest_us && first_us - newest_us <= FORWARD_WINDOW_US
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
            assert_eq!(tl.finish(), Step::only(Action::Continue(Vec::new())));
        }
    }

    #[test]
    fn one_frame_1_to_5_s_ahead_is_dropped_alone() {
        for ahead in [1_000_001u64, 2_000_000, 4_900_000, 5_000_000] {
            let mut tl = Timeline::default();
            assert_eq!(tl.admit(10_000_000, &f()).action, Action::Process);
            assert_eq!(tl.admit(10_000_000 + ahead, &f()).action, Action::Held);
            let s = tl.admit(10_010_000, &f());
            assert_eq!(s.dropped, [(10_000_000 + ahead, f())]);
            assert_eq!(s.action, Action::Process);
            assert_eq!(tl.admit(10_020_000, &f()).action, Action::Process);
            assert_eq!(tl.newest_us(), Some(10_020_000));
        }
        // Up to 1 s ahead: processed at once.
        let mut tl = Timeline::default();
        assert_eq!(tl.admit(10_000_000, &f()).action, Action::Process);
        assert_eq!(tl.admit(11_000_000, &f()).action, Action::Process);
    }

    #[test]
    fn a_gap_of_1_to_5_s_confirmed_by_following_frames_continues_the_segment() {
        for gap in [1_000_001u64, 2_000_000, 4_900_000, 5_000_000] {
            let mut tl = Timeline::default();
            assert_eq!(tl.admit(10_000_000, &f()).action, Action::Process);
            let start = 10_000_000 + gap;
            for k in 0..CONFIRM_FRAMES as u64 - 1 {
                assert_eq!(tl.admit(start + k, &f()).action, Action::Held);
            }
            match tl.admit(start + 10, &f()).action {
                Action::Continue(held) => {
                    assert_eq!(held.len(), CONFIRM_FRAMES);
                    assert_eq!(held[0].0, start);
                }
                other => panic!("{other:?}"),
            }
            assert_eq!(tl.newest_us(), Some(start + 10));
            assert_eq!(tl.admit(start + 20, &f()).action, Action::Process);
        }
    }

    #[test]
    fn at_the_end_a_gap_is_processed_and_a_jump_dropped() {
        let mut tl = Timeline::default();
        assert_eq!(tl.admit(10_000_000, &f()).action, Action::Process);
        assert_eq!(tl.admit(12_000_000, &f()).action, Action::Held);
        assert_eq!(tl.admit(12_000_001, &f()).action, Action::Held);
        let end = tl.finish();
        assert!(end.dropped.is_empty());
        assert_eq!(
            end.action,
            Action::Continue(vec![(12_000_000, f()), (12_000_001, f())])
        );
        assert_eq!(tl.newest_us(), Some(12_000_001));

        let mut tl = Timeline::default();
        assert_eq!(tl.admit(10_000_000, &f()).action, Action::Process);
        assert_eq!(tl.admit(16_000_000, &f()).action, Action::Held);
        let end = tl.finish();
        assert_eq!(end.dropped, [(16_000_000, f())]);
        assert_eq!(end.action, Action::Continue(Vec::new()));
        assert_eq!(tl.newest_us(), Some(10_000_000));
    }

    #[test]
    fn two_consecutive_frames_ahead_are_dropped_both() {
        let mut tl = Timeline::default();
        assert_eq!(tl.admit(10_000_000, &f()).action, Action::Process);
        assert_eq!(tl.admit(12_010_000, &f()).action, Action::Held);
        assert_eq!(tl.admit(12_020_000, &f()).action, Action::Held);
        let s = tl.admit(10_030_000, &f());
        assert_eq!(s.dropped, [(12_010_000, f()), (12_020_000, f())]);
        assert_eq!(s.action, Action::Process);
    }
}
