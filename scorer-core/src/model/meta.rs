//! The metadata records a version-2 blob carries after its model: what a model says about how to
//! use it (today: its default warning threshold and how that was chosen).
//!
//! Wire form (inside the CRC-covered payload, right after the kind's model struct): zero or more
//! records, each `tag: u8`, `length: varint u32`, then `length` body bytes. A record of an unknown
//! tag is skipped (a newer exporter may add records an older reader does not need); a known tag
//! whose body is not exactly its postcard encoding, or a tag given twice, is an error. Byte-level
//! specification: `docs/model-format.md`.
use serde::{Deserialize, Serialize};

use super::blend::{Blend, BLEND_TAG};
use super::geometry_coverage::{GeometryCoverage, GEOMETRY_COVERAGE_TAG};
use super::kinematic_fallback::{KinematicFallback, KINEMATIC_FALLBACK_TAG};
use super::training_domain::{OutsidePolicy, TrainingDomain, TRAINING_DOMAIN_TAG};
use super::ModelError;
use crate::wire_reader::WireReader;

/// Record tag of the [`DefaultThreshold`].
pub const DEFAULT_THRESHOLD_TAG: u8 = 1;
/// Longest description of the calibration data a blob may carry (bytes of UTF-8).
pub const MAX_DATA_DESCRIPTION: usize = 200;
/// Rounding room between a stored measured share and its target (both `f32`).
const SHARE_TOLERANCE: f32 = 1e-6;

/// How a default threshold was chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum ThresholdRule {
    /// The kind's rule of thumb without data ([`super::Model::kind_default_threshold`]).
    KindDefault,
    /// The smallest sequence maximum at which at most `target` of `sequences` normal-driving
    /// sequences warn; `measured` is the share that does (both fractions in `[0, 1]`).
    SafeShare {
        /// The largest share of the sequences allowed to warn, a fraction in `[0, 1]` (0.05 for
        /// the shipped blobs' 5 % rule); outside, [`DefaultThreshold::validate`] refuses it.
        target: f32,
        /// The share that warns at the chosen threshold, a fraction in `[0, 1]` and at most
        /// `target` (plus 1e-6 of rounding room); else refused.
        measured: f32,
        /// How many normal-driving sequences the shares were measured on (a count).
        sequences: u32,
    },
}

/// A model's default warning threshold, the rule that chose it and a description of the data.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DefaultThreshold<'a> {
    /// Warn when the score is `>= threshold`.
    pub threshold: f32,
    /// How the threshold was chosen (for people and tools; scoring does not read it).
    pub rule: ThresholdRule,
    /// What the rule was measured on (for people: shown by `inspect-model`), at most
    /// [`MAX_DATA_DESCRIPTION`] bytes.
    pub data: &'a str,
}

impl<'a> DefaultThreshold<'a> {
    /// The record body's fields, in postcard order.
    fn read(r: &mut WireReader<'a>) -> Result<Self, postcard::Error> {
        let threshold = r.f32()?;
        let rule = match r.u32()? {
            0 => ThresholdRule::KindDefault,
            1 => ThresholdRule::SafeShare {
                target: r.f32()?,
                measured: r.f32()?,
                sequences: r.u32()?,
            },
            // What serde's derived variant visitor reports through postcard.
            _ => return Err(postcard::Error::SerdeDeCustom),
        };
        Ok(Self {
            threshold,
            rule,
            data: r.str()?,
        })
    }

    /// Finite threshold, fractions in `[0, 1]`, a bounded description.
    pub fn validate(&self) -> Result<(), ModelError> {
        let field = "default_threshold";
        if !self.threshold.is_finite() {
            return Err(ModelError::NonFinite { field, index: 0 });
        }
        if let ThresholdRule::SafeShare {
            target, measured, ..
        } = self.rule
        {
            if !((0.0..=1.0).contains(&target) && (0.0..=1.0).contains(&measured)) {
                return Err(ModelError::BadRecord {
                    field: "default_threshold.rule",
                    reason: "target and measured shares must lie in [0, 1]",
                });
            }
            // The rule allows at most the target share; a little room for the f32 rounding.
            if measured > target + SHARE_TOLERANCE {
                return Err(ModelError::BadRecord {
                    field: "default_threshold.rule",
                    reason: "the measured share exceeds the target the rule promises",
                });
            }
        }
        // The description is printed by tools and logs: no control characters (escape codes,
        // line breaks) that could forge output.
        if has_control_character(self.data) {
            return Err(ModelError::BadRecord {
                field: "default_threshold.data",
                reason: "control characters are not allowed",
            });
        }
        if self.data.len() > MAX_DATA_DESCRIPTION {
            return Err(ModelError::CapacityExceeded {
                field: "default_threshold.data",
                len: self.data.len(),
                max: MAX_DATA_DESCRIPTION,
            });
        }
        Ok(())
    }
}

/// Everything a blob says beside its model. The default (no records) is what a version-1 blob has.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ModelMeta<'a> {
    /// Tag 1: the calibrated default warning threshold (same unit as the model's score);
    /// `None`: [`ModelBlob::default_threshold`](super::ModelBlob::default_threshold) falls back to
    /// the kind's rule ([`super::Model::kind_default_threshold`]).
    pub default_threshold: Option<DefaultThreshold<'a>>,
    /// Tag 2: the inputs' trained ranges and the policy outside them, with the covered geometry
    /// cells of tag 4 when the blob has them; `None` scores unguarded.
    pub training_domain: Option<TrainingDomain<'a>>,
    /// Tag 3: the score outside the domain under [`OutsidePolicy::Fallback`] and
    /// [`OutsidePolicy::Blend`]; present exactly when the domain has one of them.
    pub kinematic_fallback: Option<KinematicFallback<'a>>,
    /// Tag 5: the model's share inside the domain under [`OutsidePolicy::Blend`]; present
    /// exactly when the domain's policy is blend.
    pub blend: Option<Blend>,
}

impl<'a> ModelMeta<'a> {
    /// True when there is nothing to write (the blob is then written as version 1).
    pub fn is_empty(&self) -> bool {
        self.default_threshold.is_none()
            && self.training_domain.is_none()
            && self.kinematic_fallback.is_none()
            && self.blend.is_none()
    }

    /// Checks every record ([`DefaultThreshold::validate`], [`TrainingDomain::validate`],
    /// [`KinematicFallback::validate`], [`Blend::validate`]) and that the records fit together:
    /// a kinematic fallback exactly when the domain's policy is fallback or blend, a blend record
    /// exactly when it is blend ([`ModelError::BadRecord`] otherwise). [`super::decode_blob`] and
    /// [`super::encode_blob`] run it.
    pub fn validate(&self) -> Result<(), ModelError> {
        if let Some(op) = &self.default_threshold {
            op.validate()?;
        }
        if let Some(domain) = &self.training_domain {
            domain.validate()?;
        }
        if let Some(fallback) = &self.kinematic_fallback {
            fallback.validate()?;
        }
        if let Some(blend) = &self.blend {
            blend.validate()?;
        }
        let policy = self.training_domain.map(|d| d.policy);
        present_exactly_when(
            policy.is_some_and(OutsidePolicy::uses_fallback),
            self.kinematic_fallback.is_some(),
            "the policy needs a fallback record (tag 3)",
            (
                "kinematic_fallback",
                "tag 3 needs the fallback or blend policy",
            ),
        )?;
        present_exactly_when(
            policy == Some(OutsidePolicy::Blend),
            self.blend.is_some(),
            "the policy needs a blend record (tag 5)",
            ("blend", "tag 5 needs the blend policy"),
        )
    }

    /// Reads the records that fill `bytes` entirely.
    pub fn decode(mut bytes: &'a [u8]) -> Result<Self, ModelError> {
        let mut meta = ModelMeta::default();
        let mut coverage = None;
        while let Some((&tag, rest)) = bytes.split_first() {
            let mut r = WireReader::new(rest);
            let len = usize::try_from(r.u32()?).unwrap_or(usize::MAX);
            let rest = r.rest();
            let (body, rest) = rest.split_at_checked(len).ok_or(ModelError::Truncated {
                needed: len,
                available: rest.len(),
            })?;
            match tag {
                DEFAULT_THRESHOLD_TAG => {
                    meta.default_threshold = Some(take_record(
                        tag,
                        body,
                        &meta.default_threshold,
                        DefaultThreshold::read,
                    )?);
                }
                TRAINING_DOMAIN_TAG => {
                    // A policy byte this build does not know is named, not a postcard error.
                    if let Some(&byte) = body.first() {
                        if OutsidePolicy::from_wire(byte).is_none() {
                            return Err(ModelError::UnknownOutsidePolicy(byte));
                        }
                    }
                    meta.training_domain = Some(take_record(
                        tag,
                        body,
                        &meta.training_domain,
                        TrainingDomain::read,
                    )?);
                }
                KINEMATIC_FALLBACK_TAG => {
                    meta.kinematic_fallback = Some(take_record(
                        tag,
                        body,
                        &meta.kinematic_fallback,
                        KinematicFallback::read,
                    )?);
                }
                BLEND_TAG => {
                    meta.blend = Some(take_record(tag, body, &meta.blend, Blend::read)?);
                }
                GEOMETRY_COVERAGE_TAG => {
                    if coverage.is_some() {
                        return Err(ModelError::DuplicateRecord { tag });
                    }
                    coverage = Some(GeometryCoverage::from_body(body));
                }
                _ => {}
            }
            bytes = rest;
        }
        if coverage.is_some() {
            let domain = meta.training_domain.as_mut().ok_or(ModelError::BadRecord {
                field: "geometry_coverage",
                reason: "needs a training domain (tag 2)",
            })?;
            domain.coverage = coverage;
        }
        // Each record, and whether they agree (they may come in any order), once all are read:
        // one copy of the checks in the image.
        meta.validate()?;
        Ok(meta)
    }

    /// Writes the records into `out` (tag order); returns the bytes written.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, ModelError> {
        self.validate()?;
        let needed = self.encoded_len()?;
        let too_small = ModelError::BufferTooSmall {
            needed,
            available: out.len(),
        };
        let mut written = 0;
        if let Some(op) = &self.default_threshold {
            let rest = out.get_mut(written..).ok_or(too_small.clone())?;
            written += write_record(DEFAULT_THRESHOLD_TAG, op, rest, &too_small)?;
        }
        if let Some(domain) = &self.training_domain {
            let rest = out.get_mut(written..).ok_or(too_small.clone())?;
            written += write_record(TRAINING_DOMAIN_TAG, domain, rest, &too_small)?;
        }
        if let Some(fallback) = &self.kinematic_fallback {
            let rest = out.get_mut(written..).ok_or(too_small.clone())?;
            written += write_record(KINEMATIC_FALLBACK_TAG, fallback, rest, &too_small)?;
        }
        if let Some(coverage) = self.coverage() {
            let rest = out.get_mut(written..).ok_or(too_small.clone())?;
            written += write_record(GEOMETRY_COVERAGE_TAG, coverage, rest, &too_small)?;
        }
        if let Some(blend) = &self.blend {
            let rest = out.get_mut(written..).ok_or(too_small.clone())?;
            written += write_record(BLEND_TAG, blend, rest, &too_small)?;
        }
        Ok(written)
    }

    /// Exact size of [`ModelMeta::encode`]'s output.
    pub fn encoded_len(&self) -> Result<usize, ModelError> {
        let threshold = match &self.default_threshold {
            Some(op) => record_len(op)?,
            None => 0,
        };
        let domain = match &self.training_domain {
            Some(domain) => record_len(domain)?,
            None => 0,
        };
        let fallback = match &self.kinematic_fallback {
            Some(fallback) => record_len(fallback)?,
            None => 0,
        };
        let coverage = match self.coverage() {
            Some(coverage) => record_len(coverage)?,
            None => 0,
        };
        let blend = match &self.blend {
            Some(blend) => record_len(blend)?,
            None => 0,
        };
        Ok(threshold + domain + fallback + coverage + blend)
    }

    /// The training domain's geometry coverage (record tag 4), if any.
    pub fn coverage(&self) -> Option<&GeometryCoverage<'a>> {
        self.training_domain.as_ref()?.coverage.as_ref()
    }
}

/// A record the domain's policy asks for (`asked`) must be there, and one it does not ask for must
/// not: `missing` names the first failure (on the policy), `orphan` (field, reason) the second.
fn present_exactly_when(
    asked: bool,
    present: bool,
    missing: &'static str,
    (orphan_field, orphan): (&'static str, &'static str),
) -> Result<(), ModelError> {
    match (asked, present) {
        (true, false) => Err(ModelError::BadRecord {
            field: "training_domain.policy",
            reason: missing,
        }),
        (false, true) => Err(ModelError::BadRecord {
            field: orphan_field,
            reason: orphan,
        }),
        _ => Ok(()),
    }
}

/// The record body of `tag`, which must be exactly one `T` (as `read` reads its postcard
/// encoding) and the first record of its tag.
fn take_record<'a, T>(
    tag: u8,
    body: &'a [u8],
    earlier: &Option<T>,
    read: fn(&mut WireReader<'a>) -> Result<T, postcard::Error>,
) -> Result<T, ModelError> {
    if earlier.is_some() {
        return Err(ModelError::DuplicateRecord { tag });
    }
    let mut r = WireReader::new(body);
    let value = read(&mut r)?;
    if !r.rest().is_empty() {
        return Err(ModelError::TrailingBytes {
            extra: r.rest().len(),
        });
    }
    Ok(value)
}

/// Writes `tag`, the varint body length and the body; returns the bytes written.
fn write_record<T: Serialize>(
    tag: u8,
    body: &T,
    out: &mut [u8],
    too_small: &ModelError,
) -> Result<usize, ModelError> {
    let body_len = postcard::experimental::serialized_size(body)?;
    let len = u32::try_from(body_len).map_err(|_| ModelError::CapacityExceeded {
        field: "record",
        len: body_len,
        max: u32::MAX as usize,
    })?;
    let (tag_byte, rest) = out.split_first_mut().ok_or(too_small.clone())?;
    *tag_byte = tag;
    let len_bytes = postcard::to_slice(&len, rest)
        .map_err(|_| too_small.clone())?
        .len();
    let body_out = rest.get_mut(len_bytes..).ok_or(too_small.clone())?;
    let written = postcard::to_slice(body, body_out)
        .map_err(|_| too_small.clone())?
        .len();
    Ok(1 + len_bytes + written)
}

/// Bytes [`write_record`] writes for `body`.
fn record_len<T: Serialize>(body: &T) -> Result<usize, ModelError> {
    let body = postcard::experimental::serialized_size(body)?;
    let len = u32::try_from(body).unwrap_or(u32::MAX);
    Ok(1 + postcard::experimental::serialized_size(&len)? + body)
}

/// True when `text` holds a C0 or C1 control character or DEL (what `char::is_control` means),
/// found on the UTF-8 bytes: C1 controls are `C2 80`..`C2 9F`. Byte-wise, so the firmware links no
/// Unicode tables.
fn has_control_character(text: &str) -> bool {
    let bytes = text.as_bytes();
    bytes.iter().enumerate().any(|(i, &b)| {
        b < 0x20
            || b == 0x7f
            || (b == 0xc2
                && bytes
                    .get(i + 1)
                    .is_some_and(|&n| (0x80..=0x9f).contains(&n)))
    })
}
