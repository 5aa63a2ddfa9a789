//! Event folders (`events.csv` + `frames.csv`, docs/event-format.md) as two Arrow tables, read
//! and written by riskscore-data. Frames carry the pair column names (`x_i ... width_j`), so a
//! frames table goes straight into `ssm` and `Model.score`.
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::cast::AsArray;
use arrow_array::types::{Float32Type, Float64Type};
use arrow_array::{Array, ArrayRef, Float32Array, Float64Array, RecordBatch, StringArray};
use arrow_pyarrow::{PyArrowType, Table};
use arrow_schema::{DataType, Field, Schema};
use pyo3::prelude::*;
use riskscore_data::events::{
    load_events, stream_events, Dims, Event, EventKind, EventSet, EventWriter, EventsError, Frame,
    IssueProblem, LoadIssue, EVENTS_FILE, FRAMES_FILE,
};
use riskscore_data::ssm_csv::STATE_FIELDS;
use scorer_core::VehicleState;

use crate::errors::Failure;

/// Columns of the events table, in order (the `events.csv` header).
const EVENT_FIELDS: [(&str, DataType, bool); 9] = [
    ("event_id", DataType::Utf8, false),
    ("kind", DataType::Utf8, false),
    ("t_start", DataType::Float64, false),
    ("t_end", DataType::Float64, false),
    ("t_impact", DataType::Float64, true),
    ("length_ego", DataType::Float32, false),
    ("width_ego", DataType::Float32, false),
    ("length_sur", DataType::Float32, false),
    ("width_sur", DataType::Float32, false),
];

/// Names of the frames table: `event_id`, `time`, then the 18 pair columns.
pub fn frame_names() -> Vec<String> {
    let pair = |suffix: &str| STATE_FIELDS.map(|f| format!("{f}_{suffix}"));
    ["event_id".to_owned(), "time".to_owned()]
        .into_iter()
        .chain(pair("i"))
        .chain(pair("j"))
        .collect()
}

fn state_values(s: &VehicleState) -> [f32; 9] {
    [s.x, s.y, s.vx, s.vy, s.hx, s.hy, s.acc, s.length, s.width]
}

fn events_batch(set: &EventSet) -> Result<RecordBatch, Failure> {
    let events = &set.events;
    let f64s = |get: &dyn Fn(&Event) -> Option<f64>| -> ArrayRef {
        Arc::new(events.iter().map(get).collect::<Float64Array>())
    };
    let f32s = |get: &dyn Fn(&Dims) -> f32| -> ArrayRef {
        Arc::new(
            events
                .iter()
                .map(|e| get(&e.dims))
                .collect::<Float32Array>(),
        )
    };
    let columns: Vec<ArrayRef> = vec![
        Arc::new(StringArray::from_iter_values(events.iter().map(|e| &e.id))),
        Arc::new(StringArray::from_iter_values(
            events.iter().map(|e| e.kind.as_str()),
        )),
        f64s(&|e| Some(e.t_start)),
        f64s(&|e| Some(e.t_end)),
        f64s(&|e| e.t_impact),
        f32s(&|d| d.length_ego),
        f32s(&|d| d.width_ego),
        f32s(&|d| d.length_partner),
        f32s(&|d| d.width_partner),
    ];
    let schema = Schema::new(
        EVENT_FIELDS
            .iter()
            .map(|(n, t, nullable)| Field::new(*n, t.clone(), *nullable))
            .collect::<Vec<_>>(),
    );
    RecordBatch::try_new(Arc::new(schema), columns).map_err(|e| Failure::Events(e.to_string()))
}

fn frames_batch(set: &EventSet) -> Result<RecordBatch, Failure> {
    let n: usize = set.iter().map(|e| e.frames.len()).sum();
    let mut ids = Vec::with_capacity(n);
    let mut times = Vec::with_capacity(n);
    let mut pair: Vec<Vec<f32>> = (0..18).map(|_| Vec::with_capacity(n)).collect();
    for event in set {
        for frame in &event.frames {
            ids.push(event.id.as_str());
            times.push(frame.time);
            let values = state_values(&frame.ego)
                .into_iter()
                .chain(state_values(&frame.partner));
            for (column, v) in pair.iter_mut().zip(values) {
                column.push(v);
            }
        }
    }
    let mut columns: Vec<ArrayRef> = vec![
        Arc::new(StringArray::from(ids)),
        Arc::new(Float64Array::from(times)),
    ];
    columns.extend(
        pair.into_iter()
            .map(|v| Arc::new(Float32Array::from(v)) as ArrayRef),
    );
    let fields: Vec<Field> = frame_fields()
        .into_iter()
        .map(|(name, kind)| Field::new(name, kind, false))
        .collect();
    RecordBatch::try_new(Arc::new(Schema::new(fields)), columns)
        .map_err(|e| Failure::Events(e.to_string()))
}

fn table(batch: RecordBatch) -> Result<PyArrowType<Table>, Failure> {
    let schema = batch.schema();
    Table::try_new(vec![batch], schema)
        .map(PyArrowType)
        .map_err(|e| Failure::Events(e.to_string()))
}

/// (events, frames, the first problems one line each, the notes one line each, the number of
/// problems).
type ReadFolder = (
    PyArrowType<Table>,
    PyArrowType<Table>,
    Vec<String>,
    Vec<String>,
    u64,
);

/// A folder's load issues split into (problems, notes), one line each
/// (`file:line: column: event: problem`), and the number of problems in all. Notes
/// ([`IssueProblem::is_note`]: a file without a final newline, a hole in the frames, ...) leave
/// nothing out: they are neither listed nor counted as problems.
pub fn split_issues(issues: &[LoadIssue]) -> (Vec<String>, Vec<String>, u64) {
    let (notes, problems): (Vec<&LoadIssue>, Vec<&LoadIssue>) =
        issues.iter().partition(|i| i.problem.is_note());
    let count = problems.iter().map(|i| i.count()).sum();
    let lines = |list: Vec<&LoadIssue>| list.iter().map(|i| i.to_string()).collect();
    (lines(problems), lines(notes), count)
}

/// The valid events of folder `dir` as (events, frames) tables, the folder's problems and notes
/// (one line each, `file:line: column: event: problem`) and how many problems there are in all.
#[pyfunction]
pub fn read_events(py: Python<'_>, dir: PathBuf) -> PyResult<ReadFolder> {
    let read = py.detach(|| -> Result<_, Failure> {
        let (set, issues) = load_events(&dir).map_err(|e| Failure::Events(e.to_string()))?;
        let (problems, notes, count) = split_issues(&issues);
        Ok((
            table(events_batch(&set)?)?,
            table(frames_batch(&set)?)?,
            problems,
            notes,
            count,
        ))
    });
    read.map_err(|f| f.into_py(py))
}

/// A typed view of one column of a table the Python side has already cast (names and types as
/// [`EVENT_FIELDS`] / [`frame_names`]), with the table's name for messages.
struct Columns<'a> {
    what: &'a str,
    batch: &'a RecordBatch,
    first_row: usize,
}

impl Columns<'_> {
    fn name(&self, k: usize) -> String {
        self.batch.schema().field(k).name().clone()
    }
    fn problem(&self, k: usize, row: usize, text: &str) -> Failure {
        Failure::Events(format!(
            "{} row {} column {}: {text}",
            self.what,
            self.first_row + row,
            self.name(k)
        ))
    }
    fn text(&self, k: usize, row: usize) -> Result<&str, Failure> {
        let column = self.batch.column(k).as_string::<i32>();
        if column.is_null(row) {
            return Err(self.problem(k, row, "missing value"));
        }
        Ok(column.value(row))
    }
    fn f64(&self, k: usize, row: usize) -> Result<Option<f64>, Failure> {
        let column = self.batch.column(k).as_primitive::<Float64Type>();
        if column.is_null(row) {
            return Ok(None);
        }
        let v = column.value(row);
        if !v.is_finite() {
            return Err(self.problem(k, row, &format!("value {v} is not finite")));
        }
        Ok(Some(v))
    }
    fn required_f64(&self, k: usize, row: usize) -> Result<f64, Failure> {
        self.f64(k, row)?
            .ok_or_else(|| self.problem(k, row, "missing value"))
    }
    fn f32(&self, k: usize, row: usize) -> Result<f32, Failure> {
        let column = self.batch.column(k).as_primitive::<Float32Type>();
        if column.is_null(row) {
            return Err(self.problem(k, row, "missing value"));
        }
        let v = column.value(row);
        if !v.is_finite() {
            return Err(self.problem(k, row, &format!("value {v} is not finite")));
        }
        Ok(v)
    }
}

/// The types the frames table's columns must have (names from [`frame_names`]): `event_id`
/// text, `time` Float64, the pair columns Float32.
fn frame_fields() -> Vec<(String, DataType)> {
    frame_names()
        .into_iter()
        .enumerate()
        .map(|(k, name)| {
            let kind = match k {
                0 => DataType::Utf8,
                1 => DataType::Float64,
                _ => DataType::Float32,
            };
            (name, kind)
        })
        .collect()
}

/// Refuses a table whose schema does not start with the `wanted` columns (name and type, in
/// order). Checked on the schema, before any row is read: a zero-row table (no batches, or
/// only empty ones) with a text column where a number belongs is refused like one with rows,
/// and a wrong type is a `ColumnError` naming the column, never a panic in a row accessor.
fn check_schema<'a>(
    what: &str,
    schema: &Schema,
    wanted: impl IntoIterator<Item = (&'a str, &'a DataType)>,
) -> Result<(), Failure> {
    for (k, (name, kind)) in wanted.into_iter().enumerate() {
        let Some(field) = schema.fields().get(k) else {
            return Err(Failure::Column(format!("{what}: missing column {name:?}")));
        };
        if field.name() != name {
            return Err(Failure::Column(format!(
                "{what}: column {} is {:?}; expected {name:?}",
                k,
                field.name()
            )));
        }
        if field.data_type() != kind {
            return Err(Failure::Column(format!(
                "{what}: column {name:?} ({}) is not {kind}",
                field.data_type()
            )));
        }
    }
    Ok(())
}

/// Calls `each` with every row of `batches` (numbered across them), `what` naming the table.
fn for_each_row(
    what: &str,
    batches: &[RecordBatch],
    mut each: impl FnMut(&Columns<'_>, usize) -> Result<(), Failure>,
) -> Result<(), Failure> {
    let mut first_row = 0;
    for batch in batches {
        let c = Columns {
            what,
            batch,
            first_row,
        };
        for row in 0..batch.num_rows() {
            each(&c, row)?;
        }
        first_row += batch.num_rows();
    }
    Ok(())
}

fn events_of(batches: &[RecordBatch]) -> Result<Vec<Event>, Failure> {
    let mut events = Vec::new();
    for_each_row("events", batches, |c, row| {
        let kind_text = c.text(1, row)?;
        let kind = EventKind::parse(kind_text).ok_or_else(|| {
            c.problem(
                1,
                row,
                &format!("unknown kind {kind_text:?} (crash, near_crash or safe)"),
            )
        })?;
        events.push(Event {
            id: c.text(0, row)?.to_owned(),
            kind,
            t_start: c.required_f64(2, row)?,
            t_end: c.required_f64(3, row)?,
            t_impact: c.f64(4, row)?,
            dims: Dims {
                length_ego: c.f32(5, row)?,
                width_ego: c.f32(6, row)?,
                length_partner: c.f32(7, row)?,
                width_partner: c.f32(8, row)?,
            },
            frames: Vec::new(),
        });
        Ok(())
    })?;
    Ok(events)
}

/// Adds the frames (columns `event_id`, `time`, `x_i ... acc_i`, `x_j ... acc_j`) to their
/// events, in table order; the box sizes are the event's. Returns, per event, the table rows of
/// its frames.
fn attach_frames(
    events: &mut [Event],
    batches: &[RecordBatch],
) -> Result<Vec<Vec<usize>>, Failure> {
    let index: HashMap<String, usize> = events
        .iter()
        .enumerate()
        .map(|(k, e)| (e.id.clone(), k))
        .collect();
    let mut rows: Vec<Vec<usize>> = vec![Vec::new(); events.len()];
    for_each_row("frames", batches, |c, row| {
        let id = c.text(0, row)?;
        let &k = index.get(id).ok_or_else(|| {
            c.problem(0, row, &format!("event {id:?} is not in the events table"))
        })?;
        let state = |base: usize, length: f32, width: f32| -> Result<VehicleState, Failure> {
            let v = |j: usize| c.f32(base + j, row);
            Ok(VehicleState {
                x: v(0)?,
                y: v(1)?,
                vx: v(2)?,
                vy: v(3)?,
                hx: v(4)?,
                hy: v(5)?,
                acc: v(6)?,
                length,
                width,
            })
        };
        let d = events[k].dims;
        let frame = Frame {
            time: c.required_f64(1, row)?,
            ego: state(2, d.length_ego, d.width_ego)?,
            partner: state(9, d.length_partner, d.width_partner)?,
        };
        events[k].frames.push(frame);
        rows[k].push(c.first_row + row);
        Ok(())
    })?;
    Ok(rows)
}

/// Writes `list` as an event folder in `dir` (the partner acceleration included, so the folder
/// reads back with exactly these values).
fn write_folder(dir: &Path, list: &[Event]) -> Result<(), Failure> {
    let mut writer = EventWriter::create_with_partner_acceleration(dir)
        .map_err(|e| Failure::Events(e.to_string()))?;
    for event in list {
        writer
            .write_event(event)
            .map_err(|e| Failure::Events(e.to_string()))?;
    }
    writer.finish().map_err(|e| Failure::Events(e.to_string()))
}

/// The frames table's name of a `frames.csv` column: `x_ego`/`acc_sur` are `x_i`/`acc_j`;
/// `event_id` and `time` are the same.
fn frames_column(file_column: &str) -> String {
    if let Some(base) = file_column.strip_suffix("_ego") {
        if STATE_FIELDS.contains(&base) {
            return format!("{base}_i");
        }
    }
    if let Some(base) = file_column.strip_suffix("_sur") {
        if STATE_FIELDS.contains(&base) {
            return format!("{base}_j");
        }
    }
    file_column.to_owned()
}

/// Where `write_events` puts its scratch folder for `dir`: inside `dir` when it exists, else
/// beside it (its nearest existing ancestor: the writer creates the missing folders; the current
/// folder for a bare name). Not the system temp folder: that may be missing, small or read-only
/// (containers, Spark executors) while the destination has room, and the check would fail a
/// write that can succeed.
fn scratch_parent(dir: &Path) -> PathBuf {
    dir.ancestors()
        .find(|a| !a.as_os_str().is_empty() && a.is_dir())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Refuses tables that would make a folder `read_events` and `riskctl` refuse (frames out of
/// time order, a repeated event_id, an event without frames, a crash without t_impact, ...): the
/// folder is written to a scratch folder beside the destination `dir` ([`scratch_parent`];
/// removed when this returns, whatever the outcome) and read back by riskscore-data's streaming
/// loader, which keeps no event (no second copy of the events in memory), and whose problems
/// are named by table row. `frame_rows` are the table rows of each event's frames.
fn check_readable(dir: &Path, list: &[Event], frame_rows: &[Vec<usize>]) -> Result<(), Failure> {
    let scratch = tempfile::Builder::new()
        .prefix(".riskscore-check-")
        .tempdir_in(scratch_parent(dir))
        .map_err(|e| Failure::Events(format!("scratch folder to check the tables: {e}")))?;
    write_folder(scratch.path(), list)?;
    // Written by EventWriter, each event's frames are one run in events.csv order, so the
    // folder streams; only tables that repeat an event_id (two runs of one id) do not, and are
    // read whole for the same problems as before.
    let issues = match stream_events::<EventsError>(scratch.path(), true, |_, _| Ok(())) {
        Err(EventsError::NotStreamable { .. }) => load_events(scratch.path()).map(|(_, i)| i),
        streamed => streamed,
    }
    .map_err(|e| Failure::Events(e.to_string()))?;
    let problems: Vec<_> = issues.iter().filter(|i| !i.problem.is_note()).collect();
    if problems.is_empty() {
        return Ok(());
    }
    // Lines of the written files (header = line 1) back to table rows: events in table order,
    // each event's frames in table order.
    let written_frames: Vec<usize> = frame_rows.iter().flatten().copied().collect();
    let event_rows: Vec<usize> = (0..list.len()).collect();
    let row_of = |rows: &[usize], line: u64| {
        (line as usize)
            .checked_sub(2)
            .and_then(|k| rows.get(k).copied())
    };
    let count: u64 = problems.iter().map(|i| i.count()).sum();
    let lines: Vec<String> = problems
        .iter()
        .map(|i| {
            let (table, rows) = if i.file.file_name() == Some(FRAMES_FILE.as_ref()) {
                ("frames", &written_frames)
            } else {
                ("events", &event_rows)
            };
            let mut line = table.to_owned();
            if let Some(r) = row_of(rows, i.line) {
                line.push_str(&format!(" row {r}"));
            }
            if let Some(c) = &i.column {
                let c = if table == "frames" {
                    frames_column(c)
                } else {
                    c.clone()
                };
                line.push_str(&format!(" column {c}"));
            }
            if let Some(id) = &i.event_id {
                line.push_str(&format!(": event {id:?}"));
            }
            // A problem that points at another line of the same file points at its row.
            let mut problem = i.problem.to_string();
            if let IssueProblem::DuplicateEventId { first_line: other }
            | IssueProblem::DuplicateTime {
                previous_line: other,
                ..
            }
            | IssueProblem::UnsortedTime {
                previous_line: other,
                ..
            } = i.problem
            {
                if let Some(r) = row_of(rows, other) {
                    problem = problem.replace(&format!("line {other}"), &format!("row {r}"));
                }
            }
            line.push_str(&format!(": {problem}"));
            line
        })
        .collect();
    Err(Failure::Events(format!(
        "{count} problem(s): the tables would make an event folder that read_events refuses \
         (nothing was written):\n  {}",
        lines.join("\n  ")
    )))
}

/// Writes an event folder from the (events, frames) tables (see `riskscore.write_events`).
#[pyfunction]
#[pyo3(signature = (dir, events, frames, overwrite = false))]
pub fn write_events(
    py: Python<'_>,
    dir: PathBuf,
    events: PyArrowType<Table>,
    frames: PyArrowType<Table>,
    overwrite: bool,
) -> PyResult<()> {
    let written = py.detach(|| -> Result<(), Failure> {
        if !overwrite {
            for name in [EVENTS_FILE, FRAMES_FILE] {
                let path = dir.join(name);
                if path.exists() {
                    return Err(Failure::Exists(format!(
                        "{} exists; pass overwrite=True to replace the folder's files",
                        path.display()
                    )));
                }
            }
        }
        check_schema(
            "events",
            &events.0.schema(),
            EVENT_FIELDS.iter().map(|(n, t, _)| (*n, t)),
        )?;
        let frame_fields = frame_fields();
        // The frames table's box sizes are not read (the events table has them).
        let read = frame_fields
            .iter()
            .filter(|(n, _)| !n.starts_with("length_") && !n.starts_with("width_"));
        check_schema(
            "frames",
            &frames.0.schema(),
            read.map(|(n, t)| (n.as_str(), t)),
        )?;
        let mut list = events_of(events.0.record_batches())?;
        let frame_rows = attach_frames(&mut list, frames.0.record_batches())?;
        check_readable(&dir, &list, &frame_rows)?;
        // The partner acceleration is always known here (recorded or derived when read), so it
        // is written: the folder reads back with exactly these values.
        write_folder(&dir, &list)
    });
    written.map_err(|f| f.into_py(py))
}
