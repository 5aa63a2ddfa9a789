//! Every way a model blob (or a model built in memory for export) can be rejected.

use core::fmt;

/// Why a model blob could not be decoded, or a model could not be encoded.
///
/// Each variant names the offending field (as it is spelled in `docs/model-format.md`) and, where it
/// applies, the layer/term and element index, so a bad export can be traced to its source.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ModelError {
    /// The blob ends before the header or the declared payload does (`needed`, `available`: bytes
    /// of the whole blob), or, inside a version-2 payload whose length and CRC are right, a
    /// metadata record declares a body longer than what follows its length varint (`needed`: the
    /// declared body length, `available`: the payload bytes left after the varint).
    Truncated {
        /// Bytes required: of the whole blob (header + declared payload), or the record body's
        /// declared length.
        needed: usize,
        /// Bytes present: of the whole blob, or of the payload after the record's length varint.
        available: usize,
    },
    /// The first four bytes are not [`MAGIC`](crate::model::MAGIC).
    BadMagic([u8; 4]),
    /// The format version is not one this build reads.
    UnsupportedVersion(u16),
    /// The model-kind byte names no known kind.
    UnknownKind(u8),
    /// A reserved header field is not zero.
    ReservedNotZero {
        /// Byte offset of the first non-zero reserved byte in the header: 7, 10 or 11.
        offset: usize,
    },
    /// The input-schema id is not one this build computes.
    UnsupportedFeatureSchema(u16),
    /// The input schema is known but not the one this build scores the model kind with (e.g. a
    /// DRL blob of schema 1 (the raw features) or 2 (the retired DRL input encoding 2) in a build
    /// that scores DRL with encoding 3).
    WrongInputSchema {
        /// The header's model kind, as [`ModelKind::name`](crate::model::ModelKind::name) spells
        /// it (`drl-int8`, `drl-f32`, `msra`, `gssm`).
        kind: &'static str,
        /// The header's input-schema id (bytes 8-9).
        found: u16,
        /// The schema this build scores the kind with
        /// ([`ModelKind::input_schema`](crate::model::ModelKind::input_schema)).
        expected: u16,
    },
    /// Bytes follow the payload (after the declared length, or inside it after the model).
    TrailingBytes {
        /// How many bytes are left over.
        extra: usize,
    },
    /// The payload CRC-32 does not match the header.
    CrcMismatch {
        /// The CRC-32 the header carries (bytes 16-19).
        stored: u32,
        /// The CRC-32/ISO-HDLC of the payload bytes as received ([`crate::crc::crc32`]).
        computed: u32,
    },
    /// The payload is not a valid postcard encoding of the model kind (the postcard error says why).
    Payload(postcard::Error),
    /// A list or dimension is larger than the compiled capacity.
    CapacityExceeded {
        /// The list or dimension, as `docs/model-format.md` spells it.
        field: &'static str,
        /// Its length: elements, or bytes for a byte string or the payload.
        len: usize,
        /// The compiled capacity it exceeds.
        max: usize,
    },
    /// A required list is empty (no inputs, no layers, no terms).
    Empty {
        /// The empty list or dimension.
        field: &'static str,
    },
    /// A byte array or list length disagrees with the dimensions it must match.
    DimensionMismatch {
        /// The array or list whose length is wrong.
        field: &'static str,
        /// The layer it belongs to (0-based); 0 for a field that is not per layer.
        index: usize,
        /// The length the dimensions require (bytes for a byte array, else elements).
        expected: usize,
        /// The length the blob has, in the same unit.
        found: usize,
    },
    /// A float parameter is NaN, infinite, or larger in magnitude than
    /// [`MAX_ABS_PARAM`](crate::mlp::MAX_ABS_PARAM).
    NonFinite {
        /// The parameter array.
        field: &'static str,
        /// Index of the offending element in it (0 for a single value).
        index: usize,
    },
    /// A scale that must be strictly positive is zero or negative.
    NonPositiveScale {
        /// The scale array.
        field: &'static str,
        /// Index of the offending element in it.
        index: usize,
    },
    /// A feature index is not below [`FEATURE_COUNT`](crate::FEATURE_COUNT).
    BadFeatureIndex {
        /// Position in the model's `inputs` list.
        index: usize,
        /// The feature index found there (must be below 13).
        feature: u8,
    },
    /// A requantisation pair is outside `multiplier in [2^30, 2^31)`, `shift in [-32, 32]`.
    BadMultiplier {
        /// The layer (0-based; only hidden layers carry requantisation pairs).
        layer: usize,
        /// The output channel of that layer (0-based).
        channel: usize,
        /// The fixed-point multiplier found (see [`crate::quant`]).
        multiplier: i32,
        /// The right shift found (see [`crate::quant`]).
        shift: i8,
    },
    /// An MSRA clip range is not `lo < hi` with finite bounds.
    BadClipRange {
        /// The MSRA term (0-based).
        term: usize,
    },
    /// An MSRA term reads GSSM but the model embeds no GSSM network.
    MissingGssm {
        /// The first MSRA term (0-based) that reads GSSM.
        term: usize,
    },
    /// The output buffer given to `encode` is too small.
    BufferTooSmall {
        /// Bytes the encoded blob (or its metadata records) takes.
        needed: usize,
        /// Bytes the buffer has.
        available: usize,
    },
    /// A metadata record of a version-2 blob appears twice.
    DuplicateRecord {
        /// The record tag given twice.
        tag: u8,
    },
    /// A metadata record's fields contradict each other or cannot be shown safely.
    BadRecord {
        /// The record field at fault, as `docs/model-format.md` spells it.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// Entry `entry` of the training-domain record (for input `input`) is unusable: an unknown
    /// input index, a non-finite bound, `lo > hi`, or an input given twice.
    BadDomainEntry {
        /// Position of the range in the record (0-based).
        entry: usize,
        /// The input index the range names.
        input: u8,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The training-domain record names an outside policy this build does not know (the first
    /// body byte; `0` flag-only, `1` clamp, `2` fallback and `3` blend are known).
    UnknownOutsidePolicy(u8),
    /// Term `term` of the kinematic-fallback record is unusable: an unknown or GSSM surrogate,
    /// or a parameter that [`MsraTerm::validate`](crate::msra::MsraTerm::validate) refuses.
    BadFallbackTerm {
        /// The fallback term (0-based).
        term: usize,
        /// What is wrong with it.
        reason: &'static str,
    },
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Truncated { needed, available } => {
                write!(f, "model blob truncated: needs {needed} bytes, has {available}")
            }
            Self::BadMagic(m) => write!(f, "not a model blob: magic {m:02x?}, expected \"RSKM\""),
            Self::UnsupportedVersion(v) => write!(f, "unsupported model format version {v}"),
            Self::UnknownKind(k) => write!(f, "unknown model kind {k}"),
            Self::ReservedNotZero { offset } => {
                write!(f, "reserved header byte at offset {offset} is not zero")
            }
            Self::UnsupportedFeatureSchema(s) => write!(f, "unsupported input schema {s}"),
            Self::WrongInputSchema {
                kind,
                found,
                expected,
            } => write!(
                f,
                "{kind} model expects input schema {found}, but this build scores {kind} with \
                 input schema {expected}; retrain or re-export it with this version (scoring it \
                 would feed it the wrong inputs)"
            ),
            Self::TrailingBytes { extra } => write!(f, "{extra} trailing bytes after the model"),
            Self::CrcMismatch { stored, computed } => write!(
                f,
                "payload CRC-32 mismatch: header says {stored:#010x}, payload has {computed:#010x}"
            ),
            Self::Payload(e) => write!(f, "malformed payload: {e}"),
            Self::CapacityExceeded { field, len, max } => {
                write!(f, "{field}: length {len} exceeds capacity {max}")
            }
            Self::Empty { field } => write!(f, "{field}: must not be empty"),
            Self::DimensionMismatch {
                field,
                index,
                expected,
                found,
            } => write!(
                f,
                "{field}[{index}]: expected length {expected}, found {found}"
            ),
            Self::NonFinite { field, index } => {
                write!(f, "{field}[{index}]: non-finite or out-of-range value")
            }
            Self::NonPositiveScale { field, index } => {
                write!(f, "{field}[{index}]: scale must be > 0")
            }
            Self::BadFeatureIndex { index, feature } => {
                write!(f, "inputs[{index}]: feature index {feature} out of range")
            }
            Self::BadMultiplier {
                layer,
                channel,
                multiplier,
                shift,
            } => write!(
                f,
                "layers[{layer}] channel {channel}: invalid requantisation pair ({multiplier}, {shift})"
            ),
            Self::BadClipRange { term } => write!(f, "terms[{term}]: clip range must be finite lo < hi"),
            Self::MissingGssm { term } => {
                write!(f, "terms[{term}]: reads GSSM but the model embeds no GSSM network")
            }
            Self::BufferTooSmall { needed, available } => {
                write!(f, "output buffer too small: needs {needed} bytes, has {available}")
            }
            Self::DuplicateRecord { tag } => {
                write!(f, "metadata record with tag {tag} appears twice")
            }
            Self::BadRecord { field, reason } => write!(f, "{field}: {reason}"),
            Self::BadDomainEntry {
                entry,
                input,
                reason,
            } => write!(f, "training_domain.ranges[{entry}] (input {input}): {reason}"),
            Self::UnknownOutsidePolicy(byte) => write!(
                f,
                "training_domain.policy: unknown outside policy {byte} (this build knows 0 \
                 flag-only, 1 clamp, 2 fallback, 3 blend); a newer exporter wrote it"
            ),
            Self::BadFallbackTerm { term, reason } => {
                write!(f, "kinematic_fallback.terms[{term}]: {reason}")
            }
        }
    }
}

impl core::error::Error for ModelError {}

impl From<postcard::Error> for ModelError {
    fn from(e: postcard::Error) -> Self {
        Self::Payload(e)
    }
}
