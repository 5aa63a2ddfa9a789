//! Property tests: features and surrogates are total functions. Whatever the inputs (NaN, +-inf,
//! huge, zero, subnormal), features are finite and each surrogate is finite or its documented
//! sentinel (`+inf` for box distance, TTC2D and TAdv; `-inf` for EI), never NaN and never a panic.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use proptest::prelude::*;
use scorer_core::geometry::boxes_overlap;
use scorer_core::surrogates::surrogates_and_features;
use scorer_core::{
    box_distance, ei, features, surrogates, tadv, tadv_corridor, ttc2d, VehicleState,
    STANDING_SPEED,
};

/// Any f32, with the nasty values drawn often.
fn nasty_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => any::<f32>(),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MAX),
        1 => Just(-f32::MAX),
        1 => Just(1e30f32),
        1 => Just(-1e30f32),
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => Just(f32::MIN_POSITIVE),
        1 => Just(1e-6f32),
        3 => -100.0f32..100.0,
    ]
}

fn nasty_state() -> impl Strategy<Value = VehicleState> {
    proptest::array::uniform9(nasty_f32()).prop_map(|[x, y, vx, vy, hx, hy, acc, length, width]| {
        VehicleState {
            x,
            y,
            vx,
            vy,
            hx,
            hy,
            acc,
            length,
            width,
        }
    })
}

/// Plausible road users: positions within 200 m, speeds up to 50 m/s, any heading.
fn road_user() -> impl Strategy<Value = VehicleState> {
    (
        -200.0f32..200.0,
        -200.0f32..200.0,
        -50.0f32..50.0,
        -50.0f32..50.0,
        0.0f32..core::f32::consts::TAU,
        1.0f32..20.0,
        0.5f32..3.0,
    )
        .prop_map(|(x, y, vx, vy, angle, length, width)| VehicleState {
            x,
            y,
            vx,
            vy,
            hx: libm::cosf(angle),
            hy: libm::sinf(angle),
            acc: 0.0,
            length,
            width,
        })
}

fn check_sentinels(a: &VehicleState, b: &VehicleState) -> Result<(), TestCaseError> {
    for (k, f) in features(a, b).iter().enumerate() {
        prop_assert!(f.is_finite(), "feature {k} = {f}");
    }
    let d = box_distance(a, b);
    prop_assert!(d >= 0.0, "box_distance = {d}"); // finite or +inf, never NaN
    let t = ttc2d(a, b);
    prop_assert!(t >= 0.0, "ttc2d = {t}");
    let adv = tadv(a, b);
    prop_assert!(adv >= 0.0, "tadv = {adv}");
    let corridor = tadv_corridor(a, b);
    prop_assert!(corridor >= 0.0, "tadv_corridor = {corridor}");
    let e = ei(a, b);
    prop_assert!(!e.is_nan() && e != f32::INFINITY, "ei = {e}");
    let all = surrogates(a, b);
    prop_assert_eq!(all.box_distance.to_bits(), d.to_bits());
    prop_assert_eq!(all.ttc2d.to_bits(), t.to_bits());
    prop_assert_eq!(all.tadv.to_bits(), adv.to_bits());
    prop_assert_eq!(all.ei.to_bits(), e.to_bits());
    prop_assert_eq!(all.tadv_corridor.to_bits(), corridor.to_bits());
    // The fused form (each heading and box computed once) gives the same bits as the parts.
    let (fused, fused_features) = surrogates_and_features(a, b);
    let bits = |s: scorer_core::Surrogates| {
        [s.box_distance, s.ttc2d, s.tadv, s.ei, s.tadv_corridor].map(f32::to_bits)
    };
    prop_assert_eq!(bits(fused), bits(all));
    prop_assert_eq!(
        fused_features.map(f32::to_bits),
        features(a, b).map(f32::to_bits)
    );
    let _ = boxes_overlap(a, b);
    Ok(())
}

/// Oracle of the corridor rule's "beside": the two boxes' corners projected, in f64, on the
/// normal of `mover`'s heading; `None` within 1e-3 m of touching (rounding decides there).
fn beside_oracle(mover: &VehicleState, standing: &VehicleState) -> Option<bool> {
    let corners = |s: &VehicleState| {
        let n = (f64::from(s.hx)).hypot(f64::from(s.hy));
        let (ax, ay) = (f64::from(s.hx) / n, f64::from(s.hy) / n);
        let (l, w) = (f64::from(s.length) / 2.0, f64::from(s.width) / 2.0);
        [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)].map(|(i, j)| {
            (
                f64::from(s.x) + i * l * ax - j * w * ay,
                f64::from(s.y) + i * l * ay + j * w * ax,
            )
        })
    };
    let n = (f64::from(mover.hx)).hypot(f64::from(mover.hy));
    let normal = (-f64::from(mover.hy) / n, f64::from(mover.hx) / n);
    let span = |s: &VehicleState| {
        corners(s)
            .iter()
            .map(|(x, y)| x * normal.0 + y * normal.1)
            .fold((f64::MAX, f64::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)))
    };
    let ((m0, m1), (s0, s1)) = (span(mover), span(standing));
    let gap = (s0 - m1).max(m0 - s1);
    (gap.abs() > 1e-3).then_some(gap > 0.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn the_corridor_rule_changes_nothing_between_moving_road_users(
        a in road_user(), b in road_user()
    ) {
        prop_assume!(a.speed() >= STANDING_SPEED && b.speed() >= STANDING_SPEED);
        prop_assert_eq!(tadv_corridor(&a, &b).to_bits(), tadv(&a, &b).to_bits());
    }

    #[test]
    fn a_standing_road_user_beside_the_movers_path_is_no_conflict(
        a in road_user(), b in road_user(), slow in 0.0f32..1.0
    ) {
        // b moves at `slow` times the standing speed, in its own direction.
        let scale = slow * STANDING_SPEED / b.speed().max(1e-3);
        let b = VehicleState { vx: b.vx * scale, vy: b.vy * scale, ..b };
        prop_assume!(b.speed() < STANDING_SPEED && a.speed() >= STANDING_SPEED);
        // Each order of the pair against the reference TAdv of the same order.
        for (first, second) in [(&a, &b), (&b, &a)] {
            let corridor = tadv_corridor(first, second);
            let reference = tadv(first, second);
            match beside_oracle(&a, &b) {
                Some(true) => prop_assert_eq!(corridor, f32::INFINITY),
                Some(false) => prop_assert_eq!(
                    corridor.to_bits(),
                    reference.to_bits(),
                    "corridor {}, reference {}",
                    corridor,
                    reference
                ),
                None => {}
            }
        }
    }

    #[test]
    fn nasty_inputs_give_finite_values_or_sentinels(a in nasty_state(), b in nasty_state()) {
        check_sentinels(&a, &b)?;
    }

    #[test]
    fn one_nasty_partner_next_to_a_normal_ego(a in road_user(), b in nasty_state()) {
        check_sentinels(&a, &b)?;
        check_sentinels(&b, &a)?;
    }

    #[test]
    fn plausible_pairs_are_finite_where_they_must_be(a in road_user(), b in road_user()) {
        check_sentinels(&a, &b)?;
        let d = box_distance(&a, &b);
        prop_assert!(d.is_finite());
        // The gap is symmetric and never more than the centre distance.
        prop_assert!((d - box_distance(&b, &a)).abs() <= 1e-3, "asymmetric gap");
        let centres = libm::hypotf(b.x - a.x, b.y - a.y);
        prop_assert!(d <= centres + 1e-3);
        // Overlap test and distance agree away from the touching boundary.
        if d > 1e-3 {
            prop_assert!(!boxes_overlap(&a, &b));
        }
        if boxes_overlap(&a, &b) {
            prop_assert!(d <= 1e-3);
        }
        // Plausible states never hit the "not computable" path: EI is finite or "no conflict",
        // TTC2D and TAdv are non-negative, and only TTC2D/TAdv may be +inf.
        let e = ei(&a, &b);
        prop_assert!(e.is_finite() || e == f32::NEG_INFINITY, "ei = {e}");
        prop_assert!(ttc2d(&a, &b) >= 0.0 && tadv(&a, &b) >= 0.0);
    }
}
