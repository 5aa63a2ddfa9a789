//! The training-domain record (tag 2) and the guard: the record's bytes as docs/model-format.md
//! gives them, its round trip and every way it is refused, inside/outside per input, NaN, both
//! policies, and old blobs scoring unguarded.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod example_blob;

use example_blob::{
    assert_truncations_refused_and_flips_handled, blob_with_records, encode, example_domain,
    example_model, hex,
};

use scorer_core::model::{
    self, InputRange, Model, ModelBlob, ModelError, ModelMeta, OutsidePolicy, TrainingDomain,
};
use scorer_core::{Observation, VehicleState};

/// A domain over `ranges` (their wire bytes leaked: test data lives as long as the test).
fn domain_of(policy: OutsidePolicy, ranges: &[InputRange]) -> TrainingDomain<'static> {
    let bytes: Vec<u8> = ranges.iter().flat_map(|r| r.to_bytes()).collect();
    TrainingDomain::new(policy, Vec::leak(bytes))
}

fn guarded_blob(policy: OutsidePolicy) -> ModelBlob<'static> {
    ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            training_domain: Some(example_domain(policy)),
            ..ModelMeta::default()
        },
    }
}

fn domain_record(domain: &TrainingDomain) -> Vec<u8> {
    let mut buf = [0u8; 256];
    let body = postcard::to_slice(domain, &mut buf).unwrap();
    let mut record = vec![
        model::training_domain::TRAINING_DOMAIN_TAG,
        body.len() as u8,
    ];
    record.extend_from_slice(body);
    record
}

/// A pair whose DRL inputs are the given ego speed and a box gap of `gap` m (straight ahead,
/// partner at the same speed).
fn pair(ego_speed: f32, gap: f32) -> (VehicleState, VehicleState) {
    example_blob::following_pair(ego_speed, gap, 0.0)
}

#[test]
fn the_worked_example_is_byte_for_byte_the_documented_one() {
    let blob = encode(&guarded_blob(OutsidePolicy::Clamp));
    assert_eq!(
        hex(&blob),
        concat!(
            "52534b4d",
            "0200",
            "02",
            "00",
            "0300",
            "0000",
            "2f000000",
            "7aa25b7e",
            // The model, as in the version-1 example.
            "0108",
            "01cdcccc3d",
            "01000080bf",
            "01",
            "01",
            "00",
            "04000080bf",
            "040000003f",
            // The record: tag 2, 20 body bytes, Clamp, 18 range bytes (two ranges).
            "02",
            "14",
            "01",
            "12",
            "03",
            "00000000",
            "00002042",
            "08",
            "000040bf",
            "0000a040",
        )
    );
}

#[test]
fn the_record_round_trips_with_and_without_a_threshold() {
    for policy in [OutsidePolicy::FlagOnly, OutsidePolicy::Clamp] {
        let original = guarded_blob(policy);
        let bytes = encode(&original);
        let back = model::decode_blob(&bytes).unwrap();
        assert_eq!(back, original);
        let mut both = guarded_blob(policy);
        both.meta.default_threshold = Some(model::DefaultThreshold {
            threshold: 1.25,
            rule: model::ThresholdRule::KindDefault,
            data: "",
        });
        assert_eq!(model::decode_blob(&encode(&both)).unwrap(), both);
    }
    // The policy's wire index is pinned.
    let mut buf = [0u8; 4];
    assert_eq!(
        postcard::to_slice(&OutsidePolicy::FlagOnly, &mut buf).unwrap(),
        [0]
    );
    assert_eq!(
        postcard::to_slice(&OutsidePolicy::Clamp, &mut buf).unwrap(),
        [1]
    );
    for p in [OutsidePolicy::FlagOnly, OutsidePolicy::Clamp] {
        assert_eq!(OutsidePolicy::from_name(p.name()), Some(p));
    }
}

#[test]
fn bad_records_are_refused() {
    let entry_error = |domain: &TrainingDomain| {
        let blob = blob_with_records(&domain_record(domain));
        let result = model::decode_blob(&blob).map(|_| ());
        match result {
            Err(ModelError::BadDomainEntry { entry, input, .. }) => (entry, input),
            other => panic!("{other:?}"),
        }
    };
    let with = |index: usize, range: InputRange| {
        let mut ranges: Vec<InputRange> = example_domain(OutsidePolicy::Clamp).ranges().collect();
        ranges[index] = range;
        domain_of(OutsidePolicy::Clamp, &ranges)
    };
    let range = |input, lo, hi| InputRange { input, lo, hi };
    assert_eq!(entry_error(&with(1, range(13, 0.0, 1.0))), (1, 13));
    assert_eq!(entry_error(&with(0, range(3, f32::NAN, 1.0))), (0, 3));
    assert_eq!(entry_error(&with(1, range(8, 0.0, f32::INFINITY))), (1, 8));
    assert_eq!(entry_error(&with(0, range(3, 2.0, 1.0))), (0, 3));
    assert_eq!(entry_error(&with(1, range(3, 0.0, 1.0))), (1, 3));
    // A single-point range is allowed (an input the training data held constant).
    let point = with(0, range(3, 7.0, 7.0));
    assert!(model::decode_blob(&blob_with_records(&domain_record(&point))).is_ok());
    // Twice, an unknown policy, a padded body, more than 13 ranges.
    let good = domain_record(&example_domain(OutsidePolicy::FlagOnly));
    assert_eq!(
        model::decode_blob(&blob_with_records(&[good.clone(), good.clone()].concat())),
        Err(ModelError::DuplicateRecord { tag: 2 })
    );
    let mut policy = good.clone();
    policy[2] = 4;
    assert_eq!(
        model::decode_blob(&blob_with_records(&policy)),
        Err(ModelError::UnknownOutsidePolicy(4))
    );
    policy[2] = 0x80;
    assert_eq!(
        model::decode_blob(&blob_with_records(&policy)),
        Err(ModelError::UnknownOutsidePolicy(0x80))
    );
    let mut padded = good.clone();
    padded[1] += 1;
    padded.push(0);
    assert_eq!(
        model::decode_blob(&blob_with_records(&padded)),
        Err(ModelError::TrailingBytes { extra: 1 })
    );
    let mut body = vec![0u8, 14 * 9];
    for i in 0..14u8 {
        body.push(i % 13);
        body.extend(0f32.to_le_bytes());
        body.extend(1f32.to_le_bytes());
    }
    assert_eq!(body.len(), 128);
    let mut many = vec![2u8, 0x80, 0x01];
    many.extend(body);
    assert!(matches!(
        model::decode_blob(&blob_with_records(&many)),
        Err(ModelError::CapacityExceeded { .. })
    ));
    // A range cut short.
    let mut cut = vec![2u8, 12, 0, 10];
    cut.extend(&example_domain(OutsidePolicy::Clamp).range_bytes[..10]);
    assert!(matches!(
        model::decode_blob(&blob_with_records(&cut)),
        Err(ModelError::DimensionMismatch { .. })
    ));
    // The encoder refuses what the decoder would.
    let bad = ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            training_domain: Some(with(0, range(3, 2.0, 1.0))),
            ..ModelMeta::default()
        },
    };
    let mut out = vec![0u8; 256];
    assert!(matches!(
        model::encode_blob(&bad, &mut out),
        Err(ModelError::BadDomainEntry { .. })
    ));
}

#[test]
fn every_truncation_and_byte_flip_of_a_guarded_blob_is_handled() {
    assert_truncations_refused_and_flips_handled(&encode(&guarded_blob(OutsidePolicy::Clamp)));
}

/// The cell of an observation: a domain without cells never asks for it.
fn no_cells() -> u8 {
    unreachable!("a domain without geometry cells asked for one")
}

#[test]
fn each_bounded_input_is_checked_on_its_own_and_the_first_leaver_is_named() {
    let domain = example_domain(OutsidePolicy::FlagOnly);
    let mut x = [0.0f32; 13];
    x[3] = 20.0;
    x[8] = 2.0;
    assert_eq!(domain.first_outside(&x, no_cells), None);
    // Unbounded inputs may be anything.
    let mut free = x;
    free[0] = 1e30;
    free[12] = f32::NAN;
    assert_eq!(domain.first_outside(&free, no_cells), None);
    // Each bound on its own, ends included.
    for (input, value, outside) in [
        (3, 0.0, false),
        (3, 40.0, false),
        (3, -0.001, true),
        (3, 40.01, true),
        (8, -0.75, false),
        (8, 5.0, false),
        (8, 5.001, true),
        (8, -1.0, true),
        (8, f32::INFINITY, true),
        (3, f32::NEG_INFINITY, true),
    ] {
        let mut y = x;
        y[input] = value;
        let expected = outside.then_some(input as u8);
        assert_eq!(
            domain.first_outside(&y, no_cells),
            expected,
            "input {input} = {value}"
        );
    }
    // Both outside: the first range of the record is named.
    let mut both = x;
    both[3] = 45.0;
    both[8] = 6.0;
    assert_eq!(domain.first_outside(&both, no_cells), Some(3));
}

#[test]
fn nan_is_outside_and_clamps_to_the_midpoint() {
    let domain = example_domain(OutsidePolicy::Clamp);
    let mut x = [0.0f32; 13];
    x[3] = 10.0;
    x[8] = f32::NAN;
    assert_eq!(domain.first_outside(&x, no_cells), Some(8));
    domain.clamp(&mut x);
    assert_eq!(x[8], 2.125);
    assert_eq!(x[3], 10.0);
    assert_eq!(domain.first_outside(&x, no_cells), None);
}

#[test]
fn clamp_scores_the_nearest_trained_observation_and_flag_only_scores_as_today() {
    let clamp_bytes = encode(&guarded_blob(OutsidePolicy::Clamp));
    let flag_bytes = encode(&guarded_blob(OutsidePolicy::FlagOnly));
    let clamp = model::decode_blob(&clamp_bytes).unwrap();
    let flag = model::decode_blob(&flag_bytes).unwrap();
    // Far beyond the trained gap (ln(0.5 + 400) = 5.99 > 5) and beyond the trained speed.
    let (ego, partner) = pair(45.0, 400.0);
    let raw = flag.model.score(&ego, &partner);
    let f = flag.score_pair_guarded(&ego, &partner);
    assert_eq!(
        (f.score.to_bits(), f.in_domain, f.first_outside),
        (raw.to_bits(), false, Some(3))
    );
    let c = clamp.score_pair_guarded(&ego, &partner);
    assert!(!c.in_domain);
    assert_eq!(c.first_outside, Some(3));
    // log_gap clamped to 5: R = 1.5 - 0.1 * 5 = 1.0, the score at the edge of the trained range.
    let mut edge = scorer_core::drl_inputs(&ego, &partner);
    edge[3] = 40.0;
    edge[8] = 5.0;
    let Model::DrlF32(net) = &clamp.model else {
        panic!("kind")
    };
    assert_eq!(c.score.to_bits(), net.forward(&edge)[0].to_bits());
    assert!(
        (c.score - 1.0).abs() < 1e-6 && (raw - 1.0).abs() > 0.05,
        "{raw} {}",
        c.score
    );
    // Inside, every policy gives the unguarded score bit for bit.
    let (ego, partner) = pair(20.0, 30.0);
    let raw = clamp.model.score(&ego, &partner);
    for blob in [&clamp, &flag] {
        let g = blob.score_pair_guarded(&ego, &partner);
        assert_eq!(
            (g.score.to_bits(), g.in_domain, g.first_outside),
            (raw.to_bits(), true, None)
        );
    }
}

#[test]
fn pair_and_observation_entry_points_agree_bit_for_bit() {
    let bytes = encode(&guarded_blob(OutsidePolicy::Clamp));
    let clamp = model::decode_blob(&bytes).unwrap();
    for (speed, gap) in [
        (0.0, 0.0),
        (20.0, 3.0),
        (45.0, 400.0),
        (38.0, 150.0),
        (5.0, 1e4),
    ] {
        let (ego, partner) = pair(speed, gap);
        let o = Observation::of(&ego, &partner);
        assert_eq!(
            clamp.score_pair_guarded(&ego, &partner),
            clamp.score_guarded(&o),
            "{speed} {gap}"
        );
    }
}

#[test]
fn old_blobs_are_unguarded() {
    // Version 1, and version 2 with only a threshold record: inside everywhere, scores as today.
    let v1 = encode(&ModelBlob {
        model: example_model(),
        meta: ModelMeta::default(),
    });
    let threshold_only = encode(&ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            default_threshold: Some(model::DefaultThreshold {
                threshold: 1.0,
                rule: model::ThresholdRule::KindDefault,
                data: "x",
            }),
            ..ModelMeta::default()
        },
    });
    assert_eq!(&v1[4..6], &[1, 0]);
    assert_eq!(&threshold_only[4..6], &[2, 0]);
    let (ego, partner) = pair(45.0, 400.0);
    for bytes in [&v1, &threshold_only] {
        let blob = model::decode_blob(bytes).unwrap();
        assert!(blob.meta.training_domain.is_none());
        let g = blob.score_pair_guarded(&ego, &partner);
        assert!(g.in_domain && g.first_outside.is_none());
        assert_eq!(
            g.score.to_bits(),
            blob.model.score(&ego, &partner).to_bits()
        );
    }
    // A reader that knows tag 2 still skips tags it does not know around it.
    let mut records = vec![9, 2, 0xaa, 0xbb];
    records.extend(domain_record(&example_domain(OutsidePolicy::Clamp)));
    records.extend([200, 0]);
    let bytes = blob_with_records(&records);
    let blob = model::decode_blob(&bytes).unwrap();
    assert_eq!(
        blob.meta.training_domain,
        Some(example_domain(OutsidePolicy::Clamp))
    );
}
