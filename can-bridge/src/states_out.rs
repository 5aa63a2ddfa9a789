//! `decode`'s table: every scored track update as the scorer saw it (ego and partner state in the
//! ego frame, the derived/defaulted flags, and the score when a model was given), written as CSV
//! or Parquet through `riskscore-eval`'s batch sink (the same writer as `riskctl ssm`).
use crate::engine::{InputFlags, ScoredUpdate};
use arrow_array::{ArrayRef, BooleanArray, Float32Array, Float64Array, RecordBatch, UInt32Array};
use arrow_schema::{DataType, Field, Schema};
use riskscore_eval::parquet_io::{BatchSink, ColumnarError};
use std::io::Write;
use std::sync::Arc;

/// Rows buffered before a batch is written.
const BATCH_ROWS: usize = 16 * 1024;

/// The state columns after `t` and `track`, in order (Float32).
pub const STATE_COLUMNS: [&str; 16] = [
    "ego_vx",
    "ego_vy",
    "ego_accel",
    "ego_length",
    "ego_width",
    "x",
    "y",
    "vx",
    "vy",
    "heading",
    "hx",
    "hy",
    "accel",
    "length",
    "width",
    "speed",
];

/// Writes scored updates in batches.
pub struct StatesWriter<W: Write + Send> {
    sink: BatchSink<W>,
    schema: Arc<Schema>,
    with_score: bool,
    rows: Vec<ScoredUpdate>,
    pub written: u64,
}

impl<W: Write + Send> StatesWriter<W> {
    /// `parquet`: Parquet, else CSV. `with_score`: add the model's `score` and `warning`.
    pub fn new(out: W, parquet: bool, with_score: bool) -> Self {
        let mut fields = vec![
            Field::new("t", DataType::Float64, false),
            Field::new("track", DataType::UInt32, false),
        ];
        fields.extend(
            STATE_COLUMNS
                .iter()
                .map(|c| Field::new(*c, DataType::Float32, false)),
        );
        if with_score {
            fields.push(Field::new("score", DataType::Float32, false));
            fields.push(Field::new("warning", DataType::Boolean, false));
        }
        fields.extend(
            InputFlags::NAMES
                .iter()
                .map(|(_, name)| Field::new(*name, DataType::Boolean, false)),
        );
        Self {
            sink: if parquet {
                BatchSink::parquet(out)
            } else {
                BatchSink::csv(out)
            },
            schema: Arc::new(Schema::new(fields)),
            with_score,
            rows: Vec::with_capacity(BATCH_ROWS),
            written: 0,
        }
    }

    pub fn push(&mut self, u: &ScoredUpdate) -> Result<(), ColumnarError> {
        self.rows.push(*u);
        if self.rows.len() >= BATCH_ROWS {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), ColumnarError> {
        if self.rows.is_empty() {
            return Ok(());
        }
        let rows = &self.rows;
        let f32s = |get: &dyn Fn(&ScoredUpdate) -> f32| -> ArrayRef {
            Arc::new(Float32Array::from_iter_values(rows.iter().map(get)))
        };
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(Float64Array::from_iter_values(
                rows.iter().map(|u| u.t_us as f64 / 1e6),
            )),
            Arc::new(UInt32Array::from_iter_values(rows.iter().map(|u| u.track))),
            f32s(&|u| u.ego.vx),
            f32s(&|u| u.ego.vy),
            f32s(&|u| u.ego.acc),
            f32s(&|u| u.ego.length),
            f32s(&|u| u.ego.width),
            f32s(&|u| u.partner.x),
            f32s(&|u| u.partner.y),
            f32s(&|u| u.partner.vx),
            f32s(&|u| u.partner.vy),
            f32s(&|u| libm::atan2f(u.partner.hy, u.partner.hx)),
            f32s(&|u| u.partner.hx),
            f32s(&|u| u.partner.hy),
            f32s(&|u| u.partner.acc),
            f32s(&|u| u.partner.length),
            f32s(&|u| u.partner.width),
            f32s(&|u| u.partner.speed()),
        ];
        if self.with_score {
            columns.push(f32s(&|u| u.score));
            columns.push(Arc::new(BooleanArray::from_iter(
                rows.iter().map(|u| Some(u.warning)),
            )));
        }
        for (flag, _) in InputFlags::NAMES {
            columns.push(Arc::new(BooleanArray::from_iter(
                rows.iter().map(|u| Some(u.flags.has(flag))),
            )));
        }
        let batch = RecordBatch::try_new(self.schema.clone(), columns)?;
        self.sink.write(&batch)?;
        self.written += rows.len() as u64;
        self.rows.clear();
        Ok(())
    }

    /// Writes the last rows and closes the table (a header or schema even with no rows).
    pub fn finish(mut self) -> Result<u64, ColumnarError> {
        self.flush()?;
        self.sink.finish(self.schema)?;
        Ok(self.written)
    }
}
