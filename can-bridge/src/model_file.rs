//! Loading a model blob for the bridge: read, decode, validate, or refuse with the reason.
use scorer_core::model::{decode, decode_blob, Model, ModelKind};
use std::path::{Path, PathBuf};

/// A model file that decoded and validated. Holds the bytes the decoded model borrows from.
#[derive(Debug)]
pub struct ModelFile {
    pub path: PathBuf,
    bytes: Vec<u8>,
    kind: ModelKind,
}

/// Why a model file was refused.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    #[error("model file {path}: cannot read: {cause}")]
    Read {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("model file {path}: refused: {reason}")]
    Refused { path: PathBuf, reason: String },
}

impl ModelFile {
    /// Reads and checks a model file (header, CRC, payload, every invariant inference relies on).
    pub fn load(path: &Path) -> Result<Self, ModelFileError> {
        let bytes = std::fs::read(path).map_err(|cause| ModelFileError::Read {
            path: path.to_path_buf(),
            cause,
        })?;
        Self::from_bytes(path, bytes)
    }

    /// Checks an in-memory blob (`path` is only used in messages).
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Self, ModelFileError> {
        let refused = |reason: String| ModelFileError::Refused {
            path: path.to_path_buf(),
            reason,
        };
        let kind = {
            let model = decode(&bytes).map_err(|e| refused(e.to_string()))?;
            model.validate().map_err(|e| refused(e.to_string()))?;
            model.kind()
        };
        Ok(Self {
            path: path.to_path_buf(),
            bytes,
            kind,
        })
    }

    pub fn kind(&self) -> ModelKind {
        self.kind
    }

    /// The decoded model (the blob was checked at load, so this cannot fail in practice).
    pub fn model(&self) -> Result<Model<'_>, ModelFileError> {
        decode(&self.bytes).map_err(|e| self.refused(e))
    }

    /// The decoded blob: the model and its records (its training domain guards the scores).
    pub fn blob(&self) -> Result<scorer_core::model::ModelBlob<'_>, ModelFileError> {
        decode_blob(&self.bytes).map_err(|e| self.refused(e))
    }

    /// The warning threshold when the user gives none: the blob's calibrated default, else its
    /// kind's rule ([`scorer_core::model::ModelBlob::default_threshold`]).
    pub fn default_threshold(&self) -> Result<f32, ModelFileError> {
        decode_blob(&self.bytes)
            .map(|b| b.default_threshold())
            .map_err(|e| self.refused(e))
    }

    fn refused(&self, e: scorer_core::model::ModelError) -> ModelFileError {
        ModelFileError::Refused {
            path: self.path.clone(),
            reason: e.to_string(),
        }
    }
}
