//! The DRL input encoding: a versioned transform of one observation into the network's inputs.
//!
//! The 13 reference features ([`crate::features()`]) are kept exactly as published (golden parity),
//! but two of them are poor network inputs: the centre distance `s` spends its range on far
//! partners and cannot tell contact from a close pass, and the angles `psi_sur` and `rho` jump by
//! `2 pi` where sideswipes and passes on the left happen. Encoding [`DRL_INPUT_ENCODING`] (= 2)
//! feeds the DRL network quantities that are continuous in the physical state and whose ratios
//! that matter for risk (gap over closing speed) become differences:
//!
//! | # | name          | definition                                                            |
//! |---|---------------|-----------------------------------------------------------------------|
//! | 0 | `tca`         | `slog(t_ca)`: time to closest approach at constant velocity, `s sin(rho) / |v_i - v_j|` (s, > 0 still approaching; `MAX_TIME` when `|v_i - v_j| <= 0.1` m/s) |
//! | 1 | `l_sur`       | partner length (m)                                                    |
//! | 2 | `w_comb`      | `(w_i + w_j) / 2` (m)                                                 |
//! | 3 | `v_ego`       | ego speed `|v_i|` (m/s)                                               |
//! | 4 | `vx_sur`      | partner velocity, ego frame, to the right (m/s)                       |
//! | 5 | `vy_sur`      | partner velocity, ego frame, ahead (m/s)                              |
//! | 6 | `cos_psi`     | cosine of the partner's heading relative to the ego's                 |
//! | 7 | `sin_psi`     | sine of the same angle (counter-clockwise positive)                   |
//! | 8 | `log_gap`     | `ln(0.5 + g)`, `g` the exact box-to-box distance in m, clamped to `[0, 1000]` |
//! | 9 | `closing`     | `slog(c)`, `c = -d|p_j - p_i|/dt = |v_i - v_j| sin(rho)` (m/s, > 0 approaching) |
//! |10 | `miss_gap`    | `ln(0.5 + max(0, s |cos(rho)| - w_comb))`: how far apart the centres pass at closest approach, less the combined half widths (m) |
//! |11 | `ahead`       | `slog(dy)`: partner centre ahead of the ego centre, ego frame (m)     |
//! |12 | `right`       | `slog(dx)`: partner centre to the ego's right, ego frame (m)          |
//!
//! `slog(x) = sign(x) ln(1 + |x|)`: linear near 0, logarithmic far away, odd. Every input is a
//! continuous function of the two states wherever the relative velocity is not zero (`s sin(rho)`
//! and `s cos(rho)` are the partner's offsets along and across the relative velocity, and
//! `|v_i - v_j| sin(rho)` the relative velocity along the line of sight). Time to closest approach
//! and the miss gap are the constant-velocity prediction of where the pair is heading; in log
//! space their ratios with the gap and the closing speed are differences an MLP forms easily.
//!
//! Inputs 11 and 12 are recovered from the features: `(x', y') = s (cos rho, sin rho)` are the
//! partner's coordinates in the frame whose `+y` is `v_i - v_j`, and that axis is expressed in the
//! ego frame assuming the ego's velocity lies along its heading (no side slip; exact for every
//! data source riskscore reads, which all give the ego speed along its heading).
//!
//! A model blob records the encoding its inputs need in the header's input-schema field
//! ([`crate::model::decode`] refuses a DRL blob of another encoding rather than score it with the
//! wrong inputs). Changing anything in this table means a new encoding number.
use crate::features::{features, Features, FEATURE_COUNT};
use crate::geometry::box_distance;
use crate::state::VehicleState;

/// The DRL input encoding this build computes (the model header's input-schema id for DRL).
pub const DRL_INPUT_ENCODING: u16 = 2;

/// Number of DRL inputs.
pub const DRL_INPUT_COUNT: usize = 13;

/// One observation encoded for the DRL network (see the module table).
pub type DrlInputs = [f32; DRL_INPUT_COUNT];

/// Input names in network order.
pub const DRL_INPUT_NAMES: [&str; DRL_INPUT_COUNT] = [
    "tca", "l_sur", "w_comb", "v_ego", "vx_sur", "vy_sur", "cos_psi", "sin_psi", "log_gap",
    "closing", "miss_gap", "ahead", "right",
];

/// Largest box gap the encoding distinguishes (m); farther (or no box at all) reads as this.
pub const MAX_GAP: f32 = 1000.0;
/// Largest time to closest approach the encoding distinguishes (s).
pub const MAX_TIME: f32 = 100.0;

// The encoding reuses the feature indices of the reference table.
const _: () = assert!(FEATURE_COUNT == 13);

/// `sign(x) ln(1 + |x|)`; 0 for NaN.
pub fn slog(x: f32) -> f32 {
    if x.is_nan() {
        0.0
    } else if x < 0.0 {
        -libm::log1pf(-x)
    } else {
        libm::log1pf(x)
    }
}

/// `ln(0.5 + g)` of a box gap `g` clamped to `[0, MAX_GAP]` (NaN and infinity read as far).
pub fn log_gap(box_distance: f32) -> f32 {
    let g = if box_distance.is_nan() {
        MAX_GAP
    } else {
        box_distance.clamp(0.0, MAX_GAP)
    };
    libm::logf(0.5 + g)
}

/// The DRL inputs of one observation: its 13 features and the exact box distance (both as computed
/// by [`crate::features()`] and [`crate::box_distance`]). Always finite.
pub fn drl_inputs(f: &Features, box_distance: f32) -> DrlInputs {
    let [_l_ego, l_sur, w_comb, v_ego, vx_sur, vy_sur, _, _, _, delta_v, psi, rho, s] = *f;
    let dv_norm = delta_v.abs();
    let (sin_rho, cos_rho) = (libm::sinf(rho), libm::cosf(rho));

    // The relative-velocity axis in the ego frame (x right, y ahead), as `features` chose it.
    let (ax, ay) = {
        let (dx, dy) = (-vx_sur, v_ego - vy_sur);
        let n = libm::sqrtf(dx * dx + dy * dy);
        if dv_norm > 0.0 && n > 0.0 && n.is_finite() {
            (dx / n, dy / n)
        } else {
            (0.0, 1.0)
        }
    };
    let (xr, yr) = (s * cos_rho, s * sin_rho);
    let right = xr * ay + yr * ax;
    let ahead = -xr * ax + yr * ay;

    // Constant-velocity closest approach: when (> 0: ahead in time) and how far apart the centres
    // pass, across the line of sight.
    let closing = dv_norm * sin_rho;
    let tca = if dv_norm > 0.1 {
        (s * sin_rho / dv_norm).clamp(-MAX_TIME, MAX_TIME)
    } else {
        MAX_TIME
    };
    let miss_gap = (s * libm::fabsf(cos_rho) - w_comb).max(0.0);
    [
        slog(tca),
        l_sur,
        w_comb,
        v_ego,
        vx_sur,
        vy_sur,
        libm::cosf(psi),
        libm::sinf(psi),
        log_gap(box_distance),
        slog(closing),
        log_gap(miss_gap),
        slog(ahead),
        slog(right),
    ]
    .map(|x| {
        if x.is_nan() {
            0.0
        } else {
            x.clamp(-f32::MAX, f32::MAX)
        }
    })
}

/// [`drl_inputs`] of an ego/partner pair, computing its features and box distance.
pub fn drl_inputs_of_pair(ego: &VehicleState, partner: &VehicleState) -> DrlInputs {
    drl_inputs(&features(ego, partner), box_distance(ego, partner))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn car(x: f32, y: f32, vx: f32, vy: f32, hx: f32, hy: f32) -> VehicleState {
        VehicleState {
            x,
            y,
            vx,
            vy,
            hx,
            hy,
            length: 4.5,
            width: 1.8,
            ..Default::default()
        }
    }

    fn encode(ego: &VehicleState, partner: &VehicleState) -> DrlInputs {
        drl_inputs_of_pair(ego, partner)
    }

    #[test]
    fn lead_vehicle_closing_in() {
        // Ego north at 20 m/s, a lead car 30 m ahead at 10 m/s: closing at 10 m/s, gap 25.5 m.
        let ego = car(0.0, 0.0, 0.0, 20.0, 0.0, 1.0);
        let lead = car(0.0, 30.0, 0.0, 10.0, 0.0, 1.0);
        let x = encode(&ego, &lead);
        assert!((x[0] - libm::log1pf(3.0)).abs() < 1e-5, "tca {}", x[0]);
        assert!((x[6] - 1.0).abs() < 1e-6 && x[7].abs() < 1e-6);
        assert!((x[8] - libm::logf(0.5 + 25.5)).abs() < 1e-5);
        assert!((x[9] - libm::log1pf(10.0)).abs() < 1e-5, "closing {}", x[9]);
        assert!(
            (x[10] - libm::logf(0.5)).abs() < 1e-5,
            "on collision course: miss gap 0"
        );
        assert!((x[11] - libm::log1pf(30.0)).abs() < 1e-4, "ahead {}", x[11]);
        assert!(x[12].abs() < 1e-4, "right {}", x[12]);
    }

    #[test]
    fn partner_behind_on_the_left_falling_back() {
        // Ego north at 25 m/s; partner 3.5 m to the left, 3 m behind, at 20 m/s: opening.
        let ego = car(0.0, 0.0, 0.0, 25.0, 0.0, 1.0);
        let p = car(-3.5, -3.0, 0.0, 20.0, 0.0, 1.0);
        let x = encode(&ego, &p);
        assert!(
            x[9] < 0.0,
            "opening must read as negative closing: {}",
            x[9]
        );
        assert!(x[0] < 0.0, "closest approach is in the past: {}", x[0]);
        // Parallel paths 3.5 m apart: the centres pass at 3.5 m, 1.7 m between the boxes.
        assert!(
            (x[10] - libm::logf(0.5 + 1.7)).abs() < 1e-3,
            "miss {}",
            x[10]
        );
        assert!((x[11] + libm::log1pf(3.0)).abs() < 1e-4, "ahead {}", x[11]);
        assert!((x[12] + libm::log1pf(3.5)).abs() < 1e-4, "right {}", x[12]);
    }

    #[test]
    fn continuous_where_rho_wraps() {
        // Moving the partner across the rear/left line where rho passes +-pi must not jump.
        let ego = car(0.0, 0.0, 0.0, 25.0, 0.0, 1.0);
        let a = encode(&ego, &car(-3.5, -0.001, 0.0, 30.0, 0.0, 1.0));
        let b = encode(&ego, &car(-3.5, 0.001, 0.0, 30.0, 0.0, 1.0));
        for k in 0..DRL_INPUT_COUNT {
            assert!(
                (a[k] - b[k]).abs() < 1e-2,
                "input {k}: {} vs {}",
                a[k],
                b[k]
            );
        }
    }

    #[test]
    fn garbage_in_gives_finite_inputs() {
        let bad = VehicleState {
            x: f32::NAN,
            vx: f32::INFINITY,
            length: f32::NEG_INFINITY,
            ..Default::default()
        };
        for v in encode(&bad, &bad) {
            assert!(v.is_finite());
        }
        assert_eq!(log_gap(f32::INFINITY), libm::logf(0.5 + MAX_GAP));
        assert_eq!(slog(f32::NAN), 0.0);
    }
}
