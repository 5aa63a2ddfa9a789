//! The 13 observation features of an ego/partner pair, in model-input order.
//!
//! Ego `i`, partner `j`; `h_i` is the ego's unit heading, `v` velocities, `p` box centres. The
//! names are the published ones (also the golden file's columns), where `sur` is the partner.
//! The ego frame has `+y` along `h_i` and `+x` to the ego's right.
//!
//! | # | name       | definition                                                               |
//! |---|------------|--------------------------------------------------------------------------|
//! | 0 | `l_ego`    | ego length                                                               |
//! | 1 | `l_sur`    | partner length                                                           |
//! | 2 | `w_comb`   | `(w_i + w_j) / 2`                                                        |
//! | 3 | `vy_ego`   | ego speed `|v_i|` (the ego's velocity seen along its own heading axis)  |
//! | 4 | `vx_sur`   | partner velocity, ego frame x (to the right): `cross(v_j, h_i)`          |
//! | 5 | `vy_sur`   | partner velocity, ego frame y (ahead): `dot(v_j, h_i)`                   |
//! | 6 | `v_ego2`   | `|v_i|^2`                                                                |
//! | 7 | `v_sur2`   | `|v_j|^2`                                                                |
//! | 8 | `delta_v2` | `|v_i - v_j|^2`                                                          |
//! | 9 | `delta_v`  | `|v_i - v_j| * sign(v_ego2 - v_sur2)` (sign(0) = 0)                      |
//! |10 | `psi_sur`  | angle from `h_i` to `h_j`, counter-clockwise positive, in `[-pi, pi]`    |
//! |11 | `rho`      | `atan2(y', x')` of `p_j - p_i` in the frame whose `+y` is `v_i - v_j`    |
//! |   |            | (the ego heading when `v_i == v_j`), `+x` to its right                   |
//! |12 | `s`        | centre-to-centre distance `|p_j - p_i|` (m)                             |
//!
//! Always finite: a NaN feature becomes 0 and an infinite one `+-f32::MAX`, so a corrupt input
//! can never poison the network. A zero or non-finite ego heading is replaced by the world `+y`
//! axis, a partner's by the ego heading (`psi_sur = 0`); the host rejects such rows before they
//! get here.
use crate::geometry::{centre_distance, position, unit_heading, velocity, Vec2};
use crate::state::VehicleState;

/// Number of observation features.
pub const FEATURE_COUNT: usize = 13;

/// One observation in model-input order (see [`FEATURE_NAMES`]).
pub type Features = [f32; FEATURE_COUNT];

/// Feature names in model-input order (CSV columns use them with an `f_` prefix).
pub const FEATURE_NAMES: [&str; FEATURE_COUNT] = [
    "l_ego", "l_sur", "w_comb", "vy_ego", "vx_sur", "vy_sur", "v_ego2", "v_sur2", "delta_v2",
    "delta_v", "psi_sur", "rho", "s",
];

/// Index of `psi_sur`, the angle from the ego's heading to the partner's.
pub(crate) const PSI_SUR: usize = 10;

/// Coordinates of `v` in the frame whose `+y` is the unit vector `y_axis` and `+x` its right.
fn in_frame(y_axis: Vec2, v: Vec2) -> Vec2 {
    Vec2::new(v.cross(y_axis), v.dot(y_axis))
}

/// `-1`, `0` or `1`; 0 for zero and NaN.
fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// `values` with NaN replaced by 0 and infinities by the largest finite value of the same sign.
///
/// The clamp leaves NaN as it is and the NaN test comes after it, so each lane is a clamp and a
/// select: the compiler runs the loop four lanes at a time on x86-64 (a NaN test before the clamp
/// makes it a branch per value), and the Cortex-M4F executes as few instructions as with branches.
pub(crate) fn finite_or_clamped<const N: usize>(mut values: [f32; N]) -> [f32; N] {
    for v in &mut values {
        let clamped = v.clamp(-f32::MAX, f32::MAX);
        *v = if clamped.is_nan() { 0.0 } else { clamped };
    }
    values
}

/// The 13 features of the pair (`ego`, `partner`), see the module table.
pub fn features(ego: &VehicleState, partner: &VehicleState) -> Features {
    features_from(
        ego,
        unit_heading(ego),
        partner,
        unit_heading(partner),
        ego.speed(),
        centre_distance(ego, partner),
    )
}

/// [`features`] with the [`unit_heading`] of each state, the ego's speed and the centre distance
/// already computed (the surrogates read them too).
pub(crate) fn features_from(
    ego: &VehicleState,
    heading_ego: Option<Vec2>,
    partner: &VehicleState,
    heading_partner: Option<Vec2>,
    speed_ego: f32,
    distance: f32,
) -> Features {
    let heading_ego = heading_ego.unwrap_or(Vec2::new(0.0, 1.0));
    let heading_partner = heading_partner.unwrap_or(heading_ego);
    let v_ego = velocity(ego);
    let v_partner = velocity(partner);
    let dv = v_ego - v_partner;
    let dp = position(partner) - position(ego);

    let v_ego2 = v_ego.norm2();
    let v_partner2 = v_partner.norm2();
    let delta_v2 = dv.norm2();
    let dv_norm = dv.norm();
    let v_partner_ego_frame = in_frame(heading_ego, v_partner);
    let psi_partner = libm::atan2f(
        heading_ego.cross(heading_partner),
        heading_ego.dot(heading_partner),
    );
    let relative_axis = if dv_norm > 0.0 && dv_norm.is_finite() {
        dv.scale(1.0 / dv_norm)
    } else {
        heading_ego
    };
    let dp_relative = in_frame(relative_axis, dp);
    let rho = libm::atan2f(dp_relative.y, dp_relative.x);

    finite_or_clamped([
        ego.length,
        partner.length,
        (ego.width + partner.width) * 0.5,
        speed_ego,
        v_partner_ego_frame.x,
        v_partner_ego_frame.y,
        v_ego2,
        v_partner2,
        delta_v2,
        dv_norm * sign(v_ego2 - v_partner2),
        psi_partner,
        rho,
        distance,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partner_ahead_to_the_right_in_ego_frame() {
        // Ego heading north at 10 m/s; partner 10 m ahead, 5 m to the right (east), driving east.
        let ego = VehicleState {
            vy: 10.0,
            hy: 1.0,
            length: 4.0,
            width: 2.0,
            ..Default::default()
        };
        let partner = VehicleState {
            x: 5.0,
            y: 10.0,
            vx: 3.0,
            hx: 1.0,
            length: 5.0,
            width: 1.8,
            ..Default::default()
        };
        let f = features(&ego, &partner);
        assert_eq!(f[0], 4.0);
        assert_eq!(f[1], 5.0);
        assert!((f[2] - 1.9).abs() < 1e-6);
        assert!((f[3] - 10.0).abs() < 1e-6);
        assert!((f[4] - 3.0).abs() < 1e-6, "to the right is +x");
        assert!(f[5].abs() < 1e-6);
        assert!((f[8] - 109.0).abs() < 1e-4);
        assert!((f[9] - libm::sqrtf(109.0)).abs() < 1e-4);
        assert!(
            (f[10] + core::f32::consts::FRAC_PI_2).abs() < 1e-6,
            "east is clockwise"
        );
        assert!((f[12] - libm::sqrtf(125.0)).abs() < 1e-4);
    }

    #[test]
    fn garbage_in_gives_finite_features() {
        let bad = VehicleState {
            x: f32::NAN,
            vx: f32::INFINITY,
            hx: 0.0,
            hy: 0.0,
            length: f32::NEG_INFINITY,
            ..Default::default()
        };
        for f in features(&bad, &bad) {
            assert!(f.is_finite());
        }
    }
}
