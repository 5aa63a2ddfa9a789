//! Same-direction families: braking or stopped leaders, cut-ins, lane changes and merges.
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::parts::{
    agent, arc_radius, distraction, driver, road_speed, roles, scripted, sign, u, Built, Vehicle,
    CRUISE,
};
use crate::sim::world::{LatPlan, Path, Piece, Seg, Trigger};

/// Rear-end family: a follower behind a leader that brakes (hazardous: hard, benign: gently or
/// just fluctuates in speed, including close following at steady speed).
pub(super) fn lead_braking(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_follows, fv, lv) = roles(rng, 0.75, ego, partner);
    let v = road_speed(rng);
    let mut fd = driver(rng, hz, v, (1.0, 1.12));
    let t_init = if hz {
        u(rng, 0.4, 1.4)
    } else {
        u(rng, 0.7, 2.5)
    };
    let gap0 = fd.s0 + v * t_init;
    let t_b = if hz {
        u(rng, 5.0, 8.0)
    } else {
        u(rng, 3.0, 8.0)
    };
    let pieces = if hz {
        let d = u(rng, 2.5, 8.0);
        let v_end = v * u(rng, 0.0, 0.6);
        vec![
            (
                0.0,
                Piece::Sine {
                    amp: u(rng, 0.0, 0.3),
                    period: u(rng, 5.0, 12.0),
                },
            ),
            (
                t_b,
                Piece::Accel {
                    a: -d,
                    v_lo: v_end,
                    v_hi: f64::MAX,
                },
            ),
        ]
    } else if rng.random_bool(0.5) {
        vec![(
            0.0,
            Piece::Sine {
                amp: u(rng, 0.2, 1.0),
                period: u(rng, 6.0, 15.0),
            },
        )]
    } else {
        vec![
            (0.0, CRUISE),
            (
                t_b,
                Piece::Accel {
                    a: -u(rng, 0.3, 1.2),
                    v_lo: v * u(rng, 0.4, 0.9),
                    v_hi: f64::MAX,
                },
            ),
        ]
    };
    if hz {
        distraction(rng, &mut fd, 0.65, t_b, (-0.3, 2.0), (0.8, 3.0));
    }
    let (ld, script) = scripted(rng, v, pieces);
    let road = Path::line(0.0, 0.0, 0.0);
    let follower = agent(road.clone(), 0.0, v * u(rng, 0.95, 1.05), fv, fd);
    let mut leader = agent(road, gap0 + 0.5 * (fv.dims.0 + lv.dims.0), v, lv, ld);
    leader.script = Some(script);
    let horizon = t_b
        + if hz {
            u(rng, 4.0, 6.0)
        } else {
            u(rng, 5.0, 8.0)
        };
    (follower, leader, horizon.max(8.0), ego_follows)
}

/// A stationary or slow vehicle in the lane; the approaching driver is distracted (hazardous) or
/// attentive and stops or changes lane to pass (benign).
pub(super) fn stopped_ahead(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_approaches, av, ov) = roles(rng, 0.85, ego, partner);
    let v = road_speed(rng).min(25.0);
    let v_o = if rng.random_bool(0.6) {
        0.0
    } else {
        u(rng, 1.0, 6.0).min(0.5 * v)
    };
    let t_enc = u(rng, 7.0, 11.0);
    let gap0 = (v - v_o) * t_enc;
    let mut ad = driver(rng, hz, v, (1.0, 1.1));
    let mut plans = Vec::new();
    if hz {
        if rng.random_bool(0.85) {
            let start = u(rng, 0.5, 3.0);
            let end = (t_enc - u(rng, 0.8, 4.0)).max(start + 0.5);
            ad.distraction.push((start, end));
        }
    } else if rng.random_bool(0.5) {
        let lane = u(rng, 3.0, 3.75);
        plans.push(LatPlan::new(
            Trigger::Time((t_enc - u(rng, 3.5, 6.0)).max(1.0)),
            sign(rng) * lane,
            u(rng, 3.0, 5.0),
        ));
    }
    let (od, script) = scripted(rng, v_o.max(0.1), vec![(0.0, CRUISE)]);
    let road = Path::line(0.0, 0.0, 0.0);
    let mut a = agent(road.clone(), 0.0, v, av, ad);
    a.plans = plans;
    let mut o = agent(road, gap0 + 0.5 * (av.dims.0 + ov.dims.0), v_o, ov, od);
    o.script = Some(script);
    let horizon = t_enc
        + if hz {
            u(rng, 2.0, 4.0)
        } else {
            u(rng, 2.0, 5.0)
        };
    (a, o, horizon, ego_approaches)
}

/// A vehicle from the adjacent lane cuts in front of another (hazardous: small gap, slower or
/// braking cutter, short manoeuvre; benign: ample gap, faster cutter).
pub(super) fn cut_in(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, partner: &Vehicle) -> Built {
    let (ego_victim, vv, cv) = roles(rng, 0.7, ego, partner);
    let lane = u(rng, 3.0, 3.75);
    let side = sign(rng);
    let v_v = road_speed(rng);
    let dv = if hz {
        u(rng, -3.0, 3.0)
    } else {
        u(rng, 0.5, 5.0)
    };
    let v_c = (v_v + dv).max(3.0);
    let t_lc = u(rng, 5.0, 8.0);
    let g = if hz {
        u(rng, -1.0, 6.0)
    } else {
        u(rng, 10.0, 35.0)
    };
    let x_c0 = g + 0.5 * (vv.dims.0 + cv.dims.0) - (v_c - v_v) * t_lc;
    let dur = if hz {
        u(rng, 1.5, 3.5)
    } else {
        u(rng, 3.0, 6.0)
    };
    let mut vd = driver(rng, hz, v_v, (1.0, 1.1));
    if let Some(sw) = vd.swerve.as_mut() {
        sw.dir = -side;
    }
    if hz {
        distraction(rng, &mut vd, 0.3, t_lc, (-0.5, 1.5), (0.5, 2.0));
    }
    let victim = agent(Path::line(0.0, 0.0, 0.0), 0.0, v_v, vv, vd);
    let mut cutter = if hz && rng.random_bool(0.4) {
        let t_brake = t_lc + dur + u(rng, 0.0, 1.5);
        let (decel, v_end) = (u(rng, 1.5, 5.0), v_c * u(rng, 0.3, 0.8));
        let (cd, script) = scripted(
            rng,
            v_c,
            vec![
                (0.0, CRUISE),
                (
                    t_brake,
                    Piece::Accel {
                        a: -decel,
                        v_lo: v_end,
                        v_hi: f64::MAX,
                    },
                ),
            ],
        );
        let mut c = agent(Path::line(0.0, side * lane, 0.0), x_c0, v_c, cv, cd);
        c.script = Some(script);
        c
    } else {
        let mut cd = driver(rng, hz, v_c, (1.0, 1.05));
        cd.swerve = None;
        agent(Path::line(0.0, side * lane, 0.0), x_c0, v_c, cv, cd)
    };
    cutter
        .plans
        .push(LatPlan::new(Trigger::Time(t_lc), -side * lane, dur));
    let horizon = t_lc + dur + u(rng, 3.0, 5.0);
    (victim, cutter, horizon, ego_victim)
}

/// A lane change into an occupied adjacent lane (hazardous: the changer misses a vehicle
/// alongside, sometimes notices and aborts) or benign passing / parallel driving / lane changes
/// into ample gaps.
pub(super) fn lane_change(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_changes, xv, yv) = roles(rng, 0.5, ego, partner);
    let lane = u(rng, 3.0, 3.75);
    let side = sign(rng);
    let v_x = road_speed(rng);
    let t_lc = u(rng, 5.0, 8.0);
    let parallel = !hz && rng.random_bool(0.5);
    let (dv, offset) = if hz {
        (u(rng, -2.0, 3.0), u(rng, -7.0, 4.0))
    } else if parallel {
        (u(rng, -4.0, 4.0), u(rng, -10.0, 10.0))
    } else if rng.random_bool(0.5) {
        (u(rng, 0.0, 4.0), u(rng, 15.0, 40.0))
    } else {
        (u(rng, -4.0, 0.0), -u(rng, 25.0, 50.0))
    };
    let v_y = (v_x + dv).max(3.0);
    let x_y0 = offset - (v_y - v_x) * t_lc;
    let mut xd = driver(rng, hz, v_x, (1.0, 1.05));
    xd.swerve = None;
    let mut x = agent(Path::line(0.0, 0.0, 0.0), 0.0, v_x, xv, xd);
    if !parallel {
        let mut plan = LatPlan::new(
            Trigger::Time(t_lc),
            side * lane,
            if hz {
                u(rng, 2.0, 4.0)
            } else {
                u(rng, 3.0, 6.0)
            },
        );
        if hz && rng.random_bool(0.5) {
            plan.abort_after = Some(u(rng, 0.5, 1.5));
        }
        x.plans.push(plan);
    }
    let mut yd = driver(rng, hz, v_y, (1.0, 1.05));
    if let Some(sw) = yd.swerve.as_mut() {
        sw.dir = side;
    }
    if hz {
        distraction(rng, &mut yd, 0.3, t_lc, (-0.5, 1.5), (0.5, 2.0));
    }
    let y = agent(Path::line(0.0, side * lane, 0.0), x_y0, v_y, yv, yd);
    let horizon = t_lc + u(rng, 4.0, 6.0);
    (x, y, horizon, ego_changes)
}

/// An on-ramp vehicle joins through an acceleration lane next to a main-lane vehicle.
pub(super) fn merge(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, partner: &Vehicle) -> Built {
    let (ego_main, mv, rv) = roles(rng, 0.6, ego, partner);
    let lane = u(rng, 3.2, 3.75);
    let v_m = u(rng, 14.0, 30.0);
    let v_r = (v_m + u(rng, -6.0, 1.0)).max(8.0);
    let phi = u(rng, 6.0, 15.0).to_radians();
    let radius = arc_radius(rng, 150.0, 400.0, rv);
    let l1 = 60.0;
    let segs = vec![
        Seg::Line(l1),
        Seg::Arc {
            len: radius * phi,
            kappa: -1.0 / radius,
        },
        Seg::Line(2000.0),
    ];
    // Place the ramp so the acceleration lane (end of the arc) starts at (0, -lane).
    let probe = Path::new(0.0, 0.0, phi, segs.clone());
    let s_ms = l1 + radius * phi;
    let e = probe.pose(s_ms);
    let ramp = Path::new(-e.x, -lane - e.y, phi, segs);
    let t_lc = u(rng, 5.0, 8.0);
    let s_lc = s_ms + u(rng, 10.0, 60.0);
    let s_r0 = s_lc - v_r * t_lc;
    let x_r_lc = s_lc - s_ms;
    let offset = if hz {
        u(rng, -5.0, 8.0)
    } else if rng.random_bool(0.6) {
        u(rng, 25.0, 60.0)
    } else {
        -u(rng, 20.0, 60.0)
    };
    let x_m0 = x_r_lc - offset - v_m * t_lc;
    let mut md = driver(rng, hz, v_m, (1.0, 1.05));
    if let Some(sw) = md.swerve.as_mut() {
        sw.dir = 1.0;
    }
    if hz {
        distraction(rng, &mut md, 0.3, t_lc, (-0.5, 1.5), (0.5, 2.0));
    }
    let main = agent(Path::line(0.0, 0.0, 0.0), x_m0, v_m, mv, md);
    let mut rd = driver(rng, hz, v_r, (1.0, 1.1));
    rd.swerve = None;
    let mut r = agent(ramp, s_r0, v_r, rv, rd);
    r.plans.push(LatPlan::new(
        Trigger::Time(t_lc),
        lane,
        if hz {
            u(rng, 2.0, 3.5)
        } else {
            u(rng, 3.0, 5.0)
        },
    ));
    let horizon = t_lc + u(rng, 4.0, 6.0);
    (main, r, horizon, ego_main)
}
