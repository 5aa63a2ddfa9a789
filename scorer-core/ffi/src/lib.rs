//! The C ABI of riskscore: a thin, allocation-free layer over `scorer-core`.
//!
//! Everything is caller-owned. The caller reserves a [`RiskscoreContext`] (a fixed-size opaque
//! block: `RISKSCORE_CONTEXT_SIZE` bytes aligned to `RISKSCORE_CONTEXT_ALIGN`, static or on the
//! stack), initialises it with [`riskscore_init`], and loads model blobs into it with
//! [`riskscore_load_model`]. The context *borrows* each blob: the blob must stay valid and unchanged
//! while the context is used (on an ECU it is a `const` array in flash). Nothing is allocated, ever.
//!
//! A context has one slot per model family (DRL, MSRA, GSSM); loading a blob fills the slot of its
//! kind and replaces what was there. [`riskscore_score_pair`] computes the 13 features, the
//! surrogates and the score of every loaded model for one ego/partner pair, each through its
//! blob's training-domain guard (the same bits as `scorer_core`'s `ModelBlob::score_guarded`, with
//! a flag per model saying whether the pair was inside the domain); the caller feeds the
//! score it warns on to [`riskscore_track_update`], which runs the warning rule of the partner's
//! track; [`riskscore_track_get`] and [`riskscore_any_warning`] read the warning state.
//!
//! Errors: every function returns a [`RiskscoreStatus`]; outputs are written only on success
//! (but [`riskscore_load_model`]'s `info`, which describes the error).
//! Null pointers, a context that was not initialised (or is misaligned or too small), malformed
//! model blobs, non-finite vehicle states, NaN scores, out-of-order updates and a full track table
//! each have their own code, as have states without a usable heading or size and the reserved track
//! id `RISKSCORE_NONE_U32` (`RISKSCORE_STATUS_INVALID_INPUT`); [`riskscore_status_str`] names them.
//!
//! Panics: `scorer-core` has no panic paths (it denies unwrap/expect/panic/indexing). As a
//! backstop, the static library is built with `panic = abort`, and an `extern "C"` function that
//! panics aborts instead of unwinding into C. On bare-metal targets the panic handler calls the
//! integrator's `riskscore_panic` hook (see the header), which never returns.
//!
//! Not thread-safe: one context per task, or serialise access. Functions taking a `const`
//! context only read it.
//!
//! `unsafe` is confined to the pointer helpers in `ptr.rs`; each use states why it is sound. The
//! public functions null-check every pointer before touching it.
//!
//! Files, one API area each: `types` (the C-visible types), `context` (the context behind the
//! opaque bytes), `convert` (C types <-> core types, status codes), `abi` (version, sizes, status
//! names), `load` (initialising a context, loading models), `score` (scoring a pair), `tracks`
//! (the warning track table), `ptr` (the pointer helpers).
#![cfg_attr(target_os = "none", no_std)]

mod types;

mod context;
mod convert;
mod ptr;

mod abi;
mod load;
mod score;
mod tracks;

pub use abi::{riskscore_abi_version, riskscore_context_size, riskscore_status_str};
pub use context::context_bytes_used;
pub use load::{riskscore_init, riskscore_load_model, riskscore_model_default_threshold};
pub use score::riskscore_score_pair;
pub use tracks::{
    riskscore_any_warning, riskscore_track_get, riskscore_track_remove, riskscore_track_update,
};
pub use types::{
    RiskscoreContext, RiskscoreLoadInfo, RiskscoreModelKind, RiskscorePairResult, RiskscoreStatus,
    RiskscoreTrack, RiskscoreTrackStatus, RiskscoreVehicleState, RiskscoreWarningConfig,
    RiskscoreWarningEvent,
};

/// Version of this C ABI; bumped on any incompatible change of the header (2: the scores are
/// guarded by the blob's training domain and `RiskscorePairResult` reports the `*_in_domain` flags).
pub const RISKSCORE_ABI_VERSION: u32 = 2;
/// Bytes a RiskscoreContext occupies (large enough on 32- and 64-bit targets).
pub const RISKSCORE_CONTEXT_SIZE: usize = 5120;
/// RISKSCORE_CONTEXT_SIZE in 64-bit words.
pub const RISKSCORE_CONTEXT_WORDS: usize = 640;
/// Alignment a RiskscoreContext needs.
pub const RISKSCORE_CONTEXT_ALIGN: usize = 8;
/// Maximum number of partner tracks a context holds.
pub const RISKSCORE_MAX_TRACKS: usize = 32;
/// Number of observation features.
pub const RISKSCORE_FEATURE_COUNT: usize = 13;
/// Length of RiskscoreLoadInfo.field including the terminating NUL.
pub const RISKSCORE_FIELD_NAME_LEN: usize = 32;
/// "No value" for the optional `u64` times in output structs (`u32` outputs use
/// `RISKSCORE_NONE_U32`).
pub const RISKSCORE_NONE_U64: u64 = u64::MAX;
/// "No value" for optional `u32` outputs.
pub const RISKSCORE_NONE_U32: u32 = u32::MAX;

/// Bare-metal panic handler. `scorer-core` has no panic paths and this crate has none either, so
/// in an optimised build the handler is unreachable and removed by the linker; if a panic path ever
/// appears, it calls the integrator's `riskscore_panic` (which must not return: reset, or enter
/// the safe state), so the failure is loud instead of a silent hang.
#[cfg(all(target_os = "none", not(test)))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    extern "C" {
        /// Provided by the firmware that links the library.
        fn riskscore_panic() -> !;
    }
    // SAFETY: an argument-less C function that the integrator provides and that never returns.
    unsafe { riskscore_panic() }
}
