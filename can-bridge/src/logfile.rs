//! Reading candump `-L` logs line by line from bytes, with every unusable line reported by its
//! number and skipped: a line that is not a frame, not UTF-8, or longer than [`MAX_LINE_BYTES`]
//! costs that line only. Memory is bounded by the line cap whatever the input (a file without
//! line breaks is refused after [`MAX_SKIP_BYTES`]).
use can_codec::{parse_line, LineError, LogRecord};
use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::Path;

/// Longest line read (bytes, without the line break). A candump `-L` line of a 64-byte CAN FD
/// frame is under 200 bytes; longer lines are reported and skipped.
pub const MAX_LINE_BYTES: usize = 4096;
/// A single line longer than this is taken for a binary file: the log is refused as a whole.
pub const MAX_SKIP_BYTES: u64 = 16 << 20;
/// Problems kept (and printed) per kind; the rest are counted.
pub const KEPT_PER_KIND: usize = 20;

/// Why a line was skipped.
#[derive(Clone, Debug, PartialEq)]
pub enum LineProblem {
    /// Valid text, but not a frame line.
    NotFrame(LineError),
    /// The line is not UTF-8 (first bad byte at this 0-based column).
    NotUtf8 { column: usize },
    /// The line is longer than [`MAX_LINE_BYTES`].
    TooLong { bytes: u64 },
}

impl LineProblem {
    /// A stable name of the kind of problem (for per-kind counts).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::NotFrame(e) => e.kind(),
            Self::NotUtf8 { .. } => "not UTF-8",
            Self::TooLong { .. } => "line too long",
        }
    }
}

impl std::fmt::Display for LineProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotFrame(e) => write!(f, "not a candump -L frame line: {e}"),
            Self::NotUtf8 { column } => {
                write!(
                    f,
                    "not UTF-8 (invalid byte at column {}): line skipped",
                    column + 1
                )
            }
            Self::TooLong { bytes } => write!(
                f,
                "line of {bytes} bytes is longer than the {MAX_LINE_BYTES}-byte limit: skipped"
            ),
        }
    }
}

/// A line that is not a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct BadLine {
    pub line: usize,
    pub problem: LineProblem,
}

/// Counts of what a log held.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LogReport {
    pub lines: usize,
    pub frames: usize,
    /// Blank lines (ignored).
    pub blank: usize,
    /// The first [`KEPT_PER_KIND`] bad lines of each kind, in line order.
    pub bad: Vec<BadLine>,
    /// Every bad line, counted by kind.
    pub bad_by_kind: BTreeMap<&'static str, usize>,
    /// The first frame's line and timestamp (us).
    pub first_frame: Option<(usize, u64)>,
    /// Whether any frame has another timestamp than the first frame.
    pub timestamps_advance: bool,
}

/// Same-time duplicates below this never make a log "too coarse" ([`LogReport::stuck_timestamps`]).
const COARSE_MIN_DUPLICATES: u64 = 10;

impl LogReport {
    /// Lines skipped for any reason.
    pub fn bad_lines(&self) -> usize {
        self.bad_by_kind.values().sum()
    }

    /// When the log's timestamps cannot order its track updates, what to tell the user; `None`
    /// otherwise. `duplicates`: updates dropped as a second update of a track at the same time,
    /// `scored`: the updates scored. Two cases: every frame (two or more) carries one timestamp
    /// and that cost updates; or most updates were such duplicates (timestamps truncated to whole
    /// seconds or milliseconds). Receive times of a real capture are microseconds apart, so a
    /// duplicate is a rare glitch; when duplicates outnumber scored updates, the scores describe
    /// a tenth of the drive, and `--max-lost` (which counts frames, not updates) cannot see it. A
    /// snapshot that scores each track once is not refused.
    pub fn stuck_timestamps(&self, duplicates: u64, scored: u64) -> Option<String> {
        let (line, t_us) = self.first_frame?;
        let advice = "the bridge needs each frame's receive time (what candump -L writes): was the log converted or written without real timestamps?";
        if self.frames >= 2 && !self.timestamps_advance && duplicates > 0 {
            return Some(format!(
                "the timestamps do not advance: all {} frames, from line {line} on, are stamped {}.{:06}, so {duplicates} track updates were dropped as second updates at the same time ({scored} scored); {advice}",
                self.frames,
                t_us / 1_000_000,
                t_us % 1_000_000
            ));
        }
        // At least a few: one repeated line beside one scored update is a glitch, not a clock.
        (duplicates > scored && duplicates >= COARSE_MIN_DUPLICATES).then(|| {
            let updates = duplicates + scored;
            format!(
                "the timestamps are too coarse to order the track updates: {duplicates} of {updates} ({:.0} %) were dropped as second updates of a track at the same timestamp, {scored} scored (were the times truncated, e.g. to whole seconds?); {advice}",
                100.0 * duplicates as f64 / updates as f64
            )
        })
    }

    fn push_bad(&mut self, line: usize, problem: LineProblem) {
        let n = self.bad_by_kind.entry(problem.kind()).or_insert(0);
        *n += 1;
        if *n <= KEPT_PER_KIND {
            self.bad.push(BadLine { line, problem });
        }
    }

    /// Prints the kept bad lines as `FILE:LINE: reason` on stderr (`<stdin>:LINE:` for `-`,
    /// [`line_name`]), then one count per kind of the lines not printed.
    pub fn print_bad_lines(&self, path: &Path) {
        let name = line_name(path);
        for b in &self.bad {
            eprintln!("{name}:{}: {}", b.line, b.problem);
        }
        for (kind, n) in &self.bad_by_kind {
            if *n > KEPT_PER_KIND {
                eprintln!(
                    "{name}: ... {} more lines skipped ({kind})",
                    n - KEPT_PER_KIND
                );
            }
        }
    }
}

fn position_of_newline(bytes: &[u8]) -> Option<usize> {
    bytes.iter().position(|b| *b == b'\n')
}

/// Calls `f(line_number, text)` for every line of `reader` that is UTF-8 and within the length
/// cap (line break and a trailing `\r` removed); records the others in `report`.
pub fn for_each_line<R: BufRead>(
    mut reader: R,
    report: &mut LogReport,
    mut f: impl FnMut(usize, &str, &mut LogReport),
) -> std::io::Result<()> {
    let mut long: Vec<u8> = Vec::new();
    loop {
        let avail = reader.fill_buf()?;
        if avail.is_empty() {
            break;
        }
        // Fast path: the whole line is in the buffer.
        if let Some(i) = position_of_newline(avail) {
            if long.is_empty() {
                report.lines += 1;
                let line_no = report.lines;
                handle(&avail[..i], line_no, report, &mut f);
                reader.consume(i + 1);
                continue;
            }
        }
        // Slow path: the line spans buffer refills; keep at most MAX_LINE_BYTES + 1 of it.
        let (chunk, end) = match position_of_newline(avail) {
            Some(i) => (&avail[..i], Some(i + 1)),
            None => (avail, None),
        };
        let mut total = long.len() as u64;
        let room = (MAX_LINE_BYTES + 1).saturating_sub(long.len());
        long.extend_from_slice(&chunk[..chunk.len().min(room)]);
        total += chunk.len() as u64;
        let consumed = end.unwrap_or(avail.len());
        reader.consume(consumed);
        let skipped = total.max(long.len() as u64);
        if end.is_none() {
            // Remember how much of an over-long line went by without storing it.
            if total > MAX_LINE_BYTES as u64 {
                skip_rest_of_line(&mut reader, report, total)?;
                long.clear();
            }
            continue;
        }
        report.lines += 1;
        let line_no = report.lines;
        if skipped > MAX_LINE_BYTES as u64 {
            report.push_bad(line_no, LineProblem::TooLong { bytes: skipped });
        } else {
            handle(&long, line_no, report, &mut f);
        }
        long.clear();
    }
    if !long.is_empty() {
        report.lines += 1;
        let line_no = report.lines;
        handle(&long, line_no, report, &mut f);
    }
    Ok(())
}

/// Consumes the rest of a line already `seen` bytes long, records it as too long, or refuses the
/// input when no line break comes within [`MAX_SKIP_BYTES`].
fn skip_rest_of_line<R: BufRead>(
    reader: &mut R,
    report: &mut LogReport,
    mut seen: u64,
) -> std::io::Result<()> {
    loop {
        let avail = reader.fill_buf()?;
        if avail.is_empty() {
            break;
        }
        let (n, done) = match position_of_newline(avail) {
            Some(i) => (i, true),
            None => (avail.len(), false),
        };
        seen += n as u64;
        reader.consume(n + usize::from(done));
        if done {
            break;
        }
        if seen > MAX_SKIP_BYTES {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "line {}: no line break in {} MiB: not a text log",
                    report.lines + 1,
                    MAX_SKIP_BYTES >> 20
                ),
            ));
        }
    }
    report.lines += 1;
    let line_no = report.lines;
    report.push_bad(line_no, LineProblem::TooLong { bytes: seen });
    Ok(())
}

fn handle(
    bytes: &[u8],
    line_no: usize,
    report: &mut LogReport,
    f: &mut impl FnMut(usize, &str, &mut LogReport),
) {
    let bytes = bytes.strip_suffix(b"\r").unwrap_or(bytes);
    if bytes.len() > MAX_LINE_BYTES {
        report.push_bad(
            line_no,
            LineProblem::TooLong {
                bytes: bytes.len() as u64,
            },
        );
        return;
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => f(line_no, text, report),
        Err(e) => report.push_bad(
            line_no,
            LineProblem::NotUtf8 {
                column: e.valid_up_to(),
            },
        ),
    }
}

/// Calls `f(line_number, record)` for every frame line of `reader`.
pub fn for_each_frame_in<R: BufRead>(
    reader: R,
    mut f: impl FnMut(usize, &LogRecord<'_>),
) -> std::io::Result<LogReport> {
    let mut report = LogReport::default();
    for_each_line(reader, &mut report, |line_no, line, report| {
        if line.trim().is_empty() {
            report.blank += 1;
            return;
        }
        match parse_line(line) {
            Ok(rec) => {
                report.frames += 1;
                match report.first_frame {
                    None => report.first_frame = Some((line_no, rec.timestamp_us)),
                    Some((_, t)) => report.timestamps_advance |= rec.timestamp_us != t,
                }
                f(line_no, &rec);
            }
            Err(error) => report.push_bad(line_no, LineProblem::NotFrame(error)),
        }
    })?;
    Ok(report)
}

/// Buffer of a log reader: whole candump lines per refill, also from a pipe.
const READ_BUFFER: usize = 1 << 20;

/// Opens the log a `--log PATH` names: standard input for `-` (as riskctl reads `-`, so
/// `riskctl events-to-candump --out - | can-bridge score-log --log -` works), the file otherwise.
/// Every command that reads a log opens it here and reads it once, front to back: standard input
/// cannot be read a second time, so none of them makes two passes over the log.
pub fn open(path: &Path) -> std::io::Result<Box<dyn BufRead>> {
    if crate::cli_values::is_std_stream(path) {
        let stdin = std::io::stdin().lock();
        return Ok(Box::new(std::io::BufReader::with_capacity(
            READ_BUFFER,
            stdin,
        )));
    }
    let file = std::fs::File::open(path)?;
    Ok(Box::new(std::io::BufReader::with_capacity(
        READ_BUFFER,
        file,
    )))
}

/// The log at `path` where a message names a line of it (`FILE:LINE: reason`): `<stdin>` for
/// `-` (as riskctl names standard input), the path otherwise.
pub fn line_name(path: &Path) -> String {
    if crate::cli_values::is_std_stream(path) {
        "<stdin>".to_string()
    } else {
        path.display().to_string()
    }
}

/// The log at `path` as a sentence names it: `standard input (--log -)` for `-`, the path
/// otherwise.
pub fn describe(path: &Path) -> String {
    if crate::cli_values::is_std_stream(path) {
        "standard input (--log -)".to_string()
    } else {
        path.display().to_string()
    }
}

/// Calls `f(line_number, record)` for every frame line of the log at `path` ([`open`]: `-` is
/// standard input).
pub fn for_each_frame(
    path: &Path,
    f: impl FnMut(usize, &LogRecord<'_>),
) -> std::io::Result<LogReport> {
    for_each_frame_in(open(path)?, f)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(bytes: &[u8], cap: usize) -> (LogReport, Vec<usize>) {
        let mut seen = Vec::new();
        let r = std::io::BufReader::with_capacity(cap, bytes);
        let rep = for_each_frame_in(r, |n, _| seen.push(n)).unwrap();
        (rep, seen)
    }

    #[test]
    fn bad_bytes_and_long_lines_cost_one_line_each_at_any_buffer_size() {
        let mut log = Vec::new();
        log.extend_from_slice(b"(1.000000) can0 123#00\n");
        log.extend_from_slice(b"(1.000001) can0 123#00 \xff\xfe\n");
        log.extend_from_slice(b"(1.000002) can0 123#00\r\n");
        log.extend(std::iter::repeat_n(b'A', MAX_LINE_BYTES + 10));
        log.push(b'\n');
        log.extend_from_slice(b"\n(1.000003) can0 123#01");
        for cap in [8, 64, 5000, 1 << 20] {
            let (rep, seen) = read(&log, cap);
            assert_eq!(seen, vec![1, 3, 6], "buffer {cap}");
            assert_eq!(rep.lines, 6);
            assert_eq!(rep.blank, 1);
            assert_eq!(rep.bad_by_kind["not UTF-8"], 1);
            assert_eq!(rep.bad_by_kind["line too long"], 1);
            assert_eq!(rep.bad[0].line, 2);
            assert_eq!(
                rep.bad[1].problem,
                LineProblem::TooLong {
                    bytes: MAX_LINE_BYTES as u64 + 10
                }
            );
        }
    }

    #[test]
    fn bad_lines_are_kept_per_kind_and_counted() {
        let mut log = String::new();
        for _ in 0..1000 {
            log.push_str("garbage\n");
        }
        log.push_str("(1.0) c 123###00\n");
        let (rep, _) = read(log.as_bytes(), 1 << 16);
        assert_eq!(rep.bad_lines(), 1001);
        assert_eq!(rep.bad.len(), KEPT_PER_KIND + 1);
        assert_eq!(rep.bad.last().unwrap().line, 1001);
    }

    #[test]
    fn a_log_whose_timestamps_never_advance_is_named_with_its_first_frame_line() {
        let log = b"\n(1700000000.250000) can0 123#00\n(1700000000.250000) can0 123#01\n";
        let (rep, _) = read(log, 1 << 16);
        assert_eq!(rep.first_frame, Some((2, 1_700_000_000_250_000)));
        assert!(!rep.timestamps_advance);
        let m = rep.stuck_timestamps(1, 1).unwrap();
        assert!(
            m.contains("all 2 frames, from line 2 on, are stamped 1700000000.250000"),
            "{m}"
        );
        assert_eq!(rep.stuck_timestamps(0, 1), None);
        let (rep, _) = read(b"(1.0) can0 123#00\n(1.000001) can0 123#00\n", 1 << 16);
        assert!(rep.timestamps_advance);
        assert_eq!(rep.stuck_timestamps(1, 5), None);
        assert_eq!(rep.stuck_timestamps(3, 3), None);
        assert_eq!(rep.stuck_timestamps(2, 1), None);
        assert!(rep.stuck_timestamps(10, 9).is_some());
    }

    #[test]
    fn a_log_whose_updates_are_mostly_same_time_duplicates_is_refused() {
        // Timestamps truncated to whole seconds: they advance, but 1865 of 2092 updates were
        // dropped as duplicates; before, this was exit 0, even with --max-lost 0.
        let (rep, _) = read(b"(1.0) can0 123#00\n(2.0) can0 123#00\n", 1 << 16);
        assert!(rep.timestamps_advance);
        let m = rep.stuck_timestamps(1865, 227).unwrap();
        assert!(
            m.starts_with("the timestamps are too coarse to order the track updates: 1865 of 2092 (89 %) were dropped"),
            "{m}"
        );
    }

    #[test]
    fn endless_line_is_refused_with_bounded_memory() {
        let zeros = std::io::Read::take(std::io::repeat(0), MAX_SKIP_BYTES + 4096);
        let err = for_each_frame_in(std::io::BufReader::new(zeros), |_, _| {}).unwrap_err();
        assert!(err.to_string().contains("line 1: no line break"), "{err}");
    }
}
