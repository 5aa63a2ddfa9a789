//! Pointer helpers: the only `unsafe` code. Each checks for NULL (and alignment/initialisation for
//! contexts) before turning a pointer into a reference.
use crate::context::{Context, CONTEXT_MAGIC};
use crate::types::{RiskscoreContext, RiskscoreStatus};
use crate::{RISKSCORE_CONTEXT_SIZE, RISKSCORE_MAX_TRACKS};
use scorer_core::warning::TrackTable;

/// Reads a `T` from a caller pointer (any alignment).
///
/// # Safety
/// `p` is NULL or valid for reading a `T`.
pub(crate) unsafe fn read<T: Copy>(p: *const T) -> Result<T, RiskscoreStatus> {
    if p.is_null() {
        return Err(RiskscoreStatus::NullPointer);
    }
    // SAFETY: non-null, and valid for reads per the contract; `read_unaligned` accepts any
    // alignment, so a packed caller struct is fine too.
    Ok(unsafe { p.read_unaligned() })
}

/// Writes `v` to a caller pointer (any alignment).
///
/// # Safety
/// `p` is NULL or valid for writing a `T`.
pub(crate) unsafe fn write<T>(p: *mut T, v: T) -> Result<(), RiskscoreStatus> {
    if p.is_null() {
        return Err(RiskscoreStatus::NullPointer);
    }
    // SAFETY: non-null and valid for writes per the contract; the output types are plain data
    // (no drop glue), so overwriting without dropping the old value is correct.
    unsafe { p.write_unaligned(v) };
    Ok(())
}

/// Writes `v` when `p` is not NULL.
///
/// # Safety
/// `p` is NULL or valid for writing a `T`.
pub(crate) unsafe fn write_optional<T>(p: *mut T, v: T) {
    if !p.is_null() {
        // SAFETY: as in `write`.
        unsafe { p.write_unaligned(v) };
    }
}

/// The caller's blob as a slice with the lifetime the caller promises (as long as the context
/// uses it).
///
/// # Safety
/// `blob` is NULL or valid for reading `len` bytes for as long as the returned slice is used.
pub(crate) unsafe fn blob_slice(
    blob: *const u8,
    len: usize,
) -> Result<&'static [u8], RiskscoreStatus> {
    if blob.is_null() {
        return Err(RiskscoreStatus::NullPointer);
    }
    // No buffer is that long (e.g. a failed read's -1 as `size_t`): more bytes than the blob has,
    // as for any other too-long `len` (not "truncated", the opposite of what is wrong).
    if len > isize::MAX as usize {
        return Err(RiskscoreStatus::ModelTrailingBytes);
    }
    // SAFETY: non-null, `len` readable bytes per the contract, `len <= isize::MAX`; `u8` has
    // alignment 1. The 'static lifetime is the caller's promise that the blob outlives its use.
    Ok(unsafe { core::slice::from_raw_parts(blob, len) })
}

/// Checks an opaque context pointer: non-null, aligned, initialised.
///
/// # Safety
/// `context` is NULL or valid for reads of `RISKSCORE_CONTEXT_SIZE` bytes.
pub(crate) unsafe fn checked(
    context: *const RiskscoreContext,
) -> Result<*const Context, RiskscoreStatus> {
    if context.is_null() {
        return Err(RiskscoreStatus::NullPointer);
    }
    let inner = context.cast::<Context>();
    if !inner.is_aligned() {
        return Err(RiskscoreStatus::ContextMisaligned);
    }
    // SAFETY: non-null, aligned, and at least `size_of::<Context>()` readable bytes (compile-time
    // assert in `context.rs`); `magic` is the first field of the `repr(C)` struct and any bit
    // pattern is a valid `u32`, so the read is sound even if the block was never initialised.
    let magic = unsafe { inner.cast::<u32>().read() };
    if magic != CONTEXT_MAGIC {
        return Err(RiskscoreStatus::ContextNotInitialized);
    }
    Ok(inner)
}

/// # Safety
/// `context` is NULL or a context initialised by `riskscore_init`, not aliased for the returned
/// lifetime (the C API is not re-entrant on one context).
pub(crate) unsafe fn context_ref<'a>(
    context: *const RiskscoreContext,
) -> Result<&'a Context, RiskscoreStatus> {
    // SAFETY: caller contract; `checked` verified non-null, alignment and the init magic, so the
    // bytes hold a `Context` written by `init_context`.
    unsafe { checked(context).map(|p| &*p) }
}

/// # Safety
/// As [`context_ref`], and writable.
pub(crate) unsafe fn context_mut<'a>(
    context: *mut RiskscoreContext,
) -> Result<&'a mut Context, RiskscoreStatus> {
    // SAFETY: as in `context_ref`; the caller owns the block mutably for the call.
    unsafe { checked(context).map(|p| &mut *(p as *mut Context)) }
}

/// Writes a fresh context into the caller's block.
///
/// # Safety
/// `context` is NULL or valid for writes of `context_size` bytes.
pub(crate) unsafe fn init_context(
    context: *mut RiskscoreContext,
    context_size: usize,
    tracks: TrackTable<RISKSCORE_MAX_TRACKS>,
) -> Result<(), RiskscoreStatus> {
    if context.is_null() {
        return Err(RiskscoreStatus::NullPointer);
    }
    if context_size < RISKSCORE_CONTEXT_SIZE {
        return Err(RiskscoreStatus::ContextTooSmall);
    }
    let inner = context.cast::<Context>();
    if !inner.is_aligned() {
        return Err(RiskscoreStatus::ContextMisaligned);
    }
    let fresh = Context {
        magic: CONTEXT_MAGIC,
        drl: None,
        msra: None,
        gssm: None,
        tracks,
    };
    // SAFETY: non-null, aligned, `context_size >= RISKSCORE_CONTEXT_SIZE >= size_of::<Context>()`
    // writable bytes. `write` does not drop the previous contents: a re-initialised context only
    // held borrowed blobs and plain data, nothing that needs dropping.
    unsafe { inner.write(fresh) };
    Ok(())
}
