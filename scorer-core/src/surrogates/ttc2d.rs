//! Two-dimensional time-to-collision (Guo et al. 2023, <https://doi.org/10.1016/j.aap.2023.107063>),
//! with the conventions of the reference implementation (Jiao, "A fast calculation of 2D TTC").
//!
//! The follower `f` is the ego unless the partner's centre lies behind the ego along the ego's
//! heading (`dot(p_j - p_i, h_i) < 0`), then the partner follows. In the follower's heading frame
//! (`+lon` along `h_f`, `+lat` to its right), with front-centre offset `s = front_l - front_f`,
//! leader length `L`, half summed width `W = (w_f + w_l) / 2`, and `dv = v_f - v_l`:
//!
//! ```text
//! ttc_lon = (s_lon - L) / clamp(dv_lon)   if s_lon > L and dv_lon > 0 and s_lat - dv_lat * ttc_lon < W
//! ttc_lat = (s_lat - W) / clamp(dv_lat)   if s_lat > W and dv_lat > 0 and s_lon - dv_lon * ttc_lat < L
//! TTC2D   = min(ttc_lon, ttc_lat)         (each is +inf when its conditions fail)
//! ```
//!
//! `clamp` keeps `|dv| >= 1e-6`. The lateral offsets are signed (no absolute value), exactly as in
//! the reference: a leader to the follower's left is judged by the longitudinal branch only.
use super::guard::clamp_away_from_zero;
use crate::geometry::{velocity, OrientedBox, Vec2};
use crate::state::VehicleState;

/// Coordinates of `v` in the frame with `+y` along `axis` and `+x` to its right.
fn lat_lon(axis: Vec2, v: Vec2) -> (f32, f32) {
    (v.cross(axis), v.dot(axis))
}

/// One ordered pair's TTC2D (`follower` behind `leader`); boxes relative to a common origin.
fn follower_leader_ttc(
    follower: (&OrientedBox, &VehicleState),
    leader: (&OrientedBox, &VehicleState),
) -> f32 {
    let (fb, fs) = follower;
    let (lb, ls) = leader;
    let axis = fb.axis;
    let (s_lat, s_lon) = lat_lon(axis, lb.front_center() - fb.front_center());
    let (v_lat, v_lon) = lat_lon(axis, velocity(fs));
    let (v0_lat, v0_lon) = lat_lon(axis, velocity(ls));
    let lead_length = ls.length;
    let half_width = (ls.width + fs.width) * 0.5;

    let dv_lon = v_lon - v0_lon;
    let dv_lat = v_lat - v0_lat;

    let ttc_lon = (s_lon - lead_length) / clamp_away_from_zero(dv_lon);
    let lon_hits = s_lon > lead_length && v_lon > v0_lon && (s_lat - dv_lat * ttc_lon) < half_width;

    let ttc_lat = (s_lat - half_width) / clamp_away_from_zero(dv_lat);
    let lat_hits = s_lat > half_width && v_lat > v0_lat && (s_lon - dv_lon * ttc_lat) < lead_length;

    let lon = if lon_hits { ttc_lon } else { f32::INFINITY };
    let lat = if lat_hits { ttc_lat } else { f32::INFINITY };
    lon.min(lat)
}

/// Two-dimensional time-to-collision (s) of the pair; `f32::INFINITY` = no conflict.
///
/// Non-finite inputs or a zero heading give `f32::INFINITY`, and so do boxes that already touch
/// or overlap whenever neither branch's gap is positive (the `s_lon > L` and `s_lat > W` tests
/// above), as in the reference implementation: an infinite TTC2D alone does not mean "no risk".
pub fn ttc2d(ego: &VehicleState, partner: &VehicleState) -> f32 {
    let (Some(bi), Some(bj)) = (OrientedBox::of(ego), OrientedBox::of(partner)) else {
        return f32::INFINITY;
    };
    // Only this much of a `BoxPair` is read here: the boxes relative to the ego's centre and the
    // partner's centre along the ego's heading.
    let origin = bi.center;
    let (bi, bj) = (bi.relative_to(origin), bj.relative_to(origin));
    let partner_behind = bj.center.dot(bi.axis) < 0.0;
    ttc2d_of_boxes(&bi, &bj, partner_behind, ego, partner)
}

/// [`ttc2d`] of two states whose boxes, relative to the ego's centre, are `bi` (ego) and `bj`
/// (partner); `partner_behind` when the partner's centre lies behind the ego along its heading.
pub(super) fn ttc2d_of_boxes(
    bi: &OrientedBox,
    bj: &OrientedBox,
    partner_behind: bool,
    ego: &VehicleState,
    partner: &VehicleState,
) -> f32 {
    let ttc = if partner_behind {
        follower_leader_ttc((bj, partner), (bi, ego))
    } else {
        follower_leader_ttc((bi, ego), (bj, partner))
    };
    if ttc.is_nan() || ttc < 0.0 {
        f32::INFINITY
    } else {
        ttc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::surrogates::test_car as car;

    #[test]
    fn rear_end_closing_gives_gap_over_speed_difference() {
        // Ego at 20 m/s, leader 30 m ahead (front to front) at 10 m/s: gap 26 m, closing 10 m/s.
        let ego = car(0.0, 0.0, 20.0, 0.0, 1.0, 0.0);
        let lead = car(30.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        assert!((ttc2d(&ego, &lead) - 2.6).abs() < 1e-5);
        // Seen from the leader the same pair is judged with the ego as follower.
        assert!((ttc2d(&lead, &ego) - 2.6).abs() < 1e-5);
    }

    #[test]
    fn opening_gap_is_no_conflict() {
        let ego = car(0.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        let lead = car(30.0, 0.0, 20.0, 0.0, 1.0, 0.0);
        assert_eq!(ttc2d(&ego, &lead), f32::INFINITY);
    }

    #[test]
    fn leader_on_the_left_is_judged_by_signed_offset() {
        // Reference quirk kept on purpose: the lateral test is `s_lat - dv_lat * t < W` without an
        // absolute value, so a slower car 5 m to the left (never touching) still gets a finite
        // TTC2D = (s_lon - L) / dv_lon = (20 - 4) / 10.
        let ego = car(0.0, 0.0, 20.0, 0.0, 1.0, 0.0);
        let left = car(20.0, 5.0, 10.0, 0.0, 1.0, 0.0);
        assert!((ttc2d(&ego, &left) - 1.6).abs() < 1e-5);
        // The mirror image on the right is correctly no conflict.
        let right = car(20.0, -5.0, 10.0, 0.0, 1.0, 0.0);
        assert_eq!(ttc2d(&ego, &right), f32::INFINITY);
    }

    #[test]
    fn bad_inputs_are_no_conflict() {
        let ego = car(0.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        let nan = car(f32::NAN, 0.0, 10.0, 0.0, 1.0, 0.0);
        let zero_heading = car(10.0, 0.0, 10.0, 0.0, 0.0, 0.0);
        assert_eq!(ttc2d(&ego, &nan), f32::INFINITY);
        assert_eq!(ttc2d(&ego, &zero_heading), f32::INFINITY);
    }
}
