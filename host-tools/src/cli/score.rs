//! `riskctl score`: the per-frame risk of every event under each model, plus the surrogates, as
//! one table a user can plot (CSV, or Parquet when the output ends in `.parquet`).
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{bail, Context};
use arrow_array::builder::{Float32Builder, Float64Builder, StringBuilder};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use host_tools::eval::{observe, Method};
use host_tools::events::{load_events, prepare_sequences, PrepareConfig, Sequence};
use host_tools::parquet_io::{is_parquet, BatchSink, BATCH_ROWS};

use super::evaluate::{named_models, read_models, report_issues};
use super::output::write_output;

const AFTER_LONG_HELP: &str = "\
OUTPUT COLUMNS (one row per frame, events in folder order, frames in time order):
  event_id      the event's id (events.csv)
  time          frame time (s, the event's clock)
  class         crash | near_crash | safe
  <model>...    each model's risk score R(o), one column per --model, named like the rows of
                `riskctl evaluate` (DRL, MSRA, GSSM, SSRA, or NAME from NAME=FILE); larger is
                riskier. Scored exactly as on the ECU (DRL through the int8 network).
  ttc2d tadv ei the surrogates of the frame (s, s, m/s); inf / -inf = no conflict.

By default every frame of every event is scored. With --sequences only the frames of the
evaluation sequences are (the windows `riskctl evaluate` scores: docs/evaluation.md).

An output path ending in .parquet is written as Apache Parquet (event_id and class strings,
time Float64, scores and surrogates Float32); anything else as CSV ('-' = standard output).
Problems in the event folder are listed on stderr; the valid events are still scored.

EXAMPLES:
  riskctl score --model models/drl-default.rsk --model models/msra-default.rsk \\
                --events data/sim --out scores.csv
  riskctl score --model MINE=run/drl.rsk --events data/sim --out scores.parquet";

/// Write every frame's risk score under each model, with TTC2D/TAdv/EI, to a CSV or Parquet table.
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

/// Column builders for one batch of rows.
struct Columns {
    event_id: StringBuilder,
    time: Float64Builder,
    class: StringBuilder,
    scores: Vec<Float32Builder>,
    surrogates: [Float32Builder; 3],
    rows: usize,
}

impl Columns {
    fn new(models: usize) -> Self {
        Self {
            event_id: StringBuilder::new(),
            time: Float64Builder::new(),
            class: StringBuilder::new(),
            scores: (0..models).map(|_| Float32Builder::new()).collect(),
            surrogates: std::array::from_fn(|_| Float32Builder::new()),
            rows: 0,
        }
    }

    fn finish(&mut self, schema: &Arc<Schema>) -> anyhow::Result<RecordBatch> {
        let mut arrays: Vec<ArrayRef> = vec![
            Arc::new(self.event_id.finish()),
            Arc::new(self.time.finish()),
            Arc::new(self.class.finish()),
        ];
        arrays.extend(
            self.scores
                .iter_mut()
                .map(|b| Arc::new(b.finish()) as ArrayRef),
        );
        arrays.extend(
            self.surrogates
                .iter_mut()
                .map(|b| Arc::new(b.finish()) as ArrayRef),
        );
        self.rows = 0;
        Ok(RecordBatch::try_new(schema.clone(), arrays)?)
    }
}

/// The table's schema for these model column names.
fn schema(model_names: &[String]) -> Arc<Schema> {
    let mut fields = vec![
        Field::new("event_id", DataType::Utf8, false),
        Field::new("time", DataType::Float64, false),
        Field::new("class", DataType::Utf8, false),
    ];
    fields.extend(
        model_names
            .iter()
            .map(|n| Field::new(n, DataType::Float32, false)),
    );
    fields.extend(["ttc2d", "tadv", "ei"].map(|n| Field::new(n, DataType::Float32, false)));
    Arc::new(Schema::new(fields))
}

/// Score the sequences one at a time into `sink`; returns the number of rows.
fn score_into<W: std::io::Write + Send>(
    sequences: impl Iterator<Item = Sequence>,
    methods: &[Method<'_>],
    mut sink: BatchSink<W>,
) -> anyhow::Result<u64> {
    let names: Vec<String> = methods.iter().map(|m| m.name.clone()).collect();
    let schema = schema(&names);
    let mut columns = Columns::new(methods.len());
    let mut rows = 0u64;
    for sequence in sequences {
        // One sequence at a time: features and surrogates through the evaluation's own path.
        for observed in observe(std::slice::from_ref(&sequence)) {
            for frame in &observed.frames {
                columns.event_id.append_value(&observed.event_id);
                columns.time.append_value(frame.time);
                columns.class.append_value(sequence.kind.as_str());
                for (builder, method) in columns.scores.iter_mut().zip(methods) {
                    builder.append_value(method.scorer.score(&frame.observation));
                }
                let s = &frame.observation.surrogates;
                for (builder, v) in columns.surrogates.iter_mut().zip([s.ttc2d, s.tadv, s.ei]) {
                    builder.append_value(v);
                }
                columns.rows += 1;
                rows += 1;
                if columns.rows == BATCH_ROWS {
                    sink.write(&columns.finish(&schema)?)?;
                }
            }
        }
    }
    if columns.rows > 0 {
        sink.write(&columns.finish(&schema)?)?;
    }
    sink.finish(schema)?;
    Ok(rows)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Models first: a bad model file is found before a large event folder is read.
    let files = read_models(&args.models)?;
    let methods = named_models(&files)?;
    let dir = &args.events;
    let (set, issues) =
        load_events(dir).with_context(|| format!("event folder {}", dir.display()))?;
    report_issues(
        "problem(s) in the event folder (those events are skipped)",
        &issues,
    );
    if set.is_empty() {
        bail!("event folder {}: no valid events to score", dir.display());
    }
    let parquet = is_parquet(&args.out);
    let written = if args.sequences {
        let (sequences, prep_issues) = prepare_sequences(&set, &PrepareConfig::default());
        report_issues(
            "event(s) yield no sequence under the preparation rules",
            &prep_issues,
        );
        write_output(&args.out, |out| {
            let sink = if parquet {
                BatchSink::parquet(out)
            } else {
                BatchSink::csv(out)
            };
            score_into(sequences.into_iter(), &methods, sink)
        })?
    } else {
        // Observations are per frame, so an event is scored in slices of frames: the copies this
        // command makes stay one batch long however long the event is.
        let whole_events = set.iter().flat_map(|ev| {
            ev.frames.chunks(BATCH_ROWS).map(move |frames| Sequence {
                event_id: ev.id.clone(),
                kind: ev.kind,
                frames: frames.to_vec(),
                endpoint: ev.t_impact,
            })
        });
        write_output(&args.out, |out| {
            let sink = if parquet {
                BatchSink::parquet(out)
            } else {
                BatchSink::csv(out)
            };
            score_into(whole_events, &methods, sink)
        })?
    };
    if let Some(rows) = written {
        eprintln!(
            "riskctl score: {} frames of {} events scored with {} model(s) -> {}",
            rows,
            set.len(),
            methods.len(),
            args.out.display()
        );
    }
    Ok(())
}
