//! Apache Parquet input and output for `riskctl ssm` and `riskctl score`, over the Arrow kernels
//! of [`crate::arrow_kernel`]. A path ending in `.parquet` (any case) is Parquet, anything else CSV.
//!
//! Columns are the same as in CSV: the input columns, then the 17 computed ones (Float32).
//! Parquet input -> pass-through columns keep their Arrow types; CSV input -> the 18 pair columns
//! become Float64 (the parsed values) and every other column Utf8 (its text). Parquet strings
//! must be UTF-8 and nothing is replaced by U+FFFD: a row whose pass-through text is not UTF-8 is a
//! bad row (reported with its line and column, skipped; `--strict` stops), and a header name that
//! is not UTF-8 stops the run. CSV output keeps such bytes as they are. Parquet output is
//! Snappy-compressed but for the computed columns that do not compress ([`UNCOMPRESSED_COLUMNS`]);
//! `riskctl ssm` writes a row group per 8 MiB of CSV input; from Parquet it keeps the input's row
//! groups, copying their column chunks ([`raw_copy`]; a row group with a bad row or of more than
//! [`raw_copy::RAW_MAX_ROWS`] rows is encoded again in row groups of 65,536 rows).
//! [`BatchSink`] (`riskctl score`) writes row groups of up to 131,072 rows (it buffers one group). Bad
//! rows are skipped and reported with their 1-based row number (Parquet input) or line number
//! (CSV input).
//!
//! Page checksums: a page that carries a CRC-32 (written by pyarrow with `write_page_checksum`,
//! by Spark and others) is verified when read, or when its column chunk is copied
//! ([`page_checksums`]); a mismatch stops the run with the row group and column named (a flipped
//! bit would otherwise become a plausible wrong value). Pages without a checksum cannot be
//! verified. A copied column is not decoded, so its values are not checked either: a text column
//! whose bytes are not UTF-8 is copied as the input has it (decoding it, e.g. to CSV, is an
//! error), where re-encoding would have stopped the run.
//!
//! `riskctl ssm` runs on every core ([`ssm_parallel`]): batches are scored and encoded in
//! parallel and written in input order, the output byte-identical whatever the thread count.
//!
//! Limitations: CSV output of a Parquet input supports pass-through columns of the string,
//! integer, float and boolean types (others are an error naming the column).
use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;
use std::sync::Arc;

use arrow_array::RecordBatch;
use arrow_schema::{DataType, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ArrowWriter;

use crate::arrow_kernel::KernelError;
use riskscore_data::ssm_csv::SsmError;

mod csv_batches;
mod csv_cells;
mod ordered;
mod page_checksums;
mod raw_copy;
mod row_groups;
mod ssm_parallel;

pub use csv_batches::{CsvBatches, CsvLayout, CsvRows};
pub(crate) use csv_cells::write_csv_rows;
pub use row_groups::{writer_properties, MAX_ROW_GROUP_ROWS, UNCOMPRESSED_COLUMNS};
pub use ssm_parallel::ssm_columnar;

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

    /// The output itself, for a writer that encodes on its own (`true`: Parquet), before any
    /// batch was written through this sink.
    pub fn into_output(self) -> Result<(W, bool), ColumnarError> {
        match self {
            BatchSink::Parquet {
                out: Some(out),
                writer: None,
            } => Ok((out, true)),
            BatchSink::Csv {
                out,
                header_written: false,
                ..
            } => Ok((out, false)),
            _ => Err(std::io::Error::other("the output was already written to").into()),
        }
    }

    /// Write one batch (the first fixes the schema).
    pub fn write(&mut self, batch: &RecordBatch) -> Result<(), ColumnarError> {
        match self {
            BatchSink::Parquet { out, writer } => {
                if writer.is_none() {
                    let props = writer_properties(&batch.schema());
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
                    (None, Some(out)) => {
                        let props = writer_properties(&schema);
                        ArrowWriter::try_new(out, schema, Some(props))?
                    }
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

/// Batches from a Parquet file.
pub fn parquet_batches(
    file: File,
) -> Result<impl Iterator<Item = Result<RecordBatch, arrow_schema::ArrowError>>, ColumnarError> {
    Ok(ParquetRecordBatchReaderBuilder::try_new(file)?
        .with_batch_size(BATCH_ROWS)
        .build()?)
}

/// A read error as it is, unless it is a page checksum mismatch: that one is located (row group
/// and column) by reading the file's pages again, as the Arrow reader does not say where it was.
pub(crate) fn locate_checksum_error(e: arrow_schema::ArrowError, file: &File) -> ColumnarError {
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
