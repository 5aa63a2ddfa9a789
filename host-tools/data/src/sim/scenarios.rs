//! Scenario families and their parameter distributions (documented in `docs/simulator.md`).
//!
//! A family builds the two vehicles (paths, initial states, drivers, scripted behaviour) from
//! randomly drawn parameters. `hazardous` selects the parameter regime: hazardous draws (short
//! headways, distraction, late or misjudged decisions, hard braking) and benign draws (ample
//! gaps, attentive drivers, gentle manoeuvres, but still close interactions). The regime only
//! shapes the draw: what actually happened is decided afterwards from the trajectories.
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, PI};

use super::world::{
    conflict_zone, Agent, Conflict, Driver, LatPlan, Path, Piece, Role, Script, Seg, Swerve,
    Trigger,
};

/// The scenario families.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    LeadBraking,
    StoppedAhead,
    CutIn,
    LaneChange,
    Merge,
    Crossing,
    LeftTurnAcross,
    TurnIntoPath,
    OppositeDrift,
}

impl Family {
    pub const ALL: [Family; 9] = [
        Family::LeadBraking,
        Family::StoppedAhead,
        Family::CutIn,
        Family::LaneChange,
        Family::Merge,
        Family::Crossing,
        Family::LeftTurnAcross,
        Family::TurnIntoPath,
        Family::OppositeDrift,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Family::LeadBraking => "lead_braking",
            Family::StoppedAhead => "stopped_ahead",
            Family::CutIn => "cut_in",
            Family::LaneChange => "lane_change",
            Family::Merge => "merge",
            Family::Crossing => "crossing",
            Family::LeftTurnAcross => "left_turn_across",
            Family::TurnIntoPath => "turn_into_path",
            Family::OppositeDrift => "opposite_drift",
        }
    }
    /// Relative frequency of the family in draws.
    fn weight(self) -> f64 {
        match self {
            Family::LeadBraking => 0.20,
            Family::StoppedAhead => 0.10,
            Family::CutIn => 0.13,
            Family::LaneChange => 0.11,
            Family::Merge => 0.08,
            Family::Crossing => 0.13,
            Family::LeftTurnAcross => 0.09,
            Family::TurnIntoPath => 0.06,
            Family::OppositeDrift => 0.10,
        }
    }
}

/// Vehicle classes and their dimension/performance ranges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VehicleClass {
    Car,
    Van,
    Truck,
    Motorbike,
}

impl VehicleClass {
    pub fn name(self) -> &'static str {
        match self {
            VehicleClass::Car => "car",
            VehicleClass::Van => "van",
            VehicleClass::Truck => "truck",
            VehicleClass::Motorbike => "motorbike",
        }
    }
}

/// A drawn vehicle: class, (length, width), (braking limit, acceleration limit).
#[derive(Clone, Copy, Debug)]
pub struct Vehicle {
    pub class: VehicleClass,
    pub dims: (f64, f64),
    pub limits: (f64, f64),
}

/// A built scenario: ego is agent 0, the surrounding road user agent 1.
pub(crate) struct Scenario {
    pub family: Family,
    pub agents: [Agent; 2],
    pub classes: [VehicleClass; 2],
    /// Simulated duration (s).
    pub horizon: f64,
}

fn u(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

fn sign(rng: &mut ChaCha8Rng) -> f64 {
    if rng.random_bool(0.5) {
        1.0
    } else {
        -1.0
    }
}

fn vehicle(rng: &mut ChaCha8Rng, ego: bool) -> Vehicle {
    let r: f64 = rng.random();
    let class = if ego {
        if r < 0.75 {
            VehicleClass::Car
        } else {
            VehicleClass::Van
        }
    } else if r < 0.55 {
        VehicleClass::Car
    } else if r < 0.75 {
        VehicleClass::Van
    } else if r < 0.92 {
        VehicleClass::Truck
    } else {
        VehicleClass::Motorbike
    };
    let (dims, limits) = match class {
        VehicleClass::Car => (
            (u(rng, 3.9, 4.9), u(rng, 1.70, 1.90)),
            (u(rng, 7.0, 9.5), 3.0),
        ),
        VehicleClass::Van => (
            (u(rng, 4.7, 5.9), u(rng, 1.85, 2.05)),
            (u(rng, 6.5, 8.5), 2.5),
        ),
        VehicleClass::Truck => (
            (u(rng, 7.5, 16.5), u(rng, 2.40, 2.55)),
            (u(rng, 4.5, 6.5), 1.2),
        ),
        VehicleClass::Motorbike => (
            (u(rng, 1.9, 2.3), u(rng, 0.70, 0.95)),
            (u(rng, 5.5, 9.0), 4.0),
        ),
    };
    Vehicle {
        class,
        dims,
        limits,
    }
}

/// Travel speed (m/s) of a road class: urban, arterial or highway.
fn road_speed(rng: &mut ChaCha8Rng) -> f64 {
    let r: f64 = rng.random();
    if r < 0.4 {
        u(rng, 8.0, 16.0)
    } else if r < 0.75 {
        u(rng, 14.0, 22.0)
    } else {
        u(rng, 22.0, 33.0)
    }
}

/// A driver whose desired speed is `v` times a factor drawn from `factor`.
fn driver(rng: &mut ChaCha8Rng, hazardous: bool, v: f64, factor: (f64, f64)) -> Driver {
    let v0 = v * u(rng, factor.0, factor.1);
    let swerve = (hazardous && rng.random_bool(0.35)).then(|| Swerve {
        dir: sign(rng),
        dd: u(rng, 0.8, 2.2),
        alat: u(rng, 3.0, 7.0),
        trigger: u(rng, 4.0, 7.0),
    });
    Driver {
        v0,
        headway: if hazardous {
            u(rng, 0.6, 1.6)
        } else {
            u(rng, 1.0, 2.2)
        },
        s0: u(rng, 1.0, 2.5),
        a_max: u(rng, 0.8, 1.8),
        b_comf: u(rng, 1.0, 2.0),
        tau: if hazardous {
            u(rng, 0.6, 2.0)
        } else {
            u(rng, 0.4, 1.2)
        },
        b_max: if hazardous {
            u(rng, 4.0, 9.5)
        } else {
            u(rng, 5.0, 9.5)
        },
        jerk: u(rng, 8.0, 30.0),
        distraction: Vec::new(),
        margin: u(rng, 0.1, 0.5),
        anticipation: u(rng, 0.0, 1.0),
        a_lat_curve: u(rng, 1.2, 2.8),
        swerve,
        hold_until: 0.0,
        reactive: true,
    }
}

/// A vehicle that follows a script and does not react.
fn scripted(rng: &mut ChaCha8Rng, v: f64, pieces: Vec<(f64, Piece)>) -> (Driver, Script) {
    let mut d = driver(rng, false, v.max(0.1), (1.0, 1.0 + 1e-9));
    d.reactive = false;
    d.swerve = None;
    d.jerk = u(rng, 5.0, 15.0);
    (d, Script { pieces })
}

fn agent(path: Path, s: f64, v: f64, veh: &Vehicle, driver: Driver) -> Agent {
    Agent::new(path, s, v, veh.dims, veh.limits, driver)
}

/// Draws one scenario of a random family.
pub(crate) fn draw(rng: &mut ChaCha8Rng, hazardous: bool) -> Scenario {
    let total: f64 = Family::ALL.iter().map(|f| f.weight()).sum();
    let mut r = u(rng, 0.0, total);
    let mut family = Family::LeadBraking;
    for f in Family::ALL {
        if r < f.weight() {
            family = f;
            break;
        }
        r -= f.weight();
    }
    build(family, rng, hazardous)
}

/// Builds a scenario of `family`.
pub(crate) fn build(family: Family, rng: &mut ChaCha8Rng, hz: bool) -> Scenario {
    let ego = vehicle(rng, true);
    let sur = vehicle(rng, false);
    // `first` is the role the family calls A; the ego takes it with probability `p_ego_first`.
    let (a, b, horizon, p_ego_first) = match family {
        Family::LeadBraking => lead_braking(rng, hz, &ego, &sur),
        Family::StoppedAhead => stopped_ahead(rng, hz, &ego, &sur),
        Family::CutIn => cut_in(rng, hz, &ego, &sur),
        Family::LaneChange => lane_change(rng, hz, &ego, &sur),
        Family::Merge => merge(rng, hz, &ego, &sur),
        Family::Crossing => crossing(rng, hz, &ego, &sur),
        Family::LeftTurnAcross => left_turn_across(rng, hz, &ego, &sur),
        Family::TurnIntoPath => turn_into_path(rng, hz, &ego, &sur),
        Family::OppositeDrift => opposite_drift(rng, hz, &ego, &sur),
    };
    // Role assignment was drawn inside: `a` is the ego when the flag says so.
    let (agents, classes) = if p_ego_first {
        ([a, b], [ego.class, sur.class])
    } else {
        ([b, a], [ego.class, sur.class])
    };
    Scenario {
        family,
        agents,
        classes,
        horizon,
    }
}

/// The role-A vehicle gets `ego` dims when `ego_first`, else `sur` dims (and vice versa).
fn roles<'v>(ego_first: bool, ego: &'v Vehicle, sur: &'v Vehicle) -> (&'v Vehicle, &'v Vehicle) {
    if ego_first {
        (ego, sur)
    } else {
        (sur, ego)
    }
}

type Built = (Agent, Agent, f64, bool);

fn distraction(
    rng: &mut ChaCha8Rng,
    d: &mut Driver,
    p: f64,
    around: f64,
    before: (f64, f64),
    dur: (f64, f64),
) {
    if rng.random_bool(p) {
        let start = (around - u(rng, before.0, before.1)).max(0.3);
        d.distraction.push((start, start + u(rng, dur.0, dur.1)));
    }
}

/// Rear-end family: a follower behind a leader that brakes (hazardous: hard, benign: gently or
/// just fluctuates in speed, including close following at steady speed).
fn lead_braking(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_follows = rng.random_bool(0.75);
    let (fv, lv) = roles(ego_follows, ego, sur);
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
            (
                0.0,
                Piece::Accel {
                    a: 0.0,
                    v_lo: 0.0,
                    v_hi: f64::MAX,
                },
            ),
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
fn stopped_ahead(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_approaches = rng.random_bool(0.85);
    let (av, ov) = roles(ego_approaches, ego, sur);
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
    let (od, script) = scripted(
        rng,
        v_o.max(0.1),
        vec![(
            0.0,
            Piece::Accel {
                a: 0.0,
                v_lo: 0.0,
                v_hi: f64::MAX,
            },
        )],
    );
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
fn cut_in(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_victim = rng.random_bool(0.7);
    let (vv, cv) = roles(ego_victim, ego, sur);
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
                (
                    0.0,
                    Piece::Accel {
                        a: 0.0,
                        v_lo: 0.0,
                        v_hi: f64::MAX,
                    },
                ),
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
fn lane_change(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_changes = rng.random_bool(0.5);
    let (xv, yv) = roles(ego_changes, ego, sur);
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
fn merge(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_main = rng.random_bool(0.6);
    let (mv, rv) = roles(ego_main, ego, sur);
    let lane = u(rng, 3.2, 3.75);
    let v_m = u(rng, 14.0, 30.0);
    let v_r = (v_m + u(rng, -6.0, 1.0)).max(8.0);
    let phi = u(rng, 6.0, 15.0).to_radians();
    let radius = u(rng, 150.0, 400.0);
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

fn yield_role(rng: &mut ChaCha8Rng, hz: bool, blind_p: f64) -> Role {
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
        other_in: b_in,
        other_out: b_out,
        role: ra,
    });
    b.conflict = Some(Conflict {
        me_in: b_in,
        me_out: b_out,
        other_in: a_in,
        other_out: a_out,
        role: rb,
    });
}

/// Straight crossing paths at an intersection: A has right of way, B gives way (or fails to).
fn crossing(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_a = rng.random_bool(0.5);
    let (av, bv) = roles(ego_a, ego, sur);
    let alpha = sign(rng) * u(rng, 60.0, 120.0).to_radians();
    let v_a = u(rng, 8.0, 20.0);
    let v_b = u(rng, 5.0, 15.0);
    let t_a = u(rng, 6.0, 9.0);
    let pa = Path::line(0.0, 0.0, 0.0);
    let pb = Path::line(0.0, 0.0, alpha);
    let zone = conflict_zone(
        (&pa, av.dims.0, av.dims.1),
        (&pb, bv.dims.0, bv.dims.1),
        (-30.0, 30.0),
        (-30.0, 30.0),
    )
    .unwrap_or((-5.0, 5.0, -5.0, 5.0));
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
    let mut a = agent(pa, -v_a * t_a, v_a, av, ad);
    let mut b = agent(pb, s_b0, v_b0, bv, bd);
    let rb = yield_role(rng, hz, 0.45);
    set_conflict(
        &mut a,
        &mut b,
        zone,
        Role::Priority {
            margin: u(rng, 0.5, 1.5),
        },
        rb,
    );
    (a, b, t_end, ego_a)
}

/// Left turn across the path of an oncoming vehicle (LTAP/OD): B turns, A goes straight.
fn left_turn_across(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_a = rng.random_bool(0.5);
    let (av, bv) = roles(ego_a, ego, sur);
    let lane = u(rng, 3.0, 3.75);
    let radius = u(rng, 6.0, 14.0);
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
    let mut ad = driver(rng, hz, v_a, (1.0, 1.08));
    if let Some(sw) = ad.swerve.as_mut() {
        sw.dir = -1.0;
    }
    if hz {
        distraction(rng, &mut ad, 0.3, t_t, (0.0, 2.0), (0.5, 2.0));
    }
    let mut bd = driver(rng, hz, v_b, (1.0, 1.1));
    bd.swerve = None;
    let mut a = agent(pa, s_a0, v_a, av, ad);
    let mut b = agent(pb, s_b0, v_b, bv, bd);
    let rb = yield_role(rng, hz, 0.35);
    set_conflict(
        &mut a,
        &mut b,
        zone,
        Role::Priority {
            margin: u(rng, 0.5, 1.5),
        },
        rb,
    );
    (a, b, t_t + dt.max(0.0) + u(rng, 4.0, 6.0), ego_a)
}

/// A vehicle from a side road turns right into the lane in front of an approaching vehicle.
fn turn_into_path(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_a = rng.random_bool(0.6);
    let (av, bv) = roles(ego_a, ego, sur);
    let radius = u(rng, 6.0, 12.0);
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
    // Only the turn itself is the crossing zone; once B is in A's lane, A follows it.
    let b_join = l_b + radius * FRAC_PI_2;
    let zone = conflict_zone(
        (&pa, av.dims.0, av.dims.1),
        (&pb, bv.dims.0, bv.dims.1),
        (x_t - 20.0, x_t + radius + 2.0),
        (l_b - 10.0, b_join),
    )
    .unwrap_or((x_t, x_t + radius + 5.0, l_b, b_join + 5.0));
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
    let mut ad = driver(rng, hz, v_a, (1.0, 1.08));
    if let Some(sw) = ad.swerve.as_mut() {
        sw.dir = 1.0;
    }
    if hz {
        distraction(rng, &mut ad, 0.3, t_b, (0.0, 2.0), (0.5, 2.0));
    }
    let mut bd = driver(rng, hz, 1.0, (8.0, 15.0));
    bd.swerve = None;
    bd.hold_until = hold;
    let mut a = agent(pa, s_a0, v_a, av, ad);
    let mut b = agent(pb, s_b0, v_b, bv, bd);
    let rb = yield_role(rng, hz, 0.35);
    set_conflict(
        &mut a,
        &mut b,
        zone,
        Role::Priority {
            margin: u(rng, 0.5, 1.5),
        },
        rb,
    );
    (a, b, t_b + dt.max(0.0) + u(rng, 4.0, 7.0), ego_a)
}

/// An oncoming vehicle drifts over the centre line (hazardous) or stays in lane / drifts
/// slightly (benign, close oncoming passes).
fn opposite_drift(rng: &mut ChaCha8Rng, hz: bool, ego: &Vehicle, sur: &Vehicle) -> Built {
    let ego_a = rng.random_bool(0.7);
    let (av, bv) = roles(ego_a, ego, sur);
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
    let mut ad = driver(rng, hz, v_a, (1.0, 1.08));
    if let Some(sw) = ad.swerve.as_mut() {
        sw.dir = -1.0;
    }
    if hz {
        distraction(rng, &mut ad, 0.3, t_d, (-1.0, 1.0), (0.5, 2.0));
    }
    let mut bd = driver(rng, hz, v_b, (1.0, 1.05));
    bd.swerve = None;
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
