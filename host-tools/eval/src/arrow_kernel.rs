//! Arrow kernels: the core's surrogates, features and model scores as functions from an Arrow
//! [`RecordBatch`] of pair columns to a batch of results, row for row.
//!
//! This is the layer an engine integration wraps (a DataFusion scalar UDF, a Spark Arrow UDF over
//! Arrow IPC; see docs/scale.md): it is stateless per row, so batches can be scored anywhere, in
//! any order. `riskctl ssm` uses it for Parquet files and `riskctl score` for its columnar output.
//!
//! Input: the 18 pair columns `x_i ... width_j` (names matched case-insensitively, as in CSV),
//! each Float64, Float32, Int64 or Int32. Output: [`SURROGATE_COLUMNS`] and the 13 `f_` features
//! as Float32, nullable: a row that fails validation (null or non-finite value, negative size,
//! zero heading; the same rules as the CSV reader) is null in every output column and listed in
//! [`SsmBatch::bad`]. Every number is computed by `scorer-core`, in f32, exactly as on the ECU.
use std::borrow::Cow;
use std::sync::Arc;

use arrow_array::cast::AsArray;
use arrow_array::types::{ArrowPrimitiveType, Float32Type, Float64Type, Int32Type, Int64Type};
use arrow_array::{Array, ArrayRef, BooleanArray, Float32Array, PrimitiveArray, RecordBatch};
use arrow_buffer::NullBuffer;
use arrow_schema::{ArrowError, DataType, Field, Schema, SchemaRef};
use scorer_core::model::ModelBlob;
use scorer_core::{Guarded, VehicleState};

use riskscore_data::ssm_csv::{
    computed_values, PairColumns, RowError, RowProblem, SsmError, SURROGATE_COLUMNS,
};

/// Number of computed columns: 4 surrogates + 13 features.
pub const COMPUTED: usize = 17;

/// A problem with a batch as a whole.
#[derive(Debug, thiserror::Error)]
pub enum KernelError {
    #[error(transparent)]
    Columns(#[from] SsmError),
    #[error(
        "column {name}: type {found} is not supported: a pair column must be Float64, Float32, Int64 or Int32 (cast it)"
    )]
    ColumnType { name: String, found: DataType },
    #[error(transparent)]
    Arrow(#[from] ArrowError),
}

/// Names of the computed columns, in output order.
pub fn computed_names() -> Vec<String> {
    SURROGATE_COLUMNS
        .iter()
        .map(|c| c.to_string())
        .chain(scorer_core::FEATURE_NAMES.iter().map(|f| format!("f_{f}")))
        .collect()
}

/// Schema of [`ssm_kernel`]'s output: 17 nullable Float32 columns.
pub fn computed_schema() -> SchemaRef {
    Arc::new(Schema::new(
        computed_names()
            .into_iter()
            .map(|n| Field::new(n, DataType::Float32, true))
            .collect::<Vec<_>>(),
    ))
}

/// Where the pair columns are in a schema.
pub fn pair_columns(schema: &Schema) -> Result<PairColumns, SsmError> {
    let names: Vec<String> = schema.fields().iter().map(|f| f.name().clone()).collect();
    PairColumns::from_header(&csv::StringRecord::from(names))
}

/// The result of one batch.
#[derive(Debug, Clone)]
pub struct SsmBatch {
    /// 17 Float32 columns ([`computed_schema`]), one row per input row.
    pub computed: RecordBatch,
    /// True for the rows that were scored (false: null outputs, listed in `bad`).
    pub valid: BooleanArray,
    /// Rows that could not be scored; `line` is the 1-based row number (`first_row` + index + 1).
    pub bad: Vec<RowError>,
}

/// One pair column of a batch as f64 values, made once per batch: a Float64 column's own buffer,
/// other types converted in one pass. The row loop then reads plain slices, without a per-value
/// type dispatch.
struct Column<'a> {
    values: Cow<'a, [f64]>,
    /// `None` when the column has no null.
    nulls: Option<&'a NullBuffer>,
}

fn numeric<'a>(batch: &'a RecordBatch, k: usize) -> Result<Column<'a>, KernelError> {
    let column = batch.column(k);
    let bad = || KernelError::ColumnType {
        name: batch.schema().field(k).name().clone(),
        found: column.data_type().clone(),
    };
    fn widened<T: ArrowPrimitiveType>(
        a: &PrimitiveArray<T>,
        f: impl Fn(T::Native) -> f64,
    ) -> Cow<'static, [f64]> {
        Cow::Owned(a.values().iter().map(|&v| f(v)).collect())
    }
    let values = match column.data_type() {
        DataType::Float64 => Cow::Borrowed(
            &**column
                .as_primitive_opt::<Float64Type>()
                .ok_or_else(bad)?
                .values(),
        ),
        DataType::Float32 => widened(
            column.as_primitive_opt::<Float32Type>().ok_or_else(bad)?,
            f64::from,
        ),
        DataType::Int64 => widened(
            column.as_primitive_opt::<Int64Type>().ok_or_else(bad)?,
            |v| v as f64,
        ),
        DataType::Int32 => widened(
            column.as_primitive_opt::<Int32Type>().ok_or_else(bad)?,
            f64::from,
        ),
        _ => return Err(bad()),
    };
    Ok(Column {
        values,
        nulls: column.nulls().filter(|n| n.null_count() > 0),
    })
}

/// Validate every row of `batch` and hand the valid pairs (row index, ego, partner) to `each`.
fn for_each_pair(
    columns: &PairColumns,
    batch: &RecordBatch,
    first_row: u64,
    mut each: impl FnMut(usize, Option<(VehicleState, VehicleState)>),
) -> Result<Vec<RowError>, KernelError> {
    let ego = vehicle_columns(batch, &columns.ego)?;
    let partner = vehicle_columns(batch, &columns.partner)?;
    let n = batch.num_rows();
    // Fixed-size arrays of slices cut to the batch length: the row loop below then reads 18
    // values with a loop the compiler unrolls, without a call or a length check per vehicle.
    let ego_values: [&[f64]; 9] = std::array::from_fn(|k| &ego[k].values[..n]);
    let partner_values: [&[f64]; 9] = std::array::from_fn(|k| &partner[k].values[..n]);
    let any_nulls = ego.iter().chain(&partner).any(|c| c.nulls.is_some());
    let mut bad = Vec::new();
    // Partners of one ego usually follow each other: its state is built once for them all.
    let mut last_ego = None;
    for row in 0..n {
        let line = first_row + row as u64 + 1;
        let present = !any_nulls
            || ego
                .iter()
                .chain(&partner)
                .all(|c| c.nulls.is_none_or(|nulls| nulls.is_valid(row)));
        let pair = if present {
            let (mut e, mut p) = ([0f64; 9], [0f64; 9]);
            for k in 0..9 {
                e[k] = ego_values[k][row];
                p[k] = partner_values[k][row];
            }
            columns.pair_from_values_reusing(e, p, line, &mut last_ego)
        } else {
            let first_null = |cols: &[Column], idx: &[usize; 9]| {
                cols.iter()
                    .zip(idx)
                    .find(|(c, _)| c.nulls.is_some_and(|nulls| nulls.is_null(row)))
                    .map(|(_, &k)| k)
            };
            let k =
                first_null(&ego, &columns.ego).or_else(|| first_null(&partner, &columns.partner));
            Err(RowError {
                line,
                column: k.and_then(|k| columns.names.get(k).cloned()),
                problem: RowProblem::Missing,
            })
        };
        match pair {
            Ok(pair) => each(row, Some(pair)),
            Err(e) => {
                bad.push(e);
                each(row, None);
            }
        }
    }
    Ok(bad)
}

/// The nine columns of one vehicle (at `indices`), in [`VehicleState`] order.
fn vehicle_columns<'a>(
    batch: &'a RecordBatch,
    indices: &[usize; 9],
) -> Result<Vec<Column<'a>>, KernelError> {
    indices.iter().map(|&k| numeric(batch, k)).collect()
}

/// Surrogates and features of every row of `batch` (pair columns located by `columns`, e.g.
/// from [`pair_columns`]). `first_row` numbers the rows in error reports.
pub fn ssm_kernel(
    columns: &PairColumns,
    batch: &RecordBatch,
    first_row: u64,
) -> Result<SsmBatch, KernelError> {
    let n = batch.num_rows();
    // Written in place, row by row (an invalid row keeps its zeros under the null mask).
    let mut out: [Vec<f32>; COMPUTED] = std::array::from_fn(|_| vec![0f32; n]);
    let mut valid = vec![true; n];
    let bad = for_each_pair(columns, batch, first_row, |row, pair| match pair {
        Some((e, p)) => {
            for (column, v) in out.iter_mut().zip(computed_values(&e, &p)) {
                column[row] = v;
            }
        }
        None => valid[row] = false,
    })?;
    let nulls = (!bad.is_empty()).then(|| NullBuffer::from(valid.clone()));
    let arrays: Vec<ArrayRef> = out
        .into_iter()
        .map(|values| Arc::new(Float32Array::new(values.into(), nulls.clone())) as ArrayRef)
        .collect();
    Ok(SsmBatch {
        computed: RecordBatch::try_new(computed_schema(), arrays)?,
        valid: BooleanArray::from(valid),
        bad,
    })
}

/// A model blob's risk score for every row of `batch`, through the same scoring path as
/// `riskctl score` and `riskctl evaluate` ([`crate::Scorer::Guarded`]: int8 for DRL, the blob's
/// training-domain policy outside its domain, as on the ECU). Invalid rows are null.
pub fn score_kernel(
    blob: &ModelBlob<'_>,
    columns: &PairColumns,
    batch: &RecordBatch,
    first_row: u64,
) -> Result<(Float32Array, Vec<RowError>), KernelError> {
    let mut scores = Vec::with_capacity(batch.num_rows());
    let bad = for_each_guarded(blob, columns, batch, first_row, |guarded| {
        scores.push(guarded.map(|g| g.score));
    })?;
    Ok((Float32Array::from(scores), bad))
}

/// [`score_kernel`]'s scores and, per row, whether the pair lies inside the blob's training
/// domain (the `<model>_in_domain` column of `riskctl score`; always for a blob without a
/// record). Invalid rows are null in both.
pub fn guarded_kernel(
    blob: &ModelBlob<'_>,
    columns: &PairColumns,
    batch: &RecordBatch,
    first_row: u64,
) -> Result<(Float32Array, BooleanArray, Vec<RowError>), KernelError> {
    let mut scores = Vec::with_capacity(batch.num_rows());
    let mut inside = Vec::with_capacity(batch.num_rows());
    let bad = for_each_guarded(blob, columns, batch, first_row, |guarded| {
        scores.push(guarded.map(|g| g.score));
        inside.push(guarded.map(|g| g.in_domain));
    })?;
    Ok((Float32Array::from(scores), BooleanArray::from(inside), bad))
}

/// Each row's guarded score in row order (`None`: an invalid row), so that a caller builds only
/// the columns it returns.
fn for_each_guarded(
    blob: &ModelBlob<'_>,
    columns: &PairColumns,
    batch: &RecordBatch,
    first_row: u64,
    mut each: impl FnMut(Option<Guarded>),
) -> Result<Vec<RowError>, KernelError> {
    for_each_pair(columns, batch, first_row, |_, pair| {
        each(pair.map(|(ego, partner)| {
            blob.score_guarded(&scorer_core::Observation::of(&ego, &partner))
        }));
    })
}

/// `input`'s columns followed by `computed`'s, keeping only the rows where `keep` is true (all
/// rows when `None`).
pub fn append_columns(
    input: &RecordBatch,
    computed: &RecordBatch,
    keep: Option<&BooleanArray>,
) -> Result<RecordBatch, ArrowError> {
    let fields: Vec<Arc<Field>> = input
        .schema()
        .fields()
        .iter()
        .chain(computed.schema().fields().iter())
        .cloned()
        .collect();
    let columns: Vec<ArrayRef> = input
        .columns()
        .iter()
        .chain(computed.columns())
        .cloned()
        .collect();
    let joined = RecordBatch::try_new(Arc::new(Schema::new(fields)), columns)?;
    match keep {
        Some(mask) if mask.false_count() > 0 => {
            arrow_select::filter::filter_record_batch(&joined, mask)
        }
        _ => Ok(joined),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::{Float64Array, Int32Array, StringArray};

    const NAMES: [&str; 9] = ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"];

    /// A batch with an `id` column and the 18 pair columns (upper-case ego names) from rows of
    /// 18 optional values.
    fn batch(rows: &[[Option<f64>; 18]]) -> RecordBatch {
        let mut fields = vec![Field::new("id", DataType::Utf8, false)];
        let mut arrays: Vec<ArrayRef> = vec![Arc::new(StringArray::from(
            (0..rows.len()).map(|k| format!("r{k}")).collect::<Vec<_>>(),
        ))];
        for (c, name) in NAMES
            .iter()
            .map(|n| format!("{}_I", n.to_uppercase()))
            .chain(NAMES.iter().map(|n| format!("{n}_j")))
            .enumerate()
        {
            fields.push(Field::new(name, DataType::Float64, true));
            arrays.push(Arc::new(Float64Array::from(
                rows.iter().map(|r| r[c]).collect::<Vec<_>>(),
            )));
        }
        RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays).unwrap()
    }

    fn rear_end() -> [Option<f64>; 18] {
        [
            0.0, 0.0, 20.0, 0.0, 1.0, 0.0, 0.5, 4.5, 1.8, 30.0, 0.0, 10.0, 0.0, 1.0, 0.0, 0.0, 4.0,
            1.9,
        ]
        .map(Some)
    }

    fn state(v: &[Option<f64>], origin: (f64, f64)) -> VehicleState {
        let v: Vec<f64> = v.iter().map(|x| x.unwrap()).collect();
        VehicleState {
            x: (v[0] - origin.0) as f32,
            y: (v[1] - origin.1) as f32,
            vx: v[2] as f32,
            vy: v[3] as f32,
            hx: v[4] as f32,
            hy: v[5] as f32,
            acc: v[6] as f32,
            length: v[7] as f32,
            width: v[8] as f32,
        }
    }

    #[test]
    fn computes_the_core_values_and_nulls_bad_rows() {
        let good = rear_end();
        let mut missing = rear_end();
        missing[12] = None; // vy_j
        let mut zero_heading = rear_end();
        zero_heading[4] = Some(0.0); // hx_i
        let mut utm = rear_end();
        utm[0] = Some(500_000.25);
        utm[9] = Some(500_030.25);
        let b = batch(&[good, missing, zero_heading, utm]);
        let columns = pair_columns(&b.schema()).unwrap();
        let out = ssm_kernel(&columns, &b, 10).unwrap();
        assert_eq!(out.computed.num_rows(), 4);
        assert_eq!(out.computed.schema(), computed_schema());
        let expected = computed_values(
            &state(&good[..9], (0.0, 0.0)),
            &state(&good[9..], (0.0, 0.0)),
        );
        for row in [0, 3] {
            for (k, e) in expected.iter().enumerate() {
                let col = out.computed.column(k).as_primitive::<Float32Type>();
                assert!(col.is_valid(row));
                assert_eq!(
                    col.value(row).to_bits(),
                    e.to_bits(),
                    "row {row} column {k}"
                );
            }
        }
        for k in 0..COMPUTED {
            let col = out.computed.column(k);
            assert!(col.is_null(1) && col.is_null(2));
        }
        assert_eq!(
            out.valid.iter().map(Option::unwrap).collect::<Vec<_>>(),
            [true, false, false, true]
        );
        let bad: Vec<(u64, Option<&str>, &str)> = out
            .bad
            .iter()
            .map(|e| (e.line, e.column.as_deref(), e.problem.kind()))
            .collect();
        assert_eq!(
            bad,
            [
                (12, Some("vy_j"), "missing field"),
                (13, Some("HX_I"), "zero heading")
            ]
        );
        let joined = append_columns(&b, &out.computed, Some(&out.valid)).unwrap();
        assert_eq!(joined.num_rows(), 2);
        assert_eq!(joined.num_columns(), 19 + COMPUTED);
        assert_eq!(
            joined.column(0).as_string::<i32>().value(1),
            "r3",
            "filtered rows keep their order"
        );
    }

    #[test]
    fn accepts_integer_and_f32_columns_and_rejects_text() {
        let b = batch(&[rear_end()]);
        let mut fields: Vec<Field> = b.schema().fields().iter().map(|f| (**f).clone()).collect();
        let mut arrays = b.columns().to_vec();
        // x_j as Int32 (30), length_j as Float32 (4).
        fields[10] = Field::new("x_j", DataType::Int32, false);
        arrays[10] = Arc::new(Int32Array::from(vec![30]));
        fields[17] = Field::new("length_j", DataType::Float32, false);
        arrays[17] = Arc::new(Float32Array::from(vec![4.0f32]));
        let mixed =
            RecordBatch::try_new(Arc::new(Schema::new(fields.clone())), arrays.clone()).unwrap();
        let columns = pair_columns(&mixed.schema()).unwrap();
        let a = ssm_kernel(&columns, &mixed, 0).unwrap();
        let b = ssm_kernel(&columns, &b, 0).unwrap();
        assert_eq!(a.computed, b.computed);

        fields[10] = Field::new("x_j", DataType::Utf8, false);
        arrays[10] = Arc::new(StringArray::from(vec!["30"]));
        let text = RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays).unwrap();
        match ssm_kernel(&columns, &text, 0) {
            Err(KernelError::ColumnType { name, .. }) => assert_eq!(name, "x_j"),
            other => panic!("expected a column type error, got {other:?}"),
        }
    }

    #[test]
    fn missing_pair_columns_are_named() {
        let schema = Schema::new(vec![Field::new("x_i", DataType::Float64, false)]);
        match pair_columns(&schema) {
            Err(SsmError::MissingColumns { missing }) => assert!(missing.contains("width_j")),
            other => panic!("expected missing columns, got {other:?}"),
        }
    }

    #[test]
    fn model_scores_match_the_evaluation_scorer_through_the_guard() {
        for file in ["drl-default.rsk", "msra-default.rsk"] {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/").to_string() + file;
            let bytes = std::fs::read(&path).unwrap();
            let blob = scorer_core::model::decode_blob(&bytes).unwrap();
            let mut near = rear_end();
            near[9] = Some(8.0);
            let mut bad = rear_end();
            bad[7] = Some(-1.0);
            // An ego at 60 m/s: beyond every shipped model's training domain.
            let mut fast = rear_end();
            fast[2] = Some(60.0);
            fast[11] = Some(50.0);
            let b = batch(&[rear_end(), near, bad, fast]);
            let columns = pair_columns(&b.schema()).unwrap();
            let (scores, errors) = score_kernel(&blob, &columns, &b, 0).unwrap();
            assert_eq!(scores.len(), 4);
            assert!(scores.is_null(2));
            assert_eq!(errors.len(), 1);
            assert_eq!(errors[0].line, 3);
            let (_, inside, _) = guarded_kernel(&blob, &columns, &b, 0).unwrap();
            assert!(inside.is_null(2));
            let scorer = crate::Scorer::Guarded(blob.clone());
            for (row, values) in [(0, rear_end()), (1, near), (3, fast)] {
                let (e, s) = (
                    state(&values[..9], (0.0, 0.0)),
                    state(&values[9..], (0.0, 0.0)),
                );
                let o = scorer_core::Observation::of(&e, &s);
                let expected = scorer.score(&o);
                assert_eq!(inside.value(row), blob.score_guarded(&o).in_domain);
                assert_eq!(
                    scores.value(row).to_bits(),
                    expected.to_bits(),
                    "{file} row {row}"
                );
                if row == 3 {
                    let guarded = blob.score_guarded(&o);
                    assert!(!guarded.in_domain, "{file}: 60 m/s is outside");
                    let unguarded = blob.model.score_observation(&o);
                    let fallback = blob
                        .meta
                        .training_domain
                        .is_some_and(|d| d.policy.uses_fallback());
                    assert_eq!(
                        scores.value(row) != unguarded,
                        fallback,
                        "{file}: the policy decides the score outside"
                    );
                }
            }
            assert!(
                scores.value(1) > scores.value(0),
                "{file}: closer is riskier"
            );
        }
    }
}
