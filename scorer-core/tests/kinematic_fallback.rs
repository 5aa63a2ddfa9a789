//! The fallback policy and its kinematic-fallback record (tag 3): the record's bytes as
//! docs/model-format.md gives them, its round trip and every way it is refused, the score outside
//! (the kinematic MSRA on the model's scale) and inside (the model's, bit for bit), and the two
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
    self, BoundedVec, KinematicFallback, ModelBlob, ModelError, ModelMeta, OutsidePolicy,
};
use scorer_core::msra::{MsraModel, MsraTerm};
use scorer_core::{Observation, SurrogateKind};

fn ei_term() -> MsraTerm {
    MsraTerm {
        kind: SurrogateKind::Ei,
        weight: 0.5,
        a: 2.0,
        b: -1.0,
        lo: -4.0,
        hi: 4.0,
    }
}

fn fallback_of(scale: f32, offset: f32, terms: &[MsraTerm]) -> KinematicFallback<'static> {
    let bytes: Vec<u8> = terms.iter().flat_map(term_to_bytes).collect();
    KinematicFallback::new(scale, offset, Vec::leak(bytes))
}

/// The documented example: one TAdv term, `2 * R - 0.5`.
fn example_fallback() -> KinematicFallback<'static> {
    fallback_of(2.0, -0.5, &[tadv_term()])
}

fn fallback_blob(fallback: KinematicFallback<'static>) -> ModelBlob<'static> {
    ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            training_domain: Some(example_domain(OutsidePolicy::Fallback)),
            kinematic_fallback: Some(fallback),
            ..ModelMeta::default()
        },
    }
}

fn record(tag: u8, body: &[u8]) -> Vec<u8> {
    let mut r = vec![tag, body.len() as u8];
    r.extend_from_slice(body);
    r
}

fn domain_record(policy: OutsidePolicy) -> Vec<u8> {
    let mut buf = [0u8; 256];
    record(
        2,
        postcard::to_slice(&example_domain(policy), &mut buf).unwrap(),
    )
}

fn fallback_record(fallback: &KinematicFallback) -> Vec<u8> {
    let mut buf = [0u8; 256];
    record(3, postcard::to_slice(fallback, &mut buf).unwrap())
}

/// docs/model-format.md: what the example scores for the pair 400 m apart at 45 m/s.
const DOCUMENTED_OUTSIDE_SCORE: f32 = -0.499_329_3;

#[test]
fn the_worked_example_is_byte_for_byte_the_documented_one() {
    let blob = encode(&fallback_blob(example_fallback()));
    assert_eq!(
        hex(&blob),
        concat!(
            "52534b4d",
            "0200",
            "02",
            "00",
            "0300",
            "0000",
            "4f000000",
            "bb0a61ec",
            // The model, as in the version-1 example.
            "0108",
            "01cdcccc3d",
            "01000080bf",
            "01",
            "01",
            "00",
            "04000080bf",
            "040000003f",
            // Tag 2 as in the training-domain example, policy byte 2 (fallback).
            "02",
            "14",
            "02",
            "12",
            "03",
            "00000000",
            "00002042",
            "08",
            "000040bf",
            "0000a040",
            // Tag 3: 30 body bytes: scale 2.0, offset -0.5, 21 term bytes (one term).
            "03",
            "1e",
            "00000040",
            "000000bf",
            "15",
            // TAdv (1): w 1.0, a -1.0, b 2.0, lo 0.0, hi 10.0.
            "01",
            "0000803f",
            "000080bf",
            "00000040",
            "00000000",
            "00002041",
        )
    );
    // The documented pair: 400 m apart at 45 m/s, outside (ego speed), scores the fallback.
    let decoded = model::decode_blob(&blob).unwrap();
    let (ego, partner) = following_pair(45.0, 400.0, 0.0);
    let g = decoded.score_pair_guarded(&ego, &partner);
    assert_eq!(g.first_outside, Some(3));
    assert!((g.score - DOCUMENTED_OUTSIDE_SCORE).abs() < 1e-6, "{g:?}");
    // The policy's wire index is pinned, and every name parses back.
    let mut buf = [0u8; 4];
    assert_eq!(
        postcard::to_slice(&OutsidePolicy::Fallback, &mut buf).unwrap(),
        [2]
    );
    for p in OutsidePolicy::ALL {
        assert_eq!(OutsidePolicy::from_name(p.name()), Some(p));
    }
}

#[test]
fn the_record_round_trips_with_a_threshold_and_in_either_record_order() {
    let original = fallback_blob(fallback_of(0.75, 1.25, &[tadv_term(), ei_term()]));
    assert_eq!(model::decode_blob(&encode(&original)).unwrap(), original);
    let mut with_threshold = original.clone();
    with_threshold.meta.default_threshold = Some(model::DefaultThreshold {
        threshold: 1.5,
        rule: model::ThresholdRule::KindDefault,
        data: "",
    });
    assert_eq!(
        model::decode_blob(&encode(&with_threshold)).unwrap(),
        with_threshold
    );
    // Tag 3 before tag 2 reads the same (records are checked against each other at the end).
    let fallback = example_fallback();
    let swapped = [
        fallback_record(&fallback),
        domain_record(OutsidePolicy::Fallback),
    ]
    .concat();
    let bytes = blob_with_records(&swapped);
    let blob = model::decode_blob(&bytes).unwrap();
    assert_eq!(blob.meta.kinematic_fallback, Some(fallback));
}

#[test]
fn bad_records_are_refused() {
    let decode = |records: &[u8]| model::decode_blob(&blob_with_records(records)).map(|_| ());
    let domain = domain_record(OutsidePolicy::Fallback);
    let with_fallback = |fb: &KinematicFallback| [domain.clone(), fallback_record(fb)].concat();
    // Policy without record, record without the policy.
    assert!(matches!(
        decode(&domain),
        Err(ModelError::BadRecord {
            field: "training_domain.policy",
            ..
        })
    ));
    for policy in [OutsidePolicy::FlagOnly, OutsidePolicy::Clamp] {
        let records = [domain_record(policy), fallback_record(&example_fallback())].concat();
        assert!(matches!(
            decode(&records),
            Err(ModelError::BadRecord {
                field: "kinematic_fallback",
                ..
            })
        ));
    }
    assert!(matches!(
        decode(&fallback_record(&example_fallback())),
        Err(ModelError::BadRecord { .. })
    ));
    // A GSSM term, an unknown surrogate byte, bad term parameters.
    let gssm = MsraTerm {
        kind: SurrogateKind::Gssm,
        ..tadv_term()
    };
    assert_eq!(
        decode(&with_fallback(&fallback_of(1.0, 0.0, &[tadv_term(), gssm]))),
        Err(ModelError::BadFallbackTerm {
            term: 1,
            reason: "GSSM is not a kinematic surrogate"
        })
    );
    let mut unknown = term_to_bytes(&tadv_term()).to_vec();
    unknown[0] = 5;
    let unknown = KinematicFallback::new(1.0, 0.0, Vec::leak(unknown));
    assert!(matches!(
        decode(&with_fallback(&unknown)),
        Err(ModelError::BadFallbackTerm { term: 0, .. })
    ));
    for bad in [
        MsraTerm {
            lo: 10.0,
            ..tadv_term()
        },
        MsraTerm {
            weight: f32::NAN,
            ..tadv_term()
        },
        MsraTerm {
            a: 2e9,
            ..tadv_term()
        },
    ] {
        assert!(matches!(
            decode(&with_fallback(&fallback_of(1.0, 0.0, &[ei_term(), bad]))),
            Err(ModelError::BadFallbackTerm { term: 1, .. })
        ));
    }
    // Scale and offset.
    for scale in [0.0, -1.0] {
        assert!(matches!(
            decode(&with_fallback(&fallback_of(scale, 0.0, &[tadv_term()]))),
            Err(ModelError::NonPositiveScale { .. })
        ));
    }
    for (scale, offset) in [(f32::NAN, 0.0), (f32::INFINITY, 0.0), (1.0, f32::NAN)] {
        assert!(matches!(
            decode(&with_fallback(&fallback_of(scale, offset, &[tadv_term()]))),
            Err(ModelError::NonFinite { .. })
        ));
    }
    // No term, five terms, a term cut short, the record twice.
    assert!(matches!(
        decode(&with_fallback(&fallback_of(1.0, 0.0, &[]))),
        Err(ModelError::Empty { .. })
    ));
    assert!(matches!(
        decode(&with_fallback(&fallback_of(1.0, 0.0, &[tadv_term(); 5]))),
        Err(ModelError::CapacityExceeded { .. })
    ));
    let cut = KinematicFallback::new(1.0, 0.0, &example_fallback().term_bytes[..20]);
    assert!(matches!(
        decode(&with_fallback(&cut)),
        Err(ModelError::DimensionMismatch { .. })
    ));
    let twice = [
        with_fallback(&example_fallback()),
        fallback_record(&example_fallback()),
    ]
    .concat();
    assert_eq!(decode(&twice), Err(ModelError::DuplicateRecord { tag: 3 }));
    // The encoder refuses what the decoder would.
    let mut out = vec![0u8; 512];
    let mut orphan = fallback_blob(example_fallback());
    orphan.meta.training_domain = Some(example_domain(OutsidePolicy::Clamp));
    assert!(matches!(
        model::encode_blob(&orphan, &mut out),
        Err(ModelError::BadRecord { .. })
    ));
}

#[test]
fn every_truncation_and_byte_flip_of_a_fallback_blob_is_handled() {
    assert_truncations_refused_and_flips_handled(&encode(&fallback_blob(fallback_of(
        0.75,
        1.25,
        &[tadv_term(), ei_term()],
    ))));
}

#[test]
fn a_tadv_corridor_term_reads_the_corridor_rule_not_the_reference() {
    let corridor = MsraTerm {
        kind: SurrogateKind::TadvCorridor,
        ..tadv_term()
    };
    let blob = fallback_blob(fallback_of(1.0, 0.0, &[corridor]));
    let bytes = encode(&blob);
    // Wire index 4 in the term's kind byte.
    let decoded = model::decode_blob(&bytes).unwrap();
    assert_eq!(decoded, blob);
    let fallback = decoded.meta.kinematic_fallback.unwrap();
    assert_eq!(
        fallback.terms().next().unwrap().kind,
        SurrogateKind::TadvCorridor
    );
    // A car parked 4 m beside the lane, 20 m ahead of an ego at 15 m/s: the reference TAdv is a
    // near miss, the corridor rule's no conflict, and the term scores what the rule says.
    let ego = scorer_core::VehicleState {
        x: 0.0,
        y: 0.0,
        vx: 15.0,
        vy: 0.0,
        hx: 1.0,
        hy: 0.0,
        acc: 0.0,
        length: 4.5,
        width: 1.8,
    };
    let parked = scorer_core::VehicleState {
        x: 20.0,
        y: 4.0,
        vx: 0.0,
        ..ego
    };
    let o = Observation::of(&ego, &parked);
    assert!(o.surrogates.tadv < 2.0, "{:?}", o.surrogates);
    assert_eq!(o.surrogates.tadv_corridor, f32::INFINITY);
    let by_corridor = fallback.msra(&o.surrogates);
    let reference = fallback_of(1.0, 0.0, &[tadv_term()]).msra(&o.surrogates);
    // Whatever the reference says.
    let other_reference = fallback.msra(&scorer_core::Surrogates {
        tadv: 0.01,
        ..o.surrogates
    });
    assert_eq!(by_corridor.to_bits(), other_reference.to_bits());
    assert_ne!(by_corridor, reference);
}

#[test]
fn outside_scores_the_kinematic_msra_on_the_model_scale_and_inside_the_model() {
    let terms = [tadv_term(), ei_term()];
    let (scale, offset) = (3.0f32, -0.25f32);
    let bytes = encode(&fallback_blob(fallback_of(scale, offset, &terms)));
    let blob = model::decode_blob(&bytes).unwrap();
    // The same terms as an MSRA model: the fallback is that score, scaled and shifted.
    let msra = MsraModel {
        terms: BoundedVec::from_slice(&terms).unwrap(),
        gssm: None,
    };
    let (mut inside, mut outside) = (0, 0);
    for (speed, gap, closing) in [
        (20.0, 3.0, 5.0),
        (30.0, 40.0, 2.0),
        (45.0, 30.0, 15.0),
        (38.0, 150.0, 10.0),
        (10.0, 1e4, 0.0),
        (44.0, 5.0, 20.0),
        (15.0, 1.0, 0.0),
    ] {
        let (ego, partner) = following_pair(speed, gap, closing);
        let o = Observation::of(&ego, &partner);
        let g = blob.score_guarded(&o);
        if g.in_domain {
            inside += 1;
            assert_eq!(
                g.score.to_bits(),
                blob.model.score_observation(&o).to_bits(),
                "{speed} {gap}"
            );
        } else {
            outside += 1;
            let expected = scale * msra.score(&o.features, &o.surrogates) + offset;
            assert_eq!(g.score.to_bits(), expected.to_bits(), "{speed} {gap}");
            assert_ne!(g.score, blob.model.score_observation(&o), "{speed} {gap}");
        }
    }
    assert!(
        inside >= 2 && outside >= 2,
        "{inside} inside, {outside} outside"
    );
    // A closer, faster approach outside scores higher: the map keeps "larger is riskier".
    let far = blob.score_pair_guarded(
        &following_pair(45.0, 60.0, 5.0).0,
        &following_pair(45.0, 60.0, 5.0).1,
    );
    let near = blob.score_pair_guarded(
        &following_pair(45.0, 8.0, 15.0).0,
        &following_pair(45.0, 8.0, 15.0).1,
    );
    assert!(!far.in_domain && !near.in_domain);
    assert!(near.score > far.score, "{near:?} {far:?}");
}

#[test]
fn pair_and_observation_entry_points_agree_bit_for_bit() {
    let bytes = encode(&fallback_blob(fallback_of(
        0.75,
        1.25,
        &[tadv_term(), ei_term()],
    )));
    let blob = model::decode_blob(&bytes).unwrap();
    let mut outside = 0;
    for speed in [0.0, 12.0, 39.0, 41.0, 50.0] {
        for gap in [0.0, 0.5, 3.0, 60.0, 400.0] {
            for closing in [-3.0, 0.0, 8.0, 25.0] {
                let (ego, partner) = following_pair(speed, gap, closing);
                let o = Observation::of(&ego, &partner);
                let (a, b) = (
                    blob.score_pair_guarded(&ego, &partner),
                    blob.score_guarded(&o),
                );
                assert_eq!(
                    a.score.to_bits(),
                    b.score.to_bits(),
                    "{speed} {gap} {closing}"
                );
                assert_eq!(a, b);
                outside += usize::from(!a.in_domain);
            }
        }
    }
    assert!(outside > 10, "{outside}");
}
