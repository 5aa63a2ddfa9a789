//! Version-2 blobs: the metadata records after the model (the default warning threshold), their
//! byte layout as docs/model-format.md gives it, and every way they are refused.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod example_blob;

use example_blob::{
    assert_truncations_refused_and_flips_handled, blob_with_records, encode, example_model,
};

use scorer_core::model::{self, DefaultThreshold, ModelBlob, ModelError, ModelMeta, ThresholdRule};

fn calibrated(threshold: f32) -> DefaultThreshold<'static> {
    DefaultThreshold {
        threshold,
        rule: ThresholdRule::SafeShare {
            target: 0.05,
            measured: 0.0495,
            sequences: 606,
        },
        data: "ngsim-us101-safe (606 sequences)",
    }
}

fn threshold_record(op: &DefaultThreshold<'_>) -> Vec<u8> {
    let mut buf = [0u8; 256];
    let body = postcard::to_slice(op, &mut buf).unwrap();
    let mut record = vec![model::meta::DEFAULT_THRESHOLD_TAG, body.len() as u8];
    record.extend_from_slice(body);
    record
}

#[test]
fn a_blob_without_metadata_is_version_1_and_uses_the_kind_rule() {
    let blob = encode(&ModelBlob {
        model: example_model(),
        meta: ModelMeta::default(),
    });
    assert_eq!(&blob[4..6], &[1, 0]);
    let decoded = model::decode_blob(&blob).unwrap();
    assert!(decoded.meta.is_empty());
    assert_eq!(decoded.default_threshold(), 2.0);
    // The plain encoder writes the same bytes.
    let mut plain = vec![0u8; model::encoded_len(&example_model()).unwrap()];
    model::encode(&example_model(), &mut plain).unwrap();
    assert_eq!(plain, blob);
}

#[test]
fn the_default_threshold_round_trips_in_a_version_2_blob() {
    let original = ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            default_threshold: Some(calibrated(2.5)),
            training_domain: None,
            kinematic_fallback: None,
            blend: None,
        },
    };
    let blob = encode(&original);
    assert_eq!(&blob[4..6], &[2, 0]);
    let back = model::decode_blob(&blob).unwrap();
    assert_eq!(back, original);
    assert_eq!(back.default_threshold(), 2.5);
    // The model alone decodes as before, and scores the same.
    assert_eq!(model::decode(&blob).unwrap(), example_model());
}

#[test]
fn the_record_bytes_are_the_documented_ones() {
    let blob = encode(&ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            default_threshold: Some(calibrated(2.5)),
            training_domain: None,
            kinematic_fallback: None,
            blend: None,
        },
    });
    let model_len = model::encoded_len(&example_model()).unwrap();
    let record = &blob[model_len..];
    let mut expected = vec![0x01, 0x30, 0x00, 0x00, 0x20, 0x40, 0x01];
    expected.extend_from_slice(&0.05f32.to_le_bytes());
    expected.extend_from_slice(&0.0495f32.to_le_bytes());
    expected.extend_from_slice(&[0xde, 0x04, 0x20]);
    expected.extend_from_slice(b"ngsim-us101-safe (606 sequences)");
    assert_eq!(record, expected.as_slice());
}

#[test]
fn unknown_records_are_skipped() {
    let mut records = vec![9, 3, 0xaa, 0xbb, 0xcc];
    records.extend(threshold_record(&calibrated(3.0)));
    records.extend([200, 0]);
    let blob = blob_with_records(&records);
    assert_eq!(model::decode_blob(&blob).unwrap().default_threshold(), 3.0);
}

#[test]
fn bad_records_are_refused() {
    let good = threshold_record(&calibrated(3.0));
    // Twice.
    let twice = [good.clone(), good.clone()].concat();
    assert_eq!(
        model::decode_blob(&blob_with_records(&twice)),
        Err(ModelError::DuplicateRecord { tag: 1 })
    );
    // A length past the end.
    let mut long = good.clone();
    long[1] += 1;
    // Record-relative sizes (docs/model-format.md, step 5): the declared body, the bytes after the
    // one-byte length varint.
    assert_eq!(
        model::decode_blob(&blob_with_records(&long)),
        Err(ModelError::Truncated {
            needed: usize::from(long[1]),
            available: long.len() - 2,
        })
    );
    // A body longer than the struct.
    let mut padded = good.clone();
    padded[1] += 1;
    padded.push(0);
    assert_eq!(
        model::decode_blob(&blob_with_records(&padded)),
        Err(ModelError::TrailingBytes { extra: 1 })
    );
    // A non-finite threshold and a share outside [0, 1].
    let nan = threshold_record(&calibrated(f32::NAN));
    assert!(matches!(
        model::decode_blob(&blob_with_records(&nan)),
        Err(ModelError::NonFinite { .. })
    ));
    let mut share = calibrated(1.0);
    share.rule = ThresholdRule::SafeShare {
        target: 1.5,
        measured: 0.0,
        sequences: 1,
    };
    assert!(matches!(
        model::decode_blob(&blob_with_records(&threshold_record(&share))),
        Err(ModelError::BadRecord { .. })
    ));
    // A rule that contradicts itself (more warn than it allows) and a description that would
    // forge terminal output are refused.
    let mut over = calibrated(1.0);
    over.rule = ThresholdRule::SafeShare {
        target: 0.01,
        measured: 0.9,
        sequences: 100,
    };
    assert!(matches!(
        model::decode_blob(&blob_with_records(&threshold_record(&over))),
        Err(ModelError::BadRecord { .. })
    ));
    for forged in [
        "x\u{1b}]0;title\u{7}",
        "a\nintegrity OK",
        "csi\u{9b}2J",
        "del\u{7f}",
    ] {
        let mut escape = calibrated(1.0);
        escape.data = forged;
        assert!(
            matches!(
                model::decode_blob(&blob_with_records(&threshold_record(&escape))),
                Err(ModelError::BadRecord { .. })
            ),
            "{forged:?}"
        );
    }
    // Text that merely is not ASCII is fine.
    let mut accented = calibrated(1.0);
    accented.data = "Lankershim \u{e9}t\u{e9} \u{a0}\u{2014} 5 %";
    assert!(model::decode_blob(&blob_with_records(&threshold_record(&accented))).is_ok());
    // The encoder refuses what the decoder would.
    let bad = ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            default_threshold: Some(calibrated(f32::INFINITY)),
            training_domain: None,
            kinematic_fallback: None,
            blend: None,
        },
    };
    let mut out = vec![0u8; 256];
    assert!(model::encode_blob(&bad, &mut out).is_err());
    let mut long_data = calibrated(1.0);
    let text = "x".repeat(model::meta::MAX_DATA_DESCRIPTION + 1);
    long_data.data = &text;
    let bad = ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            default_threshold: Some(long_data),
            training_domain: None,
            kinematic_fallback: None,
            blend: None,
        },
    };
    assert!(matches!(
        model::encode_blob(&bad, &mut out),
        Err(ModelError::CapacityExceeded { .. })
    ));
}

#[test]
fn a_version_1_blob_with_records_is_refused() {
    let mut blob = blob_with_records(&threshold_record(&calibrated(3.0)));
    blob[4] = 1;
    assert!(matches!(
        model::decode_blob(&blob),
        Err(ModelError::TrailingBytes { .. })
    ));
}

#[test]
fn every_truncation_and_byte_flip_of_a_version_2_blob_is_handled() {
    let blob = encode(&ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            default_threshold: Some(calibrated(2.5)),
            training_domain: None,
            kinematic_fallback: None,
            blend: None,
        },
    });
    assert_truncations_refused_and_flips_handled(&blob);
}
