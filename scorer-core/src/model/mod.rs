//! The model blob: a fixed 20-byte header and a postcard payload, decoded without allocation.
//!
//! Byte-level specification: `docs/model-format.md`. In short (all integers little-endian):
//!
//! | offset | size | field                                                     |
//! |--------|------|-----------------------------------------------------------|
//! | 0      | 4    | magic `"RSKM"`                                            |
//! | 4      | 2    | format version (`u16`, 1 or [`FORMAT_VERSION`])          |
//! | 6      | 1    | model kind ([`ModelKind`])                                |
//! | 7      | 1    | reserved, 0                                               |
//! | 8      | 2    | input schema id (`u16`, [`ModelKind::input_schema`])      |
//! | 10     | 2    | reserved, 0                                               |
//! | 12     | 4    | payload length in bytes (`u32`)                           |
//! | 16     | 4    | CRC-32/ISO-HDLC of the payload (`u32`, [`crate::crc`])    |
//! | 20     | n    | payload: postcard encoding of the kind's model struct     |
//! |        |      | (version 2: then the metadata records of [`meta`])        |
//!
//! [`decode`] checks, in this order: header length, magic, version, kind, reserved bytes, input
//! schema (the one the kind is scored with in this build), declared payload length against the blob (short: `Truncated`, long: `TrailingBytes`),
//! CRC, postcard payload (must consume it exactly), then the model's own `validate` (capacities,
//! dimensions, finite parameters, positive scales). [`encode`] validates before writing, so the host
//! cannot produce a blob the MCU would reject.

pub mod blend;
pub mod geometry_coverage;
pub mod kinematic_fallback;
pub mod meta;
mod payload_reader;
pub mod training_domain;

pub use crate::bounded::BoundedVec;
pub use crate::model_error::ModelError;
pub use blend::{Blend, BLEND_TAG};
pub use geometry_coverage::{GeometryCoverage, GEOMETRY_COVERAGE_TAG, GEOMETRY_INPUT};
pub use kinematic_fallback::{KinematicFallback, KINEMATIC_FALLBACK_TAG};
pub use meta::{DefaultThreshold, ModelMeta, ThresholdRule};
pub use training_domain::{InputRange, OutsidePolicy, TrainingDomain};

use crate::encoding::{drl_inputs, DRL_INPUT_ENCODING};
use crate::features::features;
use crate::gssm::GssmModel;
use crate::mlp::{FloatMlp, QuantMlp};
use crate::msra::MsraModel;
use crate::observation::Observation;
use crate::state::VehicleState;
use crate::surrogates::surrogates_and_features;
use crate::wire_reader::WireReader;

/// First four bytes of every model blob.
pub const MAGIC: [u8; 4] = *b"RSKM";
/// The newest format version this build reads and writes: version 2 adds metadata records after
/// the model ([`ModelMeta`]). A blob without metadata is written as version 1, which every build
/// reads.
pub const FORMAT_VERSION: u16 = 2;
/// The version of a blob that carries only its model.
pub const MODEL_ONLY_VERSION: u16 = 1;
/// Input schema id 1: the 13 features of [`crate::FEATURE_NAMES`] in that order, as computed by
/// [`crate::features()`] (with the surrogates, for MSRA). MSRA and GSSM blobs are scored with it.
pub const FEATURE_SCHEMA: u16 = 1;
/// Input schema id 3: the DRL input encoding of [`crate::encoding`]. DRL blobs are scored with it;
/// a DRL blob of an older schema (1: the raw features; 2: the retired encoding 2, which derived
/// the same inputs from the features through `sin`/`cos`) is refused with
/// [`ModelError::WrongInputSchema`].
pub const DRL_INPUT_SCHEMA: u16 = DRL_INPUT_ENCODING;
/// Every input-schema id this build knows (1 up to the current DRL encoding); an id outside is
/// [`ModelError::UnsupportedFeatureSchema`].
pub const KNOWN_INPUT_SCHEMAS: core::ops::RangeInclusive<u16> = FEATURE_SCHEMA..=DRL_INPUT_SCHEMA;
/// Length of the fixed header.
pub const HEADER_LEN: usize = 20;

/// What the payload holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ModelKind {
    /// DRL network, int8 ([`QuantMlp`]).
    DrlInt8 = 1,
    /// DRL network, f32 ([`FloatMlp`]).
    DrlF32 = 2,
    /// MSRA combination ([`MsraModel`]), optionally embedding a GSSM network.
    Msra = 3,
    /// GSSM / SSRA lognormal spacing model ([`GssmModel`]).
    Gssm = 4,
}

impl ModelKind {
    /// The kind for a header byte.
    pub fn from_u8(byte: u8) -> Result<Self, ModelError> {
        match byte {
            1 => Ok(Self::DrlInt8),
            2 => Ok(Self::DrlF32),
            3 => Ok(Self::Msra),
            4 => Ok(Self::Gssm),
            other => Err(ModelError::UnknownKind(other)),
        }
    }

    /// The input schema this build scores the kind with (header bytes 8-9).
    pub fn input_schema(self) -> u16 {
        match self {
            Self::DrlInt8 | Self::DrlF32 => DRL_INPUT_SCHEMA,
            Self::Msra | Self::Gssm => FEATURE_SCHEMA,
        }
    }

    /// Short lowercase name (`drl-int8`, `drl-f32`, `msra`, `gssm`).
    pub fn name(self) -> &'static str {
        match self {
            Self::DrlInt8 => "drl-int8",
            Self::DrlF32 => "drl-f32",
            Self::Msra => "msra",
            Self::Gssm => "gssm",
        }
    }
}

/// The decoded fixed header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModelHeader {
    /// Format version (bytes 4-5): [`MODEL_ONLY_VERSION`] (1, model only) or [`FORMAT_VERSION`]
    /// (2, model then metadata records); any other is [`ModelError::UnsupportedVersion`].
    pub version: u16,
    /// Model kind (byte 6); an unknown byte is [`ModelError::UnknownKind`].
    pub kind: ModelKind,
    /// Input-schema id (bytes 8-9): must be [`ModelKind::input_schema`] of `kind` in this build
    /// (1 for MSRA and GSSM, 3 for DRL); an id outside [`KNOWN_INPUT_SCHEMAS`] is
    /// [`ModelError::UnsupportedFeatureSchema`], a known one of the wrong kind
    /// [`ModelError::WrongInputSchema`].
    pub feature_schema: u16,
    /// Payload length in bytes after the 20-byte header (bytes 12-15); the blob must be exactly
    /// `HEADER_LEN + payload_len` long ([`ModelError::Truncated`] / [`ModelError::TrailingBytes`];
    /// [`decode_header`] alone does not check it).
    pub payload_len: u32,
    /// CRC-32/ISO-HDLC of the payload (bytes 16-19, [`crate::crc`]); checked by [`decode_blob`]
    /// ([`ModelError::CrcMismatch`]), not by [`decode_header`].
    pub payload_crc: u32,
}

impl ModelHeader {
    /// The 20 header bytes.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let mut h = [0u8; HEADER_LEN];
        let parts: [&[u8]; 8] = [
            &MAGIC,
            &self.version.to_le_bytes(),
            &[self.kind as u8],
            &[0],
            &self.feature_schema.to_le_bytes(),
            &[0, 0],
            &self.payload_len.to_le_bytes(),
            &self.payload_crc.to_le_bytes(),
        ];
        let mut dst = h.iter_mut();
        for byte in parts.iter().flat_map(|p| p.iter()) {
            if let Some(d) = dst.next() {
                *d = *byte;
            }
        }
        h
    }
}

/// A decoded model, borrowing its weights from the blob.
#[derive(Clone, Debug, PartialEq)]
pub enum Model<'a> {
    /// The int8 DRL network, as deployed ([`ModelKind::DrlInt8`]); reads the DRL inputs.
    DrlInt8(QuantMlp<'a>),
    /// The f32 DRL network, the int8 one's parity reference ([`ModelKind::DrlF32`]); reads the DRL
    /// inputs.
    DrlF32(FloatMlp<'a>),
    /// A multi-surrogate risk aggregation ([`ModelKind::Msra`]); reads the features and the
    /// surrogates.
    Msra(MsraModel<'a>),
    /// A GSSM / SSRA lognormal spacing model ([`ModelKind::Gssm`]); reads the features.
    Gssm(GssmModel<'a>),
}

impl<'a> Model<'a> {
    /// The kind byte this model is stored under.
    pub fn kind(&self) -> ModelKind {
        match self {
            Self::DrlInt8(_) => ModelKind::DrlInt8,
            Self::DrlF32(_) => ModelKind::DrlF32,
            Self::Msra(_) => ModelKind::Msra,
            Self::Gssm(_) => ModelKind::Gssm,
        }
    }

    /// Checks every invariant inference relies on (see each model's `validate`).
    pub fn validate(&self) -> Result<(), ModelError> {
        match self {
            Self::DrlInt8(m) => m.validate(),
            Self::DrlF32(m) => m.validate(),
            Self::Msra(m) => m.validate(),
            Self::Gssm(m) => m.validate(),
        }
    }

    /// True for the DRL kinds: they read the DRL inputs (encoding 3).
    pub fn reads_drl_inputs(&self) -> bool {
        matches!(self, Self::DrlInt8(_) | Self::DrlF32(_))
    }

    /// True for the kinds that run a network fitted on data (DRL, GSSM, SSRA): only their
    /// training domain may carry geometry cells, and only they hand over to a kinematic fallback
    /// (an MSRA is itself a sum of kinematic terms).
    pub fn runs_a_network(&self) -> bool {
        !matches!(self, Self::Msra(_))
    }

    /// True when scoring needs the surrogates (MSRA); DRL reads its own inputs (computed from the
    /// states, box distance included) and GSSM the features.
    pub fn needs_surrogates(&self) -> bool {
        matches!(self, Self::Msra(_))
    }

    /// The model's own risk score of one ego/partner pair (larger is riskier), without the blob's
    /// training-domain guard: for a blob with a training-domain record the deployed score is
    /// [`ModelBlob::score_guarded`] (see [`decode`]). Computes only what the model reads: the DRL
    /// inputs for DRL, features and surrogates for MSRA, features for GSSM. Bit for bit
    /// [`Model::score_observation`] of [`Observation::of`] the pair. Finite for every input.
    pub fn score(&self, ego: &VehicleState, partner: &VehicleState) -> f32 {
        match self {
            Self::DrlInt8(m) => m.forward(&drl_inputs(ego, partner))[0],
            Self::DrlF32(m) => m.forward(&drl_inputs(ego, partner))[0],
            Self::Msra(m) => {
                let (s, f) = surrogates_and_features(ego, partner);
                m.score(&f, &s)
            }
            Self::Gssm(m) => m.score(&features(ego, partner)),
        }
    }

    /// The warning threshold used when the user gives none, by model kind: DRL is trained to put
    /// impact states at r* = 4 and earlier conflict states under u, so half of r* is a neutral
    /// start; MSRA scores lie in [0, sum |w_k|] and a GSSM's in its score mode's range, so half
    /// of the range ([`crate::gssm::GssmScore::range_midpoint`]).
    pub fn kind_default_threshold(&self) -> f32 {
        match self {
            Self::DrlInt8(_) | Self::DrlF32(_) => 2.0,
            Self::Msra(m) => {
                0.5 * m
                    .terms
                    .as_slice()
                    .iter()
                    .map(|t| libm::fabsf(t.weight))
                    .sum::<f32>()
            }
            Self::Gssm(m) => m.score.range_midpoint(),
        }
    }

    /// The same score from an observation computed once ([`Observation::of`]) and shared by every
    /// model: DRL reads its `drl_inputs`, MSRA the features and surrogates, GSSM the features.
    pub fn score_observation(&self, observation: &Observation) -> f32 {
        let o = observation;
        match self {
            Self::DrlInt8(m) => m.forward(&o.drl_inputs)[0],
            Self::DrlF32(m) => m.forward(&o.drl_inputs)[0],
            Self::Msra(m) => m.score(&o.features, &o.surrogates),
            Self::Gssm(m) => m.score(&o.features),
        }
    }
}

fn le_u16(bytes: &[u8], at: usize) -> u16 {
    let b = |i: usize| bytes.get(at + i).copied().unwrap_or(0);
    u16::from_le_bytes([b(0), b(1)])
}

fn le_u32(bytes: &[u8], at: usize) -> u32 {
    let b = |i: usize| bytes.get(at + i).copied().unwrap_or(0);
    u32::from_le_bytes([b(0), b(1), b(2), b(3)])
}

/// Parses and checks the 20-byte header (not the payload or its CRC).
pub fn decode_header(blob: &[u8]) -> Result<ModelHeader, ModelError> {
    if blob.len() < HEADER_LEN {
        // A blob too short for its magic is reported as bad magic only if the bytes present differ.
        let present = blob.len().min(MAGIC.len());
        if blob.get(..present) != MAGIC.get(..present) {
            let mut m = [0u8; 4];
            for (d, s) in m.iter_mut().zip(blob) {
                *d = *s;
            }
            return Err(ModelError::BadMagic(m));
        }
        return Err(ModelError::Truncated {
            needed: HEADER_LEN,
            available: blob.len(),
        });
    }
    let magic = [
        blob.first().copied().unwrap_or(0),
        blob.get(1).copied().unwrap_or(0),
        blob.get(2).copied().unwrap_or(0),
        blob.get(3).copied().unwrap_or(0),
    ];
    if magic != MAGIC {
        return Err(ModelError::BadMagic(magic));
    }
    let version = le_u16(blob, 4);
    if !(MODEL_ONLY_VERSION..=FORMAT_VERSION).contains(&version) {
        return Err(ModelError::UnsupportedVersion(version));
    }
    let kind = ModelKind::from_u8(blob.get(6).copied().unwrap_or(0))?;
    for offset in [7usize, 10, 11] {
        if blob.get(offset).copied().unwrap_or(0) != 0 {
            return Err(ModelError::ReservedNotZero { offset });
        }
    }
    let feature_schema = le_u16(blob, 8);
    if !KNOWN_INPUT_SCHEMAS.contains(&feature_schema) {
        return Err(ModelError::UnsupportedFeatureSchema(feature_schema));
    }
    if feature_schema != kind.input_schema() {
        return Err(ModelError::WrongInputSchema {
            kind: kind.name(),
            found: feature_schema,
            expected: kind.input_schema(),
        });
    }
    Ok(ModelHeader {
        version,
        kind,
        feature_schema,
        payload_len: le_u32(blob, 12),
        payload_crc: le_u32(blob, 16),
    })
}

/// A decoded blob: the model and what the blob says about using it.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelBlob<'a> {
    /// The model, borrowing its weights from the blob. Its [`Model::score`] is the unguarded
    /// score: score as deployed with [`ModelBlob::score_pair_guarded`].
    pub model: Model<'a>,
    /// The blob's metadata records (default threshold, training domain, kinematic fallback,
    /// blend); empty for a version-1 blob, which then scores unguarded.
    pub meta: ModelMeta<'a>,
}

impl<'a> From<Model<'a>> for ModelBlob<'a> {
    /// A model without metadata, as a version-1 blob decodes.
    fn from(model: Model<'a>) -> Self {
        Self {
            model,
            meta: ModelMeta::default(),
        }
    }
}

impl ModelBlob<'_> {
    /// The warning threshold to use when the user gives none: the blob's calibrated operating
    /// point, else the kind's rule ([`Model::kind_default_threshold`]).
    pub fn default_threshold(&self) -> f32 {
        self.meta
            .default_threshold
            .map_or_else(|| self.model.kind_default_threshold(), |op| op.threshold)
    }
}

/// The kind's model struct at the front of `bytes`, and what follows it.
fn take_model<'a>(kind: ModelKind, bytes: &'a [u8]) -> Result<(Model<'a>, &'a [u8]), ModelError> {
    let mut r = WireReader::new(bytes);
    let model = match kind {
        ModelKind::DrlInt8 => Model::DrlInt8(payload_reader::quant_mlp(&mut r)?),
        ModelKind::DrlF32 => Model::DrlF32(payload_reader::float_mlp(&mut r)?),
        ModelKind::Msra => Model::Msra(payload_reader::msra(&mut r)?),
        ModelKind::Gssm => Model::Gssm(payload_reader::gssm(&mut r)?),
    };
    Ok((model, r.rest()))
}

/// Decodes and validates a model blob. Borrows the weights from `blob`; allocates nothing; returns
/// a typed error (never panics) for any malformed input.
///
/// The model alone: the blob's metadata records are validated and then dropped, so
/// [`Model::score`] of the result is the unguarded score. For a blob with a training-domain record
/// (every shipped blob) that is not the score `riskctl`, the CAN bridge and the C ABI give (the
/// shipped DRL's `blend` mixes in its kinematic fallback even inside the domain): to score as
/// deployed, use [`decode_blob`] and [`ModelBlob::score_guarded`].
pub fn decode(blob: &[u8]) -> Result<Model<'_>, ModelError> {
    decode_blob(blob).map(|b| b.model)
}

/// Decodes and validates a model blob and its metadata records (none for version 1).
pub fn decode_blob(blob: &[u8]) -> Result<ModelBlob<'_>, ModelError> {
    let header = decode_header(blob)?;
    let body = blob.get(HEADER_LEN..).unwrap_or(&[]);
    let declared = usize::try_from(header.payload_len).unwrap_or(usize::MAX);
    if body.len() < declared {
        return Err(ModelError::Truncated {
            needed: HEADER_LEN.saturating_add(declared),
            available: blob.len(),
        });
    }
    if body.len() > declared {
        return Err(ModelError::TrailingBytes {
            extra: body.len() - declared,
        });
    }
    let computed = crate::crc::crc32(body);
    if computed != header.payload_crc {
        return Err(ModelError::CrcMismatch {
            stored: header.payload_crc,
            computed,
        });
    }
    let (model, rest) = take_model(header.kind, body)?;
    let meta = if header.version == MODEL_ONLY_VERSION {
        if !rest.is_empty() {
            return Err(ModelError::TrailingBytes { extra: rest.len() });
        }
        ModelMeta::default()
    } else {
        ModelMeta::decode(rest)?
    };
    model.validate()?;
    meta_fits_model(&model, &meta)?;
    Ok(ModelBlob { model, meta })
}

/// The records that only some kinds may carry: geometry cells bound where a network was fitted.
fn meta_fits_model(model: &Model<'_>, meta: &ModelMeta<'_>) -> Result<(), ModelError> {
    if meta.coverage().is_some() && !model.runs_a_network() {
        return Err(ModelError::BadRecord {
            field: "geometry_coverage",
            reason: "only DRL and GSSM blobs carry one",
        });
    }
    Ok(())
}

fn payload_size(model: &Model<'_>) -> Result<usize, ModelError> {
    let n = match model {
        Model::DrlInt8(m) => postcard::experimental::serialized_size(m),
        Model::DrlF32(m) => postcard::experimental::serialized_size(m),
        Model::Msra(m) => postcard::experimental::serialized_size(m),
        Model::Gssm(m) => postcard::experimental::serialized_size(m),
    }?;
    Ok(n)
}

/// Exact size in bytes of the blob [`encode`] writes for `model` (header included).
pub fn encoded_len(model: &Model<'_>) -> Result<usize, ModelError> {
    Ok(HEADER_LEN + payload_size(model)?)
}

/// Exact size in bytes of the blob [`encode_blob`] writes.
pub fn encoded_blob_len(blob: &ModelBlob<'_>) -> Result<usize, ModelError> {
    Ok(encoded_len(&blob.model)? + blob.meta.encoded_len()?)
}

/// Validates `model` and writes its blob (version 1, no metadata) into `out`; returns the number
/// of bytes written.
pub fn encode(model: &Model<'_>, out: &mut [u8]) -> Result<usize, ModelError> {
    encode_blob(
        &ModelBlob {
            model: model.clone(),
            meta: ModelMeta::default(),
        },
        out,
    )
}

/// Validates the model and its metadata and writes the blob into `out` (version 1 when the
/// metadata is empty, else [`FORMAT_VERSION`]); returns the number of bytes written.
pub fn encode_blob(blob: &ModelBlob<'_>, out: &mut [u8]) -> Result<usize, ModelError> {
    let model = &blob.model;
    model.validate()?;
    blob.meta.validate()?;
    meta_fits_model(model, &blob.meta)?;
    let needed = encoded_blob_len(blob)?;
    let available = out.len();
    let too_small = ModelError::BufferTooSmall { needed, available };
    let (head, body) = out
        .split_at_mut_checked(HEADER_LEN)
        .ok_or(too_small.clone())?;
    let model_len = match model {
        Model::DrlInt8(m) => postcard::to_slice(m, body),
        Model::DrlF32(m) => postcard::to_slice(m, body),
        Model::Msra(m) => postcard::to_slice(m, body),
        Model::Gssm(m) => postcard::to_slice(m, body),
    }
    .map_err(|e| match e {
        postcard::Error::SerializeBufferFull => too_small.clone(),
        other => ModelError::Payload(other),
    })?
    .len();
    let meta_len = blob
        .meta
        .encode(body.get_mut(model_len..).ok_or(too_small.clone())?)?;
    let payload_len = model_len + meta_len;
    let written = body.get(..payload_len).ok_or(too_small)?;
    let header = ModelHeader {
        version: if blob.meta.is_empty() {
            MODEL_ONLY_VERSION
        } else {
            FORMAT_VERSION
        },
        kind: model.kind(),
        feature_schema: model.kind().input_schema(),
        payload_len: u32::try_from(payload_len).map_err(|_| ModelError::CapacityExceeded {
            field: "payload",
            len: payload_len,
            max: u32::MAX as usize,
        })?,
        payload_crc: crate::crc::crc32(written),
    };
    head.copy_from_slice(&header.to_bytes());
    Ok(HEADER_LEN + payload_len)
}
