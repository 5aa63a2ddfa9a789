//! Live scoring on a SocketCAN interface.
use crate::engine::{Engine, Output, Stats};
use crate::events_out::{status_line, EventWriter, ProblemPrinter};
use crate::socket::{self, SocketError};
use socketcan::Socket;
use std::time::{Duration, Instant};

/// How long to run and how often to report.
#[derive(Clone, Debug)]
pub struct LiveOptions {
    pub iface: String,
    pub status_every: Duration,
    /// Stop after this long (None: until the interface goes away).
    pub duration: Option<Duration>,
    /// Stop after this long without any received frame (None: never).
    pub idle_exit: Option<Duration>,
    /// Print the status line (stderr).
    pub status: bool,
}

/// Why the live loop ended normally.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    Duration,
    Idle,
}

fn interface_exists(iface: &str) -> bool {
    std::path::Path::new("/sys/class/net").join(iface).exists()
}

/// Runs until `duration`/`idle_exit`, or until the interface fails (error).
pub fn run(
    engine: &mut Engine<'_>,
    opts: &LiveOptions,
    events: &mut EventWriter,
    problems: &mut ProblemPrinter,
) -> Result<(StopReason, Stats), SocketError> {
    let ids = engine.map().input_ids();
    let read_timeout = Duration::from_millis(100);
    let sock = socket::open_bridge_socket(&opts.iface, &ids, read_timeout)?;
    eprintln!(
        "can-bridge: listening on {} ({} input ids filtered in the kernel, error frames on)",
        opts.iface,
        ids.len()
    );
    let started = Instant::now();
    let mut last_frame = Instant::now();
    let mut last_status = Instant::now();
    let mut prev_stats = *engine.stats();
    let mut send_error: Option<SocketError> = None;
    let mut event_error: Option<std::io::Error> = None;
    loop {
        match sock.read_frame_with_timestamp() {
            Ok((frame, ts)) => {
                last_frame = Instant::now();
                let t_us = socket::micros(ts);
                if let Some(f) = socket::from_socketcan(&frame) {
                    engine.process(t_us, &f, &mut |o: Output| {
                        if let Output::WarningFrame { frame, .. } = &o {
                            if send_error.is_none() {
                                if let Some(sf) = socket::to_socketcan(frame) {
                                    if let Err(e) = socket::send(&sock, &opts.iface, &sf) {
                                        send_error = Some(e);
                                    }
                                }
                            }
                        }
                        if let Err(e) = events.handle(&o) {
                            event_error.get_or_insert(e);
                        }
                        problems.handle(&o);
                    });
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                if !interface_exists(&opts.iface) {
                    return Err(SocketError::Gone {
                        iface: opts.iface.clone(),
                        cause: std::io::Error::from_raw_os_error(19),
                    });
                }
                let now_us = socket::micros(std::time::SystemTime::now());
                engine.tick(now_us, &mut |o: Output| {
                    let _ = events.handle(&o);
                    problems.handle(&o);
                });
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(cause) if socket::is_interface_gone(&cause) => {
                return Err(SocketError::Gone {
                    iface: opts.iface.clone(),
                    cause,
                })
            }
            Err(cause) => {
                return Err(SocketError::Io {
                    iface: opts.iface.clone(),
                    what: "receiving",
                    cause,
                })
            }
        }
        if let Some(e) = send_error.take() {
            return Err(e);
        }
        if let Some(e) = event_error.take() {
            return Err(SocketError::Io {
                iface: opts.iface.clone(),
                what: "writing warning events",
                cause: e,
            });
        }
        let elapsed = last_status.elapsed();
        if opts.status && elapsed >= opts.status_every {
            let now = *engine.stats();
            eprintln!(
                "{}",
                status_line(
                    &now,
                    &prev_stats,
                    elapsed.as_secs_f64(),
                    engine.track_count()
                )
            );
            prev_stats = now;
            last_status = Instant::now();
        }
        if opts.duration.is_some_and(|d| started.elapsed() >= d) {
            return Ok((StopReason::Duration, *engine.stats()));
        }
        if opts.idle_exit.is_some_and(|d| last_frame.elapsed() >= d) {
            return Ok((StopReason::Idle, *engine.stats()));
        }
    }
}
