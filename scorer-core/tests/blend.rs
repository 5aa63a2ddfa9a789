//! The blend policy and its record (tag 5): the record's bytes as docs/model-format.md gives
//! them, its round trip and every way it is refused, the score inside (the model's share plus the
//! rest of the kinematic fallback, bit for bit) and outside (the fallback alone), and the two
//! entry points agreeing bit for bit.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod example_blob;

use example_blob::{
    assert_truncations_refused_and_flips_handled, blob_with_records, encode, example_domain,
    example_model, following_pair, hex, tadv_term,
};

use scorer_core::model::kinematic_fallback::term_to_bytes;
use scorer_core::model::{
    self, Blend, KinematicFallback, ModelBlob, ModelError, ModelMeta, OutsidePolicy, BLEND_TAG,
};
use scorer_core::Observation;

/// The documented example's fallback: one TAdv term, `2 * R - 0.5`.
fn example_fallback() -> KinematicFallback<'static> {
    let bytes: Vec<u8> = term_to_bytes(&tadv_term()).to_vec();
    KinematicFallback::new(2.0, -0.5, Vec::leak(bytes))
}

fn blend_blob(network_weight: f32) -> ModelBlob<'static> {
    ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            training_domain: Some(example_domain(OutsidePolicy::Blend)),
            kinematic_fallback: Some(example_fallback()),
            blend: Some(Blend { network_weight }),
            ..ModelMeta::default()
        },
    }
}

fn record<T: serde::Serialize>(tag: u8, value: &T) -> Vec<u8> {
    let mut buf = [0u8; 256];
    let body = postcard::to_slice(value, &mut buf).unwrap();
    let mut r = vec![tag, body.len() as u8];
    r.extend_from_slice(body);
    r
}

#[test]
fn the_worked_example_ends_in_the_documented_records() {
    let blob = encode(&blend_blob(0.7));
    let text = hex(&blob);
    // Tag 2 with policy byte 3 (blend), tag 3, then tag 5 closes the records: 4 body bytes,
    // 0.7f32.
    let records = [
        record(2, &example_domain(OutsidePolicy::Blend)),
        record(3, &example_fallback()),
        hex_bytes("05043333333f"),
    ]
    .concat();
    assert_eq!(&records[..3], [2, 0x14, 3]);
    assert!(text.ends_with(&hex(&records)), "{text}");
    // A reader names the policies it knows when a newer exporter wrote another.
    let msg = ModelError::UnknownOutsidePolicy(4).to_string();
    assert!(msg.contains("3 blend"), "{msg}");
    let mut buf = [0u8; 4];
    assert_eq!(
        postcard::to_slice(&OutsidePolicy::Blend, &mut buf).unwrap(),
        [3]
    );
    assert_eq!(
        OutsidePolicy::from_name("blend"),
        Some(OutsidePolicy::Blend)
    );
    assert_eq!(model::decode_blob(&blob).unwrap(), blend_blob(0.7));
}

fn hex_bytes(text: &str) -> Vec<u8> {
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&text[i..i + 2], 16).unwrap())
        .collect()
}

#[test]
fn the_records_read_alike_in_any_order() {
    let (domain, fallback) = (
        record(2, &example_domain(OutsidePolicy::Blend)),
        record(3, &example_fallback()),
    );
    let blend = record(
        BLEND_TAG,
        &Blend {
            network_weight: 0.7,
        },
    );
    let expected = blend_blob(0.7).meta;
    for order in [
        [&blend, &domain, &fallback],
        [&fallback, &blend, &domain],
        [&domain, &blend, &fallback],
    ] {
        let bytes = blob_with_records(&order.map(|r| r.as_slice()).concat());
        assert_eq!(model::decode_blob(&bytes).unwrap().meta, expected);
    }
}

#[test]
fn bad_records_are_refused() {
    let decode = |records: &[u8]| model::decode_blob(&blob_with_records(records)).map(|_| ());
    let domain = |policy| record(2, &example_domain(policy));
    let fallback = record(3, &example_fallback());
    let blend = |w: f32| record(BLEND_TAG, &Blend { network_weight: w });
    let bad = |field: &'static str| move |r: Result<(), ModelError>| matches!(r, Err(ModelError::BadRecord { field: f, .. }) if f == field);
    let good = [domain(OutsidePolicy::Blend), fallback.clone(), blend(0.7)].concat();
    assert_eq!(decode(&good), Ok(()));
    // The policy without its blend record, or without its fallback record.
    let no_blend = [domain(OutsidePolicy::Blend), fallback.clone()].concat();
    assert!(bad("training_domain.policy")(decode(&no_blend)));
    let no_fallback = [domain(OutsidePolicy::Blend), blend(0.7)].concat();
    assert!(bad("training_domain.policy")(decode(&no_fallback)));
    // A blend record under another policy, or with no domain at all.
    let under_fallback = [
        domain(OutsidePolicy::Fallback),
        fallback.clone(),
        blend(0.7),
    ]
    .concat();
    assert!(bad("blend")(decode(&under_fallback)));
    assert!(bad("blend")(decode(&blend(0.7))));
    // Weights at or beyond the ends, not a number.
    for w in [0.0, 1.0, -0.5, 1.5, f32::NAN, f32::INFINITY] {
        let records = [domain(OutsidePolicy::Blend), fallback.clone(), blend(w)].concat();
        assert!(bad("blend.network_weight")(decode(&records)), "{w}");
    }
    // Twice; a padded body; a body cut short.
    let twice = [good.clone(), blend(0.7)].concat();
    assert_eq!(
        decode(&twice),
        Err(ModelError::DuplicateRecord { tag: BLEND_TAG })
    );
    let mut padded = good.clone();
    let at = padded.len() - 5;
    padded[at] += 1;
    padded.push(0);
    assert_eq!(decode(&padded), Err(ModelError::TrailingBytes { extra: 1 }));
    let mut cut = good.clone();
    cut[at] -= 1;
    cut.pop();
    assert!(decode(&cut).is_err());
    // The encoder refuses what the decoder would.
    let mut out = vec![0u8; 512];
    assert!(matches!(
        model::encode_blob(&blend_blob(1.0), &mut out),
        Err(ModelError::BadRecord { .. })
    ));
}

#[test]
fn every_truncation_and_byte_flip_of_a_blend_blob_is_handled() {
    assert_truncations_refused_and_flips_handled(&encode(&blend_blob(0.7)));
}

#[test]
fn inside_mixes_the_model_with_the_fallback_and_outside_scores_the_fallback() {
    let w = 0.7f32;
    let bytes = encode(&blend_blob(w));
    let blob = model::decode_blob(&bytes).unwrap();
    let fallback = example_fallback();
    let (mut inside, mut outside) = (0, 0);
    for (speed, gap, closing) in [
        (20.0, 3.0, 5.0),
        (30.0, 40.0, 2.0),
        (15.0, 1.0, 0.0),
        (45.0, 30.0, 15.0),
        (38.0, 150.0, 10.0),
        (44.0, 5.0, 20.0),
    ] {
        let (ego, partner) = following_pair(speed, gap, closing);
        let o = Observation::of(&ego, &partner);
        let g = blob.score_guarded(&o);
        let kinematic = fallback.score(&o.surrogates);
        let expected = if g.in_domain {
            inside += 1;
            w * blob.model.score_observation(&o) + (1.0 - w) * kinematic
        } else {
            outside += 1;
            kinematic
        };
        assert_eq!(g.score.to_bits(), expected.to_bits(), "{speed} {gap}");
        // The ECU's entry point gives the same bits.
        assert_eq!(blob.score_pair_guarded(&ego, &partner), g, "{speed} {gap}");
    }
    assert!(
        inside >= 2 && outside >= 2,
        "{inside} inside, {outside} outside"
    );
}
