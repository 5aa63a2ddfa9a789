//! Emergency index (Cheng et al., reference code github.com/AutoChengh/EmergencyIndex, as adapted
//! by Jiao for GSSM), with `D_safe = 0` and no range filter.
//!
//! Each vehicle moves with its speed `|v| = |(vx, vy)|` along its unit heading `h` (not with
//! `(vx, vy)`). With `d = p_j - p_i` and `u = |v_j| h_j - |v_i| h_i`:
//!
//! ```text
//! closing   = -dot(d / |d|, u)                    (0 when d = 0), rounded to 2 decimals
//! conflict  = closing > 0 and (paths cross ahead of both boxes or near-parallel overlap)
//! theta     = u / |u|
//! TDM       = -dot(d, theta) / |u|                  (time to the closest approach)
//! InDepth   = D_safe - (|cross(d, theta)| - r_i - r_j),
//!             r = length/2 |cross(h, theta)| + width/2 |dot(h, theta)|  (half extent across theta)
//! EI        = InDepth / TDM                         (-inf when there is no conflict)
//! ```
//!
//! "Paths cross": the heading lines meet at `P = p_i + t h_i` and, widened by the crossing-zone
//! extents `width / |sin(dh)|`, the zone is ahead of each vehicle's rear. "Near-parallel overlap": the
//! headings differ by at most `gamma = 0.01396` rad modulo pi, the boxes overlap laterally, and one
//! is ahead of the other (or they overlap longitudinally by the reference's rotated-axis test).
use super::angle::{line_angle_within, TangentBand};
use crate::geometry::{BoxPair, OrientedBox, Speeds, Vec2};
use crate::state::VehicleState;
use core::f32::consts::PI;

/// Near-parallel tolerance (rad), the reference's default (0.8 degrees).
const GAMMA: f32 = 0.01396;
/// Around `tan(GAMMA) = 0.013961`.
const GAMMA_TANGENTS: TangentBand = TangentBand {
    below: 0.0136,
    above: 0.0143,
};
/// The safety margin of the index; 0 = the bare vehicle boxes.
const D_SAFE: f32 = 0.0;

/// One vehicle as the EI reference sees it: unit heading, speed, size.
struct Mover {
    h: Vec2,
    speed: f32,
    length: f32,
    width: f32,
}

impl Mover {
    fn new(b: &OrientedBox, s: &VehicleState, speed: f32) -> Self {
        Self {
            h: b.axis,
            speed,
            length: s.length,
            width: s.width,
        }
    }

    /// Half extent of the box across the unit direction `theta`.
    fn half_extent_across(&self, theta: Vec2) -> f32 {
        0.5 * self.length * self.h.cross(theta).abs() + 0.5 * self.width * self.h.dot(theta).abs()
    }
}

/// True when `closing` (m/s) rounds to a positive value at 2 decimals (half to even: 0.005 -> 0).
fn closing_after_rounding(closing: f32) -> bool {
    closing * 100.0 > 0.5
}

/// The headings are parallel or anti-parallel within `GAMMA` (the heading difference modulo pi).
/// `heading_angle` gives the signed angle from the ego's heading to the partner's,
/// `atan2(sin, cos)` of `boxes` (asked only when the tangent does not settle it).
///
/// The reference compares `dh = psi_j - psi_i` (each from `atan2`, so `dh` is in `[-2 pi, 2 pi]`)
/// with 0 and +-pi; it misses the `+-2 pi` wrap for two vehicles heading almost exactly west
/// (one at `+pi - e`, the other at `-pi + e`). Folding the signed angle between the headings
/// gives the same answer everywhere else and the physically right one there.
fn near_parallel(boxes: &BoxPair, heading_angle: impl FnOnce() -> f32) -> bool {
    line_angle_within(GAMMA_TANGENTS, boxes.sin, boxes.cos).unwrap_or_else(|| {
        let dh = heading_angle().abs(); // in [0, pi]
        dh <= GAMMA || PI - dh <= GAMMA
    })
}

/// The two heading lines cross in a zone that lies ahead of both vehicles' rears.
fn paths_cross(a: &Mover, b: &Mover, boxes: &BoxPair) -> bool {
    let sin_dh = boxes.sin;
    if sin_dh == 0.0 {
        // Exactly parallel lines never meet. (The reference's arithmetic yields NaN or +-inf
        // here depending on float64 rounding of sin/cos; near-parallel pairs are judged by
        // `parallel_overlap` instead.)
        return false;
    }
    let cos_dh = boxes.cos;
    let d = boxes.b.center;
    let t_a = d.cross(b.h) / sin_dh; // P = p_a + t_a h_a
    let s_b = t_a * cos_dh - d.dot(b.h); // P = p_b + s_b h_b
    let zone_a = a.width / sin_dh.abs(); // extent of the crossing zone along b's heading
    let zone_b = b.width / sin_dh.abs(); // ... along a's heading
    let ahead_a = t_a + 0.5 * a.length + 0.5 * zone_b + 0.5 * zone_a * cos_dh.abs() > 0.0;
    let ahead_b = s_b + 0.5 * b.length + 0.5 * zone_b * cos_dh.abs() + 0.5 * zone_a > 0.0;
    ahead_a && ahead_b
}

/// Near-parallel configuration with lateral overlap, per the reference's test (including its
/// `dx cos - dy sin` longitudinal term).
fn parallel_overlap(a: &Mover, b: &Mover, boxes: &BoxPair) -> bool {
    let d = boxes.b.center;
    let (cos_a, sin_a) = (a.h.x, a.h.y);
    // Each centre along the other's heading.
    let b_ahead_of_a = boxes.b_in_a.0 >= 0.0;
    let a_ahead_of_b = boxes.a_in_b.0 >= 0.0;
    let lon_overlap = (d.x * cos_a - d.y * sin_a).abs() - 0.5 * (a.length + b.length) <= 0.0;
    let lat_overlap = (d.x * sin_a - d.y * cos_a).abs() - 0.5 * (a.width + b.width) <= 0.0;
    (b_ahead_of_a || a_ahead_of_b || lon_overlap) && lat_overlap
}

/// Emergency index (m/s) of the pair; `f32::NEG_INFINITY` = no conflict. Larger is riskier.
///
/// Non-finite inputs or a zero heading give `f32::NEG_INFINITY`; the result is never NaN or `+inf`
/// (an overflowing value is clamped to `f32::MAX`).
pub fn ei(ego: &VehicleState, partner: &VehicleState) -> f32 {
    let (Some(bi), Some(bj)) = (OrientedBox::of(ego), OrientedBox::of(partner)) else {
        return f32::NEG_INFINITY;
    };
    let boxes = BoxPair::new(&bi, &bj);
    let distance = boxes.b.center.norm();
    ei_of_pair(
        &boxes,
        ego,
        partner,
        Speeds::of(ego, partner),
        distance,
        || libm::atan2f(boxes.sin, boxes.cos),
    )
}

/// [`ei`] of two states whose boxes are `boxes.a` (ego) and `boxes.b` (partner), with their
/// `speeds` and centre `distance`; `heading_angle` gives `atan2(boxes.sin, boxes.cos)` when it
/// is needed (a caller that has it passes it instead of computing it twice).
pub(super) fn ei_of_pair(
    boxes: &BoxPair,
    ego: &VehicleState,
    partner: &VehicleState,
    speeds: Speeds,
    distance: f32,
    heading_angle: impl FnOnce() -> f32,
) -> f32 {
    let a = Mover::new(&boxes.a, ego, speeds.ego);
    let b = Mover::new(&boxes.b, partner, speeds.partner);
    let d = boxes.b.center;
    let u = b.h.scale(b.speed) - a.h.scale(a.speed);
    let closing = if distance != 0.0 {
        -d.dot(u) / distance
    } else {
        0.0
    };
    if !closing_after_rounding(closing) {
        return f32::NEG_INFINITY;
    }
    let conflict = paths_cross(&a, &b, boxes)
        || (near_parallel(boxes, heading_angle) && parallel_overlap(&a, &b, boxes));
    if !conflict {
        return f32::NEG_INFINITY;
    }
    let u_norm = u.norm();
    let theta = u.scale(1.0 / u_norm);
    let tdm = -d.dot(theta) / u_norm;
    let miss_distance = d.cross(theta).abs();
    let min_future_distance =
        miss_distance - (a.half_extent_across(theta) + b.half_extent_across(theta));
    let in_depth = D_SAFE - min_future_distance;
    let ei = in_depth / tdm;
    if ei.is_nan() {
        f32::NEG_INFINITY
    } else {
        ei.min(f32::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn car(x: f32, y: f32, speed: f32, hx: f32, hy: f32) -> VehicleState {
        VehicleState {
            x,
            y,
            vx: speed * hx,
            vy: speed * hy,
            hx,
            hy,
            acc: 0.0,
            length: 4.0,
            width: 2.0,
        }
    }

    #[test]
    fn head_on_rear_end_geometry() {
        // Ego at 20 m/s behind a stopped car 30 m ahead in the same lane: the boxes will overlap
        // fully across theta, InDepth = r_i + r_j = 1 + 1, TDM = 30 / 20.
        let ego = car(0.0, 0.0, 20.0, 1.0, 0.0);
        let stopped = car(30.0, 0.0, 0.0, 1.0, 0.0);
        let e = ei(&ego, &stopped);
        assert!((e - 2.0 / 1.5).abs() < 1e-5, "{e}");
    }

    #[test]
    fn opening_gap_is_no_conflict() {
        let ego = car(0.0, 0.0, 10.0, 1.0, 0.0);
        let lead = car(30.0, 0.0, 20.0, 1.0, 0.0);
        assert_eq!(ei(&ego, &lead), f32::NEG_INFINITY);
    }

    #[test]
    fn closing_speed_below_half_a_centimetre_per_second_is_no_conflict() {
        let ego = car(0.0, 0.0, 10.004, 1.0, 0.0);
        let lead = car(30.0, 0.0, 10.0, 1.0, 0.0);
        assert_eq!(ei(&ego, &lead), f32::NEG_INFINITY);
        let ego = car(0.0, 0.0, 10.01, 1.0, 0.0);
        assert!(ei(&ego, &lead).is_finite());
    }

    #[test]
    fn crossing_paths_conflict() {
        let ego = car(-30.0, 0.0, 10.0, 1.0, 0.0);
        let partner = car(0.0, -30.0, 10.0, 0.0, 1.0);
        let e = ei(&ego, &partner);
        assert!(e.is_finite() && e > 0.0, "{e}");
        // Separated side by side: lines cross behind the partner, which drives away.
        let away = car(0.0, 10.0, 10.0, 0.0, 1.0);
        assert_eq!(ei(&ego, &away), f32::NEG_INFINITY);
    }

    #[test]
    fn near_parallel_is_modulo_pi_across_the_atan2_branch_cut() {
        let parallel = |angle_a: f32, angle_b: f32| {
            let [a, b] = [angle_a, angle_b].map(|angle| {
                OrientedBox::of(&car(0.0, 0.0, 1.0, libm::cosf(angle), libm::sinf(angle))).unwrap()
            });
            let boxes = BoxPair::new(&a, &b);
            near_parallel(&boxes, || libm::atan2f(boxes.sin, boxes.cos))
        };
        assert!(
            parallel(PI - 0.005, -PI + 0.005),
            "0.01 rad apart across +-pi"
        );
        assert!(parallel(0.3, 0.3 + PI - 0.01), "anti-parallel");
        assert!(!parallel(0.3, 0.33));
        // Near GAMMA itself the arctangent decides, as the reference does.
        assert!(parallel(0.3, 0.3 + GAMMA * 0.999));
        assert!(!parallel(0.3, 0.3 + GAMMA * 1.001));
    }
}
