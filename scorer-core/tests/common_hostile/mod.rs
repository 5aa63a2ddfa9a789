//! Test-side strategies of hostile inputs: f32 values a sensor or a corrupted bus can deliver
//! (NaN, infinities, extremes, subnormals, any bit pattern) and vehicle states made of them.
//! Shared by the property tests of the inference layer and of the deployed, guarded path.
#![allow(dead_code)]

use proptest::prelude::*;
use scorer_core::VehicleState;

/// Any f32 a caller may pass: `finite_weight` parts of ordinary values in [-1e3, 1e3) against
/// one part each of every special value and two of random bit patterns.
pub fn nasty_f32_weighted(finite_weight: u32) -> impl Strategy<Value = f32> {
    prop_oneof![
        finite_weight => -1.0e3f32..1.0e3,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => Just(f32::MAX),
        1 => Just(f32::MIN),
        1 => Just(f32::MIN_POSITIVE),
        1 => Just(1.0e-40f32),
        2 => any::<u32>().prop_map(f32::from_bits),
    ]
}

/// A vehicle state whose every field is drawn from `values`.
pub fn nasty_state_of(values: impl Strategy<Value = f32>) -> impl Strategy<Value = VehicleState> {
    proptest::array::uniform9(values).prop_map(|v| VehicleState {
        x: v[0],
        y: v[1],
        vx: v[2],
        vy: v[3],
        hx: v[4],
        hy: v[5],
        acc: v[6],
        length: v[7],
        width: v[8],
    })
}
