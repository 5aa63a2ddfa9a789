//! The worked example of docs/model-format.md (`R = 1.5 - 0.1 log_gap`) and version-2 blobs built
//! around it: shared by the tests of the metadata records.
#![allow(
    dead_code,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use scorer_core::mlp::{FloatLayer, FloatMlp};
use scorer_core::model::{
    self, BoundedVec, InputRange, Model, ModelBlob, ModelMeta, OutsidePolicy, TrainingDomain,
    HEADER_LEN,
};
use scorer_core::msra::MsraTerm;
use scorer_core::{SurrogateKind, VehicleState};

const W: [u8; 4] = (-1.0f32).to_le_bytes();
const B: [u8; 4] = 0.5f32.to_le_bytes();

/// The worked example's model: one linear layer on `log_gap` (DRL input 8).
pub fn example_model() -> Model<'static> {
    let mut layers = BoundedVec::new();
    layers
        .push(FloatLayer {
            out_dim: 1,
            relu: false,
            weights: &W,
            bias: &B,
        })
        .unwrap();
    Model::DrlF32(FloatMlp {
        inputs: BoundedVec::from_slice(&[8]).unwrap(),
        input_scale: BoundedVec::from_slice(&[0.1]).unwrap(),
        input_offset: BoundedVec::from_slice(&[-1.0]).unwrap(),
        layers,
    })
}

/// The documented example domain of the worked example: ego speed (DRL input 3) in [0, 40] m/s,
/// log gap (8) in [-0.75, 5] (its range bytes leaked: test data lives as long as the test).
pub fn example_domain(policy: OutsidePolicy) -> TrainingDomain<'static> {
    let ranges = [
        InputRange {
            input: 3,
            lo: 0.0,
            hi: 40.0,
        },
        InputRange {
            input: 8,
            lo: -0.75,
            hi: 5.0,
        },
    ];
    let bytes: Vec<u8> = ranges.iter().flat_map(|r| r.to_bytes()).collect();
    TrainingDomain::new(policy, Vec::leak(bytes))
}

/// A kinematic MSRA term of the worked fallback example (TAdv, clipped to [0, 10]).
pub fn tadv_term() -> MsraTerm {
    MsraTerm {
        kind: SurrogateKind::Tadv,
        weight: 1.0,
        a: -1.0,
        b: 2.0,
        lo: 0.0,
        hi: 10.0,
    }
}

/// Lowercase hex of `bytes`, for comparing blobs with the byte listings of docs/model-format.md.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// `blob` encoded (exactly [`model::encoded_blob_len`] bytes).
pub fn encode(blob: &ModelBlob<'_>) -> Vec<u8> {
    let mut out = vec![0u8; model::encoded_blob_len(blob).unwrap()];
    let n = model::encode_blob(blob, &mut out).unwrap();
    assert_eq!(n, out.len());
    out
}

/// A version-2 blob of the example model whose payload is the model followed by `records`, with
/// a correct length and CRC (so only the records can be at fault).
pub fn blob_with_records(records: &[u8]) -> Vec<u8> {
    let plain = encode(&ModelBlob {
        model: example_model(),
        meta: ModelMeta::default(),
    });
    let mut payload = plain[HEADER_LEN..].to_vec();
    payload.extend_from_slice(records);
    let mut blob = plain[..HEADER_LEN].to_vec();
    blob[4] = 2;
    blob[12..16].copy_from_slice(&(payload.len() as u32).to_le_bytes());
    blob[16..20].copy_from_slice(&scorer_core::crc::crc32(&payload).to_le_bytes());
    blob.extend_from_slice(&payload);
    blob
}

/// Every prefix of `blob` is refused, and no single-bit flip makes decoding panic.
pub fn assert_truncations_refused_and_flips_handled(blob: &[u8]) {
    for n in 0..blob.len() {
        assert!(model::decode_blob(&blob[..n]).is_err(), "prefix {n}");
    }
    for i in 0..blob.len() {
        for bit in 0..8 {
            let mut flipped = blob.to_vec();
            flipped[i] ^= 1 << bit;
            // Never a panic; the CRC catches every flip inside the payload.
            let _ = model::decode_blob(&flipped);
        }
    }
}

/// Ego at `ego_speed` straight ahead, a car of the same size `gap` m ahead (box gap) closing at
/// `closing` m/s: the pairs the guard tests place inside or outside the example domain.
pub fn following_pair(ego_speed: f32, gap: f32, closing: f32) -> (VehicleState, VehicleState) {
    let car = |y: f32, vy: f32| VehicleState {
        y,
        vy,
        hy: 1.0,
        length: 4.0,
        width: 2.0,
        ..Default::default()
    };
    (car(0.0, ego_speed), car(4.0 + gap, ego_speed - closing))
}
