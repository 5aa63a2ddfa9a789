//! Model blob format: round trips per kind, a byte-exact worked example (the one in
//! docs/model-format.md), and one test per `ModelError` variant, plus exhaustive truncation and
//! byte-flip sweeps that must return errors, never panic.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common_models;

use common_models::*;
use scorer_core::gssm::{GssmModel, GssmScore};
use scorer_core::mlp::{FloatLayer, FloatMlp};
use scorer_core::model::{self, BoundedVec, Model, ModelError, ModelKind, HEADER_LEN};
use scorer_core::msra::{MsraModel, MsraTerm};
use scorer_core::{Features, Observation, SurrogateKind, Surrogates, VehicleState};
use serde::Serialize;

fn encode_vec(m: &Model<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; model::encoded_len(m).unwrap()];
    let n = model::encode(m, &mut buf).unwrap();
    assert_eq!(n, buf.len());
    buf
}

/// An observation of random numbers (not of any pair of states): the round trip only needs every
/// model to read the same inputs before and after.
fn observation(rng: &mut Rng) -> Observation {
    Observation {
        features: random_features(rng),
        surrogates: surrogates(rng),
        drl_inputs: random_features(rng),
    }
}

fn surrogates(rng: &mut Rng) -> Surrogates {
    Surrogates {
        box_distance: rng.uniform(0.0, 30.0),
        ttc2d: rng.uniform(0.0, 12.0),
        tadv: rng.uniform(0.0, 8.0),
        tadv_corridor: rng.uniform(0.0, 8.0),
        ei: rng.uniform(-3.0, 3.0),
    }
}

/// Every model kind used by the tests, with owned backing storage.
struct Fixtures {
    drl: FloatNet,
    drl_q: QuantNet,
    gssm: FloatNet,
}

impl Fixtures {
    fn new() -> Self {
        let drl = FloatNet::random(11, &ALL_FEATURES, &[16, 8], 1);
        let mut rng = Rng(5);
        let calib: Vec<Features> = (0..500).map(|_| random_features(&mut rng)).collect();
        let drl_q = QuantNet::quantize(&drl, &calib);
        let gssm = FloatNet::random(22, &CONTEXT_FEATURES, &[12], 2);
        Self { drl, drl_q, gssm }
    }

    fn gssm_model(&self, score: GssmScore) -> GssmModel<'_> {
        GssmModel {
            net: self.gssm.mlp(),
            score,
        }
    }

    fn models(&self) -> Vec<Model<'_>> {
        let msra_terms = [
            MsraTerm {
                kind: SurrogateKind::Tadv,
                weight: 0.7,
                a: -1.3,
                b: 2.0,
                lo: 0.0,
                hi: 10.0,
            },
            MsraTerm {
                kind: SurrogateKind::Ei,
                weight: 0.2,
                a: 0.8,
                b: -0.5,
                lo: -5.0,
                hi: 5.0,
            },
            MsraTerm {
                kind: SurrogateKind::Gssm,
                weight: 0.1,
                a: 1.1,
                b: -2.0,
                lo: 0.0,
                hi: 6.0,
            },
        ];
        vec![
            Model::DrlF32(self.drl.mlp()),
            Model::DrlInt8(self.drl_q.mlp()),
            Model::Gssm(self.gssm_model(GssmScore::Intensity)),
            Model::Gssm(self.gssm_model(GssmScore::Logit)),
            Model::Msra(MsraModel {
                terms: BoundedVec::from_slice(&msra_terms).unwrap(),
                gssm: Some(self.gssm_model(GssmScore::Intensity)),
            }),
            Model::Msra(MsraModel {
                terms: BoundedVec::from_slice(&[
                    MsraTerm {
                        kind: SurrogateKind::Ttc2d,
                        weight: 1.0,
                        a: -0.9,
                        b: 1.5,
                        lo: 0.0,
                        hi: 10.0,
                    },
                    MsraTerm {
                        kind: SurrogateKind::Ei,
                        weight: 0.5,
                        a: 0.8,
                        b: -0.5,
                        lo: -5.0,
                        hi: 5.0,
                    },
                ])
                .unwrap(),
                gssm: None,
            }),
        ]
    }
}

#[test]
fn round_trip_every_kind() {
    let fx = Fixtures::new();
    let kinds = [
        ModelKind::DrlF32,
        ModelKind::DrlInt8,
        ModelKind::Gssm,
        ModelKind::Gssm,
        ModelKind::Msra,
        ModelKind::Msra,
    ];
    for (m, kind) in fx.models().iter().zip(kinds) {
        assert_eq!(m.kind(), kind);
        let blob = encode_vec(m);
        let header = model::decode_header(&blob).unwrap();
        assert_eq!(header.kind, kind);
        assert_eq!(header.payload_len as usize, blob.len() - HEADER_LEN);
        let back = model::decode(&blob).unwrap();
        assert_eq!(&back, m);
        let mut rng = Rng(99);
        for _ in 0..200 {
            let o = observation(&mut rng);
            let (a, b) = (m.score_observation(&o), back.score_observation(&o));
            assert!(a.is_finite());
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }
}

/// The deployed one-call path (`Model::score`, which computes only what its model reads) and the
/// host's shared observation (`Observation::of` + `score_observation`) give the same bits, for
/// every kind, on random pairs of road users.
#[test]
fn score_equals_score_observation_bit_for_bit() {
    let fx = Fixtures::new();
    let mut rng = Rng(7);
    let user = |rng: &mut Rng| {
        let angle = rng.uniform(-3.2, 3.2);
        VehicleState {
            x: rng.uniform(-60.0, 60.0),
            y: rng.uniform(-60.0, 60.0),
            vx: rng.uniform(-30.0, 30.0),
            vy: rng.uniform(-30.0, 30.0),
            hx: libm::cosf(angle),
            hy: libm::sinf(angle),
            acc: rng.uniform(-4.0, 2.0),
            length: rng.uniform(3.5, 15.0),
            width: rng.uniform(1.6, 2.6),
        }
    };
    for m in fx.models() {
        for _ in 0..500 {
            let (ego, partner) = (user(&mut rng), user(&mut rng));
            let direct = m.score(&ego, &partner);
            let shared = m.score_observation(&Observation::of(&ego, &partner));
            assert!(direct.is_finite());
            assert_eq!(direct.to_bits(), shared.to_bits(), "{:?}", m.kind());
        }
    }
}

/// A GSSM blob without a calibrated threshold warns at the middle of its own score mode's range
/// (the rule MSRA follows too), not at a fixed 0.5 that is near the top of a CDF's range but near
/// the bottom of an intensity's.
#[test]
fn a_gssm_kind_threshold_is_the_middle_of_its_score_modes_range() {
    use scorer_core::gssm::{intensity, logit};
    let fx = Fixtures::new();
    for (mode, lowest, highest) in [
        (GssmScore::Intensity, intensity(0.0), intensity(1.0)),
        (GssmScore::Logit, logit(0.0), logit(1.0)),
        (GssmScore::Cdf, 0.0, 1.0),
    ] {
        let threshold = Model::Gssm(fx.gssm_model(mode)).kind_default_threshold();
        // f32 clipping makes the logit's range asymmetric by 0.01 in 27.6: within 0.1 % of it.
        let middle = 0.5 * (lowest + highest);
        let tolerance = 1e-3 * (highest - lowest);
        assert!(
            (threshold - middle).abs() < tolerance,
            "{mode:?}: {threshold} vs {middle}"
        );
    }
}

#[test]
fn decoding_borrows_weights_from_the_blob() {
    let fx = Fixtures::new();
    let blob = encode_vec(&Model::DrlF32(fx.drl.mlp()));
    let Model::DrlF32(m) = model::decode(&blob).unwrap() else {
        panic!("kind")
    };
    let w = m.layers[0].weights;
    let range = blob.as_ptr_range();
    assert!(
        range.contains(&w.as_ptr()),
        "weights must point into the blob, not a copy"
    );
    assert_eq!(w, &fx.drl.w_bytes[0][..]);
}

/// The worked example of docs/model-format.md, byte for byte.
#[test]
fn worked_example_matches_the_spec() {
    let w = (-1.0f32).to_le_bytes();
    let b = 0.5f32.to_le_bytes();
    let mut layers = BoundedVec::new();
    layers
        .push(FloatLayer {
            out_dim: 1,
            relu: false,
            weights: &w,
            bias: &b,
        })
        .unwrap();
    let m = Model::DrlF32(FloatMlp {
        inputs: BoundedVec::from_slice(&[8]).unwrap(),
        input_scale: BoundedVec::from_slice(&[0.1]).unwrap(),
        input_offset: BoundedVec::from_slice(&[-1.0]).unwrap(),
        layers,
    });
    let blob = encode_vec(&m);
    let hex: String = blob.iter().map(|b| format!("{b:02x}")).collect();
    println!("{hex}");
    assert_eq!(
        hex,
        concat!(
            "52534b4d",
            "0100",
            "02",
            "00",
            "0300",
            "0000",
            "19000000",
            "898a88bc",
            "0108",
            "01cdcccc3d",
            "01000080bf",
            "01",
            "01",
            "00",
            "04000080bf",
            "040000003f"
        )
    );
    // R = w * (x * 0.1 - 1) + b = 1.5 - 0.1 x, x = log_gap = ln(0.5 + gap): 1.0 at x = 5.
    let Model::DrlF32(net) = model::decode(&blob).unwrap() else {
        panic!("kind")
    };
    let mut x = [0.0f32; 13];
    x[8] = 5.0;
    let r = net.forward(&x)[0];
    assert!((r - 1.0).abs() < 1e-6, "{r}");
    // The same through the deployed entry point: two boxes e^5 - 0.5 m apart.
    let gap = libm::expf(5.0) - 0.5;
    let car = |y: f32| VehicleState {
        y,
        hy: 1.0,
        length: 4.0,
        width: 2.0,
        ..Default::default()
    };
    let m = model::decode(&blob).unwrap();
    let r = m.score(&car(0.0), &car(4.0 + gap));
    assert!((r - 1.0).abs() < 1e-4, "{r}");
    let o = Observation::of(&car(0.0), &car(4.0 + gap));
    assert_eq!(r.to_bits(), m.score_observation(&o).to_bits());
}

/// A DRL blob of an older input schema (1: the raw features; 2: encoding 2, whose inputs were
/// derived through sin/cos) is refused with a message that says why, never scored with the wrong
/// inputs.
#[test]
fn drl_blob_of_an_old_input_schema_is_refused() {
    for old in [1u16, 2] {
        let mut blob = valid_drl_blob();
        blob[8..10].copy_from_slice(&old.to_le_bytes());
        let err = model::decode(&blob).unwrap_err();
        assert_eq!(
            err,
            ModelError::WrongInputSchema {
                kind: "drl-f32",
                found: old,
                expected: 3
            }
        );
        let text = err.to_string();
        assert!(text.contains("retrain or re-export"), "{text}");
    }
    // And MSRA/GSSM blobs must not claim a DRL encoding.
    let fx = Fixtures::new();
    for m in fx.models() {
        if matches!(m, Model::Msra(_) | Model::Gssm(_)) {
            for drl_schema in [2u8, 3] {
                let mut blob = encode_vec(&m);
                blob[8] = drl_schema;
                assert!(matches!(
                    model::decode(&blob),
                    Err(ModelError::WrongInputSchema { found, expected: 1, .. }) if found == u16::from(drl_schema)
                ));
            }
        }
    }
}

#[test]
fn every_truncation_is_an_error() {
    let fx = Fixtures::new();
    for m in fx.models() {
        let blob = encode_vec(&m);
        for n in 0..blob.len() {
            let err = model::decode(&blob[..n]).unwrap_err();
            assert!(
                matches!(err, ModelError::Truncated { .. }),
                "{:?} cut at {n}: {err:?}",
                m.kind()
            );
        }
    }
}

#[test]
fn every_byte_flip_is_an_error() {
    let fx = Fixtures::new();
    for m in fx.models() {
        let blob = encode_vec(&m);
        let mut copy = blob.clone();
        for i in 0..blob.len() {
            for mask in [0x01u8, 0x80, 0xFF] {
                copy[i] ^= mask;
                assert!(
                    model::decode(&copy).is_err(),
                    "{:?}: byte {i} ^ {mask:#x} accepted",
                    m.kind()
                );
                copy[i] ^= mask;
            }
        }
        assert!(model::decode(&copy).is_ok());
    }
}

// ---- one test per error variant -----------------------------------------------------------------

fn valid_drl_blob() -> Vec<u8> {
    let fx = Fixtures::new();
    let blob = encode_vec(&Model::DrlF32(fx.drl.mlp()));
    blob
}

#[test]
fn err_truncated_header() {
    assert_eq!(
        model::decode(b"RSKM\x01"),
        Err(ModelError::Truncated {
            needed: HEADER_LEN,
            available: 5
        })
    );
    assert_eq!(
        model::decode(b""),
        Err(ModelError::Truncated {
            needed: 20,
            available: 0
        })
    );
}

#[test]
fn err_bad_magic() {
    let mut blob = valid_drl_blob();
    blob[0] = b'X';
    assert_eq!(model::decode(&blob), Err(ModelError::BadMagic(*b"XSKM")));
    assert!(matches!(
        model::decode(b"PK\x03"),
        Err(ModelError::BadMagic(_))
    ));
}

#[test]
fn err_unsupported_version() {
    let mut blob = valid_drl_blob();
    blob[4] = 3;
    assert_eq!(model::decode(&blob), Err(ModelError::UnsupportedVersion(3)));
    blob[4] = 0;
    assert_eq!(model::decode(&blob), Err(ModelError::UnsupportedVersion(0)));
}

#[test]
fn err_unknown_kind() {
    for k in [0u8, 5, 0xFF] {
        let mut blob = valid_drl_blob();
        blob[6] = k;
        assert_eq!(model::decode(&blob), Err(ModelError::UnknownKind(k)));
    }
}

#[test]
fn err_reserved_not_zero() {
    for offset in [7usize, 10, 11] {
        let mut blob = valid_drl_blob();
        blob[offset] = 1;
        assert_eq!(
            model::decode(&blob),
            Err(ModelError::ReservedNotZero { offset })
        );
    }
}

#[test]
fn err_unsupported_feature_schema() {
    let mut blob = valid_drl_blob();
    blob[8] = 7;
    assert_eq!(
        model::decode(&blob),
        Err(ModelError::UnsupportedFeatureSchema(7))
    );
}

#[test]
fn err_wrong_kind_for_payload() {
    // A DRL-f32 payload declared as int8 must fail in postcard or validation, not be misread.
    let mut blob = valid_drl_blob();
    blob[6] = ModelKind::DrlInt8 as u8;
    assert!(model::decode(&blob).is_err());
}

#[test]
fn err_trailing_bytes() {
    let mut blob = valid_drl_blob();
    blob.push(0);
    assert_eq!(
        model::decode(&blob),
        Err(ModelError::TrailingBytes { extra: 1 })
    );
    // Extra bytes inside a correctly declared, correctly checksummed payload.
    let mut payload = valid_drl_blob()[HEADER_LEN..].to_vec();
    payload.extend_from_slice(&[0, 0]);
    assert_eq!(
        model::decode(&wrap(ModelKind::DrlF32 as u8, &payload)),
        Err(ModelError::TrailingBytes { extra: 2 })
    );
}

#[test]
fn err_truncated_payload() {
    let blob = valid_drl_blob();
    let len = blob.len();
    assert_eq!(
        model::decode(&blob[..len - 3]),
        Err(ModelError::Truncated {
            needed: len,
            available: len - 3
        })
    );
    // Declared length larger than the blob (e.g. a header from a bigger model).
    let mut blob = valid_drl_blob();
    blob[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        model::decode(&blob),
        Err(ModelError::Truncated { .. })
    ));
}

#[test]
fn err_crc_mismatch() {
    let mut blob = valid_drl_blob();
    let last = blob.len() - 1;
    blob[last] ^= 0x10;
    let Err(ModelError::CrcMismatch { stored, computed }) = model::decode(&blob) else {
        panic!("expected CrcMismatch");
    };
    assert_ne!(stored, computed);
    assert_eq!(computed, scorer_core::crc::crc32(&blob[HEADER_LEN..]));
}

#[test]
fn err_payload() {
    for payload in [&[0xFFu8, 0xFF, 0xFF][..], &[], &[1, 0, 1]] {
        let err = model::decode(&wrap(ModelKind::DrlF32 as u8, payload)).unwrap_err();
        assert!(matches!(err, ModelError::Payload(_)), "{err:?}");
    }
    // A bool that is neither 0 nor 1.
    let mut payload = valid_drl_blob()[HEADER_LEN..].to_vec();
    // inputs(1+13) scale(1+52) offset(1+52) layers-len(1) out_dim(1) relu at offset 122
    assert_eq!(payload[122], 1, "layout assumption: relu of layer 0");
    payload[122] = 2;
    assert_eq!(
        model::decode(&wrap(2, &payload)),
        Err(ModelError::Payload(postcard::Error::DeserializeBadBool))
    );
}

/// Wire mirrors used to write payloads the real types cannot hold (over capacity).
#[derive(Serialize)]
struct WireLayer {
    out_dim: u16,
    relu: bool,
    weights: Vec<u8>,
    bias: Vec<u8>,
}
#[derive(Serialize)]
struct WireFloatMlp {
    inputs: Vec<u8>,
    input_scale: Vec<f32>,
    input_offset: Vec<f32>,
    layers: Vec<WireLayer>,
}

fn wire_net(n_inputs: usize, widths: &[usize]) -> WireFloatMlp {
    let mut layers = Vec::new();
    let mut in_dim = n_inputs;
    for &w in widths {
        layers.push(WireLayer {
            out_dim: w as u16,
            relu: true,
            weights: f32_bytes(&vec![0.01; w * in_dim]),
            bias: f32_bytes(&vec![0.0; w]),
        });
        in_dim = w;
    }
    WireFloatMlp {
        inputs: (0..n_inputs as u8).map(|i| i % 13).collect(),
        input_scale: vec![1.0; n_inputs],
        input_offset: vec![0.0; n_inputs],
        layers,
    }
}

fn decode_wire(w: &WireFloatMlp) -> Result<(), ModelError> {
    model::decode(&wrap(ModelKind::DrlF32 as u8, &postcard_bytes(w))).map(|_| ())
}

#[test]
fn wire_mirror_matches_real_encoding() {
    assert_eq!(decode_wire(&wire_net(3, &[4, 1])), Ok(()));
}

#[test]
fn err_capacity_exceeded() {
    assert_eq!(
        decode_wire(&wire_net(3, &[4, 4, 4, 4, 1])),
        Err(ModelError::CapacityExceeded {
            field: "layers",
            len: 5,
            max: 4
        })
    );
    assert_eq!(
        decode_wire(&wire_net(14, &[4, 1])),
        Err(ModelError::CapacityExceeded {
            field: "inputs",
            len: 14,
            max: 13
        })
    );
    assert_eq!(
        decode_wire(&wire_net(3, &[65, 1])),
        Err(ModelError::CapacityExceeded {
            field: "layers.out_dim",
            len: 65,
            max: 64
        })
    );
    assert_eq!(
        decode_wire(&wire_net(3, &[8, 3])),
        Err(ModelError::CapacityExceeded {
            field: "layers.out_dim",
            len: 3,
            max: 2
        })
    );
    // Widths at capacity are fine.
    assert_eq!(decode_wire(&wire_net(13, &[64, 64, 64, 2])), Ok(()));
}

#[test]
fn err_empty() {
    assert_eq!(
        decode_wire(&wire_net(3, &[])),
        Err(ModelError::Empty { field: "layers" })
    );
    assert_eq!(
        decode_wire(&wire_net(0, &[1])),
        Err(ModelError::Empty { field: "inputs" })
    );
    assert_eq!(
        decode_wire(&wire_net(3, &[0, 1])),
        Err(ModelError::Empty {
            field: "layers.out_dim"
        })
    );
    let m = Model::Msra(MsraModel {
        terms: BoundedVec::new(),
        gssm: None,
    });
    assert_eq!(
        model::encode(&m, &mut [0u8; 64]),
        Err(ModelError::Empty { field: "terms" })
    );
}

#[test]
fn err_dimension_mismatch() {
    let mut w = wire_net(3, &[4, 1]);
    w.layers[1].weights.pop();
    assert_eq!(
        decode_wire(&w),
        Err(ModelError::DimensionMismatch {
            field: "layers.weights",
            index: 1,
            expected: 16,
            found: 15
        })
    );
    let mut w = wire_net(3, &[4, 1]);
    w.input_offset.pop();
    assert_eq!(
        decode_wire(&w),
        Err(ModelError::DimensionMismatch {
            field: "input_offset",
            index: 0,
            expected: 3,
            found: 2
        })
    );
    let mut w = wire_net(3, &[4, 1]);
    w.layers[0].bias.extend_from_slice(&[0; 4]);
    assert!(matches!(
        decode_wire(&w),
        Err(ModelError::DimensionMismatch {
            field: "layers.bias",
            ..
        })
    ));
    // GSSM needs exactly two outputs.
    let fx = Fixtures::new();
    let g = Model::Gssm(GssmModel {
        net: fx.drl.mlp(),
        score: GssmScore::Cdf,
    });
    assert_eq!(
        model::encode(&g, &mut [0u8; 4096]),
        Err(ModelError::DimensionMismatch {
            field: "gssm.outputs",
            index: 0,
            expected: 2,
            found: 1
        })
    );
}

#[test]
fn err_non_finite() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 2.0e9] {
        let mut w = wire_net(3, &[4, 1]);
        w.layers[0].weights[20..24].copy_from_slice(&bad.to_le_bytes());
        assert_eq!(
            decode_wire(&w),
            Err(ModelError::NonFinite {
                field: "layers.weights",
                index: 5
            })
        );
        let mut w = wire_net(3, &[4, 1]);
        w.input_offset[2] = bad;
        assert_eq!(
            decode_wire(&w),
            Err(ModelError::NonFinite {
                field: "input_offset",
                index: 2
            })
        );
    }
    let mut terms = [MsraTerm {
        kind: SurrogateKind::Ttc2d,
        weight: 1.0,
        a: -1.0,
        b: 0.0,
        lo: 0.0,
        hi: 10.0,
    }];
    terms[0].a = f32::NAN;
    let m = Model::Msra(MsraModel {
        terms: BoundedVec::from_slice(&terms).unwrap(),
        gssm: None,
    });
    assert_eq!(
        model::encode(&m, &mut [0u8; 256]),
        Err(ModelError::NonFinite {
            field: "terms.a",
            index: 0
        })
    );
}

#[test]
fn err_non_positive_scale() {
    for bad in [0.0f32, -0.0, -1.0] {
        let mut w = wire_net(3, &[4, 1]);
        w.input_scale[1] = bad;
        assert_eq!(
            decode_wire(&w),
            Err(ModelError::NonPositiveScale {
                field: "input_scale",
                index: 1
            })
        );
    }
    let fx = Fixtures::new();
    let mut q = fx.drl_q.clone();
    q.output_scales[0] = 0.0;
    assert_eq!(
        model::encode(&Model::DrlInt8(q.mlp()), &mut [0u8; 8192]),
        Err(ModelError::NonPositiveScale {
            field: "output_scales",
            index: 0
        })
    );
    let mut q = fx.drl_q.clone();
    q.input_mul[4] = -2.0;
    assert_eq!(
        model::encode(&Model::DrlInt8(q.mlp()), &mut [0u8; 8192]),
        Err(ModelError::NonPositiveScale {
            field: "input_mul",
            index: 4
        })
    );
}

#[test]
fn err_bad_feature_index() {
    let mut w = wire_net(3, &[4, 1]);
    w.inputs[2] = 13;
    assert_eq!(
        decode_wire(&w),
        Err(ModelError::BadFeatureIndex {
            index: 2,
            feature: 13
        })
    );
}

#[test]
fn err_bad_multiplier() {
    let fx = Fixtures::new();
    let mut q = fx.drl_q.clone();
    q.m[1][4..8].copy_from_slice(&5i32.to_le_bytes());
    let payload = postcard_bytes(&q.mlp());
    let err = model::decode(&wrap(ModelKind::DrlInt8 as u8, &payload)).unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::BadMultiplier {
                layer: 1,
                channel: 1,
                multiplier: 5,
                ..
            }
        ),
        "{err:?}"
    );
    let mut q = fx.drl_q.clone();
    q.s[0][3] = 40;
    let err = model::encode(&Model::DrlInt8(q.mlp()), &mut [0u8; 8192]).unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::BadMultiplier {
                layer: 0,
                channel: 3,
                shift: 40,
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn err_bad_clip_range() {
    for (lo, hi) in [
        (1.0, 1.0),
        (2.0, 1.0),
        (f32::NEG_INFINITY, 1.0),
        (0.0, f32::NAN),
    ] {
        let t = MsraTerm {
            kind: SurrogateKind::Ei,
            weight: 1.0,
            a: 1.0,
            b: 0.0,
            lo,
            hi,
        };
        let m = Model::Msra(MsraModel {
            terms: BoundedVec::from_slice(&[t]).unwrap(),
            gssm: None,
        });
        assert_eq!(
            model::encode(&m, &mut [0u8; 256]),
            Err(ModelError::BadClipRange { term: 0 })
        );
    }
}

#[test]
fn err_missing_gssm() {
    let t = MsraTerm {
        kind: SurrogateKind::Gssm,
        weight: 1.0,
        a: 1.0,
        b: 0.0,
        lo: 0.0,
        hi: 6.0,
    };
    let m = MsraModel {
        terms: BoundedVec::from_slice(&[t]).unwrap(),
        gssm: None,
    };
    let payload = postcard_bytes(&m);
    assert_eq!(
        model::decode(&wrap(ModelKind::Msra as u8, &payload)),
        Err(ModelError::MissingGssm { term: 0 })
    );
}

#[test]
fn err_buffer_too_small() {
    let fx = Fixtures::new();
    let m = Model::DrlF32(fx.drl.mlp());
    let needed = model::encoded_len(&m).unwrap();
    for size in [0, 10, HEADER_LEN, needed - 1] {
        let mut buf = vec![0u8; size];
        assert_eq!(
            model::encode(&m, &mut buf),
            Err(ModelError::BufferTooSmall {
                needed,
                available: size
            })
        );
    }
    let mut buf = vec![0u8; needed + 100];
    assert_eq!(model::encode(&m, &mut buf), Ok(needed));
}

#[test]
fn errors_display_their_field() {
    let e = ModelError::DimensionMismatch {
        field: "layers.weights",
        index: 1,
        expected: 16,
        found: 15,
    };
    assert_eq!(
        e.to_string(),
        "layers.weights[1]: expected length 16, found 15"
    );
    let e = ModelError::CrcMismatch {
        stored: 1,
        computed: 2,
    };
    assert!(e.to_string().contains("0x00000001"));
}

/// The enum indices are part of the wire format (docs/model-format.md); reordering variants must
/// fail here, not silently change what old blobs mean.
#[test]
fn enum_wire_indices_are_pinned() {
    for (kind, index) in [
        (SurrogateKind::Ttc2d, 0u8),
        (SurrogateKind::Tadv, 1),
        (SurrogateKind::Ei, 2),
        (SurrogateKind::Gssm, 3),
        (SurrogateKind::TadvCorridor, 4),
    ] {
        let t = MsraTerm {
            kind,
            weight: 1.0,
            a: 1.0,
            b: 0.0,
            lo: 0.0,
            hi: 1.0,
        };
        assert_eq!(postcard_bytes(&t)[0], index, "{kind:?}");
    }
    for (score, index) in [
        (GssmScore::Intensity, 0u8),
        (GssmScore::Cdf, 1),
        (GssmScore::Logit, 2),
    ] {
        assert_eq!(postcard_bytes(&score), [index]);
    }
    for (kind, byte) in [
        (ModelKind::DrlInt8, 1u8),
        (ModelKind::DrlF32, 2),
        (ModelKind::Msra, 3),
        (ModelKind::Gssm, 4),
    ] {
        assert_eq!(kind as u8, byte);
        assert_eq!(ModelKind::from_u8(byte), Ok(kind));
    }
}
