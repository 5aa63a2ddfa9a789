//! Time advantage (Laureshyn et al. 2010, <https://doi.org/10.1016/j.aap.2010.03.021>), with the
//! conventions of the reference implementation (Jiao, "SSMsOnPlane").
//!
//! Crossing motion: for each of the 16 (ego corner `a`, partner corner `b`) pairs, the rays
//! `a + t v_i` and `b + u v_j` meet where
//!
//! ```text
//! t = cross(b - a, v_j) / cross(v_i, v_j),   u = cross(b - a, v_i) / cross(v_i, v_j)
//! ```
//!
//! and the pair's time advantage is `|t - u|` when the point lies ahead of both (`t, u >= 0`),
//! else `+inf`. TAdv is the minimum over the 16 pairs.
//!
//! Near-parallel motion (angle between `v_i` and `v_j` below 3 deg or above 177 deg, or a vehicle
//! standing still) falls back to `D / dv`: `D` the exact box distance, and `dv` a signed speed
//! difference `|v_i| - |v_j|` (ego behind), `|v_j| - |v_i|` (partner behind, same direction) or
//! `|v_i| + |v_j|` (opposite directions, judged along the ego heading), kept at `|dv| >= 1e-6`.
//! A negative result (the gap opens) is `+inf`; two stopped vehicles give `D / 1e-6`, about 1e7 s.
use super::angle::{line_angle_within, TangentBand};
use super::guard::clamp_away_from_zero;
use crate::geometry::{velocity, BoxPair, OrientedBox, Speeds};
use crate::state::VehicleState;

/// 3 degrees: below it (or above 177 degrees) the paths are treated as parallel.
const PARALLEL_ANGLE: f32 = core::f32::consts::PI / 60.0;
/// 177 degrees.
const ANTIPARALLEL_ANGLE: f32 = core::f32::consts::PI * 59.0 / 60.0;
/// Around `tan(3 deg) = 0.05241`.
const PARALLEL_TANGENTS: TangentBand = TangentBand {
    below: 0.0512,
    above: 0.0536,
};
/// Speeds below this divide as if they were this (the reference's zero-division guard).
const MIN_SPEED: f32 = 1e-6;

/// Time advantage (s) of the pair; `f32::INFINITY` = no conflict.
///
/// Non-finite inputs or a zero heading give `f32::INFINITY`.
pub fn tadv(ego: &VehicleState, partner: &VehicleState) -> f32 {
    let (Some(bi), Some(bj)) = (OrientedBox::of(ego), OrientedBox::of(partner)) else {
        return f32::INFINITY;
    };
    let boxes = BoxPair::new(&bi, &bj);
    tadv_of_pair(&boxes, ego, partner, Speeds::of(ego, partner), || {
        boxes.gap()
    })
}

/// [`tadv`] of two states whose boxes are `boxes.a` (ego) and `boxes.b` (partner); `gap` gives
/// their [`BoxPair::gap`] (asked for near-parallel motion only, so a caller that has it already
/// passes it instead of measuring twice).
pub(super) fn tadv_of_pair(
    boxes: &BoxPair,
    ego: &VehicleState,
    partner: &VehicleState,
    speeds: Speeds,
    gap: impl FnOnce() -> f32,
) -> f32 {
    let v_i = velocity(ego);
    let v_j = velocity(partner);

    let cross = v_i.cross(v_j);
    let dot = v_i.dot(v_j);
    let parallel = cross == 0.0
        || line_angle_within(PARALLEL_TANGENTS, cross, dot).unwrap_or_else(|| {
            let angle = libm::atan2f(cross, dot).abs();
            !(PARALLEL_ANGLE..=ANTIPARALLEL_ANGLE).contains(&angle)
        });

    let result = if parallel {
        parallel_fallback(boxes, partner, speeds, gap())
    } else {
        crossing_time_advantage(boxes, ego, partner, speeds, cross)
    };
    if result.is_nan() {
        f32::INFINITY
    } else {
        result
    }
}

/// The box distance `gap` over the signed speed difference (see the module doc). A NaN gap
/// (which [`BoxPair::gap`] reports as `+inf`) ends as `+inf` either way: NaN and `+-inf` over
/// any speed are NaN, `+inf` or negative, all "no conflict".
fn parallel_fallback(boxes: &BoxPair, partner: &VehicleState, speeds: Speeds, gap: f32) -> f32 {
    // The partner's centre along the ego's heading.
    let partner_behind = boxes.b_in_a.0 < 0.0;
    let partner_forward = velocity(partner).dot(boxes.a.axis);
    let (speed_i, speed_j) = (speeds.ego, speeds.partner);
    let closing = if partner_forward < 0.0 {
        speed_i + speed_j
    } else if partner_behind {
        speed_j - speed_i
    } else {
        speed_i - speed_j
    };
    let ttc = gap / clamp_away_from_zero(closing);
    if ttc < 0.0 {
        f32::INFINITY
    } else {
        ttc
    }
}

/// Minimum over the 16 corner pairs of the arrival-time difference at their path crossing.
fn crossing_time_advantage(
    boxes: &BoxPair,
    ego: &VehicleState,
    partner: &VehicleState,
    speeds: Speeds,
    cross: f32,
) -> f32 {
    let v_i = velocity(ego);
    let v_j = velocity(partner);
    let (speed_i, speed_j) = (speeds.ego, speeds.partner);
    // Time to travel distance `t * |v|` at the guarded speed, as the reference does.
    let time_i = |t: f32| t * speed_i / speed_i.max(MIN_SPEED);
    let time_j = |u: f32| u * speed_j / speed_j.max(MIN_SPEED);
    let mut best = f32::INFINITY;
    let corners_j = boxes.b.corners();
    for a in boxes.a.corners() {
        for b in corners_j {
            let ab = b - a;
            let t = ab.cross(v_j) / cross;
            let u = ab.cross(v_i) / cross;
            if t >= 0.0 && u >= 0.0 {
                best = best.min((time_i(t) - time_j(u)).abs());
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::surrogates::test_car as car;

    #[test]
    fn right_angle_crossing_is_smallest_corner_arrival_difference() {
        // Ego eastbound at 10 m/s from x = -30; partner northbound at 10 m/s from y = -20.
        // Corner pair (front-left of ego, front-right of partner) ... the minimum over corners.
        let ego = car(-30.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        let partner = car(0.0, -20.0, 0.0, 10.0, 0.0, 1.0);
        let t = tadv(&ego, &partner);
        // Brute force over the same 16 corner rays in f64.
        let ci = [(-28.0, 1.0), (-28.0, -1.0), (-32.0, 1.0), (-32.0, -1.0)];
        let cj = [(-1.0, -18.0), (1.0, -18.0), (-1.0, -22.0), (1.0, -22.0)];
        let mut best = f64::INFINITY;
        for (ax, ay) in ci {
            for (bx, by) in cj {
                // ego ray is horizontal y = ay, partner ray vertical x = bx
                let ti: f64 = (bx - ax) / 10.0;
                let tj: f64 = (ay - by) / 10.0;
                if ti >= 0.0 && tj >= 0.0 {
                    best = best.min((ti - tj).abs());
                }
            }
        }
        assert!((t as f64 - best).abs() < 1e-5, "{t} vs {best}");
    }

    #[test]
    fn parallel_following_uses_box_gap_over_speed_difference() {
        let ego = car(0.0, 0.0, 20.0, 0.0, 1.0, 0.0);
        let lead = car(30.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        assert!((tadv(&ego, &lead) - 2.6).abs() < 1e-5);
        // Partner behind and faster: it closes in on the ego.
        let chaser = car(-30.0, 0.0, 30.0, 0.0, 1.0, 0.0);
        assert!((tadv(&ego, &chaser) - 2.6).abs() < 1e-5);
        // Leader pulling away.
        let away = car(30.0, 0.0, 30.0, 0.0, 1.0, 0.0);
        assert_eq!(tadv(&ego, &away), f32::INFINITY);
    }

    #[test]
    fn both_stopped_gives_huge_finite_value() {
        let a = car(0.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        let b = car(14.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        let t = tadv(&a, &b);
        assert!((t - 1.0e7).abs() < 10.0, "{t}");
    }

    #[test]
    fn diverging_paths_are_no_conflict() {
        let ego = car(0.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        let partner = car(0.0, -20.0, 0.0, -10.0, 0.0, -1.0);
        assert_eq!(tadv(&ego, &partner), f32::INFINITY);
    }
}
