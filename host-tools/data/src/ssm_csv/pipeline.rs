//! The chunked, parallel `riskctl ssm` pipeline: read -> cut into chunks of whole records ->
//! (workers) parse, score, format -> write in input order.
//!
//! The calling thread reads, cuts and writes; `threads` workers parse, score and format. At most
//! `2 x threads + 2` chunks are in flight (read but not yet written), and their buffers are reused,
//! so memory is bounded by about that many chunks whatever the file size. Results are written in
//! chunk order, so the output is the same as a one-row-at-a-time run.
use super::field::push_field;
use super::split::{Chunk, Piece, Splitter, DEFAULT_MAX_RECORD_BYTES};
use super::{
    computed_values, F32Texts, LastEgo, PairColumns, RowError, RowFields, RowProblem, SsmError,
};
use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::sync::mpsc;
use std::sync::Mutex;

/// Bytes of input per chunk: large enough to amortise the hand-offs, small enough to keep both
/// workers busy on short files and memory low.
const CHUNK_BYTES: usize = 512 * 1024;

/// Options of one run.
#[derive(Debug, Clone, Copy)]
pub struct SsmOptions {
    /// Stop at the first bad row with [`SsmError::BadRow`] instead of skipping it.
    pub strict: bool,
    /// Longest accepted record (header or row) in bytes; a longer line is reported and skipped.
    pub max_record_bytes: usize,
    /// Worker threads; 0 = one per available core.
    pub threads: usize,
}

impl Default for SsmOptions {
    fn default() -> Self {
        Self {
            strict: false,
            max_record_bytes: DEFAULT_MAX_RECORD_BYTES,
            threads: 0,
        }
    }
}

/// Row counts of a finished run.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SsmSummary {
    pub rows_ok: u64,
    pub rows_bad: u64,
    /// Computed column names that the input already had (both copies are in the output: the
    /// input's, passed through, and the computed one after it).
    pub duplicated_columns: Vec<String>,
}

/// The unescaped fields of one record, parsed by `csv-core`.
#[derive(Default)]
pub struct FieldBuf {
    bytes: Vec<u8>,
    ends: Vec<usize>,
    used: usize,
    count: usize,
    /// `bytes` is the raw line, fields separated by one comma each (else: back to back).
    plain: bool,
}

impl RowFields for FieldBuf {
    fn field_count(&self) -> usize {
        self.count
    }
    fn field(&self, k: usize) -> Option<&[u8]> {
        if k >= self.count {
            return None;
        }
        let start = match k {
            0 => 0,
            _ => self.ends[k - 1] + usize::from(self.plain),
        };
        Some(&self.bytes[start..self.ends[k]])
    }
    fn plain_span(&self, first: usize, last: usize) -> Option<&[u8]> {
        if !self.plain || first > last || last >= self.count {
            return None;
        }
        let start = match first {
            0 => 0,
            _ => self.ends[first - 1] + 1,
        };
        Some(&self.bytes[start..self.ends[last]])
    }
}

impl FieldBuf {
    /// Fill from a line without quotes or carriage returns: its fields are exactly the pieces
    /// between commas (what `csv-core` makes of it, without its state machine).
    pub fn set_plain(&mut self, line: &[u8]) {
        self.bytes.clear();
        self.bytes.extend_from_slice(line);
        self.used = line.len();
        self.ends.clear();
        push_comma_offsets(line, &mut self.ends);
        self.ends.push(line.len());
        self.count = self.ends.len();
        self.plain = true;
    }

    pub fn is_blank(&self) -> bool {
        (0..self.count).all(|k| {
            let f = self.field(k).unwrap_or_default();
            // An ASCII character that is not white space settles it without decoding the field
            // (the usual row: its first field).
            !f.iter()
                .any(|&b| b.is_ascii() && !char::from(b).is_whitespace())
                && std::str::from_utf8(f).is_ok_and(|s| s.trim().is_empty())
        })
    }
}

/// Append the offset of every comma of `line` to `offsets`, in order. Eight bytes at a time: a
/// row has a comma every eight bytes or so, which makes a `memchr` call per comma cost more than
/// looking at every byte.
fn push_comma_offsets(line: &[u8], offsets: &mut Vec<usize>) {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    const COMMAS: u64 = 0x2c2c_2c2c_2c2c_2c2c;
    let mut words = line.chunks_exact(8);
    let mut base = 0;
    for word in &mut words {
        let mut bytes = [0u8; 8];
        bytes.copy_from_slice(word);
        let x = u64::from_le_bytes(bytes) ^ COMMAS;
        // The high bit of each byte that was a comma (now zero), and of no other byte: exact,
        // unlike the shorter has-zero-byte test, whose carries can mark a byte after a zero.
        let mut zeros = !(((x & LOW7) + LOW7) | x | LOW7);
        while zeros != 0 {
            offsets.push(base + (zeros.trailing_zeros() / 8) as usize);
            zeros &= zeros - 1;
        }
        base += 8;
    }
    for (k, &b) in words.remainder().iter().enumerate() {
        if b == b',' {
            offsets.push(base + k);
        }
    }
}

/// A `csv-core` reader for records that each end with a line feed.
pub fn record_reader() -> csv_core::Reader {
    let mut reader = csv_core::Reader::new();
    // Past the start of input: a byte-order mark is only stripped at the very start of a file,
    // which the header parse handles with a fresh reader.
    let _ = reader.read_record(b"\n", &mut [0u8; 1], &mut [0usize; 1]);
    reader
}

/// Parse the record(s) of `line_bytes` (normally one; a lone `\r` ends a record too, as in the
/// `csv` crate) and call `each` on every record.
pub fn for_each_record(
    reader: &mut csv_core::Reader,
    fields: &mut FieldBuf,
    mut input: &[u8],
    mut each: impl FnMut(&FieldBuf) -> bool,
) {
    use csv_core::ReadRecordResult as R;
    if fields.bytes.len() < input.len() {
        fields.bytes.resize(input.len().max(256), 0);
    }
    if fields.ends.len() < 64 {
        fields.ends.resize(64, 0);
    }
    fields.used = 0;
    fields.count = 0;
    fields.plain = false;
    let mut finishing = false;
    loop {
        let (result, nin, nout, nend) = reader.read_record(
            input,
            &mut fields.bytes[fields.used..],
            &mut fields.ends[fields.count..],
        );
        input = &input[nin..];
        fields.used += nout;
        fields.count += nend;
        match result {
            R::InputEmpty if fields.used == 0 && fields.count == 0 && !finishing => return,
            // The record did not end with the line (cannot happen with the splitter's
            // boundaries; if it does, end it here rather than let it run into the next line).
            R::InputEmpty => finishing = true,
            R::OutputFull => {
                let n = fields.bytes.len() * 2;
                fields.bytes.resize(n, 0);
            }
            R::OutputEndsFull => {
                let n = fields.ends.len() * 2;
                fields.ends.resize(n, 0);
            }
            R::Record => {
                if !each(fields) {
                    return;
                }
                fields.used = 0;
                fields.count = 0;
                if input.is_empty() {
                    if finishing {
                        *reader = record_reader();
                    }
                    return;
                }
            }
            R::End => {
                *reader = record_reader();
                return;
            }
        }
    }
}

/// What a worker made of one chunk.
struct Done {
    seq: u64,
    chunk: Chunk,
    out: Vec<u8>,
    bad: Vec<RowError>,
    rows_ok: u64,
    /// Strict mode: the chunk stopped at this bad row (rows before it are in `out`).
    stopped: bool,
}

struct Job {
    seq: u64,
    chunk: Chunk,
    out: Vec<u8>,
}

/// Parse, score and format every record of a chunk.
fn process_chunk(
    columns: &PairColumns,
    strict: bool,
    reader: &mut csv_core::Reader,
    fields: &mut FieldBuf,
    texts: &mut F32Texts,
    last_ego: &mut LastEgo,
    job: Job,
) -> Done {
    let Job {
        seq,
        chunk,
        mut out,
    } = job;
    out.clear();
    let mut bad = Vec::new();
    let mut rows_ok = 0u64;
    let mut stopped = false;
    let n_names = columns.names.len();
    // One look at the whole chunk instead of one per line: pair files rarely quote anything.
    let plain_chunk = memchr::memchr2(b'"', b'\r', &chunk.data).is_none();
    for piece in &chunk.pieces {
        match *piece {
            Piece::Problem { line, problem } => {
                bad.push(RowError {
                    line,
                    column: None,
                    problem: RowProblem::from(problem),
                });
                if strict {
                    stopped = true;
                }
            }
            Piece::Record { start, end, line } => {
                let record = &chunk.data[start..end];
                let line_body = &record[..record.len() - 1];
                let mut emit = |fields: &FieldBuf, raw: Option<&[u8]>| -> bool {
                    if fields.is_blank() {
                        return true;
                    }
                    match columns.parse_pair(fields, line, last_ego) {
                        Ok((ego, partner)) => {
                            match raw {
                                // No field needs quoting: the line is its own output.
                                Some(raw) => out.extend_from_slice(raw),
                                None => {
                                    for k in 0..fields.count {
                                        if k > 0 {
                                            out.push(b',');
                                        }
                                        push_field(&mut out, fields.field(k).unwrap_or_default());
                                    }
                                }
                            }
                            // Missing trailing pass-through columns are written empty.
                            out.extend(std::iter::repeat_n(
                                b',',
                                n_names.saturating_sub(fields.count),
                            ));
                            for v in computed_values(&ego, &partner) {
                                out.push(b',');
                                texts.push(&mut out, v);
                            }
                            out.push(b'\n');
                            rows_ok += 1;
                            true
                        }
                        Err(e) => {
                            bad.push(e);
                            stopped = strict;
                            !strict
                        }
                    }
                };
                if plain_chunk || memchr::memchr2(b'"', b'\r', line_body).is_none() {
                    fields.set_plain(line_body);
                    emit(fields, Some(line_body));
                } else {
                    for_each_record(reader, fields, record, |f| emit(f, None));
                }
            }
        }
        if stopped {
            break;
        }
    }
    Done {
        seq,
        chunk,
        out,
        bad,
        rows_ok,
        stopped,
    }
}

/// Find and parse the header: the first non-empty record. Returns the columns and the rest of the
/// chunk it was in.
pub fn read_header<R: Read>(
    splitter: &mut Splitter<R>,
) -> Result<(PairColumns, Option<Chunk>), SsmError> {
    loop {
        let Some(mut chunk) = splitter
            .next_chunk(Chunk::default())
            .map_err(SsmError::Read)?
        else {
            return Err(SsmError::EmptyInput);
        };
        for (k, piece) in chunk.pieces.iter().enumerate() {
            let (start, end) = match *piece {
                Piece::Problem { line, problem } => {
                    return Err(SsmError::BadHeader { line, problem })
                }
                Piece::Record { start, end, .. } => (start, end),
            };
            // A fresh reader strips a byte-order mark, like the csv crate at the start of a file.
            let mut reader = csv_core::Reader::new();
            let mut fields = FieldBuf::default();
            let mut names: Option<Vec<Vec<u8>>> = None;
            for_each_record(&mut reader, &mut fields, &chunk.data[start..end], |f| {
                names = Some(
                    (0..f.count)
                        .map(|i| f.field(i).unwrap_or_default().to_vec())
                        .collect(),
                );
                false
            });
            if let Some(names) = names {
                let columns = PairColumns::from_header_bytes(names)?;
                chunk.pieces.drain(..=k);
                let rest = (!chunk.pieces.is_empty()).then_some(chunk);
                return Ok((columns, rest));
            }
        }
    }
}

/// Stream `input` to `output`, calling `on_bad_row` for every skipped row, in input order.
///
/// The output is flushed before returning. In strict mode the first bad row is returned as
/// [`SsmError::BadRow`] (rows before it have been written).
pub fn score_csv<R: Read, W: Write>(
    input: R,
    mut output: W,
    options: SsmOptions,
    mut on_bad_row: impl FnMut(&RowError),
) -> Result<SsmSummary, SsmError> {
    let mut splitter = Splitter::new(input, CHUNK_BYTES, options.max_record_bytes);
    let (columns, first_rows) = read_header(&mut splitter)?;
    output.write_all(&columns.output_header_line())?;

    let mut summary = SsmSummary {
        duplicated_columns: columns.clashing_output_columns(),
        ..SsmSummary::default()
    };
    let threads = match options.threads {
        0 => std::thread::available_parallelism().map_or(2, |n| n.get()),
        n => n,
    };
    let max_in_flight = 2 * threads + 2;
    let strict = options.strict;

    let (job_tx, job_rx) = mpsc::channel::<Job>();
    let job_rx = Mutex::new(job_rx);
    let (done_tx, done_rx) = mpsc::channel::<Done>();
    std::thread::scope(|scope| -> Result<SsmSummary, SsmError> {
        for _ in 0..threads {
            let done_tx = done_tx.clone();
            let (job_rx, columns) = (&job_rx, &columns);
            scope.spawn(move || {
                let mut reader = record_reader();
                let mut fields = FieldBuf::default();
                let mut texts = F32Texts::default();
                let mut last_ego = LastEgo::default();
                loop {
                    // Hold the lock only to take a job, not while working on it.
                    let job = match job_rx.lock() {
                        Ok(rx) => rx.recv(),
                        Err(_) => return,
                    };
                    let Ok(job) = job else { return };
                    let done = process_chunk(
                        columns,
                        strict,
                        &mut reader,
                        &mut fields,
                        &mut texts,
                        &mut last_ego,
                        job,
                    );
                    if done_tx.send(done).is_err() {
                        return;
                    }
                }
            });
        }
        drop(done_tx);

        let mut job_tx = Some(job_tx);
        let mut pending = first_rows;
        let mut spare: Vec<(Chunk, Vec<u8>)> = Vec::new();
        let mut ready: BTreeMap<u64, Done> = BTreeMap::new();
        let (mut next_seq, mut next_write, mut in_flight) = (0u64, 0u64, 0usize);
        loop {
            // Write what is complete, in order.
            while let Some(done) = ready.remove(&next_write) {
                output.write_all(&done.out)?;
                summary.rows_ok += done.rows_ok;
                summary.rows_bad += done.bad.len() as u64;
                if done.stopped {
                    output.flush()?;
                    let first = done.bad.into_iter().next();
                    return Err(SsmError::BadRow(first.unwrap_or(RowError {
                        line: 0,
                        column: None,
                        problem: RowProblem::Missing,
                    })));
                }
                for e in &done.bad {
                    on_bad_row(e);
                }
                next_write += 1;
                in_flight -= 1;
                let mut chunk = done.chunk;
                chunk.data.clear();
                chunk.pieces.clear();
                spare.push((chunk, done.out));
            }
            // Keep the workers fed.
            if let Some(tx) = &job_tx {
                if in_flight < max_in_flight {
                    let (recycled, out) = spare.pop().unwrap_or_default();
                    let chunk = match pending.take() {
                        Some(c) => Some(c),
                        None => splitter.next_chunk(recycled).map_err(SsmError::Read)?,
                    };
                    match chunk {
                        Some(chunk) => {
                            let job = Job {
                                seq: next_seq,
                                chunk,
                                out,
                            };
                            if tx.send(job).is_err() {
                                break;
                            }
                            next_seq += 1;
                            in_flight += 1;
                        }
                        None => job_tx = None,
                    }
                    continue;
                }
            }
            if in_flight == 0 {
                break;
            }
            match done_rx.recv() {
                Ok(done) => {
                    ready.insert(done.seq, done);
                }
                Err(_) => break,
            }
        }
        output.flush()?;
        Ok(std::mem::take(&mut summary))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blank_record_is_white_space_in_every_field_unicode_included() {
        let mut fields = FieldBuf::default();
        for (line, blank) in [
            (&b""[..], true),
            (b" ,\t, \x0c", true),
            ("\u{3000},\u{a0} ".as_bytes(), true),
            (b" , x", false),
            ("\u{3000}x".as_bytes(), false),
            (b"\xff, ", false),
            (b"\x0b", true),
        ] {
            fields.set_plain(line);
            assert_eq!(fields.is_blank(), blank, "{line:?}");
        }
    }

    #[test]
    fn comma_offsets_are_those_of_a_byte_scan() {
        // Every byte value around commas and word boundaries, lines of 0..40 bytes.
        let mut s: u32 = 0x1234_5678;
        for len in 0..40 {
            for _ in 0..500 {
                let line: Vec<u8> = (0..len)
                    .map(|_| {
                        s ^= s << 13;
                        s ^= s >> 17;
                        s ^= s << 5;
                        match s % 4 {
                            0 => b',',
                            1 => b',' ^ (1 << ((s >> 8) % 8)),
                            _ => (s >> 16) as u8,
                        }
                    })
                    .collect();
                let mut fast = Vec::new();
                push_comma_offsets(&line, &mut fast);
                let slow: Vec<usize> = (0..line.len()).filter(|&k| line[k] == b',').collect();
                assert_eq!(fast, slow, "{line:?}");
            }
        }
    }
}
