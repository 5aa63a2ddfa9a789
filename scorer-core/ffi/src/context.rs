//! The context behind the opaque bytes: what an initialised `RiskscoreContext` holds, and the
//! compile-time proof that it fits.
use crate::types::RiskscoreContext;
use crate::{
    RISKSCORE_CONTEXT_ALIGN, RISKSCORE_CONTEXT_SIZE, RISKSCORE_CONTEXT_WORDS,
    RISKSCORE_FEATURE_COUNT, RISKSCORE_MAX_TRACKS,
};
use core::mem::{align_of, size_of};
use scorer_core::model::ModelBlob;
use scorer_core::warning::TrackTable;
use scorer_core::FEATURE_COUNT;

/// Marks an initialised context ("RSKC"); anything else is rejected.
pub(crate) const CONTEXT_MAGIC: u32 = 0x434b_5352;

#[repr(C)]
pub(crate) struct Context {
    /// First field, so it can be checked through a `u32` read before the rest is trusted.
    pub magic: u32,
    /// Each slot keeps the blob's metadata records with its model: the training domain and the
    /// fallback are what `riskscore_score_pair` scores through (`ModelBlob::score_guarded`).
    pub drl: Option<ModelBlob<'static>>,
    pub msra: Option<ModelBlob<'static>>,
    pub gssm: Option<ModelBlob<'static>>,
    pub tracks: TrackTable<RISKSCORE_MAX_TRACKS>,
}

// The opaque block must hold the context on every target; checked at compile time.
const _: () = assert!(size_of::<Context>() <= RISKSCORE_CONTEXT_SIZE);
const _: () = assert!(align_of::<Context>() <= RISKSCORE_CONTEXT_ALIGN);
const _: () = assert!(align_of::<RiskscoreContext>() >= RISKSCORE_CONTEXT_ALIGN);
const _: () = assert!(size_of::<RiskscoreContext>() == RISKSCORE_CONTEXT_SIZE);
const _: () = assert!(RISKSCORE_CONTEXT_WORDS * 8 == RISKSCORE_CONTEXT_SIZE);
const _: () = assert!(RISKSCORE_FEATURE_COUNT == FEATURE_COUNT);

/// Bytes of the context actually used on this target (the rest of `RISKSCORE_CONTEXT_SIZE` is
/// slack for other pointer widths and future versions).
pub const fn context_bytes_used() -> usize {
    size_of::<Context>()
}
