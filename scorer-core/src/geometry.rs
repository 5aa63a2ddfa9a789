//! Oriented vehicle boxes and the exact distance between two of them.
//! PLACEHOLDER: the surrogate/feature helper replaces the body.
use crate::state::VehicleState;

pub fn box_distance(_a: &VehicleState, _b: &VehicleState) -> f32 {
    0.0
}
