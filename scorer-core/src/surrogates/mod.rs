//! Surrogate safety measures. PLACEHOLDER: the surrogate/feature helper replaces the bodies.
use crate::state::VehicleState;

/// Which surrogate an MSRA term (or a baseline) reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[repr(u8)]
pub enum SurrogateKind {
    Ttc2d = 0,
    Tadv = 1,
    Ei = 2,
    Gssm = 3,
}

/// All surrogates of one pair, computed once and shared by MSRA and baselines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surrogates {
    pub box_distance: f32,
    pub ttc2d: f32,
    pub tadv: f32,
    pub ei: f32,
}

pub fn ttc2d(_ego: &VehicleState, _partner: &VehicleState) -> f32 {
    f32::INFINITY
}
pub fn tadv(_ego: &VehicleState, _partner: &VehicleState) -> f32 {
    f32::INFINITY
}
pub fn ei(_ego: &VehicleState, _partner: &VehicleState) -> f32 {
    f32::NEG_INFINITY
}

pub fn surrogates(ego: &VehicleState, partner: &VehicleState) -> Surrogates {
    Surrogates {
        box_distance: crate::geometry::box_distance(ego, partner),
        ttc2d: ttc2d(ego, partner),
        tadv: tadv(ego, partner),
        ei: ei(ego, partner),
    }
}
