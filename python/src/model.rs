//! `riskscore.Model`: a model blob, scored over tables of pairs exactly as on the ECU.
use std::io::Read;

use arrow_array::{Array, BooleanArray, Float32Array};
use arrow_data::ArrayData;
use arrow_pyarrow::{PyArrowType, Table};

use arrow_array::RecordBatch;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use rayon::prelude::*;
use riskscore_data::ssm_csv::{PairColumns, RowError};
use riskscore_eval::arrow_kernel::{guarded_kernel, score_kernel, KernelError};
use riskscore_eval::model_files::{
    model_file_kind, ModelFileError, ModelFileKind, KIND_HEAD_BYTES,
};
use scorer_core::model::{self, ThresholdRule, DRL_INPUT_SCHEMA};

use crate::errors::{BadRow, Failure};
use crate::tables::{
    flatten_flags, flatten_scores, gather_bad, kernel_failure, locate, rows_per_task, slices,
};

/// The file `path` (`None`: bytes given to `from_bytes`) is not a blob, because of `e`. A file
/// that is a training checkpoint (`head`: its first bytes, [`model_file_kind`]) is named as one,
/// with the command that exports its blob, in riskctl's words ([`ModelFileError::Checkpoint`]).
fn invalid(path: Option<&str>, head: &[u8], e: model::ModelError) -> Failure {
    match path {
        Some(path) if model_file_kind(head) == Some(ModelFileKind::Checkpoint) => {
            Failure::Model(ModelFileError::Checkpoint { path: path.into() }.to_string())
        }
        _ => Failure::Model(format!(
            "{}: not a valid model blob: {e}",
            path.unwrap_or("model bytes")
        )),
    }
}

/// A decoded, validated model blob (`*.rsk`).
#[pyclass(frozen, module = "riskscore._riskscore")]
pub struct Model {
    bytes: Vec<u8>,
    /// Where the blob was read from (`None` for `from_bytes`), for messages.
    path: Option<String>,
}

impl Model {
    fn checked(bytes: Vec<u8>, path: Option<String>) -> Result<Self, Failure> {
        model::decode_blob(&bytes).map_err(|e| invalid(path.as_deref(), &bytes, e))?;
        Ok(Model { bytes, path })
    }

    fn blob(&self) -> model::ModelBlob<'_> {
        // Validated in `checked`, and the bytes never change.
        model::decode_blob(&self.bytes).expect("validated at construction")
    }

    /// `kernel` over the slices of `table` on every core: its per-slice outputs in row order,
    /// the first bad rows, their count and the number of rows.
    fn over_slices<T: Send>(
        &self,
        table: PyArrowType<Table>,
        kernel: impl Fn(
                &model::ModelBlob<'_>,
                &PairColumns,
                &RecordBatch,
                u64,
            ) -> Result<(T, Vec<RowError>), KernelError>
            + Sync,
    ) -> Result<(Vec<T>, Vec<BadRow>, u64, usize), Failure> {
        let (batches, schema) = table.0.into_inner();
        let columns = locate(&schema)?;
        let blob = self.blob();
        let total = batches.iter().map(|b| b.num_rows()).sum();
        let results: Vec<_> = crate::pool::install(|| {
            slices(&batches, rows_per_task(total))
                .par_iter()
                .map(|(first, batch)| {
                    kernel(&blob, &columns, batch, *first).map_err(kernel_failure)
                })
                .collect::<Result<_, Failure>>()
        })??;
        let (parts, bad): (Vec<_>, Vec<_>) = results.into_iter().unzip();
        let (listed, count) = gather_bad(bad);
        Ok((parts, listed, count, total))
    }
}

#[pymethods]
impl Model {
    #[staticmethod]
    fn load(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        let shown = path.display().to_string();
        let read_error = |e: std::io::Error| {
            let message = format!("model file {shown}: cannot read: {e}");
            // OSError(errno, text) is the errno's subclass: FileNotFoundError, PermissionError...
            match e.raw_os_error() {
                Some(errno) => pyo3::exceptions::PyOSError::new_err((errno, message)),
                None => pyo3::exceptions::PyOSError::new_err(message),
            }
        };
        // The header first: a file that is no blob (a Parquet table of pairs passed by mistake,
        // a pipe) is refused from its first 20 bytes, not read whole into memory. Only a header
        // that is merely short goes on to the full read, whose check reports it as before.
        let mut file = std::fs::File::open(&path).map_err(read_error)?;
        let mut bytes = Vec::with_capacity(model::HEADER_LEN);
        (&mut file)
            .take(model::HEADER_LEN as u64)
            .read_to_end(&mut bytes)
            .map_err(read_error)?;
        match model::decode_header(&bytes) {
            Err(e) if !matches!(e, model::ModelError::Truncated { .. }) => {
                // Enough of a regular file to tell a training checkpoint (a pipe is not waited
                // on: its header decided).
                if file.metadata().is_ok_and(|m| m.is_file()) {
                    (&mut file)
                        .take((KIND_HEAD_BYTES - bytes.len()) as u64)
                        .read_to_end(&mut bytes)
                        .map_err(read_error)?;
                }
                return Err(invalid(Some(&shown), &bytes, e).into_py(py));
            }
            _ => {}
        }
        file.read_to_end(&mut bytes).map_err(read_error)?;
        Model::checked(bytes, Some(shown)).map_err(|f| f.into_py(py))
    }

    #[staticmethod]
    fn from_bytes(py: Python<'_>, blob: &[u8]) -> PyResult<Self> {
        Model::checked(blob.to_vec(), None).map_err(|f| f.into_py(py))
    }

    /// The blob's bytes (what `from_bytes` takes; what a Spark job broadcasts).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.bytes)
    }

    #[getter]
    fn path(&self) -> Option<String> {
        self.path.clone()
    }

    /// What `riskctl inspect-model` reports, as a dict.
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let header = model::decode_header(&self.bytes).expect("validated at construction");
        let blob = self.blob();
        let info = PyDict::new(py);
        info.set_item("kind", header.kind.name())?;
        info.set_item("kind_byte", header.kind as u8)?;
        info.set_item("format_version", header.version)?;
        info.set_item("input_schema", header.feature_schema)?;
        let drl = header.feature_schema == DRL_INPUT_SCHEMA;
        info.set_item(
            "encoding",
            if drl {
                "DRL input encoding 3 (scorer_core::encoding)"
            } else {
                "the 13 features"
            },
        )?;
        let inputs: Vec<&str> = if drl {
            scorer_core::DRL_INPUT_NAMES.to_vec()
        } else {
            scorer_core::FEATURE_NAMES.to_vec()
        };
        info.set_item("inputs", inputs)?;
        info.set_item("int8", matches!(blob.model, model::Model::DrlInt8(_)))?;
        info.set_item("payload_bytes", header.payload_len)?;
        info.set_item("payload_crc32", header.payload_crc)?;
        info.set_item("total_bytes", self.bytes.len())?;
        info.set_item("default_threshold", blob.default_threshold())?;
        let rule = PyDict::new(py);
        match blob.meta.default_threshold {
            None => rule.set_item("rule", "kind_default")?,
            Some(op) => {
                match op.rule {
                    ThresholdRule::KindDefault => rule.set_item("rule", "kind_default")?,
                    ThresholdRule::SafeShare {
                        target,
                        measured,
                        sequences,
                    } => {
                        rule.set_item("rule", "safe_share")?;
                        rule.set_item("target", target)?;
                        rule.set_item("measured", measured)?;
                        rule.set_item("sequences", sequences)?;
                    }
                }
                rule.set_item("data", op.data)?;
            }
        }
        rule.set_item("stored", blob.meta.default_threshold.is_some())?;
        info.set_item("threshold_rule", rule)?;
        // What scoring does outside the training domain (`None`: the blob has no record).
        info.set_item(
            "domain_policy",
            blob.meta.training_domain.map(|d| d.policy.name()),
        )?;
        // The network's share inside the domain under `blend` (`None` under any other policy).
        info.set_item(
            "blend_network_weight",
            blob.meta.blend.map(|b| b.network_weight),
        )?;
        Ok(info)
    }

    /// Scores of every row of `table` as one contiguous f32 column (NaN where a row is bad), the
    /// first bad rows and their count.
    fn _score(
        &self,
        py: Python<'_>,
        table: PyArrowType<Table>,
    ) -> PyResult<(PyArrowType<ArrayData>, Vec<BadRow>, u64)> {
        let scored = py.detach(|| {
            self.over_slices(table, |blob, columns, batch, first| {
                score_kernel(blob, columns, batch, first)
            })
            .map(|(parts, listed, count, total)| {
                let scores = Float32Array::from(flatten_scores(&parts, total));
                (PyArrowType(scores.into_data()), listed, count)
            })
        });
        scored.map_err(|f| f.into_py(py))
    }

    /// Whether every row of `table` lies inside the model's training domain, as one bool column
    /// (false where a row is bad), the first bad rows and their count.
    fn _in_domain(
        &self,
        py: Python<'_>,
        table: PyArrowType<Table>,
    ) -> PyResult<(PyArrowType<ArrayData>, Vec<BadRow>, u64)> {
        let flagged = py.detach(|| {
            self.over_slices(table, |blob, columns, batch, first| {
                guarded_kernel(blob, columns, batch, first).map(|(_, inside, bad)| (inside, bad))
            })
            .map(|(parts, listed, count, total)| {
                let flags = BooleanArray::from(flatten_flags(&parts, total));
                (PyArrowType(flags.into_data()), listed, count)
            })
        });
        flagged.map_err(|f| f.into_py(py))
    }

    fn __repr__(&self) -> String {
        let header = model::decode_header(&self.bytes).expect("validated at construction");
        match &self.path {
            Some(p) => format!("<riskscore.Model {} from {p}>", header.kind.name()),
            None => format!(
                "<riskscore.Model {} ({} bytes)>",
                header.kind.name(),
                self.bytes.len()
            ),
        }
    }
}
