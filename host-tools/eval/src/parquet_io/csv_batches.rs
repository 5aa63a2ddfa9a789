//! A pair CSV as Arrow batches: the 18 pair columns Float64 (the parsed values), every other
//! column Utf8 (its text). Rows that fail the CSV reader's checks are reported and left out.
use std::io::Read;
use std::sync::Arc;

use arrow_array::builder::{Float64Builder, StringBuilder};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, Schema};

use super::BATCH_ROWS;
use riskscore_data::ssm_csv::split::{Chunk, Piece, Splitter};
use riskscore_data::ssm_csv::{
    FieldBuf, LastEgo, PairColumns, RowError, RowFields, RowProblem, SsmError, SsmOptions,
};

/// The Arrow layout of a pair CSV, fixed by its header.
#[derive(Debug, Clone)]
pub struct CsvLayout {
    pub columns: PairColumns,
    pub schema: Arc<Schema>,
    /// Per CSV column: its index among the 18 pair columns (ego then partner), if it is one.
    pair: Vec<Option<usize>>,
}

impl CsvLayout {
    /// The layout of `columns`; a header name that is not UTF-8 cannot be an Arrow field name.
    pub fn new(columns: PairColumns) -> Result<Self, SsmError> {
        if let Some((column, name)) = columns.non_utf8_name() {
            return Err(SsmError::NonUtf8Name { column, name });
        }
        let pair: Vec<Option<usize>> = (0..columns.names.len())
            .map(|k| {
                columns
                    .ego
                    .iter()
                    .chain(&columns.partner)
                    .position(|&c| c == k)
            })
            .collect();
        let schema = Arc::new(Schema::new(
            columns
                .names
                .iter()
                .zip(&pair)
                .map(|(n, p)| {
                    let t = match p {
                        Some(_) => DataType::Float64,
                        None => DataType::Utf8,
                    };
                    Field::new(n, t, true)
                })
                .collect::<Vec<_>>(),
        ));
        Ok(Self {
            columns,
            schema,
            pair,
        })
    }
}

/// Arrow builders for the rows of one batch, filled chunk by chunk.
pub struct CsvRows {
    numbers: Vec<Float64Builder>,
    texts: Vec<StringBuilder>,
    rows: usize,
    reader: csv_core::Reader,
    fields: FieldBuf,
    last_ego: LastEgo,
}

impl Default for CsvRows {
    fn default() -> Self {
        Self {
            numbers: Vec::new(),
            texts: Vec::new(),
            rows: 0,
            reader: riskscore_data::ssm_csv::record_reader(),
            fields: FieldBuf::default(),
            last_ego: LastEgo::default(),
        }
    }
}

impl CsvRows {
    /// Rows added since the last [`Self::finish`].
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Add the good rows of `chunk`; bad ones go to `on_bad_row`. `strict`: the first bad row
    /// stops the chunk and is returned (the rows before it are kept).
    pub fn push_chunk(
        &mut self,
        layout: &CsvLayout,
        chunk: &Chunk,
        strict: bool,
        mut on_bad_row: impl FnMut(&RowError),
    ) -> Result<(), RowError> {
        let n = layout.columns.names.len();
        self.numbers.resize_with(18, Float64Builder::new);
        self.texts.resize_with(n, StringBuilder::new);
        let (numbers, texts, rows, last_ego) = (
            &mut self.numbers,
            &mut self.texts,
            &mut self.rows,
            &mut self.last_ego,
        );
        let mut failure: Option<RowError> = None;
        for piece in &chunk.pieces {
            let (start, end, line) = match *piece {
                Piece::Problem { line, problem } => {
                    let e = RowError {
                        line,
                        column: None,
                        problem: RowProblem::from(problem),
                    };
                    if strict {
                        return Err(e);
                    }
                    on_bad_row(&e);
                    continue;
                }
                Piece::Record { start, end, line } => (start, end, line),
            };
            let columns = &layout.columns;
            let mut add = |f: &FieldBuf| {
                if f.is_blank() {
                    return true;
                }
                let values = columns
                    .parse_values(f, line, last_ego)
                    .and_then(|v| texts_are_utf8(layout, f, line).map(|()| v));
                match values {
                    Ok((ego, partner)) => {
                        for (b, v) in numbers.iter_mut().zip(ego.iter().chain(&partner)) {
                            b.append_value(*v);
                        }
                        for (k, b) in texts.iter_mut().enumerate() {
                            if layout.pair[k].is_some() {
                                continue;
                            }
                            match f.field(k).map(std::str::from_utf8) {
                                Some(Ok(text)) => b.append_value(text),
                                _ => b.append_null(),
                            }
                        }
                        *rows += 1;
                        true
                    }
                    Err(e) if strict => {
                        failure = Some(e);
                        false
                    }
                    Err(e) => {
                        on_bad_row(&e);
                        true
                    }
                }
            };
            let record = &chunk.data[start..end];
            let body = &record[..record.len() - 1];
            // A line without quotes or CR is its fields split at commas, as in the CSV pipeline.
            if memchr::memchr2(b'"', b'\r', body).is_none() {
                self.fields.set_plain(body);
                add(&self.fields);
            } else {
                riskscore_data::ssm_csv::for_each_record(
                    &mut self.reader,
                    &mut self.fields,
                    record,
                    add,
                );
            }
            if let Some(e) = failure {
                return Err(e);
            }
        }
        Ok(())
    }

    /// The rows added so far as one batch of `layout.schema`; the builders start over.
    pub fn finish(&mut self, layout: &CsvLayout) -> Result<RecordBatch, SsmError> {
        let n = layout.columns.names.len();
        self.numbers.resize_with(18, Float64Builder::new);
        self.texts.resize_with(n, StringBuilder::new);
        self.rows = 0;
        let mut numbers: Vec<Option<ArrayRef>> = self
            .numbers
            .iter_mut()
            .map(|b| Some(Arc::new(b.finish()) as ArrayRef))
            .collect();
        let arrays: Vec<ArrayRef> = (0..n)
            .map(|k| match layout.pair[k] {
                Some(p) => numbers[p]
                    .take()
                    .unwrap_or_else(|| Arc::new(Float64Builder::new().finish())),
                None => Arc::new(self.texts[k].finish()) as ArrayRef,
            })
            .collect();
        RecordBatch::try_new(layout.schema.clone(), arrays)
            .map_err(|e| SsmError::Io(std::io::Error::other(e)))
    }
}

/// A row's pass-through fields are UTF-8 (Arrow strings must be): else the row is bad, with the
/// first offending column and its text (bytes shown `\xNN`).
fn texts_are_utf8(layout: &CsvLayout, fields: &FieldBuf, line: u64) -> Result<(), RowError> {
    for (k, is_pair) in layout.pair.iter().enumerate() {
        let Some(bytes) = fields.field(k).filter(|_| is_pair.is_none()) else {
            continue;
        };
        if std::str::from_utf8(bytes).is_err() {
            return Err(RowError {
                line,
                column: layout.columns.names.get(k).cloned(),
                problem: RowProblem::NotUtf8(riskscore_data::ssm_csv::escape_non_utf8(bytes)),
            });
        }
    }
    Ok(())
}

/// Reads a pair CSV into Arrow batches of up to [`BATCH_ROWS`] good rows, on the calling thread.
pub struct CsvBatches<R: Read> {
    splitter: Splitter<R>,
    layout: CsvLayout,
    rows: CsvRows,
    pending: Option<Chunk>,
    strict: bool,
}

impl<R: Read> CsvBatches<R> {
    pub fn new(input: R, options: &SsmOptions) -> Result<Self, SsmError> {
        let mut splitter = Splitter::new(input, 1 << 20, options.max_record_bytes);
        let (columns, pending) = riskscore_data::ssm_csv::read_header(&mut splitter)?;
        Ok(Self {
            splitter,
            layout: CsvLayout::new(columns)?,
            rows: CsvRows::default(),
            pending,
            strict: options.strict,
        })
    }

    pub fn columns(&self) -> &PairColumns {
        &self.layout.columns
    }

    pub fn schema(&self) -> Arc<Schema> {
        self.layout.schema.clone()
    }

    /// The next batch of up to [`BATCH_ROWS`] good rows; `None` at the end.
    pub fn next_batch(
        &mut self,
        mut on_bad_row: impl FnMut(&RowError),
    ) -> Result<Option<RecordBatch>, SsmError> {
        while self.rows.rows() < BATCH_ROWS {
            let chunk = match self.pending.take() {
                Some(c) => c,
                None => match self.splitter.next_chunk(Chunk::default()) {
                    Ok(Some(c)) => c,
                    Ok(None) => break,
                    Err(e) => return Err(SsmError::Read(e)),
                },
            };
            self.rows
                .push_chunk(&self.layout, &chunk, self.strict, &mut on_bad_row)
                .map_err(SsmError::BadRow)?;
        }
        if self.rows.rows() == 0 {
            return Ok(None);
        }
        self.rows.finish(&self.layout).map(Some)
    }
}
