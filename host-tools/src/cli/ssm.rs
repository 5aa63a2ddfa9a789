//! `riskctl ssm`: surrogate safety measures and features for a CSV of ego/partner pairs.
use anyhow::Context;
use host_tools::ssm_csv::{score_csv, SsmError, SsmOptions};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

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
  tadv          time advantage (s); inf = no conflict; smaller is riskier
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
  line number and column, and skipped. With --strict the first bad row stops the run with
  exit status 1 and no output file is left behind. A summary (rows ok / rows bad) is
  printed on stderr at the end.

  The file is streamed one row at a time, so memory use does not depend on its size. A
  regular output file is written to <OUTPUT>.partial and renamed when complete.

EXAMPLES:
  riskctl ssm --input pairs.csv --output pairs_ssm.csv
  riskctl ssm --input pairs.csv --output pairs_ssm.csv --strict
  zcat pairs.csv.gz | riskctl ssm --input - --output - | less -S";

/// Compute box distance, TTC2D, TAdv, EI and the 13 features for every ego/partner row of a CSV.
#[derive(clap::Args, Debug)]
#[command(after_long_help = AFTER_LONG_HELP)]
pub struct Args {
    /// Input CSV with the x_i ... width_j pair columns; '-' reads standard input.
    #[arg(long, short, value_name = "FILE")]
    pub input: PathBuf,
    /// Output CSV (input columns + surrogates + f_ features); '-' writes standard output.
    #[arg(long, short, value_name = "FILE")]
    pub output: PathBuf,
    /// Stop with an error (exit status 1) at the first bad row instead of skipping it.
    #[arg(long)]
    pub strict: bool,
}

fn is_dash(p: &Path) -> bool {
    p.as_os_str() == "-"
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let input_name = if is_dash(&args.input) {
        "<stdin>".to_string()
    } else {
        args.input.display().to_string()
    };
    let input: Box<dyn Read> = if is_dash(&args.input) {
        Box::new(std::io::stdin().lock())
    } else {
        let f = File::open(&args.input)
            .with_context(|| format!("cannot open input {}", args.input.display()))?;
        Box::new(BufReader::new(f))
    };
    let options = SsmOptions {
        strict: args.strict,
    };

    let summary = if is_dash(&args.output) {
        let out = std::io::stdout().lock();
        match stream(input, out, options, &input_name) {
            Ok(summary) => summary,
            // The reader of our stdout went away (`| head`): stop quietly, like other filters.
            Err(e) if is_broken_pipe(&e) => return Ok(()),
            Err(e) => return Err(e),
        }
    } else if is_special_file(&args.output) {
        // A device or pipe (e.g. /dev/null): write straight into it, nothing to rename.
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(&args.output)
            .with_context(|| format!("cannot open output {}", args.output.display()))?;
        stream(input, BufWriter::new(file), options, &input_name)?
    } else {
        let partial = partial_path(&args.output);
        let file = File::create(&partial)
            .with_context(|| format!("cannot create output {}", partial.display()))?;
        match stream(input, BufWriter::new(file), options, &input_name) {
            Ok(summary) => {
                std::fs::rename(&partial, &args.output).with_context(|| {
                    format!(
                        "cannot move {} to {}",
                        partial.display(),
                        args.output.display()
                    )
                })?;
                summary
            }
            Err(e) => {
                // Never leave a half-written file that looks like a result.
                let _ = std::fs::remove_file(&partial);
                return Err(e);
            }
        }
    };
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

/// True when the error comes from writing to a closed pipe.
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    let broken = |io: &std::io::Error| io.kind() == std::io::ErrorKind::BrokenPipe;
    e.chain().any(|cause| {
        cause.downcast_ref::<std::io::Error>().is_some_and(broken)
            || cause
                .downcast_ref::<csv::Error>()
                .is_some_and(|c| matches!(c.kind(), csv::ErrorKind::Io(io) if broken(io)))
    })
}

/// True when `path` exists and is not a regular file (a device, FIFO or socket).
fn is_special_file(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// `<output>.partial` next to the output file.
fn partial_path(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

fn stream<R: Read, W: Write>(
    input: R,
    output: W,
    options: SsmOptions,
    input_name: &str,
) -> anyhow::Result<host_tools::ssm_csv::SsmSummary> {
    let result = score_csv(input, output, options, |bad| {
        eprintln!("riskctl ssm: {input_name}: {bad} (row skipped)");
    });
    match result {
        Ok(summary) => Ok(summary),
        Err(SsmError::BadRow(bad)) => {
            anyhow::bail!("{input_name}: {bad} (--strict: stopping at the first bad row)")
        }
        Err(e) => Err(anyhow::Error::new(e).context(format!("processing {input_name}"))),
    }
}
