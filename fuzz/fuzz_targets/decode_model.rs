//! Fuzzes model decoding: any byte string must decode to `Ok` or a typed `ModelError`, never panic,
//! and every model that decodes must score finite values (directly and through its blob's
//! training-domain guard, `ModelBlob::score_guarded`) and survive an encode/decode round trip.
#![no_main]

use libfuzzer_sys::fuzz_target;
use scorer_core::model::{self, ModelKind, HEADER_LEN};
use scorer_core::{Features, Observation, Surrogates, VehicleState};

/// Wraps `payload` in a valid header so the fuzzer also reaches the postcard and validation layers
/// (a random header almost never passes the CRC). The header carries the kind's own input schema
/// (3 for the DRL kinds, 1 for MSRA and GSSM): with another one the header check refuses the blob
/// before its payload is read.
fn with_header(kind: ModelKind, payload: &[u8], out: &mut Vec<u8>) {
    out.clear();
    out.extend_from_slice(b"RSKM");
    out.extend_from_slice(&model::FORMAT_VERSION.to_le_bytes());
    out.push(kind as u8);
    out.push(0);
    out.extend_from_slice(&kind.input_schema().to_le_bytes());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(&scorer_core::crc::crc32(payload).to_le_bytes());
    out.extend_from_slice(payload);
}

/// Ego at 20 m/s, 8 m behind a partner at 12 m/s, and the partner crossing: one pair inside a
/// typical training domain, one likely outside.
fn pairs() -> [(VehicleState, VehicleState); 2] {
    let ego = VehicleState {
        vy: 20.0,
        hy: 1.0,
        length: 4.5,
        width: 1.8,
        ..VehicleState::default()
    };
    let lead = VehicleState {
        y: 12.5,
        vy: 12.0,
        ..ego
    };
    let crossing = VehicleState {
        x: -15.0,
        y: 20.0,
        vx: 14.0,
        vy: 0.0,
        hx: 1.0,
        hy: 0.0,
        length: 18.75,
        ..ego
    };
    [(ego, lead), (ego, crossing)]
}

fn exercise(blob: &[u8]) {
    let Ok(b) = model::decode_blob(blob) else {
        return;
    };
    // The guarded score of the whole blob (its records: domain, policy, fallback, blend), on real
    // pairs and on an all-NaN observation.
    for (ego, partner) in pairs() {
        let g = b.score_guarded(&Observation::of(&ego, &partner));
        assert!(g.score.is_finite(), "non-finite guarded score {}", g.score);
    }
    let m = &b.model;
    let features: Features = [
        1.0, 4.5, 1.8, 0.1, 12.0, -0.3, 100.0, 144.0, 4.0, 2.0, 0.2, 0.5, 8.0,
    ];
    let surrogates = Surrogates {
        box_distance: 8.0,
        ttc2d: 3.0,
        tadv: f32::INFINITY,
        // Finite, unlike TAdv here: a term that reads it goes through the clip.
        tadv_corridor: 2.5,
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
    assert!(b.score_guarded(&nan).score.is_finite());
    // Postcard may accept non-minimal varints, so compare models, not bytes.
    let mut again = vec![0u8; blob.len()];
    let n = model::encode(m, &mut again).expect("a decoded model re-encodes");
    let back = model::decode(&again[..n]).expect("a re-encoded model decodes");
    assert_eq!(&back, m, "round trip changed the model");
}

fuzz_target!(|data: &[u8]| {
    exercise(data);
    if let Some((&kind, payload)) = data.split_first() {
        let mut blob = Vec::with_capacity(HEADER_LEN + payload.len());
        let kind = match kind % 4 {
            0 => ModelKind::DrlInt8,
            1 => ModelKind::DrlF32,
            2 => ModelKind::Msra,
            _ => ModelKind::Gssm,
        };
        with_header(kind, payload, &mut blob);
        exercise(&blob);
    }
});
