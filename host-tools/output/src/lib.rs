//! The one output layer of `riskctl` and `can-bridge`: nothing a user owns is ever destroyed.
//!
//! - [`refuse_overlaps`]: an output that is, contains or lies inside an input is refused before
//!   anything is read or written (device and inode, so links and `./x` vs `x` count).
//! - [`AtomicFile`] / [`AtomicSet`]: files written under a unique temporary name beside the
//!   target, synced, and renamed into place only on commit; removed when dropped.
//! - [`OutputDir`]: a folder built complete beside the target, then swapped in as a whole.
//! - [`OutputLock`]: a second process writing the same target is refused.
//! - [`NewFolders`]: folders made for an output are removed again if the run fails; every
//!   output's missing parent folders are made that way ([`OutputLock`], [`create_live_file`]).
//! - [`remove_temporaries_on_signals`]: Ctrl-C and SIGTERM remove the temporaries (exit 130/143).
//! - Devices and pipes (`/dev/null`) are written directly.
//! - [`is_stdout`]: every name of standard output (`-`, `/dev/stdout`, the file it is); and
//!   [`refuse_overwriting_a_model`]: a model blob or training checkpoint is not replaced by a
//!   command's table or log.
//!
//! The contract is written down in `docs/outputs.md`.
mod cleanup;
mod dir;
mod existing;
mod file;
mod folders;
mod lock;
mod overlap;
mod writeback;

pub use cleanup::remove_temporaries_on_signals;
pub use dir::{carry_missing, refuse_kind_clash, refuse_unswappable, OutputDir};
pub use existing::{
    is_stdout, model_file_kind, refuse_overwriting_a_model, refuse_replacing_a_non_blob,
    ExistingFileError, ModelFileKind, KIND_HEAD_BYTES,
};
pub use file::{is_read_only, open_special, AtomicFile, AtomicSet, READ_ONLY};
pub use folders::{create_live_file, NewFolders};
pub use lock::OutputLock;
pub use overlap::{
    is_dash, is_special_file, lies_within, refuse_overlaps, NamedPath, Overlap, SamePathError,
};
