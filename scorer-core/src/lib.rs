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
//! - [`mod@surrogates`]: surrogate safety measures TTC2D, TAdv and EI.
//! - [`quant`]: fixed-point requantisation shared by the int8 network and the host quantiser.
//! - [`mlp`]: the DRL network, int8 (deployed) and f32 (parity) paths over one structure.
//! - [`msra`]: the multi-surrogate risk aggregation `R = sum_k w_k sigmoid(a_k g_k(f_k) + b_k)`.
//! - [`gssm`]: the lognormal spacing model (GSSM / SSRA): `F_S`, intensity, score modes.
//! - [`warning`]: the first-threshold warning rule and a fixed-capacity track table.
//! - [`crc`]: CRC-32 used by the model blob header.
//! - [`domain`]: the guard: is an observation inside the model's training domain; guarded scores.
//! - [`model`]: the model blob format (header + postcard payload), decoding without allocation.
#![no_std]
#![forbid(unsafe_code)]
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

pub use encoding::{drl_inputs, DrlInputs, DRL_INPUT_COUNT, DRL_INPUT_ENCODING, DRL_INPUT_NAMES};
pub use features::{features, Features, FEATURE_COUNT, FEATURE_NAMES};
pub use geometry::box_distance;
pub use state::VehicleState;
pub use surrogates::{ei, surrogates, tadv, ttc2d, SurrogateKind, Surrogates};

pub use domain::Guarded;
pub use gssm::{GssmModel, GssmScore};
pub use mlp::{FloatMlp, QuantMlp};
pub use model::{decode, encode, Model, ModelError, ModelKind};
pub use msra::{MsraModel, MsraTerm};
pub use observation::Observation;
pub use warning::{FirstThreshold, TrackTable, WarningConfig};
