//! The DRL input encoding: a versioned transform of one ego/partner pair into the network's inputs.
//!
//! The 13 reference features ([`crate::features()`]) are kept exactly as published (golden parity),
//! but two of them are poor network inputs: the centre distance `s` spends its range on far
//! partners and cannot tell contact from a close pass, and the angles `psi_sur` and `rho` jump by
//! `2 pi` where sideswipes and passes on the left happen. Encoding [`DRL_INPUT_ENCODING`] (= 3)
//! feeds the DRL network quantities that are continuous in the physical state and whose ratios
//! that matter for risk (gap over closing speed) become differences. It is computed from the two
//! states with vector algebra only (no `sinf`/`cosf`/`atan2f`: on a single-precision FPU `libm`
//! evaluates those in software `f64`).
//!
//! Notation: ego `i`, partner `j`; `h_i`, `h_j` unit headings (a zero or non-finite ego heading reads
//! as the world `+y`, a partner's as `h_i`, as in [`crate::features()`]); `dp = p_j - p_i` (centres),
//! `dv = v_i - v_j`, `s = |dp|`; `a . b` dot product, `a x b = a.x b.y - a.y b.x` (positive when
//! `b` is counter-clockwise of `a`). The ego frame has `+y` along `h_i` and `+x` to its right.
//!
//! | # | name          | definition                                                            |
//! |---|---------------|-----------------------------------------------------------------------|
//! | 0 | `tca`         | `slog(t_ca)`, `t_ca = (dp . dv) / |dv|^2` clamped to `[-MAX_TIME, MAX_TIME]`: time to closest approach at constant velocity (s, > 0 still approaching); `MAX_TIME` when `|dv| <= 0.1` m/s |
//! | 1 | `l_sur`       | partner length (m)                                                    |
//! | 2 | `w_comb`      | `(w_i + w_j) / 2` (m)                                                 |
//! | 3 | `v_ego`       | ego speed `|v_i|` (m/s)                                               |
//! | 4 | `vx_sur`      | partner velocity, ego frame, to the right: `v_j x h_i` (m/s)          |
//! | 5 | `vy_sur`      | partner velocity, ego frame, ahead: `v_j . h_i` (m/s)                 |
//! | 6 | `cos_psi`     | `h_i . h_j`: cosine of the partner's heading relative to the ego's    |
//! | 7 | `sin_psi`     | `h_i x h_j`: its sine (counter-clockwise positive)                    |
//! | 8 | `log_gap`     | `ln(0.5 + g)`, `g` the exact box-to-box distance in m ([`crate::box_distance`]), clamped to `[0, MAX_GAP]` (no box: `MAX_GAP`) |
//! | 9 | `closing`     | `slog(c)`, `c = (dp . dv) / s = -d|dp|/dt` (m/s, > 0 approaching; 0 when `s = 0`) |
//! |10 | `miss_gap`    | `ln(0.5 + clamp(|dp x dv| / |dv| - w_comb, 0, MAX_GAP))`: how far apart the centres pass at closest approach, less the combined half widths (m); `|dp x h_i|` across the ego heading when `dv = 0` |
//! |11 | `ahead`       | `slog(dp . h_i)`: partner centre ahead of the ego centre, ego frame (m) |
//! |12 | `right`       | `slog(dp x h_i)`: partner centre to the ego's right, ego frame (m)    |
//!
//! `slog(x) = sign(x) ln(1 + |x|)`: linear near 0, logarithmic far away, odd. Every input is a
//! continuous function of the two states wherever the relative velocity is not zero. Time to
//! closest approach and the miss gap are the constant-velocity prediction of where the pair is
//! heading; in log space their ratios with the gap and the closing speed are differences an MLP
//! forms easily. A NaN input becomes 0 and an infinite one `+-f32::MAX`.
//!
//! The inputs mean what encoding 2 meant (same names, same order, same units): encoding 2 derived
//! them from the features through `sin`/`cos` of `rho` and `psi_sur`, and inputs 11 and 12 through
//! the relative-velocity frame assuming no side slip; encoding 3 reads them off the states, exactly
//! (side slip included), and rounds differently. Square roots: `|v_i|`, `|dv|`, `s`, the two unit
//! headings and the box gap's one (`libm::sqrtf`, correctly rounded in software on every target).
//!
//! A model blob records the encoding its inputs need in the header's input-schema field
//! ([`crate::model::decode`] refuses a DRL blob of another encoding rather than score it with the
//! wrong inputs). Changing anything in this table means a new encoding number.
use crate::features::finite_or_clamped;
use crate::geometry::{box_distance_with_headings, position, unit_heading, velocity, Vec2};
use crate::state::VehicleState;

/// The DRL input encoding this build computes (the model header's input-schema id for DRL).
pub const DRL_INPUT_ENCODING: u16 = 3;

/// Number of DRL inputs.
pub const DRL_INPUT_COUNT: usize = 13;

/// One observation encoded for the DRL network (see the module table).
pub type DrlInputs = [f32; DRL_INPUT_COUNT];

/// Input names in network order.
pub const DRL_INPUT_NAMES: [&str; DRL_INPUT_COUNT] = [
    "tca", "l_sur", "w_comb", "v_ego", "vx_sur", "vy_sur", "cos_psi", "sin_psi", "log_gap",
    "closing", "miss_gap", "ahead", "right",
];

/// Indices (into [`DrlInputs`]) of the inputs other modules read by name: the geometry cell
/// ([`crate::geometry_cell`]) reads the relative heading, the gap and the partner's offsets.
pub(crate) const COS_PSI: usize = 6;
pub(crate) const SIN_PSI: usize = 7;
pub(crate) const LOG_GAP: usize = 8;
pub(crate) const AHEAD: usize = 11;
pub(crate) const RIGHT: usize = 12;

/// Largest box gap the encoding distinguishes (m); farther (or no box at all) reads as this.
pub const MAX_GAP: f32 = 1000.0;
/// Largest time to closest approach the encoding distinguishes (s).
pub const MAX_TIME: f32 = 100.0;
/// Relative speed (m/s) at or below which the time to closest approach reads as [`MAX_TIME`].
pub const MIN_RELATIVE_SPEED: f32 = 0.1;

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

/// The DRL inputs of the pair (`ego`, `partner`), see the module table. Always finite.
pub fn drl_inputs(ego: &VehicleState, partner: &VehicleState) -> DrlInputs {
    let (hi, hj) = (unit_heading(ego), unit_heading(partner));
    let gap = box_distance_with_headings(ego, hi, partner, hj);
    encode(ego, hi, partner, hj, gap)
}

/// [`drl_inputs`] with the [`unit_heading`] of each state and the pair's box distance already
/// computed (it must be [`crate::box_distance`]`(ego, partner)`: [`crate::Observation::of`]
/// shares the surrogates').
pub(crate) fn encode(
    ego: &VehicleState,
    heading_ego: Option<Vec2>,
    partner: &VehicleState,
    heading_partner: Option<Vec2>,
    box_distance: f32,
) -> DrlInputs {
    let hi = heading_ego.unwrap_or(Vec2::new(0.0, 1.0));
    let hj = heading_partner.unwrap_or(hi);
    let (v_ego, v_partner) = (velocity(ego), velocity(partner));
    let dp = position(partner) - position(ego);
    let dv = v_ego - v_partner;
    let s = dp.norm();
    let dv_norm = dv.norm();
    let w_comb = (ego.width + partner.width) * 0.5;

    // Constant-velocity closest approach: when (> 0: ahead in time), how fast the centres close in,
    // and how far apart they pass, across the relative velocity.
    let along = dp.dot(dv);
    let tca = if dv_norm > MIN_RELATIVE_SPEED {
        (along / dv.norm2()).clamp(-MAX_TIME, MAX_TIME)
    } else {
        MAX_TIME
    };
    let closing = if s > 0.0 { along / s } else { 0.0 };
    let across = if dv_norm > 0.0 && dv_norm.is_finite() {
        dp.cross(dv) / dv_norm
    } else {
        dp.cross(hi)
    };
    let miss_gap = (libm::fabsf(across) - w_comb).max(0.0);
    finite_or_clamped([
        slog(tca),
        partner.length,
        w_comb,
        v_ego.norm(),
        v_partner.cross(hi),
        v_partner.dot(hi),
        hi.dot(hj),
        hi.cross(hj),
        log_gap(box_distance),
        slog(closing),
        log_gap(miss_gap),
        slog(dp.dot(hi)),
        slog(dp.cross(hi)),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_named_indices_are_the_table_s() {
        for (index, name) in [
            (COS_PSI, "cos_psi"),
            (SIN_PSI, "sin_psi"),
            (LOG_GAP, "log_gap"),
            (AHEAD, "ahead"),
            (RIGHT, "right"),
        ] {
            assert_eq!(DRL_INPUT_NAMES[index], name);
        }
    }

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
        drl_inputs(ego, partner)
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
    /// Encoding 2, kept as the definition encoding 3 must keep: the same inputs derived from the
    /// features (`rho`, `psi_sur`) through sin/cos, assuming no side slip.
    fn encoding_2(ego: &VehicleState, partner: &VehicleState) -> DrlInputs {
        let f = crate::features(ego, partner);
        let [_, l_partner, w_comb, v_ego, vx_partner, vy_partner, _, _, _, delta_v, psi, rho, s] =
            f;
        let dv_norm = delta_v.abs();
        let (sin_rho, cos_rho) = (libm::sinf(rho), libm::cosf(rho));
        let (ax, ay) = {
            let (dx, dy) = (-vx_partner, v_ego - vy_partner);
            let n = libm::sqrtf(dx * dx + dy * dy);
            if dv_norm > 0.0 && n > 0.0 {
                (dx / n, dy / n)
            } else {
                (0.0, 1.0)
            }
        };
        let (xr, yr) = (s * cos_rho, s * sin_rho);
        let tca = if dv_norm > 0.1 {
            (s * sin_rho / dv_norm).clamp(-MAX_TIME, MAX_TIME)
        } else {
            MAX_TIME
        };
        [
            slog(tca),
            l_partner,
            w_comb,
            v_ego,
            vx_partner,
            vy_partner,
            libm::cosf(psi),
            libm::sinf(psi),
            log_gap(crate::box_distance(ego, partner)),
            slog(dv_norm * sin_rho),
            log_gap((s * libm::fabsf(cos_rho) - w_comb).max(0.0)),
            slog(-xr * ax + yr * ay),
            slog(xr * ay + yr * ax),
        ]
    }

    use proptest::prelude::*;

    /// A road user driving forward along its heading (what encoding 2 assumed: no side slip, no
    /// reversing).
    fn no_slip() -> impl Strategy<Value = VehicleState> {
        (
            (-80.0f32..80.0, -80.0f32..80.0),
            -3.2f32..3.2,
            prop_oneof![1 => Just(0.0f32), 4 => 0.0f32..40.0],
            (2.0f32..18.0, 1.5f32..2.6),
        )
            .prop_map(|((x, y), angle, speed, (length, width))| {
                let (hx, hy) = (libm::cosf(angle), libm::sinf(angle));
                VehicleState {
                    x,
                    y,
                    vx: speed * hx,
                    vy: speed * hy,
                    hx,
                    hy,
                    length,
                    width,
                    ..Default::default()
                }
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(5_000))]

        /// Encoding 3 computes what encoding 2 meant, input by input, wherever encoding 2's
        /// no-side-slip assumption holds (away from the `|dv| = 0.1` switch of `tca`).
        #[test]
        fn encoding_3_means_what_encoding_2_meant(ego in no_slip(), partner in no_slip()) {
            let dv = crate::geometry::velocity(&ego) - crate::geometry::velocity(&partner);
            prop_assume!((dv.norm() - MIN_RELATIVE_SPEED).abs() > 1e-3);
            let new = drl_inputs(&ego, &partner);
            let old = encoding_2(&ego, &partner);
            for k in 0..DRL_INPUT_COUNT {
                prop_assert!(
                    (new[k] - old[k]).abs() <= 2e-3 * (1.0 + old[k].abs()),
                    "input {} ({}): encoding 3 {} vs encoding 2 {}",
                    k, DRL_INPUT_NAMES[k], new[k], old[k]
                );
            }
        }
    }

    #[test]
    fn side_slip_is_read_off_the_states() {
        // A partner 10 m ahead and 2 m to the right whose velocity is not along the ego heading:
        // the ego-frame offsets are exact, whatever the velocities.
        let mut ego = car(0.0, 0.0, 3.0, 20.0, 0.0, 1.0);
        ego.hx = 0.0;
        let p = car(2.0, 10.0, -1.0, 15.0, 0.0, 1.0);
        let x = encode(&ego, &p);
        assert!((x[11] - libm::log1pf(10.0)).abs() < 1e-5, "ahead {}", x[11]);
        assert!((x[12] - libm::log1pf(2.0)).abs() < 1e-5, "right {}", x[12]);
    }
}
