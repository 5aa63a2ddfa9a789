//! `riskctl ssm`: surrogate safety measures and features for a CSV of ego/partner pairs.
use anyhow::{bail, Context};
use riskscore_data::ssm_csv::{
    score_csv, RowError, SsmError, SsmOptions, SsmSummary, DEFAULT_MAX_RECORD_BYTES,
};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use super::output::{is_dash, write_output};

const AFTER_LONG_HELP: &str = "\
INPUT COLUMNS (header names matched case-insensitively, any order):
  x_i, y_i            ego box centre (m, world frame)
  vx_i, vy_i          ego velocity (m/s)
  hx_i, hy_i          ego heading vector (any non-zero length; normalised)
  acc_i               ego longitudinal acceleration (m/s^2)
  length_i, width_i   ego box size (m, >= 0)
  ... and the same nine with suffix _j for the partner.
  Any other column is copied to the output unchanged, in its original position.

OUTPUT COLUMNS (appended after the input columns):
  box_distance  exact gap between the two boxes (m), 0 when they touch or overlap
  ttc2d         two-dimensional time-to-collision (s); inf = no conflict; smaller is riskier
  tadv          time advantage (s); inf = no conflict; smaller is riskier. Near-parallel
                pairs with no closing speed (same-speed following, both stopped) give a
                huge finite value, box distance / 1e-6 (about 1e7 s), exactly as the
                reference implementation does (golden cases same_velocity, both_stopped)
  ei            emergency index (m/s); -inf = no conflict; larger is riskier
  f_l_ego f_l_sur f_w_comb f_vy_ego f_vx_sur f_vy_sur f_v_ego2 f_v_sur2 f_delta_v2 f_delta_v
  f_psi_sur f_rho f_s
                the 13 model features in model-input order (see tests/data/golden_README.md)
  Values are computed in f32 by scorer-core, exactly as on the ECU, and written in the
  shortest form that reads back to the same f32. Positions are first made relative to the
  ego (in f64), so large world coordinates such as UTM keep centimetre precision.

BAD ROWS:
  A row with a missing or empty pair field, a value that is not a finite number, a zero
  heading vector, a negative length/width, or too many fields is reported on stderr with its
  line number and column, and skipped. So is a line longer than --max-line-bytes (default
  1 MiB; skipped without being held in memory) and a quoted field that is never closed (only
  the line where it starts is lost; reading resumes on the next line). Line numbers count
  every line of the file, blank ones included. Pass-through columns and the header are copied
  byte for byte to CSV output, in any encoding; nothing is ever replaced by U+FFFD.

  The first --show-bad messages of each kind of problem are printed (default 10), then a
  count per kind. With --strict the first bad row stops the run with exit status 1 and no
  output file is left behind. A summary (rows ok / rows bad) is printed on stderr at the end.

  The file is streamed in chunks of whole rows, scored in parallel (--threads, default one
  per core) and written in input order, so memory use does not depend on its size. A regular
  output file is written to a unique hidden temporary beside it and renamed when complete;
  an output that is the input is refused, and so is a second run writing the same output.

PARQUET:
  An input or output path ending in .parquet is Apache Parquet, anything else CSV (any mix).
  Same columns: the input columns, then the 17 computed ones (Float32). From CSV, the 18 pair
  columns become Float64 and every other column a UTF-8 string (Parquet strings must be UTF-8:
  a row whose pass-through text is not is reported with its line and column and skipped, and a
  header name that is not stops the run; write CSV output to keep such bytes, or convert the
  input with iconv); from Parquet the pair columns may be Float64, Float32, Int64 or Int32 and
  other columns keep their type. Bad rows are reported
  with their row number (Parquet input). Page checksums (CRC-32, when the writer stored them) are
  verified: a damaged page stops the run, naming the row group and column, with no output
  written. A missing pair column, a pair column that is not numeric and a damaged or truncated
  file stop the run before anything is written, naming the column or the file.

  The Parquet paths use every core too (--threads): the file is read in batches of 65,536 rows
  (16,384 for CSV output), or chunks of 8 MiB for CSV input, which are scored and encoded in
  parallel and written in input order; the output is the same byte for byte whatever
  --threads is, and memory stays bounded (a few batches) whatever the file size. Parquet
  output gets one row group per batch or chunk, but Parquet -> Parquet keeps the input's row
  groups: each of up to 262,144 rows whose rows are all good is written as one row group whose
  input columns are the input's column chunks copied as they are (same codec and encodings;
  only the pair columns are decoded) followed by the 17 computed ones. A row group with a bad
  row, or a larger one, is encoded again in row groups of 65,536 rows.

EXAMPLES:
  riskctl ssm --input pairs.csv --output pairs_ssm.csv
  riskctl ssm --input pairs.parquet --output pairs_ssm.parquet
  riskctl ssm --input pairs.csv --output pairs_ssm.csv --strict
  zcat pairs.csv.gz | riskctl ssm --input - --output - | less -S";

/// Compute box distance, TTC2D, TAdv, EI and the 13 features for every ego/partner row of a CSV.
#[derive(clap::Args, Debug)]
#[command(after_long_help = AFTER_LONG_HELP)]
pub struct Args {
    /// Input CSV (or .parquet) with the x_i ... width_j pair columns; '-' reads standard input.
    #[arg(long, short, value_name = "FILE")]
    pub input: PathBuf,
    /// Output CSV (or .parquet): input columns + surrogates + f_ features; '-' writes stdout.
    #[arg(long, short, value_name = "FILE")]
    pub output: PathBuf,
    /// Stop with an error (exit status 1) at the first bad row instead of skipping it.
    #[arg(long)]
    pub strict: bool,
    /// Longest accepted line (bytes, 1 to 1 GiB); longer lines are reported and skipped.
    #[arg(long, value_name = "BYTES", default_value_t = DEFAULT_MAX_RECORD_BYTES)]
    pub max_line_bytes: usize,
    /// Messages printed per kind of bad row; the rest are counted in the summary.
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub show_bad: u64,
    /// Worker threads (0 = one per core; at most 4 per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub threads: usize,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let input_name = if is_dash(&args.input) {
        "<stdin>".to_string()
    } else {
        args.input.display().to_string()
    };
    check_sizes(&args)?;
    let options = SsmOptions {
        strict: args.strict,
        max_record_bytes: args.max_line_bytes,
        threads: args.threads,
    };
    let mut report = BadRowReport::new(args.show_bad);
    super::output::refuse(&[("--input", &args.input)], &[("--output", &args.output)])?;
    super::output::refuse_overwriting_a_model("--output", &args.output, "a table")?;
    let columnar = is_parquet(&args.input) || is_parquet(&args.output);
    let summary = write_output(&args.output, |out| {
        let summary = if columnar {
            run_columnar(&args, out, options, &input_name, &mut report)?
        } else {
            let input: Box<dyn Read> = if is_dash(&args.input) {
                Box::new(std::io::stdin().lock())
            } else {
                Box::new(
                    File::open(&args.input)
                        .with_context(|| format!("cannot open input {}", args.input.display()))?,
                )
            };
            stream(input, out, options, &input_name, &mut report)?
        };
        refuse_empty_output(&summary, &input_name, &args.output)?;
        Ok(summary)
    })?;
    // None: our stdout reader went away (`| head`); stop quietly, like other filters.
    let Some(summary) = summary else {
        return Ok(());
    };
    report.print_hidden(&input_name);
    if !summary.duplicated_columns.is_empty() {
        eprintln!(
            "riskctl ssm: note: the input already has column(s) {}; the output keeps the input's \
             copy and appends the computed one after it",
            summary.duplicated_columns.join(", ")
        );
    }
    eprintln!(
        "riskctl ssm: {}: {} rows ok, {} rows bad{}",
        input_name,
        summary.rows_ok,
        summary.rows_bad,
        if summary.rows_bad > 0 {
            " (skipped)"
        } else {
            ""
        }
    );
    Ok(())
}

/// A run without one good row has nothing to write: an existing output is left as it was (the
/// error drops the temporary) rather than replaced by a bare header.
fn refuse_empty_output(
    summary: &SsmSummary,
    input_name: &str,
    output: &Path,
) -> anyhow::Result<()> {
    if summary.rows_ok > 0 {
        return Ok(());
    }
    let untouched = if is_dash(output) {
        String::from("only the header was written")
    } else {
        super::output::left_alone(output)
    };
    if summary.rows_bad > 0 {
        bail!(
            "no valid row in {input_name} ({} bad rows): nothing written, {untouched}",
            summary.rows_bad
        );
    }
    bail!("{input_name} has no data row: nothing written, {untouched}");
}

/// The longest line `--max-line-bytes` accepts: 1 GiB, a thousand times the default. A line is
/// held whole until it ends, so the limit is also what one line may cost in memory.
const MAX_LINE_BYTES_CAP: usize = 1 << 30;

/// Thread count and line length checked before any thread starts or any byte is read.
fn check_sizes(args: &Args) -> anyhow::Result<()> {
    use riskscore_data::limits::{check_cap, check_memory, check_threads};
    check_threads("--threads", args.threads)?;
    if args.max_line_bytes == 0 {
        anyhow::bail!("--max-line-bytes 0: every line would be too long (at least 1 byte)");
    }
    let line = args.max_line_bytes as u128;
    check_cap(
        "--max-line-bytes",
        line,
        MAX_LINE_BYTES_CAP as u128,
        "1 GiB: a line is held in memory whole",
    )?;
    // The line being read, and its copy in the chunk handed to a worker.
    check_memory(
        "--max-line-bytes",
        line,
        (args.max_line_bytes as u64).saturating_mul(2),
    )?;
    Ok(())
}

fn is_parquet(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// Parquet in and/or out, through the Arrow kernel.
#[cfg(feature = "parquet")]
fn run_columnar(
    args: &Args,
    out: Box<dyn Write + Send>,
    options: SsmOptions,
    input_name: &str,
    report: &mut BadRowReport,
) -> anyhow::Result<SsmSummary> {
    use riskscore_eval::parquet_io::{ssm_columnar, BatchSink, ColumnarInput};
    let input = if is_parquet(&args.input) {
        ColumnarInput::Parquet(
            File::open(&args.input)
                .with_context(|| format!("cannot open input {}", args.input.display()))?,
        )
    } else if is_dash(&args.input) {
        ColumnarInput::Csv(Box::new(std::io::stdin()) as Box<dyn Read>)
    } else {
        ColumnarInput::Csv(Box::new(
            File::open(&args.input)
                .with_context(|| format!("cannot open input {}", args.input.display()))?,
        ) as Box<dyn Read>)
    };
    let sink = if is_parquet(&args.output) {
        BatchSink::parquet(out)
    } else {
        BatchSink::csv(out)
    };
    let unit = if is_parquet(&args.input) {
        "row"
    } else {
        "line"
    };
    ssm_columnar(input, sink, options, |bad| {
        report.bad_row(input_name, &bad.to_string().replacen("line", unit, 1), bad)
    })
    .map_err(|e| match e {
        riskscore_eval::parquet_io::ColumnarError::Ssm(SsmError::BadRow(bad)) => anyhow::anyhow!(
            "{input_name}: {} (--strict: stopping at the first bad row)",
            bad.to_string().replacen("line", unit, 1)
        ),
        e => anyhow::Error::new(e).context(format!("processing {input_name}")),
    })
}

#[cfg(not(feature = "parquet"))]
fn run_columnar(
    _: &Args,
    _: Box<dyn Write + Send>,
    _: SsmOptions,
    _: &str,
    _: &mut BadRowReport,
) -> anyhow::Result<SsmSummary> {
    anyhow::bail!("this riskctl was built without Parquet support (cargo feature `parquet`)")
}

/// Prints the first few bad rows of each kind and counts the rest, so a file of millions of bad
/// rows does not flood stderr.
struct BadRowReport {
    show: u64,
    /// Per kind: rows seen.
    seen: BTreeMap<&'static str, u64>,
}

impl BadRowReport {
    fn new(show: u64) -> Self {
        Self {
            show,
            seen: BTreeMap::new(),
        }
    }

    fn bad_row(&mut self, input_name: &str, message: &str, bad: &RowError) {
        let seen = self.seen.entry(bad.problem.kind()).or_default();
        *seen += 1;
        if *seen <= self.show {
            eprintln!("riskctl ssm: {input_name}: {message} (row skipped)");
        }
    }

    fn print_hidden(&self, input_name: &str) {
        for (kind, &seen) in &self.seen {
            if seen > self.show {
                eprintln!(
                    "riskctl ssm: {input_name}: {} more row(s) skipped for \"{kind}\" (not shown; \
                     --show-bad N shows more)",
                    seen - self.show
                );
            }
        }
    }
}

fn stream<R: Read, W: Write>(
    input: R,
    output: W,
    options: SsmOptions,
    input_name: &str,
    report: &mut BadRowReport,
) -> anyhow::Result<riskscore_data::ssm_csv::SsmSummary> {
    let result = score_csv(input, output, options, |bad| {
        report.bad_row(input_name, &bad.to_string(), bad)
    });
    match result {
        Ok(summary) => Ok(summary),
        Err(SsmError::BadRow(bad)) => {
            anyhow::bail!("{input_name}: {bad} (--strict: stopping at the first bad row)")
        }
        Err(e) => Err(anyhow::Error::new(e).context(format!("processing {input_name}"))),
    }
}
