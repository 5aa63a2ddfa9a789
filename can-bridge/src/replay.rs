//! `can-bridge replay`: send a candump log onto an interface with its original timing, frame `i`
//! of a log segment leaving at `segment start + (t_i - t_segment) / rate`.
//!
//! Which frames are sent follows the same timeline rules as `score-log` ([`crate::timeline`]), so
//! a replay puts on the bus what the offline bridge scores: a frame up to 1 s late is dropped, a
//! single frame far off the timeline (a glitch stamped 1e6 s ahead) is dropped alone instead of
//! making the replay wait, and a jump confirmed by the following frames (recordings concatenated)
//! starts a new segment that plays on at once, with its own relative timing. Every dropped frame
//! is counted and named by its line ([`crate::losses`]). The pacing ([`Pacer`]) is clock-free and
//! socket-free; [`replay`] only waits and sends.
use crate::engine::LossKind;
use crate::logfile::{for_each_frame_in, LogReport};
use crate::losses::FrameLosses;
use crate::socket::{self, SocketError};
use crate::timeline::{Action, Timeline};
use can_codec::Frame;
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
    /// Frames read but not sent (late, off the timeline, refused by the interface), by line.
    pub losses: FrameLosses,
    /// Lines, frames and the lines that were not frames.
    pub log: LogReport,
    /// New log segments started (timestamp jumps confirmed by the following frames).
    pub segments: u64,
    pub elapsed: Duration,
    /// Largest lateness of a frame against its schedule.
    pub max_late: Duration,
}

/// Kind of loss of a frame the interface refused.
pub const NOT_SENT: &str = "frames not sent";

/// One decision of the [`Pacer`].
#[derive(Clone, Debug, PartialEq)]
pub enum Paced {
    /// Send `frame`, read at `line`, at `at` after the start of the replay (`Duration::ZERO`
    /// for `--rate max`: at once).
    Send {
        at: Duration,
        line: u64,
        frame: Frame,
        /// Index of the interface to send on.
        port: usize,
    },
    /// The frame of `line` is not sent.
    Drop {
        line: u64,
        kind: LossKind,
        reason: String,
    },
    /// A new segment starts with the next `Send`.
    NewSegment { t_us: u64 },
}

/// When each frame of a replay leaves: the engine's timeline rules applied to pacing.
#[derive(Debug)]
pub struct Pacer {
    rate: Rate,
    timeline: Timeline<(Frame, u64, usize)>,
    /// Log time and replay offset of the current segment's first frame.
    anchor: Option<(u64, Duration)>,
    /// Latest send time scheduled so far.
    last_at: Duration,
    /// Log line of the newest frame sent (0: none yet): a late frame names it.
    newest_line: u64,
}

impl Pacer {
    pub fn new(rate: Rate) -> Self {
        Self {
            rate,
            timeline: Timeline::default(),
            anchor: None,
            last_at: Duration::ZERO,
            newest_line: 0,
        }
    }

    /// Decides on the frame of `line` stamped `t_us`; `out` gets what to send or drop now (a held
    /// frame is decided later, together with the frames that confirm or refute its jump).
    pub fn admit(&mut self, t_us: u64, frame: &Frame, line: u64, out: &mut impl FnMut(Paced)) {
        self.admit_on(t_us, frame, line, 0, out);
    }

    /// [`Pacer::admit`] for a frame to be sent on interface `port`.
    pub fn admit_on(
        &mut self,
        t_us: u64,
        frame: &Frame,
        line: u64,
        port: usize,
        out: &mut impl FnMut(Paced),
    ) {
        let step = self.timeline.admit(t_us, &(*frame, line, port));
        self.drop_off_timeline(&step.dropped, out);
        match step.action {
            Action::Process => {
                if self.timeline.newest_us() == Some(t_us) {
                    self.newest_line = line;
                }
                let at = self.schedule(t_us);
                out(Paced::Send {
                    at,
                    line,
                    frame: *frame,
                    port,
                });
            }
            Action::Late { newest_us } => out(Paced::Drop {
                line,
                kind: LossKind::Late,
                reason: format!(
                    "frame {} at {t_us} us is older than the newest frame ({newest_us} us{}): not sent",
                    frame.id,
                    if self.newest_line == 0 {
                        String::new()
                    } else {
                        format!(", line {}", self.newest_line)
                    }
                ),
            }),
            Action::Held => {}
            // A gap: the frames play on the current segment's timing.
            Action::Continue(held) => self.send_held(held, out),
            Action::NewSegment(held) => {
                // The new segment plays on from the last frame sent, with its own timing.
                self.anchor = Some((held[0].0, self.last_at));
                out(Paced::NewSegment { t_us: held[0].0 });
                self.send_held(held, out);
            }
        }
    }

    /// Sends frames the timeline held, in order.
    fn send_held(&mut self, held: Vec<(u64, (Frame, u64, usize))>, out: &mut impl FnMut(Paced)) {
        for (t, (f, l, port)) in held {
            if self.timeline.newest_us() == Some(t) {
                self.newest_line = l;
            }
            let at = self.schedule(t);
            out(Paced::Send {
                at,
                line: l,
                frame: f,
                port,
            });
        }
    }

    /// End of the log: frames still held for an unconfirmed jump are dropped; those held after a
    /// gap are sent.
    pub fn finish(&mut self, out: &mut impl FnMut(Paced)) {
        let step = self.timeline.finish();
        self.drop_off_timeline(&step.dropped, out);
        if let Action::Continue(held) = step.action {
            self.send_held(held, out);
        }
    }

    fn drop_off_timeline(
        &self,
        dropped: &[(u64, (Frame, u64, usize))],
        out: &mut impl FnMut(Paced),
    ) {
        let newest = self.timeline.newest_us().unwrap_or(0);
        for (t, (f, line, _)) in dropped {
            out(Paced::Drop {
                line: *line,
                kind: LossKind::OffTimeline,
                reason: format!(
                    "frame {} at {t} us is far outside the log's timeline (newest frame {newest} us) and fewer than 3 frames after it continue from it (no new log segment): not sent",
                    f.id
                ),
            });
        }
    }

    /// Send time of an in-order frame of the current segment.
    fn schedule(&mut self, t_us: u64) -> Duration {
        let Rate::Factor(rate) = self.rate else {
            return Duration::ZERO;
        };
        let (t0, base) = *self.anchor.get_or_insert((t_us, self.last_at));
        let at = base + Duration::from_secs_f64(t_us.saturating_sub(t0) as f64 / 1e6 / rate);
        self.last_at = self.last_at.max(at);
        at
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

/// Most blank bytes [`leading_blank`] reads off a log looking for its first other byte.
const BLANK_PEEK: usize = 1 << 20;

/// Reads the ASCII whitespace that starts `reader` (up to [`BLANK_PEEK`] bytes, pipes included):
/// those bytes, and whether the reader ended after them (an empty log, or blank lines only).
fn leading_blank(reader: &mut impl std::io::BufRead) -> std::io::Result<(Vec<u8>, bool)> {
    let mut blank = Vec::new();
    loop {
        let buf = match reader.fill_buf() {
            Ok(buf) => buf,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if buf.is_empty() {
            return Ok((blank, true));
        }
        let n = buf
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .unwrap_or(buf.len());
        let found = n < buf.len();
        blank.extend_from_slice(&buf[..n]);
        reader.consume(n);
        if found || blank.len() >= BLANK_PEEK {
            return Ok((blank, false));
        }
    }
}

/// Opens a send-only socket on `iface`.
fn open_sender(iface: &str) -> Result<socketcan::CanFdSocket, SocketError> {
    let sock = socket::open(iface)?;
    let no_filters: [socketcan::CanFilter; 0] = [];
    socketcan::SocketOptions::set_filters(&sock, &no_filters).map_err(|cause| {
        SocketError::Setup {
            iface: iface.to_string(),
            what: "disabling reception",
            cause,
        }
    })?;
    Ok(sock)
}

/// Replays `log` onto `ifaces`: with one, every frame goes to it; with several, each frame goes
/// to the interface its line names (a line naming another is not sent, and counted). `-` is
/// standard input ([`crate::logfile::open`]), read once like a file.
pub fn replay(log: &Path, ifaces: &[String], rate: Rate) -> Result<ReplaySummary, ReplayError> {
    let read_err = |cause| ReplayError::Read {
        path: crate::logfile::describe(log),
        cause,
    };
    let mut reader = crate::logfile::open(log).map_err(read_err)?;
    // An empty log (no byte but blank lines) is refused by the caller before a socket is opened:
    // its summary counts no frame and no bad line.
    let (blank, ended) = leading_blank(&mut reader).map_err(read_err)?;
    if ended {
        let log = for_each_frame_in(std::io::Cursor::new(blank), |_, _| {}).map_err(read_err)?;
        return Ok(ReplaySummary {
            log,
            ..ReplaySummary::default()
        });
    }
    // The blank bytes read off go first again, so the lines keep their numbers.
    let reader = std::io::Read::chain(std::io::Cursor::new(blank), reader);
    let socks = ifaces
        .iter()
        .map(|i| open_sender(i))
        .collect::<Result<Vec<_>, _>>()?;
    let mut summary = ReplaySummary::default();
    let mut pacer = Pacer::new(rate);
    let start = Instant::now();
    let mut fatal: Option<SocketError> = None;
    let mut act = |p: Paced, summary: &mut ReplaySummary| match p {
        Paced::Send {
            at,
            line,
            frame,
            port,
        } => {
            if fatal.is_some() {
                return;
            }
            if at > Duration::ZERO {
                let deadline = start + at;
                wait_until(deadline);
                let late = Instant::now().saturating_duration_since(deadline);
                summary.max_late = summary.max_late.max(late);
            }
            let Some(frame) = socket::to_socketcan(&frame) else {
                summary.losses.record(line, NOT_SENT, || {
                    "not representable as a socket frame: not sent".into()
                });
                return;
            };
            match socket::send(&socks[port], &ifaces[port], &frame) {
                Ok(()) => summary.sent += 1,
                Err(SocketError::Io { cause, .. }) => summary
                    .losses
                    .record(line, NOT_SENT, || format!("{cause}: not sent")),
                Err(e) => fatal = Some(e),
            }
        }
        Paced::Drop { line, kind, reason } => {
            summary.losses.record(line, kind.as_str(), || reason);
        }
        Paced::NewSegment { .. } => summary.segments += 1,
    };
    let log_report = for_each_frame_in(reader, |line_no, rec| {
        let port = if ifaces.len() == 1 {
            Some(0)
        } else {
            ifaces.iter().position(|i| i == rec.iface)
        };
        match port {
            Some(port) => pacer.admit_on(
                rec.timestamp_us,
                &rec.frame,
                line_no as u64,
                port,
                &mut |p| act(p, &mut summary),
            ),
            None => summary.losses.record(line_no as u64, NOT_SENT, || {
                format!("interface {} is not one of --iface: not sent", rec.iface)
            }),
        }
    })
    .map_err(read_err)?;
    pacer.finish(&mut |p| act(p, &mut summary));
    if let Some(e) = fatal {
        return Err(e.into());
    }
    summary.log = log_report;
    summary.elapsed = start.elapsed();
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use can_codec::CanId;

    const T0: u64 = 1_700_000_000_000_000;

    fn frame() -> Frame {
        Frame::data_frame(CanId::Standard(0x100), &[1, 2]).unwrap()
    }

    /// Feeds `(t_us)` stamps (lines 1, 2, ...) and collects the pacer's decisions.
    fn pace(rate: Rate, stamps: &[u64]) -> Vec<Paced> {
        let mut p = Pacer::new(rate);
        let mut out = Vec::new();
        for (i, t) in stamps.iter().enumerate() {
            p.admit(*t, &frame(), i as u64 + 1, &mut |d| out.push(d));
        }
        p.finish(&mut |d| out.push(d));
        out
    }

    fn sends(out: &[Paced]) -> Vec<(u64, Duration)> {
        out.iter()
            .filter_map(|d| match d {
                Paced::Send { at, line, .. } => Some((*line, *at)),
                _ => None,
            })
            .collect()
    }

    fn drops(out: &[Paced]) -> Vec<(u64, LossKind)> {
        out.iter()
            .filter_map(|d| match d {
                Paced::Drop { line, kind, .. } => Some((*line, *kind)),
                _ => None,
            })
            .collect()
    }

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    /// Ten frames 100 ms apart from `t`.
    fn cycle(t: u64) -> Vec<u64> {
        (0..10).map(|k| t + k * 100_000).collect()
    }

    #[test]
    fn each_frame_keeps_its_interface_also_when_held_for_a_jump() {
        let mut p = Pacer::new(Rate::Max);
        let mut out = Vec::new();
        // A jump of 200 s ahead, confirmed by the frames after it: held, then sent.
        let stamps = [
            1_000_000u64,
            1_001_000,
            201_000_000,
            201_001_000,
            201_002_000,
            201_003_000,
        ];
        for (i, t) in stamps.iter().enumerate() {
            p.admit_on(*t, &frame(), i as u64 + 1, i % 2, &mut |x| out.push(x));
        }
        p.finish(&mut |x| out.push(x));
        let ports: Vec<(u64, usize)> = out
            .iter()
            .filter_map(|x| match x {
                Paced::Send { line, port, .. } => Some((*line, *port)),
                _ => None,
            })
            .collect();
        assert_eq!(ports.len(), 6);
        assert!(out.iter().any(|x| matches!(x, Paced::NewSegment { .. })));
        for (line, port) in ports {
            assert_eq!(port, (line as usize - 1) % 2, "line {line}");
        }
    }

    #[test]
    fn a_frame_a_million_seconds_ahead_is_dropped_alone_and_nobody_waits_for_it() {
        let mut stamps = cycle(T0);
        stamps.insert(5, T0 + 1_000_000_000_000);
        let out = pace(Rate::Factor(1.0), &stamps);
        assert_eq!(drops(&out), [(6, LossKind::OffTimeline)]);
        let s = sends(&out);
        assert_eq!(s.len(), 10);
        // The schedule is the original timing: the last frame leaves 0.9 s after the first.
        assert_eq!(s.last(), Some(&(11, ms(900))));
        assert!(s.iter().all(|(_, at)| *at <= ms(900)), "{s:?}");
    }

    #[test]
    fn a_frame_2_s_ahead_is_dropped_alone_and_the_frames_after_it_are_sent() {
        let mut stamps = cycle(T0);
        stamps[4] += 2_000_000;
        let out = pace(Rate::Factor(1.0), &stamps);
        assert_eq!(drops(&out), [(5, LossKind::OffTimeline)]);
        assert!(!out.iter().any(|x| matches!(x, Paced::NewSegment { .. })));
        let s = sends(&out);
        assert_eq!(s.len(), 9);
        assert_eq!(s.last(), Some(&(10, ms(900))));
    }

    #[test]
    fn a_gap_of_2_s_plays_on_the_same_timing_also_at_the_end() {
        let mut stamps = cycle(T0);
        stamps.extend(cycle(T0 + 2_900_000));
        // Two frames after a second gap end the log: sent, on the same timing.
        stamps.extend([T0 + 6_000_000, T0 + 6_100_000]);
        let out = pace(Rate::Factor(1.0), &stamps);
        assert!(drops(&out).is_empty(), "{out:?}");
        assert!(!out.iter().any(|x| matches!(x, Paced::NewSegment { .. })));
        let s = sends(&out);
        assert_eq!(s.len(), 22);
        assert_eq!(s[10], (11, ms(2900)));
        assert_eq!(s[21], (22, ms(6100)));
    }

    #[test]
    fn a_jump_back_of_100_s_starts_a_new_segment_that_plays_on_at_once() {
        let mut stamps = cycle(T0 + 100_000_000);
        stamps.extend(cycle(T0 + 1_000_000));
        let out = pace(Rate::Factor(1.0), &stamps);
        assert!(drops(&out).is_empty(), "{out:?}");
        assert!(out.contains(&Paced::NewSegment {
            t_us: T0 + 1_000_000
        }));
        let s = sends(&out);
        assert_eq!(s.len(), 20);
        // Lines in order; the second recording starts where the first ended, with its own timing.
        assert!(s.windows(2).all(|w| w[0].0 < w[1].0 && w[0].1 <= w[1].1));
        assert_eq!(s[10], (11, ms(900)));
        assert_eq!(s[19], (20, ms(1800)));
    }

    #[test]
    fn a_late_frame_names_the_line_of_the_frame_stamped_ahead() {
        let mut stamps = cycle(T0);
        // Line 3 is stamped 0.6 s ahead: lines 4..=8 (up to T0 + 0.6 s) are late.
        stamps[2] = T0 + 800_000;
        let out = pace(Rate::Max, &stamps);
        let reasons: Vec<&str> = out
            .iter()
            .filter_map(|d| match d {
                Paced::Drop { reason, .. } => Some(reason.as_str()),
                _ => None,
            })
            .collect();
        assert!(!reasons.is_empty());
        for r in reasons {
            assert!(
                r.ends_with(&format!("({} us, line 3): not sent", T0 + 800_000)),
                "{r}"
            );
        }
    }

    #[test]
    fn late_frames_are_dropped_and_rate_scales_the_schedule() {
        let mut stamps = cycle(T0);
        stamps.insert(3, T0 + 100_000 - 500_000);
        let out = pace(Rate::Factor(2.0), &stamps);
        assert_eq!(drops(&out), [(4, LossKind::Late)]);
        assert_eq!(sends(&out).last(), Some(&(11, ms(450))));
        let out = pace(Rate::Max, &stamps);
        assert!(sends(&out).iter().all(|(_, at)| at.is_zero()));
        assert_eq!(drops(&out).len(), 1);
    }

    #[test]
    fn a_jump_too_short_to_confirm_at_the_end_is_dropped_by_line() {
        let mut stamps = cycle(T0);
        stamps.extend([T0 + 3_600_000_000, T0 + 3_600_100_000]);
        let out = pace(Rate::Factor(1.0), &stamps);
        assert_eq!(
            drops(&out),
            [(11, LossKind::OffTimeline), (12, LossKind::OffTimeline)]
        );
        assert_eq!(sends(&out).len(), 10);
    }
}
