//! The bridge's human- and machine-readable outputs: JSON Lines warning events and the status line.
use crate::engine::{Output, Stats};
use crate::sanity::Sanity;
use riskscore_output::AtomicFile;
use std::io::Write;

/// Seconds with microsecond precision, as JSON numbers.
fn seconds(t_us: u64) -> f64 {
    t_us as f64 / 1e6
}

/// The JSON Lines record of a warning transition (`None` for other outputs, or for every scored
/// observation when `all_scores` is set).
pub fn json_event(output: &Output, all_scores: bool) -> Option<serde_json::Value> {
    match output {
        Output::WarningOn {
            t_us,
            track,
            score,
            level,
        } => Some(serde_json::json!({
            "t": seconds(*t_us), "track": track, "score": score, "warning": true, "level": level,
        })),
        Output::WarningOff {
            t_us,
            track,
            score,
            reason,
        } => Some(serde_json::json!({
            "t": seconds(*t_us), "track": track, "score": score, "warning": false,
            "reason": reason.as_str(),
        })),
        Output::Scored(o) if all_scores => Some(serde_json::json!({
            "t": seconds(o.t_us), "track": o.track, "score": o.score, "warning": o.warning,
            "level": o.level, "scored": true,
        })),
        _ => None,
    }
}

/// Where an output stream goes.
pub enum Sink {
    Stdout(std::io::Stdout),
    /// Offline runs: a file that replaces its destination only when the run succeeds.
    Atomic(AtomicFile),
    /// Live runs: a file written as it goes, so a reader can follow it.
    Streaming(std::io::BufWriter<std::fs::File>),
}

impl Sink {
    /// Flushes, and for [`Sink::Atomic`] renames the file into place.
    pub fn finish(self) -> std::io::Result<()> {
        match self {
            Self::Stdout(mut s) => s.flush(),
            Self::Atomic(f) => f.commit(),
            Self::Streaming(mut f) => f.flush(),
        }
    }
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Self::Stdout(s) => s.write(buf),
            Self::Atomic(f) => f.write(buf),
            Self::Streaming(f) => f.write(buf),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Self::Stdout(s) => s.flush(),
            Self::Atomic(f) => f.flush(),
            Self::Streaming(f) => f.flush(),
        }
    }
}

/// Writes JSON Lines events; flushes every line so a reader (or a killed process) loses nothing.
pub struct EventWriter {
    out: Sink,
    pub all_scores: bool,
    pub written: u64,
}

impl EventWriter {
    pub fn new(out: Sink, all_scores: bool) -> Self {
        Self {
            out,
            all_scores,
            written: 0,
        }
    }

    pub fn handle(&mut self, output: &Output) -> std::io::Result<()> {
        if let Some(v) = json_event(output, self.all_scores) {
            writeln!(self.out, "{v}")?;
            self.out.flush()?;
            self.written += 1;
        }
        Ok(())
    }

    /// Ends the stream (see [`Sink::finish`]).
    pub fn finish(self) -> std::io::Result<()> {
        self.out.finish()
    }
}

/// Rate-limited printing of per-frame problems on stderr, and the run-end sanity report over
/// the scored states ([`Sanity`]), so every command that prints problems also checks the map.
pub struct ProblemPrinter {
    pub limit: u64,
    pub printed: u64,
    pub suppressed: u64,
    /// Offline: how the log's lines are named (`drive.log`, `<stdin>`,
    /// [`crate::logfile::line_name`]), so a problem names its line as a decode error does.
    pub log: Option<String>,
    /// Lost frames are listed by log line elsewhere ([`crate::losses`]): do not print them here.
    pub skip_lost: bool,
    pub sanity: Sanity,
}

impl ProblemPrinter {
    pub fn new(limit: u64) -> Self {
        Self {
            limit,
            printed: 0,
            suppressed: 0,
            log: None,
            skip_lost: false,
            sanity: Sanity::default(),
        }
    }

    /// `FILE:LINE: T: reason` offline (the line of the frame being processed when it happened),
    /// `can-bridge: T: reason` live.
    fn line(&self, t_us: u64, source: u64, reason: &crate::engine::Problem) -> String {
        match &self.log {
            Some(name) if source > 0 => format!("{name}:{source}: {:.6}: {reason}", seconds(t_us)),
            _ => format!("can-bridge: {:.6}: {reason}", seconds(t_us)),
        }
    }

    pub fn handle(&mut self, output: &Output) {
        if let Output::Scored(update) = output {
            self.sanity.observe(update);
        }
        if let Output::Problem {
            t_us,
            source,
            reason,
            lost,
        } = output
        {
            if self.skip_lost && lost.is_some() {
                return;
            }
            if self.printed < self.limit {
                eprintln!("{}", self.line(*t_us, *source, reason));
                self.printed += 1;
            } else {
                self.suppressed += 1;
            }
        }
    }
}

/// The periodic status line: rates since the previous line plus totals.
pub fn status_line(now: &Stats, prev: &Stats, elapsed_s: f64, tracks: usize) -> String {
    let rate = if elapsed_s > 0.0 {
        (now.frames - prev.frames) as f64 / elapsed_s
    } else {
        0.0
    };
    format!(
        "status: {rate:.0} frames/s, {tracks} tracks, {} scored, {} warning frames, {} decode errors, {} stale drops, {} bus errors ({} bus-off), {} unknown ids, {} reordered, {} off the timeline, {} outside the training domain",
        now.scored,
        now.warning_frames,
        now.decode_errors,
        now.stale_drops,
        now.bus_errors(),
        now.bus_off,
        now.unknown_ids,
        now.reordered,
        now.out_of_window,
        now.out_of_domain,
    )
}
