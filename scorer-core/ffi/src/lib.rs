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
//! surrogates and the score of every loaded model for one ego/partner pair; the caller feeds the
//! score it warns on to [`riskscore_track_update`], which runs the warning rule of the partner's
//! track; [`riskscore_track_get`] and [`riskscore_any_warning`] read the warning state.
//!
//! Errors: every function returns a [`RiskscoreStatus`]; outputs are written only on success.
//! Null pointers, a context that was not initialised (or is misaligned or too small), malformed
//! model blobs, non-finite vehicle states, NaN scores, out-of-order updates and a full track table
//! each have their own code; [`riskscore_status_str`] names them.
//!
//! Panics: `scorer-core` has no panic paths (it denies unwrap/expect/panic/indexing). As a
//! backstop, the static library is built with `panic = abort`, and an `extern "C"` function that
//! panics aborts instead of unwinding into C. On bare-metal targets the panic handler calls the
//! integrator's `riskscore_panic` hook (see the header), which never returns.
//!
//! Not thread-safe: one context per task, or serialise access. Functions taking a `const`
//! context only read it.
//!
//! `unsafe` is confined to the pointer helpers at the bottom of this file; each use states why it is
//! sound. The public functions null-check every pointer before touching it.
#![cfg_attr(target_os = "none", no_std)]

use core::ffi::c_char;
use core::mem::{align_of, size_of};

use scorer_core::model::{self, Model, ModelError, ModelKind};
use scorer_core::warning::{FullPolicy, TrackTable, WarningConfig, WarningError, WarningEvent};
use scorer_core::{Observation, VehicleState, FEATURE_COUNT};

/// Version of this C ABI; bumped on any incompatible change of the header.
pub const RISKSCORE_ABI_VERSION: u32 = 1;
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
/// "No value" for the optional `u64` times and `u32` indices in output structs.
pub const RISKSCORE_NONE_U64: u64 = u64::MAX;
/// "No value" for optional `u32` outputs.
pub const RISKSCORE_NONE_U32: u32 = u32::MAX;

/// Result of every call. `RISKSCORE_STATUS_OK` is 0; everything else is an error and leaves the
/// outputs untouched.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RiskscoreStatus {
    Ok = 0,
    /// A required pointer argument is NULL.
    NullPointer = 1,
    /// `riskscore_init`: `context_size` is smaller than `RISKSCORE_CONTEXT_SIZE` (header and library
    /// disagree).
    ContextTooSmall = 2,
    /// The context pointer is not aligned to `RISKSCORE_CONTEXT_ALIGN`.
    ContextMisaligned = 3,
    /// The context was not initialised by `riskscore_init` (or was overwritten).
    ContextNotInitialized = 4,
    /// A `RiskscoreWarningConfig` field is invalid (NaN threshold, negative or non-finite
    /// hysteresis, a flag other than 0/1).
    InvalidConfig = 5,
    /// A vehicle state has a NaN or infinite field.
    NonFiniteState = 6,
    /// `riskscore_score_pair` with no model loaded.
    NoModel = 7,
    /// Model blob: shorter than its header or declared payload.
    ModelTruncated = 8,
    /// Model blob: does not start with "RSKM".
    ModelBadMagic = 9,
    /// Model blob: format version not supported by this library.
    ModelUnsupportedVersion = 10,
    /// Model blob: unknown model kind byte.
    ModelUnknownKind = 11,
    /// Model blob: a reserved header byte is not zero.
    ModelReservedNotZero = 12,
    /// Model blob: feature schema not computed by this library.
    ModelUnsupportedFeatureSchema = 13,
    /// Model blob: bytes after the payload.
    ModelTrailingBytes = 14,
    /// Model blob: payload CRC-32 mismatch (corrupted in storage or transfer).
    ModelCrcMismatch = 15,
    /// Model blob: the payload does not decode.
    ModelMalformedPayload = 16,
    /// Model blob: decodes but fails validation (capacity, dimensions, non-finite or out-of-range
    /// parameters); `RiskscoreLoadInfo.field` names the field.
    ModelInvalid = 17,
    /// `riskscore_track_update`: the score is NaN.
    NanScore = 18,
    /// `riskscore_track_update`: `now_us` is earlier than the track's last update.
    OutOfOrder = 19,
    /// `riskscore_track_update`: no room for a new track (every track is warning, or the policy is
    /// reject).
    TableFull = 20,
    /// The track id is not in the table.
    UnknownTrack = 21,
}

/// Every status, in code order.
const STATUS_ALL: [RiskscoreStatus; 22] = {
    use RiskscoreStatus as S;
    [
        S::Ok,
        S::NullPointer,
        S::ContextTooSmall,
        S::ContextMisaligned,
        S::ContextNotInitialized,
        S::InvalidConfig,
        S::NonFiniteState,
        S::NoModel,
        S::ModelTruncated,
        S::ModelBadMagic,
        S::ModelUnsupportedVersion,
        S::ModelUnknownKind,
        S::ModelReservedNotZero,
        S::ModelUnsupportedFeatureSchema,
        S::ModelTrailingBytes,
        S::ModelCrcMismatch,
        S::ModelMalformedPayload,
        S::ModelInvalid,
        S::NanScore,
        S::OutOfOrder,
        S::TableFull,
        S::UnknownTrack,
    ]
};

impl RiskscoreStatus {
    /// The status with numeric code `code`, if any.
    pub fn from_code(code: i32) -> Option<Self> {
        STATUS_ALL.iter().copied().find(|s| *s as i32 == code)
    }
}

/// Model family, as reported by `riskscore_load_model`.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RiskscoreModelKind {
    None = 0,
    DrlInt8 = 1,
    DrlF32 = 2,
    Msra = 3,
    Gssm = 4,
}

/// What a track update changed.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RiskscoreWarningEvent {
    /// The warning state did not change.
    None = 0,
    /// The warning turned on.
    Onset = 1,
    /// The warning was released (live mode only).
    Release = 2,
}

/// Caller-owned storage for one scorer. Opaque: only its size and alignment are part of the ABI.
#[repr(C)]
pub struct RiskscoreContext {
    /// `u64` words give the 8-byte alignment on every C ABI we target.
    pub opaque: [u64; RISKSCORE_CONTEXT_WORDS],
}

/// One road user at one instant: SI units, world frame, centre of its box, unit heading `(hx, hy)`,
/// longitudinal acceleration `acc` along the heading.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RiskscoreVehicleState {
    pub x: f32,
    pub y: f32,
    pub vx: f32,
    pub vy: f32,
    pub hx: f32,
    pub hy: f32,
    pub acc: f32,
    pub length: f32,
    pub width: f32,
}

/// Parameters of the per-partner warning rule and of the track table.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RiskscoreWarningConfig {
    /// Warn when the score is `>= threshold`.
    pub threshold: f32,
    /// Live mode: release when the score is `< threshold - hysteresis` (`>= 0`).
    pub hysteresis: f32,
    /// Live mode: a warning stays on at least this long (microseconds).
    pub min_on_us: u64,
    /// Tracks not updated for longer than this are dropped (`RISKSCORE_NONE_U64`: never).
    pub stale_after_us: u64,
    /// 1: latched (evaluation semantics: once on, stays on for the track's life); 0: live mode.
    pub latch: u8,
    /// 1: when the table is full, evict the least recently updated non-warning track; 0: reject
    /// the new track with `RISKSCORE_STATUS_TABLE_FULL`.
    pub evict_when_full: u8,
}

/// Everything computed for one ego/partner pair.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RiskscorePairResult {
    /// The 13 observation features in model-input order (l_ego, l_sur, w_comb, vy_ego, vx_sur,
    /// vy_sur, v_ego2, v_sur2, delta_v2, delta_v, psi_sur, rho, s).
    pub features: [f32; RISKSCORE_FEATURE_COUNT],
    /// Exact gap between the two boxes (m), 0 when they touch or overlap.
    pub box_distance: f32,
    /// Two-dimensional time-to-collision (s); +INFINITY = no conflict.
    pub ttc2d: f32,
    /// Time advantage (s); +INFINITY = no conflict.
    pub tadv: f32,
    /// Emergency index (m/s); -INFINITY = no conflict.
    pub ei: f32,
    /// Score of the loaded DRL model (int8 or f32); NaN when `has_drl` is 0.
    pub drl_score: f32,
    /// Score of the loaded MSRA model; NaN when `has_msra` is 0.
    pub msra_score: f32,
    /// Score of the loaded GSSM model; NaN when `has_gssm` is 0.
    pub gssm_score: f32,
    /// 1 when a DRL model is loaded (and `drl_score` valid), else 0.
    pub has_drl: u8,
    /// 1 when an MSRA model is loaded, else 0.
    pub has_msra: u8,
    /// 1 when a GSSM model is loaded, else 0.
    pub has_gssm: u8,
}

/// Result of one `riskscore_track_update`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RiskscoreTrackStatus {
    /// 1 when the partner's warning is on after this update.
    pub warning: u8,
    /// What changed (`RiskscoreWarningEvent`).
    pub event: RiskscoreWarningEvent,
    /// 1 when this update created the track (new id, or an id whose track had been dropped).
    pub new_track: u8,
    /// Id of a track evicted to make room, or `RISKSCORE_NONE_U32`.
    pub evicted_id: u32,
}

/// One partner's warning state.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RiskscoreTrack {
    pub id: u32,
    /// 1 when the warning is on (and the track is not stale at the query time).
    pub warning: u8,
    /// 1 when the track is stale at the query time (it is dropped at the next update).
    pub stale: u8,
    /// Last accepted score.
    pub last_score: f32,
    pub created_us: u64,
    pub last_update_us: u64,
    /// When the current warning turned on, or `RISKSCORE_NONE_U64`.
    pub on_since_us: u64,
    /// When the track first warned, or `RISKSCORE_NONE_U64`.
    pub first_warning_us: u64,
    /// Number of accepted updates.
    pub updates: u32,
    /// Number of warning onsets.
    pub onsets: u32,
}

/// Details of a `riskscore_load_model` call.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RiskscoreLoadInfo {
    /// Kind of the loaded model (`RiskscoreModelKind`); `RISKSCORE_MODEL_KIND_NONE` on failure
    /// before the header was read.
    pub kind: RiskscoreModelKind,
    /// On `RISKSCORE_STATUS_MODEL_INVALID` and friends: the offending field as spelled in
    /// docs/model-format.md (NUL-terminated, truncated to fit); empty otherwise.
    pub field: [c_char; RISKSCORE_FIELD_NAME_LEN],
    /// Element, layer or term index of the offending value, or `RISKSCORE_NONE_U32`.
    pub index: u32,
    /// Size errors: bytes (or elements) needed/expected, else `RISKSCORE_NONE_U32`.
    pub expected: u32,
    /// Size errors: bytes (or elements) found, else `RISKSCORE_NONE_U32`.
    pub found: u32,
}

// ------------------------------------------------------------------------------------------------
// The context behind the opaque bytes.

/// Marks an initialised context ("RSKC"); anything else is rejected.
const CONTEXT_MAGIC: u32 = 0x434b_5352;

#[repr(C)]
struct Context {
    /// First field, so it can be checked through a `u32` read before the rest is trusted.
    magic: u32,
    drl: Option<Model<'static>>,
    msra: Option<Model<'static>>,
    gssm: Option<Model<'static>>,
    tracks: TrackTable<RISKSCORE_MAX_TRACKS>,
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

// ------------------------------------------------------------------------------------------------
// Conversions.

fn vehicle(s: &RiskscoreVehicleState) -> Result<VehicleState, RiskscoreStatus> {
    let v = VehicleState {
        x: s.x,
        y: s.y,
        vx: s.vx,
        vy: s.vy,
        hx: s.hx,
        hy: s.hy,
        acc: s.acc,
        length: s.length,
        width: s.width,
    };
    if v.is_finite() {
        Ok(v)
    } else {
        Err(RiskscoreStatus::NonFiniteState)
    }
}

fn flag(v: u8) -> Result<bool, RiskscoreStatus> {
    match v {
        0 => Ok(false),
        1 => Ok(true),
        _ => Err(RiskscoreStatus::InvalidConfig),
    }
}

fn warning_config(c: &RiskscoreWarningConfig) -> Result<WarningConfig, RiskscoreStatus> {
    let config = WarningConfig {
        threshold: c.threshold,
        latch: flag(c.latch)?,
        hysteresis: c.hysteresis,
        min_on_us: c.min_on_us,
        stale_after_us: c.stale_after_us,
        when_full: if flag(c.evict_when_full)? {
            FullPolicy::EvictLeastRecent
        } else {
            FullPolicy::Reject
        },
    };
    config
        .validate()
        .map_err(|_| RiskscoreStatus::InvalidConfig)?;
    Ok(config)
}

fn kind_code(kind: ModelKind) -> RiskscoreModelKind {
    match kind {
        ModelKind::DrlInt8 => RiskscoreModelKind::DrlInt8,
        ModelKind::DrlF32 => RiskscoreModelKind::DrlF32,
        ModelKind::Msra => RiskscoreModelKind::Msra,
        ModelKind::Gssm => RiskscoreModelKind::Gssm,
    }
}

fn sat_u32(v: usize) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX - 1)
}

/// Status code and load details for a model error.
fn model_error(e: &ModelError, info: &mut RiskscoreLoadInfo) -> RiskscoreStatus {
    let mut field = |name: &str| {
        let room = RISKSCORE_FIELD_NAME_LEN - 1;
        for (dst, &b) in info.field.iter_mut().take(room).zip(name.as_bytes()) {
            *dst = b as c_char;
        }
    };
    match e {
        ModelError::Truncated { needed, available } => {
            info.expected = sat_u32(*needed);
            info.found = sat_u32(*available);
            RiskscoreStatus::ModelTruncated
        }
        ModelError::BadMagic(_) => RiskscoreStatus::ModelBadMagic,
        ModelError::UnsupportedVersion(v) => {
            info.found = u32::from(*v);
            RiskscoreStatus::ModelUnsupportedVersion
        }
        ModelError::UnknownKind(k) => {
            info.found = u32::from(*k);
            RiskscoreStatus::ModelUnknownKind
        }
        ModelError::ReservedNotZero { offset } => {
            info.index = sat_u32(*offset);
            RiskscoreStatus::ModelReservedNotZero
        }
        ModelError::UnsupportedFeatureSchema(s) => {
            info.found = u32::from(*s);
            RiskscoreStatus::ModelUnsupportedFeatureSchema
        }
        ModelError::WrongInputSchema {
            found, expected, ..
        } => {
            field("input_schema");
            info.found = u32::from(*found);
            info.expected = u32::from(*expected);
            RiskscoreStatus::ModelUnsupportedFeatureSchema
        }
        ModelError::TrailingBytes { extra } => {
            info.found = sat_u32(*extra);
            RiskscoreStatus::ModelTrailingBytes
        }
        ModelError::CrcMismatch { stored, computed } => {
            info.expected = *stored;
            info.found = *computed;
            RiskscoreStatus::ModelCrcMismatch
        }
        ModelError::Payload(_) => RiskscoreStatus::ModelMalformedPayload,
        ModelError::CapacityExceeded { field: f, len, max } => {
            field(f);
            info.expected = sat_u32(*max);
            info.found = sat_u32(*len);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::Empty { field: f } => {
            field(f);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::DimensionMismatch {
            field: f,
            index,
            expected,
            found,
        } => {
            field(f);
            info.index = sat_u32(*index);
            info.expected = sat_u32(*expected);
            info.found = sat_u32(*found);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::NonFinite { field: f, index }
        | ModelError::NonPositiveScale { field: f, index } => {
            field(f);
            info.index = sat_u32(*index);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadFeatureIndex { index, feature } => {
            field("inputs");
            info.index = sat_u32(*index);
            info.found = u32::from(*feature);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadMultiplier { layer, channel, .. } => {
            field("layers.multipliers");
            info.index = sat_u32(*layer);
            info.found = sat_u32(*channel);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadClipRange { term } | ModelError::MissingGssm { term } => {
            field("terms");
            info.index = sat_u32(*term);
            RiskscoreStatus::ModelInvalid
        }
        // Encoding-only errors and variants added to the core later.
        _ => RiskscoreStatus::ModelInvalid,
    }
}

fn warning_error(e: WarningError) -> RiskscoreStatus {
    match e {
        WarningError::NonFiniteScore { .. } => RiskscoreStatus::NanScore,
        WarningError::OutOfOrder { .. } => RiskscoreStatus::OutOfOrder,
        WarningError::TableFull { .. } => RiskscoreStatus::TableFull,
        WarningError::InvalidConfig(_) => RiskscoreStatus::InvalidConfig,
    }
}

fn event_code(e: WarningEvent) -> RiskscoreWarningEvent {
    match e {
        WarningEvent::None => RiskscoreWarningEvent::None,
        WarningEvent::Onset => RiskscoreWarningEvent::Onset,
        WarningEvent::Release => RiskscoreWarningEvent::Release,
    }
}

fn opt_us(v: Option<u64>) -> u64 {
    v.unwrap_or(RISKSCORE_NONE_U64)
}

// ------------------------------------------------------------------------------------------------
// The C functions. Each: validate pointers, do the work on safe references, write outputs last.

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
        Some(RiskscoreStatus::ModelUnsupportedFeatureSchema) => b"unsupported input schema (a DRL model of an older input encoding: retrain or re-export it)\0",
        Some(RiskscoreStatus::ModelTrailingBytes) => b"trailing bytes after the model\0",
        Some(RiskscoreStatus::ModelCrcMismatch) => b"model payload CRC mismatch\0",
        Some(RiskscoreStatus::ModelMalformedPayload) => b"malformed model payload\0",
        Some(RiskscoreStatus::ModelInvalid) => b"model fails validation\0",
        Some(RiskscoreStatus::NanScore) => b"score is NaN\0",
        Some(RiskscoreStatus::OutOfOrder) => b"update older than the track's last update\0",
        Some(RiskscoreStatus::TableFull) => b"track table full\0",
        Some(RiskscoreStatus::UnknownTrack) => b"unknown track id\0",
        None => b"unknown status code\0",
    };
    s.as_ptr().cast()
}

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
/// replacing the previous model of that family. On error the context is unchanged. `info` may be
/// NULL; otherwise it receives the kind and, on error, the offending field.
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
    let mut details = RiskscoreLoadInfo {
        kind: RiskscoreModelKind::None,
        field: [0; RISKSCORE_FIELD_NAME_LEN],
        index: RISKSCORE_NONE_U32,
        expected: RISKSCORE_NONE_U32,
        found: RISKSCORE_NONE_U32,
    };
    let mut run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_mut(context) }?;
        // SAFETY: caller contract above: the blob outlives every use of the context.
        let bytes: &'static [u8] = unsafe { blob_slice(blob, len) }?;
        if let Ok(header) = model::decode_header(bytes) {
            details.kind = kind_code(header.kind);
        }
        let m = model::decode(bytes).map_err(|e| model_error(&e, &mut details))?;
        let slot = match m.kind() {
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

/// Scores one ego/partner pair: features, surrogates and the score of every loaded model.
///
/// # Safety
/// `context` must be NULL or initialised; `ego`, `partner` NULL or readable; `out` NULL or
/// writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_score_pair(
    context: *const RiskscoreContext,
    ego: *const RiskscoreVehicleState,
    partner: *const RiskscoreVehicleState,
    out: *mut RiskscorePairResult,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_ref(context) }?;
        // SAFETY: caller contract above.
        let (ego, partner) = unsafe { (read(ego)?, read(partner)?) };
        if out.is_null() {
            return Err(RiskscoreStatus::NullPointer);
        }
        let (ego, partner) = (vehicle(&ego)?, vehicle(&partner)?);
        if ctx.drl.is_none() && ctx.msra.is_none() && ctx.gssm.is_none() {
            return Err(RiskscoreStatus::NoModel);
        }
        let o = Observation::of(&ego, &partner);
        let s = o.surrogates;
        let score =
            |m: &Option<Model<'static>>| m.as_ref().map_or(f32::NAN, |m| m.score_observation(&o));
        let result = RiskscorePairResult {
            features: o.features,
            box_distance: s.box_distance,
            ttc2d: s.ttc2d,
            tadv: s.tadv,
            ei: s.ei,
            drl_score: score(&ctx.drl),
            msra_score: score(&ctx.msra),
            gssm_score: score(&ctx.gssm),
            has_drl: u8::from(ctx.drl.is_some()),
            has_msra: u8::from(ctx.msra.is_some()),
            has_gssm: u8::from(ctx.gssm.is_some()),
        };
        // SAFETY: `out` is non-null (checked) and writable per the caller contract.
        unsafe { write(out, result) }
    };
    status(run())
}

/// Feeds the score `risk` of partner `track_id` at time `now_us` (monotonic microseconds) to the
/// track table: drops stale tracks, finds or creates the partner's track, applies the warning rule.
/// `out` may be NULL. On error nothing changes except the drop of stale tracks.
///
/// # Safety
/// `context` must be NULL or initialised; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_track_update(
    context: *mut RiskscoreContext,
    track_id: u32,
    now_us: u64,
    risk: f32,
    out: *mut RiskscoreTrackStatus,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_mut(context) }?;
        let st = ctx
            .tracks
            .update(track_id, now_us, risk)
            .map_err(warning_error)?;
        let result = RiskscoreTrackStatus {
            warning: u8::from(st.warning),
            event: event_code(st.event),
            new_track: u8::from(st.new_track),
            evicted_id: st.evicted.unwrap_or(RISKSCORE_NONE_U32),
        };
        // SAFETY: caller contract above; `out` is optional.
        unsafe { write_optional(out, result) };
        Ok(())
    };
    status(run())
}

/// Reads the state of track `track_id` as of `now_us` (staleness is judged at `now_us`).
///
/// # Safety
/// `context` must be NULL or initialised; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_track_get(
    context: *const RiskscoreContext,
    track_id: u32,
    now_us: u64,
    out: *mut RiskscoreTrack,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_ref(context) }?;
        if out.is_null() {
            return Err(RiskscoreStatus::NullPointer);
        }
        let t = ctx
            .tracks
            .get(track_id)
            .ok_or(RiskscoreStatus::UnknownTrack)?;
        let stale = now_us.saturating_sub(t.last_update_us) > ctx.tracks.config().stale_after_us;
        let result = RiskscoreTrack {
            id: t.id,
            warning: u8::from(ctx.tracks.is_warning(track_id, now_us)),
            stale: u8::from(stale),
            last_score: t.last_score,
            created_us: t.created_us,
            last_update_us: t.last_update_us,
            on_since_us: opt_us(t.on_since_us()),
            first_warning_us: opt_us(t.first_warning_us()),
            updates: t.updates,
            onsets: t.onsets,
        };
        // SAFETY: non-null (checked), writable per the caller contract.
        unsafe { write(out, result) }
    };
    status(run())
}

/// Drops the track of `track_id` (`RISKSCORE_STATUS_UNKNOWN_TRACK` if there is none).
///
/// # Safety
/// `context` must be NULL or initialised.
#[no_mangle]
pub unsafe extern "C" fn riskscore_track_remove(
    context: *mut RiskscoreContext,
    track_id: u32,
) -> RiskscoreStatus {
    // SAFETY: caller contract above.
    let run = || match unsafe { context_mut(context) }?.tracks.remove(track_id) {
        true => Ok(()),
        false => Err(RiskscoreStatus::UnknownTrack),
    };
    status(run())
}

/// Writes to `warning_count` the number of fresh (non-stale at `now_us`) tracks whose warning is
/// on, and to `track_count` the number of tracks held (stale ones included until the next update).
/// Either output may be NULL.
///
/// # Safety
/// `context` must be NULL or initialised; the outputs NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_any_warning(
    context: *const RiskscoreContext,
    now_us: u64,
    warning_count: *mut u32,
    track_count: *mut u32,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_ref(context) }?;
        let warnings = sat_u32(ctx.tracks.warnings(now_us).count());
        let held = sat_u32(ctx.tracks.len());
        // SAFETY: caller contract above; both optional.
        unsafe {
            write_optional(warning_count, warnings);
            write_optional(track_count, held);
        }
        Ok(())
    };
    status(run())
}

fn status(r: Result<(), RiskscoreStatus>) -> RiskscoreStatus {
    match r {
        Ok(()) => RiskscoreStatus::Ok,
        Err(e) => e,
    }
}

// ------------------------------------------------------------------------------------------------
// Pointer helpers: the only `unsafe` code. Each checks for NULL (and alignment/initialisation for
// contexts) before turning a pointer into a reference.

/// Reads a `T` from a caller pointer (any alignment).
///
/// # Safety
/// `p` is NULL or valid for reading a `T`.
unsafe fn read<T: Copy>(p: *const T) -> Result<T, RiskscoreStatus> {
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
unsafe fn write<T>(p: *mut T, v: T) -> Result<(), RiskscoreStatus> {
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
unsafe fn write_optional<T>(p: *mut T, v: T) {
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
unsafe fn blob_slice(blob: *const u8, len: usize) -> Result<&'static [u8], RiskscoreStatus> {
    if blob.is_null() {
        return Err(RiskscoreStatus::NullPointer);
    }
    if len > isize::MAX as usize {
        return Err(RiskscoreStatus::ModelTruncated);
    }
    // SAFETY: non-null, `len` readable bytes per the contract, `len <= isize::MAX`; `u8` has
    // alignment 1. The 'static lifetime is the caller's promise that the blob outlives its use.
    Ok(unsafe { core::slice::from_raw_parts(blob, len) })
}

/// Checks an opaque context pointer: non-null, aligned, initialised.
///
/// # Safety
/// `context` is NULL or valid for reads of `RISKSCORE_CONTEXT_SIZE` bytes.
unsafe fn checked(context: *const RiskscoreContext) -> Result<*const Context, RiskscoreStatus> {
    if context.is_null() {
        return Err(RiskscoreStatus::NullPointer);
    }
    let inner = context.cast::<Context>();
    if !inner.is_aligned() {
        return Err(RiskscoreStatus::ContextMisaligned);
    }
    // SAFETY: non-null, aligned, and at least `size_of::<Context>()` readable bytes (compile-time
    // assert above); `magic` is the first field of the `repr(C)` struct and any bit pattern is a
    // valid `u32`, so the read is sound even if the block was never initialised.
    let magic = unsafe { inner.cast::<u32>().read() };
    if magic != CONTEXT_MAGIC {
        return Err(RiskscoreStatus::ContextNotInitialized);
    }
    Ok(inner)
}

/// # Safety
/// `context` is NULL or a context initialised by `riskscore_init`, not aliased for the returned
/// lifetime (the C API is not re-entrant on one context).
unsafe fn context_ref<'a>(
    context: *const RiskscoreContext,
) -> Result<&'a Context, RiskscoreStatus> {
    // SAFETY: caller contract; `checked` verified non-null, alignment and the init magic, so the
    // bytes hold a `Context` written by `init_context`.
    unsafe { checked(context).map(|p| &*p) }
}

/// # Safety
/// As [`context_ref`], and writable.
unsafe fn context_mut<'a>(
    context: *mut RiskscoreContext,
) -> Result<&'a mut Context, RiskscoreStatus> {
    // SAFETY: as in `context_ref`; the caller owns the block mutably for the call.
    unsafe { checked(context).map(|p| &mut *(p as *mut Context)) }
}

/// Writes a fresh context into the caller's block.
///
/// # Safety
/// `context` is NULL or valid for writes of `context_size` bytes.
unsafe fn init_context(
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
