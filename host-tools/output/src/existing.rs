//! What already stands where an output goes: standard output under another name, a user's model
//! blob or training checkpoint. Both tools (`riskctl`, `can-bridge`) ask here, so a name of
//! standard output or a model is told apart the same way and refused with the same words.
use std::path::{Path, PathBuf};

/// True when the output `path` is this process's standard output: `-`, or a path to the same
/// file (`/dev/stdout`, `/proc/self/fd/1`, the terminal or pipe standard output is). The data
/// then owns standard output, and a command's human-readable summary goes to stderr.
pub fn is_stdout(path: &Path) -> bool {
    use std::os::fd::AsFd;
    use std::os::unix::fs::MetadataExt;
    if crate::is_dash(path) {
        return true;
    }
    let Ok(target) = std::fs::metadata(path) else {
        return false;
    };
    // Data thrown away is not a stream a summary could spoil (`--out /dev/null >/dev/null`).
    if std::fs::metadata("/dev/null")
        .is_ok_and(|n| n.dev() == target.dev() && n.ino() == target.ino())
    {
        return false;
    }
    let Ok(fd) = std::io::stdout().as_fd().try_clone_to_owned() else {
        return false;
    };
    std::fs::File::from(fd)
        .metadata()
        .is_ok_and(|m| m.dev() == target.dev() && m.ino() == target.ino())
}

/// What a file of a user's models is, told from its first bytes ([`model_file_kind`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelFileKind {
    /// A model blob (`*.rsk`): it starts with the blob magic, whether or not it decodes.
    Blob,
    /// A training checkpoint (`drl.json`, `msra.json`, the JSON `riskctl train` writes).
    Checkpoint,
}

/// How many leading bytes of a file [`model_file_kind`] reads (more are ignored).
pub const KIND_HEAD_BYTES: usize = 4096;

/// What the file starting with `head` is, if it is a model blob or a training checkpoint; `None`
/// for anything else. `head`: the file's first [`KIND_HEAD_BYTES`] bytes (or all, if fewer).
pub fn model_file_kind(head: &[u8]) -> Option<ModelFileKind> {
    if head.starts_with(&scorer_core::model::MAGIC) {
        Some(ModelFileKind::Blob)
    } else if looks_like_checkpoint(head) {
        Some(ModelFileKind::Checkpoint)
    } else {
        None
    }
}

/// A JSON object that names the training checkpoint format (`"format": "riskscore-checkpoint"`,
/// `riskscore_train::export::CHECKPOINT_FORMAT`) near its start: not a blob, but the file a blob
/// is exported from.
fn looks_like_checkpoint(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(KIND_HEAD_BYTES)];
    // A UTF-8 byte-order mark (saved again by a Windows editor) is not part of the JSON.
    let head = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    head.trim_ascii_start().starts_with(b"{")
        && head
            .windows(b"\"riskscore-checkpoint\"".len())
            .any(|w| w == b"\"riskscore-checkpoint\"")
}

/// What an existing output file holds, read from its first bytes ([`model_file_kind`]).
enum ExistingFile {
    /// Nothing to lose: no regular file there (missing, `-`, a pipe, a device: written into), an
    /// empty one, or one that cannot be read (the write says why it cannot replace it either).
    Nothing,
    Blob,
    Checkpoint,
    Other,
}

fn existing_file(out: &Path) -> ExistingFile {
    use std::io::Read;
    if is_stdout(out) || !std::fs::metadata(out).is_ok_and(|m| m.is_file() && m.len() > 0) {
        return ExistingFile::Nothing;
    }
    let mut head = Vec::with_capacity(KIND_HEAD_BYTES);
    let read = std::fs::File::open(out)
        .and_then(|f| f.take(KIND_HEAD_BYTES as u64).read_to_end(&mut head));
    match (read, model_file_kind(&head)) {
        (Err(_), _) => ExistingFile::Nothing,
        (Ok(_), Some(ModelFileKind::Blob)) => ExistingFile::Blob,
        (Ok(_), Some(ModelFileKind::Checkpoint)) => ExistingFile::Checkpoint,
        (Ok(_), None) => ExistingFile::Other,
    }
}

const CHECKPOINT: &str = "a training checkpoint (the JSON `riskctl train` writes)";

/// An output file that holds something a user would lose if it were written; it was left as it
/// is ([`refuse_overwriting_a_model`], [`refuse_replacing_a_non_blob`]).
#[derive(Debug, thiserror::Error)]
#[error("{flag} {}: {reason}", out.display())]
pub struct ExistingFileError {
    pub flag: String,
    pub out: PathBuf,
    reason: String,
}

/// Refuses an output file `out` (given with `flag`) that holds a user's model: a model blob or a
/// training checkpoint. A table or log written over it would lose the model (`score --out
/// run/drl.rsk`, one tab completion from `run/drl.csv`), and a model is never an output of the
/// commands that call this. `writes`: what the command writes there ("a candump log").
pub fn refuse_overwriting_a_model(
    flag: &str,
    out: &Path,
    writes: &str,
) -> Result<(), ExistingFileError> {
    let what = match existing_file(out) {
        ExistingFile::Nothing | ExistingFile::Other => return Ok(()),
        ExistingFile::Blob => "a model blob",
        ExistingFile::Checkpoint => CHECKPOINT,
    };
    Err(ExistingFileError {
        flag: flag.to_owned(),
        out: out.to_path_buf(),
        reason: format!(
            "it is {what}, not {writes}: writing there would replace the model; it is left as \
             it is. Give {flag} another name"
        ),
    })
}

/// Refuses an output file `out` (given with `flag`) that a model blob would replace although it
/// is not one: a training checkpoint (its trained parameters are lost), a table, a user's notes.
/// A blob (re-calibrating in place), an empty file, standard output and a device are written.
pub fn refuse_replacing_a_non_blob(flag: &str, out: &Path) -> Result<(), ExistingFileError> {
    let what = match existing_file(out) {
        ExistingFile::Nothing | ExistingFile::Blob => return Ok(()),
        ExistingFile::Checkpoint => {
            format!("{CHECKPOINT}: a blob written over it would lose its trained parameters")
        }
        ExistingFile::Other => {
            "not a model blob: a blob written over it would lose what it holds".to_owned()
        }
    };
    Err(ExistingFileError {
        flag: flag.to_owned(),
        out: out.to_path_buf(),
        reason: format!(
            "it is {what}; it is left as it is. Give {flag} another name (conventionally *.rsk)"
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_of_standard_output() {
        assert!(is_stdout(Path::new("-")));
        // Thrown away, not a stream a summary could spoil, whatever standard output is.
        assert!(!is_stdout(Path::new("/dev/null")));
        assert!(!is_stdout(Path::new("/no/such/file")));
    }

    #[test]
    fn a_model_blob_or_checkpoint_is_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let blob = dir.path().join("m.rsk");
        let mut bytes = scorer_core::model::MAGIC.to_vec();
        bytes.extend_from_slice(&[0; 12]);
        std::fs::write(&blob, &bytes).unwrap();
        let err = refuse_overwriting_a_model("--out", &blob, "a log").unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "--out {}: it is a model blob, not a log: writing there would replace the model; \
                 it is left as it is. Give --out another name",
                blob.display()
            )
        );
        let ckpt = dir.path().join("drl.json");
        std::fs::write(&ckpt, "\u{feff}{\"format\": \"riskscore-checkpoint\"}").unwrap();
        assert_eq!(
            model_file_kind(&std::fs::read(&ckpt).unwrap()),
            Some(ModelFileKind::Checkpoint)
        );
        assert!(refuse_overwriting_a_model("--out", &ckpt, "a log").is_err());
        assert!(refuse_replacing_a_non_blob("--out", &ckpt).is_err());
        refuse_replacing_a_non_blob("--out", &blob).unwrap();
        let notes = dir.path().join("notes.txt");
        std::fs::write(&notes, "mine").unwrap();
        refuse_overwriting_a_model("--out", &notes, "a log").unwrap();
        assert!(refuse_replacing_a_non_blob("--out", &notes).is_err());
        refuse_overwriting_a_model("--out", &dir.path().join("new.log"), "a log").unwrap();
    }
}
