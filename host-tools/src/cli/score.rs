//! `riskctl score`: the per-frame risk of every event under each model, plus the surrogates, as
//! one table a user can plot (CSV, or Parquet when the output ends in `.parquet`).
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{bail, Context};
use arrow_array::builder::{Float32Builder, Float64Builder, StringBuilder};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use riskscore_data::events::{
    load_events, prepare_owned_event, stream_events, Event, EventSet, EventsError, Frame,
    LoadIssue, PrepareConfig, PrepareIssue, Sequence,
};
use riskscore_eval::parquet_io::{is_parquet, BatchSink, BATCH_ROWS};
use riskscore_eval::{observe_frames, Method};

use super::evaluate::{named_models, read_models, report_issues};
use super::output::{is_dash, write_output};

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

Memory: with --out FILE the folder is read and scored one event at a time, so memory is one
event whatever the folder's size. To '-', a pipe or a device, or when an event's frames are not
one run of consecutive rows in events.csv order, the folder is read whole first.

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

/// The output table being written: one batch of rows in builders, the rest already in the sink.
struct TableWriter<'a, 'm, W: std::io::Write + Send> {
    methods: &'a [Method<'m>],
    schema: Arc<Schema>,
    columns: Columns,
    sink: BatchSink<W>,
    rows: u64,
}

impl<'a, 'm, W: std::io::Write + Send> TableWriter<'a, 'm, W> {
    fn new(methods: &'a [Method<'m>], sink: BatchSink<W>) -> Self {
        let names: Vec<String> = methods.iter().map(|m| m.name.clone()).collect();
        Self {
            methods,
            schema: schema(&names),
            columns: Columns::new(methods.len()),
            sink,
            rows: 0,
        }
    }

    /// Scores one sequence's frames into the table (a full batch goes to the sink).
    fn add(&mut self, sequence: &Sequence, frames: &[Frame]) -> anyhow::Result<()> {
        // Features and surrogates through the evaluation's own path.
        for frame in observe_frames(frames) {
            let columns = &mut self.columns;
            columns.event_id.append_value(&sequence.event_id);
            columns.time.append_value(frame.time);
            columns.class.append_value(sequence.kind.as_str());
            for (builder, method) in columns.scores.iter_mut().zip(self.methods) {
                builder.append_value(method.scorer.score(&frame.observation));
            }
            let s = &frame.observation.surrogates;
            for (builder, v) in columns.surrogates.iter_mut().zip([s.ttc2d, s.tadv, s.ei]) {
                builder.append_value(v);
            }
            columns.rows += 1;
            self.rows += 1;
            if columns.rows == BATCH_ROWS {
                self.sink.write(&columns.finish(&self.schema)?)?;
            }
        }
        Ok(())
    }

    /// Scores what `--sequences` asks for of one event: its evaluation sequence, or every frame.
    /// Frames are observed a batch at a time, so the observations held stay one batch long
    /// however long the event is. `Err(issue)`: the event yields no sequence.
    fn add_event(
        &mut self,
        event: Event,
        sequences: bool,
    ) -> anyhow::Result<Result<(), PrepareIssue>> {
        let sequence = if sequences {
            match prepare_owned_event(event, &PrepareConfig::default()) {
                Ok(sequence) => sequence,
                Err(issue) => return Ok(Err(issue)),
            }
        } else {
            Sequence {
                endpoint: event.t_impact,
                event_id: event.id,
                kind: event.kind,
                frames: event.frames,
            }
        };
        for frames in sequence.frames.chunks(BATCH_ROWS) {
            self.add(&sequence, frames)?;
        }
        Ok(Ok(()))
    }

    /// Writes the last batch and the file's end; returns the number of rows.
    fn finish(mut self) -> anyhow::Result<u64> {
        if self.columns.rows > 0 {
            self.sink.write(&self.columns.finish(&self.schema)?)?;
        }
        self.sink.finish(self.schema)?;
        Ok(self.rows)
    }
}

/// What scoring a folder found besides the table.
struct Scored {
    rows: u64,
    events: usize,
    load_issues: Vec<LoadIssue>,
    prepare_issues: Vec<PrepareIssue>,
}

/// Scores the folder one event at a time as `frames.csv` is read ([`stream_events`]): memory is
/// one event. Fails with [`EventsError::NotStreamable`] when the frames are not grouped by event
/// in `events.csv` order; the caller then discards the output and uses [`score_whole`].
fn score_streaming<W: std::io::Write + Send>(
    dir: &Path,
    methods: &[Method<'_>],
    sequences: bool,
    sink: BatchSink<W>,
) -> anyhow::Result<Scored> {
    let mut table = TableWriter::new(methods, sink);
    let mut events = 0;
    let mut prepare_issues = Vec::new();
    let load_issues = stream_events(dir, true, |_, event| -> anyhow::Result<()> {
        events += 1;
        if let Err(issue) = table.add_event(event, sequences)? {
            prepare_issues.push(issue);
        }
        Ok(())
    })
    .with_context(|| format!("event folder {}", dir.display()))?;
    no_events_is_an_error(dir, events, &load_issues)?;
    Ok(Scored {
        rows: table.finish()?,
        events,
        load_issues,
        prepare_issues,
    })
}

/// Scores the folder read whole ([`load_events`]): for outputs that cannot be restarted and
/// folders that cannot be streamed.
fn score_whole<W: std::io::Write + Send>(
    set: EventSet,
    methods: &[Method<'_>],
    sequences: bool,
    sink: BatchSink<W>,
) -> anyhow::Result<(u64, Vec<PrepareIssue>)> {
    let mut table = TableWriter::new(methods, sink);
    let mut prepare_issues = Vec::new();
    for event in set.events {
        if let Err(issue) = table.add_event(event, sequences)? {
            prepare_issues.push(issue);
        }
    }
    Ok((table.finish()?, prepare_issues))
}

fn no_events_is_an_error(dir: &Path, events: usize, issues: &[LoadIssue]) -> anyhow::Result<()> {
    if events == 0 {
        report_load_issues(issues);
        bail!("event folder {}: no valid events to score", dir.display());
    }
    Ok(())
}

fn report_load_issues(issues: &[LoadIssue]) {
    report_issues(
        "problem(s) in the event folder (those events are skipped)",
        issues,
    );
}

fn sink<W: std::io::Write + Send>(out: W, parquet: bool) -> BatchSink<W> {
    if parquet {
        BatchSink::parquet(out)
    } else {
        BatchSink::csv(out)
    }
}

/// True for an output that can be written twice: a regular file (written to `.partial` and
/// renamed), not standard output, a pipe or a device, where a discarded first attempt would
/// already have been read.
fn restartable(out: &Path) -> bool {
    !is_dash(out) && std::fs::metadata(out).map_or(true, |m| m.is_file())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Models first: a bad model file is found before a large event folder is read.
    let files = read_models(&args.models)?;
    let methods = named_models(&files)?;
    let dir = &args.events;
    let parquet = is_parquet(&args.out);

    let mut scored = None;
    if restartable(&args.out) {
        match write_output(&args.out, |out| {
            score_streaming(dir, &methods, args.sequences, sink(out, parquet))
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
                score_whole(set, &methods, args.sequences, sink(out, parquet))
            })?
            .map(|(rows, prepare_issues)| Scored {
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
