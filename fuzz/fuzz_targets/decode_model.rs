//! Fuzzes model decoding: any byte string must decode to `Ok` or a typed `ModelError`, never panic,
//! and every model that decodes must score finite values and survive an encode/decode round trip.
#![no_main]

use libfuzzer_sys::fuzz_target;
use scorer_core::model::{self, HEADER_LEN};
use scorer_core::{Features, Observation, Surrogates};

/// Wraps `payload` in a valid header so the fuzzer also reaches the postcard and validation layers
/// (a random header almost never passes the CRC).
fn with_header(kind: u8, payload: &[u8], out: &mut Vec<u8>) {
    out.clear();
    out.extend_from_slice(b"RSKM");
    out.extend_from_slice(&model::FORMAT_VERSION.to_le_bytes());
    out.push(kind);
    out.push(0);
    out.extend_from_slice(&model::FEATURE_SCHEMA.to_le_bytes());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(&scorer_core::crc::crc32(payload).to_le_bytes());
    out.extend_from_slice(payload);
}

fn exercise(blob: &[u8]) {
    let Ok(m) = model::decode(blob) else {
        return;
    };
    let features: Features = [
        1.0, 4.5, 1.8, 0.1, 12.0, -0.3, 100.0, 144.0, 4.0, 2.0, 0.2, 0.5, 8.0,
    ];
    let surrogates = Surrogates {
        box_distance: 8.0,
        ttc2d: 3.0,
        tadv: f32::INFINITY,
        ei: f32::NEG_INFINITY,
    };
    let observation = Observation {
        features,
        surrogates,
        drl_inputs: features,
    };
    let r = m.score_observation(&observation);
    assert!(r.is_finite(), "non-finite score {r}");
    let nan = Observation {
        features: [f32::NAN; 13],
        surrogates,
        drl_inputs: [f32::NAN; 13],
    };
    assert!(m.score_observation(&nan).is_finite());
    // Postcard may accept non-minimal varints, so compare models, not bytes.
    let mut again = vec![0u8; blob.len()];
    let n = model::encode(&m, &mut again).expect("a decoded model re-encodes");
    let back = model::decode(&again[..n]).expect("a re-encoded model decodes");
    assert_eq!(back, m, "round trip changed the model");
}

fuzz_target!(|data: &[u8]| {
    exercise(data);
    if let Some((&kind, payload)) = data.split_first() {
        let mut blob = Vec::with_capacity(HEADER_LEN + payload.len());
        with_header(1 + kind % 4, payload, &mut blob);
        exercise(&blob);
    }
});
