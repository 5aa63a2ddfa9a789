//! The C-visible types of the ABI: status codes, model kinds, warning events, the opaque context
//! block, vehicle states, the warning configuration and every result struct.
use crate::{RISKSCORE_CONTEXT_WORDS, RISKSCORE_FEATURE_COUNT, RISKSCORE_FIELD_NAME_LEN};
use core::ffi::c_char;

/// Result of every call. `RISKSCORE_STATUS_OK` is 0; everything else is an error and leaves the
/// outputs untouched, except `riskscore_load_model`'s `info`, which describes the error.
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
    /// A `RiskscoreWarningConfig` field is invalid (NaN or infinite threshold, negative or
    /// non-finite hysteresis, a hysteresis so large that `threshold - hysteresis` overflows to
    /// `-inf`, `stale_after_us` of 0, a flag other than 0/1).
    InvalidConfig = 5,
    /// A vehicle state has a NaN or infinite field.
    NonFiniteState = 6,
    /// `riskscore_score_pair` with no model loaded.
    NoModel = 7,
    /// Model blob: shorter than its header or declared payload (`RiskscoreLoadInfo.expected` /
    /// `found`: the blob's bytes), or a metadata record of a version-2 blob declares more bytes
    /// than its payload has left (`expected`: the record's declared body length, any `u32`, so
    /// possibly more than the whole blob; `found`: the payload bytes left after its length, less
    /// than the blob's length).
    ModelTruncated = 8,
    /// Model blob: does not start with "RSKM".
    ModelBadMagic = 9,
    /// Model blob: format version not supported by this library.
    ModelUnsupportedVersion = 10,
    /// Model blob: unknown model kind byte.
    ModelUnknownKind = 11,
    /// Model blob: a reserved header byte is not zero.
    ModelReservedNotZero = 12,
    /// Model blob: input (feature) schema unknown to this library, or not the one its model kind
    /// reads (e.g. a DRL model of an older input encoding).
    ModelUnsupportedFeatureSchema = 13,
    /// Model blob: bytes after the payload (`RiskscoreLoadInfo.found`: how many), or a `len`
    /// above `PTRDIFF_MAX`, which no buffer has (e.g. a failed read's `-1` cast to `size_t`;
    /// `found` is then `RISKSCORE_NONE_U32`, and the blob is not read).
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
    /// `riskscore_track_update`: `now_us` is earlier than the track's last update, by at most
    /// `stale_after_us` (earlier by more, the time base was reset: the track is stale, and the
    /// update drops it and starts a new one).
    OutOfOrder = 19,
    /// `riskscore_track_update`: no room for a new track (every track is warning, or the policy is
    /// reject). A track left ahead of `now_us` by a reset time base counts with the warning it had,
    /// though no query reports it: after a reset, remove the tracks or re-initialise.
    TableFull = 20,
    /// The track id is not in the table.
    UnknownTrack = 21,
    /// A vehicle state has a zero heading vector (one `scorer_core::geometry::unit_heading`
    /// cannot normalise: the box and the box-based surrogates would be lost) or a negative length
    /// or width (a size of 0 is scored as a point, as `riskctl ssm` scores it; the event loader
    /// refuses it); or `riskscore_track_update` got the track id `RISKSCORE_NONE_U32`, which is
    /// reserved for "no track" in `RiskscoreTrackStatus.evicted_id`.
    InvalidInput = 22,
}

/// Every status, in code order.
const STATUS_ALL: [RiskscoreStatus; 23] = {
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
        S::InvalidInput,
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
    /// The warning was released by this update's score (live mode only). Not the only way a
    /// warning ends: a track that goes stale reads as not warning from then on and is dropped
    /// by a later update, and one restarted after a reset time base comes back with
    /// `new_track` and its warning off, neither with a RELEASE (nor in latched mode). Drive a
    /// warning output from `RiskscoreTrackStatus.warning` and `riskscore_any_warning`, not from
    /// ONSET/RELEASE alone.
    Release = 2,
}

/// Caller-owned storage for one scorer. Opaque: only its size and alignment are part of the ABI.
#[repr(C)]
pub struct RiskscoreContext {
    /// `u64` words give the 8-byte alignment on every C ABI we target.
    pub opaque: [u64; RISKSCORE_CONTEXT_WORDS],
}

/// One road user at one instant: SI units, centre of its box, unit heading `(hx, hy)` (the box's
/// long axis, pointing forward), longitudinal acceleration `acc` along the heading. Coordinates:
/// one fixed right-handed Cartesian world frame (e.g. local ENU) for ego and partner; `(vx, vy)` is
/// the velocity over ground in that frame, not relative to the ego. Refused: a NaN/infinite field
/// (`RISKSCORE_STATUS_NON_FINITE_STATE`), a zero heading vector or a negative length/width
/// (`RISKSCORE_STATUS_INVALID_INPUT`; a size of 0 is a point, as `riskctl ssm` scores it).
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
    /// Warn when the score is `>= threshold`. Finite: NaN and +-infinity are refused
    /// (`RISKSCORE_STATUS_INVALID_CONFIG`; `+inf` would never warn on a finite score, `-inf` would
    /// warn on every partner).
    pub threshold: f32,
    /// Live mode: release when the score is `< threshold - hysteresis` (`>= 0`).
    pub hysteresis: f32,
    /// Live mode: a warning stays on at least this long (microseconds).
    pub min_on_us: u64,
    /// Tracks not updated for longer than this are dropped (`RISKSCORE_NONE_U64`: never; 0 is
    /// refused with `RISKSCORE_STATUS_INVALID_CONFIG`: every track would be stale as soon as the
    /// clock moves on, so no warning would persist and no partner be followed). A track
    /// last updated more than this after `now_us` (the time base was reset) is stale: not reported
    /// as warning, restarted by the next update of its own id, evictable only if its warning was
    /// off (a warning one is kept and can fill the table: `RISKSCORE_STATUS_TABLE_FULL`); other
    /// ids' updates leave it in place.
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
    /// Two-dimensional time-to-collision (s); +INFINITY = no conflict by the measure's rules,
    /// which boxes that already touch or overlap (`box_distance` 0) often get too, as in the
    /// reference implementation: +INFINITY alone does not mean "no risk".
    pub ttc2d: f32,
    /// Time advantage (s); +INFINITY = no conflict.
    pub tadv: f32,
    /// Emergency index (m/s); -INFINITY = no conflict.
    pub ei: f32,
    /// Score of the loaded DRL model (int8 or f32) under its blob's training-domain policy (see
    /// `drl_in_domain`); NaN when `has_drl` is 0.
    pub drl_score: f32,
    /// Score of the loaded MSRA model under its blob's training-domain policy; NaN when
    /// `has_msra` is 0.
    pub msra_score: f32,
    /// Score of the loaded GSSM model under its blob's training-domain policy; NaN when
    /// `has_gssm` is 0.
    pub gssm_score: f32,
    /// 1 when a DRL model is loaded (and `drl_score` valid), else 0.
    pub has_drl: u8,
    /// 1 when an MSRA model is loaded, else 0.
    pub has_msra: u8,
    /// 1 when a GSSM model is loaded, else 0.
    pub has_gssm: u8,
    /// 1 when the pair is inside the training domain the DRL blob records (or the blob has no
    /// training-domain record, or no DRL model is loaded); 0 when an input is outside its trained
    /// range, or when every input is inside but the blob's geometry-coverage record says training
    /// never reached the pair's geometry cell (bearing, relative heading, gap band; e.g. an
    /// oncoming car in the ego's lane 10 m ahead). Outside, `drl_score` follows the blob's policy:
    /// `flag-only` scores the model as is, `clamp` scores it on inputs clamped into their ranges
    /// (outside only by its cell: as is), `fallback` and `blend` score the
    /// blob's kinematic fallback instead of the model; inside, `blend` mixes the model's score
    /// with that fallback by the blob's weight (docs/domain-guard.md).
    pub drl_in_domain: u8,
    /// As `drl_in_domain`, for the MSRA blob and `msra_score`.
    pub msra_in_domain: u8,
    /// As `drl_in_domain`, for the GSSM blob and `gssm_score`.
    pub gssm_in_domain: u8,
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
    /// 1 when the track is stale at the query time: not updated for more than `stale_after_us`
    /// (dropped by the next update of any id), or last updated more than that after `now_us`, a
    /// reset time base (dropped by its own id's next update, a remove or a re-init, or, not
    /// warning, evicted when the table is full).
    pub stale: u8,
    /// Last accepted score.
    pub last_score: f32,
    pub created_us: u64,
    pub last_update_us: u64,
    /// When the track's warning turned on, or `RISKSCORE_NONE_U64` while it is off. A stale
    /// track keeps the time of the warning it had, though `warning` reads 0.
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
    /// Kind of the model (`RiskscoreModelKind`), also on failure once the header's magic, version
    /// and kind byte were read (e.g. reserved byte or schema errors); `RISKSCORE_MODEL_KIND_NONE`
    /// when the failure came before.
    pub kind: RiskscoreModelKind,
    /// On `RISKSCORE_STATUS_MODEL_INVALID` and friends: the offending field as spelled in
    /// docs/model-format.md (NUL-terminated, truncated to fit); empty otherwise.
    pub field: [c_char; RISKSCORE_FIELD_NAME_LEN],
    /// Element, layer, term or training-domain range index of the offending value, the header
    /// offset of a reserved byte that is not zero, or `RISKSCORE_NONE_U32`.
    pub index: u32,
    /// Size errors: bytes (or elements) needed/expected; `RISKSCORE_STATUS_MODEL_CRC_MISMATCH`:
    /// the CRC-32 the header stores; a known but wrong input schema: the one the kind reads; else
    /// `RISKSCORE_NONE_U32`.
    pub expected: u32,
    /// Size errors: bytes (or elements) found; otherwise the offending number where there is one:
    /// the format version, kind byte or input schema of the header, the CRC-32 of the payload, the
    /// count of trailing bytes, a feature index, a requantisation channel, an outside-policy byte,
    /// the input of a bad training-domain range, the tag of a record given twice; else
    /// `RISKSCORE_NONE_U32`.
    pub found: u32,
}
