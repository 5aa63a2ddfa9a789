//! `can-bridge replay`: send a candump log onto an interface with its original timing (canplayer
//! semantics: frame `i` leaves at `start + (t_i - t_0) / rate`; frames whose time has passed, or
//! that go back in time, leave at once).
use crate::logfile::{for_each_frame_in, LogReport};
use crate::socket::{self, SocketError};
use std::path::Path;
use std::time::{Duration, Instant};

/// Replay speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rate {
    /// Real time multiplied by this factor (> 0).
    Factor(f64),
    /// As fast as the interface accepts.
    Max,
}

impl std::str::FromStr for Rate {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "max" {
            return Ok(Rate::Max);
        }
        match s.parse::<f64>() {
            Ok(r) if r.is_finite() && r > 0.0 => Ok(Rate::Factor(r)),
            _ => Err(format!(
                "rate must be a positive number or `max`, not `{s}`"
            )),
        }
    }
}

/// What a replay did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplaySummary {
    pub sent: u64,
    /// The first frames the kernel refused (e.g. error frames on some drivers), by line.
    pub refused: Vec<(usize, String)>,
    /// Every refused frame.
    pub refused_total: u64,
    /// Lines, frames and the lines that were not frames.
    pub log: LogReport,
    pub elapsed: Duration,
    /// Largest lateness of a frame against its schedule.
    pub max_late: Duration,
}

impl ReplaySummary {
    fn refuse(&mut self, line: usize, why: String) {
        self.refused_total += 1;
        if self.refused.len() < crate::logfile::KEPT_PER_KIND {
            self.refused.push((line, why));
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("reading {path}: {cause}")]
    Read { path: String, cause: std::io::Error },
    #[error(transparent)]
    Socket(#[from] SocketError),
}

fn wait_until(deadline: Instant) {
    loop {
        let now = Instant::now();
        if now >= deadline {
            return;
        }
        let left = deadline - now;
        if left > Duration::from_micros(300) {
            std::thread::sleep(left - Duration::from_micros(200));
        } else {
            std::hint::spin_loop();
        }
    }
}

/// Replays `log` onto `iface`.
pub fn replay(log: &Path, iface: &str, rate: Rate) -> Result<ReplaySummary, ReplayError> {
    let read_err = |cause| ReplayError::Read {
        path: log.display().to_string(),
        cause,
    };
    let file = std::fs::File::open(log).map_err(read_err)?;
    let reader = std::io::BufReader::with_capacity(1 << 20, file);
    let sock = socket::open(iface)?;
    // This socket only sends: receive nothing.
    let no_filters: [socketcan::CanFilter; 0] = [];
    socketcan::SocketOptions::set_filters(&sock, &no_filters).map_err(|cause| {
        SocketError::Setup {
            iface: iface.to_string(),
            what: "disabling reception",
            cause,
        }
    })?;
    let mut summary = ReplaySummary::default();
    let start = Instant::now();
    let mut t0: Option<u64> = None;
    let mut fatal: Option<SocketError> = None;
    let log_report = for_each_frame_in(reader, |line_no, rec| {
        if fatal.is_some() {
            return;
        }
        if let Rate::Factor(r) = rate {
            let t0 = *t0.get_or_insert(rec.timestamp_us);
            let offset_us = rec.timestamp_us.saturating_sub(t0) as f64 / r;
            let deadline = start + Duration::from_micros(offset_us as u64);
            wait_until(deadline);
            let late = Instant::now().saturating_duration_since(deadline);
            summary.max_late = summary.max_late.max(late);
        }
        let Some(frame) = socket::to_socketcan(&rec.frame) else {
            summary.refuse(line_no, "not representable as a socket frame".into());
            return;
        };
        match socket::send(&sock, iface, &frame) {
            Ok(()) => summary.sent += 1,
            Err(SocketError::Io { cause, .. }) => summary.refuse(line_no, cause.to_string()),
            Err(e) => fatal = Some(e),
        }
    })
    .map_err(read_err)?;
    if let Some(e) = fatal {
        return Err(e.into());
    }
    summary.log = log_report;
    summary.elapsed = start.elapsed();
    Ok(summary)
}
