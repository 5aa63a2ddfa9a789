//! Signalised junctions at urban speeds (8-17 m/s): crossing traffic (a vehicle waiting at red,
//! passing on its own phase, or running the red), permissive left turns across oncoming traffic
//! (turning ahead of it, or waiting in the junction while it passes), and right turns on red into
//! the path of crossing traffic.
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::crossing::{
    left_turn_paths, priority_and_yielding, right_turn_paths, steady_driver, straight_crossing,
    swerving_driver, JunctionPaths,
};
use super::parts::{agent, arc_radius, distraction, driver, roles, sign, u, Built, Vehicle};

/// Speeds through a signalised junction on green (m/s): 30-60 km/h.
const V_GREEN: (f64, f64) = (8.0, 17.0);

/// Crossing traffic at a signalised junction (paths at 75-105 degrees). A crosses on green.
/// Benign: B waits at its red stop line until A has gone, or passes 2.5-7 s before or after A
/// (its own phase). Hazardous: B runs the red, arriving within 1.2 s of A, usually without
/// looking (p = 0.7), otherwise misjudging A's speed.
pub(super) fn signal_crossing(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_a, av, bv) = roles(rng, 0.5, ego, partner);
    let alpha = sign(rng) * u(rng, 75.0, 105.0).to_radians();
    let v_a = u(rng, V_GREEN.0, V_GREEN.1);
    let v_b = u(rng, V_GREEN.0, V_GREEN.1);
    let t_a = u(rng, 6.0, 9.0);
    let JunctionPaths {
        a: pa, b: pb, zone, ..
    } = straight_crossing(alpha, av, bv);
    let mut bd = driver(rng, hz, v_b, (1.0, 1.1));
    let waits = !hz && rng.random_bool(0.4);
    let (s_b0, v_b0, horizon) = if waits {
        bd.hold_until = t_a + u(rng, 0.5, 3.0);
        (zone.2 - u(rng, 1.5, 4.0), 0.0, t_a + u(rng, 6.0, 9.0))
    } else {
        let dt = if hz {
            u(rng, -1.2, 1.2)
        } else {
            sign(rng) * u(rng, 2.5, 7.0)
        };
        let t_b = (t_a + dt).max(3.0);
        let s_b0 = 0.5 * (zone.2 + zone.3) - v_b * t_b;
        (s_b0, v_b, t_a.max(t_b) + u(rng, 3.0, 5.0))
    };
    let mut ad = driver(rng, hz, v_a, (1.0, 1.08));
    if hz {
        distraction(rng, &mut ad, 0.35, t_a, (1.0, 3.0), (0.5, 2.0));
    }
    let s_a0 = 0.5 * (zone.0 + zone.1) - v_a * t_a;
    let (a, b) = (agent(pa, s_a0, v_a, av, ad), agent(pb, s_b0, v_b0, bv, bd));
    let (a, b) = priority_and_yielding(rng, hz, zone, (a, b), 0.7);
    (a, b, horizon, ego_a)
}

/// Permissive left turn at a signal: B, oncoming, turns left (radius 8-16 m) across A's lane.
/// B either arrives rolling at 5-11 m/s or waits in the junction (40 % benign, 30 % hazardous)
/// and goes when it accepts the gap. Benign: B turns 3-7 s before A arrives or after it, or lets
/// A pass at lane-width distance. Hazardous: B misjudges A's speed or does not look (p = 0.35),
/// with A arriving 0.5 s before to 2 s after B's turn.
pub(super) fn signal_left_turn(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_a, av, bv) = roles(rng, 0.5, ego, partner);
    let lane = u(rng, 3.0, 3.6);
    let radius = arc_radius(rng, 8.0, 16.0, bv);
    let JunctionPaths {
        a: pa, b: pb, zone, ..
    } = left_turn_paths(lane, radius, av, bv);
    let v_a = u(rng, V_GREEN.0, V_GREEN.1);
    let waits = rng.random_bool(if hz { 0.3 } else { 0.4 });
    let (v_b, s_b0, t_turn, hold) = if waits {
        let hold = u(rng, 1.0, 4.0);
        (0.0, zone.2 - u(rng, 1.0, 3.0), hold, hold)
    } else {
        let v_b = u(rng, 5.0, 11.0);
        let t_turn = u(rng, 6.0, 8.5);
        (v_b, zone.2 - v_b * t_turn, t_turn, 0.0)
    };
    let dt = if hz {
        u(rng, -0.5, 2.0)
    } else {
        sign(rng) * u(rng, 3.0, 7.0)
    };
    let s_a0 = 0.5 * (zone.0 + zone.1) - v_a * (t_turn + dt).max(4.5);
    let ad = swerving_driver(rng, hz, v_a, -1.0, (t_turn, (0.0, 2.0)));
    // A waiting turner wants the speed it would have turned at.
    let v_want = v_b.max(u(rng, 6.0, 11.0));
    let mut bd = steady_driver(rng, hz, v_want, (1.0, 1.1));
    bd.hold_until = hold;
    let (a, b) = (agent(pa, s_a0, v_a, av, ad), agent(pb, s_b0, v_b, bv, bd));
    let (a, b) = priority_and_yielding(rng, hz, zone, (a, b), 0.35);
    let horizon = (t_turn + dt).max(4.5) + u(rng, 4.0, 7.0);
    (a, b, horizon, ego_a)
}

/// Right turn on red: B stops at its stop line, then turns right (radius 6-12 m, a truck 8-12 m)
/// into the lane of A, who crosses on green from B's left. B goes when it accepts the gap
/// (benign: ample margins; hazardous: misjudged speed or no look, p = 0.35); once B is in the
/// lane, A follows it.
pub(super) fn signal_right_turn(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_a, av, bv) = roles(rng, 0.6, ego, partner);
    let radius = arc_radius(rng, 6.0, 12.0, bv);
    let JunctionPaths {
        a: pa,
        b: pb,
        zone,
        b_turn,
    } = right_turn_paths(radius, av, bv);
    let v_a = u(rng, V_GREEN.0, V_GREEN.1);
    let hold = u(rng, 1.0, 3.0);
    let dt = if hz {
        u(rng, -0.5, 3.0)
    } else {
        u(rng, -2.0, 8.0)
    };
    let t_a = (hold + dt).max(4.5);
    let s_a0 = zone.0 - v_a * t_a;
    let ad = swerving_driver(rng, hz, v_a, 1.0, (hold, (0.0, 2.0)));
    let mut bd = steady_driver(rng, hz, 1.0, (8.0, 14.0));
    bd.hold_until = hold;
    // The stop line is before the turn, not in it.
    let s_b0 = zone.2.min(b_turn) - u(rng, 1.5, 3.0);
    let (a, b) = (agent(pa, s_a0, v_a, av, ad), agent(pb, s_b0, 0.0, bv, bd));
    let (a, b) = priority_and_yielding(rng, hz, zone, (a, b), 0.35);
    (a, b, t_a + u(rng, 4.0, 7.0), ego_a)
}
