//! The one way a candump log's records reach the engine offline (`score-log`, `check`, `decode`):
//! each record is routed to its bus by its interface name ([`crate::map::CompiledMap::bus_of`])
//! and passed through a bounded reorder window.
//!
//! `candump -L can0 can1` reads each interface with its own socket and interleaves them with
//! inversions of a few milliseconds: a frame of one bus can follow a later frame of the other. The
//! engine's timeline drops a frame older than the newest as late, so without the window such a log
//! would lose a large part of its frames. [`LogFeed`] holds frames in timestamp order and hands a
//! frame to the engine once a frame `window` newer has been read (live does the same with
//! `--merge-wait-ms`, [`crate::live`]); a frame that arrives later than the window behind the
//! newest is still late, as before. Like live, each interface is taken to be in order by itself:
//! only inversions *between* interfaces are undone. A frame older than an earlier frame of its own
//! interface goes to the engine right after the frames pending up to that interface's newest
//! (and is late there, as without the window). So a log of one interface reaches the engine in
//! exactly the order it had without the window, inversions, clock steps and all, and its outputs
//! are unchanged. A frame far off the
//! timeline (a glitch or a jump to a new log segment, [`crate::timeline`]) is not buffered: what
//! is pending goes first, then that frame, so segments are never mixed.
//!
//! Memory: at most [`MAX_PENDING`] frames are held (the oldest goes to the engine when it is
//! full), whatever the window and the log.
use crate::engine::{Engine, Output};
use crate::timeline::{FORWARD_WINDOW_US, LATE_WINDOW_US};
use can_codec::{Frame, LogRecord};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Default reorder window (ms): the same as `live --merge-wait-ms`.
pub const DEFAULT_REORDER_MS: u64 = 20;
/// Frames held at most, whatever the window.
pub const MAX_PENDING: usize = 1 << 16;
/// Interfaces whose newest frame is remembered (a log has a handful; more are not checked for
/// their own order).
const MAX_IFACES: usize = 64;

/// A frame waiting in the window; ordered by timestamp, then by its order in the log.
struct Pending {
    t_us: u64,
    seq: u64,
    frame: Frame,
    bus: Option<u8>,
    line: u64,
}

impl PartialEq for Pending {
    fn eq(&self, other: &Self) -> bool {
        (self.t_us, self.seq) == (other.t_us, other.seq)
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Pending {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        (self.t_us, self.seq).cmp(&(other.t_us, other.seq))
    }
}

/// Feeds a log's records to an engine: bus routing and the reorder window.
pub struct LogFeed {
    window_us: u64,
    pending: BinaryHeap<Reverse<Pending>>,
    seq: u64,
    /// The newest timestamp read on the current timeline.
    newest_us: Option<u64>,
    /// The newest timestamp read per interface.
    iface_newest: Vec<(String, u64)>,
}

impl LogFeed {
    /// A feed with a reorder window of `window_ms` milliseconds (0: none).
    pub fn new(window_ms: u64) -> Self {
        Self {
            window_us: window_ms.saturating_mul(1000),
            pending: BinaryHeap::new(),
            seq: 0,
            newest_us: None,
            iface_newest: Vec::new(),
        }
    }

    /// Hands the record read at log line `line` to `engine` (now or once the window has passed).
    pub fn push(
        &mut self,
        engine: &mut Engine<'_>,
        line: u64,
        rec: &LogRecord<'_>,
        out: &mut impl FnMut(Output),
    ) {
        let bus = engine.map().bus_of(rec.iface);
        let t_us = rec.timestamp_us;
        let window = self.window_us;
        let near = self.newest_us.is_none_or(|n| {
            t_us.saturating_add(LATE_WINDOW_US) >= n && t_us <= n.saturating_add(FORWARD_WINDOW_US)
        });
        if !near {
            // Off the timeline: what is pending belongs before it; the engine's timeline decides
            // whether it is a glitch or a new segment, and the window follows the engine.
            self.flush(engine, out);
            engine.process_on_bus(t_us, &rec.frame, bus, line, out);
            self.newest_us = engine.newest_us();
            self.note_iface(rec.iface, t_us);
            if let Some(n) = self.newest_us {
                self.iface_newest
                    .iter_mut()
                    .for_each(|(_, t)| *t = (*t).min(n));
            }
            return;
        }
        // Older than a frame of its own interface: what was pending up to that frame goes first,
        // then this one (late, as without the window).
        if let Some(own) = self.note_iface(rec.iface, t_us).filter(|own| t_us < *own) {
            self.flush_until(own, engine, out);
            engine.process_on_bus(t_us, &rec.frame, bus, line, out);
            return;
        }
        let newest = self.newest_us.map_or(t_us, |n| n.max(t_us));
        self.newest_us = Some(newest);
        if self.pending.is_empty() && t_us.saturating_add(window) <= newest {
            engine.process_on_bus(t_us, &rec.frame, bus, line, out);
            return;
        }
        self.seq += 1;
        self.pending.push(Reverse(Pending {
            t_us,
            seq: self.seq,
            frame: rec.frame,
            bus,
            line,
        }));
        while let Some(Reverse(p)) = self.pending.peek() {
            if p.t_us.saturating_add(window) > newest && self.pending.len() <= MAX_PENDING {
                break;
            }
            let Some(Reverse(p)) = self.pending.pop() else {
                break;
            };
            engine.process_on_bus(p.t_us, &p.frame, p.bus, p.line, out);
        }
    }

    /// Records `t_us` as read on `iface`; returns that interface's newest timestamp before it.
    fn note_iface(&mut self, iface: &str, t_us: u64) -> Option<u64> {
        if let Some((_, newest)) = self.iface_newest.iter_mut().find(|(i, _)| i == iface) {
            let before = *newest;
            *newest = before.max(t_us);
            return Some(before);
        }
        if self.iface_newest.len() < MAX_IFACES {
            self.iface_newest.push((iface.to_owned(), t_us));
        }
        None
    }

    /// Hands the pending frames stamped at most `until_us` to the engine, in timestamp order.
    fn flush_until(
        &mut self,
        until_us: u64,
        engine: &mut Engine<'_>,
        out: &mut impl FnMut(Output),
    ) {
        while self
            .pending
            .peek()
            .is_some_and(|Reverse(p)| p.t_us <= until_us)
        {
            let Some(Reverse(p)) = self.pending.pop() else {
                break;
            };
            engine.process_on_bus(p.t_us, &p.frame, p.bus, p.line, out);
        }
    }

    /// Hands every pending frame to the engine, in timestamp order.
    fn flush(&mut self, engine: &mut Engine<'_>, out: &mut impl FnMut(Output)) {
        self.flush_until(u64::MAX, engine, out);
    }

    /// End of the log: the pending frames, then the engine's own end ([`Engine::finish`]).
    pub fn finish(&mut self, engine: &mut Engine<'_>, out: &mut impl FnMut(Output)) {
        self.flush(engine, out);
        engine.finish(out);
    }
}
