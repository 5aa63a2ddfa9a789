//! `riskctl inspect-model`: describe a model blob and check its integrity.
use std::path::{Path, PathBuf};

use anyhow::Context;
use riskscore_eval::model_files::{model_file_kind, ModelFileKind};
use riskscore_train::export::{Checkpoint, ExportError};

/// Print a model blob's header, sizes and parameter summary, and check its integrity (magic,
/// version, kind, feature schema, payload length, CRC-32, and the model's own validation).
/// Exits with an error naming the problem when any check fails.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model blob (`*.rsk`).
    pub file: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let blob = std::fs::read(&args.file)
        .with_context(|| format!("{}: cannot read", args.file.display()))?;
    if let Some(not_a_blob) = checkpoint_not_blob(&args.file, &blob) {
        return Err(not_a_blob);
    }
    let text = riskscore_train::export::inspect(&blob)
        .map_err(|e| anyhow::anyhow!("{}: integrity check failed: {e}", args.file.display()))?;
    outln!("{}", args.file.display());
    out!("{text}");
    Ok(())
}

/// A training checkpoint (JSON) is not a blob: say what it is and how to get the blob. A file
/// that starts like JSON (`{`, after a UTF-8 byte-order mark and white space), as a checkpoint
/// does, but does not load as one (cut short, a field missing or renamed, another version) is
/// named as such with the loader's reason (line, column, field), not as a blob with a bad magic.
/// `None` for anything else: it is checked as a blob.
fn checkpoint_not_blob(path: &Path, bytes: &[u8]) -> Option<anyhow::Error> {
    let json = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if !json.trim_ascii_start().starts_with(b"{") {
        return None;
    }
    let file = path.display();
    let why = match Checkpoint::from_bytes(bytes.to_vec(), path) {
        Ok(_) => {
            return Some(anyhow::anyhow!(
                "{file}: not a model blob: it is a training checkpoint (the JSON `riskctl train` \
                 writes); export it first: riskctl export-model {file} --out MODEL.rsk"
            ))
        }
        Err(ExportError::BadCheckpoint { message, .. }) => message,
        Err(other) => other.to_string(),
    };
    let what = if model_file_kind(bytes) == Some(ModelFileKind::Checkpoint) {
        "it looks like a training checkpoint (JSON naming the format \"riskscore-checkpoint\")"
    } else {
        "it starts like JSON, as a training checkpoint does"
    };
    Some(anyhow::anyhow!(
        "{file}: not a model blob: {what}, but it does not load as one: {why}. \
         `riskctl train` writes each checkpoint with its blob beside it (drl.json: drl.rsk, \
         msra.json: msra.rsk); a blob is exported from a checkpoint that loads: \
         riskctl export-model CHECKPOINT --out MODEL.rsk"
    ))
}
