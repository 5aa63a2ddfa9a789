//! The model payloads are read by hand (no serde deserialiser in the firmware image); this pins
//! that `decode_blob` accepts and refuses exactly what reading the kind's struct with postcard
//! through its serde `Deserialize` impl does, error for error: on every shipped model and the
//! worked example (all four kinds), on every truncation and byte flip of their payloads (header
//! length and CRC kept correct, so the payload itself is at fault), and on random payloads.
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
    assert_eq!(
        model::decode_blob(blob),
        decode_with_serde(blob),
        "payload {:02x?}",
        &blob[HEADER_LEN..]
    );
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
