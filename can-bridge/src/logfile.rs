//! Reading candump `-L` logs line by line, with every unusable line reported by its number.
use can_codec::{parse_line, LineError, LogRecord};
use std::io::BufRead;
use std::path::Path;

/// A line that is not a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct BadLine {
    pub line: usize,
    pub error: LineError,
}

/// Counts of what a log held.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LogReport {
    pub lines: usize,
    pub frames: usize,
    /// Blank lines (ignored).
    pub blank: usize,
    /// Every bad line, in order (the caller decides how many to print).
    pub bad: Vec<BadLine>,
}

impl LogReport {
    /// Prints up to `limit` bad lines as `FILE:LINE: reason` on stderr.
    pub fn print_bad_lines(&self, path: &Path, limit: usize) {
        for b in self.bad.iter().take(limit) {
            eprintln!(
                "{}:{}: not a candump -L frame line: {}",
                path.display(),
                b.line,
                b.error
            );
        }
        if self.bad.len() > limit {
            eprintln!(
                "{}: ... {} more lines that are not frames",
                path.display(),
                self.bad.len() - limit
            );
        }
    }
}

/// Calls `f(line_number, record)` for every frame line of the log at `path`.
pub fn for_each_frame(
    path: &Path,
    mut f: impl FnMut(usize, &LogRecord<'_>),
) -> std::io::Result<LogReport> {
    let file = std::fs::File::open(path)?;
    let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
    let mut report = LogReport::default();
    let mut buf = String::with_capacity(128);
    loop {
        buf.clear();
        if reader.read_line(&mut buf)? == 0 {
            break;
        }
        report.lines += 1;
        let line = buf.trim_end_matches(['\n', '\r']);
        if line.trim().is_empty() {
            report.blank += 1;
            continue;
        }
        match parse_line(line) {
            Ok(rec) => {
                report.frames += 1;
                f(report.lines, &rec);
            }
            Err(error) => report.bad.push(BadLine {
                line: report.lines,
                error,
            }),
        }
    }
    Ok(report)
}
