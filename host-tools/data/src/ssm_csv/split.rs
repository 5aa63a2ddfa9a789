//! Cutting a CSV byte stream into chunks of whole records, with physical line numbers and a cap on
//! the length of one record, so that the records of a chunk can be parsed on any thread.
//!
//! Record boundaries follow the `csv` crate's reader: a record ends at a line feed outside a quoted
//! field; a quote opens a quoted field only at the start of a field; inside one, `""` is a quote
//! and line breaks belong to the field. Two things the `csv` reader does not do:
//!
//! - **Length cap.** A record longer than the limit (bytes, without its line feed) is reported as
//!   [`SplitProblem::TooLong`] and skipped up to the next line feed, without being held in memory:
//!   `/dev/zero` as input reports one over-long line and reads on in constant memory.
//! - **Unterminated quote.** A quoted field that is still open at the end of the input, or after
//!   the limit, is reported as [`SplitProblem::UnterminatedQuote`] on the line where its record
//!   starts; reading resumes on the next physical line, so only that line is lost.
//!
//! Line numbers count every line feed before the record (blank lines included), starting at 1.
//! A lone carriage return is not a line break here (the `csv` reader ends a record there; the
//! record parser downstream still does, so such a file parses as before, with each record of a
//! line reported under that line's number).

use std::io::{self, Read};

/// Default cap on the length of one record (header or row), in bytes: 1 MiB.
pub const DEFAULT_MAX_RECORD_BYTES: usize = 1 << 20;

/// Why a line produced no record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SplitProblem {
    /// The record is longer than the limit; it was skipped up to the next line feed.
    TooLong { limit: usize },
    /// A quoted field was not closed before the end of the input or within the limit.
    UnterminatedQuote { limit: usize },
}

impl SplitProblem {
    /// What is wrong, without what the reader does about it (for a header, which ends the run).
    pub fn what(&self) -> String {
        match self {
            SplitProblem::TooLong { limit } => format!("line longer than {limit} bytes"),
            SplitProblem::UnterminatedQuote { limit } => {
                format!("quoted field not closed (by the end of the input or within {limit} bytes)")
            }
        }
    }
}

impl std::fmt::Display for SplitProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SplitProblem::TooLong { limit } => {
                write!(
                    f,
                    "line longer than {limit} bytes (skipped to the next line)"
                )
            }
            SplitProblem::UnterminatedQuote { limit } => write!(
                f,
                "quoted field not closed (by the end of the input or within {limit} bytes); \
                 reading resumes on the next line"
            ),
        }
    }
}

/// One item of a chunk, in input order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Piece {
    /// `data[start..end]` is one record including its line feed; it starts on line `line`.
    Record { start: usize, end: usize, line: u64 },
    /// Line `line` produced no record.
    Problem { line: u64, problem: SplitProblem },
}

/// A run of whole records.
#[derive(Debug, Default)]
pub struct Chunk {
    /// The bytes of the records; every record ends with a line feed (one is added to a last line
    /// that lacks it).
    pub data: Vec<u8>,
    pub pieces: Vec<Piece>,
}

/// How far the scan of a record got.
enum Scan {
    /// The record ends just before this offset (after its line feed); `lines` is how many line
    /// feeds it holds (more than one only inside quotes).
    End { end: usize, lines: u64 },
    /// No line feed ends the record yet; `quoted` says whether a quoted field is open.
    Open { quoted: bool },
}

#[derive(Clone, Copy)]
enum State {
    FieldStart,
    InField,
    InQuoted,
    QuoteInQuoted,
}

/// Scan one record from the start of `bytes`.
fn scan_record(bytes: &[u8]) -> Scan {
    // Fast path: no quote before the line feed (nearly every numeric row).
    match memchr::memchr2(b'\n', b'"', bytes) {
        None => return Scan::Open { quoted: false },
        Some(k) if bytes[k] == b'\n' => {
            return Scan::End {
                end: k + 1,
                lines: 1,
            }
        }
        Some(_) => {}
    }
    let mut state = State::FieldStart;
    for (k, &b) in bytes.iter().enumerate() {
        state = match (state, b) {
            (State::InQuoted, b'"') => State::QuoteInQuoted,
            (State::InQuoted, _) => State::InQuoted,
            (_, b'\n') => {
                let lines = newlines(&bytes[..=k]);
                return Scan::End { end: k + 1, lines };
            }
            (_, b'\r') | (_, b',') => State::FieldStart,
            (State::FieldStart, b'"') | (State::QuoteInQuoted, b'"') => State::InQuoted,
            _ => State::InField,
        };
    }
    Scan::Open {
        quoted: matches!(state, State::InQuoted),
    }
}

/// Reads an input and hands it out as [`Chunk`]s of about `chunk_bytes` each.
pub struct Splitter<R> {
    input: R,
    /// Bytes read but not yet handed out: the start of an incomplete record.
    pending: Vec<u8>,
    /// Line number of `pending[0]`.
    line: u64,
    eof: bool,
    max_record: usize,
    chunk_bytes: usize,
    /// `pending` starts inside an over-long line already reported: drop it up to its line feed.
    skip_pending_line: bool,
}

impl<R: Read> Splitter<R> {
    pub fn new(input: R, chunk_bytes: usize, max_record: usize) -> Self {
        Self {
            input,
            pending: Vec::new(),
            line: 1,
            eof: false,
            max_record: max_record.max(1),
            chunk_bytes: chunk_bytes.max(1),
            skip_pending_line: false,
        }
    }

    /// Read until `buf` holds at least `want` bytes or the input ends. Through `read_to_end`,
    /// which reads into the spare capacity of a reused buffer without zeroing it first (a
    /// `File` fills uninitialised memory), unlike growing the buffer with zeros to read into.
    fn fill(&mut self, buf: &mut Vec<u8>, want: usize) -> io::Result<()> {
        while !self.eof && buf.len() < want {
            let grow = (want - buf.len()).max(64 * 1024);
            buf.reserve(grow);
            let n = (&mut self.input).take(grow as u64).read_to_end(buf)?;
            // `take` stops at `grow` bytes; fewer means the input ended.
            if n < grow {
                self.eof = true;
            }
        }
        Ok(())
    }

    /// Discard input up to and including the next line feed (an over-long line), reading in
    /// fixed-size blocks so memory stays constant however long the line is.
    fn skip_line(&mut self, mut rest: Vec<u8>) -> io::Result<()> {
        loop {
            if let Some(k) = memchr::memchr(b'\n', &rest) {
                self.pending = rest.split_off(k + 1);
                return Ok(());
            }
            if self.eof {
                self.pending.clear();
                return Ok(());
            }
            rest.clear();
            self.fill(&mut rest, 64 * 1024)?;
        }
    }

    /// The next chunk, `None` at the end of the input. `recycled` is an emptied chunk whose
    /// buffers are reused.
    pub fn next_chunk(&mut self, mut recycled: Chunk) -> io::Result<Option<Chunk>> {
        if std::mem::take(&mut self.skip_pending_line) {
            let rest = std::mem::take(&mut self.pending);
            self.skip_line(rest)?;
        }
        let mut data = std::mem::take(&mut recycled.data);
        let mut pieces = std::mem::take(&mut recycled.pieces);
        data.clear();
        pieces.clear();
        data.append(&mut self.pending);
        let mut pos = 0usize;
        let mut want = self.chunk_bytes;
        loop {
            self.fill(&mut data, want)?;
            // Whole records.
            while pos < data.len() {
                match scan_record(&data[pos..]) {
                    Scan::End { end: n, lines } => {
                        let end = pos + n;
                        if n - 1 > self.max_record {
                            pieces.push(Piece::Problem {
                                line: self.line,
                                problem: SplitProblem::TooLong {
                                    limit: self.max_record,
                                },
                            });
                        } else {
                            pieces.push(Piece::Record {
                                start: pos,
                                end,
                                line: self.line,
                            });
                        }
                        self.line += lines;
                        pos = end;
                        if pos >= self.chunk_bytes {
                            break;
                        }
                    }
                    Scan::Open { quoted } => {
                        let open = data.len() - pos;
                        if !self.eof && open <= self.max_record {
                            break; // need more input
                        }
                        // End of input, or the record is over the limit without an end.
                        if quoted && (self.eof || memchr::memchr(b'\n', &data[pos..]).is_some()) {
                            pieces.push(Piece::Problem {
                                line: self.line,
                                problem: SplitProblem::UnterminatedQuote {
                                    limit: self.max_record,
                                },
                            });
                            // Resume on the line after the record's first line.
                            match memchr::memchr(b'\n', &data[pos..]) {
                                Some(k) => {
                                    data.drain(pos..pos + k + 1);
                                    self.line += 1;
                                }
                                None => data.truncate(pos),
                            }
                            continue;
                        }
                        if self.eof {
                            // A last line without a line feed: give it one.
                            if open > self.max_record {
                                pieces.push(Piece::Problem {
                                    line: self.line,
                                    problem: SplitProblem::TooLong {
                                        limit: self.max_record,
                                    },
                                });
                                data.truncate(pos);
                            } else {
                                data.push(b'\n');
                                pieces.push(Piece::Record {
                                    start: pos,
                                    end: data.len(),
                                    line: self.line,
                                });
                                pos = data.len();
                            }
                            continue;
                        }
                        // Over-long unquoted line: reported now, with the records before it (a
                        // header that long ends the run at once, even on an input that never
                        // has a line feed, like /dev/zero), and dropped without being held at
                        // the next call.
                        pieces.push(Piece::Problem {
                            line: self.line,
                            problem: SplitProblem::TooLong {
                                limit: self.max_record,
                            },
                        });
                        self.pending = data.split_off(pos);
                        self.skip_pending_line = true;
                        self.line += 1;
                        return Ok(Some(Chunk { data, pieces }));
                    }
                }
            }
            if pos >= self.chunk_bytes || self.eof || !pieces.is_empty() {
                break;
            }
            // Not one complete record yet: read more (bounded by the record cap).
            want = data.len() + self.chunk_bytes;
        }
        self.pending = data.split_off(pos);
        if data.is_empty() && pieces.is_empty() {
            return Ok(None);
        }
        Ok(Some(Chunk { data, pieces }))
    }
}

fn newlines(bytes: &[u8]) -> u64 {
    memchr::memchr_iter(b'\n', bytes).count() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn split_all(
        input: &[u8],
        chunk: usize,
        max: usize,
    ) -> Vec<(u64, Result<String, SplitProblem>)> {
        let mut s = Splitter::new(input, chunk, max);
        let mut out = Vec::new();
        while let Some(c) = s.next_chunk(Chunk::default()).unwrap() {
            for p in &c.pieces {
                out.push(match p {
                    Piece::Record { start, end, line } => (
                        *line,
                        Ok(String::from_utf8_lossy(&c.data[*start..*end]).into_owned()),
                    ),
                    Piece::Problem { line, problem } => (*line, Err(*problem)),
                });
            }
        }
        out
    }

    #[test]
    fn records_and_line_numbers_do_not_depend_on_chunk_size() {
        let input = b"h1,h2\n\na,\"b\nc\"\nx,y\n\"q\"\"\",z\nlast";
        let expected = vec![
            (1, Ok("h1,h2\n".to_string())),
            (2, Ok("\n".to_string())),
            (3, Ok("a,\"b\nc\"\n".to_string())),
            (5, Ok("x,y\n".to_string())),
            (6, Ok("\"q\"\"\",z\n".to_string())),
            (7, Ok("last\n".to_string())),
        ];
        for chunk in [1, 2, 3, 7, 64, 4096] {
            assert_eq!(split_all(input, chunk, 1000), expected, "chunk {chunk}");
        }
    }

    #[test]
    fn quote_inside_an_unquoted_field_is_literal() {
        let got = split_all(b"a\"b,c\nd\n", 4, 100);
        assert_eq!(got.len(), 2);
        assert_eq!(got[1], (2, Ok("d\n".to_string())));
    }

    #[test]
    fn unterminated_quote_costs_one_line() {
        let input = b"h\nok1\nbad,\"open\nok2\nok3\n";
        for chunk in [1, 5, 100] {
            let got = split_all(input, chunk, 1000);
            assert_eq!(
                got,
                vec![
                    (1, Ok("h\n".into())),
                    (2, Ok("ok1\n".into())),
                    (3, Err(SplitProblem::UnterminatedQuote { limit: 1000 })),
                    (4, Ok("ok2\n".into())),
                    (5, Ok("ok3\n".into())),
                ],
                "chunk {chunk}"
            );
        }
        // Also when the quote stays open beyond the limit in a long file.
        let mut long = b"h\nbad,\"open\n".to_vec();
        for _ in 0..100 {
            long.extend_from_slice(b"row\n");
        }
        let got = split_all(&long, 16, 64);
        assert_eq!(
            got[1],
            (2, Err(SplitProblem::UnterminatedQuote { limit: 64 }))
        );
        assert_eq!(got[2], (3, Ok("row\n".into())));
        assert_eq!(got.len(), 102);
    }

    #[test]
    fn over_long_lines_are_skipped_in_constant_memory() {
        let mut input = b"h\n".to_vec();
        input.extend(std::iter::repeat_n(b'7', 10_000));
        input.extend_from_slice(b"\nnext\n");
        input.extend(std::iter::repeat_n(b'8', 500));
        for chunk in [3, 100, 100_000] {
            let got = split_all(&input, chunk, 256);
            assert_eq!(
                got,
                vec![
                    (1, Ok("h\n".into())),
                    (2, Err(SplitProblem::TooLong { limit: 256 })),
                    (3, Ok("next\n".into())),
                    (4, Err(SplitProblem::TooLong { limit: 256 })),
                ],
                "chunk {chunk}"
            );
        }
    }

    /// The first chunk of `s`: only the report of an over-long line 1 (limit 64 KiB).
    fn first_chunk_is_one_too_long_line<R: Read>(s: &mut Splitter<R>) -> Chunk {
        let chunk = s.next_chunk(Chunk::default()).unwrap().unwrap();
        assert_eq!(
            chunk.pieces,
            vec![Piece::Problem {
                line: 1,
                problem: SplitProblem::TooLong { limit: 1 << 16 }
            }]
        );
        chunk
    }

    #[test]
    fn endless_line_reports_once_and_keeps_memory_bounded() {
        // An endless input without line feeds (like /dev/zero), cut off after 64 MiB.
        let endless = std::io::repeat(0).take(64 << 20);
        let mut s = Splitter::new(endless, 1 << 16, 1 << 16);
        let chunk = first_chunk_is_one_too_long_line(&mut s);
        assert!(chunk.data.capacity() < 1 << 20);
        assert!(s.next_chunk(Chunk::default()).unwrap().is_none());
    }

    #[test]
    fn an_endless_line_is_reported_before_its_end_is_read() {
        // Counts the bytes handed out: the report must not wait for a line feed that never comes.
        struct Counted(u64);
        impl Read for Counted {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                buf.fill(b'x');
                self.0 += buf.len() as u64;
                Ok(buf.len())
            }
        }
        let mut s = Splitter::new(Counted(0), 1 << 16, 1 << 16);
        first_chunk_is_one_too_long_line(&mut s);
        assert!(s.input.0 < 1 << 20, "read {} bytes", s.input.0);
    }
}
