//! Families whose paths cross or oppose: intersections, turns across or into a path, oncoming drift.
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, PI};

use super::parts::{agent, arc_radius, distraction, driver, roles, sign, u, Built, Vehicle};
use crate::sim::world::{
    conflict_zone, Agent, Conflict, Driver, LatPlan, Path, Role, Seg, Trigger,
};

pub(super) fn yield_role(rng: &mut ChaCha8Rng, hz: bool, blind_p: f64) -> Role {
    if hz {
        Role::Yield {
            margin: u(rng, 0.3, 1.5),
            misjudge: u(rng, 0.4, 0.9),
            blind: rng.random_bool(blind_p),
        }
    } else {
        Role::Yield {
            margin: u(rng, 1.5, 4.0),
            misjudge: u(rng, 0.9, 1.1),
            blind: false,
        }
    }
}

fn set_conflict(a: &mut Agent, b: &mut Agent, zone: (f64, f64, f64, f64), ra: Role, rb: Role) {
    let (a_in, a_out, b_in, b_out) = zone;
    a.conflict = Some(Conflict {
        me_in: a_in,
        me_out: a_out,
        partner_in: b_in,
        partner_out: b_out,
        role: ra,
    });
    b.conflict = Some(Conflict {
        me_in: b_in,
        me_out: b_out,
        partner_in: a_in,
        partner_out: a_out,
        role: rb,
    });
}

/// A (right of way) and B (giving way, blind with probability `blind_p` when hazardous) meet at
/// the crossing `zone`.
pub(super) fn priority_and_yielding(
    rng: &mut ChaCha8Rng,
    hz: bool,
    zone: (f64, f64, f64, f64),
    (mut a, mut b): (Agent, Agent),
    blind_p: f64,
) -> (Agent, Agent) {
    let rb = yield_role(rng, hz, blind_p);
    set_conflict(
        &mut a,
        &mut b,
        zone,
        Role::Priority {
            margin: u(rng, 0.5, 1.5),
        },
        rb,
    );
    (a, b)
}

/// A driver (desired speed `v` times a factor drawn from `factor`) who never swerves.
pub(super) fn steady_driver(rng: &mut ChaCha8Rng, hz: bool, v: f64, factor: (f64, f64)) -> Driver {
    let mut d = driver(rng, hz, v, factor);
    d.swerve = None;
    d
}

/// A driver at about speed `v` who swerves towards `swerve_dir` (if it swerves) and, hazardous,
/// may be distracted for 0.5-2 s starting `before` (a range) ahead of the time `around`.
pub(super) fn swerving_driver(
    rng: &mut ChaCha8Rng,
    hz: bool,
    v: f64,
    swerve_dir: f64,
    (around, before): (f64, (f64, f64)),
) -> Driver {
    let mut d = driver(rng, hz, v, (1.0, 1.08));
    if let Some(sw) = d.swerve.as_mut() {
        sw.dir = swerve_dir;
    }
    if hz {
        distraction(rng, &mut d, 0.3, around, before, (0.5, 2.0));
    }
    d
}

/// The two paths of a junction manoeuvre (A straight along the x axis from the origin's west, B
/// as the manoeuvre has it), their conflict zone, and where B's turn begins on its path.
pub(super) struct JunctionPaths {
    pub a: Path,
    pub b: Path,
    pub zone: (f64, f64, f64, f64),
    pub b_turn: f64,
}

/// Straight paths crossing at the origin at angle `alpha`.
pub(super) fn straight_crossing(alpha: f64, av: &Vehicle, bv: &Vehicle) -> JunctionPaths {
    let pa = Path::line(0.0, 0.0, 0.0);
    let pb = Path::line(0.0, 0.0, alpha);
    let zone = conflict_zone(
        (&pa, av.dims.0, av.dims.1),
        (&pb, bv.dims.0, bv.dims.1),
        (-30.0, 30.0),
        (-30.0, 30.0),
    )
    .unwrap_or((-5.0, 5.0, -5.0, 5.0));
    JunctionPaths {
        a: pa,
        b: pb,
        zone,
        b_turn: 0.0,
    }
}

/// B oncoming in the lane `lane` to A's left turns left (radius `radius`) across A's lane.
pub(super) fn left_turn_paths(lane: f64, radius: f64, av: &Vehicle, bv: &Vehicle) -> JunctionPaths {
    let l_b = 200.0;
    let x_t = 0.0;
    let pb = Path::new(
        x_t + l_b,
        lane,
        PI,
        vec![
            Seg::Line(l_b),
            Seg::Arc {
                len: radius * FRAC_PI_2,
                kappa: 1.0 / radius,
            },
            Seg::Line(300.0),
        ],
    );
    let pa = Path::line(0.0, 0.0, 0.0);
    let zone = conflict_zone(
        (&pa, av.dims.0, av.dims.1),
        (&pb, bv.dims.0, bv.dims.1),
        (x_t - radius - 30.0, x_t + 20.0),
        (l_b - 10.0, l_b + radius * FRAC_PI_2 + 20.0),
    )
    .unwrap_or((-radius, 0.0, l_b, l_b + radius * 1.5));
    JunctionPaths {
        a: pa,
        b: pb,
        zone,
        b_turn: l_b,
    }
}

/// B from a side road on A's right turns right (radius `radius`) into A's lane. Only the turn
/// itself is the conflict zone; once B is in A's lane, A follows it.
pub(super) fn right_turn_paths(radius: f64, av: &Vehicle, bv: &Vehicle) -> JunctionPaths {
    let l_b = 60.0;
    let x_t = 0.0;
    let pb = Path::new(
        x_t,
        -radius - l_b,
        FRAC_PI_2,
        vec![
            Seg::Line(l_b),
            Seg::Arc {
                len: radius * FRAC_PI_2,
                kappa: -1.0 / radius,
            },
            Seg::Line(2000.0),
        ],
    );
    let pa = Path::line(0.0, 0.0, 0.0);
    let b_join = l_b + radius * FRAC_PI_2;
    let zone = conflict_zone(
        (&pa, av.dims.0, av.dims.1),
        (&pb, bv.dims.0, bv.dims.1),
        (x_t - 20.0, x_t + radius + 2.0),
        (l_b - 10.0, b_join),
    )
    .unwrap_or((x_t, x_t + radius + 5.0, l_b, b_join + 5.0));
    JunctionPaths {
        a: pa,
        b: pb,
        zone,
        b_turn: l_b,
    }
}

/// Straight crossing paths at an intersection: A has right of way, B gives way (or fails to).
pub(super) fn crossing(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, partner: &Vehicle) -> Built {
    let (ego_a, av, bv) = roles(rng, 0.5, ego, partner);
    let alpha = sign(rng) * u(rng, 60.0, 120.0).to_radians();
    let v_a = u(rng, 8.0, 20.0);
    let v_b = u(rng, 5.0, 15.0);
    let t_a = u(rng, 6.0, 9.0);
    let JunctionPaths {
        a: pa, b: pb, zone, ..
    } = straight_crossing(alpha, av, bv);
    let standing = !hz && rng.random_bool(0.35);
    let (s_b0, v_b0, t_end) = if standing {
        (zone.2 - 1.5, 0.0, t_a + u(rng, 5.0, 8.0))
    } else {
        let dt = if hz {
            u(rng, -1.2, 1.2)
        } else {
            sign(rng) * u(rng, 2.5, 6.0)
        };
        let t_b = (t_a + dt).max(3.0);
        (-v_b * t_b, v_b, t_a.max(t_b) + u(rng, 3.0, 5.0))
    };
    let mut ad = driver(rng, hz, v_a, (1.0, 1.08));
    if hz {
        distraction(rng, &mut ad, 0.35, t_a, (1.0, 3.0), (0.5, 2.0));
    }
    let bd = driver(rng, hz, v_b, (1.0, 1.1));
    let (a, b) = (
        agent(pa, -v_a * t_a, v_a, av, ad),
        agent(pb, s_b0, v_b0, bv, bd),
    );
    let (a, b) = priority_and_yielding(rng, hz, zone, (a, b), 0.45);
    (a, b, t_end, ego_a)
}

/// Left turn across the path of an oncoming vehicle (LTAP/OD): B turns, A goes straight.
pub(super) fn left_turn_across(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_a, av, bv) = roles(rng, 0.5, ego, partner);
    let lane = u(rng, 3.0, 3.75);
    let radius = arc_radius(rng, 6.0, 14.0, bv);
    let JunctionPaths {
        a: pa,
        b: pb,
        zone,
        b_turn: l_b,
    } = left_turn_paths(lane, radius, av, bv);
    let v_b = u(rng, 7.0, 14.0);
    let t_t = u(rng, 6.0, 8.5);
    let s_b0 = l_b - v_b * t_t;
    let v_a = u(rng, 8.0, 20.0);
    let dt = if hz {
        u(rng, -0.5, 2.0)
    } else {
        sign(rng) * u(rng, 3.0, 7.0)
    };
    let a_mid = 0.5 * (zone.0 + zone.1);
    let s_a0 = a_mid - v_a * (t_t + dt).max(3.0);
    let ad = swerving_driver(rng, hz, v_a, -1.0, (t_t, (0.0, 2.0)));
    let bd = steady_driver(rng, hz, v_b, (1.0, 1.1));
    let (a, b) = (agent(pa, s_a0, v_a, av, ad), agent(pb, s_b0, v_b, bv, bd));
    let (a, b) = priority_and_yielding(rng, hz, zone, (a, b), 0.35);
    (a, b, t_t + dt.max(0.0) + u(rng, 4.0, 6.0), ego_a)
}

/// An oncoming vehicle drifts over the centre line (hazardous) or stays in lane / drifts
/// slightly (benign, close oncoming passes).
pub(super) fn opposite_drift(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_a, av, bv) = roles(rng, 0.7, ego, partner);
    let lane = u(rng, 3.0, 3.7);
    let v_a = u(rng, 12.0, 27.0);
    let v_b = u(rng, 12.0, 27.0);
    let t_meet = u(rng, 6.5, 9.5);
    let dd = if hz {
        u(rng, 1.4, 3.6)
    } else {
        u(rng, 0.0, 0.5)
    };
    let v_lat = u(rng, 0.3, 1.2);
    let drift_dur = (dd / v_lat).max(0.5);
    let t_d = t_meet - u(rng, 1.5, 4.0);
    let t_back = t_d + drift_dur + u(rng, 0.3, 2.5);
    let ad = swerving_driver(rng, hz, v_a, -1.0, (t_d, (-1.0, 1.0)));
    let mut bd = steady_driver(rng, hz, v_b, (1.0, 1.05));
    bd.distraction.push(((t_d - 1.0).max(0.0), t_back));
    let a = agent(Path::line(0.0, 0.0, 0.0), -v_a * t_meet, v_a, av, ad);
    let mut b = agent(Path::line(0.0, lane, PI), -v_b * t_meet, v_b, bv, bd);
    if dd > 0.0 {
        b.plans
            .push(LatPlan::new(Trigger::Time(t_d), dd, drift_dur));
        b.plans
            .push(LatPlan::new(Trigger::Time(t_back), -dd, u(rng, 1.0, 2.5)));
    }
    (a, b, t_meet + u(rng, 2.0, 4.0), ego_a)
}

/// A vehicle from a side road turns right into the lane in front of an approaching vehicle.
pub(super) fn turn_into_path(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_a, av, bv) = roles(rng, 0.6, ego, partner);
    let radius = arc_radius(rng, 6.0, 12.0, bv);
    let JunctionPaths {
        a: pa, b: pb, zone, ..
    } = right_turn_paths(radius, av, bv);
    let v_a = u(rng, 10.0, 20.0);
    let standing = rng.random_bool(0.4);
    let t_b = u(rng, 5.5, 8.0);
    let (v_b, s_b0, hold) = if standing {
        (0.0, zone.2 - 1.5, t_b)
    } else {
        let v = u(rng, 3.0, 8.0);
        (v, zone.2 - 1.0 - v * t_b, 0.0)
    };
    let dt = if hz {
        u(rng, -0.5, 3.0)
    } else {
        u(rng, 5.0, 9.0)
    };
    let s_a0 = zone.0 - v_a * (t_b + dt).max(3.0);
    let ad = swerving_driver(rng, hz, v_a, 1.0, (t_b, (0.0, 2.0)));
    let mut bd = steady_driver(rng, hz, 1.0, (8.0, 15.0));
    bd.hold_until = hold;
    let (a, b) = (agent(pa, s_a0, v_a, av, ad), agent(pb, s_b0, v_b, bv, bd));
    let (a, b) = priority_and_yielding(rng, hz, zone, (a, b), 0.35);
    (a, b, t_b + dt.max(0.0) + u(rng, 4.0, 7.0), ego_a)
}
