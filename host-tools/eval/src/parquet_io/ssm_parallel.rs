//! `riskctl ssm` where the input or the output (or both) is Parquet, on every core.
//!
//! The calling thread reads (decodes Parquet batches in file order, or cuts CSV into chunks of
//! whole records) and writes; `threads` workers parse (CSV), score with the Arrow kernel and
//! encode (a Parquet row group, or CSV text). Parquet -> Parquet: a job is an input row group,
//! which its worker decodes itself (only the pair columns) and whose pass-through column chunks
//! are copied ([`super::raw_copy`]); the calling thread only decodes a row group too large to
//! copy, cut into batches as before. Results are written in input order and at most
//! `2 x threads + 2` jobs are in flight ([`super::ordered`]), so memory does not grow with the
//! file. How the input is cut does not depend on the thread count (Parquet: its row groups, or
//! batches of a fixed number of rows; CSV: chunks of a fixed number of bytes), and each piece of output depends only
//! on its own rows, so the output is byte-identical whatever `--threads` is.
use std::io::{Read, Write};
use std::sync::Arc;

use arrow_array::RecordBatch;
use arrow_schema::{Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::arrow_writer::ArrowColumnChunk;

use super::csv_batches::{CsvLayout, CsvRows};
use super::ordered::ordered_map;
use super::raw_copy::{read_metadata, GroupOutcome, PositionalFile, RawSource};
use super::row_groups::{row_group_file, CopiedGroup, RowGroupEncoder, RowGroupFile};
use super::{locate_checksum_error, write_csv_rows, BatchSink, ColumnarError, ColumnarInput};
use crate::arrow_kernel::{append_columns, computed_schema, pair_columns, ssm_kernel};
use riskscore_data::ssm_csv::split::{Chunk, Splitter};
use riskscore_data::ssm_csv::{PairColumns, RowError, SsmError, SsmOptions, SsmSummary};

/// How the input is cut into jobs. Fixed for a run (never derived from the thread count), so the
/// output does not depend on it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cutting {
    /// Rows per Parquet batch when the output is Parquet: one output row group each.
    pub rows_to_parquet: usize,
    /// Rows per Parquet batch when the output is CSV: the text is several times the decoded
    /// batch, so smaller batches keep the jobs in flight small.
    pub rows_to_csv: usize,
    /// Bytes of CSV per job (one output row group).
    pub csv_chunk_bytes: usize,
    /// Largest Parquet input row group whose pass-through columns are copied into the Parquet
    /// output ([`super::raw_copy`]); a larger one is cut into `rows_to_parquet` rows.
    pub raw_max_rows: usize,
}

impl Default for Cutting {
    fn default() -> Self {
        Self {
            rows_to_parquet: 64 * 1024,
            rows_to_csv: 16 * 1024,
            // About 47,000 rows of the 23-column NGSIM pairs.
            csv_chunk_bytes: 8 << 20,
            raw_max_rows: super::raw_copy::RAW_MAX_ROWS,
        }
    }
}

/// One job: rows to score.
enum Job {
    /// Decoded Parquet rows; `first_row` counts the rows before them (for row numbers).
    Batch { batch: RecordBatch, first_row: u64 },
    /// Whole CSV records, not parsed yet.
    Chunk(Chunk),
    /// A Parquet input row group, to be copied to the Parquet output with its computed columns
    /// (the worker decodes what it needs); `first_row` counts the rows before it.
    Group { group: usize, first_row: u64 },
}

/// A job's rows, scored and encoded.
struct Scored {
    rows_ok: u64,
    /// In input order. Strict mode: the first one stopped the job.
    bad: Vec<RowError>,
    out: Encoded,
}

enum Encoded {
    Nothing,
    Csv(Vec<u8>),
    RowGroup(Vec<ArrowColumnChunk>),
    /// An input row group with its pass-through columns copied.
    Copied(CopiedGroup),
    /// An input row group that had bad rows, encoded again in row groups of `rows_to_parquet`.
    RowGroups(Vec<Vec<ArrowColumnChunk>>),
}

/// Where the scored rows go.
enum Output<W: Write + Send> {
    Csv(W),
    Parquet(RowGroupFile<W>),
}

/// What a worker needs to score a job (shared by all workers).
struct Scoring<'a> {
    columns: &'a PairColumns,
    /// CSV input: how to turn a chunk into a batch.
    csv: Option<&'a CsvLayout>,
    /// Parquet output: the row group encoder; `None`: CSV text.
    encoder: Option<&'a RowGroupEncoder>,
    /// Parquet input and output: the input row groups to copy.
    raw: Option<&'a RawSource>,
    /// Rows per decoded batch of a copied row group.
    batch_rows: usize,
    strict: bool,
}

impl Scoring<'_> {
    fn score(&self, rows: &mut CsvRows, job: Job, index: usize) -> Result<Scored, ColumnarError> {
        let mut bad = Vec::new();
        let (batch, first_row) = match job {
            Job::Group { group, first_row } => return self.copy_group(rows, group, first_row),
            Job::Batch { batch, first_row } => (batch, first_row),
            Job::Chunk(chunk) => {
                let layout = self
                    .csv
                    .ok_or_else(|| std::io::Error::other("a CSV chunk without the CSV's layout"))?;
                let pushed = rows.push_chunk(layout, &chunk, self.strict, |e| bad.push(e.clone()));
                let batch = rows.finish(layout)?;
                if let Err(e) = pushed {
                    bad.push(e);
                    return Ok(stopped(bad));
                }
                // CSV rows were checked when parsed: the kernel's row numbers are not used.
                (batch, 0)
            }
        };
        let scored = ssm_kernel(self.columns, &batch, first_row)?;
        bad.extend(scored.bad);
        if self.strict && !bad.is_empty() {
            return Ok(stopped(bad));
        }
        let joined = append_columns(&batch, &scored.computed, Some(&scored.valid))?;
        let rows_ok = joined.num_rows() as u64;
        let out = match self.encoder {
            _ if rows_ok == 0 => Encoded::Nothing,
            Some(encoder) => Encoded::RowGroup(encoder.encode(&joined, index)?),
            None => {
                let mut text = Vec::new();
                write_csv_rows(&joined, &mut text, &mut Vec::new())?;
                Encoded::Csv(text)
            }
        };
        Ok(Scored { rows_ok, bad, out })
    }
}

impl Scoring<'_> {
    /// An input row group copied with its computed columns, or (a bad row: the pass-through
    /// rows would no longer line up) encoded again the old way.
    fn copy_group(
        &self,
        rows: &mut CsvRows,
        group: usize,
        first_row: u64,
    ) -> Result<Scored, ColumnarError> {
        let (Some(raw), Some(encoder)) = (self.raw, self.encoder) else {
            return Err(
                std::io::Error::other("a row group to copy without a Parquet output").into(),
            );
        };
        match raw.score_group(group, first_row, self.batch_rows, encoder)? {
            GroupOutcome::Copied { rows, group } => Ok(Scored {
                rows_ok: rows,
                bad: Vec::new(),
                out: Encoded::Copied(group),
            }),
            GroupOutcome::BadRows(bad) if self.strict => Ok(stopped(bad)),
            GroupOutcome::BadRows(_) => {
                let mut all = Scored {
                    rows_ok: 0,
                    bad: Vec::new(),
                    out: Encoded::Nothing,
                };
                let mut groups = Vec::new();
                let mut next_row = first_row;
                for batch in raw.group_batches(group, self.batch_rows)? {
                    let batch = batch.map_err(|e| locate_checksum_error(e, raw.file()))?;
                    let batch_rows = batch.num_rows() as u64;
                    let job = Job::Batch {
                        batch,
                        first_row: next_row,
                    };
                    next_row += batch_rows;
                    let scored = self.score(rows, job, group)?;
                    all.rows_ok += scored.rows_ok;
                    all.bad.extend(scored.bad);
                    if let Encoded::RowGroup(chunks) = scored.out {
                        groups.push(chunks);
                    }
                }
                all.out = Encoded::RowGroups(groups);
                Ok(all)
            }
        }
    }
}

/// A strict-mode job that stopped at its first bad row (nothing of it is written).
fn stopped(bad: Vec<RowError>) -> Scored {
    Scored {
        rows_ok: 0,
        bad,
        out: Encoded::Nothing,
    }
}

/// The jobs of a Parquet input copied to a Parquet output: one per input row group, but a row
/// group larger than [`Cutting::raw_max_rows`] is decoded here, in batches of
/// [`Cutting::rows_to_parquet`] rows (one job each), and an empty one is skipped.
#[derive(Default)]
struct RawGroups {
    next_group: usize,
    /// Rows of the file before the next job's.
    first_row: u64,
    /// The batches of a row group too large to copy.
    cutting: Option<parquet::arrow::arrow_reader::ParquetRecordBatchReader>,
}

impl RawGroups {
    fn next_job(
        &mut self,
        raw: &RawSource,
        cutting: &Cutting,
    ) -> Result<Option<Job>, ColumnarError> {
        loop {
            if let Some(batches) = self.cutting.as_mut() {
                match batches.next() {
                    Some(batch) => {
                        let batch = batch.map_err(|e| locate_checksum_error(e, raw.file()))?;
                        let first_row = self.first_row;
                        self.first_row += batch.num_rows() as u64;
                        return Ok(Some(Job::Batch { batch, first_row }));
                    }
                    None => self.cutting = None,
                }
            }
            if self.next_group >= raw.num_groups() {
                return Ok(None);
            }
            let group = self.next_group;
            self.next_group += 1;
            let rows = raw.group_rows(group);
            if rows > cutting.raw_max_rows {
                self.cutting = Some(raw.group_batches(group, cutting.rows_to_parquet)?);
            } else if rows > 0 {
                let first_row = self.first_row;
                self.first_row += rows as u64;
                return Ok(Some(Job::Group { group, first_row }));
            }
        }
    }
}

/// The input's columns followed by the 17 computed ones.
fn output_schema(input: &Schema) -> Arc<Schema> {
    let computed = computed_schema();
    let fields: Vec<Arc<Field>> = input
        .fields()
        .iter()
        .chain(computed.fields().iter())
        .cloned()
        .collect();
    Arc::new(Schema::new(fields))
}

/// `riskctl ssm` where the input or the output (or both) is Parquet: bad rows are reported to
/// `on_bad_row` in input order (Parquet input: 1-based row numbers; CSV: line numbers).
pub fn ssm_columnar<R: Read, W: Write + Send>(
    input: ColumnarInput<R>,
    sink: BatchSink<W>,
    options: SsmOptions,
    on_bad_row: impl FnMut(&RowError),
) -> Result<SsmSummary, ColumnarError> {
    ssm_columnar_cut(input, sink, options, Cutting::default(), on_bad_row)
}

/// [`ssm_columnar`] with the input cut as `cutting` says.
pub(crate) fn ssm_columnar_cut<R: Read, W: Write + Send>(
    input: ColumnarInput<R>,
    sink: BatchSink<W>,
    options: SsmOptions,
    cutting: Cutting,
    mut on_bad_row: impl FnMut(&RowError),
) -> Result<SsmSummary, ColumnarError> {
    let (out, parquet_out) = sink.into_output()?;
    let threads = match options.threads {
        0 => std::thread::available_parallelism().map_or(2, |n| n.get()),
        n => n,
    };
    // The input side: its columns and a source of jobs.
    let mut parquet_in = None;
    let mut raw_in = None;
    let mut csv_in = None;
    let mut csv_layout = None;
    let (columns, input_schema) = match input {
        ColumnarInput::Parquet(file) if parquet_out => {
            let file = PositionalFile::new(file);
            let metadata = read_metadata(&file)?;
            let schema = metadata.schema().clone();
            let columns = pair_columns(&schema)?;
            // Wrong column types are found before any row is read (and for an empty file).
            ssm_kernel(&columns, &RecordBatch::new_empty(schema.clone()), 0)?;
            raw_in = Some((file, metadata));
            (columns, schema)
        }
        ColumnarInput::Parquet(file) => {
            let again = file.try_clone()?;
            let builder = ParquetRecordBatchReaderBuilder::try_new(file)?;
            let columns = pair_columns(builder.schema())?;
            let schema = builder.schema().clone();
            // Wrong column types are found before any row is read (and for an empty file).
            ssm_kernel(&columns, &RecordBatch::new_empty(schema.clone()), 0)?;
            let rows = if parquet_out {
                cutting.rows_to_parquet
            } else {
                cutting.rows_to_csv
            };
            parquet_in = Some((builder.with_batch_size(rows).build()?, again));
            (columns, schema)
        }
        ColumnarInput::Csv(reader) => {
            let mut splitter =
                Splitter::new(reader, cutting.csv_chunk_bytes, options.max_record_bytes);
            let (columns, first) = riskscore_data::ssm_csv::read_header(&mut splitter)?;
            let layout = CsvLayout::new(columns.clone())?;
            let schema = layout.schema.clone();
            csv_in = Some((splitter, first));
            csv_layout = Some(layout);
            (columns, schema)
        }
    };
    let schema = output_schema(&input_schema);
    let mut summary = SsmSummary {
        duplicated_columns: columns.clashing_output_columns(),
        ..SsmSummary::default()
    };

    let encoder;
    let mut raw = None;
    let mut output = if parquet_out {
        let (file, row_groups) = row_group_file(out, schema.clone())?;
        encoder = Some(row_groups);
        if let Some((input, metadata)) = raw_in {
            let fields = schema.fields().len();
            raw = Some(RawSource::new(
                input,
                metadata,
                &columns,
                file.schema_descr(),
                fields,
            )?);
        }
        Output::Parquet(file)
    } else {
        encoder = None;
        let mut out = out;
        let mut header = Vec::new();
        for (k, f) in schema.fields().iter().enumerate() {
            if k > 0 {
                header.push(b',');
            }
            riskscore_data::ssm_csv::push_field(&mut header, f.name().as_bytes());
        }
        header.push(b'\n');
        out.write_all(&header)?;
        Output::Csv(out)
    };

    let scoring = Scoring {
        columns: &columns,
        csv: csv_layout.as_ref(),
        encoder: encoder.as_ref(),
        raw: raw.as_ref(),
        batch_rows: cutting.rows_to_parquet,
        strict: options.strict,
    };
    let (mut first_row, mut index) = (0u64, 0usize);
    let mut groups = RawGroups::default();
    let produce = || -> Result<Option<(Job, usize)>, ColumnarError> {
        let job = if let Some(raw) = raw.as_ref() {
            groups.next_job(raw, &cutting)?
        } else if let Some((reader, file)) = parquet_in.as_mut() {
            match reader.next() {
                None => None,
                Some(batch) => {
                    let batch = batch.map_err(|e| locate_checksum_error(e, file))?;
                    let rows = batch.num_rows() as u64;
                    first_row += rows;
                    Some(Job::Batch {
                        batch,
                        first_row: first_row - rows,
                    })
                }
            }
        } else if let Some((splitter, first)) = csv_in.as_mut() {
            match first.take() {
                Some(chunk) => Some(Job::Chunk(chunk)),
                None => splitter
                    .next_chunk(Chunk::default())
                    .map_err(SsmError::Read)?
                    .map(Job::Chunk),
            }
        } else {
            None
        };
        Ok(job.map(|j| {
            index += 1;
            (j, index - 1)
        }))
    };
    let consume = |scored: Result<Scored, ColumnarError>| -> Result<(), ColumnarError> {
        let scored = scored?;
        summary.rows_bad += scored.bad.len() as u64;
        if options.strict {
            if let Some(first) = scored.bad.into_iter().next() {
                return Err(SsmError::BadRow(first).into());
            }
        } else {
            scored.bad.iter().for_each(&mut on_bad_row);
        }
        summary.rows_ok += scored.rows_ok;
        match (scored.out, &mut output) {
            (Encoded::Nothing, _) => {}
            (Encoded::Csv(text), Output::Csv(out)) => out.write_all(&text)?,
            (Encoded::RowGroup(chunks), Output::Parquet(file)) => file.append(chunks)?,
            (Encoded::Copied(group), Output::Parquet(file)) => match raw.as_ref() {
                Some(raw) => file.append_copied(raw.input(), group)?,
                None => {
                    return Err(
                        std::io::Error::other("a copied row group without its input").into(),
                    )
                }
            },
            (Encoded::RowGroups(groups), Output::Parquet(file)) => {
                for chunks in groups {
                    file.append(chunks)?;
                }
            }
            _ => return Err(std::io::Error::other("output of the wrong format").into()),
        }
        Ok(())
    };
    ordered_map(
        threads,
        2 * threads + 2,
        produce,
        CsvRows::default,
        |rows, (job, index)| scoring.score(rows, job, index),
        consume,
        || std::io::Error::other("a worker thread stopped without a result").into(),
    )?;
    match output {
        Output::Csv(mut out) => out.flush()?,
        Output::Parquet(file) => {
            file.finish()?;
        }
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parquet_io::UNCOMPRESSED_COLUMNS;
    use arrow_array::{ArrayRef, Float64Array, StringArray};
    use parquet::arrow::ArrowWriter;
    use parquet::file::reader::{FileReader, SerializedFileReader};

    const NAMES: [&str; 9] = ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"];

    /// The 18 pair values of row `k`: varied, all valid.
    fn pair(k: usize) -> [f64; 18] {
        let f = k as f64;
        [
            f * 0.37 % 50.0,
            (f * 1.3) % 7.0 - 3.0,
            20.0 + f % 5.0,
            0.1 * (f % 3.0),
            1.0,
            0.01 * (f % 7.0),
            f % 2.0 - 0.5,
            4.5,
            1.8,
            30.0 + f % 40.0,
            (f * 0.7) % 9.0 - 4.0,
            10.0 + f % 11.0,
            -0.2 * (f % 4.0),
            1.0,
            -0.02 * (f % 5.0),
            0.0,
            4.0 + f % 2.0,
            1.9,
        ]
    }

    fn header() -> String {
        let names: Vec<String> = NAMES
            .iter()
            .map(|n| format!("{n}_i"))
            .chain(NAMES.iter().map(|n| format!("{n}_j")))
            .collect();
        format!("id,{},note", names.join(","))
    }

    /// A CSV of `rows` rows; the rows in `bad` get an invalid value (by kind, in turn).
    fn csv(rows: usize, bad: &[usize]) -> Vec<u8> {
        let mut text = header() + "\n";
        for k in 0..rows {
            let mut values: Vec<String> = pair(k).iter().map(|v| v.to_string()).collect();
            if let Some(i) = bad.iter().position(|&b| b == k) {
                match i % 3 {
                    0 => values[6] = "NaN".into(),
                    1 => values[11] = "inf".into(),
                    _ => values[7] = "-4.5".into(),
                }
            }
            text += &format!("r{k},{},\"note, {k}\"\n", values.join(","));
        }
        text.into_bytes()
    }

    /// The same rows as Parquet, in row groups of `group` rows; pair values of the `bad` rows
    /// non-finite (NaN, inf) or a negative size.
    fn parquet(rows: usize, bad: &[usize], group: usize) -> Vec<u8> {
        write_parquet(&pairs_batch(rows, bad), group)
    }

    /// The rows of [`parquet`] as a batch.
    fn pairs_batch(rows: usize, bad: &[usize]) -> RecordBatch {
        let mut fields = vec![Field::new("id", arrow_schema::DataType::Utf8, false)];
        let mut columns: Vec<ArrayRef> = vec![Arc::new(StringArray::from(
            (0..rows).map(|k| format!("r{k}")).collect::<Vec<_>>(),
        ))];
        let names: Vec<String> = NAMES
            .iter()
            .map(|n| format!("{n}_i"))
            .chain(NAMES.iter().map(|n| format!("{n}_j")))
            .collect();
        for (c, name) in names.iter().enumerate() {
            fields.push(Field::new(name, arrow_schema::DataType::Float64, true));
            let values: Vec<f64> = (0..rows)
                .map(|k| match bad.iter().position(|&b| b == k) {
                    Some(i) if i % 3 == 0 && c == 6 => f64::NAN,
                    Some(i) if i % 3 == 1 && c == 11 => f64::INFINITY,
                    Some(i) if i % 3 == 2 && c == 7 => -4.5,
                    _ => pair(k)[c],
                })
                .collect();
            columns.push(Arc::new(Float64Array::from(values)));
        }
        RecordBatch::try_new(Arc::new(Schema::new(fields)), columns).unwrap()
    }

    /// `batch` as Parquet (uncompressed: the parquet crate's default), row groups of `group` rows.
    fn write_parquet(batch: &RecordBatch, group: usize) -> Vec<u8> {
        let props = parquet::file::properties::WriterProperties::builder()
            .set_max_row_group_row_count(Some(group))
            .build();
        let mut out = Vec::new();
        let mut writer = ArrowWriter::try_new(&mut out, batch.schema(), Some(props)).unwrap();
        writer.write(batch).unwrap();
        writer.close().unwrap();
        out
    }

    /// `batch`'s fields, to change.
    fn fields_of(batch: &RecordBatch) -> Vec<Field> {
        let schema = batch.schema();
        schema.fields().iter().map(|f| f.as_ref().clone()).collect()
    }

    fn small_cuts() -> Cutting {
        Cutting {
            rows_to_parquet: 300,
            rows_to_csv: 170,
            csv_chunk_bytes: 16 << 10,
            raw_max_rows: 1000,
        }
    }

    /// The output bytes, the bad rows reported (line and column) and the summary of a run.
    type Run = (Vec<u8>, Vec<(u64, Option<String>)>, SsmSummary);

    /// Runs one path.
    fn run(
        input: &[u8],
        parquet_in: bool,
        parquet_out: bool,
        threads: usize,
        strict: bool,
    ) -> Result<Run, ColumnarError> {
        run_cut(
            input,
            parquet_in,
            parquet_out,
            threads,
            strict,
            small_cuts(),
        )
    }

    /// Runs one path with the input cut as `cutting` says.
    fn run_cut(
        input: &[u8],
        parquet_in: bool,
        parquet_out: bool,
        threads: usize,
        strict: bool,
        cutting: Cutting,
    ) -> Result<Run, ColumnarError> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in");
        std::fs::write(&path, input).unwrap();
        let file = std::fs::File::open(&path).unwrap();
        let input = if parquet_in {
            ColumnarInput::Parquet(file)
        } else {
            ColumnarInput::Csv(file)
        };
        let mut out = Vec::new();
        let sink = if parquet_out {
            BatchSink::parquet(&mut out)
        } else {
            BatchSink::csv(&mut out)
        };
        let options = SsmOptions {
            strict,
            threads,
            ..SsmOptions::default()
        };
        let mut bad = Vec::new();
        let summary = ssm_columnar_cut(input, sink, options, cutting, |e| {
            bad.push((e.line, e.column.clone()))
        })?;
        Ok((out, bad, summary))
    }

    fn as_file(bytes: &[u8]) -> std::fs::File {
        use std::io::{Seek, Write as _};
        let mut file = tempfile::tempfile().unwrap();
        file.write_all(bytes).unwrap();
        file.rewind().unwrap();
        file
    }

    fn row_groups(file: Vec<u8>) -> usize {
        SerializedFileReader::new(as_file(&file))
            .unwrap()
            .num_row_groups()
    }

    #[test]
    fn every_path_gives_the_same_bytes_on_one_and_on_four_threads() {
        let bad = [5, 701, 702, 1999];
        let csv_in = csv(3000, &bad);
        let (pq_from_csv, _, _) = run(&csv_in, false, true, 1, false).unwrap();
        assert!(
            row_groups(pq_from_csv.clone()) > 5,
            "CSV chunks: one row group each"
        );
        let pq_in = parquet(3000, &bad, 700);
        // The scored Parquet holds the good rows only.
        for (input, parquet_in, parquet_out, bad) in [
            (&csv_in, false, true, 4),
            (&pq_in, true, true, 4),
            (&pq_in, true, false, 4),
            (&pq_from_csv, true, false, 0),
        ] {
            let (one, bad1, sum1) = run(input, parquet_in, parquet_out, 1, false).unwrap();
            let (four, bad4, sum4) = run(input, parquet_in, parquet_out, 4, false).unwrap();
            assert!(
                one == four,
                "1 and 4 threads differ ({parquet_in} -> {parquet_out})"
            );
            assert_eq!(bad1, bad4);
            assert_eq!(sum1, sum4);
            assert_eq!((sum1.rows_ok, sum1.rows_bad), (2996, bad));
            if parquet_out {
                assert!(row_groups(four) > 5);
            } else {
                let text = String::from_utf8(four).unwrap();
                assert_eq!(text.lines().count(), 2997, "header + good rows");
            }
        }
    }

    #[test]
    fn incompressible_computed_columns_are_stored_plain_and_the_rest_with_snappy() {
        use parquet::basic::Compression;
        let (file, _, summary) = run(&csv(1000, &[]), false, true, 2, false).unwrap();
        assert_eq!(summary.rows_ok, 1000);
        let reader = SerializedFileReader::new(as_file(&file)).unwrap();
        let meta = reader.metadata();
        let mut plain = Vec::new();
        for (k, group) in meta.row_groups().iter().enumerate() {
            for column in group.columns() {
                let name = column.column_path().string();
                let expected = if UNCOMPRESSED_COLUMNS.contains(&name.as_str()) {
                    Compression::UNCOMPRESSED
                } else {
                    Compression::SNAPPY
                };
                assert_eq!(column.compression(), expected, "{name}");
                if k == 0 && expected == Compression::UNCOMPRESSED {
                    plain.push(name);
                }
            }
        }
        assert_eq!(
            plain, UNCOMPRESSED_COLUMNS,
            "every listed column is computed"
        );
    }

    #[test]
    fn bad_rows_in_the_middle_are_reported_in_order_with_their_numbers() {
        let bad = [3, 299, 300, 301, 1234, 2999];
        // CSV: line numbers (header is line 1). Parquet: 1-based row numbers.
        let csv_lines = bad.iter().map(|&k| k as u64 + 2);
        let parquet_rows = bad.iter().map(|&k| k as u64 + 1);
        let columns = |i: usize| match i % 3 {
            0 => "acc_i",
            1 => "vx_j",
            _ => "length_i",
        };
        for threads in [1, 4] {
            let (_, reported, _) = run(&csv(3000, &bad), false, true, threads, false).unwrap();
            let expected: Vec<(u64, Option<String>)> = csv_lines
                .clone()
                .enumerate()
                .map(|(i, l)| (l, Some(columns(i).to_string())))
                .collect();
            assert_eq!(reported, expected, "CSV input, {threads} threads");
            for parquet_out in [true, false] {
                let input = parquet(3000, &bad, 500);
                let (_, reported, _) = run(&input, true, parquet_out, threads, false).unwrap();
                let expected: Vec<(u64, Option<String>)> = parquet_rows
                    .clone()
                    .enumerate()
                    .map(|(i, l)| (l, Some(columns(i).to_string())))
                    .collect();
                assert_eq!(reported, expected, "Parquet input, {threads} threads");
            }
        }
    }

    #[test]
    fn strict_stops_at_the_first_bad_row_of_the_file() {
        let bad = [1700, 2500];
        for threads in [1, 4] {
            for (input, parquet_in, line) in [
                (csv(3000, &bad), false, 1702),
                (parquet(3000, &bad, 400), true, 1701),
            ] {
                match run(&input, parquet_in, true, threads, true) {
                    Err(ColumnarError::Ssm(SsmError::BadRow(e))) => {
                        assert_eq!(e.line, line);
                        assert_eq!(e.column.as_deref(), Some("acc_i"));
                    }
                    other => panic!("expected the bad row, got {:?}", other.map(|r| r.2)),
                }
            }
        }
    }

    #[test]
    fn a_pair_column_of_the_wrong_type_is_named_before_any_row_is_scored() {
        let good = parquet(10, &[], 10);
        let reader = ParquetRecordBatchReaderBuilder::try_new(as_file(&good))
            .unwrap()
            .build()
            .unwrap();
        let batch = reader.into_iter().next().unwrap().unwrap();
        // width_j as text.
        let k = batch.schema().index_of("width_j").unwrap();
        let mut fields = fields_of(&batch);
        fields[k] = Field::new("width_j", arrow_schema::DataType::Utf8, true);
        let mut columns = batch.columns().to_vec();
        columns[k] = Arc::new(StringArray::from(vec!["1.9"; 10]));
        for rows in [10, 0] {
            let b = RecordBatch::try_new(Arc::new(Schema::new(fields.clone())), columns.clone())
                .unwrap()
                .slice(0, rows);
            let mut file = Vec::new();
            let mut w = ArrowWriter::try_new(&mut file, b.schema(), None).unwrap();
            w.write(&b).unwrap();
            w.close().unwrap();
            let err = run(&file, true, true, 4, false).unwrap_err().to_string();
            assert!(err.contains("width_j") && err.contains("Utf8"), "{err}");
        }
    }

    #[test]
    fn a_truncated_parquet_file_is_an_error() {
        let file = parquet(1000, &[], 300);
        for cut in [file.len() - 3, file.len() / 2] {
            for parquet_out in [false, true] {
                let err = run(&file[..cut], true, parquet_out, 2, false).unwrap_err();
                assert!(matches!(err, ColumnarError::Parquet(_)), "{err}");
            }
        }
    }

    /// The table a reader gets back from a Parquet file (its batches concatenated).
    fn read_back(file: &[u8]) -> RecordBatch {
        let reader = ParquetRecordBatchReaderBuilder::try_new(as_file(file))
            .unwrap()
            .build()
            .unwrap();
        let schema = arrow_array::RecordBatchReader::schema(&reader);
        let batches: Vec<RecordBatch> = reader.map(|b| b.unwrap()).collect();
        arrow_select::concat::concat_batches(&schema, &batches).unwrap()
    }

    /// `small_cuts` without copying: every row group is decoded and encoded again, as before
    /// the copying path existed.
    fn encoding_cuts() -> Cutting {
        Cutting {
            raw_max_rows: 0,
            ..small_cuts()
        }
    }

    /// Rows per row group and the codec of column `column` in each.
    fn groups_and_codec(file: &[u8], column: &str) -> Vec<(i64, parquet::basic::Compression)> {
        let reader = SerializedFileReader::new(as_file(file)).unwrap();
        let meta = reader.metadata();
        meta.row_groups()
            .iter()
            .map(|g| {
                let chunk = g
                    .columns()
                    .iter()
                    .find(|c| c.column_path().string() == column)
                    .unwrap();
                (g.num_rows(), chunk.compression())
            })
            .collect()
    }

    /// The pairs of [`pairs_batch`] with pass-through columns of several types, with nulls.
    fn typed_batch(rows: usize, bad: &[usize]) -> RecordBatch {
        use arrow_array::{
            BooleanArray, DictionaryArray, Float32Array, Int64Array, TimestampMillisecondArray,
        };
        use arrow_schema::{DataType, TimeUnit};
        let pairs = pairs_batch(rows, bad);
        let note: StringArray = (0..rows)
            .map(|k| (k % 7 != 3).then(|| format!("note {}", k % 13)))
            .collect();
        let count: Int64Array = (0..rows)
            .map(|k| (k % 5 != 0).then_some(k as i64 * 3 - 700))
            .collect();
        let flag: BooleanArray = (0..rows)
            .map(|k| (k % 4 != 1).then_some(k % 3 == 0))
            .collect();
        let ratio: Float32Array = (0..rows)
            .map(|k| (k % 9 != 2).then_some(k as f32 / 7.0))
            .collect();
        let when = TimestampMillisecondArray::from(
            (0..rows)
                .map(|k| 1_700_000_000_000 + k as i64 * 100)
                .collect::<Vec<_>>(),
        )
        .with_timezone("UTC");
        let lane: DictionaryArray<arrow_array::types::Int32Type> = (0..rows)
            .map(|k| ["left", "middle", "right"][k % 3])
            .collect();
        let mut fields = fields_of(&pairs);
        let mut columns = pairs.columns().to_vec();
        let extra: [(&str, DataType, bool, ArrayRef); 6] = [
            ("note", DataType::Utf8, true, Arc::new(note)),
            ("count", DataType::Int64, true, Arc::new(count)),
            ("flag", DataType::Boolean, true, Arc::new(flag)),
            ("ratio", DataType::Float32, true, Arc::new(ratio)),
            (
                "when",
                DataType::Timestamp(TimeUnit::Millisecond, Some("UTC".into())),
                false,
                Arc::new(when),
            ),
            (
                "lane",
                DataType::Dictionary(Box::new(DataType::Int32), Box::new(DataType::Utf8)),
                false,
                Arc::new(lane),
            ),
        ];
        // Pass-through columns before, between and after the pair columns.
        for (k, (name, data_type, nullable, column)) in extra.into_iter().enumerate() {
            let at = [0, 3, 10, 19, 22, 24][k];
            fields.insert(at, Field::new(name, data_type, nullable));
            columns.insert(at, column);
        }
        RecordBatch::try_new(Arc::new(Schema::new(fields)), columns).unwrap()
    }

    #[test]
    fn copied_row_groups_read_back_equal_to_encoded_ones_and_follow_the_input() {
        use parquet::basic::Compression::{SNAPPY, UNCOMPRESSED};
        // Row groups of 700 rows; rows 5 and 1500 are bad (groups 0 and 2).
        let input = write_parquet(&typed_batch(3000, &[5, 1500]), 700);
        let (encoded, bad_encoded, sum_encoded) =
            run_cut(&input, true, true, 2, false, encoding_cuts()).unwrap();
        for threads in [1, 4] {
            let (copied, bad, summary) = run(&input, true, true, threads, false).unwrap();
            assert_eq!(read_back(&copied), read_back(&encoded), "{threads} threads");
            assert_eq!(
                (bad.clone(), summary),
                (bad_encoded.clone(), sum_encoded.clone())
            );
            assert_eq!(
                bad.iter().map(|b| b.0).collect::<Vec<_>>(),
                [6, 1501],
                "1-based row numbers"
            );
            // The input is uncompressed, so a copied chunk is too; a group with a bad row is
            // encoded again (Snappy) in groups of 300 rows, and so is a computed column.
            let copied_groups = [
                (299, SNAPPY),
                (300, SNAPPY),
                (100, SNAPPY),
                (700, UNCOMPRESSED),
                (299, SNAPPY),
                (300, SNAPPY),
                (100, SNAPPY),
                (700, UNCOMPRESSED),
                (200, UNCOMPRESSED),
            ];
            for column in ["id", "note", "x_i", "when", "lane", "width_j"] {
                assert_eq!(groups_and_codec(&copied, column), copied_groups, "{column}");
            }
            let computed = groups_and_codec(&copied, "ttc2d");
            assert!(computed.iter().all(|&(_, c)| c == SNAPPY), "{computed:?}");
        }
        let (one, _, _) = run(&input, true, true, 1, false).unwrap();
        let (four, _, _) = run(&input, true, true, 4, false).unwrap();
        assert!(one == four, "1 and 4 threads differ");
    }

    #[test]
    fn strict_stops_at_a_bad_row_inside_a_copied_row_group() {
        let input = write_parquet(&typed_batch(3000, &[1234, 2500]), 700);
        for threads in [1, 4] {
            match run(&input, true, true, threads, true) {
                Err(ColumnarError::Ssm(SsmError::BadRow(e))) => {
                    assert_eq!((e.line, e.column.as_deref()), (1235, Some("acc_i")));
                }
                other => panic!("expected the bad row, got {:?}", other.map(|r| r.2)),
            }
        }
        let (_, bad, summary) = run(&input, true, true, 4, false).unwrap();
        assert_eq!(bad.iter().map(|b| b.0).collect::<Vec<_>>(), [1235, 2501]);
        assert_eq!((summary.rows_ok, summary.rows_bad), (2998, 2));
    }

    #[test]
    fn a_row_group_larger_than_the_copy_limit_is_encoded_again_in_smaller_groups() {
        use parquet::basic::Compression::SNAPPY;
        // One group of 2,500 rows (over the limit of 1,000), then one of 500 (copied).
        let batch = typed_batch(3000, &[]);
        let props = parquet::file::properties::WriterProperties::builder()
            .set_max_row_group_row_count(Some(2500))
            .build();
        let mut input = Vec::new();
        let mut writer = ArrowWriter::try_new(&mut input, batch.schema(), Some(props)).unwrap();
        writer.write(&batch).unwrap();
        writer.close().unwrap();
        let (encoded, _, _) = run_cut(&input, true, true, 1, false, encoding_cuts()).unwrap();
        let (one, _, summary) = run(&input, true, true, 1, false).unwrap();
        let (four, _, _) = run(&input, true, true, 4, false).unwrap();
        assert!(one == four, "1 and 4 threads differ");
        assert_eq!(summary.rows_ok, 3000);
        assert_eq!(read_back(&one), read_back(&encoded));
        let mut expected = vec![(300, SNAPPY); 8];
        expected.push((100, SNAPPY));
        expected.push((500, parquet::basic::Compression::UNCOMPRESSED));
        assert_eq!(groups_and_codec(&one, "note"), expected);
    }

    #[test]
    fn an_empty_parquet_file_gives_an_empty_file_with_every_column() {
        let input = write_parquet(&typed_batch(0, &[]), 700);
        let (copied, bad, summary) = run(&input, true, true, 2, false).unwrap();
        let (encoded, _, _) = run_cut(&input, true, true, 2, false, encoding_cuts()).unwrap();
        assert!(bad.is_empty());
        assert_eq!((summary.rows_ok, summary.rows_bad), (0, 0));
        assert_eq!(row_groups(copied.clone()), 0);
        let table = read_back(&copied);
        assert_eq!(table, read_back(&encoded));
        assert_eq!(table.num_rows(), 0);
        assert_eq!(table.num_columns(), 25 + 17);
    }

    /// Pairs with a legacy INT96 timestamp column (Spark's), which Arrow reads as a nanosecond
    /// timestamp and the output stores as INT64: a column the output types differently.
    fn int96_parquet(rows: usize) -> Vec<u8> {
        use parquet::data_type::{DoubleType, Int96, Int96Type};
        use parquet::file::writer::SerializedFileWriter;
        let pairs = pairs_batch(rows, &[]);
        let mut message = "message pairs { required int96 seen;".to_string();
        for field in pairs.schema().fields().iter().skip(1) {
            message += &format!(" required double {};", field.name());
        }
        message += " }";
        let schema = Arc::new(parquet::schema::parser::parse_message_type(&message).unwrap());
        let mut out = Vec::new();
        let mut writer = SerializedFileWriter::new(&mut out, schema, Default::default()).unwrap();
        for start in (0..rows).step_by(400) {
            let end = (start + 400).min(rows);
            let mut group = writer.next_row_group().unwrap();
            let mut column = group.next_column().unwrap().unwrap();
            let seen: Vec<Int96> = (start..end)
                .map(|k| {
                    let mut v = Int96::new();
                    // Nanoseconds of the day (two words), Julian day.
                    v.set_data(k as u32 * 1000, 0, 2_460_000 + (k % 3) as u32);
                    v
                })
                .collect();
            column
                .typed::<Int96Type>()
                .write_batch(&seen, None, None)
                .unwrap();
            column.close().unwrap();
            for c in 1..pairs.num_columns() {
                let values = pairs.column(c).as_any().downcast_ref::<Float64Array>();
                let values = &values.unwrap().values()[start..end];
                let mut column = group.next_column().unwrap().unwrap();
                column
                    .typed::<DoubleType>()
                    .write_batch(values, None, None)
                    .unwrap();
                column.close().unwrap();
            }
            group.close().unwrap();
        }
        writer.close().unwrap();
        out
    }

    #[test]
    fn a_pass_through_column_the_output_types_differently_is_encoded_again_beside_copies() {
        use parquet::basic::{Compression, Type};
        let input = int96_parquet(1000);
        let (copied, _, summary) = run(&input, true, true, 2, false).unwrap();
        let (encoded, _, _) = run_cut(&input, true, true, 2, false, encoding_cuts()).unwrap();
        assert_eq!(summary.rows_ok, 1000);
        let table = read_back(&copied);
        assert_eq!(table, read_back(&encoded));
        assert!(matches!(
            table.schema().field(0).data_type(),
            arrow_schema::DataType::Timestamp(arrow_schema::TimeUnit::Nanosecond, _)
        ));
        let reader = SerializedFileReader::new(as_file(&copied)).unwrap();
        for group in reader.metadata().row_groups() {
            let seen = group.column(0);
            assert_eq!(seen.column_type(), Type::INT64, "encoded again");
            assert_eq!(seen.compression(), Compression::SNAPPY);
            let x = group.column(1);
            assert_eq!(x.compression(), Compression::UNCOMPRESSED, "copied");
        }
        let sizes: Vec<i64> = reader
            .metadata()
            .row_groups()
            .iter()
            .map(|g| g.num_rows())
            .collect();
        assert_eq!(sizes, [400, 400, 200]);
    }

    #[test]
    fn a_copied_chunk_keeps_the_input_page_index_pointing_at_its_new_place() {
        use parquet::arrow::arrow_reader::{ArrowReaderOptions, RowSelection, RowSelector};
        use parquet::file::metadata::PageIndexPolicy;
        // Pages of 100 rows, with the page index the parquet crate writes by default.
        let batch = typed_batch(3000, &[]);
        let props = parquet::file::properties::WriterProperties::builder()
            .set_max_row_group_row_count(Some(700))
            .set_data_page_row_count_limit(100)
            .set_write_batch_size(50)
            .build();
        let mut input = Vec::new();
        let mut writer = ArrowWriter::try_new(&mut input, batch.schema(), Some(props)).unwrap();
        writer.write(&batch).unwrap();
        writer.close().unwrap();
        let (copied, _, _) = run(&input, true, true, 2, false).unwrap();
        assert_eq!(
            groups_and_codec(&copied, "note")[1],
            (700, parquet::basic::Compression::UNCOMPRESSED),
            "copied"
        );
        let options = ArrowReaderOptions::new().with_page_index_policy(PageIndexPolicy::Required);
        let builder =
            ParquetRecordBatchReaderBuilder::try_new_with_options(as_file(&copied), options)
                .unwrap();
        let index = builder.metadata().page_index().expect("a page index");
        let columns = builder.parquet_schema().columns();
        let note = columns.iter().position(|c| c.name() == "note").unwrap();
        let pages = index.offset_index(1, note).unwrap().page_locations().len();
        assert!(
            pages >= 7,
            "{pages} pages in the copied chunk's offset index"
        );
        // A selection that the reader serves from the offset index: only the pages it needs,
        // read at the offsets the index gives.
        let selection = RowSelection::from(vec![RowSelector::skip(1250), RowSelector::select(300)]);
        let reader = builder.with_row_selection(selection).build().unwrap();
        let batches: Vec<RecordBatch> = reader.map(|b| b.unwrap()).collect();
        let selected =
            arrow_select::concat::concat_batches(&batches[0].schema(), &batches).unwrap();
        assert_eq!(selected, read_back(&copied).slice(1250, 300));
    }

    #[test]
    fn a_copied_chunk_whose_page_header_is_damaged_is_an_error_naming_it() {
        let mut file = parquet(1000, &[], 300);
        let reader = SerializedFileReader::new(as_file(&file)).unwrap();
        let (start, _) = reader.metadata().row_group(1).column(0).byte_range();
        // A field of type 0, which is no Thrift type: the page cannot be walked.
        file[start as usize] = 0x10;
        let err = run(&file, true, true, 2, false).unwrap_err().to_string();
        assert!(
            err.contains("row group 1 (counting from 0), column id: its pages cannot be read"),
            "{err}"
        );
    }
}
