//! The training-domain record (tag 2 of a version-2 blob): the range of every model input its
//! training data covered, and what scoring does with an observation outside it.
//!
//! The inputs are the vector the model kind reads (the model's "input space"): the 13 DRL inputs of
//! schema 3 for DRL blobs, the 13 features of schema 1 for GSSM and MSRA blobs (MSRA's surrogates
//! are clipped by its own terms; the features are what places an MSRA observation in speed and
//! geometry, and what its embedded GSSM reads). Checking and clamping live in [`crate::domain`];
//! this module is the record and its validation. Byte layout: `docs/model-format.md`.
use serde::{Deserialize, Serialize};

use super::ModelError;
use crate::bounded::BoundedVec;

/// Record tag of the [`TrainingDomain`].
pub const TRAINING_DOMAIN_TAG: u8 = 2;
/// Inputs a domain can bound: every model kind reads 13 numbers.
pub const MAX_DOMAIN_INPUTS: usize = 13;

/// What scoring does with an observation that is outside the training domain.
///
/// Wire indices are pinned (postcard enum variant index): `0` FlagOnly, `1` Clamp.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum OutsidePolicy {
    /// Score as an unguarded model would and report the flag.
    FlagOnly,
    /// Clamp each input into its trained range (a NaN input to the range's midpoint), then score:
    /// the model never sees a value it was not trained on.
    Clamp,
}

impl OutsidePolicy {
    /// Lowercase name as the tools print and parse it (`flag-only`, `clamp`).
    pub fn name(self) -> &'static str {
        match self {
            Self::FlagOnly => "flag-only",
            Self::Clamp => "clamp",
        }
    }

    /// The policy for a name of [`OutsidePolicy::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::FlagOnly, Self::Clamp]
            .into_iter()
            .find(|p| p.name() == name)
    }
}

/// The trained range `[lo, hi]` of one input (an index into the kind's input vector).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputRange {
    pub input: u8,
    pub lo: f32,
    pub hi: f32,
}

/// The training domain: the ranges of the bounded inputs (inputs not listed are unbounded) and
/// the policy for outside.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingDomain {
    pub policy: OutsidePolicy,
    pub ranges: BoundedVec<InputRange, MAX_DOMAIN_INPUTS>,
}

impl TrainingDomain {
    /// At most 13 ranges, each of a known input given once, with finite `lo <= hi`.
    pub fn validate(&self) -> Result<(), ModelError> {
        self.ranges.check_capacity("training_domain.ranges")?;
        for (entry, range) in self.ranges.iter().enumerate() {
            let bad = |reason| ModelError::BadDomainEntry {
                entry,
                input: range.input,
                reason,
            };
            if usize::from(range.input) >= MAX_DOMAIN_INPUTS {
                return Err(bad("input index must be below 13"));
            }
            if !(range.lo.is_finite() && range.hi.is_finite()) {
                return Err(bad("lo and hi must be finite"));
            }
            if range.lo > range.hi {
                return Err(bad("lo must not exceed hi"));
            }
            let earlier = self.ranges.get(..entry).unwrap_or(&[]);
            if earlier.iter().any(|r| r.input == range.input) {
                return Err(bad("input given twice"));
            }
        }
        Ok(())
    }
}
