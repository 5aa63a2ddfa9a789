//! The 13 observation features of an ego/partner pair (model-input order).
//! PLACEHOLDER: the surrogate/feature helper replaces the body.
use crate::state::VehicleState;

pub const FEATURE_COUNT: usize = 13;
pub type Features = [f32; FEATURE_COUNT];
pub const FEATURE_NAMES: [&str; FEATURE_COUNT] = [
    "l_ego", "l_sur", "w_comb", "vy_ego", "vx_sur", "vy_sur", "v_ego2", "v_sur2", "delta_v2",
    "delta_v", "psi_sur", "rho", "s",
];

pub fn features(_ego: &VehicleState, _partner: &VehicleState) -> Features {
    [0.0; FEATURE_COUNT]
}
