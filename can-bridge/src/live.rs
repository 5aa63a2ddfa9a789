//! Live scoring on one or more SocketCAN interfaces, on one timeline.
//!
//! One socket per interface, each read by its own thread (kernel filters: the ids of the messages
//! on that interface's bus). Frames are handed to the engine in kernel receive-timestamp order
//! (all interfaces stamp on the same clock): with several interfaces, a frame waits until every
//! other interface has delivered a later frame, or [`LiveOptions::merge_wait`] has passed since its
//! timestamp, so a frame of one bus never arrives behind a later frame of another and is dropped
//! as late. With one interface nothing waits.
use crate::engine::{Engine, Output, Stats};
use crate::events_out::{status_line, EventWriter, ProblemPrinter};
use crate::socket::{self, SocketError};
use can_codec::Frame;
use socketcan::{CanFdSocket, Socket};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long to run and how often to report.
#[derive(Clone, Debug)]
pub struct LiveOptions {
    /// The interfaces to read (at least one); warnings are sent on the warning message's bus
    /// when it is one of them, else on the first.
    pub ifaces: Vec<String>,
    pub status_every: Duration,
    /// Stop after this long (None: until the interface goes away).
    pub duration: Option<Duration>,
    /// Stop after this long without any received frame (None: never).
    pub idle_exit: Option<Duration>,
    /// Print the status line (stderr).
    pub status: bool,
    /// Several interfaces: how long a frame may wait for the other interfaces to pass its
    /// timestamp before it is processed anyway.
    pub merge_wait: Duration,
}

/// Default [`LiveOptions::merge_wait`].
pub const DEFAULT_MERGE_WAIT: Duration = Duration::from_millis(20);

/// Why the live loop ended normally.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    Duration,
    Idle,
}

fn interface_exists(iface: &str) -> bool {
    std::path::Path::new("/sys/class/net").join(iface).exists()
}

/// What a reader thread reports.
enum Received {
    Frame {
        port: usize,
        t_us: u64,
        frame: Frame,
    },
    Failed(SocketError),
}

/// Reads `sock` until `stop`, sending every frame (and a failure, once) to `tx`.
fn read_loop(
    port: usize,
    iface: String,
    sock: Arc<CanFdSocket>,
    stop: Arc<AtomicBool>,
    tx: mpsc::Sender<Received>,
) {
    while !stop.load(Ordering::Relaxed) {
        let failed = match sock.read_frame_with_timestamp() {
            Ok((frame, ts)) => {
                if let Some(frame) = socket::from_socketcan(&frame) {
                    let t_us = socket::micros(ts);
                    if tx.send(Received::Frame { port, t_us, frame }).is_err() {
                        return;
                    }
                }
                None
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                (!interface_exists(&iface)).then(|| SocketError::Gone {
                    iface: iface.clone(),
                    cause: std::io::Error::from_raw_os_error(19),
                })
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => None,
            Err(cause) if socket::is_interface_gone(&cause) => Some(SocketError::Gone {
                iface: iface.clone(),
                cause,
            }),
            Err(cause) => Some(SocketError::Io {
                iface: iface.clone(),
                what: "receiving",
                cause,
            }),
        };
        if let Some(e) = failed {
            let _ = tx.send(Received::Failed(e));
            return;
        }
    }
}

/// Frames received and not yet processed, in timestamp order, and how far each interface has got.
struct Merge {
    pending: VecDeque<(u64, usize, Frame)>,
    latest_us: Vec<Option<u64>>,
    wait_us: u64,
}

impl Merge {
    fn push(&mut self, t_us: u64, port: usize, frame: Frame) {
        let seen = &mut self.latest_us[port];
        *seen = Some(seen.map_or(t_us, |s| s.max(t_us)));
        // Frames of one interface come in order: the place is nearly always the end.
        let at = self
            .pending
            .iter()
            .rposition(|(t, _, _)| *t <= t_us)
            .map_or(0, |i| i + 1);
        self.pending.insert(at, (t_us, port, frame));
    }

    /// The oldest frame, if no other interface can still deliver an older one.
    fn pop_ready(&mut self, now_us: u64) -> Option<(u64, usize, Frame)> {
        let &(t, port, _) = self.pending.front()?;
        let others_passed = self
            .latest_us
            .iter()
            .enumerate()
            .all(|(p, seen)| p == port || seen.is_some_and(|s| s >= t));
        if others_passed || now_us >= t.saturating_add(self.wait_us) {
            self.pending.pop_front()
        } else {
            None
        }
    }

    /// How long until the oldest frame is processed whatever the other interfaces do.
    fn next_deadline(&self, now_us: u64) -> Option<Duration> {
        self.pending.front().map(|(t, _, _)| {
            Duration::from_micros(t.saturating_add(self.wait_us).saturating_sub(now_us))
        })
    }
}

/// Runs until `duration`/`idle_exit`, or until an interface fails (error).
pub fn run(
    engine: &mut Engine<'_>,
    opts: &LiveOptions,
    events: &mut EventWriter,
    problems: &mut ProblemPrinter,
) -> Result<(StopReason, Stats), SocketError> {
    let read_timeout = Duration::from_millis(100);
    let map = engine.map();
    let buses: Vec<Option<u8>> = opts.ifaces.iter().map(|i| map.bus_of(i)).collect();
    let mut sockets = Vec::new();
    for (iface, bus) in opts.ifaces.iter().zip(&buses) {
        let ids: Vec<_> = map
            .inputs
            .iter()
            .filter(|m| m.bus.is_none() || m.bus == *bus)
            .map(|m| m.spec.id)
            .collect();
        let sock = socket::open_bridge_socket(iface, &ids, read_timeout)?;
        eprintln!(
            "can-bridge: listening on {iface} ({} input ids filtered in the kernel, error frames on)",
            ids.len()
        );
        sockets.push(Arc::new(sock));
    }
    let send_port = map
        .warning_bus
        .and_then(|b| buses.iter().position(|x| *x == Some(b)))
        .unwrap_or(0);
    let send_iface = opts.ifaces[send_port].clone();
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let readers: Vec<_> = sockets
        .iter()
        .enumerate()
        .map(|(port, sock)| {
            let (iface, sock, stop, tx) = (
                opts.ifaces[port].clone(),
                Arc::clone(sock),
                Arc::clone(&stop),
                tx.clone(),
            );
            std::thread::spawn(move || read_loop(port, iface, sock, stop, tx))
        })
        .collect();
    drop(tx);
    let result = serve(
        engine,
        opts,
        events,
        problems,
        &rx,
        &buses,
        (&sockets[send_port], &send_iface),
    );
    stop.store(true, Ordering::Relaxed);
    drop(rx);
    for r in readers {
        let _ = r.join();
    }
    result
}

fn serve(
    engine: &mut Engine<'_>,
    opts: &LiveOptions,
    events: &mut EventWriter,
    problems: &mut ProblemPrinter,
    rx: &mpsc::Receiver<Received>,
    buses: &[Option<u8>],
    (send_sock, send_iface): (&CanFdSocket, &str),
) -> Result<(StopReason, Stats), SocketError> {
    let started = Instant::now();
    let mut last_frame = Instant::now();
    let mut last_status = Instant::now();
    let mut prev_stats = *engine.stats();
    let mut send_error: Option<SocketError> = None;
    let mut event_error: Option<std::io::Error> = None;
    let mut merge = Merge {
        pending: VecDeque::new(),
        latest_us: vec![None; buses.len()],
        wait_us: if buses.len() > 1 {
            opts.merge_wait.as_micros() as u64
        } else {
            0
        },
    };
    let now_us = || socket::micros(std::time::SystemTime::now());
    loop {
        let wait = merge
            .next_deadline(now_us())
            .map_or(Duration::from_millis(100), |d| {
                d.min(Duration::from_millis(100))
            });
        match rx.recv_timeout(wait) {
            Ok(Received::Frame { port, t_us, frame }) => {
                last_frame = Instant::now();
                merge.push(t_us, port, frame);
                // Drain what else has arrived before deciding on order.
                while let Ok(r) = rx.try_recv() {
                    match r {
                        Received::Frame { port, t_us, frame } => merge.push(t_us, port, frame),
                        Received::Failed(e) => return Err(e),
                    }
                }
            }
            Ok(Received::Failed(e)) => return Err(e),
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if merge.pending.is_empty() {
                    engine.tick(now_us(), &mut |o: Output| {
                        let _ = events.handle(&o);
                        problems.handle(&o);
                    });
                }
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(SocketError::Io {
                    iface: send_iface.to_string(),
                    what: "receiving",
                    cause: std::io::Error::other("every reader stopped"),
                })
            }
        }
        let now = now_us();
        while let Some((t_us, port, frame)) = merge.pop_ready(now) {
            engine.process_on_bus(t_us, &frame, buses[port], 0, &mut |o: Output| {
                if let Output::WarningFrame { frame, .. } = &o {
                    if send_error.is_none() {
                        if let Some(sf) = socket::to_socketcan(frame) {
                            if let Err(e) = socket::send(send_sock, send_iface, &sf) {
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
        if let Some(e) = send_error.take() {
            return Err(e);
        }
        if let Some(e) = event_error.take() {
            return Err(SocketError::Io {
                iface: send_iface.to_string(),
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
        let done = |reason| Ok((reason, *engine.stats()));
        if opts.duration.is_some_and(|d| started.elapsed() >= d) {
            return done(StopReason::Duration);
        }
        if merge.pending.is_empty() && opts.idle_exit.is_some_and(|d| last_frame.elapsed() >= d) {
            return done(StopReason::Idle);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use can_codec::CanId;

    fn f(id: u16) -> Frame {
        Frame::data_frame(CanId::Standard(id), &[id as u8]).unwrap()
    }

    #[test]
    fn frames_of_two_interfaces_are_processed_in_timestamp_order() {
        let mut m = Merge {
            pending: VecDeque::new(),
            latest_us: vec![None; 2],
            wait_us: 20_000,
        };
        m.push(1_000, 0, f(1));
        m.push(1_300, 0, f(2));
        // Interface 1 has not passed 1000 us yet: nothing is ready before the wait is over.
        assert!(m.pop_ready(5_000).is_none());
        assert_eq!(m.next_deadline(5_000), Some(Duration::from_micros(16_000)));
        // An older frame of interface 1 arrives late: it goes first.
        m.push(900, 1, f(3));
        m.push(1_200, 1, f(4));
        let order: Vec<u64> = std::iter::from_fn(|| m.pop_ready(5_000))
            .map(|(t, _, _)| t)
            .collect();
        // 1300 waits: interface 1 has only got to 1200.
        assert_eq!(order, [900, 1_000, 1_200]);
        assert_eq!(m.pop_ready(21_299).map(|x| x.0), None);
        assert_eq!(m.pop_ready(21_300).map(|x| x.0), Some(1_300));
    }
}
