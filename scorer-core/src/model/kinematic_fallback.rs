//! The kinematic-fallback record (tag 3 of a version-2 blob): the score a model hands over to
//! outside its training domain under [`OutsidePolicy::Fallback`](super::OutsidePolicy::Fallback).
//!
//! The fallback is an MSRA over kinematic surrogates only (TTC2D, TAdv, EI, TAdv-corridor: no GSSM, which is a
//! learned model with a domain of its own), put on the model's own score scale by an affine map:
//! `score = scale * sum_k w_k sigmoid(a_k g_k(f_k) + b_k) + offset`, each term exactly an
//! [`MsraTerm`] ([`MsraTerm::value`]). One threshold then serves both the model inside its domain
//! and the fallback outside. Training fits the terms and the map on the model's own training data
//! (`docs/domain-guard.md`).
//!
//! Like the training-domain ranges, the terms stay in the blob as a byte string
//! ([`FALLBACK_TERM_BYTES`] per term: `kind: u8` (the [`SurrogateKind`] wire index), then `w`,
//! `a`, `b`, `lo`, `hi` as `f32` little-endian) that the decoder borrows and validates: no copy,
//! no allocation on the ECU. Byte layout: `docs/model-format.md`.
use serde::{Deserialize, Serialize};

use super::ModelError;
use crate::msra::{MsraTerm, MAX_TERMS};
use crate::surrogates::{SurrogateKind, Surrogates};
use crate::wire_reader::WireReader;

/// Record tag of the [`KinematicFallback`].
pub const KINEMATIC_FALLBACK_TAG: u8 = 3;
/// Bytes of one term on the wire.
pub const FALLBACK_TERM_BYTES: usize = 21;

/// `scale * MSRA(kinematic terms) + offset`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct KinematicFallback<'a> {
    /// Multiplies the terms' sum (finite, `> 0`: the map keeps "larger is riskier").
    pub scale: f32,
    /// Added after scaling (finite).
    pub offset: f32,
    /// The terms, [`FALLBACK_TERM_BYTES`] each ([`KinematicFallback::terms`] reads them).
    #[serde(borrow)]
    pub term_bytes: &'a [u8],
}

/// The 21 wire bytes of one term.
pub fn term_to_bytes(term: &MsraTerm) -> [u8; FALLBACK_TERM_BYTES] {
    let mut out = [0u8; FALLBACK_TERM_BYTES];
    let floats = [term.weight, term.a, term.b, term.lo, term.hi];
    let bytes =
        core::iter::once(term.kind as u8).chain(floats.iter().flat_map(|x| x.to_le_bytes()));
    for (d, s) in out.iter_mut().zip(bytes) {
        *d = s;
    }
    out
}

/// The term of 21 wire bytes; `None` for a kind byte that names no surrogate.
fn term_from_bytes(b: &[u8]) -> Option<MsraTerm> {
    let at = |i: usize| b.get(i).copied().unwrap_or(0);
    let f = |i: usize| f32::from_le_bytes([at(i), at(i + 1), at(i + 2), at(i + 3)]);
    let kind = *SurrogateKind::ALL.get(usize::from(at(0)))?;
    Some(MsraTerm {
        kind,
        weight: f(1),
        a: f(5),
        b: f(9),
        lo: f(13),
        hi: f(17),
    })
}

impl<'a> KinematicFallback<'a> {
    /// A fallback over `term_bytes` (the concatenated [`term_to_bytes`] of its terms).
    pub fn new(scale: f32, offset: f32, term_bytes: &'a [u8]) -> Self {
        Self {
            scale,
            offset,
            term_bytes,
        }
    }

    /// The record body's fields, in postcard order.
    pub(super) fn read(r: &mut WireReader<'a>) -> Result<Self, postcard::Error> {
        Ok(Self::new(r.f32()?, r.f32()?, r.bytes()?))
    }

    /// The terms, in record order (a term of an unknown kind byte is skipped: validation refuses it).
    pub fn terms(&self) -> impl Iterator<Item = MsraTerm> + 'a {
        self.term_bytes
            .chunks_exact(FALLBACK_TERM_BYTES)
            .filter_map(term_from_bytes)
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.term_bytes.len() / FALLBACK_TERM_BYTES
    }

    /// True when the record holds no term.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The terms' sum before the affine map (what training aligns to the model's scale).
    pub fn msra(&self, surrogates: &Surrogates) -> f32 {
        self.terms()
            .map(|t| t.value(surrogates.kinematic(t.kind).unwrap_or(f32::NAN)))
            .sum()
    }

    /// The fallback score: `scale * msra + offset`. Finite for every input of a validated record.
    pub fn score(&self, surrogates: &Surrogates) -> f32 {
        let r = self.scale * self.msra(surrogates) + self.offset;
        if r.is_finite() {
            r
        } else {
            self.offset
        }
    }

    /// 1 to [`MAX_TERMS`] whole terms, each of a kinematic surrogate with valid parameters;
    /// finite `scale > 0` and `offset`.
    pub fn validate(&self) -> Result<(), ModelError> {
        let field = "kinematic_fallback.terms";
        if !self.term_bytes.len().is_multiple_of(FALLBACK_TERM_BYTES) {
            return Err(ModelError::DimensionMismatch {
                field,
                index: 0,
                expected: self.len().saturating_add(1) * FALLBACK_TERM_BYTES,
                found: self.term_bytes.len(),
            });
        }
        if self.is_empty() {
            return Err(ModelError::Empty { field });
        }
        if self.len() > MAX_TERMS {
            return Err(ModelError::CapacityExceeded {
                field,
                len: self.len(),
                max: MAX_TERMS,
            });
        }
        for (k, chunk) in self
            .term_bytes
            .chunks_exact(FALLBACK_TERM_BYTES)
            .enumerate()
        {
            let bad = |reason| ModelError::BadFallbackTerm { term: k, reason };
            let term = term_from_bytes(chunk).ok_or(bad("unknown surrogate kind"))?;
            if term.kind == SurrogateKind::Gssm {
                return Err(bad("GSSM is not a kinematic surrogate"));
            }
            term.validate(k)
                .map_err(|_| bad("parameters not finite, too large, or clip range not lo < hi"))?;
        }
        if !(self.scale.is_finite() && self.scale <= crate::mlp::MAX_ABS_PARAM) {
            return Err(ModelError::NonFinite {
                field: "kinematic_fallback.scale",
                index: 0,
            });
        }
        if self.scale <= 0.0 {
            return Err(ModelError::NonPositiveScale {
                field: "kinematic_fallback.scale",
                index: 0,
            });
        }
        if !(self.offset.is_finite() && self.offset.abs() <= crate::mlp::MAX_ABS_PARAM) {
            return Err(ModelError::NonFinite {
                field: "kinematic_fallback.offset",
                index: 0,
            });
        }
        Ok(())
    }
}
