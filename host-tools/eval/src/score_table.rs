//! The per-frame score table of `riskctl score`: every frame's risk under each method and its
//! surrogates, built in Arrow batches and written to a CSV or Parquet sink, one event at a time.
use scorer_core::SurrogateKind;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::builder::{Float32Builder, Float64Builder, StringBuilder, UInt8Builder};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{ArrowError, DataType, Field, Schema};
use riskscore_data::events::{
    prepare_owned_event, stream_events, Event, EventSet, EventsError, Frame, LoadIssue,
    PrepareConfig, PrepareIssue, Sequence,
};

use crate::parquet_io::{BatchSink, ColumnarError, BATCH_ROWS};
use crate::{observe_frames, Method};

/// Scoring into a table failed.
#[derive(Debug, thiserror::Error)]
pub enum ScoreTableError {
    /// The event folder could not be read (its source says why).
    #[error("event folder {}", dir.display())]
    Folder {
        dir: PathBuf,
        #[source]
        source: EventsError,
    },
    /// The folder has no valid event; `load_issues` says why.
    #[error("event folder {}: no valid events to score", dir.display())]
    NoEvents {
        dir: PathBuf,
        load_issues: Vec<LoadIssue>,
    },
    /// Reading the folder failed before its path was known here; [`ScoreTableError::in_folder`]
    /// turns it into [`ScoreTableError::Folder`].
    #[error(transparent)]
    Events(#[from] EventsError),
    #[error(transparent)]
    Sink(#[from] ColumnarError),
    #[error(transparent)]
    Arrow(#[from] ArrowError),
}

impl ScoreTableError {
    /// Names `dir` in an event folder error.
    fn in_folder(self, dir: &Path) -> Self {
        match self {
            ScoreTableError::Events(source) => ScoreTableError::Folder {
                dir: dir.to_path_buf(),
                source,
            },
            other => other,
        }
    }
}

/// Column builders for one batch of rows.
struct Columns {
    event_id: StringBuilder,
    time: Float64Builder,
    kind: StringBuilder,
    scores: Vec<Float32Builder>,
    surrogates: [Float32Builder; SURROGATE_COLUMNS.len()],
    /// One per method with a training domain: 1 inside, 0 outside.
    in_domain: Vec<UInt8Builder>,
    rows: usize,
}

impl Columns {
    fn new(models: usize, guarded: usize) -> Self {
        Self {
            in_domain: (0..guarded).map(|_| UInt8Builder::new()).collect(),
            event_id: StringBuilder::new(),
            time: Float64Builder::new(),
            kind: StringBuilder::new(),
            scores: (0..models).map(|_| Float32Builder::new()).collect(),
            surrogates: std::array::from_fn(|_| Float32Builder::new()),
            rows: 0,
        }
    }

    fn finish(&mut self, schema: &Arc<Schema>) -> Result<RecordBatch, ArrowError> {
        let mut arrays: Vec<ArrayRef> = vec![
            Arc::new(self.event_id.finish()),
            Arc::new(self.time.finish()),
            Arc::new(self.kind.finish()),
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
        arrays.extend(
            self.in_domain
                .iter_mut()
                .map(|b| Arc::new(b.finish()) as ArrayRef),
        );
        self.rows = 0;
        RecordBatch::try_new(schema.clone(), arrays)
    }
}

/// The column of a guarded model's flag: `<model>_in_domain`.
pub fn in_domain_column(model_name: &str) -> String {
    format!("{model_name}_in_domain")
}

/// The surrogates written after the model columns, each under its key (`ttc2d`, ...): the
/// published three, then the corridor rule's TAdv, which MSRA terms and fallbacks may read.
const SURROGATE_COLUMNS: [SurrogateKind; 4] = [
    SurrogateKind::Ttc2d,
    SurrogateKind::Tadv,
    SurrogateKind::Ei,
    SurrogateKind::TadvCorridor,
];

/// The table's schema for these model column names (and those of the guarded models' flags).
fn schema(model_names: &[String], guarded_names: &[String]) -> Arc<Schema> {
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
    fields.extend(SURROGATE_COLUMNS.map(|kind| Field::new(kind.key(), DataType::Float32, false)));
    fields.extend(
        guarded_names
            .iter()
            .map(|n| Field::new(in_domain_column(n), DataType::UInt8, false)),
    );
    Arc::new(Schema::new(fields))
}

/// The output table being written: one batch of rows in builders, the rest already in the sink.
pub struct ScoreTable<'a, 'm, W: std::io::Write + Send> {
    methods: &'a [Method<'m>],
    schema: Arc<Schema>,
    columns: Columns,
    sink: BatchSink<W>,
    rows: u64,
}

impl<'a, 'm, W: std::io::Write + Send> ScoreTable<'a, 'm, W> {
    /// An empty table with one score column per method, written to `sink`.
    pub fn new(methods: &'a [Method<'m>], sink: BatchSink<W>) -> Self {
        let names: Vec<String> = methods.iter().map(|m| m.name.clone()).collect();
        let guarded: Vec<String> = methods
            .iter()
            .filter(|m| m.scorer.has_domain())
            .map(|m| m.name.clone())
            .collect();
        Self {
            methods,
            schema: schema(&names, &guarded),
            columns: Columns::new(methods.len(), guarded.len()),
            sink,
            rows: 0,
        }
    }

    /// Scores one sequence's frames into the table (a full batch goes to the sink).
    fn add(&mut self, sequence: &Sequence, frames: &[Frame]) -> Result<(), ScoreTableError> {
        // Features and surrogates through the evaluation's own path.
        for frame in observe_frames(frames) {
            let columns = &mut self.columns;
            columns.event_id.append_value(&sequence.event_id);
            columns.time.append_value(frame.time);
            columns.kind.append_value(sequence.kind.as_str());
            let mut flags = columns.in_domain.iter_mut();
            for (builder, method) in columns.scores.iter_mut().zip(self.methods) {
                match method.scorer.score_guarded(&frame.observation) {
                    Some(guarded) => {
                        builder.append_value(guarded.score);
                        if let Some(flag) = flags.next() {
                            flag.append_value(u8::from(guarded.in_domain));
                        }
                    }
                    None => builder.append_value(method.scorer.score(&frame.observation)),
                }
            }
            let s = &frame.observation.surrogates;
            for (builder, kind) in columns.surrogates.iter_mut().zip(SURROGATE_COLUMNS) {
                builder.append_value(kind.value_in(s));
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
    pub fn add_event(
        &mut self,
        event: Event,
        sequences: bool,
    ) -> Result<Result<(), PrepareIssue>, ScoreTableError> {
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
    pub fn finish(mut self) -> Result<u64, ScoreTableError> {
        if self.columns.rows > 0 {
            self.sink.write(&self.columns.finish(&self.schema)?)?;
        }
        self.sink.finish(self.schema)?;
        Ok(self.rows)
    }
}

/// What scoring a folder found besides the table.
pub struct ScoredFolder {
    /// Rows written.
    pub rows: u64,
    /// Valid events read.
    pub events: usize,
    pub load_issues: Vec<LoadIssue>,
    pub prepare_issues: Vec<PrepareIssue>,
}

/// Scores the folder one event at a time as `frames.csv` is read ([`stream_events`]): memory is
/// one event. Fails with [`EventsError::NotStreamable`] when the frames are not grouped by event
/// in `events.csv` order; the caller then discards the output and uses [`score_whole`].
pub fn score_streaming<W: std::io::Write + Send>(
    dir: &Path,
    methods: &[Method<'_>],
    sequences: bool,
    sink: BatchSink<W>,
) -> Result<ScoredFolder, ScoreTableError> {
    let mut table = ScoreTable::new(methods, sink);
    let mut events = 0;
    let mut prepare_issues = Vec::new();
    let load_issues = stream_events(dir, true, |_, event| -> Result<(), ScoreTableError> {
        events += 1;
        if let Err(issue) = table.add_event(event, sequences)? {
            prepare_issues.push(issue);
        }
        Ok(())
    })
    .map_err(|e| e.in_folder(dir))?;
    if events == 0 {
        return Err(ScoreTableError::NoEvents {
            dir: dir.to_path_buf(),
            load_issues,
        });
    }
    Ok(ScoredFolder {
        rows: table.finish()?,
        events,
        load_issues,
        prepare_issues,
    })
}

/// Scores the folder read whole ([`riskscore_data::events::load_events`]): for outputs that cannot be restarted and
/// folders that cannot be streamed.
pub fn score_whole<W: std::io::Write + Send>(
    set: EventSet,
    methods: &[Method<'_>],
    sequences: bool,
    sink: BatchSink<W>,
) -> Result<(u64, Vec<PrepareIssue>), ScoreTableError> {
    let mut table = ScoreTable::new(methods, sink);
    let mut prepare_issues = Vec::new();
    for event in set.events {
        if let Err(issue) = table.add_event(event, sequences)? {
            prepare_issues.push(issue);
        }
    }
    Ok((table.finish()?, prepare_issues))
}
