//! `scorer-core`: the risk scoring core that runs on the vehicle's ECU.
//!
//! `#![no_std]`, no `alloc`, no `unsafe`, no panics. Every transcendental goes through `libm`, so the
//! host (training, evaluation, CAN bridge) and the microcontroller compute the same numbers.
//!
//! Layers, each in its own module:
//! - [`state`]: the kinematic state of one road user ([`VehicleState`]).
//! - [`geometry`]: oriented boxes and the exact box-to-box distance.
//! - [`interaction`]: the geometry of a pair (following, adjacent, crossing, oncoming).
//! - [`mod@features`]: the 13 observation features of an ego/partner pair.
//! - [`encoding`]: the DRL input encoding (versioned, trig-free transform of the two states).
//! - [`geometry_cell`]: bearing, relative heading and distance band of a pair, from its DRL inputs.
//! - [`observation`]: features + surrogates + DRL inputs of a pair, computed once ([`Observation`]).
//! - [`mod@surrogates`]: surrogate safety measures TTC2D, TAdv and EI, and TAdv under the corridor
//!   rule.
//! - [`quant`]: fixed-point requantisation shared by the int8 network and the host quantiser.
//! - [`mlp`]: the DRL network, int8 (deployed) and f32 (parity) paths over one structure.
//! - [`msra`]: the multi-surrogate risk aggregation `R = sum_k w_k sigmoid(a_k g_k(f_k) + b_k)`.
//! - [`gssm`]: the lognormal spacing model (GSSM / SSRA): `F_S`, intensity, score modes.
//! - [`warning`]: the first-threshold warning rule and a fixed-capacity track table.
//! - [`crc`]: CRC-32 used by the model blob header.
//! - [`domain`]: the guard: is an observation inside the model's training domain; guarded scores.
//! - [`model`]: the model blob format (header + postcard payload), decoding without allocation.
//!
//! # Scoring as deployed, from Rust firmware
//!
//! Decode the blob once with [`decode_blob`] (it borrows the weights: keep the blob in flash or a
//! `static`), score each ego/partner pair through the blob's training-domain guard with
//! [`ModelBlob::score_pair_guarded`], and feed the score to a [`TrackTable`] with the blob's own
//! threshold ([`ModelBlob::default_threshold`]). [`decode`] and [`Model::score`] skip the guard:
//! for the shipped blobs, which all carry a training-domain record, that is not the deployed score.
//!
//! ```
//! use scorer_core::warning::WarningEvent;
//! use scorer_core::{decode_blob, ModelError, TrackTable, VehicleState, WarningConfig};
//!
//! // On the ECU: `static DRL: &[u8] = include_bytes!(...)` in flash.
//! let blob_bytes: &[u8] = include_bytes!("../../models/drl-default.rsk");
//! let blob = decode_blob(blob_bytes)?; // header, CRC, payload, records, validation
//! let threshold = blob.default_threshold(); // the calibrated 2.881 of the shipped DRL
//!
//! // SI units, one world frame, box centres, unit heading; velocity over ground.
//! let car = |x: f32, vx: f32| VehicleState {
//!     x, y: 0.0, vx, vy: 0.0, hx: 1.0, hy: 0.0, acc: 0.0, length: 4.5, width: 1.8,
//! };
//! let ego = car(0.0, 25.0);
//! // Refuse states without a usable box first, as the C ABI does (see `VehicleState`).
//!
//! // Live mode: release 0.05 below the threshold after 0.5 s on; drop tracks silent for 1 s.
//! let config = WarningConfig::live(threshold, 0.05, 500_000, 1_000_000);
//! let mut tracks = TrackTable::<32>::new(config).expect("a finite threshold is valid");
//!
//! let mut onset_at = None;
//! for frame in 0..60u64 {
//!     let now_us = frame * 100_000; // 10 Hz, monotonic microseconds
//!     // A partner 150 m ahead at 5 m/s: the gap closes at 20 m/s (to 32 m at the last frame).
//!     let partner = car(150.0 - 2.0 * frame as f32, 5.0);
//!     let guarded = blob.score_pair_guarded(&ego, &partner);
//!     assert!(guarded.score.is_finite()); // always, NaN/inf states included
//!     let status = tracks.update(7, now_us, guarded.score).expect("valid update");
//!     if status.event == WarningEvent::Onset {
//!         onset_at.get_or_insert(frame);
//!     }
//! }
//! // Not at once (at 145 m the guarded score is below the threshold), but before the gap is gone.
//! assert!(matches!(onset_at, Some(frame) if frame > 0));
//!
//! // The unguarded score of `decode` / `Model::score` would have warned at once, 150 m away.
//! let far = car(150.0, 5.0);
//! assert!(blob.model.score(&ego, &far) >= threshold);
//! assert!(blob.score_pair_guarded(&ego, &far).score < threshold);
//!
//! // Bad bytes are a typed error, never a panic.
//! assert_eq!(decode_blob(&blob_bytes[..10]), Err(ModelError::Truncated { needed: 20, available: 10 }));
//! # Ok::<(), ModelError>(())
//! ```
#![no_std]
#![forbid(unsafe_code)]
// Every public item says what an integrator needs (unit, frame, range, what happens outside it).
#![deny(missing_docs)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod bounded;
pub mod crc;
pub mod domain;
pub mod encoding;
pub mod features;
pub mod geometry;
pub mod geometry_cell;
pub mod gssm;
pub mod interaction;
pub mod mlp;
pub mod model;
pub mod model_error;
pub mod msra;
pub mod observation;
pub mod quant;
pub mod state;
pub mod surrogates;
pub mod vec2;
pub mod warning;
mod wire_reader;

/// `models/README.md`, whose Rust example runs as a doctest (`cargo test -p scorer-core --doc`),
/// so the example a user copies from it compiles against this crate and scores through the guard.
#[cfg(doctest)]
#[doc = include_str!("../../models/README.md")]
pub struct ModelsReadme;

pub use encoding::{drl_inputs, DrlInputs, DRL_INPUT_COUNT, DRL_INPUT_ENCODING, DRL_INPUT_NAMES};
pub use features::{features, Features, FEATURE_COUNT, FEATURE_NAMES};
pub use geometry::box_distance;
pub use state::VehicleState;
pub use surrogates::{
    ei, surrogates, tadv, tadv_corridor, ttc2d, SurrogateKind, Surrogates, STANDING_SPEED,
};

pub use domain::Guarded;
pub use gssm::{GssmModel, GssmScore};
pub use mlp::{FloatMlp, QuantMlp};
pub use model::{decode, decode_blob, encode, Model, ModelBlob, ModelError, ModelKind};
pub use msra::{MsraModel, MsraTerm};
pub use observation::Observation;
pub use warning::{FirstThreshold, TrackTable, WarningConfig, WarningError};
