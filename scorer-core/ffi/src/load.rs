//! Setting up a context: initialisation with a warning configuration, and loading model blobs.
use crate::convert::{kind_code, model_error, status, warning_config, warning_error};
use crate::ptr::{blob_slice, context_mut, init_context, read, write, write_optional};
use crate::types::{
    RiskscoreContext, RiskscoreLoadInfo, RiskscoreModelKind, RiskscoreStatus,
    RiskscoreWarningConfig,
};
use crate::{RISKSCORE_FIELD_NAME_LEN, RISKSCORE_NONE_U32};
use scorer_core::model::{self, ModelError, ModelKind};
use scorer_core::warning::TrackTable;

/// Initialises `context` (`context_size` bytes, pass `sizeof(RiskscoreContext)`): no model, empty
/// track table with `config`. Re-initialising drops the models and tracks.
///
/// # Safety
/// `context` must be NULL or point to `context_size` writable bytes; `config` must be NULL or
/// point to a readable `RiskscoreWarningConfig`.
#[no_mangle]
pub unsafe extern "C" fn riskscore_init(
    context: *mut RiskscoreContext,
    context_size: usize,
    config: *const RiskscoreWarningConfig,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: the caller guarantees `config` is NULL or valid for reads.
        let config = unsafe { read(config) }?;
        let config = warning_config(&config)?;
        let tracks = TrackTable::new(config).map_err(warning_error)?;
        // SAFETY: the caller guarantees `context` is NULL or valid for `context_size` bytes.
        unsafe { init_context(context, context_size, tracks) }
    };
    status(run())
}

/// Decodes and validates the model `blob` (`len` bytes) and installs it in the slot of its kind,
/// replacing the previous model of that family (DRL int8 or f32; MSRA, also one embedding a GSSM;
/// GSSM, also an SSRA, which is a fine-tuned GSSM: one context scores one of the two). The model
/// keeps the blob's metadata records: a training-domain record guards its scores in
/// `riskscore_score_pair`. On error the context is
/// unchanged. `info` may be NULL; otherwise it receives the kind (also on error once the header's
/// kind byte was read) and, on error, the offending field.
///
/// # Safety
/// `context` must be NULL or a context initialised by `riskscore_init`; `blob` must be NULL or
/// point to `len` readable bytes that stay valid and unchanged while the context uses the model;
/// `info` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_load_model(
    context: *mut RiskscoreContext,
    blob: *const u8,
    len: usize,
    info: *mut RiskscoreLoadInfo,
) -> RiskscoreStatus {
    let mut details = no_details();
    let mut run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_mut(context) }?;
        // SAFETY: caller contract above: the blob outlives every use of the context.
        let bytes: &'static [u8] = unsafe { blob_slice(blob, len) }?;
        // The kind byte (offset 6) is checked right after the magic and version: an error after it
        // (reserved byte, input schema) leaves a valid kind to report.
        match model::decode_header(bytes) {
            Ok(header) => details.kind = kind_code(header.kind),
            Err(
                ModelError::ReservedNotZero { .. }
                | ModelError::UnsupportedFeatureSchema(_)
                | ModelError::WrongInputSchema { .. },
            ) => {
                if let Some(Ok(kind)) = bytes.get(6).map(|&b| ModelKind::from_u8(b)) {
                    details.kind = kind_code(kind);
                }
            }
            Err(_) => {}
        }
        let m = model::decode_blob(bytes).map_err(|e| model_error(&e, &mut details))?;
        let slot = match m.model.kind() {
            ModelKind::DrlInt8 | ModelKind::DrlF32 => &mut ctx.drl,
            ModelKind::Msra => &mut ctx.msra,
            ModelKind::Gssm => &mut ctx.gssm,
        };
        *slot = Some(m);
        Ok(())
    };
    let result = run();
    // SAFETY: caller contract above; `info` is optional.
    unsafe { write_optional(info, details) };
    status(result)
}

/// Writes the default warning threshold of the model `blob` (`len` bytes) to `*threshold`: the
/// calibrated threshold a version-2 blob carries, else the rule of its kind (DRL 2.0, MSRA half
/// the sum of its weights' magnitudes, GSSM the middle of its score mode's range: 2.918 for the
/// intensity, 0 for the logit, 0.5 for the CDF). Fill `RiskscoreWarningConfig::threshold` with it when the
/// integration has no threshold of its own; `riskctl inspect-model` prints how it was chosen.
/// The blob is fully decoded and validated; `*threshold` is written only on success.
///
/// # Safety
/// `blob` must be NULL or point to `len` readable bytes; `threshold` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_model_default_threshold(
    blob: *const u8,
    len: usize,
    threshold: *mut f32,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above (the slice is only read within this call).
        let bytes = unsafe { blob_slice(blob, len) }?;
        let mut details = no_details();
        let decoded = model::decode_blob(bytes).map_err(|e| model_error(&e, &mut details))?;
        // SAFETY: caller contract above.
        unsafe { write(threshold, decoded.default_threshold()) }
    };
    status(run())
}

/// Load details before anything is known: no kind, no field, every number "none".
fn no_details() -> RiskscoreLoadInfo {
    RiskscoreLoadInfo {
        kind: RiskscoreModelKind::None,
        field: [0; RISKSCORE_FIELD_NAME_LEN],
        index: RISKSCORE_NONE_U32,
        expected: RISKSCORE_NONE_U32,
        found: RISKSCORE_NONE_U32,
    }
}
