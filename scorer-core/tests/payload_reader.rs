//! The model payloads are read by hand (no serde deserialiser in the firmware image); this pins
//! that `decode_blob` accepts and refuses exactly what reading the kind's struct with postcard
//! through its serde `Deserialize` impl does, error for error: on every shipped model and the
//! worked example (all four kinds), on every truncation and byte flip of their payloads (header
//! length and CRC kept correct, so the payload itself is at fault), and on random payloads.
//!
//! One deliberate difference: a length varint (of a byte string or a sequence) is read as a `u32`
//! varint on every target, as postcard reads a `usize` on the 32-bit ECU; postcard on the 64-bit
//! host would also take 6..=10-byte ones. Pinned by `length_varints_are_u32_wide_on_every_target`.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod example_blob;

use proptest::prelude::*;

use scorer_core::gssm::GssmModel;
use scorer_core::mlp::{FloatMlp, QuantMlp};
use scorer_core::model::{
    self, Model, ModelBlob, ModelError, ModelKind, ModelMeta, HEADER_LEN, MODEL_ONLY_VERSION,
};
use scorer_core::msra::MsraModel;

/// `decode_blob` after the header and CRC checks, with the model read through serde.
fn decode_with_serde(blob: &[u8]) -> Result<ModelBlob<'_>, ModelError> {
    fn take<'a, T: serde::Deserialize<'a>>(
        body: &'a [u8],
        wrap: fn(T) -> Model<'a>,
    ) -> Result<(Model<'a>, &'a [u8]), ModelError> {
        let (m, rest) = postcard::take_from_bytes::<T>(body)?;
        Ok((wrap(m), rest))
    }
    let header = model::decode_header(blob)?;
    let body = &blob[HEADER_LEN..];
    let (model, rest) = match header.kind {
        ModelKind::DrlInt8 => take::<QuantMlp>(body, Model::DrlInt8),
        ModelKind::DrlF32 => take::<FloatMlp>(body, Model::DrlF32),
        ModelKind::Msra => take::<MsraModel>(body, Model::Msra),
        ModelKind::Gssm => take::<GssmModel>(body, Model::Gssm),
    }?;
    let meta = if header.version == MODEL_ONLY_VERSION {
        if !rest.is_empty() {
            return Err(ModelError::TrailingBytes { extra: rest.len() });
        }
        ModelMeta::default()
    } else {
        ModelMeta::decode(rest)?
    };
    model.validate()?;
    Ok(ModelBlob { model, meta })
}

/// `header` (version, kind, schema) around `payload`, with its length and CRC.
fn with_payload(header: &[u8], payload: &[u8]) -> Vec<u8> {
    let mut blob = header[..HEADER_LEN].to_vec();
    blob[12..16].copy_from_slice(&(payload.len() as u32).to_le_bytes());
    blob[16..20].copy_from_slice(&scorer_core::crc::crc32(payload).to_le_bytes());
    blob.extend_from_slice(payload);
    blob
}

fn assert_same(blob: &[u8]) {
    let ours = model::decode_blob(blob);
    let serde = decode_with_serde(blob);
    // The one deliberate difference (module doc): a length varint wider than a u32 is a bad
    // varint here, as on the 32-bit ECU; the 64-bit host's postcard reads it as a usize (and then
    // usually runs out of bytes).
    // Such a varint has at least four continuation bytes in a row; any other disagreement fails.
    let wide_varint = blob[HEADER_LEN..]
        .windows(4)
        .any(|w| w.iter().all(|b| b & 0x80 != 0));
    if wide_varint
        && ours == Err(ModelError::Payload(postcard::Error::DeserializeBadVarint))
        && serde != ours
    {
        return;
    }
    assert_eq!(ours, serde, "payload {:02x?}", &blob[HEADER_LEN..]);
}

/// The shipped models (DRL int8, GSSM, SSRA, MSRA with and without GSSM) and the worked example
/// (DRL f32).
fn sample_blobs() -> Vec<Vec<u8>> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../models");
    let mut blobs: Vec<Vec<u8>> = [
        "drl-default.rsk",
        "gssm-default.rsk",
        "ssra-default.rsk",
        "msra-default.rsk",
        "msra-gssm.rsk",
    ]
    .iter()
    .map(|name| std::fs::read(format!("{dir}/{name}")).unwrap())
    .collect();
    blobs.push(example_blob::encode(&example_model_blob()));
    blobs
}

fn example_model_blob() -> ModelBlob<'static> {
    ModelBlob::from(example_blob::example_model())
}

#[test]
fn every_kind_decodes_alike() {
    let mut kinds = Vec::new();
    for blob in sample_blobs() {
        let decoded = model::decode_blob(&blob).unwrap();
        kinds.push(decoded.model.kind());
        assert_same(&blob);
    }
    for kind in [
        ModelKind::DrlInt8,
        ModelKind::DrlF32,
        ModelKind::Msra,
        ModelKind::Gssm,
    ] {
        assert!(kinds.contains(&kind), "{kind:?} not sampled");
    }
}

#[test]
fn every_truncation_and_byte_flip_of_a_payload_decodes_alike() {
    for blob in sample_blobs() {
        let payload = &blob[HEADER_LEN..];
        for len in 0..payload.len() {
            assert_same(&with_payload(&blob, &payload[..len]));
        }
        for i in 0..payload.len() {
            for value in [0x00, 0x01, 0x02, 0x03, 0x04, 0x0d, 0x7f, 0x80, 0xff] {
                let mut flipped = payload.to_vec();
                flipped[i] = value;
                assert_same(&with_payload(&blob, &flipped));
            }
        }
    }
}

proptest! {
    #[test]
    fn random_payloads_decode_alike(
        which in 0usize..6,
        payload in proptest::collection::vec(any::<u8>(), 0..96),
    ) {
        let blob = &sample_blobs()[which];
        assert_same(&with_payload(blob, &payload));
    }
}

/// The DRL blob with its first length varint (the `inputs` count, payload byte 0) written in
/// `bytes` non-canonical bytes: `count | 0x80`, `0x80` continuations, a final `0x00`.
fn with_long_inputs_count(bytes: usize) -> Vec<u8> {
    let blob = &sample_blobs()[0];
    let payload = &blob[HEADER_LEN..];
    assert!(payload[0] < 0x80, "a one-byte count");
    let mut varint = vec![payload[0] | 0x80];
    varint.resize(bytes - 1, 0x80);
    varint.push(0x00);
    let mut long = varint;
    long.extend_from_slice(&payload[1..]);
    with_payload(blob, &long)
}

#[test]
fn length_varints_are_u32_wide_on_every_target() {
    // 5 bytes (the most a u32 takes): accepted, as on the ECU, where postcard's usize is 32 bits.
    let five = with_long_inputs_count(5);
    assert!(model::decode_blob(&five).is_ok());
    // 6 bytes: the 32-bit ECU refuses it, so the host does too (postcard on a 64-bit host would
    // accept it as a usize).
    let six = with_long_inputs_count(6);
    assert_eq!(
        model::decode_blob(&six),
        Err(ModelError::Payload(postcard::Error::DeserializeBadVarint))
    );
    // So does a 5-byte one carrying bits beyond 32.
    let mut wide = with_long_inputs_count(5);
    wide[HEADER_LEN + 4] = 0x10;
    let payload = wide[HEADER_LEN..].to_vec();
    let wide = with_payload(&wide, &payload);
    assert_eq!(
        model::decode_blob(&wide),
        Err(ModelError::Payload(postcard::Error::DeserializeBadVarint))
    );
}
