//! `riskctl score`: the per-frame risk of every event under each model, plus the surrogates, as
//! one table a user can plot (CSV, or Parquet when the output ends in `.parquet`).
use std::path::{Path, PathBuf};

use anyhow::Context;
use riskscore_data::events::{load_events, EventsError, LoadIssue};
use riskscore_eval::parquet_io::{is_parquet, BatchSink};
use riskscore_eval::score_table::{score_streaming, score_whole, ScoreTableError, ScoredFolder};

use riskscore_eval::model_files::{named_models, ModelFile};

use super::evaluate::{report_issues, report_load_issues};
use super::output::{is_stdout, write_output};

const AFTER_LONG_HELP: &str = "\
OUTPUT COLUMNS (one row per frame, events in folder order, frames in time order):
  event_id      the event's id (events.csv)
  time          frame time (s, the event's clock)
  class         crash | near_crash | safe
  <model>...    each model's risk score R(o), one column per --model, named like the rows of
                `riskctl evaluate` (DRL, MSRA, GSSM, SSRA, or NAME from NAME=FILE); larger is
                riskier. Scored exactly as on the ECU (DRL through the int8 network).
  ttc2d tadv ei the published surrogates of the frame (s, s, m/s); inf / -inf = no conflict.
  tadv_corridor TAdv under the corridor rule (s; a road user under 0.5 m/s counts as standing,
                and a standing one wholly beside the mover's path is no conflict: inf), which
                MSRA terms and kinematic fallbacks may read (docs/training.md).
  <model>_in_domain
                for each model whose blob carries a training domain (`riskctl calibrate-domain`,
                docs/domain-guard.md): 1 when the frame lies inside the input ranges its
                training data covered and, where the blob records geometry cells, in a cell
                (gap band, partner's bearing and heading) its training data covered; 0 outside
                (`riskctl inspect-model` prints the ranges and how many cells are covered). Its score column is then the guarded score
                (the blob's policy: flag-only scores as without the record, clamp scores the
                inputs moved into their ranges, fallback the kinematic fallback outside; blend,
                the shipped DRL's, also mixes that fallback into the score inside).

By default every frame of every event is scored. With --sequences only the frames of the
evaluation sequences are (the windows `riskctl evaluate` scores: docs/evaluation.md).

An output path ending in .parquet is written as Apache Parquet (event_id and class strings,
time Float64, scores and surrogates Float32); anything else as CSV ('-' = standard output).
An --out that is a model blob or a training checkpoint is refused and left as it is.
Problems in the event folder are listed on stderr; the valid events are still scored.

Memory: with --out FILE the folder is read and scored one event at a time, so memory is one
event whatever the folder's size. To '-', a pipe or a device, or when an event's frames are not
one run of consecutive rows in events.csv order, the folder is read whole first.

EXAMPLES:
  riskctl score --model models/drl-default.rsk --model models/msra-default.rsk \\
                --events data/sim --out scores.csv
  riskctl score --model MINE=run/drl.rsk --events data/sim --out scores.parquet";

/// Write every frame's risk score under each model, with TTC2D/TAdv/EI/TAdv-corridor, to a CSV or
/// Parquet table.
#[derive(clap::Args, Debug)]
#[command(after_long_help = AFTER_LONG_HELP)]
pub struct Args {
    /// Model blob to score with (repeatable); `NAME=FILE` names its column.
    #[arg(long = "model", value_name = "[NAME=]FILE", required = true)]
    models: Vec<String>,
    /// Event folder (events.csv + frames.csv, see docs/event-format.md).
    #[arg(long, value_name = "DIR")]
    events: PathBuf,
    /// Output table: .parquet for Parquet, anything else CSV; '-' writes standard output.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Score only the evaluation sequences' frames instead of every frame of every event.
    #[arg(long)]
    sequences: bool,
}

/// The library's [`ScoreTableError::NoEvents`] for a folder read whole, after listing why.
fn no_events_is_an_error(dir: &Path, events: usize, issues: &[LoadIssue]) -> anyhow::Result<()> {
    if events == 0 {
        report_load_issues(issues);
        return Err(ScoreTableError::NoEvents {
            dir: dir.to_path_buf(),
            load_issues: issues.to_vec(),
        }
        .into());
    }
    Ok(())
}

fn sink<W: std::io::Write + Send>(out: W, parquet: bool) -> BatchSink<W> {
    if parquet {
        BatchSink::parquet(out)
    } else {
        BatchSink::csv(out)
    }
}

/// True for an output that can be written twice: a regular file (written to a temporary and
/// renamed), not standard output under any of its names (`/dev/stdout` redirected to a file is
/// a regular file too), a descriptor path, a pipe or a device, where a discarded first attempt
/// would already have been read.
fn restartable(out: &Path) -> bool {
    !is_stdout(out)
        && !riskscore_output::is_special_file(out)
        && std::fs::metadata(out).map_or(true, |m| m.is_file())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Models first: a bad model file is found before a large event folder is read.
    let files = ModelFile::read_all(&args.models)?;
    let methods = named_models(&files)?;
    let dir = &args.events;
    super::output::refuse_overwriting_inputs(&files, dir, &[("--out", &args.out)])?;
    // A model of the user's that is not one of the --model files (`--out run/msra.rsk`).
    super::output::refuse_overwriting_a_model("--out", &args.out, "a score table")?;
    let parquet = is_parquet(&args.out);

    let mut scored = None;
    if restartable(&args.out) {
        match write_output(&args.out, |out| {
            score_streaming(dir, &methods, args.sequences, sink(out, parquet)).map_err(|e| {
                if let ScoreTableError::NoEvents { load_issues, .. } = &e {
                    report_load_issues(load_issues);
                }
                anyhow::Error::from(e)
            })
        }) {
            Err(e) if not_streamable(&e) => {
                eprintln!("riskctl score: {e:#}: reading the folder whole instead");
            }
            other => scored = Some(other?),
        }
    }
    let scored = match scored {
        Some(scored) => scored,
        None => {
            let (set, load_issues) =
                load_events(dir).with_context(|| format!("event folder {}", dir.display()))?;
            no_events_is_an_error(dir, set.len(), &load_issues)?;
            report_load_issues(&load_issues);
            let events = set.len();
            write_output(&args.out, |out| {
                Ok(score_whole(
                    set,
                    &methods,
                    args.sequences,
                    sink(out, parquet),
                )?)
            })?
            .map(|(rows, prepare_issues)| ScoredFolder {
                rows,
                events,
                load_issues: Vec::new(), // listed above, before the table
                prepare_issues,
            })
        }
    };
    if let Some(scored) = scored {
        report_load_issues(&scored.load_issues);
        report_issues(
            "event(s) yield no sequence under the preparation rules",
            &scored.prepare_issues,
        );
        eprintln!(
            "riskctl score: {} frames of {} events scored with {} model(s) -> {}",
            scored.rows,
            scored.events,
            methods.len(),
            args.out.display()
        );
    }
    Ok(())
}

/// True when `e` is [`EventsError::NotStreamable`].
fn not_streamable(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        matches!(
            cause.downcast_ref::<EventsError>(),
            Some(EventsError::NotStreamable { .. })
        )
    })
}
