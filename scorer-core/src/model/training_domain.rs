//! The training-domain record (tag 2 of a version-2 blob): the range of every model input its
//! training data covered, and what scoring does with an observation outside it.
//!
//! The inputs are the vector the model kind reads (the model's "input space"): the 13 DRL inputs of
//! schema 3 for DRL blobs, the 13 features of schema 1 for GSSM and MSRA blobs (MSRA's surrogates
//! are clipped by its own terms; the features are what places an MSRA observation in speed and
//! geometry, and what its embedded GSSM reads). Checking and clamping live in [`crate::domain`];
//! this module is the record and its validation. Byte layout: `docs/model-format.md`.
//!
//! The ranges stay in the blob: like the weight arrays they are a byte string (9 bytes per range:
//! `input: u8`, `lo: f32`, `hi: f32`, little-endian) that the decoder borrows and validates, so the
//! record costs the ECU no copy and no per-field deserialiser.
use serde::{Deserialize, Serialize};

use super::geometry_coverage::GeometryCoverage;
use super::ModelError;
use crate::wire_reader::WireReader;

/// Record tag of the [`TrainingDomain`].
pub const TRAINING_DOMAIN_TAG: u8 = 2;
/// Inputs a domain can bound: every model kind reads 13 numbers.
pub const MAX_DOMAIN_INPUTS: usize = 13;
/// Bytes of one range on the wire.
pub const RANGE_BYTES: usize = 9;

/// What scoring does with an observation that is outside the training domain.
///
/// Wire indices are pinned (postcard enum variant index, one byte): `0` FlagOnly, `1` Clamp,
/// `2` Fallback, `3` Blend; any other byte is [`ModelError::UnknownOutsidePolicy`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum OutsidePolicy {
    /// Score as an unguarded model would and report the flag.
    FlagOnly,
    /// Clamp each input into its trained range (a NaN input to the range's midpoint), then score:
    /// the model never sees a value it was not trained on.
    Clamp,
    /// Score the blob's kinematic fallback (record tag 3,
    /// [`KinematicFallback`](super::KinematicFallback)) instead of the model: outside its domain
    /// the model hands over to a kinematic MSRA on the model's own score scale.
    Fallback,
    /// Outside the domain as [`OutsidePolicy::Fallback`]; inside it the score is the model's
    /// mixed with the same fallback by the blob's [`Blend`](super::Blend) record (tag 5).
    Blend,
}

impl OutsidePolicy {
    /// Every policy, in wire order.
    pub const ALL: [OutsidePolicy; 4] = [Self::FlagOnly, Self::Clamp, Self::Fallback, Self::Blend];

    /// Lowercase name as the tools print and parse it (`flag-only`, `clamp`, `fallback`,
    /// `blend`).
    pub fn name(self) -> &'static str {
        match self {
            Self::FlagOnly => "flag-only",
            Self::Clamp => "clamp",
            Self::Fallback => "fallback",
            Self::Blend => "blend",
        }
    }

    /// The policy for a name of [`OutsidePolicy::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The policy of a wire byte (the first byte of the record body), `None` if unknown.
    pub fn from_wire(byte: u8) -> Option<Self> {
        Self::ALL.get(usize::from(byte)).copied()
    }

    /// True for the policies that score the kinematic fallback (record tag 3) outside the domain.
    pub fn uses_fallback(self) -> bool {
        matches!(self, Self::Fallback | Self::Blend)
    }
}

/// The trained range `[lo, hi]` of one input (an index into the kind's input vector).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InputRange {
    /// Index into the vector the model kind reads
    /// ([`Model::domain_inputs`](crate::model::Model::domain_inputs)): `0..13`, named by
    /// [`crate::DRL_INPUT_NAMES`] for DRL blobs and [`crate::FEATURE_NAMES`] for MSRA and GSSM
    /// blobs. 13 or more is refused ([`ModelError::BadDomainEntry`]).
    pub input: u8,
    /// Lowest trained value, inclusive, in that input's own unit (m, m/s, m^2/s^2, rad,
    /// dimensionless, or the log and `slog` scales of the DRL inputs; see
    /// [`crate::features`](mod@crate::features) and [`crate::encoding`]). Finite and `<= hi`,
    /// else the record is refused.
    pub lo: f32,
    /// Highest trained value, inclusive, in the same unit; finite and `>= lo`. An input `x` is
    /// inside when `lo <= x <= hi` ([`InputRange::contains`]; NaN is outside).
    pub hi: f32,
}

impl InputRange {
    /// The range's 9 wire bytes.
    pub fn to_bytes(&self) -> [u8; RANGE_BYTES] {
        let mut out = [0u8; RANGE_BYTES];
        let (lo, hi) = (self.lo.to_le_bytes(), self.hi.to_le_bytes());
        for (d, s) in out
            .iter_mut()
            .zip(core::iter::once(&self.input).chain(&lo).chain(&hi))
        {
            *d = *s;
        }
        out
    }

    fn from_bytes(b: &[u8]) -> Self {
        let at = |i: usize| b.get(i).copied().unwrap_or(0);
        let f = |i: usize| f32::from_le_bytes([at(i), at(i + 1), at(i + 2), at(i + 3)]);
        Self {
            input: at(0),
            lo: f(1),
            hi: f(5),
        }
    }
}

/// The training domain: the ranges of the bounded inputs (inputs not listed are unbounded), the
/// geometry cells the training data reached (DRL and GSSM blobs; record tag 4, stored beside this
/// one) and the policy for outside.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingDomain<'a> {
    /// What the guarded score is for an observation outside the domain (the first body byte on
    /// the wire: 0 flag-only, 1 clamp, 2 fallback, 3 blend; another byte is
    /// [`ModelError::UnknownOutsidePolicy`]).
    pub policy: OutsidePolicy,
    /// [`InputRange`]s, [`RANGE_BYTES`] each ([`TrainingDomain::ranges`] reads them).
    #[serde(borrow)]
    pub range_bytes: &'a [u8],
    /// The covered geometry cells; `None`: every cell counts as covered. Its own record (tag 4),
    /// so a build that does not know it still reads the ranges.
    #[serde(skip)]
    pub coverage: Option<GeometryCoverage<'a>>,
}

impl<'a> TrainingDomain<'a> {
    /// A domain over `range_bytes` (the concatenated [`InputRange::to_bytes`] of its ranges).
    pub fn new(policy: OutsidePolicy, range_bytes: &'a [u8]) -> Self {
        Self {
            policy,
            range_bytes,
            coverage: None,
        }
    }

    /// The domain with its geometry coverage set.
    pub fn with_coverage(self, coverage: Option<GeometryCoverage<'a>>) -> Self {
        Self { coverage, ..self }
    }

    /// The record body's fields, in postcard order (a policy index this build does not know is
    /// what serde's derived variant visitor reports through postcard).
    pub(super) fn read(r: &mut WireReader<'a>) -> Result<Self, postcard::Error> {
        let policy = u8::try_from(r.u32()?)
            .ok()
            .and_then(OutsidePolicy::from_wire)
            .ok_or(postcard::Error::SerdeDeCustom)?;
        Ok(Self::new(policy, r.bytes()?))
    }

    /// The ranges, in record order.
    pub fn ranges(&self) -> impl Iterator<Item = InputRange> + 'a {
        self.range_bytes
            .chunks_exact(RANGE_BYTES)
            .map(InputRange::from_bytes)
    }

    /// Number of ranges.
    pub fn len(&self) -> usize {
        self.range_bytes.len() / RANGE_BYTES
    }

    /// True when no input is bounded.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whole ranges, at most 13, each of a known input given once, with finite `lo <= hi`; a
    /// valid coverage.
    pub fn validate(&self) -> Result<(), ModelError> {
        if let Some(coverage) = &self.coverage {
            coverage.validate()?;
        }
        let field = "training_domain.ranges";
        if !self.range_bytes.len().is_multiple_of(RANGE_BYTES) {
            return Err(ModelError::DimensionMismatch {
                field,
                index: 0,
                expected: self.len().saturating_add(1) * RANGE_BYTES,
                found: self.range_bytes.len(),
            });
        }
        if self.len() > MAX_DOMAIN_INPUTS {
            return Err(ModelError::CapacityExceeded {
                field,
                len: self.len(),
                max: MAX_DOMAIN_INPUTS,
            });
        }
        let mut seen = 0u16;
        for (entry, range) in self.ranges().enumerate() {
            let bad = |reason| ModelError::BadDomainEntry {
                entry,
                input: range.input,
                reason,
            };
            if usize::from(range.input) >= MAX_DOMAIN_INPUTS {
                return Err(bad("unknown input"));
            }
            if !(range.lo.is_finite() && range.hi.is_finite()) {
                return Err(bad("bound not finite"));
            }
            if range.lo > range.hi {
                return Err(bad("lo > hi"));
            }
            let bit = 1u16 << range.input;
            if seen & bit != 0 {
                return Err(bad("input given twice"));
            }
            seen |= bit;
        }
        Ok(())
    }
}
