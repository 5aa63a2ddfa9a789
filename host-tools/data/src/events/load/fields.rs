//! Reading the CSV tables: opening a file, finding the required columns, one record at a time, and
//! parsing its fields into numbers and headings with one issue per bad field.
use std::borrow::Cow;
use std::fs::File;
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::Path;

use super::issues::{EventsError, IssueProblem, LoadIssue, HEADING_TOLERANCE};

/// How a file ends its lines, which the record line numbers depend on (see [`record_line`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineEnds {
    /// The first line ends with `\r\n` (a Windows file).
    crlf: bool,
}

pub(crate) fn open(path: &Path) -> Result<(csv::Reader<BufReader<File>>, LineEnds), EventsError> {
    let io = |source| EventsError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(io)?;
    let mut buf = BufReader::with_capacity(1 << 20, file);
    let head = buf.fill_buf().map_err(io)?;
    // UTF-16 (Excel's "Unicode Text", Windows tools) reads as invalid UTF-8 in field 0 of line
    // 1; its byte-order mark says what it is.
    if head.starts_with(&[0xFF, 0xFE]) || head.starts_with(&[0xFE, 0xFF]) {
        return Err(io(std::io::Error::other(
            "the file is UTF-16 (it starts with a UTF-16 byte-order mark, as Excel's \
             \"Unicode Text\" writes); event folders are UTF-8 CSV: save it as \"CSV UTF-8\" \
             or convert it (iconv -f UTF-16 -t UTF-8)",
        )));
    }
    let crlf = memchr::memchr(b'\n', head).is_some_and(|i| i > 0 && head[i - 1] == b'\r');
    let rdr = csv::ReaderBuilder::new()
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(buf);
    Ok((rdr, LineEnds { crlf }))
}

/// The 1-based line of a record the CSV reader read from `start` to `end`. The reader's own
/// record position is taken before it skips the line end left by the previous record (the `\n`
/// of a `\r\n`, where it stopped at the `\r`) and blank lines, so it was short on every row of
/// a Windows file and on a row right after blank lines. At `end` the reader has counted every line
/// end up to the record's own: on a `\r\n` line that is the `\r` (the `\n` is not counted yet),
/// on a `\n` line the `\n` (one line further), at the end of a file without a final newline none.
fn record_line(start: &csv::Position, end: &csv::Position, ends: LineEnds) -> u64 {
    if ends.crlf {
        end.line()
    } else {
        start.line().max(end.line().saturating_sub(1))
    }
}

pub(super) fn column_map(
    path: &Path,
    rdr: &mut csv::Reader<BufReader<File>>,
    required: &[&'static str],
) -> Result<(Vec<usize>, csv::StringRecord), EventsError> {
    let headers = rdr
        .headers()
        .map_err(|source| EventsError::Csv {
            path: path.to_path_buf(),
            line: 1,
            source,
        })?
        .clone();
    if headers.iter().all(str::is_empty) {
        return Err(EventsError::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    let cols = required
        .iter()
        .map(|&name| {
            find_column(path, &headers, name)?.ok_or_else(|| EventsError::MissingColumn {
                path: path.to_path_buf(),
                column: name,
                hint: missing_column_hint(&headers, name),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((cols, headers))
}

/// The 0-based position of the optional column `name`, `None` when the header lacks it; like a
/// required column, twice is [`EventsError::DuplicateColumn`], and a column that is `name` in
/// other case is [`EventsError::MiscasedColumn`] (ignored as an extra column, it would silently
/// drop the data it holds).
pub(super) fn optional_column(
    path: &Path,
    headers: &csv::StringRecord,
    name: &'static str,
) -> Result<Option<usize>, EventsError> {
    let at = find_column(path, headers, name)?;
    if at.is_none() {
        if let Some(found) = headers.iter().find(|h| h.eq_ignore_ascii_case(name)) {
            return Err(EventsError::MiscasedColumn {
                path: path.to_path_buf(),
                column: name,
                found: found.to_string(),
            });
        }
    }
    Ok(at)
}

/// The 0-based position of the column spelled exactly `name`; two of them is an error.
fn find_column(
    path: &Path,
    headers: &csv::StringRecord,
    name: &'static str,
) -> Result<Option<usize>, EventsError> {
    let mut at = headers.iter().enumerate().filter(|(_, h)| *h == name);
    match (at.next(), at.next()) {
        (Some((first, _)), Some((second, _))) => Err(EventsError::DuplicateColumn {
            path: path.to_path_buf(),
            column: name,
            first: first + 1,
            second: second + 1,
        }),
        (first, _) => Ok(first.map(|(i, _)| i)),
    }
}

/// Why a header may lack `name`: a file separated by something else than commas (the header
/// is then one column), or the name in other case.
fn missing_column_hint(headers: &csv::StringRecord, name: &str) -> String {
    if let [one] = headers.iter().collect::<Vec<_>>()[..] {
        for (sep, what) in [(';', "semicolons"), ('\t', "tabs"), ('|', "`|`")] {
            if one.contains(sep) {
                let mut shown: String = one.chars().take(60).collect();
                if shown.len() < one.len() {
                    shown.push('…');
                }
                return format!(
                    " (the header is one column, `{shown}`: the file is separated by {what}; \
                     event folders are comma separated)"
                );
            }
        }
    }
    match headers.iter().find(|h| h.eq_ignore_ascii_case(name)) {
        Some(h) => format!(" (there is `{h}`: column names are lower case, spelled exactly)"),
        None => String::new(),
    }
}

/// Reads one record into `rec` and returns its 1-based line (the file's own numbering, on Windows
/// files and after blank lines too); `Ok(None)` at the end of the file. For CSV files beside the
/// event tables (an import's `scenarios.csv`) that report errors by line.
pub(crate) fn read_numbered_record<R: std::io::Read>(
    rdr: &mut csv::Reader<R>,
    rec: &mut csv::StringRecord,
    ends: LineEnds,
) -> csv::Result<Option<u64>> {
    let line = rdr.position().line();
    if !rdr.read_record(rec)? {
        return Ok(None);
    }
    Ok(Some(
        rec.position()
            .map_or(line, |p| record_line(p, rdr.position(), ends)),
    ))
}

/// Reads one record; `Ok(None)` at end of file, `Err(issue)` for a malformed row.
pub(super) fn next_record(
    path: &Path,
    rdr: &mut csv::Reader<BufReader<File>>,
    rec: &mut csv::ByteRecord,
    expected: usize,
    id_col: usize,
    ends: LineEnds,
) -> Result<Option<Result<u64, LoadIssue>>, EventsError> {
    let line = rdr.position().line();
    let mut read = rdr.read_byte_record(rec);
    // A row of empty fields (`,,,,`: what a spreadsheet saves for a row it shows blank) is a
    // blank line, as the reader already treats a truly empty one: no data, nothing to report.
    while matches!(read, Ok(true)) && rec.iter().all(<[u8]>::is_empty) {
        read = rdr.read_byte_record(rec);
    }
    match read {
        Ok(false) => Ok(None),
        Ok(true) => {
            let line = rec
                .position()
                .map_or(line, |p| record_line(p, rdr.position(), ends));
            // No field of an event folder spans lines: one that does was opened by a stray `"` and
            // swallowed the following lines (up to the next `"` or the end of the file).
            if let Some(broken) = rec.iter().position(|f| memchr::memchr(b'\n', f).is_some()) {
                let start = rec.position().cloned().unwrap_or_else(csv::Position::new);
                let (line, resume) = line_after(path, &start)?;
                rdr.seek(resume).map_err(|source| EventsError::Csv {
                    path: path.to_path_buf(),
                    line,
                    source,
                })?;
                // Fields before the broken one were read normally; the others cannot be trusted.
                let event_id = rec
                    .get(id_col)
                    .filter(|s| id_col < broken && !s.is_empty())
                    .map(|s| field_str(s).into_owned());
                return Ok(Some(Err(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: None,
                    event_id,
                    problem: IssueProblem::BadRow(
                        "unmatched `\"`: a quoted field starts on this line and does not end on it; \
                         the row is skipped and reading resumes on the next line"
                            .into(),
                    ),
                })));
            }
            if rec.len() != expected {
                Ok(Some(Err(LoadIssue {
                    file: path.to_path_buf(),
                    line,
                    column: None,
                    event_id: rec
                        .get(id_col)
                        .filter(|s| !s.is_empty())
                        .map(|s| field_str(s).into_owned()),
                    problem: IssueProblem::RowLength {
                        found: rec.len(),
                        expected,
                    },
                })))
            } else {
                Ok(Some(Ok(line)))
            }
        }
        Err(e) if matches!(e.kind(), csv::ErrorKind::Io(_)) => Err(EventsError::Csv {
            path: path.to_path_buf(),
            line,
            source: e,
        }),
        Err(e) => {
            let line = e.position().map_or(line, |p| p.line());
            Ok(Some(Err(LoadIssue {
                file: path.to_path_buf(),
                line,
                column: None,
                event_id: None,
                problem: IssueProblem::BadRow(e.to_string()),
            })))
        }
    }
}

/// [`IssueProblem::NoFinalNewline`] for a file that does not end with a line end, on its last
/// line (where `rdr`, at the end of the file, stopped). An empty file has no last line.
pub(super) fn no_final_newline(
    path: &Path,
    rdr: &csv::Reader<BufReader<File>>,
) -> Result<Option<LoadIssue>, EventsError> {
    let io = |source| EventsError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = File::open(path).map_err(io)?;
    let len = file.seek(SeekFrom::End(0)).map_err(io)?;
    if len == 0 {
        return Ok(None);
    }
    file.seek(SeekFrom::End(-1)).map_err(io)?;
    let mut last = [0u8; 1];
    std::io::Read::read_exact(&mut file, &mut last).map_err(io)?;
    if matches!(last[0], b'\n' | b'\r') {
        return Ok(None);
    }
    Ok(Some(LoadIssue {
        file: path.to_path_buf(),
        line: rdr.position().line(),
        column: None,
        event_id: None,
        problem: IssueProblem::NoFinalNewline,
    }))
}

/// The line of the record that starts at `start` and the position just after that line, read
/// from the file itself (the CSV reader has already consumed the lines after it).
fn line_after(path: &Path, start: &csv::Position) -> Result<(u64, csv::Position), EventsError> {
    let io = |source| EventsError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = BufReader::new(File::open(path).map_err(io)?);
    file.seek(SeekFrom::Start(start.byte())).map_err(io)?;
    // The record may start with the end of the previous line (`\n` of a CRLF) or blank lines.
    let (mut byte, mut line) = (start.byte(), start.line());
    loop {
        let buf = file.fill_buf().map_err(io)?;
        let skip = buf
            .iter()
            .take_while(|&&b| b == b'\r' || b == b'\n')
            .count();
        line += buf[..skip].iter().filter(|&&b| b == b'\n').count() as u64;
        byte += skip as u64;
        let more = skip == buf.len() && skip > 0;
        file.consume(skip);
        if !more {
            break;
        }
    }
    let mut text = Vec::new();
    let len = file.read_until(b'\n', &mut text).map_err(io)?;
    let mut resume = csv::Position::new();
    resume
        .set_byte(byte + len as u64)
        .set_line(line + u64::from(text.last() == Some(&b'\n')))
        .set_record(start.record() + 1);
    Ok((line, resume))
}

/// A field as text; invalid UTF-8 is shown with its bytes escaped (`\xff`), so it still names what
/// was in the file, and then fails to parse as a number.
pub(super) fn field_str(b: &[u8]) -> Cow<'_, str> {
    match std::str::from_utf8(b) {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(b.escape_ascii().to_string()),
    }
}

/// Field parser that records an issue per bad field.
pub(super) struct Fields<'a> {
    pub(super) path: &'a Path,
    pub(super) line: u64,
    pub(super) id: &'a str,
    pub(super) rec: &'a csv::ByteRecord,
    pub(super) cols: &'a [usize],
    pub(super) names: &'a [&'static str],
    pub(super) issues: Vec<LoadIssue>,
}

impl Fields<'_> {
    /// The field as text; invalid UTF-8 is escaped (`\xff`) and then fails to parse as a number.
    pub(super) fn raw(&self, i: usize) -> Cow<'_, str> {
        field_str(self.rec.get(self.cols[i]).unwrap_or(b""))
    }
    pub(super) fn push(&mut self, i: usize, problem: IssueProblem) {
        self.issues.push(LoadIssue {
            file: self.path.to_path_buf(),
            line: self.line,
            column: Some(self.names[i].to_owned()),
            event_id: Some(self.id.to_owned()),
            problem,
        });
    }
    /// The field as a finite number; anything else is an issue and reads as NaN.
    fn number<T: std::str::FromStr + Copy>(
        &mut self,
        i: usize,
        is_finite: fn(T) -> bool,
        nan: T,
    ) -> T {
        let s = self.raw(i);
        match s.parse::<T>() {
            Ok(v) if is_finite(v) => v,
            Ok(_) => {
                let s = s.into_owned();
                self.push(i, IssueProblem::NonFinite(s));
                nan
            }
            Err(_) => {
                let s = s.into_owned();
                self.push(i, IssueProblem::BadNumber(s));
                nan
            }
        }
    }
    pub(super) fn f64(&mut self, i: usize) -> f64 {
        self.number(i, f64::is_finite, f64::NAN)
    }
    pub(super) fn f32(&mut self, i: usize) -> f32 {
        self.number(i, f32::is_finite, f32::NAN)
    }
    /// A unit heading from columns `ix`, `iy`: normalised when within tolerance, else an issue.
    pub(super) fn heading(&mut self, ix: usize, iy: usize) -> (f32, f32) {
        let (hx, hy) = (self.f32(ix), self.f32(iy));
        if !(hx.is_finite() && hy.is_finite()) {
            return (hx, hy);
        }
        let norm = f64::from(hx).hypot(f64::from(hy));
        if (norm - 1.0).abs() > HEADING_TOLERANCE {
            self.push(ix, IssueProblem::HeadingNotUnit { norm });
            (f32::NAN, f32::NAN)
        } else if (norm - 1.0).abs() > 1e-5 {
            ((f64::from(hx) / norm) as f32, (f64::from(hy) / norm) as f32)
        } else {
            // Already unit to f32 precision: keep the exact values (write/load round-trips bit-exactly).
            (hx, hy)
        }
    }
}
