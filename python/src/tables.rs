//! Tables of pairs through the Arrow kernels: split into slices (zero-copy), scored on every
//! core with the GIL released, reassembled in input order.
use std::sync::Arc;

use arrow_array::{Array, BooleanArray, Float32Array, RecordBatch};
use arrow_pyarrow::{PyArrowType, Table};
use arrow_schema::{DataType, Field, Schema};
use pyo3::prelude::*;
use rayon::prelude::*;
use riskscore_data::ssm_csv::{PairColumns, RowError};
use riskscore_eval::arrow_kernel::{
    append_columns, computed_names, computed_schema, pair_columns, ssm_kernel, KernelError,
};

use crate::errors::{bad_rows, BadRow, Failure};

/// At most this many bad rows are described one by one (all are counted).
pub const LISTED_BAD_ROWS: usize = 100;

/// The 17 computed column names, in output order.
#[pyfunction]
pub fn computed_columns() -> Vec<String> {
    computed_names()
}

/// `(first row, slice)` pieces of `batches` of at most `rows` rows each: slices share the input
/// buffers, and the first row numbers errors across the whole table.
pub fn slices(batches: &[RecordBatch], rows: usize) -> Vec<(u64, RecordBatch)> {
    let mut out = Vec::new();
    let mut first = 0u64;
    for batch in batches {
        let mut offset = 0;
        while offset < batch.num_rows() {
            let len = rows.min(batch.num_rows() - offset);
            out.push((first + offset as u64, batch.slice(offset, len)));
            offset += len;
        }
        first += batch.num_rows() as u64;
    }
    out
}

/// Rows per task: about eight tasks per core so the cores finish together, but large enough
/// that per-task overhead is noise (called inside [`crate::pool::install`], so "core" is a
/// thread of that pool).
pub fn rows_per_task(total: usize) -> usize {
    let tasks = 8 * rayon::current_num_threads().max(1);
    total.div_ceil(tasks).clamp(4096, 1 << 17)
}

pub fn kernel_failure(e: KernelError) -> Failure {
    Failure::Column(e.to_string())
}

/// Where the pair columns are, or which are missing; a pair column whose type the kernels do
/// not read is refused here, from the table's schema, not by the kernels batch by batch: a
/// zero-row table (no batches, or only empty ones) with a text pair column gets the same
/// `ColumnError` as one with rows.
pub fn locate(schema: &Schema) -> Result<PairColumns, Failure> {
    let columns = pair_columns(schema).map_err(|e| Failure::Column(e.to_string()))?;
    for &k in columns.ego.iter().chain(&columns.partner) {
        let field = schema.field(k);
        let supported = matches!(
            field.data_type(),
            DataType::Float64 | DataType::Float32 | DataType::Int64 | DataType::Int32
        );
        if !supported {
            // The kernels' own message, so a table with rows and one without read alike.
            return Err(kernel_failure(KernelError::ColumnType {
                name: field.name().clone(),
                found: field.data_type().clone(),
            }));
        }
    }
    Ok(columns)
}

/// The first [`LISTED_BAD_ROWS`] bad rows of all slices, and how many there are.
pub fn gather_bad(per_slice: impl IntoIterator<Item = Vec<RowError>>) -> (Vec<BadRow>, u64) {
    let mut listed = Vec::new();
    let mut total = 0u64;
    for errors in per_slice {
        total += errors.len() as u64;
        let room = LISTED_BAD_ROWS.saturating_sub(listed.len());
        listed.extend(bad_rows(errors.into_iter().take(room)));
    }
    (listed, total)
}

/// Surrogates and features of every row of `table` (see `riskscore.ssm`): the computed table
/// (after the input's columns when `keep_input`), the first bad rows and their count.
#[pyfunction]
#[pyo3(signature = (table, keep_input = false))]
pub fn ssm(
    py: Python<'_>,
    table: PyArrowType<Table>,
    keep_input: bool,
) -> PyResult<(PyArrowType<Table>, Vec<BadRow>, u64)> {
    let (batches, schema) = table.0.into_inner();
    let computed = py.detach(|| -> Result<_, Failure> {
        crate::pool::install(|| ssm_on_slices(batches, &schema, keep_input))?
    });
    let (table, listed, count) = computed.map_err(|f| f.into_py(py))?;
    Ok((PyArrowType(table), listed, count))
}

/// [`ssm`]'s work, on the current rayon pool.
fn ssm_on_slices(
    batches: Vec<RecordBatch>,
    schema: &Arc<Schema>,
    keep_input: bool,
) -> Result<(Table, Vec<BadRow>, u64), Failure> {
    let columns = locate(schema)?;
    let total = batches.iter().map(RecordBatch::num_rows).sum();
    let pieces = slices(&batches, rows_per_task(total));
    let results: Vec<_> = pieces
        .par_iter()
        .map(|(first, batch)| {
            let out = ssm_kernel(&columns, batch, *first).map_err(kernel_failure)?;
            let joined = if keep_input {
                append_columns(batch, &out.computed, None)
                    .map_err(|e| Failure::Column(e.to_string()))?
            } else {
                out.computed
            };
            Ok((joined, out.bad))
        })
        .collect::<Result<_, Failure>>()?;
    let out_schema = if keep_input {
        joined_schema(schema)
    } else {
        computed_schema()
    };
    let (out, bad): (Vec<RecordBatch>, Vec<Vec<RowError>>) = results.into_iter().unzip();
    let (listed, count) = gather_bad(bad);
    let table = Table::try_new(out, out_schema).map_err(|e| Failure::Column(e.to_string()))?;
    Ok((table, listed, count))
}

/// The input's fields followed by the computed ones.
fn joined_schema(input: &Schema) -> Arc<Schema> {
    let fields: Vec<Arc<Field>> = input
        .fields()
        .iter()
        .chain(computed_schema().fields().iter())
        .cloned()
        .collect();
    Arc::new(Schema::new(fields))
}

/// The kernel's in-domain flags of consecutive slices as one, false where a row was bad.
pub fn flatten_flags(parts: &[BooleanArray], total: usize) -> Vec<bool> {
    let mut out = Vec::with_capacity(total);
    for part in parts {
        out.extend(part.iter().map(|v| v.unwrap_or(false)));
    }
    out
}

/// One column of f32 scores as a contiguous vector, NaN where a slice's score is null.
pub fn flatten_scores(parts: &[Float32Array], total: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(total);
    for part in parts {
        if part.null_count() == 0 {
            out.extend_from_slice(part.values());
        } else {
            out.extend(part.iter().map(|v| v.unwrap_or(f32::NAN)));
        }
    }
    out
}
