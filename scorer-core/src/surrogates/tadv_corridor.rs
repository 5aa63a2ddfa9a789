//! TAdv under the corridor rule: the time advantage of [`super::tadv`], except that a standing
//! road user (slower than [`STANDING_SPEED`]) whose box lies wholly beside the *corridor* of a
//! moving one (the band the mover's box sweeps along its heading) is no conflict: `+inf`.
//!
//! Why: the reference treats a standing road user as moving parallel to everything and divides the
//! box gap by the speed difference, whatever the direction of that gap. A car passing a standing
//! car in the next lane or a turn bay, or a parked object beside the lane, then reads as a near
//! miss (0.01-0.16 s on real city traffic; `docs/training.md`, "A standing road user beside the
//! path is no conflict"). A standing road user *in* the corridor (a queue ahead) keeps the
//! reference's gap over speed; so does every pair of moving road users, bit for bit.
//!
//! The corridor follows the mover's heading, not its velocity: the boxes' lateral separation is
//! then one of the separating-axis tests the pair's geometry already has ([`BoxPair`]), which
//! keeps the rule within the ECU's flash budget; a vehicle's velocity lies along its heading
//! except when it skids.
//!
//! Not a published measure: the TAdv baseline and [`SurrogateKind::Tadv`](super::SurrogateKind)
//! stay the reference; MSRA terms and kinematic fallbacks may read this one instead
//! ([`SurrogateKind::TadvCorridor`](super::SurrogateKind)).
use super::tadv::tadv_of_pair;
use crate::geometry::{BoxPair, OrientedBox, Speeds};
use crate::state::VehicleState;

/// Speed (m/s) under which a road user counts as standing: a car creeping in a queue, not a
/// vehicle on its way somewhere.
pub const STANDING_SPEED: f32 = 0.5;

/// [`super::surrogates`]' `tadv_corridor` of the pair (s); `f32::INFINITY` = no conflict.
pub fn tadv_corridor(ego: &VehicleState, partner: &VehicleState) -> f32 {
    let (Some(bi), Some(bj)) = (OrientedBox::of(ego), OrientedBox::of(partner)) else {
        return f32::INFINITY;
    };
    let boxes = BoxPair::new(&bi, &bj);
    let speeds = Speeds::of(ego, partner);
    let reference = tadv_of_pair(&boxes, ego, partner, speeds, || boxes.gap());
    tadv_corridor_of_pair(&boxes, speeds, reference)
}

/// [`tadv_corridor`] of two road users whose boxes are `boxes.a` (ego) and `boxes.b` (partner),
/// moving at `speeds`, with `reference` their reference TAdv.
pub(super) fn tadv_corridor_of_pair(boxes: &BoxPair, speeds: Speeds, reference: f32) -> f32 {
    let ego_standing = speeds.ego < STANDING_SPEED;
    let partner_standing = speeds.partner < STANDING_SPEED;
    // One stands, the other moves: the mover is the ego when the partner stands.
    if ego_standing != partner_standing && boxes.apart_across(partner_standing) {
        f32::INFINITY
    } else {
        reference
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::surrogates::tadv;
    use crate::surrogates::test_car as car;

    #[test]
    fn passing_a_standing_car_in_the_next_lane_is_no_conflict() {
        // Ego at 10 m/s, a stopped car 3.5 m to the left, 20 m ahead: the reference reads a
        // near-parallel gap over the speed difference.
        let ego = car(0.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        let parked = car(20.0, 3.5, 0.0, 0.0, 1.0, 0.0);
        assert!(tadv(&ego, &parked) < 2.0, "{}", tadv(&ego, &parked));
        assert_eq!(tadv_corridor(&ego, &parked), f32::INFINITY);
        // Seen from the standing car, the same: the mover's corridor is what counts.
        assert_eq!(tadv_corridor(&parked, &ego), f32::INFINITY);
    }

    #[test]
    fn a_standing_car_in_the_corridor_keeps_the_reference() {
        let ego = car(0.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        // 1.9 m to the side: the 2 m wide boxes overlap across the direction of travel by 0.1 m.
        for y in [0.0, 1.9, -1.9] {
            let queue = car(20.0, y, 0.0, 0.0, 1.0, 0.0);
            assert_eq!(tadv_corridor(&ego, &queue), tadv(&ego, &queue), "y {y}");
            assert!(tadv(&ego, &queue).is_finite());
        }
        // Touching the corridor's edge counts as inside.
        let edge = car(20.0, 2.0, 0.0, 0.0, 1.0, 0.0);
        assert_eq!(tadv_corridor(&ego, &edge), tadv(&ego, &edge));
    }

    #[test]
    fn the_corridor_follows_the_heading_either_way() {
        // Reversing at 3 m/s past a car parked 3.5 m to the side: beside, as driving forward.
        let reversing = car(0.0, 0.0, -3.0, 0.0, 1.0, 0.0);
        let parked = car(-15.0, 3.5, 0.0, 0.0, 1.0, 0.0);
        assert_eq!(tadv_corridor(&reversing, &parked), f32::INFINITY);
        // A car standing across the lane 2.5 m to the side: its 4 m length reaches 0.5 m from
        // the centre line, into the ego's 2 m wide corridor: in the path.
        let across = car(-15.0, 2.5, 0.0, 0.0, 0.0, 1.0);
        assert_eq!(
            tadv_corridor(&reversing, &across),
            tadv(&reversing, &across)
        );
        // Turned 45 degrees, the ego's corridor is the diagonal band.
        let h = core::f32::consts::FRAC_1_SQRT_2;
        let diagonal = car(0.0, 0.0, 10.0 * h, 10.0 * h, h, h);
        let on_it = car(20.0, 20.0, 0.0, 0.0, 1.0, 0.0);
        let off_it = car(20.0, 10.0, 0.0, 0.0, 1.0, 0.0);
        assert_eq!(tadv_corridor(&diagonal, &on_it), tadv(&diagonal, &on_it));
        assert_eq!(tadv_corridor(&diagonal, &off_it), f32::INFINITY);
    }

    #[test]
    fn a_creeping_road_user_counts_as_standing() {
        let ego = car(0.0, 0.0, 10.0, 0.0, 1.0, 0.0);
        // Creeping at 0.3 m/s towards the path from 5 m beside it: no conflict.
        let beside = car(20.0, 5.0, 0.0, -0.3, 0.0, -1.0);
        assert!(tadv(&ego, &beside).is_finite());
        assert_eq!(tadv_corridor(&ego, &beside), f32::INFINITY);
        // In the path, the reference's own value (the rule changes no number, it only drops
        // road users beside the path).
        let in_path = car(20.0, 0.0, 0.0, 0.3, 0.0, 1.0);
        assert_eq!(tadv_corridor(&ego, &in_path), tadv(&ego, &in_path));
        // At the standing speed it moves: the reference.
        let moving = car(20.0, 5.0, 0.0, STANDING_SPEED, 0.0, 1.0);
        assert_eq!(tadv_corridor(&ego, &moving), tadv(&ego, &moving));
    }

    #[test]
    fn two_standing_road_users_keep_the_reference() {
        let a = car(0.0, 0.0, 0.2, 0.0, 1.0, 0.0);
        let b = car(14.0, 5.0, 0.0, 0.1, 1.0, 0.0);
        assert_eq!(tadv_corridor(&a, &b), tadv(&a, &b));
    }

    #[test]
    fn no_box_is_no_conflict() {
        let ego = car(0.0, 0.0, 10.0, 0.0, 0.0, 0.0);
        let other = car(20.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        assert_eq!(tadv_corridor(&ego, &other), f32::INFINITY);
        let nan = car(f32::NAN, 0.0, 10.0, 0.0, 1.0, 0.0);
        assert_eq!(tadv_corridor(&nan, &other), f32::INFINITY);
    }
}
