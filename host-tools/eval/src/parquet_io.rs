//! Apache Parquet input and output for `riskctl ssm` and `riskctl score`, over the Arrow kernels
//! of [`crate::arrow_kernel`]. A path ending in `.parquet` (any case) is Parquet, anything else CSV.
//!
//! Columns are the same as in CSV: the input columns, then the 17 computed ones (Float32).
//! Parquet input -> pass-through columns keep their Arrow types; CSV input -> the 18 pair columns
//! become Float64 (the parsed values) and every other column Utf8 (its text). Parquet strings
//! must be UTF-8 and nothing is replaced by U+FFFD: a row whose pass-through text is not UTF-8 is a
//! bad row (reported with its line and column, skipped; `--strict` stops), and a header name that
//! is not UTF-8 stops the run. CSV output keeps such bytes as they are. Parquet output is written with
//! Snappy compression in row groups of up to 131,072 rows (the writer buffers one group); bad rows are skipped and reported with
//! their 1-based row number (Parquet input) or line number (CSV input).
//!
//! Page checksums: a page that carries a CRC-32 (written by pyarrow with `write_page_checksum`,
//! by Spark and others) is verified when read; a mismatch stops the run with the row group and
//! column named (a flipped bit would otherwise become a plausible wrong value). Pages without a
//! checksum cannot be verified.
//!
//! Limitations: CSV output of a Parquet input supports pass-through columns of the string,
//! integer, float and boolean types (others are an error naming the column). The columnar path
//! runs on one thread: see docs/benchmarks.md for its rate.
use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;
use std::sync::Arc;

use arrow_array::builder::{Float64Builder, StringBuilder};
use arrow_array::cast::AsArray;
use arrow_array::types::*;
use arrow_array::{Array, ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::properties::WriterProperties;

use crate::arrow_kernel::{append_columns, pair_columns, ssm_kernel, KernelError};
use riskscore_data::ssm_csv::split::{Chunk, Piece, Splitter};
use riskscore_data::ssm_csv::{
    push_f32, FieldBuf, PairColumns, RowError, RowFields, RowProblem, SsmError, SsmOptions,
    SsmSummary,
};

/// Rows per Arrow batch read or built.
pub const BATCH_ROWS: usize = 64 * 1024;

/// True when `path` names a Parquet file (extension `.parquet`, any case).
pub fn is_parquet(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// A problem with a columnar run.
#[derive(Debug, thiserror::Error)]
pub enum ColumnarError {
    #[error(transparent)]
    Ssm(#[from] SsmError),
    #[error(transparent)]
    Kernel(#[from] KernelError),
    #[error("Parquet: {0}")]
    Parquet(#[from] parquet::errors::ParquetError),
    #[error("Arrow: {0}")]
    Arrow(#[from] arrow_schema::ArrowError),
    #[error("column {name}: type {found} cannot be written to CSV")]
    CsvType { name: String, found: DataType },
    #[error("row group {row_group} (counting from 0), column {column}: a page's CRC-32 checksum does not match its bytes: the file is damaged, no output written")]
    PageChecksum { row_group: usize, column: String },
    #[error("I/O")]
    Io(#[from] std::io::Error),
}

/// Where batches go: a Parquet file or CSV text.
pub enum BatchSink<W: Write + Send> {
    Parquet {
        out: Option<W>,
        writer: Option<Box<ArrowWriter<W>>>,
    },
    Csv {
        out: W,
        header_written: bool,
        line: Vec<u8>,
    },
}

impl<W: Write + Send> BatchSink<W> {
    pub fn parquet(out: W) -> Self {
        BatchSink::Parquet {
            out: Some(out),
            writer: None,
        }
    }

    pub fn csv(out: W) -> Self {
        BatchSink::Csv {
            out,
            header_written: false,
            line: Vec::new(),
        }
    }

    /// Write one batch (the first fixes the schema).
    pub fn write(&mut self, batch: &RecordBatch) -> Result<(), ColumnarError> {
        match self {
            BatchSink::Parquet { out, writer } => {
                if writer.is_none() {
                    let props = WriterProperties::builder()
                        .set_compression(Compression::SNAPPY)
                        .set_max_row_group_row_count(Some(1 << 17))
                        .build();
                    let sink = out.take().ok_or_else(|| {
                        std::io::Error::other("Parquet sink used after it was closed")
                    })?;
                    *writer = Some(Box::new(ArrowWriter::try_new(
                        sink,
                        batch.schema(),
                        Some(props),
                    )?));
                }
                if let Some(w) = writer {
                    w.write(batch)?;
                }
            }
            BatchSink::Csv {
                out,
                header_written,
                line,
            } => {
                if !*header_written {
                    line.clear();
                    for (k, f) in batch.schema().fields().iter().enumerate() {
                        if k > 0 {
                            line.push(b',');
                        }
                        riskscore_data::ssm_csv::push_field(line, f.name().as_bytes());
                    }
                    line.push(b'\n');
                    out.write_all(line)?;
                    *header_written = true;
                }
                write_csv_rows(batch, out, line)?;
            }
        }
        Ok(())
    }

    /// Finish the file (Parquet footer) and flush. `schema` is used when no batch was written.
    pub fn finish(self, schema: Arc<Schema>) -> Result<(), ColumnarError> {
        match self {
            BatchSink::Parquet { out, writer } => {
                let writer = match (writer, out) {
                    (Some(w), _) => *w,
                    (None, Some(out)) => ArrowWriter::try_new(out, schema, None)?,
                    (None, None) => return Ok(()),
                };
                let mut inner = writer.into_inner()?;
                inner.flush()?;
            }
            BatchSink::Csv {
                mut out,
                header_written,
                mut line,
            } => {
                if !header_written {
                    let empty = RecordBatch::new_empty(schema);
                    let mut sink = BatchSink::Csv {
                        out,
                        header_written,
                        line,
                    };
                    sink.write(&empty)?;
                    return sink.finish(empty.schema());
                }
                line.clear();
                out.flush()?;
            }
        }
        Ok(())
    }
}

/// One cell as CSV text (before quoting); nulls are empty.
fn push_cell(out: &mut Vec<u8>, column: &dyn Array, row: usize) -> bool {
    use std::io::Write as _;
    if column.is_null(row) {
        return true;
    }
    macro_rules! int {
        ($t:ty) => {{
            let _ = write!(out, "{}", column.as_primitive::<$t>().value(row));
        }};
    }
    match column.data_type() {
        DataType::Utf8 => out.extend_from_slice(column.as_string::<i32>().value(row).as_bytes()),
        DataType::LargeUtf8 => {
            out.extend_from_slice(column.as_string::<i64>().value(row).as_bytes())
        }
        DataType::Utf8View => out.extend_from_slice(column.as_string_view().value(row).as_bytes()),
        DataType::Float32 => push_f32(out, column.as_primitive::<Float32Type>().value(row)),
        DataType::Float64 => {
            let v = column.as_primitive::<Float64Type>().value(row);
            if v.is_infinite() {
                out.extend_from_slice(if v > 0.0 { b"inf" } else { b"-inf" });
            } else {
                let _ = write!(out, "{v}");
            }
        }
        DataType::Int8 => int!(Int8Type),
        DataType::Int16 => int!(Int16Type),
        DataType::Int32 => int!(Int32Type),
        DataType::Int64 => int!(Int64Type),
        DataType::UInt8 => int!(UInt8Type),
        DataType::UInt16 => int!(UInt16Type),
        DataType::UInt32 => int!(UInt32Type),
        DataType::UInt64 => int!(UInt64Type),
        DataType::Boolean => {
            let _ = write!(out, "{}", column.as_boolean().value(row));
        }
        _ => return false,
    }
    true
}

fn write_csv_rows<W: Write>(
    batch: &RecordBatch,
    out: &mut W,
    line: &mut Vec<u8>,
) -> Result<(), ColumnarError> {
    let mut cell = Vec::new();
    for row in 0..batch.num_rows() {
        line.clear();
        for (k, column) in batch.columns().iter().enumerate() {
            if k > 0 {
                line.push(b',');
            }
            cell.clear();
            if !push_cell(&mut cell, column.as_ref(), row) {
                return Err(ColumnarError::CsvType {
                    name: batch.schema().field(k).name().clone(),
                    found: column.data_type().clone(),
                });
            }
            riskscore_data::ssm_csv::push_field(line, &cell);
        }
        line.push(b'\n');
        out.write_all(line)?;
    }
    Ok(())
}

/// Batches from a Parquet file.
pub fn parquet_batches(
    file: File,
) -> Result<impl Iterator<Item = Result<RecordBatch, arrow_schema::ArrowError>>, ColumnarError> {
    Ok(ParquetRecordBatchReaderBuilder::try_new(file)?
        .with_batch_size(BATCH_ROWS)
        .build()?)
}

/// Reads a pair CSV into Arrow batches: pair columns Float64, other columns Utf8. Rows that fail
/// the CSV reader's checks are reported through `on_bad_row` and left out.
pub struct CsvBatches<R: Read> {
    splitter: Splitter<R>,
    columns: PairColumns,
    schema: Arc<Schema>,
    reader: csv_core::Reader,
    fields: FieldBuf,
    pending: Option<Chunk>,
    strict: bool,
}

impl<R: Read> CsvBatches<R> {
    pub fn new(input: R, options: &SsmOptions) -> Result<Self, SsmError> {
        let mut splitter = Splitter::new(input, 1 << 20, options.max_record_bytes);
        let (columns, pending) = riskscore_data::ssm_csv::read_header(&mut splitter)?;
        if let Some((column, name)) = columns.non_utf8_name() {
            return Err(SsmError::NonUtf8Name { column, name });
        }
        let pair: Vec<usize> = columns
            .ego
            .iter()
            .chain(&columns.partner)
            .copied()
            .collect();
        let schema = Arc::new(Schema::new(
            columns
                .names
                .iter()
                .enumerate()
                .map(|(k, n)| {
                    let t = if pair.contains(&k) {
                        DataType::Float64
                    } else {
                        DataType::Utf8
                    };
                    Field::new(n, t, true)
                })
                .collect::<Vec<_>>(),
        ));
        Ok(Self {
            splitter,
            columns,
            schema,
            reader: riskscore_data::ssm_csv::record_reader(),
            fields: FieldBuf::default(),
            pending,
            strict: options.strict,
        })
    }

    pub fn columns(&self) -> &PairColumns {
        &self.columns
    }

    pub fn schema(&self) -> Arc<Schema> {
        self.schema.clone()
    }

    /// The next batch of up to [`BATCH_ROWS`] good rows; `None` at the end.
    pub fn next_batch(
        &mut self,
        mut on_bad_row: impl FnMut(&RowError),
    ) -> Result<Option<RecordBatch>, SsmError> {
        let n = self.columns.names.len();
        let pair: Vec<Option<usize>> = (0..n)
            .map(|k| {
                self.columns
                    .ego
                    .iter()
                    .chain(&self.columns.partner)
                    .position(|&c| c == k)
            })
            .collect();
        let mut numbers: Vec<Float64Builder> = (0..18).map(|_| Float64Builder::new()).collect();
        let mut texts: Vec<StringBuilder> = (0..n).map(|_| StringBuilder::new()).collect();
        let mut rows = 0usize;
        let mut failure: Option<RowError> = None;
        while rows < BATCH_ROWS && failure.is_none() {
            let chunk = match self.pending.take() {
                Some(c) => c,
                None => match self.splitter.next_chunk(Chunk::default()) {
                    Ok(Some(c)) => c,
                    Ok(None) => break,
                    Err(e) => return Err(SsmError::Read(e)),
                },
            };
            for piece in &chunk.pieces {
                let (start, end, line) = match *piece {
                    Piece::Problem { line, problem } => {
                        let e = RowError {
                            line,
                            column: None,
                            problem: RowProblem::from(problem),
                        };
                        if self.strict {
                            failure = Some(e);
                            break;
                        }
                        on_bad_row(&e);
                        continue;
                    }
                    Piece::Record { start, end, line } => (start, end, line),
                };
                let columns = &self.columns;
                riskscore_data::ssm_csv::for_each_record(
                    &mut self.reader,
                    &mut self.fields,
                    &chunk.data[start..end],
                    |f| {
                        if f.is_blank() {
                            return true;
                        }
                        let values = columns
                            .parse_values(f, line)
                            .and_then(|v| texts_are_utf8(columns, &pair, f, line).map(|()| v));
                        match values {
                            Ok((ego, partner)) => {
                                for (b, v) in numbers.iter_mut().zip(ego.iter().chain(&partner)) {
                                    b.append_value(*v);
                                }
                                for (k, b) in texts.iter_mut().enumerate() {
                                    if pair[k].is_some() {
                                        continue;
                                    }
                                    match f.field(k).map(std::str::from_utf8) {
                                        Some(Ok(text)) => b.append_value(text),
                                        _ => b.append_null(),
                                    }
                                }
                                rows += 1;
                                true
                            }
                            Err(e) if self.strict => {
                                failure = Some(e);
                                false
                            }
                            Err(e) => {
                                on_bad_row(&e);
                                true
                            }
                        }
                    },
                );
                if failure.is_some() {
                    break;
                }
            }
        }
        if let Some(e) = failure {
            return Err(SsmError::BadRow(e));
        }
        if rows == 0 {
            return Ok(None);
        }
        let mut numbers: Vec<ArrayRef> = numbers
            .iter_mut()
            .map(|b| Arc::new(b.finish()) as ArrayRef)
            .collect();
        let arrays: Vec<ArrayRef> = (0..n)
            .map(|k| match pair[k] {
                Some(p) => {
                    std::mem::replace(&mut numbers[p], Arc::new(Float64Builder::new().finish()))
                }
                None => Arc::new(texts[k].finish()) as ArrayRef,
            })
            .collect();
        Ok(Some(
            RecordBatch::try_new(self.schema.clone(), arrays)
                .map_err(|e| SsmError::Io(std::io::Error::other(e)))?,
        ))
    }
}

/// A row's pass-through fields are UTF-8 (Arrow strings must be): else the row is bad, with the
/// first offending column and its text (bytes shown `\xNN`).
fn texts_are_utf8(
    columns: &PairColumns,
    pair: &[Option<usize>],
    fields: &FieldBuf,
    line: u64,
) -> Result<(), RowError> {
    for (k, is_pair) in pair.iter().enumerate() {
        let Some(bytes) = fields.field(k).filter(|_| is_pair.is_none()) else {
            continue;
        };
        if std::str::from_utf8(bytes).is_err() {
            return Err(RowError {
                line,
                column: columns.names.get(k).cloned(),
                problem: RowProblem::NotUtf8(riskscore_data::ssm_csv::escape_non_utf8(bytes)),
            });
        }
    }
    Ok(())
}

/// `riskctl ssm` where the input or the output (or both) is Parquet.
pub fn ssm_columnar<R: Read, W: Write + Send>(
    input: ColumnarInput<R>,
    mut sink: BatchSink<W>,
    options: SsmOptions,
    mut on_bad_row: impl FnMut(&RowError),
) -> Result<SsmSummary, ColumnarError> {
    let mut summary = SsmSummary::default();
    let mut report = |e: &RowError, summary: &mut SsmSummary| -> Result<(), ColumnarError> {
        summary.rows_bad += 1;
        if options.strict {
            return Err(SsmError::BadRow(e.clone()).into());
        }
        on_bad_row(e);
        Ok(())
    };
    // Score one batch, write its good rows; returns the output schema and the bad rows.
    let write_scored = |batch: &RecordBatch,
                        columns: &PairColumns,
                        first_row: u64,
                        summary: &mut SsmSummary,
                        sink: &mut BatchSink<W>|
     -> Result<(Arc<Schema>, Vec<RowError>), ColumnarError> {
        let scored = ssm_kernel(columns, batch, first_row)?;
        let joined = append_columns(batch, &scored.computed, Some(&scored.valid))?;
        summary.rows_ok += joined.num_rows() as u64;
        if scored.bad.is_empty() || !options.strict {
            sink.write(&joined)?;
        }
        Ok((joined.schema(), scored.bad))
    };
    let schema = match input {
        ColumnarInput::Parquet(file) => {
            let again = file.try_clone()?;
            let builder = ParquetRecordBatchReaderBuilder::try_new(file)?;
            let columns = pair_columns(builder.schema())?;
            summary.duplicated_columns = columns.clashing_output_columns();
            let empty = RecordBatch::new_empty(builder.schema().clone());
            let reader = builder.with_batch_size(BATCH_ROWS).build()?;
            let mut first_row = 0u64;
            let mut schema = None;
            for batch in reader {
                let batch = batch.map_err(|e| locate_checksum_error(e, &again))?;
                let (s, bad) = write_scored(&batch, &columns, first_row, &mut summary, &mut sink)?;
                for e in &bad {
                    report(e, &mut summary)?;
                }
                schema = Some(s);
                first_row += batch.num_rows() as u64;
            }
            match schema {
                Some(s) => s,
                None => write_scored(&empty, &columns, 0, &mut summary, &mut sink)?.0,
            }
        }
        ColumnarInput::Csv(reader) => {
            let mut batches = CsvBatches::new(reader, &options)?;
            summary.duplicated_columns = batches.columns().clashing_output_columns();
            let columns = batches.columns().clone();
            let mut bad = Vec::new();
            let mut schema = None;
            loop {
                let next = batches.next_batch(|e| bad.push(e.clone()));
                for e in bad.drain(..) {
                    report(&e, &mut summary)?;
                }
                let Some(batch) = next? else { break };
                schema = Some(write_scored(&batch, &columns, 0, &mut summary, &mut sink)?.0);
            }
            match schema {
                Some(s) => s,
                None => {
                    let empty = RecordBatch::new_empty(batches.schema());
                    write_scored(&empty, &columns, 0, &mut summary, &mut sink)?.0
                }
            }
        }
    };
    sink.finish(schema)?;
    Ok(summary)
}

/// A read error as it is, unless it is a page checksum mismatch: that one is located (row group
/// and column) by reading the file's pages again, as the Arrow reader does not say where it was.
fn locate_checksum_error(e: arrow_schema::ArrowError, file: &File) -> ColumnarError {
    // The parquet crate reports a mismatch only as this text (`crc` feature, `decode_page`).
    if !e.to_string().contains("CRC checksum mismatch") {
        return e.into();
    }
    match file.try_clone().ok().and_then(first_corrupt_page) {
        Some((row_group, column)) => ColumnarError::PageChecksum { row_group, column },
        None => e.into(),
    }
}

/// The row group (0-based) and column path of the first page that does not read back.
fn first_corrupt_page(file: File) -> Option<(usize, String)> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let reader = SerializedFileReader::new(file).ok()?;
    for row_group in 0..reader.num_row_groups() {
        let group = reader.get_row_group(row_group).ok()?;
        for column in 0..group.num_columns() {
            let name = || group.metadata().column(column).column_path().string();
            let Ok(mut pages) = group.get_column_page_reader(column) else {
                return Some((row_group, name()));
            };
            if pages.any(|page| page.is_err()) {
                return Some((row_group, name()));
            }
        }
    }
    None
}

/// The input of a columnar run.
pub enum ColumnarInput<R: Read> {
    Parquet(File),
    Csv(R),
}
