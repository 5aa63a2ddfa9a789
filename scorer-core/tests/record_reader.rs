//! The metadata records are read by hand (no serde deserialiser in the firmware image); this pins
//! that `ModelMeta::decode` accepts and refuses exactly what reading each record body with
//! postcard through the types' serde `Deserialize` impls does, error for error: on valid record
//! streams, on every truncation and byte flip of them, and on random bytes; except that a length
//! varint is read `u32`-wide on every target (tests/payload_reader.rs).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod example_blob;

use proptest::prelude::*;

use scorer_core::model::kinematic_fallback::term_to_bytes;
use scorer_core::model::meta::DEFAULT_THRESHOLD_TAG;
use scorer_core::model::{
    Blend, DefaultThreshold, InputRange, KinematicFallback, ModelError, ModelMeta, OutsidePolicy,
    ThresholdRule, TrainingDomain, BLEND_TAG, KINEMATIC_FALLBACK_TAG,
};

/// The record loop as it read the bodies through serde.
fn decode_with_serde(mut bytes: &[u8]) -> Result<ModelMeta<'_>, ModelError> {
    fn take<'a, T: serde::Deserialize<'a>>(
        tag: u8,
        body: &'a [u8],
        earlier: &Option<T>,
    ) -> Result<T, ModelError> {
        if earlier.is_some() {
            return Err(ModelError::DuplicateRecord { tag });
        }
        let (value, extra) = postcard::take_from_bytes::<T>(body)?;
        if !extra.is_empty() {
            return Err(ModelError::TrailingBytes { extra: extra.len() });
        }
        Ok(value)
    }
    let mut meta = ModelMeta::default();
    while let Some((&tag, rest)) = bytes.split_first() {
        let (len, rest) = postcard::take_from_bytes::<u32>(rest)?;
        let len = usize::try_from(len).unwrap_or(usize::MAX);
        let (body, rest) = rest.split_at_checked(len).ok_or(ModelError::Truncated {
            needed: len,
            available: rest.len(),
        })?;
        match tag {
            1 => meta.default_threshold = Some(take(tag, body, &meta.default_threshold)?),
            2 => {
                if let Some(&byte) = body.first() {
                    if OutsidePolicy::from_wire(byte).is_none() {
                        return Err(ModelError::UnknownOutsidePolicy(byte));
                    }
                }
                meta.training_domain = Some(take(tag, body, &meta.training_domain)?);
            }
            3 => meta.kinematic_fallback = Some(take(tag, body, &meta.kinematic_fallback)?),
            5 => meta.blend = Some(take(tag, body, &meta.blend)?),
            _ => {}
        }
        bytes = rest;
    }
    meta.validate()?;
    Ok(meta)
}

fn assert_same(bytes: &[u8]) {
    let ours = ModelMeta::decode(bytes);
    let serde = decode_with_serde(bytes);
    // The one deliberate difference: a length varint inside a body (`&[u8]`, sequences) wider
    // than a u32 is a bad varint here, as on the 32-bit ECU; the 64-bit host's postcard reads it
    // as a usize (tests/payload_reader.rs pins it).
    // Such a varint has at least four continuation bytes in a row; any other disagreement fails.
    let wide_varint = bytes.windows(4).any(|w| w.iter().all(|b| b & 0x80 != 0));
    if wide_varint
        && ours == Err(ModelError::Payload(postcard::Error::DeserializeBadVarint))
        && serde != ours
    {
        return;
    }
    assert_eq!(ours, serde, "records {bytes:02x?}");
}

fn record(tag: u8, body: &[u8]) -> Vec<u8> {
    let mut out = vec![tag];
    let mut len = [0u8; 5];
    out.extend_from_slice(postcard::to_slice(&(body.len() as u32), &mut len).unwrap());
    out.extend_from_slice(body);
    out
}

fn body<T: serde::Serialize>(value: &T) -> Vec<u8> {
    let mut buf = [0u8; 256];
    postcard::to_slice(value, &mut buf).unwrap().to_vec()
}

/// Valid streams of every record (both threshold rules, every policy).
fn valid_streams() -> Vec<Vec<u8>> {
    let ranges: Vec<u8> = [(3u8, 0.0f32, 40.0f32), (8, -0.75, 5.0)]
        .iter()
        .flat_map(|&(input, lo, hi)| InputRange { input, lo, hi }.to_bytes())
        .collect();
    let terms = term_to_bytes(&example_blob::tadv_term());
    let fallback = record(
        KINEMATIC_FALLBACK_TAG,
        &body(&KinematicFallback::new(2.0, 0.5, &terms)),
    );
    let threshold = |rule| {
        record(
            DEFAULT_THRESHOLD_TAG,
            &body(&DefaultThreshold {
                threshold: 2.5,
                rule,
                data: "ngsim-us101-safe (606 sequences) \u{e9}",
            }),
        )
    };
    let mut streams = Vec::new();
    for policy in OutsidePolicy::ALL {
        let mut s = threshold(ThresholdRule::SafeShare {
            target: 0.05,
            measured: 0.0495,
            sequences: 606,
        });
        s.extend(record(2, &body(&TrainingDomain::new(policy, &ranges))));
        if policy.uses_fallback() {
            s.extend(&fallback);
        }
        if policy == OutsidePolicy::Blend {
            s.extend(record(
                BLEND_TAG,
                &body(&Blend {
                    network_weight: 0.7,
                }),
            ));
        }
        streams.push(s);
    }
    streams.push(threshold(ThresholdRule::KindDefault));
    streams
}

#[test]
fn valid_records_decode_alike() {
    for s in valid_streams() {
        assert!(ModelMeta::decode(&s).is_ok());
        assert_same(&s);
    }
}

#[test]
fn every_truncation_and_byte_flip_decodes_alike() {
    for s in valid_streams() {
        for len in 0..s.len() {
            assert_same(&s[..len]);
        }
        for i in 0..s.len() {
            for value in [0x00, 0x01, 0x02, 0x03, 0x0f, 0x10, 0x7f, 0x80, 0xc0, 0xff] {
                let mut flipped = s.clone();
                flipped[i] = value;
                assert_same(&flipped);
            }
        }
    }
}

#[test]
fn long_and_overlong_varints_are_refused_alike() {
    // Record lengths and byte-string lengths of 5 and more varint bytes (the 5th byte of a u32
    // may carry 4 bits; postcard's usize on a 64-bit host takes up to 10).
    for last in [0x00, 0x01, 0x0f, 0x10, 0x7f, 0x80] {
        assert_same(&[1, 0x80, 0x80, 0x80, 0x80, last]);
        let mut domain = vec![
            2, 12, 0, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80,
        ];
        domain.push(last);
        assert_same(&domain);
    }
}

proptest! {
    #[test]
    fn random_record_bytes_decode_alike(
        tag in 1u8..=3,
        body in proptest::collection::vec(any::<u8>(), 0..64),
    ) {
        assert_same(&record(tag, &body));
    }

    #[test]
    fn random_streams_decode_alike(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
        assert_same(&bytes);
    }
}
