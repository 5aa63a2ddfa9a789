//! Model files named on a command line (`[NAME=]FILE`): read, decoded and named as the rows of an
//! evaluation (and the columns of a score table).
use std::path::PathBuf;

use scorer_core::model::ModelError;

use crate::scoring::{model_row_name, reserved_name_clash, row_names, Method, Scorer};

/// A model file read into memory, so that decoded models can borrow from its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelFile {
    /// The row name given as `NAME=FILE`, if any.
    pub name: Option<String>,
    pub path: PathBuf,
    pub bytes: Vec<u8>,
}

/// A model file could not be read or is not a model blob.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    #[error("model file {}: cannot read", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("model file {}: not a valid model blob: {source}", path.display())]
    Decode {
        path: PathBuf,
        #[source]
        source: ModelError,
    },
    /// The file is a training checkpoint (`drl.json`, `msra.json`), which `riskctl train` writes
    /// beside the blobs: say so and how to get the blob, as `riskctl inspect-model` does.
    #[error(
        "model file {}: not a model blob: it is a training checkpoint (the JSON `riskctl train` \
         writes); give the blob written beside it (drl.rsk, msra.rsk) or export it first: \
         riskctl export-model {} --out MODEL.rsk",
        path.display(),
        path.display()
    )]
    Checkpoint { path: PathBuf },
    /// A model row named like a baseline row or a fixed column of the score table
    /// ([`reserved_name_clash`]): the report would hold two rows, or the table two columns, of it.
    #[error("--model {spec}: the name {name:?} clashes with {clash}; give the model another name (--model NAME=FILE)")]
    ReservedName {
        spec: String,
        name: String,
        clash: String,
    },
}

impl ModelFile {
    /// Splits `[NAME=]FILE` (a name has no path separator; otherwise the whole spec is the file)
    /// and reads the file.
    pub fn read(spec: &str) -> Result<ModelFile, ModelFileError> {
        let (name, path) = match spec.split_once('=') {
            Some((name, file))
                if !name.is_empty() && !name.contains(['/', '\\']) && !file.is_empty() =>
            {
                (Some(name.to_owned()), PathBuf::from(file))
            }
            _ => (None, PathBuf::from(spec)),
        };
        match std::fs::read(&path) {
            Ok(bytes) => Ok(ModelFile { name, path, bytes }),
            Err(source) => Err(ModelFileError::Read { path, source }),
        }
    }

    /// Reads every spec, in order.
    pub fn read_all(specs: &[String]) -> Result<Vec<ModelFile>, ModelFileError> {
        specs.iter().map(|spec| ModelFile::read(spec)).collect()
    }

    /// The decoded blob: the model and its metadata.
    pub fn blob(&self) -> Result<scorer_core::model::ModelBlob<'_>, ModelFileError> {
        scorer_core::model::decode_blob(&self.bytes).map_err(|source| {
            if model_file_kind(&self.bytes) == Some(ModelFileKind::Checkpoint) {
                ModelFileError::Checkpoint {
                    path: self.path.clone(),
                }
            } else {
                ModelFileError::Decode {
                    path: self.path.clone(),
                    source,
                }
            }
        })
    }

    /// The warning threshold the model's users get when they choose none: the calibrated
    /// threshold the blob carries, else its kind's rule
    /// ([`ModelBlob::default_threshold`](scorer_core::model::ModelBlob::default_threshold)).
    pub fn default_threshold(&self) -> Result<f32, ModelFileError> {
        Ok(self.blob()?.default_threshold())
    }
}

// Told apart in the output layer, where can-bridge's and riskctl's refusals to write over a
// model ask too; re-exported for the readers of model files (riskctl, the Python module).
pub use riskscore_output::{model_file_kind, ModelFileKind, KIND_HEAD_BYTES};

/// Decodes model files and names each: its `NAME=`, else its family (`DRL`, `MSRA`, ...), with the
/// file stem added only where two rows would share a name. A name that clashes with a baseline row
/// or a score-table column, given or derived, is refused.
pub fn named_models(files: &[ModelFile]) -> Result<Vec<Method<'_>>, ModelFileError> {
    let mut decoded = Vec::with_capacity(files.len());
    for f in files {
        let blob = f.blob()?;
        let stem = f.path.file_stem().map_or_else(
            || f.path.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        decoded.push((f.name.clone(), blob, stem));
    }
    let names = row_names(
        &decoded
            .iter()
            .map(|(n, b, stem)| (n.clone(), model_row_name(&b.model), stem.clone()))
            .collect::<Vec<_>>(),
    );
    for (file, name) in files.iter().zip(&names) {
        for name in file.name.iter().chain([name]) {
            if let Some(clash) = reserved_name_clash(name) {
                let spec = match &file.name {
                    Some(n) => format!("{n}={}", file.path.display()),
                    None => file.path.display().to_string(),
                };
                return Err(ModelFileError::ReservedName {
                    spec,
                    name: name.clone(),
                    clash,
                });
            }
        }
    }
    Ok(decoded
        .into_iter()
        .zip(names)
        .map(|((_, blob, _), name)| Method {
            name,
            scorer: Scorer::of_blob(blob),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_needs_no_path_separator_and_a_file() {
        let dir = std::env::temp_dir().join(format!("riskscore-models-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("a=b.rsk");
        std::fs::write(&file, b"not a model").unwrap();
        let spec = format!("MINE={}", file.display());
        let named = ModelFile::read(&spec).unwrap();
        assert_eq!((named.name.as_deref(), &named.path), (Some("MINE"), &file));
        // `dir/a=b.rsk`: the part before `=` holds a separator, so the whole spec is the file.
        let plain = ModelFile::read(&file.display().to_string()).unwrap();
        assert_eq!((plain.name.as_deref(), &plain.path), (None, &file));
        let err = named_models(std::slice::from_ref(&plain)).unwrap_err();
        assert!(matches!(err, ModelFileError::Decode { .. }), "{err}");
        assert!(matches!(
            ModelFile::read("X=/no/such/file"),
            Err(ModelFileError::Read { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// `riskctl evaluate --model run/drl.json` (the checkpoint beside the blobs `train` wrote) was
    /// refused as `not a model blob: magic [7b, 0a, 20, 20], expected "RSKM"`; it now says what
    /// the file is and which command makes the blob, as `inspect-model` does.
    #[test]
    fn a_training_checkpoint_is_named_as_one() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("drl.json");
        std::fs::write(
            &file,
            "{\n  \"format\": \"riskscore-checkpoint\",\n  \"version\": 3,\n  \"model\": {}\n}\n",
        )
        .unwrap();
        let f = ModelFile::read(&file.display().to_string()).unwrap();
        let err = named_models(std::slice::from_ref(&f))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("it is a training checkpoint")
                && err.contains(&format!("riskctl export-model {} --out", file.display())),
            "{err}"
        );
        // With a UTF-8 byte-order mark in front (export-model reads it) it is still one.
        let mut bom = b"\xEF\xBB\xBF".to_vec();
        bom.extend(std::fs::read(&file).unwrap());
        std::fs::write(&file, bom).unwrap();
        let f = ModelFile::read(&file.display().to_string()).unwrap();
        let err = named_models(std::slice::from_ref(&f)).unwrap_err();
        assert!(matches!(err, ModelFileError::Checkpoint { .. }), "{err}");
        // Other JSON is still a plain decode error.
        std::fs::write(&file, "{\"format\": \"something else\"}").unwrap();
        let f = ModelFile::read(&file.display().to_string()).unwrap();
        let err = named_models(std::slice::from_ref(&f)).unwrap_err();
        assert!(matches!(err, ModelFileError::Decode { .. }), "{err}");
    }
}
