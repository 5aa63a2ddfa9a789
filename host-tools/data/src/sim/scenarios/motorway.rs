//! Motorway families (three lanes of 3.5-3.75 m, 25-50 m/s, speed differences up to 25 m/s): a
//! fast approach to slower traffic in the lane, and a slower vehicle pulling out in front of a
//! fast approacher.
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::parts::{
    agent, distracted_until, distraction, driver, roles, scripted, u, Built, Vehicle,
};
use crate::sim::world::{Driver, FollowLaw, LatPlan, Path, Piece, Trigger};

/// Slowest and fastest motorway speeds drawn (m/s): the slower vehicle keeps above the lower
/// bound (its speed fluctuation is at most about 0.3 m/s), nobody wants to go above the upper.
const V_SLOW: (f64, f64) = (25.5, 40.0);
const V_MAX: f64 = 50.0;

/// Lane width and the lane of the slower vehicle (0 = right, 1 = middle; the passing lane is the
/// next one to the left, so both exist on a three-lane carriageway).
fn carriageway(rng: &mut ChaCha8Rng) -> (f64, f64) {
    let width = u(rng, 3.5, 3.75);
    let lane = f64::from(rng.random_range(0..2u8));
    (width, lane * width)
}

/// The slower speed and the faster one, `dv` U(3, 25) m/s above it but at most [`V_MAX`].
fn speeds(rng: &mut ChaCha8Rng) -> (f64, f64) {
    let slow = u(rng, V_SLOW.0, V_SLOW.1);
    let fast = (slow + u(rng, 3.0, 25.0)).min(V_MAX);
    (slow, fast)
}

/// A motorway driver: the ACC following law (no over-braking when a large speed difference is
/// seen far ahead), 250-400 m of sight, and no wish to exceed [`V_MAX`].
fn motorway_driver(rng: &mut ChaCha8Rng, hz: bool, v: f64) -> Driver {
    let mut d = driver(rng, hz, v, (1.0, 1.05));
    d.v0 = d.v0.min(V_MAX).max(v);
    d.law = FollowLaw::Acc;
    d.sight = u(rng, 250.0, 400.0);
    d
}

/// A slower vehicle cruising with a small speed fluctuation (does not react: nothing is ahead).
fn cruiser(rng: &mut ChaCha8Rng, v: f64) -> (Driver, crate::sim::world::Script) {
    let fluctuation = Piece::Sine {
        amp: u(rng, 0.0, 0.15),
        period: u(rng, 6.0, 15.0),
    };
    scripted(rng, v, vec![(0.0, fluctuation)])
}

/// A fast vehicle A closes in on a slower vehicle B in its lane. Benign: A changes to the
/// passing lane in time (time to contact 4-9 s) or brakes early and gently behind it. Hazardous:
/// A is distracted and brakes late, starts its lane change late (time to contact 0.8-2.2 s), or
/// aborts it (a vehicle in the passing lane) and must then brake hard.
pub(super) fn motorway_approach(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_fast, av, bv) = roles(rng, 0.7, ego, partner);
    let (width, y) = carriageway(rng);
    let (v_b, v_a) = speeds(rng);
    let dv = v_a - v_b;
    let mut ad = motorway_driver(rng, hz, v_a);
    if let Some(sw) = ad.swerve.as_mut() {
        sw.dir = 1.0;
    }
    let variant: f64 = rng.random();
    // Time to contact at the start; the lane change or the wake-up comes later.
    let mut plans = Vec::new();
    let ttc0 = if !hz && variant < 0.6 {
        let ttc_lc = u(rng, 4.0, 9.0);
        ad.pass_intent = Some(u(rng, 1.5, 2.5));
        plans.push(LatPlan::new(Trigger::Ttc(ttc_lc), width, u(rng, 3.5, 7.0)));
        ttc_lc + u(rng, 1.5, 4.0)
    } else if !hz {
        u(rng, 8.0, 14.0)
    } else if variant < 0.35 {
        let ttc0 = u(rng, 6.5, 11.0);
        let wake = u(rng, 1.0, 4.0);
        distracted_until(&mut ad, ttc0 - wake);
        ttc0
    } else if variant < 0.7 {
        let ttc_lc = u(rng, 0.8, 2.2);
        ad.pass_intent = Some(u(rng, 0.3, 0.8));
        plans.push(LatPlan::new(Trigger::Ttc(ttc_lc), width, u(rng, 1.8, 3.5)));
        ttc_lc + u(rng, 4.0, 8.0)
    } else {
        let ttc_lc = u(rng, 2.5, 5.0);
        ad.pass_intent = Some(u(rng, 0.8, 2.0));
        let mut plan = LatPlan::new(Trigger::Ttc(ttc_lc), width, u(rng, 3.0, 5.0));
        plan.abort_after = Some(u(rng, 0.8, 2.0));
        plans.push(plan);
        ttc_lc + u(rng, 3.0, 6.0)
    };
    let gap0 = dv * ttc0;
    let mut a = agent(Path::line(0.0, y, 0.0), 0.0, v_a, av, ad);
    a.plans = plans;
    let (bd, script) = cruiser(rng, v_b);
    let mut b = agent(
        Path::line(0.0, y, 0.0),
        gap0 + 0.5 * (av.dims.0 + bv.dims.0),
        v_b,
        bv,
        bd,
    );
    b.script = Some(script);
    // Until A is 10-40 m past B (or, braking behind it, well settled), at most 30 s.
    let pass = (gap0 + av.dims.0 + bv.dims.0 + u(rng, 10.0, 40.0)) / dv;
    let horizon = if hz {
        ttc0 + u(rng, 2.0, 4.0)
    } else {
        pass.max(ttc0 + 4.0)
    };
    (a, b, horizon.min(30.0), ego_fast)
}

/// A slower vehicle B in the lane to the right pulls out into the lane of a fast approacher A.
/// Benign: it pulls out far enough ahead for A to slow gently, or after A has passed. Hazardous:
/// it misjudges the closing speed and pulls out 1-4 s of time to contact ahead of A.
pub(super) fn motorway_cut_in(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_fast, av, bv) = roles(rng, 0.6, ego, partner);
    let (width, y_b) = carriageway(rng);
    let (v_b, v_a) = speeds(rng);
    let dv = v_a - v_b;
    let t_lc = u(rng, 5.0, 8.0);
    // Bumper gap from A's front to B's rear when B starts to pull out.
    let gap = if hz {
        dv * u(rng, 1.0, 4.0) + u(rng, 0.0, 8.0)
    } else if rng.random_bool(0.65) {
        // Far enough for A to match B's speed at 0.6-1.2 m/s^2 and keep 1-2 s behind it.
        dv * dv / (2.0 * u(rng, 0.6, 1.2)) + v_b * u(rng, 1.0, 2.0)
    } else {
        -(av.dims.0 + bv.dims.0 + u(rng, 15.0, 50.0))
    };
    let mut ad = motorway_driver(rng, hz, v_a);
    if let Some(sw) = ad.swerve.as_mut() {
        sw.dir = 1.0;
    }
    if hz {
        distraction(rng, &mut ad, 0.3, t_lc, (-0.5, 1.5), (0.5, 2.0));
    }
    let y_a = y_b + width;
    let a = agent(Path::line(0.0, y_a, 0.0), 0.0, v_a, av, ad);
    let mut bd = motorway_driver(rng, hz, v_b);
    bd.swerve = None;
    let x_b0 = gap + 0.5 * (av.dims.0 + bv.dims.0) + dv * t_lc;
    let mut b = agent(Path::line(0.0, y_b, 0.0), x_b0, v_b, bv, bd);
    let dur = if hz {
        u(rng, 2.0, 4.0)
    } else {
        u(rng, 3.5, 6.0)
    };
    b.plans.push(LatPlan::new(Trigger::Time(t_lc), width, dur));
    let horizon = t_lc + dur + u(rng, 4.0, 8.0);
    (a, b, horizon, ego_fast)
}
