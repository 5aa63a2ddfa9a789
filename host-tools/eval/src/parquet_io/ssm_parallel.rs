//! `riskctl ssm` where the input or the output (or both) is Parquet, on every core.
//!
//! The calling thread reads (decodes Parquet batches in file order, or cuts CSV into chunks of
//! whole records) and writes; `threads` workers parse (CSV), score with the Arrow kernel and
//! encode (a Parquet row group, or CSV text). Results are written in input order and at most
//! `2 x threads + 2` jobs are in flight ([`super::ordered`]), so memory does not grow with the
//! file. How the input is cut does not depend on the thread count (Parquet: batches of a fixed
//! number of rows; CSV: chunks of a fixed number of bytes), and each piece of output depends only
//! on its own rows, so the output is byte-identical whatever `--threads` is.
use std::io::{Read, Write};
use std::sync::Arc;

use arrow_array::RecordBatch;
use arrow_schema::{Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::arrow_writer::ArrowColumnChunk;

use super::csv_batches::{CsvLayout, CsvRows};
use super::ordered::ordered_map;
use super::row_groups::{row_group_file, RowGroupEncoder, RowGroupFile};
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
}

impl Default for Cutting {
    fn default() -> Self {
        Self {
            rows_to_parquet: 64 * 1024,
            rows_to_csv: 16 * 1024,
            // About 47,000 rows of the 23-column NGSIM pairs.
            csv_chunk_bytes: 8 << 20,
        }
    }
}

/// One job: rows to score.
enum Job {
    /// Decoded Parquet rows; `first_row` counts the rows before them (for row numbers).
    Batch { batch: RecordBatch, first_row: u64 },
    /// Whole CSV records, not parsed yet.
    Chunk(Chunk),
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
    strict: bool,
}

impl Scoring<'_> {
    fn score(&self, rows: &mut CsvRows, job: Job, index: usize) -> Result<Scored, ColumnarError> {
        let mut bad = Vec::new();
        let (batch, first_row) = match job {
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

/// A strict-mode job that stopped at its first bad row (nothing of it is written).
fn stopped(bad: Vec<RowError>) -> Scored {
    Scored {
        rows_ok: 0,
        bad,
        out: Encoded::Nothing,
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
    let mut csv_in = None;
    let mut csv_layout = None;
    let (columns, input_schema) = match input {
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
    let mut output = if parquet_out {
        let (file, row_groups) = row_group_file(out, schema.clone())?;
        encoder = Some(row_groups);
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
        strict: options.strict,
    };
    let (mut first_row, mut index) = (0u64, 0usize);
    let produce = || -> Result<Option<(Job, usize)>, ColumnarError> {
        let job = if let Some((reader, file)) = parquet_in.as_mut() {
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
        let batch = RecordBatch::try_new(Arc::new(Schema::new(fields)), columns).unwrap();
        let props = parquet::file::properties::WriterProperties::builder()
            .set_max_row_group_row_count(Some(group))
            .build();
        let mut out = Vec::new();
        let mut writer = ArrowWriter::try_new(&mut out, batch.schema(), Some(props)).unwrap();
        writer.write(&batch).unwrap();
        writer.close().unwrap();
        out
    }

    fn small_cuts() -> Cutting {
        Cutting {
            rows_to_parquet: 300,
            rows_to_csv: 170,
            csv_chunk_bytes: 16 << 10,
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
        let summary = ssm_columnar_cut(input, sink, options, small_cuts(), |e| {
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
        let mut fields: Vec<Field> = batch
            .schema()
            .fields()
            .iter()
            .map(|f| f.as_ref().clone())
            .collect();
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
            let err = run(&file[..cut], true, false, 2, false).unwrap_err();
            assert!(matches!(err, ColumnarError::Parquet(_)), "{err}");
        }
    }
}
