//! What the linked library is: its ABI version, its context size and the names of status codes.
use crate::types::RiskscoreStatus;
use crate::{RISKSCORE_ABI_VERSION, RISKSCORE_CONTEXT_SIZE};
use core::ffi::c_char;

/// Returns `RISKSCORE_ABI_VERSION` of the linked library (compare with the header's).
#[no_mangle]
pub extern "C" fn riskscore_abi_version() -> u32 {
    RISKSCORE_ABI_VERSION
}

/// Returns `RISKSCORE_CONTEXT_SIZE` of the linked library (compare with the header's).
#[no_mangle]
pub extern "C" fn riskscore_context_size() -> usize {
    RISKSCORE_CONTEXT_SIZE
}

/// A static, NUL-terminated description of a status code (e.g. "model payload CRC mismatch");
/// never NULL. Takes the raw code so any integer is safe to pass.
#[no_mangle]
pub extern "C" fn riskscore_status_str(status: i32) -> *const c_char {
    let s: &'static [u8] = match RiskscoreStatus::from_code(status) {
        Some(RiskscoreStatus::Ok) => b"ok\0",
        Some(RiskscoreStatus::NullPointer) => b"null pointer argument\0",
        Some(RiskscoreStatus::ContextTooSmall) => b"context smaller than RISKSCORE_CONTEXT_SIZE\0",
        Some(RiskscoreStatus::ContextMisaligned) => {
            b"context not aligned to RISKSCORE_CONTEXT_ALIGN\0"
        }
        Some(RiskscoreStatus::ContextNotInitialized) => {
            b"context not initialised by riskscore_init\0"
        }
        Some(RiskscoreStatus::InvalidConfig) => b"invalid warning configuration\0",
        Some(RiskscoreStatus::NonFiniteState) => b"vehicle state has a NaN or infinite field\0",
        Some(RiskscoreStatus::NoModel) => b"no model loaded\0",
        Some(RiskscoreStatus::ModelTruncated) => b"model blob truncated\0",
        Some(RiskscoreStatus::ModelBadMagic) => b"not a model blob (bad magic)\0",
        Some(RiskscoreStatus::ModelUnsupportedVersion) => b"unsupported model format version\0",
        Some(RiskscoreStatus::ModelUnknownKind) => b"unknown model kind\0",
        Some(RiskscoreStatus::ModelReservedNotZero) => b"model header reserved byte not zero\0",
        Some(RiskscoreStatus::ModelUnsupportedFeatureSchema) => {
            b"input schema unknown or wrong for the model kind\0"
        }
        Some(RiskscoreStatus::ModelTrailingBytes) => b"trailing bytes after the model\0",
        Some(RiskscoreStatus::ModelCrcMismatch) => b"model payload CRC mismatch\0",
        Some(RiskscoreStatus::ModelMalformedPayload) => b"malformed model payload\0",
        Some(RiskscoreStatus::ModelInvalid) => b"model fails validation\0",
        Some(RiskscoreStatus::NanScore) => b"score is NaN\0",
        Some(RiskscoreStatus::OutOfOrder) => b"update older than the track's last update\0",
        Some(RiskscoreStatus::TableFull) => b"track table full\0",
        Some(RiskscoreStatus::UnknownTrack) => b"unknown track id\0",
        Some(RiskscoreStatus::InvalidInput) => b"bad heading, size or track id\0",
        None => b"unknown status code\0",
    };
    s.as_ptr().cast()
}
